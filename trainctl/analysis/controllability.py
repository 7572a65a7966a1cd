# Controllability and observability: Kalman rank, PBH, finite-horizon Gramians.
"""Controllability and observability without slycot.

- Kalman rank of [B, AB, ..., A^{n-1}B] from singular values with a stated
  relative tolerance, and its condition number. Train models mix scales
  (B ~ 1/m ~ 1e-5, A ~ k/m ~ 250), so the raw Kalman matrix spans a dozen
  decades and its numerical rank means little. The rank is therefore taken
  after two rank-preserving scalings: a diagonal state balancing
  (``scipy.linalg.matrix_balance``) and normalising block k by ||A||^k and
  every input column to unit norm. The reported singular values and
  condition number are those of this scaled matrix.
- PBH test per distinct eigenvalue: rank [A - lambda I, B] < n marks an
  uncontrollable mode; its left eigenvector (w^T A = lambda w^T, w^T B = 0)
  is reported by state name.
- Finite-horizon (time-limited) Gramians, which exist for marginally stable
  and unstable systems alike (python-control's ``gram`` needs slycot and an
  asymptotically stable system): continuous W(T) = ∫_0^T e^{At} B B^T e^{A^T t} dt
  by Van Loan's block matrix exponential, discrete W_N = Σ_{k<N} A^k B B^T (A^T)^k
  by doubling (W_{2N} = W_N + A^N W_N (A^N)^T).

Observability is the dual problem (A^T, C^T).
"""

from __future__ import annotations

import math
from typing import TypedDict, TypeVar

import control as ct
import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from trainctl.analysis.rank_results import ControllabilityResult as ControllabilityResult
from trainctl.analysis.rank_results import ObservabilityResult as ObservabilityResult
from trainctl.analysis.rank_results import UncontrollableMode as UncontrollableMode
from trainctl.analysis.rank_results import UnobservableMode as UnobservableMode

__all__ = [
    "ControllabilityResult",
    "ObservabilityResult",
    "UncontrollableMode",
    "UnobservableMode",
    "analyse_controllability",
    "analyse_observability",
    "finite_horizon_gramian",
    "kalman_matrix",
]

_Mode = TypeVar("_Mode", bound=UncontrollableMode)


class _Numbers(TypedDict):
    """The fields of a rank test's result that :func:`_analyse` computes."""

    n_states: int
    rank: int
    tol: float
    singular_values: NDArray[np.float64]
    condition_number: float
    gramian_horizon: float
    gramian_eigenvalues: NDArray[np.float64]


def finite_horizon_gramian(
    A: NDArray[np.float64], B: NDArray[np.float64], horizon: float, *, discrete: bool
) -> NDArray[np.float64]:
    """Finite-horizon controllability Gramian (works for marginal systems).

    Parameters
    ----------
    A, B : ndarray
        State and input matrices.
    horizon : float
        T [s] for continuous systems; number of steps N (int >= 1) for discrete.
    discrete : bool
        True for x(k+1) = A x + B u.

    Returns
    -------
    ndarray
        The symmetric positive semidefinite Gramian.

    Examples
    --------
    >>> import numpy as np
    >>> W = finite_horizon_gramian(np.eye(1), np.ones((1, 1)), 5, discrete=True)
    >>> float(W[0, 0])
    5.0
    """
    A = np.asarray(A, dtype=float)
    Q = np.asarray(B, dtype=float) @ np.asarray(B, dtype=float).T
    if not discrete:
        n = A.shape[0]
        M = np.block([[-A, Q], [np.zeros((n, n)), A.T]]) * float(horizon)
        F: NDArray[np.float64] = scipy.linalg.expm(M)  # scipy is untyped here
        W = F[n:, n:].T @ F[:n, n:]
        return 0.5 * (W + W.T)
    steps = int(horizon)
    if steps != horizon or steps < 1:
        raise ValueError(
            f"finite_horizon_gramian: 'horizon' must be an int >= 1 steps (got {horizon!r})."
        )
    W = np.zeros_like(Q)
    power = np.eye(A.shape[0])  # A^(steps done so far)
    block, block_power = Q, A   # Gramian over 2^j steps and A^(2^j)
    while steps:
        if steps & 1:
            W = W + power @ block @ power.T
            power = power @ block_power
        steps >>= 1
        if steps:
            block = block + block_power @ block @ block_power.T
            block_power = block_power @ block_power
    return 0.5 * (W + W.T)


