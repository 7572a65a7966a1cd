# Linearisation of the train about its cruise equilibrium.
"""Linear (deviation) model of a train about cruise at speed v_r.

The state is ``[v~_0 .. v~_{n-1}, delta~_0 .. delta~_{n-2}]`` (deviations of
speed [m/s] and coupler elongation [m] from the equilibrium), the input the
force deviations u~ [N]. Because the couplers are linear springs the matrices
do not depend on the static elongations; the equilibrium only enters the
absolute coupler forces. The head position is left out: on level track it
does not influence the dynamics. (A, B) are those of the chain,
:class:`~trainctl.models.Chain`, with the Davis damping as speed damping.

Two treatments of the quadratic Davis term are offered:

``"jacobian"`` (default)
    The true linearisation: damping per unit mass a1 + 2·a2·v_r.
``"book"``
    Seed 000's printed secant damping a1 + a2·v_r (Li & Zheng eq. 12.10–12.11
    drop the factor 2; about 45 % too little damping at 300 km/h), kept so the
    book's matrices can be reproduced.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl._validation import check_finite_arrays, check_positive
from trainctl.exceptions import ModelError
from trainctl.models.chain import Chain
from trainctl.models.train import Train

if TYPE_CHECKING:
    import control as ct

__all__ = ["LINEARISATIONS", "OUTPUT_GROUPS", "linear_matrices", "linearise", "resistance_damping"]

LINEARISATIONS = ("jacobian", "book")
"""Names of the supported treatments of the Davis quadratic term."""

OUTPUT_GROUPS = ("v", "delta", "force")
"""Output groups: velocities [m/s], elongations [m], coupler forces [N]."""


def resistance_damping(train: Train, speed: float, method: str = "jacobian") -> NDArray[np.float64]:
    """Resistance damping per unit mass at ``speed`` [1/s], one per vehicle.

    Parameters
    ----------
    train : Train
        The train.
    speed : float
        Linearisation speed v_r [m/s], > 0.
    method : {"jacobian", "book"}
        ``a1 + 2 a2 v_r`` or the book's ``a1 + a2 v_r``.

    Returns
    -------
    ndarray
        Damping per unit mass [1/s], shape (n,).

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> float(resistance_damping(crh2_half(), 300 / 3.6)[0].round(8))
    0.00268486
    """
    speed = check_positive("resistance_damping", "speed", speed)
    if method not in LINEARISATIONS:
        raise ModelError(
            f"linearise: 'method' must be one of {LINEARISATIONS} (got {method!r}). "
            "'jacobian' is the true linearisation; 'book' reproduces Li & Zheng's matrices."
        )
    factor = 2.0 if method == "jacobian" else 1.0
    damping: NDArray[np.float64] = train.davis[1] + factor * train.davis[2] * speed
    return damping


def linear_matrices(
    train: Train, speed: float, *, method: str = "jacobian", dummy_state: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """State and input matrices (A, B) of the deviation model.

    Parameters
    ----------
    train : Train
        The train.
    speed : float
        Linearisation speed v_r [m/s].
    method : {"jacobian", "book"}
        Treatment of the quadratic Davis term (module docstring).
    dummy_state : bool
        Append seed 000's dummy elongation of the (non-existent) coupler
        behind the last vehicle: an extra state with all-zero row and column.

    Returns
    -------
    A : ndarray
        Shape (2n-1, 2n-1), or (2n, 2n) with the dummy state [SI].
    B : ndarray
        Shape (2n-1, n) or (2n, n) [1/kg].

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> A, B = linear_matrices(crh2_half(), 300 / 3.6)
    >>> A.shape, B.shape
    ((7, 7), (7, 4))
    """
    damp = resistance_damping(train, speed, method)
    A, B = Chain.from_train(train, damp, dummy_state=dummy_state).matrices()
    return A, B


def linearise(
    train: Train,
    speed: float,
    *,
    method: str = "jacobian",
    dummy_state: bool = False,
    outputs: tuple[str, ...] = ("v",),
    name: str = "train",
) -> ct.StateSpace:
    """Linear deviation model at cruise speed as a named ``StateSpace``.

    Parameters
    ----------
    train : Train
        The train.
    speed : float
        Linearisation speed v_r [m/s], > 0.
    method : {"jacobian", "book"}
        Treatment of the quadratic Davis term.
    dummy_state : bool
        Include seed 000's dummy state ``delta[n-1]`` (eigenvalue 0,
        uncontrollable and unobservable).
    outputs : tuple of str
        Output groups, from ``"v"`` (velocities [m/s]), ``"delta"``
        (elongations [m]) and ``"force"`` (coupler forces [N]).
    name : str
        System name.

    Returns
    -------
    control.StateSpace
        States ``v[i]``, ``delta[i]``; inputs ``u[i]`` [N]; outputs as asked.

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> sys = linearise(crh2_half(), 300 / 3.6, dummy_state=True)
    >>> sys.nstates, sys.ninputs, sys.noutputs
    (8, 4, 4)
    >>> sys.state_labels[-1]
    'delta[3]'
    """
    import control as ct

    A, B = linear_matrices(train, speed, method=method, dummy_state=dummy_state)
    check_finite_arrays("linearise", f" The train's parameters at {speed!r} m/s give a model "
                        "beyond floating point; check masses, couplers and Davis terms.", A=A, B=B)
    C, out_labels = _output_matrix(train, outputs, A.shape[0])
    n = train.n_vehicles
    states = train.state_labels() + ([f"delta[{n - 1}]"] if dummy_state else [])
    return ct.ss(
        A, B, C, np.zeros((C.shape[0], n)),
        states=states, inputs=[f"u[{i}]" for i in range(n)], outputs=out_labels, name=name,
    )


def _output_matrix(
    train: Train, outputs: tuple[str, ...], nx: int
) -> tuple[NDArray[np.float64], list[str]]:
    n, nc = train.n_vehicles, train.n_couplers
    if (
        not outputs
        or any(g not in OUTPUT_GROUPS for g in outputs)
        or len(set(outputs)) != len(outputs)
    ):
        raise ModelError(
            f"linearise: 'outputs' must be distinct groups from {OUTPUT_GROUPS} (got {outputs!r})."
        )
    rows: list[NDArray[np.float64]] = []
    labels: list[str] = []
    for group in outputs:
        block = np.zeros((n if group == "v" else nc, nx))
        if group == "v":
            block[:, :n] = np.eye(n)
        elif group == "delta":
            block[:, n : n + nc] = np.eye(nc)
        else:
            block[:, n : n + nc] = np.diag(train.stiffness)
            for i, d in enumerate(train.damping):
                block[i, i], block[i, i + 1] = d, -d
        rows.append(block)
        label = {"v": "v", "delta": "delta", "force": "f"}[group]
        labels += [f"{label}[{i}]" for i in range(block.shape[0])]
    return np.vstack(rows), labels
