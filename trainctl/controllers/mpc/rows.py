# Bound rows of the MPC core, affine in the state and the previous input.
"""Constraint rows of the MPC core on inputs, input rates, states and outputs.

Every bounded quantity is affine in the plan z and in the data of the step:
q = rows·z + Ox·x(k) + Ou·u(k-1). A bound lo ≤ q ≤ hi becomes the QP row
lo - (Ox x + Ou u(k-1)) ≤ rows·z ≤ hi - (Ox x + Ou u(k-1)); rows whose
bounds are both infinite are left out. Hard rows go to the QP's C, soft rows
(with their slack penalties) to its F.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.mpc.condensed import MoveMaps, input_rows

__all__ = ["ConstraintRows", "constraint_rows"]

Array = NDArray[np.float64]
Prediction = tuple[Array, Array, Array]
"""(Φ, S_u, G) of :func:`trainctl.controllers.mpc.theory.mpc.prediction_matrices`."""


@dataclass(frozen=True)
class ConstraintRows:
    """Rows lower - (Ox x + Ou u(k-1)) ≤ rows z ≤ upper - (Ox x + Ou u(k-1)).

    Parameters
    ----------
    rows, Ox, Ou : ndarray
        The rows' dependence on the plan, the state and the previous input.
    lower, upper : ndarray
        The bounds (±inf allowed on one side).
    linear, quadratic : ndarray
        Slack penalties w1, w2 per row (soft rows; zeros for hard rows).

    Examples
    --------
    One soft row x(1) <= 5 m of a scalar state, x(1) = x + u_0: at x = 2 m the
    plan may move by up to 3 m.

    >>> rows = ConstraintRows(np.array([[1.0]]), np.array([[1.0]]), np.array([[0.0]]),
    ...                       np.array([-np.inf]), np.array([5.0]), np.array([10.0]),
    ...                       np.array([1.0]))
    >>> lower, upper = rows.bounds(np.array([2.0]), np.array([0.0]))
    >>> rows.size, lower.tolist(), upper.tolist()
    (1, [-inf], [3.0])
    """

    rows: Array
    Ox: Array
    Ou: Array
    lower: Array
    upper: Array
    linear: Array
    quadratic: Array

    @property
    def size(self) -> int:
        """Number of rows."""
        return int(self.rows.shape[0])

    def bounds(self, x: Array, u_prev: Array) -> tuple[Array, Array]:
        """The QP bounds of the rows at state ``x`` and previous input ``u_prev``.

        Parameters
        ----------
        x : ndarray, shape (nx,)
            The state x(k), in the model's units.
        u_prev : ndarray, shape (nu,)
            The input applied at the previous sample u(k-1), in the model's units.

        Returns
        -------
        (ndarray, ndarray)
            ``lower - (Ox x + Ou u_prev)`` and ``upper - (Ox x + Ou u_prev)``,
            shape (size,) each (±inf kept).
        """
        offset = self.Ox @ x + self.Ou @ u_prev
        return self.lower - offset, self.upper - offset


def constraint_rows(maps: MoveMaps, states: Prediction, outputs: Prediction,
                    bounds: Mapping[str, tuple[Array, Array]],
                    soft: Mapping[str, tuple[float, float] | None]
                    ) -> tuple[ConstraintRows, ConstraintRows]:
    """The hard and the soft rows of the bounds.

    Parameters
    ----------
    maps : MoveMaps
        The plan's maps.
    states, outputs : tuple of ndarray
        (Φ, S_u, G) of the states and of the outputs at steps 1..P.
    bounds : mapping of str to (ndarray, ndarray)
        (lower, upper) per bounded group ``"u"``, ``"du"``, ``"x"``, ``"y"``
        (per input, state or output; repeated over the moves or steps).
    soft : mapping of str to (float, float) or None
        The slack penalties (linear, quadratic) of the soft groups; None: hard.

    Returns
    -------
    hard, soft : ConstraintRows
        The rows, in the order u, du, x, y.

    Examples
    --------
    A scalar integrator x(k+1) = x(k) + u(k) over P = M = 2 steps: x(1) = x + u_0,
    x(2) = x + u_0 + u_1, so Φ = S_u = [1; 1] and G = [[1, 0], [1, 1]].

    >>> from trainctl.controllers.mpc.condensed import move_maps
    >>> pred = (np.ones((2, 1)), np.ones((2, 1)), np.array([[1.0, 0.0], [1.0, 1.0]]))
    >>> hard, soft = constraint_rows(move_maps(1, 2, "u"), pred, pred,
    ...                              {"u": (np.array([-1.0]), np.array([1.0])),
    ...                               "x": (np.array([-np.inf]), np.array([5.0]))},
    ...                              {"u": None, "x": (10.0, 1.0)})
    >>> hard.rows.tolist(), soft.rows.tolist()  # |u_m| <= 1 hard, x(1..2) <= 5 soft
    ([[1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [1.0, 1.0]])
    >>> [b.tolist() for b in soft.bounds(np.array([2.0]), np.array([0.0]))]  # at x = 2
    [[-inf, -inf], [3.0, 3.0]]
    """
    nu, M = maps.n_inputs, maps.control_horizon
    nx, nz = states[0].shape[1], maps.L.shape[1]
    P = states[2].shape[0] // nx
    held = np.asarray(np.kron(np.ones((M, 1)), np.eye(nu)) if maps.form == "du"
                      else np.zeros((M * nu, nu)), dtype=np.float64)  # moves' part in u(k-1)
    first = np.zeros((M * nu, nu))
    first[:nu] = np.eye(nu)  # u(k-1) before move 0
    every = np.arange(nz)
    groups = {"u": (input_rows(maps, every, bounds=True, rate=False), np.zeros((M * nu, nx)),
                    held, M),
              "du": (input_rows(maps, every, bounds=False, rate=True), np.zeros((M * nu, nx)),
                     maps.D @ held - first, M),
              "x": (states[2], states[0], states[1], P),
              "y": (outputs[2], outputs[0], outputs[1], P)}
    parts: dict[bool, list[tuple[Array, ...]]] = {False: [], True: []}
    for key in ("u", "du", "x", "y"):
        if key not in bounds:
            continue
        rows, Ox, Ou, repeats = groups[key]
        lower, upper = np.tile(bounds[key][0], repeats), np.tile(bounds[key][1], repeats)
        keep = np.isfinite(lower) | np.isfinite(upper)
        penalty = soft.get(key)
        w1, w2 = penalty if penalty is not None else (0.0, 0.0)
        n = int(keep.sum())
        parts[penalty is not None].append((rows[keep], Ox[keep], Ou[keep], lower[keep],
                                           upper[keep], np.full(n, w1), np.full(n, w2)))
    empty = (np.zeros((0, nz)), np.zeros((0, nx)), np.zeros((0, nu)), *(np.zeros(0),) * 4)
    hard, soft_rows = (ConstraintRows(*(np.concatenate(p) for p in zip(*parts[is_soft],
                                                                         strict=True)))
                       if parts[is_soft] else ConstraintRows(*empty)
                       for is_soft in (False, True))
    return hard, soft_rows
