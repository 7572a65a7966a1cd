# Unconstrained MPC and distributed-MPC theory in closed form.
"""Closed-form analysis of centralised, N-DMPC and cooperative DMPC.

Notation (all in *design units*: inputs and outputs already scaled so that
the weights are plain numbers, e.g. u in kN and R per kN²). The discrete
model x(k+1) = A x(k) + B u(k), y = C x is predicted over P steps with M
free moves, the input held after move M:

- u-form: Y = Φ x + G U, decision U = [u(k); ...; u(k+M-1)], cost
  ‖Y - Y_r‖²_Q + ‖U‖²_R (penalises the input deviation from equilibrium).
- Δu-form: Y = Φ x + S_u u(k-1) + G ΔU, cost ‖Y - Y_r‖²_Q + ‖ΔU‖²_R.

The decision vector is ordered move by move ([all inputs at move 0], [all
inputs at move 1], ...); coach i owns input i at every move.

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
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..exceptions import ModelError

__all__ = [
    "FORMS",
    "MPCDesign",
    "Prediction",
    "RelaxationResult",
    "closed_loop_matrix",
    "convergence_sweep",
    "cooperative_iteration",
    "finite_iteration_closed_loop",
    "iteration_matrices",
    "nash_gain",
    "prediction",
    "prediction_matrices",
    "relaxation",
    "shift_matrix",
    "spectral_radius",
    "threshold_weight",
]

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
        return self.B.shape[1]

    def with_r(self, r: float | Array) -> MPCDesign:
        """A copy with input weights ``r`` (scalar: the same for every input)."""
        rr = np.broadcast_to(np.asarray(r, dtype=float), (self.n_inputs,)).copy()
        return MPCDesign(A=self.A, B=self.B, C=self.C, prediction_horizon=self.prediction_horizon,
                         control_horizon=self.control_horizon, form=self.form, q=self.q, r=rr,
                         output_owner=self.output_owner, neighbourhoods=self.neighbourhoods)

    def with_neighbourhoods(self, neighbourhoods: Sequence[Sequence[int]]) -> MPCDesign:
        """A copy with other neighbourhoods."""
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
    """

    Phi: Array
    Su: Array
    G: Array
    Qbar: Array
    Rbar: Array
    columns: tuple[NDArray[np.int64], ...]
    first_move: Array

    def hessian(self) -> Array:
        """Centralised Hessian H = GᵀQG + R."""
        return self.G.T @ self.Qbar @ self.G + self.Rbar

    def centralised_gain(self) -> Array:
        """K_c with U* = K_c e, K_c = H⁻¹ GᵀQ."""
        return np.asarray(np.linalg.solve(self.hessian(), self.G.T @ self.Qbar), dtype=np.float64)

    def cost(self, U: Array, e: Array) -> float:
        """Cost ‖G U - e‖²_Q + ‖U‖²_R of decision U for error e = Y_r - free response."""
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


def _local_weight(design: MPCDesign, members: Sequence[int]) -> Array:
    mask = np.array([owner in members for owner in design.output_owner], dtype=float)
    weight = np.kron(np.eye(design.prediction_horizon), np.diag(design.q * mask))
    return np.asarray(weight, dtype=np.float64)


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
    for i, cols in enumerate(pred.columns):
        W = _local_weight(design, design.neighbourhoods[i])
        Gi = G[:, cols]
        H = Gi.T @ W @ Gi + pred.Rbar[np.ix_(cols, cols)]
        K = np.linalg.solve(H, Gi.T @ W)
        D1[cols] = K
        D0[cols] = -K @ G
        D0[np.ix_(cols, cols)] = 0.0
    return D0, D1


def spectral_radius(M: Array) -> float:
    """Largest |eigenvalue| of a square matrix (0 for an empty one)."""
    return float(np.max(np.abs(np.linalg.eigvals(M)))) if M.size else 0.0


def nash_gain(D0: Array, D1: Array) -> Array:
    """T_N with U_Nash = T_N e: (I - D0)⁻¹ D1."""
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
    """Warm start from the previous plan: drop the first move, repeat (u) or zero (Δu) the last."""
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
    return 10.0**hi


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
        ρ(D0) for each weight, same shape as ``weights``.

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
    """

    exists: bool
    omega_max: float
    omega_best: float
    rate: float

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict."""
        def clean(x: float) -> float | None:
            return None if math.isnan(x) else x
        return {"exists": self.exists, "omega_max": clean(self.omega_max),
                "omega_best": clean(self.omega_best), "rate": clean(self.rate)}


def relaxation(D0: Array) -> RelaxationResult:
    """Best relaxation factor for the Jacobi iteration matrix D0.

    The relaxed iteration matrix (1-ω)I + ωD0 has eigenvalues 1 - ω(1 - λ);
    |1 - ω(1 - λ)| < 1 iff 0 < ω < 2(1 - Re λ)/|1 - λ|², which needs Re λ < 1.

    Parameters
    ----------
    D0 : ndarray
        Jacobi iteration matrix.

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
    lam = np.linalg.eigvals(D0) if D0.size else np.zeros(1)
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
