# Unconstrained MPC designs and their condensed prediction.
"""MPC designs in design units and their condensed prediction matrices.

Notation (all in *design units*: inputs and outputs already scaled so that
the weights are plain numbers, e.g. u in kN and R per kN²). The discrete
model x(k+1) = A x(k) + B u(k), y = C x is predicted over P steps with M
free moves, the input held after move M:

- u-form: Y = Φ x + G U, decision U = [u(k); ...; u(k+M-1)], cost
  ‖Y - Y_r‖²_Q + ‖U‖²_R (penalises the input deviation from equilibrium).
- Δu-form: Y = Φ x + S_u u(k-1) + G ΔU, cost ‖Y - Y_r‖²_Q + ‖ΔU‖²_R.

The decision vector is ordered move by move ([all inputs at move 0], [all
inputs at move 1], ...); coach i owns input i at every move.

The distributed-MPC theory on these matrices (N-DMPC iteration, Nash point,
cooperative DMPC, closed loops, threshold weight) is in
:mod:`trainctl.controllers.mpc.theory.iteration`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trainctl.exceptions import ModelError

__all__ = ["FORMS", "MPCDesign", "Prediction", "prediction", "prediction_matrices"]

FORMS = ("u", "du")
"""MPC forms: penalise the input (``"u"``) or its increments (``"du"``)."""

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class MPCDesign:
    """An unconstrained (D)MPC design on a discrete model, in design units.

    Parameters
    ----------
    A, B, C : ndarray
        Discrete model x(k+1) = A x + B u, y = C x (inputs and outputs in
        design units).
    prediction_horizon : int
        P >= 1 steps.
    control_horizon : int
        M, 1 <= M <= P free moves.
    form : {"u", "du"}
        Input or input-increment penalty.
    q : ndarray
        Output weights, one per output row.
    r : ndarray
        Input weights, one per input.
    output_owner : tuple of int
        The coach owning each output row.
    neighbourhoods : tuple of tuple of int
        N_i^out for each coach (must contain i).

    Examples
    --------
    One coach on an integrator, x(k+1) = x + u, weighing y = x over P = 2 steps:

    >>> import numpy as np
    >>> d = MPCDesign(A=np.eye(1), B=np.eye(1), C=np.eye(1), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.ones(1),
    ...               output_owner=(0,), neighbourhoods=((0,),))
    >>> d.n_inputs, d.with_r(4.0).r.tolist()
    (1, [4.0])
    >>> try:
    ...     MPCDesign(A=np.eye(1), B=np.eye(1), C=np.eye(1), prediction_horizon=2,
    ...               control_horizon=3, form="u", q=np.ones(1), r=np.ones(1),
    ...               output_owner=(0,), neighbourhoods=((0,),))
    ... except ModelError as err:
    ...     print(err)
    MPCDesign: horizons must be ints with 1 <= M <= P (got P=2, M=3).
    """

    A: Array
    B: Array
    C: Array
    prediction_horizon: int
    control_horizon: int
    form: str
    q: Array
    r: Array
    output_owner: tuple[int, ...]
    neighbourhoods: tuple[tuple[int, ...], ...]

    def __post_init__(self) -> None:
        nx, nu = self.B.shape
        P, M = self.prediction_horizon, self.control_horizon
        if self.A.shape != (nx, nx) or self.C.shape[1] != nx:
            raise ModelError(
                "MPCDesign: A, B, C shapes disagree "
                f"({self.A.shape}, {self.B.shape}, {self.C.shape})."
            )
        if not (isinstance(P, int) and isinstance(M, int) and 1 <= M <= P):
            raise ModelError(
                f"MPCDesign: horizons must be ints with 1 <= M <= P (got P={P!r}, M={M!r})."
            )
        if self.form not in FORMS:
            raise ModelError(f"MPCDesign: 'form' must be one of {FORMS} (got {self.form!r}).")
        if self.q.shape != (self.C.shape[0],) or self.r.shape != (nu,):
            raise ModelError("MPCDesign: q needs one weight per output and r one per input.")
        if np.any(self.q < 0) or np.any(self.r < 0):
            raise ModelError("MPCDesign: weights must be >= 0.")
        if len(self.output_owner) != self.C.shape[0] or len(self.neighbourhoods) != nu:
            raise ModelError(
                "MPCDesign: output_owner needs one coach per output, "
                "neighbourhoods one per input."
            )

    @property
    def n_inputs(self) -> int:
        """Number of inputs (= coaches)."""
        n_inputs: int = self.B.shape[1]
        return n_inputs

    def with_r(self, r: float | Array) -> MPCDesign:
        """A copy with input weights ``r`` (scalar: the same for every input).

        Parameters
        ----------
        r : float or ndarray
            Input weight(s) [per design unit²], >= 0: one number, or one per
            input, shape (nu,).

        Returns
        -------
        MPCDesign
            The same design with ``r`` as its input weights.

        Raises
        ------
        ModelError
            If a weight is negative.
        """
        rr = np.broadcast_to(np.asarray(r, dtype=float), (self.n_inputs,)).copy()
        return MPCDesign(A=self.A, B=self.B, C=self.C, prediction_horizon=self.prediction_horizon,
                         control_horizon=self.control_horizon, form=self.form, q=self.q, r=rr,
                         output_owner=self.output_owner, neighbourhoods=self.neighbourhoods)

    def with_neighbourhoods(self, neighbourhoods: Sequence[Sequence[int]]) -> MPCDesign:
        """A copy with other neighbourhoods.

        Parameters
        ----------
        neighbourhoods : sequence of sequence of int
            N_i^out for each coach, one per input (coach i's must contain
            i), coaches 0-based.

        Returns
        -------
        MPCDesign
            The same design with these neighbourhoods (as tuples of int).

        Raises
        ------
        ModelError
            If there is not one neighbourhood per input.
        """
        return MPCDesign(A=self.A, B=self.B, C=self.C, prediction_horizon=self.prediction_horizon,
                         control_horizon=self.control_horizon, form=self.form, q=self.q, r=self.r,
                         output_owner=self.output_owner,
                         neighbourhoods=tuple(tuple(int(j) for j in nb) for nb in neighbourhoods))


@dataclass(frozen=True, kw_only=True)
class Prediction:
    """Prediction matrices and the quadratic cost of an MPC design.

    Parameters
    ----------
    Phi : ndarray
        Free response from x, shape (P·ny, nx).
    Su : ndarray
        Free response from u(k-1) (Δu-form; zeros in the u-form).
    G : ndarray
        Forced response from the decision vector, shape (P·ny, M·nu).
    Qbar, Rbar : ndarray
        Block-diagonal weights over the horizon.
    columns : tuple of ndarray
        Decision-vector indices owned by each input.
    first_move : ndarray
        Γ, selects the first move of every input from the decision vector.

    Examples
    --------
    An integrator with one held move over P = 2 steps: G = [1, 2]ᵀ, so
    H = 1 + 4 + r = 6 and K_c = [1, 2]/6; from x = 1 (e = −Φx = [−1, −1])
    the plan is u = −3/6 = −0.5 and the cost 0.5² + 0² + 0.5² = 0.5.

    >>> import numpy as np
    >>> d = MPCDesign(A=np.eye(1), B=np.eye(1), C=np.eye(1), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.ones(1),
    ...               output_owner=(0,), neighbourhoods=((0,),))
    >>> p = prediction(d)
    >>> p.G.tolist(), p.hessian().tolist()
    ([[1.0], [2.0]], [[6.0]])
    >>> e = -p.Phi @ np.ones(1)
    >>> U = p.centralised_gain() @ e
    >>> U.round(4).tolist(), round(p.cost(U, e), 4)
    ([-0.5], 0.5)
    """

    Phi: Array
    Su: Array
    G: Array
    Qbar: Array
    Rbar: Array
    columns: tuple[NDArray[np.int64], ...]
    first_move: Array

    def hessian(self) -> Array:
        """Centralised Hessian H = GᵀQG + R.

        Returns
        -------
        ndarray, shape (M·nu, M·nu)
            H, symmetric, in design units (per design unit² of the decision).
        """
        return self.G.T @ self.Qbar @ self.G + self.Rbar

    def centralised_gain(self) -> Array:
        """K_c with U* = K_c e, K_c = H⁻¹ GᵀQ.

        Returns
        -------
        ndarray, shape (M·nu, P·ny)
            The gain from the error e = Y_r − free response to the
            centralised optimal decision U*.
        """
        return np.asarray(np.linalg.solve(self.hessian(), self.G.T @ self.Qbar), dtype=np.float64)

    def cost(self, U: Array, e: Array) -> float:
        """Cost ‖G U - e‖²_Q + ‖U‖²_R of decision U for error e = Y_r - free response.

        Parameters
        ----------
        U : ndarray, shape (M·nu,)
            The decision vector, move by move (design units).
        e : ndarray, shape (P·ny,)
            The error Y_r − free response over the horizon (design units).

        Returns
        -------
        float
            The cost [-], >= 0.
        """
        res = self.G @ U - e
        return float(res @ self.Qbar @ res + U @ self.Rbar @ U)


def prediction(design: MPCDesign) -> Prediction:
    """Prediction matrices Φ, S_u, G and weights for ``design``.

    Parameters
    ----------
    design : MPCDesign
        The design.

    Returns
    -------
    Prediction
        The stacked matrices.

    Examples
    --------
    >>> import numpy as np
    >>> d = MPCDesign(A=np.eye(1), B=np.eye(1), C=np.eye(1), prediction_horizon=3,
    ...               control_horizon=2, form="u", q=np.ones(1), r=np.ones(1),
    ...               output_owner=(0,), neighbourhoods=((0,),))
    >>> prediction(d).G.tolist()
    [[1.0, 0.0], [1.0, 1.0], [1.0, 2.0]]
    """
    P, M = design.prediction_horizon, design.control_horizon
    nu = design.n_inputs
    Phi, Su, G = prediction_matrices(design.A, design.B, design.C, prediction_horizon=P,
                                     control_horizon=M, form=design.form)
    Qbar = np.asarray(np.kron(np.eye(P), np.diag(design.q)), dtype=np.float64)
    Rbar = np.asarray(np.kron(np.eye(M), np.diag(design.r)), dtype=np.float64)
    columns = tuple(np.arange(M) * nu + i for i in range(nu))
    first = np.zeros((nu, M * nu))
    first[:, :nu] = np.eye(nu)
    return Prediction(Phi=Phi, Su=Su, G=G, Qbar=Qbar, Rbar=Rbar, columns=columns, first_move=first)


def prediction_matrices(A: Array, B: Array, C: Array, *, prediction_horizon: int,
                        control_horizon: int, form: str) -> tuple[Array, Array, Array]:
    """Condensed prediction Y = Φ x + S_u u(k-1) + G U of y = C x over P steps.

    Y stacks y(k+1), ..., y(k+P); U stacks the M moves (u-form: the inputs
    u(k), ..., u(k+M-1), held after move M; Δu-form: their increments, with
    u(k+j) = u(k-1) + Σ_{m<=min(j, M-1)} Δu(k+m)).

    Parameters
    ----------
    A, B, C : ndarray
        Discrete model x(k+1) = A x + B u, y = C x.
    prediction_horizon : int
        P >= 1 steps.
    control_horizon : int
        M free moves, 1 <= M <= P.
    form : {"u", "du"}
        Decision: the inputs or their increments.

    Returns
    -------
    Phi : ndarray
        Free response from x, shape (P·ny, nx).
    Su : ndarray
        Free response from u(k-1), shape (P·ny, nu) (zeros in the u-form).
    G : ndarray
        Forced response from U, shape (P·ny, M·nu).

    Examples
    --------
    >>> import numpy as np
    >>> Phi, Su, G = prediction_matrices(np.eye(1), np.eye(1), np.eye(1), prediction_horizon=3,
    ...                                  control_horizon=2, form="du")
    >>> G.tolist(), Su.ravel().tolist()
    ([[1.0, 0.0], [2.0, 1.0], [3.0, 2.0]], [1.0, 2.0, 3.0])
    """
    P, M = prediction_horizon, control_horizon
    nx, nu = B.shape
    ny = C.shape[0]
    powers = [np.eye(nx)]
    for _ in range(P):
        powers.append(A @ powers[-1])
    Phi = np.vstack([C @ powers[j] for j in range(1, P + 1)])
    # Markov blocks C A^(j-1-l) B: effect at step j of the input applied at step l < j.
    markov = [C @ powers[i] @ B for i in range(P)]
    G = np.zeros((P * ny, M * nu))
    Su = np.zeros((P * ny, nu))
    for j in range(1, P + 1):
        rows = slice((j - 1) * ny, j * ny)
        for step in range(j):
            block = markov[j - 1 - step]
            move = min(step, M - 1)
            if form == "u":
                G[rows, move * nu:(move + 1) * nu] += block
            else:
                Su[rows] += block
                for m in range(move + 1):
                    G[rows, m * nu:(m + 1) * nu] += block
    return Phi, Su, G
