# The local Jacobi iteration to the Nash point, its plan gain and the closed loops it gives.
"""The local iteration and its Nash point (:func:`local_iteration`, :func:`local_nash_gain`),
the closed loops at the Nash point or after finitely many iterations, and the
threshold weight below which the iteration converges.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse
from numpy.typing import NDArray

from trainctl.controllers.mpc.theory.iteration import log_bisection, spectral_radius
from trainctl.controllers.mpc.theory.local_iteration.model import LocalModel
from trainctl.controllers.mpc.theory.local_iteration.predictions import (
    CoachPrediction,
    coach_predictions,
)
from trainctl.controllers.mpc.theory.mpc import MPCDesign, prediction

__all__ = [
    "LocalIteration", "local_closed_loop", "local_finite_iteration_closed_loop", "local_iteration",
    "local_nash_gain", "local_shift_matrix", "local_threshold_weight",
]

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class LocalIteration:
    """The stacked Jacobi iteration ξ^{l+1} = D0 ξ^l + D1 θ of local N-DMPC.

    Parameters
    ----------
    D0 : ndarray
        Iteration matrix on ξ = [U; X] (M·n plans, then P·nx predicted states).
    D1 : ndarray
        Map from θ = [x(k); u(k-1)] (u(k-1) unused in the u-form).
    n_plan : int
        M·n, the length of U in ξ.
    gains : tuple of ndarray
        K_i of every coach (M × P·|R_i|).
    coaches : tuple of CoachPrediction
        The local predictions.

    Examples
    --------
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> it = local_iteration(d, m)
    >>> it.n_plan, it.D0.shape, it.D1.shape  # xi = [u0, u1, z(k+1), z(k+2)]
    (2, (6, 6), (6, 4))
    >>> np.round(it.gains[0], 4).tolist()  # K_0 = (GᵀQG + R)⁻¹GᵀQ, G = [0.35, 0.7]
    [[0.4308, 0.8615]]
    """

    D0: Array
    D1: Array
    n_plan: int
    gains: tuple[Array, ...]
    coaches: tuple[CoachPrediction, ...]

    @property
    def rho(self) -> float:
        """ρ(D0): the iteration converges from any start iff it is < 1."""
        return spectral_radius(self.D0)


def local_iteration(design: MPCDesign, model: LocalModel,
                    coaches: Sequence[CoachPrediction] | None = None,
                    r: float | Array | None = None) -> LocalIteration:
    """D0, D1 of local N-DMPC (module docstring).

    Parameters
    ----------
    design : MPCDesign
        The design (weights q, r; ``r`` overrides its input weights).
    model : LocalModel
        Its continuous model partitioned by coach.
    coaches : sequence of CoachPrediction or None
        Precomputed :func:`coach_predictions`.
    r : float or ndarray or None
        Input weights (scalar: common) [per design unit²]; None: ``design.r``.

    Returns
    -------
    LocalIteration
        The iteration matrices.

    Examples
    --------
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> # By hand (β = 0.35, γ = 0.15, q = 2, r = 0.4): ρ(D0) = 2qβ²γ/(5qβ² + r) = 0.04523.
    >>> round(local_iteration(d, m).rho, 5)
    0.04523
    """
    coaches = coach_predictions(design, model) if coaches is None else tuple(coaches)
    n, nx = design.n_inputs, design.A.shape[0]
    P, M = design.prediction_horizon, design.control_horizon
    rr = design.r if r is None else np.broadcast_to(np.asarray(r, dtype=float), (n,))
    MN = M * n
    fine = P * model.substeps
    size = MN + fine * nx
    D0 = np.zeros((size, size))
    D1 = np.zeros((size, nx + n))
    moves = np.arange(M)
    steps = np.arange(fine)
    gains = []
    for c in coaches:
        i, nI = c.coach, c.inputs.size
        own_pos = c.own_input
        q = np.tile(design.q[c.rows], P)
        own_cols = moves * nI + own_pos                      # own moves in the local G
        Gii = c.y.G[:, own_cols]
        H = Gii.T @ (q[:, None] * Gii) + np.eye(M) * rr[i]
        K = np.linalg.solve(H, Gii.T * q[None, :])
        gains.append(K)
        ui = moves * n + i                                   # own moves in ξ
        xo = (MN + steps[:, None] * nx + c.outer[None, :]).ravel()  # X_O in ξ (step-major)
        uI = (moves[:, None] * n + c.inputs[None, :]).ravel()       # U_I in ξ (move-major)
        others = np.setdiff1d(np.arange(M * nI), own_cols)
        # U_i rows
        D0[np.ix_(ui, xo)] = -K @ c.y.Psi
        D0[np.ix_(ui, uI[others])] = -K @ c.y.G[:, others]
        D1[np.ix_(ui, c.states)] = -K @ c.y.Phi
        D1[np.ix_(ui, c.outer)] += -K @ c.y.Phi_o
        D1[np.ix_(ui, nx + c.inputs)] += -K @ c.y.Su
        # X_i rows: own-state trajectory with the new own plan
        xi = (MN + steps[:, None] * nx + c.own[None, :]).ravel()
        Gz_own = c.z.G[:, own_cols]
        D0[xi] = Gz_own @ D0[ui]
        D1[xi] = Gz_own @ D1[ui]
        D0[np.ix_(xi, xo)] += c.z.Psi
        D0[np.ix_(xi, uI[others])] += c.z.G[:, others]
        D1[np.ix_(xi, c.states)] += c.z.Phi
        D1[np.ix_(xi, c.outer)] += c.z.Phi_o
        D1[np.ix_(xi, nx + c.inputs)] += c.z.Su
    return LocalIteration(D0=D0, D1=D1, n_plan=MN, gains=tuple(gains), coaches=coaches)


def local_nash_gain(it: LocalIteration) -> Array:
    """(I - D0)⁻¹ D1: the fixed point ξ* = gain θ (plans, then predicted states).

    Parameters
    ----------
    it : LocalIteration
        The local iteration, with its matrices D0 and D1.

    Returns
    -------
    ndarray
        The gain from θ = [x(k); u(k-1)] to the fixed point ξ*.

    Examples
    --------
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> it = local_iteration(d, m)
    >>> g = local_nash_gain(it)
    >>> g.shape  # rows: the plans, then the trajectories; columns: x(k), u(k-1)
    (6, 4)
    >>> xi = g @ np.array([1.0, 1.0, 0.0, 0.0])  # both coaches at z = 1
    >>> bool(np.allclose(it.D0 @ xi + it.D1 @ np.array([1.0, 1.0, 0.0, 0.0]), xi))  # fixed point
    True
    >>> # By hand: u = -qβ(3a + 2γs)/(5qβ² + r), a = 1 + γ, s = a(2qβ² + r)/(5qβ² + r + 2qβ²γ).
    >>> np.round(xi[:2], 4).tolist()  # first moves [design units]
    [-1.564, -1.564]
    """
    return np.asarray(np.linalg.solve(np.eye(it.D0.shape[0]) - it.D0, it.D1), dtype=np.float64)


def local_closed_loop(design: MPCDesign, plan_gain: Array) -> Array:
    """Closed loop on the global discrete model when the plan is U = plan_gain θ.

    Parameters
    ----------
    design : MPCDesign
        The design (its A, B: the true discrete model).
    plan_gain : ndarray
        (M·n, nx + n): the plan's dependence on θ = [x(k); u(k-1)] (the
        first M·n rows of :func:`local_nash_gain`).

    Returns
    -------
    ndarray
        A_cl on x (u-form) or on [x; u(k-1)] (Δu-form).

    Examples
    --------
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> it = local_iteration(d, m)
    >>> A_cl = local_closed_loop(d, local_nash_gain(it)[:it.n_plan])
    >>> np.round(np.abs(np.linalg.eigvals(A_cl)), 4).tolist()  # stable
    [0.5712, 0.5242]
    """
    nx, n = design.A.shape[0], design.n_inputs
    K = prediction(design).first_move @ plan_gain
    Kx, Ku = K[:, :nx], K[:, nx:]
    A, B = design.A, design.B
    if design.form == "u":
        return np.asarray(A + B @ Kx, dtype=np.float64)
    top = np.hstack([A + B @ Kx, B @ (np.eye(n) + Ku)])
    bottom = np.hstack([Kx, np.eye(n) + Ku])
    return np.asarray(np.vstack([top, bottom]), dtype=np.float64)


def local_shift_matrix(design: MPCDesign, it: LocalIteration, substeps: int) -> Array:
    """Warm start of the next sample: ξ = [U; X] shifted by one sample.

    The plan as :func:`~trainctl.controllers.mpc.theory.iteration.shift_matrix`; the
    trajectories drop their first N fine samples and repeat the last one N
    times (as ``ndmpc-local`` does).

    Parameters
    ----------
    design : MPCDesign
        The design (horizons, inputs, form).
    it : LocalIteration
        The local iteration whose ξ is shifted.
    substeps : int
        N, the fine samples per controller sample.

    Returns
    -------
    ndarray
        The square matrix mapping ξ to the next sample's warm start.

    Examples
    --------
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> S = local_shift_matrix(d, local_iteration(d, m), 1)
    >>> S[2:].astype(int).tolist()  # z(k+1) <- z(k+2), z(k+2) <- z(k+2)
    [[0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1]]
    """
    from trainctl.controllers.mpc.theory.iteration import shift_matrix

    MN, size = it.n_plan, it.D0.shape[0]
    nx = design.A.shape[0]
    fine = (size - MN) // nx
    S = np.zeros((size, size))
    S[:MN, :MN] = shift_matrix(design)
    for tau in range(fine):
        src = min(tau + substeps, fine - 1)
        rows = MN + tau * nx + np.arange(nx)
        S[rows, MN + src * nx + np.arange(nx)] = 1.0
    return S


def local_finite_iteration_closed_loop(design: MPCDesign, it: LocalIteration, iterations: int,
                                       substeps: int = 1) -> Array:
    """Closed loop with L local Jacobi iterations per sample from the shifted previous ξ.

    The state is augmented with the previous [plans; trajectories]:
    [x; ξ_prev] (u-form) or [x; u(k-1); ξ_prev] (Δu-form), with
    ξ = D0^L S ξ_prev + Σ_{k<L} D0^k D1 θ, θ = [x; u(k-1)].

    Parameters
    ----------
    design : MPCDesign
        The design (its A, B: the true discrete model).
    it : LocalIteration
        The local iteration.
    iterations : int
        L >= 1.
    substeps : int
        N of the local model (the trajectories' fine samples per sample).

    Returns
    -------
    ndarray
        The augmented closed-loop matrix.

    Examples
    --------
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> it = local_iteration(d, m)
    >>> F = local_finite_iteration_closed_loop(d, it, 3)
    >>> F.shape  # [x; xi_prev]
    (8, 8)
    >>> # ρ(D0) = 0.045: three sweeps already give nearly the converged loop's 0.5712.
    >>> round(spectral_radius(F), 4)
    0.5713
    """
    nx, n = design.A.shape[0], design.n_inputs
    # D0 couples each coach with its neighbours only (0.8 % nonzero for the 204-vehicle chain,
    # 4682 rows): its powers are taken sparse, and Σ_{k<L} D0^k D1 by Horner on D1's columns
    # (dense matrix_power and the sum of powers: 51 s there; this: under a second).
    D0 = scipy.sparse.csr_array(it.D0)
    D1 = it.D1
    xi_prev = scipy.sparse.csr_array(local_shift_matrix(design, it, substeps))
    xi_theta = D1.copy()
    for _ in range(iterations):
        xi_prev = D0 @ xi_prev                                 # ξ from ξ_prev: D0^L S
    for _ in range(iterations - 1):
        xi_theta = D1 + D0 @ xi_theta                          # ξ from θ: Σ_{k<L} D0^k D1
    xi_prev = xi_prev.toarray()
    F = np.zeros((n, D0.shape[0]))
    F[:, :n] = np.eye(n)                                       # first move of every coach
    A, B = design.A, design.B
    if design.form == "u":
        Kx = F @ xi_theta[:, :nx]
        top = np.hstack([A + B @ Kx, B @ F @ xi_prev])
        return np.asarray(np.vstack([top, np.hstack([xi_theta[:, :nx], xi_prev])]),
                          dtype=np.float64)
    Kx, Ku = F @ xi_theta[:, :nx], F @ xi_theta[:, nx:]
    rows_x = np.hstack([A + B @ Kx, B @ (np.eye(n) + Ku), B @ F @ xi_prev])
    rows_u = np.hstack([Kx, np.eye(n) + Ku, F @ xi_prev])
    rows_p = np.hstack([xi_theta[:, :nx], xi_theta[:, nx:], xi_prev])
    return np.asarray(np.vstack([rows_x, rows_u, rows_p]), dtype=np.float64)


def local_threshold_weight(design: MPCDesign, model: LocalModel, *, low: float = 1e-12,
                           high: float = 1e12, rtol: float = 1e-6) -> float:
    """Smallest common input weight R* with ρ(D0_local) < 1, by bisection on log R.

    Parameters
    ----------
    design : MPCDesign
        The design (its own ``r`` is ignored).
    model : LocalModel
        Its partitioned continuous model.
    low, high : float
        Search bracket [per design unit²].
    rtol : float
        Relative accuracy of R*.

    Returns
    -------
    float
        R* (``low`` if converging already there; inf if diverging even at ``high``).

    Examples
    --------
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> # ρ(D0) = 2qβ²γ/(5qβ² + R) < 2γ/5 = 0.06 for every R: already converging at low.
    >>> local_threshold_weight(d, m)
    1e-12
    """
    coaches = coach_predictions(design, model)

    def excess(log_r: float) -> float:
        return local_iteration(design, model, coaches, r=10.0**log_r).rho - 1.0

    return log_bisection(excess, low, high, rtol)
