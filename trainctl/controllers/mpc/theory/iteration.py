# Distributed-MPC theory in closed form: N-DMPC iteration, Nash point, cooperative DMPC.
"""Closed-form analysis of centralised, N-DMPC and cooperative DMPC.

On the condensed prediction of :mod:`trainctl.controllers.mpc.theory.mpc` (design units,
decision vector ordered move by move, coach i owning input i):

N-DMPC (neighbourhood optimisation, Jacobi): coach i minimises the output
cost of its neighbourhood N_i (weights W_i: Q restricted to the outputs owned
by coaches in N_i) over its own moves U_i, the others' moves fixed at the
previous iterate:

    U_i^{l+1} = K_i (e - Σ_{j≠i} G_j U_j^l),  K_i = (G_iᵀ W_i G_i + R_i)⁻¹ G_iᵀ W_i,

with e = Y_r - Φx (- S_u u(k-1)). Stacked, U^{l+1} = D0 U^l + D1 e with
D0 = -[K_i G_j]_{j≠i} (zero diagonal blocks) and D1 = col(K_i). The iteration
converges from any start iff ρ(D0) < 1; its fixed point (the Nash point) is
(I - D0)⁻¹ D1 e. Cooperative DMPC uses the whole-train cost for every coach
and the convex-combination update U^{l+1} = (I - W)U^l + W(D0 U^l + D1 e)
(Stewart, Venkat, Rawlings et al.), whose fixed point is the centralised optimum.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.controllers.mpc.theory.mpc import MPCDesign, Prediction, prediction
from trainctl.exceptions import ModelError

__all__ = [
    "RelaxationResult",
    "closed_loop_matrix",
    "convergence_sweep",
    "cooperative_iteration",
    "finite_iteration_closed_loop",
    "iteration_matrices",
    "log_bisection",
    "nash_gain",
    "relaxation",
    "shift_matrix",
    "spectral_radius",
    "threshold_weight",
]

Array = NDArray[np.float64]


def iteration_matrices(design: MPCDesign, pred: Prediction | None = None) -> tuple[Array, Array]:
    """Jacobi iteration matrices (D0, D1) of N-DMPC.

    Parameters
    ----------
    design : MPCDesign
        The design; ``neighbourhoods`` define each coach's cost.
    pred : Prediction or None
        Precomputed prediction matrices.

    Returns
    -------
    D0 : ndarray
        Iteration matrix (zero diagonal blocks), in decision-vector order.
    D1 : ndarray
        Map from the error e to the update.

    Examples
    --------
    >>> import numpy as np
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 2)), C=np.eye(1), prediction_horizon=1,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.ones(2),
    ...               output_owner=(0,), neighbourhoods=((0, 1), (0, 1)))
    >>> D0, D1 = iteration_matrices(d)
    >>> D0.tolist()
    [[0.0, -0.5], [-0.5, 0.0]]
    """
    pred = prediction(design) if pred is None else pred
    G = pred.G
    D0 = np.zeros((G.shape[1], G.shape[1]))
    D1 = np.zeros((G.shape[1], G.shape[0]))
    P = design.prediction_horizon
    for i, cols in enumerate(pred.columns):
        # W = diag(w) weighs only the neighbourhood's output rows: work on those rows alone
        # (O(P·|N_i|) each, not O(P·n)), so that the whole matrix costs O(n²), not O(n³).
        mask = np.array([owner in design.neighbourhoods[i] for owner in design.output_owner],
                        dtype=float)
        w = np.tile(design.q * mask, P)
        rows = np.flatnonzero(w)
        Gr = G[rows]
        Gi = Gr[:, cols]
        H = Gi.T @ (w[rows, None] * Gi) + pred.Rbar[np.ix_(cols, cols)]
        K = np.linalg.solve(H, Gi.T * w[None, rows])
        D1[np.ix_(cols, rows)] = K
        D0[cols] = -K @ Gr
        D0[np.ix_(cols, cols)] = 0.0
    return D0, D1


def spectral_radius(M: Array) -> float:
    """Largest |eigenvalue| of a square matrix (0 for an empty one).

    Parameters
    ----------
    M : ndarray
        A square matrix.

    Returns
    -------
    float
        The spectral radius max |λ(M)|, 0.0 when M is empty.

    Examples
    --------
    >>> import numpy as np
    >>> spectral_radius(np.array([[0.5, 1.0], [0.0, -0.8]]))  # triangular: eigenvalues 0.5, -0.8
    0.8
    >>> spectral_radius(np.array([[0.0, -1.0], [1.0, 0.0]]))  # a rotation: ±j
    1.0
    """
    return float(np.max(np.abs(np.linalg.eigvals(M)))) if M.size else 0.0


def nash_gain(D0: Array, D1: Array) -> Array:
    """T_N with U_Nash = T_N e: (I - D0)⁻¹ D1.

    Parameters
    ----------
    D0 : ndarray
        Jacobi iteration matrix (M, M).
    D1 : ndarray
        Map from the initial state (and last input) into one iteration (M, k).

    Returns
    -------
    ndarray
        The gain T_N (M, k) from that vector to the Nash plan.

    Examples
    --------
    >>> import numpy as np
    >>> # Two players on one integrator, both weighing the same output (P = M = 1, q = r = 1).
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 2)), C=np.eye(1), prediction_horizon=1,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.ones(2),
    ...               output_owner=(0,), neighbourhoods=((0, 1), (0, 1)))
    >>> D0, D1 = iteration_matrices(d)
    >>> # Player i minimises (x + u_i + u_j)² + u_i², so u_i = -(x + u_j)/2: u = -x/3 each.
    >>> np.round(nash_gain(D0, D1), 4).tolist()  # U = T_N e with e = -x
    [[0.3333], [0.3333]]
    """
    return np.asarray(np.linalg.solve(np.eye(D0.shape[0]) - D0, D1), dtype=np.float64)


def closed_loop_matrix(
    design: MPCDesign, gain: Array, pred: Prediction | None = None
) -> Array:
    """Closed-loop state matrix when the plan is U = gain · e (regulation, Y_r = 0).

    Parameters
    ----------
    design : MPCDesign
        The design.
    gain : ndarray
        T with U = T e (centralised: H⁻¹GᵀQ; Nash: (I - D0)⁻¹D1).
    pred : Prediction or None
        Precomputed prediction matrices.

    Returns
    -------
    ndarray
        A_cl on x (u-form) or on [x; u(k-1)] (Δu-form).

    Examples
    --------
    >>> import numpy as np
    >>> # Two players on one integrator, both weighing the same output (P = M = 1, q = r = 1).
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 2)), C=np.eye(1), prediction_horizon=1,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.ones(2),
    ...               output_owner=(0,), neighbourhoods=((0, 1), (0, 1)))
    >>> D0, D1 = iteration_matrices(d)
    >>> # Both players apply u = -x/3: x(k+1) = x - 2x/3 = x/3.
    >>> np.round(closed_loop_matrix(d, nash_gain(D0, D1)), 4).tolist()
    [[0.3333]]
    """
    pred = prediction(design) if pred is None else pred
    A, B = design.A, design.B
    K = pred.first_move @ gain
    if design.form == "u":
        return A - B @ K @ pred.Phi
    nu = design.n_inputs
    Kx, Ku = K @ pred.Phi, K @ pred.Su
    top = np.hstack([A - B @ Kx, B @ (np.eye(nu) - Ku)])
    bottom = np.hstack([-Kx, np.eye(nu) - Ku])
    return np.vstack([top, bottom])


def shift_matrix(design: MPCDesign) -> Array:
    """Warm start from the previous plan: drop the first move, repeat (u) or zero (Δu) the last.

    Parameters
    ----------
    design : MPCDesign
        The design: its horizons, input count and form (``"u"`` or ``"du"``).

    Returns
    -------
    ndarray
        The square matrix mapping a plan to the next sample's starting plan.

    Examples
    --------
    >>> import dataclasses
    >>> import numpy as np
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 1)), C=np.eye(1), prediction_horizon=3,
    ...               control_horizon=3, form="u", q=np.ones(1), r=np.ones(1),
    ...               output_owner=(0,), neighbourhoods=((0,),))
    >>> shift_matrix(d).tolist()  # [u1, u2, u2]: the last input is held
    [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]]
    >>> shift_matrix(dataclasses.replace(d, form="du")).tolist()  # [Δu1, Δu2, 0]
    [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]
    """
    nu, M = design.n_inputs, design.control_horizon
    S = np.zeros((M * nu, M * nu))
    for m in range(M):
        src = min(m + 1, M - 1)
        if design.form == "du" and m + 1 > M - 1:
            continue
        S[m * nu:(m + 1) * nu, src * nu:(src + 1) * nu] = np.eye(nu)
    return S


def finite_iteration_closed_loop(
    design: MPCDesign, D0: Array, D1: Array, iterations: int, pred: Prediction | None = None
) -> Array:
    """Closed loop with a fixed number L of Jacobi iterations per sample.

    The iteration starts from the shifted previous plan, so the state is
    augmented with it: ξ = [x; U_prev] (u-form) or [x; u(k-1); ΔU_prev] (Δu-form).

    Parameters
    ----------
    design : MPCDesign
        The design.
    D0, D1 : ndarray
        Iteration matrices.
    iterations : int
        L >= 1 iterations per sample.
    pred : Prediction or None
        Precomputed prediction matrices.

    Returns
    -------
    ndarray
        The augmented closed-loop matrix.

    Examples
    --------
    >>> import numpy as np
    >>> # Two players on one integrator, both weighing the same output (P = M = 1, q = r = 1).
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 2)), C=np.eye(1), prediction_horizon=1,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.ones(2),
    ...               output_owner=(0,), neighbourhoods=((0, 1), (0, 1)))
    >>> D0, D1 = iteration_matrices(d)
    >>> # One sweep from the previous plan: x(k+1) = -(u1_prev + u2_prev)/2, and the loop on
    >>> # [x; U_prev] is -(J - I)/2 with eigenvalues -1, 1/2, 1/2: marginally stable.
    >>> F = finite_iteration_closed_loop(d, D0, D1, 1)
    >>> F.tolist()
    [[0.0, -0.5, -0.5], [-0.5, 0.0, -0.5], [-0.5, -0.5, 0.0]]
    >>> F2 = finite_iteration_closed_loop(d, D0, D1, 2)  # two sweeps per sample
    >>> round(spectral_radius(F), 4), round(spectral_radius(F2), 4)
    (1.0, 0.5)
    """
    pred = prediction(design) if pred is None else pred
    A, B, nu = design.A, design.B, design.n_inputs
    DL = np.linalg.matrix_power(D0, iterations)
    SL = sum((np.linalg.matrix_power(D0, k) for k in range(iterations)), np.zeros_like(D0))
    S = shift_matrix(design)
    plan_x = -SL @ D1 @ pred.Phi            # dependence of U^(L) on x
    plan_p = DL @ S                         # ... on the previous plan
    F = pred.first_move
    if design.form == "u":
        top = np.hstack([A + B @ F @ plan_x, B @ F @ plan_p])
        return np.vstack([top, np.hstack([plan_x, plan_p])])
    plan_u = -SL @ D1 @ pred.Su              # ... on u(k-1)
    rows_x = np.hstack([A + B @ F @ plan_x, B @ (np.eye(nu) + F @ plan_u), B @ F @ plan_p])
    rows_u = np.hstack([F @ plan_x, np.eye(nu) + F @ plan_u, F @ plan_p])
    rows_p = np.hstack([plan_x, plan_u, plan_p])
    return np.vstack([rows_x, rows_u, rows_p])


def threshold_weight(
    design: MPCDesign, *, low: float = 1e-12, high: float = 1e12, rtol: float = 1e-6
) -> float:
    """Smallest common input weight R* with ρ(D0) < 1, by bisection on log R.

    Parameters
    ----------
    design : MPCDesign
        The design (its own ``r`` is ignored; all inputs get the same weight).
    low, high : float
        Search bracket [design units].
    rtol : float
        Relative accuracy of R*.

    Returns
    -------
    float
        R* (``low`` if the iteration converges already at ``low``; inf if it
        diverges even at ``high``).

    Examples
    --------
    Three identical inputs on one integrator: ρ(D0) = 10/(5 + R)
    (:func:`convergence_sweep`), so R* = 5.

    >>> import numpy as np
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 3)), C=np.eye(1), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.full(3, 0.1),
    ...               output_owner=(0,), neighbourhoods=((0, 1, 2),) * 3)
    >>> round(threshold_weight(d), 4)
    5.0
    """
    pred = prediction(design)  # independent of R: build once, swap the weight block
    M = design.control_horizon

    def excess(log_r: float) -> float:
        r = 10.0**log_r
        Rbar = np.asarray(np.kron(np.eye(M), np.diag(np.full(design.n_inputs, r))),
                          dtype=np.float64)
        trial = dataclasses.replace(pred, Rbar=Rbar)
        D0, _ = iteration_matrices(design.with_r(r), trial)
        return spectral_radius(D0) - 1.0

    return log_bisection(excess, low, high, rtol)


def log_bisection(excess: Callable[[float], float], low: float, high: float,
                  rtol: float) -> float:
    """Smallest weight in [low, high] where ``excess(log10 weight) < 0``, by bisection on log R.

    Parameters
    ----------
    excess : callable
        log10 R → ρ(R) - 1, decreasing through 0 once in the bracket.
    low, high : float
        Search bracket (> 0).
    rtol : float
        Relative accuracy of the result.

    Returns
    -------
    float
        ``low`` if ``excess`` is negative already there; inf if it is not
        negative even at ``high``.

    Examples
    --------
    >>> round(log_bisection(lambda log_r: 2.0 - log_r, 1e-3, 1e6, 1e-9), 6)
    100.0
    """
    lo, hi = math.log10(low), math.log10(high)
    if excess(lo) < 0:
        return low
    if excess(hi) >= 0:
        return math.inf
    while hi - lo > rtol / math.log(10):
        mid = 0.5 * (lo + hi)
        if excess(mid) >= 0:
            lo = mid
        else:
            hi = mid
    bound: float = 10.0**hi  # float ** float is Any in typeshed (a negative base is complex)
    return bound


def convergence_sweep(design: MPCDesign, weights: ArrayLike) -> Array:
    """ρ(D0) of the N-DMPC Jacobi iteration for each common input weight R.

    The curve behind :func:`threshold_weight`: ρ(D0) falls through 1 at R*.

    Parameters
    ----------
    design : MPCDesign
        The design (its own ``r`` is ignored; all inputs get the same weight).
    weights : array_like
        Input weights R > 0 [design units, e.g. per kN²].

    Returns
    -------
    ndarray
        The spectral radius ρ(D0) for each weight, same shape as ``weights``.

    Examples
    --------
    >>> import numpy as np
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 3)), C=np.eye(1), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.full(3, 0.1),
    ...               output_owner=(0,), neighbourhoods=((0, 1, 2),) * 3)
    >>> # By hand: D0 = -5/(5 + R) (J - I), so ρ(D0) = 10/(5 + R).
    >>> convergence_sweep(d, [1.0, 5.0, 25.0]).round(4).tolist()
    [1.6667, 1.0, 0.3333]
    """
    r = np.asarray(weights, dtype=float)
    if np.any(~np.isfinite(r)) or np.any(r <= 0):
        raise ModelError("convergence_sweep: weights must be finite and > 0.")
    pred = prediction(design)  # independent of R: build once, swap the weight block
    M = design.control_horizon
    out = np.empty(r.shape)
    for index, value in np.ndenumerate(r):
        Rbar = np.asarray(np.kron(np.eye(M), np.diag(np.full(design.n_inputs, value))),
                          dtype=np.float64)
        D0, _ = iteration_matrices(design.with_r(value), dataclasses.replace(pred, Rbar=Rbar))
        out[index] = spectral_radius(D0)
    return out


@dataclass(frozen=True, kw_only=True)
class RelaxationResult:
    """Relaxed Jacobi U ← (1-ω)U + ω U_new on an iteration matrix D0.

    Parameters
    ----------
    exists : bool
        Some ω in (0, 1] converges (iff every eigenvalue of D0 has Re < 1).
    omega_max : float
        Largest convergent ω (NaN when none exists).
    omega_best : float
        ω in (0, 1] minimising the spectral radius (NaN when none exists).
    rate : float
        max|1 - ω + ωλ| at ``omega_best``.

    Examples
    --------
    D0 with an eigenvalue at +2: no relaxation factor converges.

    >>> import numpy as np
    >>> res = relaxation(np.array([[0.0, 2.0], [2.0, 0.0]]))
    >>> res.exists, res.to_dict()["omega_best"]
    (False, None)
    """

    exists: bool
    omega_max: float
    omega_best: float
    rate: float

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``exists``, ``omega_max``, ``omega_best`` and ``rate`` [-]
            (None where NaN: no convergent ω).
        """
        def clean(x: float) -> float | None:
            return None if math.isnan(x) else x
        return {"exists": self.exists, "omega_max": clean(self.omega_max),
                "omega_best": clean(self.omega_best), "rate": clean(self.rate)}