def kalman_matrix(A: NDArray[np.float64], B: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unscaled Kalman matrix [B, AB, ..., A^{n-1}B] (as ``control.ctrb``).

    Parameters
    ----------
    A, B : ndarray
        State and input matrices.

    Returns
    -------
    ndarray
        Shape (n, n·m).

    Examples
    --------
    >>> import numpy as np
    >>> kalman_matrix(np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]])).tolist()
    [[0.0, 1.0], [1.0, 0.0]]
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    blocks = [B]
    for _ in range(A.shape[0] - 1):
        blocks.append(A @ blocks[-1])
    return np.hstack(blocks)


def _scaled_kalman(A: NDArray[np.float64], B: NDArray[np.float64]) -> NDArray[np.float64]:
    _, (scale, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    Ab = A * scale[None, :] / scale[:, None]
    Bb = B / scale[:, None]
    norms = np.linalg.norm(Bb, axis=0)
    Bb = Bb / np.where(norms > 0, norms, 1.0)
    step = max(1.0, float(np.linalg.norm(Ab, 2)))
    blocks = [Bb]
    for _ in range(A.shape[0] - 1):
        blocks.append(Ab @ blocks[-1] / step)
    return np.hstack(blocks)


def analyse_controllability(
    sys: ct.StateSpace,
    *,
    tol: float = 1e-9,
    horizon: float | None = None,
) -> ControllabilityResult:
    """Kalman rank, PBH test and finite-horizon Gramian of (A, B).

    Parameters
    ----------
    sys : control.StateSpace
        Continuous or discrete system.
    tol : float
        Relative tolerance: singular values below tol times the largest count
        as zero (Kalman rank and PBH).
    horizon : float or None
        Gramian horizon: T [s] (continuous, default 10 s) or N steps
        (discrete, default the state dimension).

    Returns
    -------
    ControllabilityResult
        Rank, condition number, uncontrollable modes and Gramian spectrum.

    Examples
    --------
    >>> from trainctl.models import crh2_half, linearise
    >>> res = analyse_controllability(linearise(crh2_half(), 300 / 3.6, dummy_state=True))
    >>> res.rank, [m.direction for m in res.uncontrollable]
    (7, [{'delta[3]': 1.0}])
    """
    numbers, modes = _analyse(sys.A, sys.B, sys, tol, horizon, UncontrollableMode)
    return ControllabilityResult(**numbers, uncontrollable=modes)


def analyse_observability(
    sys: ct.StateSpace,
    *,
    tol: float = 1e-9,
    horizon: float | None = None,
) -> ObservabilityResult:
    """Observability: Kalman rank, PBH test and Gramian of (A, C).

    Computed as the controllability of the dual pair (A^T, C^T), with the
    same tolerances and scalings.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous or discrete system.
    tol : float
        Relative singular-value tolerance.
    horizon : float or None
        Gramian horizon, as for :func:`analyse_controllability`.

    Returns
    -------
    ObservabilityResult
        Rank, condition number, unobservable modes (their right
        eigenvectors) and the observability Gramian's spectrum.

    Examples
    --------
    >>> from trainctl.models import crh2_half, linearise
    >>> res = analyse_observability(linearise(crh2_half(), 300 / 3.6, dummy_state=True))
    >>> res.rank, [m.direction for m in res.unobservable]
    (7, [{'delta[3]': 1.0}])
    """
    numbers, modes = _analyse(sys.A.T, sys.C.T, sys, tol, horizon, UnobservableMode)
    return ObservabilityResult(**numbers, unobservable=modes)


def _analyse(
    A: NDArray[np.float64], B: NDArray[np.float64], sys: ct.StateSpace, tol: float,
    horizon: float | None, mode_type: type[_Mode],
) -> tuple[_Numbers, tuple[_Mode, ...]]:
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    n = A.shape[0]
    discrete = bool(sys.dt)
    sv = np.asarray(np.linalg.svd(_scaled_kalman(A, B), compute_uv=False), dtype=np.float64)
    rank = int(np.sum(sv > tol * sv[0])) if sv.size and sv[0] > 0 else 0
    cond = float(sv[0] / sv[n - 1]) if sv.size >= n and sv[n - 1] > 0 else math.inf
    if horizon is None:
        horizon = float(n) if discrete else 10.0
    W = finite_horizon_gramian(A, B, horizon, discrete=discrete)
    gramian_eigenvalues = np.asarray(np.linalg.eigvalsh(W), dtype=np.float64)
    numbers: _Numbers = {"n_states": n, "rank": rank, "tol": tol, "singular_values": sv,
               "condition_number": cond, "gramian_horizon": float(horizon),
               "gramian_eigenvalues": gramian_eigenvalues}
    return numbers, _pbh(A, B, list(sys.state_labels), tol, mode_type)


def _pbh(
    A: NDArray[np.float64], B: NDArray[np.float64], labels: list[str], tol: float,
    mode_type: type[_Mode],
) -> tuple[_Mode, ...]:
    n = A.shape[0]
    found: list[_Mode] = []
    seen: list[complex] = []
    screen = _RankScreen(A, B, tol)
    for value in np.linalg.eigvals(A):
        if any(abs(value - s) <= 1e-9 * max(1.0, abs(s)) for s in seen):
            continue
        seen.append(complex(value))
        if screen.clearly_full_rank(complex(value)):
            continue
        M = np.hstack([A - value * np.eye(n), B])
        # The singular values alone first (several times cheaper for long trains); the left
        # singular vectors only when a mode is found.
        sv = np.linalg.svd(M, compute_uv=False)
        if sv.size >= n and sv[n - 1] > tol * max(float(sv[0]), 1e-300):
            continue
        U, sv, _ = np.linalg.svd(M)
        full = np.concatenate([sv, np.zeros(n - sv.size)]) if sv.size < n else sv[:n]
        null = np.flatnonzero(full <= tol * max(float(sv[0]), 1e-300))
        for k in null:  # one entry per independent left null vector
            w = U[:, k]  # w^H [A - lambda I, B] = 0
            weights = np.abs(w) / np.linalg.norm(w)
            order = np.argsort(-weights)[:4]
            direction = {labels[i]: round(float(weights[i]), 6) for i in order
                         if weights[i] > 1e-3}
            found.append(mode_type(eigenvalue=complex(value),
                                            pbh_margin=float(full[k] / sv[0]),
                                            direction=direction))
    return tuple(found)


class _RankScreen:
    """A proof, by one Cholesky factorisation, that the PBH test passes at an eigenvalue.

    The PBH rank test compares σ_n([A - λI, B]) with tol·σ_1 for every distinct eigenvalue;
    an SVD per eigenvalue makes it O(n⁴) (28 s for the 407 states of the 204-vehicle
    chain). Most modes pass by orders of magnitude, which a Cholesky factorisation proves in
    O(n³/3). With the inputs scaled by c = ‖A‖_F/‖B‖_F (M' = [A - λI, cB], so that neither
    block drowns the other), G(λ) = M'M'^H = (AA^T + c²BB^T) - conj(λ)A - λA^T + |λ|²I (the
    first term formed once); G - τI positive definite means σ_n(M') ≥ √τ, so
    σ_n(M) ≥ √τ / max(1, c), while σ_1(M) ≤ ‖A‖_F + |λ| + ‖B‖_F =: b. The factorisation
    is tried with τ = max((1.01·max(1, c)·tol·b)², 1e-11·s), s = (‖A‖_F + |λ|)² + c²‖B‖_F²
    ≥ ‖G‖_2: the least τ that proves σ_n(M) > tol·σ_1(M), raised where needed to stand
    well clear (about 100 times n·eps for a few hundred states) of the rounding of forming
    and factorising G. Success proves the verdict the SVD would give; a failed
    factorisation proves nothing and the SVD decides, as before. On the 204-vehicle chain
    every eigenvalue is proved this way (controllability 27.8 s → 2.2 s).
    """

    def __init__(self, A: NDArray[np.float64], B: NDArray[np.float64], tol: float) -> None:
        self.tol = tol
        self.A = A
        self.norm_a = float(np.linalg.norm(A))
        self.norm_b = float(np.linalg.norm(B))
        self.c = self.norm_a / self.norm_b if self.norm_b > 0 and self.norm_a > 0 else 1.0
        self.base = A @ A.T + self.c**2 * (B @ B.T)

    def clearly_full_rank(self, value: complex) -> bool:
        if self.norm_b == 0.0:
            return False
        b = self.norm_a + abs(value) + self.norm_b
        size = (self.norm_a + abs(value)) ** 2 + (self.c * self.norm_b) ** 2
        tau = max((1.01 * max(1.0, self.c) * self.tol * b) ** 2, 1e-11 * size)
        G = self.base - np.conj(value) * self.A - value * self.A.T
        G[np.diag_indices_from(G)] += abs(value) ** 2 - tau
        try:
            scipy.linalg.cholesky(G, lower=True, overwrite_a=True, check_finite=False)
        except np.linalg.LinAlgError:
            return False
        return True
