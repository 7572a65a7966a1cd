# The local model of each coach of neighbourhood-local N-DMPC: owned, outside and input sets.
"""The neighbourhood model of each coach (:func:`local_model`): which states it owns,
which act on it from outside, and its own discretisation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from trainctl.controllers.mpc.theory.mpc import MPCDesign
from trainctl.exceptions import ModelError

__all__ = ["BOUNDARIES", "HOLDS", "LocalModel", "local_model", "train_state_owner"]

Array = NDArray[np.float64]


def train_state_owner(n: int) -> tuple[int, ...]:
    """Owner of each state of the train design model [v_0..v_{n-1}, delta_0..delta_{n-2}].

    Coach i owns its speed and the elongation of the coupler behind it (z_i of eq. 12.12).

    Parameters
    ----------
    n : int
        Number of coaches.

    Returns
    -------
    tuple of int
        The owning coach of each of the 2n - 1 states.

    Examples
    --------
    >>> train_state_owner(3)
    (0, 1, 2, 0, 1)
    """
    return tuple(range(n)) + tuple(range(n - 1))


@dataclass(frozen=True, kw_only=True)
class LocalModel:
    """The continuous design model partitioned by coach.

    Parameters
    ----------
    A : ndarray
        Continuous state matrix (nx, nx) [1/s], design units.
    B : ndarray
        Continuous input matrix (nx, nu) [state unit per s per input unit, e.g. m/s² per kN].
    dt : float
        Sample time T [s].
    state_owner : tuple of int
        The coach owning each state.
    hold : {"foh", "zoh"}
        Outer states between the exchanged samples: linear or constant.
    substeps : int
        N >= 1: the trajectories are exchanged at T/N (the local models are
        sampled at T/N; the inputs are still held over T).
    boundary : {"state", "force"}
        What a neighbourhood takes from outside (:func:`local_model`).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> m.state_owner, m.hold, m.substeps, m.boundary
    ((0, 1), 'zoh', 1, 'state')
    """

    A: Array
    B: Array
    dt: float
    state_owner: tuple[int, ...]
    hold: str = "foh"
    substeps: int = 1
    boundary: str = "state"


HOLDS = ("zoh", "foh")
"""How the exchanged outer-state samples are held over a sample: constant, or linear."""

BOUNDARIES = ("state", "force")
"""What a neighbourhood takes from outside: the adjacent subsystems' states (the book's
Â_{i,i±1} z_{i±2}) or, in addition, the elongations of its boundary couplers."""


def local_model(design: MPCDesign, A: Array, B: Array, dt: float,
                state_owner: Sequence[int], *, hold: str = "foh", substeps: int = 1,
                boundary: str = "state", rtol: float = 1e-7) -> LocalModel:
    """A :class:`LocalModel` of ``design``, checked: ZOH(A, B, dt) must be the design's (A, B).

    Parameters
    ----------
    design : MPCDesign
        The discrete design (its A, B are the exact ZOH of the continuous model).
    A, B : ndarray
        The continuous design model.
    dt : float
        Sample time [s].
    state_owner : sequence of int
        Coach owning each state (:func:`train_state_owner` for the train).
    hold : {"foh", "zoh"}
        Outer states between the exchanged samples: linear (first-order
        hold, default) or constant (zero-order hold).
    substeps : int
        N >= 1 exchanged samples per sample T (the hold error falls like
        (ωT/N)² with the first-order hold, like ωT/N with the zero-order hold).
    boundary : {"state", "force"}
        ``"state"`` (the book's Â_{i,i±1}): the neighbourhood predicts all its
        members' states; the outer states z_{i±2} are exchanged. For the
        train this is asymmetric: at the front the outer elongation delta_{i-2}
        enters as a force on coach i-1, at the rear the outer speed v_{i+2}
        drives the boundary elongation delta_{i+1}, so the neighbourhood is
        tied to a prescribed motion there. ``"force"``: a member state
        without an input of its own that is driven from outside (the rear
        boundary elongation) is exchanged too (its owner, for whom it is
        inside, predicts it), so both ends see a coupler force and the
        neighbourhood keeps its rigid-body mode. The coach's own states are
        always predicted.
    rtol : float
        Relative tolerance of the check.

    Returns
    -------
    LocalModel
        The partitioned continuous model.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> m.dt, m.B.tolist()
    (0.5, [[0.7, 0.0], [0.0, 0.7]])
    >>> try:  # not the model the design was sampled from
    ...     local_model(d, Ac, 2 * Bc, T, (0, 1))
    ... except ModelError as err:
    ...     print(type(err).__name__, "zero-order hold of (A, B)" in str(err))
    ModelError True
    """
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    nx, nu = design.B.shape
    owner = tuple(int(o) for o in state_owner)
    if A.shape != (nx, nx) or B.shape != (nx, nu) or len(owner) != nx:
        raise ModelError(f"local_model: shapes disagree with the design (A {A.shape}, "
                         f"B {B.shape}, {len(owner)} owners; design {nx} states, {nu} inputs).")
    if hold not in HOLDS:
        raise ModelError(f"local_model: 'hold' must be one of {HOLDS} (got {hold!r}).")
    if boundary not in BOUNDARIES:
        raise ModelError(f"local_model: 'boundary' must be one of {BOUNDARIES} "
                         f"(got {boundary!r}).")
    if not (isinstance(substeps, int) and substeps >= 1):
        raise ModelError(f"local_model: 'substeps' must be an int >= 1 (got {substeps!r}).")
    if any(not 0 <= o < nu for o in owner):
        raise ModelError(f"local_model: state owners must be coaches 0..{nu - 1}.")
    Ad, Bd, _, _ = _discretise(A, B, np.zeros((nx, 0)), dt, "zoh")
    scale = max(float(np.abs(design.A).max()), float(np.abs(design.B).max()), 1e-300)
    if not (np.allclose(Ad, design.A, rtol=rtol, atol=rtol * scale)
            and np.allclose(Bd, design.B, rtol=rtol, atol=rtol * scale)):
        raise ModelError("local_model: the zero-order hold of (A, B) at dt is not the design's "
                         "discrete model.")
    return LocalModel(A=A, B=B, dt=float(dt), state_owner=owner, hold=hold, substeps=substeps,
                      boundary=boundary)


def _discretise(A: Array, B: Array, E: Array, dt: float,
                hold: str) -> tuple[Array, Array, Array, Array]:
    """Exact sampling of dz/dt = A z + B u + E w: u held; w held (zoh) or linear (foh).

    Returns Ad, Bd, E0, E1 with z(k+1) = Ad z(k) + Bd u(k) + E0 w(k) + E1 w(k+1)
    (E1 = 0 for the zero-order hold). In scaled time τ = t/T the first-order
    hold is w(τ) = w(k) + τ (w(k+1) - w(k)): the augmented state
    [z; u; w; dw/dτ] has the generator [[AT, BT, ET, 0], [0, 0, 0, 0],
    [0, 0, 0, I], [0, 0, 0, 0]], whose exponential holds the maps.
    """
    n, nb, ne = A.shape[0], B.shape[1], E.shape[1]
    size = n + nb + 2 * ne
    M = np.zeros((size, size))
    M[:n, :n], M[:n, n:n + nb], M[:n, n + nb:n + nb + ne] = A * dt, B * dt, E * dt
    if hold == "foh":
        M[n + nb:n + nb + ne, n + nb + ne:] = np.eye(ne)
    Md = expm(M)
    Ad, Bd = Md[:n, :n], Md[:n, n:n + nb]
    F1, F2 = Md[:n, n + nb:n + nb + ne], Md[:n, n + nb + ne:]
    return Ad, Bd, F1 - F2, F2