def relaxation(D0: Array, eigenvalues: NDArray[np.complex128] | None = None) -> RelaxationResult:
    """Best relaxation factor for the Jacobi iteration matrix D0.

    The relaxed iteration matrix (1-ω)I + ωD0 has eigenvalues 1 - ω(1 - λ);
    |1 - ω(1 - λ)| < 1 iff 0 < ω < 2(1 - Re λ)/|1 - λ|², which needs Re λ < 1.

    Parameters
    ----------
    D0 : ndarray
        Jacobi iteration matrix.
    eigenvalues : ndarray or None
        D0's eigenvalues when already computed (the spectrum of a long train's
        local iteration matrix takes seconds).

    Returns
    -------
    RelaxationResult
        Whether a convergent ω exists, the range and the best rate.

    Examples
    --------
    >>> import numpy as np
    >>> D0 = -0.75 * (np.ones((3, 3)) - np.eye(3))  # three identical players: ρ = 1.5
    >>> res = relaxation(D0)
    >>> res.exists, round(res.omega_best, 4), round(res.rate, 4)
    (True, 0.7273, 0.8182)
    """
    lam: NDArray[np.complex128]
    if eigenvalues is not None and np.size(eigenvalues):
        lam = np.asarray(eigenvalues, dtype=np.complex128)
    else:
        lam = np.asarray(np.linalg.eigvals(D0) if D0.size else np.zeros(1), dtype=np.complex128)
    if np.any(lam.real >= 1.0 - 1e-12):
        return RelaxationResult(
            exists=False, omega_max=math.nan, omega_best=math.nan, rate=math.nan
        )
    one_minus = 1.0 - lam
    omega_max = float(min(1.0, np.min(2.0 * one_minus.real / np.abs(one_minus) ** 2)))

    def radius(w: float) -> float:
        return float(np.max(np.abs(1.0 - w * one_minus)))

    grid = np.linspace(omega_max / 400, min(omega_max, 1.0), 400)
    best = float(grid[int(np.argmin([radius(w) for w in grid]))])
    step = grid[1] - grid[0]
    lo, hi = max(best - step, 1e-12), min(best + step, 1.0)
    for _ in range(60):  # golden-section refinement of a unimodal max of convex functions
        a, b = lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo)
        lo, hi = (lo, b) if radius(a) <= radius(b) else (a, hi)
    best = float(0.5 * (lo + hi))
    return RelaxationResult(exists=True, omega_max=omega_max, omega_best=best, rate=radius(best))


def cooperative_iteration(
    design: MPCDesign, weights: Array | None = None, pred: Prediction | None = None
) -> tuple[Array, Array]:
    """Cooperative DMPC iteration U^{l+1} = T U^l + c(e) with convex weights.

    Every coach minimises the whole-train cost over its own moves; the new
    plan is the convex combination Σ_i w_i (plan with block i replaced).

    Parameters
    ----------
    design : MPCDesign
        The design (its neighbourhoods are ignored: every coach sees all).
    weights : ndarray or None
        Convex weights w_i > 0 summing to 1; default 1/n each.
    pred : Prediction or None
        Precomputed prediction matrices.

    Returns
    -------
    T : ndarray
        Iteration matrix (I - W) + W D0_coop.
    D1w : ndarray
        W D1_coop, so that U^{l+1} = T U^l + D1w e.

    Examples
    --------
    >>> import numpy as np
    >>> # Two players on one integrator, both weighing the same output (P = M = 1, q = r = 1).
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 2)), C=np.eye(1), prediction_horizon=1,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.ones(2),
    ...               output_owner=(0,), neighbourhoods=((0, 1), (0, 1)))
    >>> D0, D1 = iteration_matrices(d)
    >>> T, D1w = cooperative_iteration(d)  # weights 1/2: T = I/2 + D0/2
    >>> T.tolist(), D1w.tolist()
    ([[0.5, -0.25], [-0.25, 0.5]], [[0.25], [0.25]])
    >>> spectral_radius(T)  # eigenvalues 1/2 ± 1/4
    0.75
    >>> np.round(np.linalg.solve(np.eye(2) - T, D1w), 4).tolist()  # fixed point: centralised -x/3
    [[0.3333], [0.3333]]
    """
    n = design.n_inputs
    w = np.full(n, 1.0 / n) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (n,) or np.any(w <= 0) or not math.isclose(float(w.sum()), 1.0, rel_tol=1e-12):
        raise ModelError(
            f"cooperative_iteration: weights must be n = {n} positive numbers summing to 1 "
            f"(got {w.tolist()})."
        )
    everyone = tuple(range(n))
    full = design.with_neighbourhoods([everyone] * n)
    pred = prediction(full) if pred is None else pred
    D0, D1 = iteration_matrices(full, pred)
    W = np.zeros(D0.shape[0])
    for i, cols in enumerate(pred.columns):
        W[cols] = w[i]
    T = np.eye(D0.shape[0]) - np.diag(W) + W[:, None] * D0
    return T, W[:, None] * D1
