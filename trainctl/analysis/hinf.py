# H∞ norms of linear systems: python-control (slycot ab13dd), a Hamiltonian level set, the BRL.
"""The H∞ norm of a stable LTI system, by three routes that check each other.

``‖G‖∞ = sup_ω σ̄(G(jω))`` (continuous) or ``sup_θ σ̄(G(e^{jθ}))``
(discrete) is the worst-case L2 (ℓ2) gain from the inputs to the outputs:
for a robust law, the largest amplification of a disturbance w into a
performance output s. Three ways to get it:

- :func:`control_hinf_norm`: python-control's ``linfnorm`` (slycot's
  ``ab13dd``), the reference;
- :func:`hamiltonian_hinf_norm`: this module's own level-set iteration
  (Bruinsma & Steinbuch, *Systems & Control Letters* 14, 1990; after Boyd,
  Balakrishnan & Kabamba, *Math. Control Signals Systems* 2, 1989). γ is a
  singular value of G(jω) exactly when jω is an eigenvalue of the
  Hamiltonian matrix H(γ) (formula in :func:`hamiltonian_matrix`), so with
  a lower bound γ_lb the level γ = (1 + 2ε)γ_lb either leaves H(γ) without
  imaginary eigenvalues (then ‖G‖∞ < γ: stop) or its imaginary eigenvalues
  jω₁ < … < jω_k bound the intervals where σ̄ > γ, and σ̄ at their midpoints
  is the next, larger lower bound (quadratic convergence). Discrete systems
  go through the Cayley transform z = (1 + s)/(1 − s), which maps the unit
  circle onto the imaginary axis (θ = 2 arctan ω) and leaves the norm
  unchanged: it turns the symplectic pencil of the discrete level set into
  the Hamiltonian matrix of a continuous system, so both time domains use
  the same exact test — chosen over a frequency sweep, which can step over
  the sharp coupler resonances of a train (damping ratios of 1–4 %); σ̄ is
  still evaluated on the discrete system itself, at z = e^{jθ};
- :func:`bounded_real_gamma`: the bounded-real lemma as an SDP in cvxpy,
  which certifies ‖G‖∞ ≤ γ with a matrix P ≻ 0 and is an exact
  characterisation (its infimum is the norm).

:func:`hinf_norm` returns the first two with their peak frequencies and
whether they agree to :data:`AGREEMENT`; :func:`channel_norms` the SISO norm
of every input → output channel, so that a report can show γ per
disturbance channel.

Stability. The H∞ norm is that of the state-space system: when A is not
Hurwitz (not Schur, discrete) the norm is infinite (``inf``, with the
spectral abscissa or radius in the result), even if the unstable mode is
uncontrollable or unobservable — reduce the system (``control.minreal``)
first when only the transfer function matters. (``linfnorm`` itself returns
the L∞ norm, finite for unstable systems without poles on the axis; this
module does not call it then.)

Scaling. Train models mix speeds [m/s], coupler elongations [m] and forces
[kN] (spec §5 item 7), so each route works on a state-balanced realisation
(a diagonal similarity from ``scipy.linalg.matrix_balance`` of the system
matrix [[A, B],[C, 0]] with the input and output blocks collapsed, which
leaves G unchanged), and the level set and the SDP on G divided by a crude
lower bound of its norm (so that γ ≈ 1). The SDP then goes on to the
square-root balanced realisation (equal, diagonal Gramians) where it
exists: a diagonal scaling alone leaves the SDP badly conditioned for a
non-normal A, and the solver fails or stops inaccurate. Outputs in
different units are never rescaled one against the other (that would
change the norm): :func:`channel_norms` reports each channel on its own.

Examples
--------
A first-order lag 2/(s + 4) has its peak 0.5 at DC:

>>> import control as ct
>>> res = hinf_norm(ct.tf([2.0], [1.0, 4.0]))
>>> round(res.norm, 9), round(res.hamiltonian, 9), res.agree
(0.5, 0.5, True)
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import control as ct
import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import DimensionError, ModelError, SolverError

if TYPE_CHECKING:
    import cvxpy as cp

__all__ = [
    "AGREEMENT", "BRL_MARGIN", "LEVEL_TOL", "BoundedRealProblem", "BoundedRealResult",
    "ChannelNorms", "HinfNorm", "bounded_real_gamma", "certified_level", "channel_norms",
    "control_hinf_norm", "gramian_transform", "hamiltonian_hinf_norm", "hamiltonian_matrix",
    "hinf_norm", "parameter_terms", "solve_quietly", "state_balance",
]

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]

AGREEMENT = 1e-4
"""Relative difference within which the two norm routes agree."""

LEVEL_TOL = 1e-9
"""ε of the level set: the norm is bracketed in [γ_lb, (1 + 2ε) γ_lb]."""

IMAGINARY_TOL = 1e-6
"""|Re λ| ≤ this × ‖H‖₁ counts an eigenvalue of H(γ) as imaginary.

Generous on purpose: a spurious imaginary eigenvalue costs one evaluation of
σ̄ (which cannot raise the lower bound above the norm), a missed one would
stop the iteration early."""

MAX_LEVELS = 100
"""Iterations of the level set before it reports non-convergence."""

BRL_MARGIN = 1e-8
"""ε of the strict bounded-real LMI (M ⪯ −εI on the balanced, normalised data)."""

_LINFNORM_TOL = 1e-10


# --------------------------------------------------------------------------------------------
# data and balancing


def _as_matrices(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike | None,
                 who: str) -> tuple[Array, Array, Array, Array]:
    """(A, B, C, D) as float arrays with consistent shapes (D None: zeros)."""
    Am = np.atleast_2d(np.asarray(A, dtype=float))
    Bm = np.atleast_2d(np.asarray(B, dtype=float))
    Cm = np.atleast_2d(np.asarray(C, dtype=float))
    n = Am.shape[0]
    if Am.ndim != 2 or Am.shape != (n, n):
        raise DimensionError(f"{who}: 'A' must be a square (n, n) matrix (got shape "
                             f"{Am.shape}).")
    if Bm.ndim != 2 or Bm.shape[0] != n:
        raise DimensionError(f"{who}: 'B' must have n = {n} rows, one per state (got shape "
                             f"{Bm.shape}).")
    if Cm.ndim != 2 or Cm.shape[1] != n:
        raise DimensionError(f"{who}: 'C' must have n = {n} columns, one per state (got "
                             f"shape {Cm.shape}).")
    m, p = Bm.shape[1], Cm.shape[0]
    Dm = np.zeros((p, m)) if D is None else np.atleast_2d(np.asarray(D, dtype=float))
    if Dm.shape != (p, m):
        raise DimensionError(f"{who}: 'D' must be (p, m) = ({p}, {m}) for {p} outputs and "
                             f"{m} inputs (got shape {Dm.shape}).")
    if m == 0 or p == 0:
        raise DimensionError(f"{who}: the system needs at least one input and one output "
                             f"(got {m} inputs, {p} outputs).")
    for name, M in (("A", Am), ("B", Bm), ("C", Cm), ("D", Dm)):
        if not np.all(np.isfinite(M)):
            raise ModelError(f"{who}: '{name}' must be finite (got NaN or inf).")
    return Am, Bm, Cm, Dm


def _system_data(sys: Any, who: str) -> tuple[Array, Array, Array, Array, float | None]:
    """(A, B, C, D, dt) of a ``control`` system; dt None for a continuous one."""
    if isinstance(sys, ct.TransferFunction):
        sys = ct.ss(sys)
    if not isinstance(sys, ct.StateSpace):
        raise ModelError(f"{who}: 'sys' must be a control.StateSpace or TransferFunction "
                         f"(got {type(sys).__name__}).")
    A, B, C, D = _as_matrices(sys.A, sys.B, sys.C, sys.D, who)
    if sys.isctime():
        return A, B, C, D, None
    dt = 1.0 if sys.dt is True else float(sys.dt)
    return A, B, C, D, dt


def state_balance(A: Array, B: Array, C: Array) -> Array:
    """Diagonal state scaling d that balances [[A, B],[C, 0]] (x = diag(d) x̃).

    ``scipy.linalg.matrix_balance`` (no permutation) on the square matrix
    [[A, b],[c, 0]] with b the row norms of B and c the column norms of C:
    one extra coordinate stands for all inputs and outputs, so the scaling
    acts on the states only and G = C(sI − A)⁻¹B is unchanged by
    Ã = D⁻¹AD, B̃ = D⁻¹B, C̃ = CD.

    Parameters
    ----------
    A, B, C : ndarray
        (n, n), (n, m), (p, n).

    Returns
    -------
    ndarray
        The scaling d, shape (n,), positive powers of 2.

    Examples
    --------
    >>> A = np.array([[-1.0, 1e6], [-1e-6, -1.0]])
    >>> d = state_balance(A, np.ones((2, 1)), np.ones((1, 2)))
    >>> At = A / d[:, None] * d[None, :]
    >>> bool(abs(At[0, 1]) < 1e3 and abs(At[1, 0]) > 1e-3)
    True
    """
    n = A.shape[0]
    if n == 0:
        return np.ones(0)
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = A
    M[:n, n] = np.linalg.norm(B, axis=1)
    M[n, :n] = np.linalg.norm(C, axis=0)
    _, (scale, _) = scipy.linalg.matrix_balance(M, permute=False, separate=True)
    s = np.asarray(scale, dtype=float)
    return s[:n] / s[n]


MAX_TRANSFORM_CONDITION = 1e8
"""Largest condition number of the Gramian-balancing transformation that is used."""


def gramian_transform(A: Array, B: Array, C: Array) -> tuple[Array, Array] | None:
    """(T, T⁻¹) of the square-root balanced realisation x = T x_b, or None.

    Controllability and observability Gramians from the Lyapunov equations
    (scipy), W_c = L_c L_cᵀ, W_o = L_o L_oᵀ, L_oᵀL_c = UΣVᵀ, T = L_c V Σ^{−1/2}:
    both Gramians become Σ (the Hankel singular values). In these
    coordinates the bounded-real P lies between Σ and γ²Σ⁻¹, which keeps the
    SDP well conditioned when a diagonal scaling does not (non-normal A,
    large ‖G‖∞). None when A is not Hurwitz, a Gramian is not positive
    definite (non-minimal realisation) or T is worse conditioned than
    :data:`MAX_TRANSFORM_CONDITION`.

    Parameters
    ----------
    A, B, C : ndarray
        Continuous realisation.

    Returns
    -------
    (ndarray, ndarray) or None
        T and T⁻¹, (n, n).

    Examples
    --------
    >>> A = np.array([[-1.0, 100.0], [0.0, -2.0]])
    >>> B, C = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])
    >>> T, Ti = gramian_transform(A, B, C)
    >>> Ab, Bb, Cb = Ti @ A @ T, Ti @ B, C @ T
    >>> import scipy.linalg
    >>> Wc = scipy.linalg.solve_continuous_lyapunov(Ab, -Bb @ Bb.T)
    >>> Wo = scipy.linalg.solve_continuous_lyapunov(Ab.T, -Cb.T @ Cb)
    >>> bool(np.allclose(Wc, Wo) and np.allclose(Wc, np.diag(np.diag(Wc))))
    True
    """
    n = A.shape[0]
    if n == 0 or np.max(np.linalg.eigvals(A).real) >= 0.0:
        return None
    try:
        Wc = scipy.linalg.solve_continuous_lyapunov(A, -B @ B.T)
        Wo = scipy.linalg.solve_continuous_lyapunov(A.T, -C.T @ C)
        Lc = np.linalg.cholesky(0.5 * (Wc + Wc.T))
        Lo = np.linalg.cholesky(0.5 * (Wo + Wo.T))
        U, s, Vt = np.linalg.svd(Lo.T @ Lc)
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not np.all(np.isfinite(s)) or s.min() <= 0.0:
        return None
    T = Lc @ Vt.T / np.sqrt(s)[None, :]
    Ti = (U / np.sqrt(s)[None, :]).T @ Lo.T
    if not (np.all(np.isfinite(T)) and np.linalg.cond(T) < MAX_TRANSFORM_CONDITION):
        return None
    return np.asarray(T, dtype=float), np.asarray(Ti, dtype=float)


def _balanced(A: Array, B: Array, C: Array) -> tuple[Array, Array, Array, Array]:
    d = state_balance(A, B, C)
    return A / d[:, None] * d[None, :], B / d[:, None], C * d[None, :], d


# --------------------------------------------------------------------------------------------
# frequency response and the level set


def _sigma_max(A: Array, B: Array, C: Array, D: Array, s: complex) -> float:
    """σ̄(C(sI − A)⁻¹B + D) [output units per input unit]."""
    n = A.shape[0]
    if n == 0:
        G = D.astype(complex)
    else:
        G = C @ np.linalg.solve(s * np.eye(n) - A, B.astype(complex)) + D
    return float(np.linalg.norm(G, 2))


def hamiltonian_matrix(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike | None,
                       gamma: float) -> Array:
    """H(γ), whose imaginary eigenvalues jω are the frequencies where γ is a singular value.

    With R = γ²I − DᵀD (requires γ > σ̄(D)) and F = A + BR⁻¹DᵀC,

        H(γ) = [[F, γ B R⁻¹ Bᵀ], [−(CᵀC + CᵀD R⁻¹ DᵀC)/γ, −Fᵀ]],

    derived from G(jω)u = γy, G(jω)ᴴy = γu with x = (jωI − A)⁻¹Bu and
    z = (−jωI − Aᵀ)⁻¹Cᵀy: (x, z) then satisfies jω(x, z) = H(γ)(x, z).

    Parameters
    ----------
    A, B, C, D : array_like
        Continuous realisation, (n, n), (n, m), (p, n), (p, m) (D None: 0).
    gamma : float
        Level γ > σ̄(D).

    Returns
    -------
    ndarray
        (2n, 2n), Hamiltonian (JH symmetric, J = [[0, I], [−I, 0]]).

    Examples
    --------
    1/(s + 1) has gain 1/√(1 + ω²): the level 0.5 is crossed at ω = √3.

    >>> H = hamiltonian_matrix([[-1.0]], [[1.0]], [[1.0]], None, 0.5)
    >>> np.round(np.sort(np.linalg.eigvals(H).imag), 6).tolist()
    [-1.732051, 1.732051]
    """
    Am, Bm, Cm, Dm = _as_matrices(A, B, C, D, "hamiltonian_matrix")
    sd = float(np.linalg.norm(Dm, 2))
    if not (math.isfinite(gamma) and gamma > sd):
        raise ModelError(f"hamiltonian_matrix: 'gamma' must exceed σ̄(D) = {sd:.6g} (got "
                         f"{gamma!r}).")
    R = gamma ** 2 * np.eye(Bm.shape[1]) - Dm.T @ Dm
    RiDtC = np.linalg.solve(R, Dm.T @ Cm)
    RiBt = np.linalg.solve(R, Bm.T)
    F = Am + Bm @ RiDtC
    top = np.hstack([F, gamma * Bm @ RiBt])
    bottom = np.hstack([-(Cm.T @ Cm + Cm.T @ Dm @ RiDtC) / gamma, -F.T])
    return np.asarray(np.vstack([top, bottom]), dtype=float)


def _level_set(A: Array, B: Array, C: Array, D: Array,
               sigma: Callable[[float], float], start: Sequence[float],
               ) -> tuple[float, float, int, bool]:
    """Bruinsma–Steinbuch on a continuous (A, B, C, D); σ̄ evaluated by ``sigma(ω)``.

    Returns (γ_lb, ω at γ_lb, iterations, converged). ``sigma(inf)`` must be σ̄(D).
    """
    best, w_best = -1.0, 0.0
    for w in start:
        g = sigma(w)
        if g > best:
            best, w_best = g, w
    if best <= 0.0:
        return 0.0, 0.0, 0, True
    for it in range(1, MAX_LEVELS + 1):
        gamma = (1.0 + 2.0 * LEVEL_TOL) * best
        H = hamiltonian_matrix(A, B, C, D, gamma)
        lam = np.linalg.eigvals(H)
        tol = IMAGINARY_TOL * max(float(np.linalg.norm(H, 1)), 1e-300)
        omegas = np.unique(np.round(np.abs(lam[np.abs(lam.real) <= tol].imag), 14))
        if omegas.size == 0:
            return best, w_best, it, True
        if omegas.size % 2:
            omegas = np.concatenate([[0.0], omegas])
        candidates = np.concatenate([0.5 * (omegas[:-1] + omegas[1:]), omegas])
        values = np.array([sigma(float(w)) for w in candidates])
        k = int(np.argmax(values))
        if values[k] <= gamma:
            # no interval above the level: the imaginary eigenvalues were spurious
            if values[k] > best:
                best, w_best = float(values[k]), float(candidates[k])
            return best, w_best, it, True
        best, w_best = float(values[k]), float(candidates[k])
    return best, w_best, MAX_LEVELS, False


def _polish(sigma: Callable[[float], float], w: float, g: float) -> tuple[float, float]:
    """Bounded scalar search of σ̄ near ω (sharpens the peak frequency; never lowers g)."""
    if not math.isfinite(w) or w <= 0.0:
        return g, w
    lo, hi = w * (1.0 - 1e-3), w * (1.0 + 1e-3)
    res = scipy.optimize.minimize_scalar(lambda x: -sigma(float(x)), bounds=(lo, hi),
                                         method="bounded", options={"xatol": 1e-12 * w})
    if -float(res.fun) > g:
        return -float(res.fun), float(res.x)
    return g, w


def _start_frequencies(lam: CArray) -> list[float]:
    """0, ∞ and the pole frequencies |λ| and |Im λ| (initial lower bounds)."""
    ws = [0.0, math.inf]
    for z in lam:
        ws.append(float(abs(z)))
        if abs(z.imag) > 0:
            ws.append(float(abs(z.imag)))
    return ws


def _cayley(A: Array, B: Array, C: Array, D: Array) -> tuple[Array, Array, Array, Array]:
    """Continuous (A_c, B_c, C_c, D_c) with G_c(s) = G_d((1 + s)/(1 − s))."""
    n = A.shape[0]
    lu = scipy.linalg.lu_factor(A + np.eye(n))
    X = scipy.linalg.lu_solve(lu, np.hstack([A - np.eye(n), B]))
    Ac, Bc = X[:, :n], math.sqrt(2.0) * X[:, n:]
    CiA = scipy.linalg.lu_solve(lu, C.T, trans=1).T  # C (A + I)⁻¹
    return Ac, Bc, math.sqrt(2.0) * CiA, D - CiA @ B


@dataclass(frozen=True, kw_only=True)
class _Own:
    gamma: float
    frequency: float
    iterations: int
    converged: bool
    stable: bool
    abscissa: float


def _own_norm(A: Array, B: Array, C: Array, D: Array, dt: float | None) -> _Own:
    n = A.shape[0]
    lam: CArray = np.asarray(np.linalg.eigvals(A) if n else np.zeros(0), dtype=complex)
    # A mode on the boundary (a consensus mode at λ = 0, say) is computed at ±eps·‖A‖ from it;
    # such a mode is marginal, not stable, whichever side rounding put it on.
    marginal = 100.0 * max(n, 1) * np.finfo(float).eps * max(1.0, float(np.linalg.norm(A, 1)))
    if dt is None:
        abscissa = float(np.max(lam.real)) if n else -math.inf
        stable = abscissa < -marginal
    else:
        abscissa = float(np.max(np.abs(lam))) if n else 0.0
        stable = abscissa < 1.0 - marginal
    if not stable:
        return _Own(gamma=math.inf, frequency=math.nan, iterations=0, converged=True,
                    stable=False, abscissa=abscissa)
    if n == 0:
        return _Own(gamma=float(np.linalg.norm(D, 2)), frequency=0.0, iterations=0,
                    converged=True, stable=True, abscissa=abscissa)
    if dt is None:
        Ab, Bb, Cb, _ = _balanced(A, B, C)
        Db = D
        starts = _start_frequencies(lam)

        def sigma_raw(w: float) -> float:
            if math.isinf(w):
                return float(np.linalg.norm(Db, 2))
            return _sigma_max(Ab, Bb, Cb, Db, 1j * w)
    else:
        Ab0, Bb0, Cb0, _ = _balanced(A, B, C)
        Ac, Bc, Cc, Dc = _cayley(Ab0, Bb0, Cb0, D)
        Ab, Bb, Cb, _ = _balanced(Ac, Bc, Cc)
        Db = Dc
        # pole angles θ map to ω_c = tan(θ/2); 0 and π are in _start_frequencies (0, ∞)
        starts = [0.0, math.inf] + [math.tan(0.5 * float(abs(np.angle(z)))) for z in lam
                                    if 0.0 < abs(np.angle(z)) < math.pi - 1e-12]

        def sigma_raw(w: float) -> float:
            if math.isinf(w):
                return _sigma_max(Ab0, Bb0, Cb0, D, -1.0 + 0j)
            return _sigma_max(Ab0, Bb0, Cb0, D, complex(np.exp(2j * math.atan(w))))
    # normalise G by a crude lower bound so that the level set works near γ = 1
    scale = max(sigma_raw(w) for w in starts)
    if scale <= 0.0:
        grid = np.logspace(-6, 6, 121)
        scale = max(sigma_raw(float(w)) for w in grid)
        starts = list(grid)
    if scale <= 0.0:
        return _Own(gamma=0.0, frequency=0.0, iterations=0, converged=True, stable=True,
                    abscissa=abscissa)

    def sigma(w: float) -> float:
        return sigma_raw(w) / scale

    g, w, iterations, converged = _level_set(Ab, Bb, Cb / scale, Db / scale, sigma, starts)
    g, w = _polish(sigma, w, g)
    frequency = w if dt is None else (math.pi if math.isinf(w) else 2.0 * math.atan(w)) / dt
    return _Own(gamma=g * scale, frequency=frequency, iterations=iterations,
                converged=converged, stable=True, abscissa=abscissa)


def hamiltonian_hinf_norm(sys: ct.StateSpace | ct.TransferFunction) -> tuple[float, float]:
    """‖G‖∞ and its peak frequency by the Hamiltonian level set (module docstring).

    Parameters
    ----------
    sys : control.StateSpace or control.TransferFunction
        Continuous or discrete system.

    Returns
    -------
    (float, float)
        The norm [output unit per input unit] (inf when A is not Hurwitz /
        not Schur) and the peak frequency [rad/s] (NaN when unstable;
        discrete: θ/dt with θ ∈ [0, π] rad per sample; a peak at DC gives
        0, at high frequency inf continuous and π/dt discrete).

    Raises
    ------
    SolverError
        The level set did not converge in :data:`MAX_LEVELS` iterations.

    Examples
    --------
    >>> import control as ct
    >>> g, w = hamiltonian_hinf_norm(ct.tf([1.0], [1.0, 0.2, 1.0]))  # ζ = 0.1
    >>> round(g, 6), round(w, 6)  # 1/(2ζ√(1 − ζ²)) at √(1 − 2ζ²)
    (5.025189, 0.989949)
    """
    A, B, C, D, dt = _system_data(sys, "hamiltonian_hinf_norm")
    own = _own_norm(A, B, C, D, dt)
    if not own.converged:
        raise SolverError(f"hamiltonian_hinf_norm: the level set did not converge in "
                          f"{MAX_LEVELS} iterations (last lower bound {own.gamma:.10g}).")
    return own.gamma, own.frequency


def control_hinf_norm(sys: ct.StateSpace | ct.TransferFunction) -> tuple[float, float]:
    """‖G‖∞ and its peak frequency from python-control's ``linfnorm`` (slycot ``ab13dd``).

    ``ab13dd`` balances the system itself (``equil='S'``) and returns the L∞
    norm; this function returns inf for a system whose A is not Hurwitz (not
    Schur), as the H∞ norm of such a system is infinite.

    Parameters
    ----------
    sys : control.StateSpace or control.TransferFunction
        Continuous or discrete system.

    Returns
    -------
    (float, float)
        The norm and the peak frequency [rad/s] (discrete: θ/dt; NaN when
        unstable).

    Examples
    --------
    >>> import control as ct
    >>> g, w = control_hinf_norm(ct.tf([2.0], [1.0, 4.0]))
    >>> round(g, 9), w
    (0.5, 0.0)
    """
    A, B, C, D, dt = _system_data(sys, "control_hinf_norm")
    n = A.shape[0]
    if n:
        lam = np.linalg.eigvals(A)
        if (dt is None and np.max(lam.real) >= 0.0) or (dt is not None
                                                        and np.max(np.abs(lam)) >= 1.0):
            return math.inf, math.nan
    system = ct.ss(A, B, C, D) if dt is None else ct.ss(A, B, C, D, dt)
    g, w = ct.linfnorm(system, tol=_LINFNORM_TOL)
    return float(g), float(w)


@dataclass(frozen=True, kw_only=True)
class HinfNorm:
    """The H∞ norm of one system by two routes.

    Parameters
    ----------
    norm : float
        ‖G‖∞ [output unit per input unit], python-control's value (the
        level set's when python-control raised; inf: not stable).
    frequency : float
        Its peak frequency [rad/s].
    control : float
        python-control / slycot ``ab13dd`` (:func:`control_hinf_norm`);
        NaN when it raised (``error``).
    control_frequency : float
        Its peak frequency [rad/s].
    hamiltonian : float
        The level set (:func:`hamiltonian_hinf_norm`).
    hamiltonian_frequency : float
        Its peak frequency [rad/s]. Equal peaks at several frequencies (a
        symmetric train) can make the two frequencies differ while the
        norms agree.
    stable : bool
        A Hurwitz (continuous) or Schur (discrete).
    abscissa : float
        Spectral abscissa max Re λ [1/s] (continuous) or spectral radius
        max |λ| [-] (discrete).
    dt : float or None
        Sample time [s]; None for a continuous system.
    iterations : int
        Level-set iterations.
    error : str
        The exception python-control raised, if any ("" otherwise).

    Examples
    --------
    A resonance 1/(s² + 2ζs + 1) with ζ = 0.1 peaks at ω = √(1 − 2ζ²) =
    0.99 rad/s with 1/(2ζ√(1 − ζ²)) = 5.0252:

    >>> import control as ct
    >>> res = hinf_norm(ct.tf([1.0], [1.0, 0.2, 1.0]))
    >>> round(res.norm, 4), round(res.frequency, 3), res.agree, res.stable
    (5.0252, 0.99, True, True)
    >>> round(res.abscissa, 4)  # poles at -0.1 ± 0.995j [1/s]
    -0.1
    """

    norm: float
    frequency: float
    control: float
    control_frequency: float
    hamiltonian: float
    hamiltonian_frequency: float
    stable: bool
    abscissa: float
    dt: float | None
    iterations: int
    error: str = ""

    @property
    def agree(self) -> bool:
        """Both routes within :data:`AGREEMENT` relative (both inf for an unstable system)."""
        a, b = self.control, self.hamiltonian
        if math.isnan(a) or math.isnan(b):
            return False
        if math.isinf(a) or math.isinf(b):
            return math.isinf(a) and math.isinf(b)
        return abs(a - b) <= AGREEMENT * max(abs(a), abs(b), 1e-300)

    @property
    def message(self) -> str:
        """One line for a report."""
        if not self.stable:
            what = "max Re λ" if self.dt is None else "spectral radius"
            return (f"not stable ({what} = {self.abscissa:.4g}): the H∞ norm is infinite")
        text = (f"‖G‖∞ = {self.norm:.6g} at {self.frequency:.4g} rad/s (python-control); "
                f"level set {self.hamiltonian:.6g} at {self.hamiltonian_frequency:.4g} rad/s")
        if self.error:
            text += f"; python-control failed: {self.error}"
        return text + ("" if self.agree else f" — routes DISAGREE beyond {AGREEMENT:g}")

    def to_dict(self) -> dict[str, object]:
        """JSON-safe (inf and NaN as None).

        Returns
        -------
        dict
            ``norm``, ``control`` and ``hamiltonian`` [output unit per
            input unit] with their frequencies [rad/s], ``stable``,
            ``abscissa``, ``dt`` [s], ``iterations``, ``agree``, ``error``
            and the one-line ``message``.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        return {"norm": f(self.norm), "frequency": f(self.frequency),
                "control": f(self.control), "control_frequency": f(self.control_frequency),
                "hamiltonian": f(self.hamiltonian),
                "hamiltonian_frequency": f(self.hamiltonian_frequency),
                "stable": self.stable, "abscissa": f(self.abscissa), "dt": self.dt,
                "iterations": self.iterations, "agree": self.agree, "error": self.error,
                "message": self.message}


def hinf_norm(sys: ct.StateSpace | ct.TransferFunction) -> HinfNorm:
    """‖G‖∞ by python-control (slycot) and by the Hamiltonian level set, and their agreement.

    Parameters
    ----------
    sys : control.StateSpace or control.TransferFunction
        Continuous or discrete system, any D.

    Returns
    -------
    HinfNorm
        Both values and peak frequencies [rad/s], stability, ``agree``
        (relative :data:`AGREEMENT`).

    Examples
    --------
    An unstable system has an infinite norm, by both routes:

    >>> import control as ct
    >>> res = hinf_norm(ct.tf([1.0], [1.0, -1.0]))
    >>> res.norm, res.stable, res.agree
    (inf, False, True)
    """
    A, B, C, D, dt = _system_data(sys, "hinf_norm")
    own = _own_norm(A, B, C, D, dt)
    error = ""
    if not own.stable:
        ref, w_ref = math.inf, math.nan
    else:
        system = ct.ss(A, B, C, D) if dt is None else ct.ss(A, B, C, D, dt)
        try:
            ref, w_ref = control_hinf_norm(system)
        except Exception as exc:  # slycot raises its own arithmetic/value errors
            ref, w_ref, error = math.nan, math.nan, f"{type(exc).__name__}: {exc}"
    if not own.converged:
        error = (error + "; " if error else "") + (
            f"level set not converged in {MAX_LEVELS} iterations")
    return HinfNorm(norm=ref if not math.isnan(ref) else own.gamma,
                    frequency=w_ref if not math.isnan(ref) else own.frequency,
                    control=ref, control_frequency=w_ref, hamiltonian=own.gamma,
                    hamiltonian_frequency=own.frequency, stable=own.stable,
                    abscissa=own.abscissa, dt=dt, iterations=own.iterations, error=error)


@dataclass(frozen=True, kw_only=True)
class ChannelNorms:
    """SISO H∞ norms of every channel, laid out like the transfer matrix.

    Parameters
    ----------
    gamma : ndarray
        (p, m): ``gamma[i, j]`` = ‖G_ij‖∞, input j → output i [output unit
        per input unit], python-control's value.
    gamma_hamiltonian : ndarray
        (p, m), the level set's.
    frequency : ndarray
        (p, m) peak frequencies [rad/s] (python-control's).
    per_input : ndarray
        (m,): ‖G e_j‖∞, input j → the whole output vector (python-control).
    per_input_hamiltonian : ndarray
        (m,), the level set's.
    inputs, outputs : tuple of str
        Channel labels.

    Examples
    --------
    y = 1/(s + 1)·a + 1/(s + 2)·b: the channels' DC gains 1 and 1/2 are their norms.

    >>> import control as ct
    >>> sys = ct.ss([[-1.0, 0.0], [0.0, -2.0]], np.eye(2), [[1.0, 1.0]], np.zeros((1, 2)),
    ...             inputs=["a", "b"], outputs=["y"])
    >>> res = channel_norms(sys)
    >>> res.gamma.round(4).tolist(), res.inputs, res.agree
    ([[1.0, 0.5]], ('a', 'b'), True)
    """

    gamma: Array
    gamma_hamiltonian: Array
    frequency: Array
    per_input: Array
    per_input_hamiltonian: Array
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]

    @property
    def agree(self) -> bool:
        """Every channel's two routes within :data:`AGREEMENT` (inf with inf)."""
        pairs = [(self.gamma, self.gamma_hamiltonian),
                 (self.per_input, self.per_input_hamiltonian)]
        for a, b in pairs:
            both_inf = np.isinf(a) & np.isinf(b)
            with np.errstate(invalid="ignore"):
                close = np.abs(a - b) <= AGREEMENT * np.maximum(np.maximum(abs(a), abs(b)),
                                                                1e-300)
            if not np.all(both_inf | close):
                return False
        return True

    def to_dict(self) -> dict[str, object]:
        """JSON-safe (inf as None).

        Returns
        -------
        dict
            ``inputs`` and ``outputs`` (labels), ``gamma`` and
            ``gamma_hamiltonian`` (nested lists, one row per output)
            [output unit per input unit], ``frequency`` (nested lists)
            [rad/s], ``per_input`` and ``per_input_hamiltonian`` (one value
            per input), and ``agree``.
        """
        def f(M: Array) -> list[Any]:
            return [None if not math.isfinite(x) else float(x) for x in np.ravel(M)] \
                if M.ndim == 1 else [f(row) for row in M]
        return {"inputs": list(self.inputs), "outputs": list(self.outputs),
                "gamma": f(self.gamma), "gamma_hamiltonian": f(self.gamma_hamiltonian),
                "frequency": f(self.frequency), "per_input": f(self.per_input),
                "per_input_hamiltonian": f(self.per_input_hamiltonian), "agree": self.agree}


def channel_norms(sys: ct.StateSpace) -> ChannelNorms:
    """The H∞ norm of each input → output channel and of each input → all outputs.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous or discrete; inputs are the disturbance channels,
        outputs the performance outputs.

    Returns
    -------
    ChannelNorms
        ``gamma[i, j]`` for input j → output i (the transfer matrix's
        layout), both routes, and ``per_input[j]`` (input j → every output).

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[-1.0, 0.0], [0.0, -2.0]], [[1.0, 0.0], [0.0, 1.0]], np.eye(2), 0)
    >>> res = channel_norms(G)
    >>> np.round(res.gamma, 6).tolist(), res.agree
    ([[1.0, 0.0], [0.0, 0.5]], True)
    """
    A, B, C, D, dt = _system_data(sys, "channel_norms")
    p, m = D.shape
    gamma = np.zeros((p, m))
    own = np.zeros((p, m))
    freq = np.zeros((p, m))
    per_input = np.zeros(m)
    per_own = np.zeros(m)

    def one(b: Array, c: Array, d: Array) -> tuple[float, float, float]:
        res = hinf_norm(ct.ss(A, b, c, d) if dt is None else ct.ss(A, b, c, d, dt))
        return res.control, res.frequency, res.hamiltonian

    for j in range(m):
        b = B[:, j:j + 1]
        per_input[j], _, per_own[j] = one(b, C, D[:, j:j + 1])
        for i in range(p):
            gamma[i, j], freq[i, j], own[i, j] = one(b, C[i:i + 1], D[i:i + 1, j:j + 1])
    inputs = tuple(getattr(sys, "input_labels", None) or [f"u[{j}]" for j in range(m)])
    outputs = tuple(getattr(sys, "output_labels", None) or [f"y[{i}]" for i in range(p)])
    return ChannelNorms(gamma=gamma, gamma_hamiltonian=own, frequency=freq,
                        per_input=per_input, per_input_hamiltonian=per_own, inputs=inputs,
                        outputs=outputs)


# --------------------------------------------------------------------------------------------
# bounded-real lemma


def certified_level(M0: Array, level: Sequence[int]) -> float:
    """Smallest t with M0 − t·E ≺ 0, E the identity on the indices ``level`` (else inf).

    An LMI that is linear in t = γ² with −tI on the diagonal block ``level``
    (and nothing else in that block) holds for t exactly when the rest R of
    M0 is negative definite and t > λ_max(−M_LR R⁻¹ M_RL) (Schur complement
    on R). This turns a solver's P into a certified γ in floating point.

    Parameters
    ----------
    M0 : ndarray
        Symmetric (k, k), the LMI at t = 0.
    level : sequence of int
        The indices of the −tI block.

    Returns
    -------
    float
        The level t (≥ 0), or inf when the rest of M0 is not negative definite.

    Examples
    --------
    [[−1, 1], [1, −t]] ≺ 0 for t > 1:

    >>> certified_level(np.array([[-1.0, 1.0], [1.0, 0.0]]), [1])
    1.0
    """
    M = 0.5 * (np.asarray(M0, dtype=float) + np.asarray(M0, dtype=float).T)
    k = M.shape[0]
    lv = np.asarray(list(level), dtype=int)
    rest = np.setdiff1d(np.arange(k), lv)
    Rm = M[np.ix_(rest, rest)]
    eig_r = np.linalg.eigvalsh(Rm) if rest.size else np.zeros(0)
    if rest.size and eig_r.max() >= -1e-14 * max(1.0, float(np.abs(eig_r).max())):
        return math.inf
    L = M[np.ix_(lv, lv)] - (M[np.ix_(lv, rest)] @ np.linalg.solve(Rm, M[np.ix_(rest, lv)])
                             if rest.size else 0.0)
    return max(float(np.max(np.linalg.eigvalsh(0.5 * (L + L.T)))), 0.0)


@dataclass(frozen=True, kw_only=True)
class BoundedRealResult:
    """A bounded-real certificate ‖G‖∞ ≤ γ.

    Parameters
    ----------
    gamma : float
        Certified γ [output unit per input unit]: recomputed in floating
        point from the solver's P (:func:`certified_level`), not the
        solver's objective; inf when nothing is certified.
    gamma_solver : float
        √t of the solver's objective (NaN without a solution).
    P : ndarray or None
        The certificate on the original state (V = xᵀPx for the original
        G; the LMI holds for it with γ), None when none.
    status : str
        cvxpy's status (``"optimal"``, ``"infeasible"``, ``"optimal_inaccurate"``,
        ``"solver_error: …"``).
    solver : str
        The solver used.
    solve_time : float
        Wall time of the solve [s].
    parameters : dict
        The parameter values of this solve.
    message : str
        What happened, for a report.

    Examples
    --------
    >>> res = bounded_real_gamma([[-2.0]], [[1.0]], [[1.0]])  # 1/(s + 2): ‖G‖∞ = 1/2
    >>> res.certified, round(res.gamma, 5), res.P.shape
    (True, 0.5, (1, 1))
    >>> bad = bounded_real_gamma([[1.0]], [[1.0]], [[1.0]])  # unstable: no certificate
    >>> bad.certified, bad.status, bad.P is None, bad.to_dict()["gamma"]
    (False, 'infeasible', True, None)
    """

    gamma: float
    gamma_solver: float
    P: Array | None
    status: str
    solver: str
    solve_time: float
    parameters: dict[str, float] = field(default_factory=dict)
    message: str = ""

    @property
    def certified(self) -> bool:
        """A finite γ is certified."""
        return math.isfinite(self.gamma)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe, without P.

        Returns
        -------
        dict
            ``gamma`` and ``gamma_solver`` [output unit per input unit]
            (None when not finite), ``status``, ``solver``, ``solve_time``
            [s], ``parameters`` (a copy), ``certified`` and ``message``.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        return {"gamma": f(self.gamma), "gamma_solver": f(self.gamma_solver),
                "status": self.status, "solver": self.solver, "solve_time": self.solve_time,
                "parameters": dict(self.parameters), "certified": self.certified,
                "message": self.message}


def solve_quietly(problem: cp.Problem, solver: str, **options: Any) -> str:
    """Solve a cvxpy problem and return its status; solver trouble becomes the status.

    cvxpy's "solution may be inaccurate" warning is swallowed because the
    status (``optimal_inaccurate``) says the same and every caller records
    it; a ``cvxpy.error.SolverError`` becomes ``"solver_error: …"``.

    Parameters
    ----------
    problem : cvxpy.Problem
        The problem.
    solver : str
        Solver name.
    **options
        Passed to ``problem.solve``.

    Returns
    -------
    str
        The status.

    Examples
    --------
    >>> import cvxpy as cp
    >>> x = cp.Variable()
    >>> solve_quietly(cp.Problem(cp.Minimize(x), [x >= 2]), "CLARABEL"), round(float(x.value), 6)
    ('optimal', 2.0)
    >>> solve_quietly(cp.Problem(cp.Minimize(x), [x >= 2, x <= 1]), "CLARABEL")
    'infeasible'
    """
    import warnings

    import cvxpy as cp

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Solution may be inaccurate")
        try:
            problem.solve(solver=solver, **options)
        except cp.error.SolverError as exc:
            return f"solver_error: {str(exc).split('.')[0]}"
    return str(problem.status)


def _solver_name(solver: str | None) -> str:
    import cvxpy as cp

    if solver is None:
        return str(cp.CLARABEL) if cp.CLARABEL in cp.installed_solvers() else str(cp.SCS)
    if solver not in cp.installed_solvers():
        raise ModelError(f"'solver' must be an installed cvxpy solver, one of "
                         f"{sorted(cp.installed_solvers())} (got {solver!r}).")
    return solver


def parameter_terms(who: str, label: str, terms: Mapping[str, ArrayLike] | None,
                    shape: tuple[int, int]) -> dict[str, Array]:
    """The matrices multiplying each named parameter, checked: finite and of ``shape``.

    Parameters
    ----------
    who : str
        The caller, for the message.
    label : str
        The argument's name (``"A_terms"``, ...).
    terms : mapping of str to array_like or None
        Parameter name → matrix; None: none.
    shape : (int, int)
        The shape every matrix must have.

    Returns
    -------
    dict of str to ndarray
        The matrices as float arrays, in the given order.

    Raises
    ------
    DimensionError
        When a matrix has another shape or a non-finite entry.

    Examples
    --------
    >>> parameter_terms("demo", "A_terms", {"k": [[-1.0]]}, (1, 1))
    {'k': array([[-1.]])}
    >>> try:
    ...     parameter_terms("demo", "A_terms", {"k": np.eye(2)}, (1, 1))
    ... except DimensionError as err:
    ...     print(err)
    demo: A_terms['k'] must be a finite (1, 1) matrix (got shape (2, 2)).
    """
    out: dict[str, Array] = {}
    for name, M in (terms or {}).items():
        Mk = np.atleast_2d(np.asarray(M, dtype=float))
        if Mk.shape != shape or not np.all(np.isfinite(Mk)):
            raise DimensionError(f"{who}: {label}[{name!r}] must be a finite "
                                 f"({shape[0]}, {shape[1]}) matrix (got shape {Mk.shape}).")
        out[name] = Mk
    return out


class BoundedRealProblem:
    """The bounded-real SDP of an affinely parametrised system, built once, re-solved.

    A(θ) = A₀ + Σ_k θ_k A_k and B(θ) = B₀ + Σ_k θ_k B_k (C, D fixed); the
    SDP in P = Pᵀ and t = γ² is

        minimise t  s.t.  P ⪰ 0,
        [[A(θ)ᵀP + PA(θ), PB(θ), Cᵀ], [B(θ)ᵀP, −tI, Dᵀ], [C, D, −I]] ⪯ −εI,

    whose (1,1) block makes AᵀP + PA ≺ −CᵀC, hence P ≻ 0 and A Hurwitz; by
    the bounded-real lemma (Schur complement of −I) V = xᵀPx then satisfies
    V̇ + |s|² − γ²|w|² ≤ 0, i.e. ‖G‖∞ ≤ γ. Each θ_k is a ``cp.Parameter``
    multiplying the variable P (DPP: parameter-affine × parameter-free), so
    cvxpy compiles the problem once and a re-solve only swaps the data.

    The data are transformed once, with the same similarity for every θ:
    the diagonal :func:`state_balance` of the system at θ_ref, then (with
    ``balance="gramian"``, when it exists) the square-root balanced
    realisation of :func:`gramian_transform`; the outputs are divided by
    ``output_scale`` (so γ ≈ 1); ε = :data:`BRL_MARGIN` on those data.

    Parameters
    ----------
    A0 : array_like
        (n, n) [1/s].
    B0 : array_like
        (n, m).
    C, D : array_like
        (p, n), (p, m) (D None: 0).
    A_terms, B_terms : mapping of str to array_like
        Per parameter name, its A_k (n, n) and B_k (n, m); a name may appear
        in either or both.
    reference : mapping of str to float
        Parameter values for the balancing (default: 1 each).
    output_scale : float or None
        Positive divisor of C and D for the SDP (None: a crude estimate of
        the norm at ``reference``).
    solver : str or None
        cvxpy solver (None: Clarabel, else SCS).
    balance : {"gramian", "diagonal"}
        Coordinates of the SDP (the diagonal scaling alone, or followed by
        the Gramian balancing where it exists; ``balancing`` says which was
        used).
    fallback : bool
        When the first solver gives no verified certificate, try SCS
        (``eps=1e-9``); the result's ``message`` records both attempts.

    Examples
    --------
    γ of 1/(s + a) over a = 2 + θ, one compiled SDP:

    >>> prob = BoundedRealProblem([[-2.0]], [[1.0]], [[1.0]], None, A_terms={"a": [[-1.0]]})
    >>> [round(prob.solve(a=th).gamma, 5) for th in (0.0, 2.0)]
    [0.5, 0.25]
    """

    def __init__(self, A0: ArrayLike, B0: ArrayLike, C: ArrayLike, D: ArrayLike | None,
                 *, A_terms: Mapping[str, ArrayLike] | None = None,
                 B_terms: Mapping[str, ArrayLike] | None = None,
                 reference: Mapping[str, float] | None = None,
                 output_scale: float | None = None, solver: str | None = None,
                 balance: str = "gramian", fallback: bool = True) -> None:
        import cvxpy as cp

        if balance not in ("gramian", "diagonal"):
            raise ModelError(f"BoundedRealProblem: 'balance' must be 'gramian' or 'diagonal' "
                             f"(got {balance!r}).")
        self.balancing = "diagonal"
        self.fallback = bool(fallback)
        A, B, Cm, Dm = _as_matrices(A0, B0, C, D, "BoundedRealProblem")
        n, m = B.shape
        p = Cm.shape[0]
        At = parameter_terms("BoundedRealProblem", "A_terms", A_terms, (n, n))
        Bt = parameter_terms("BoundedRealProblem", "B_terms", B_terms, (n, m))
        self.names: tuple[str, ...] = tuple(dict.fromkeys([*At, *Bt]))
        ref = {k: 1.0 for k in self.names}
        ref.update(reference or {})
        A_ref = A + sum((ref[k] * M for k, M in At.items()), np.zeros((n, n)))
        B_ref = B + sum((ref[k] * M for k, M in Bt.items()), np.zeros((n, m)))
        d = state_balance(A_ref, B_ref, Cm)
        T, Ti = np.diag(d), np.diag(1.0 / d)
        if balance == "gramian":
            tg = gramian_transform(Ti @ A_ref @ T, Ti @ B_ref, Cm @ T)
            if tg is not None:
                T, Ti = T @ tg[0], tg[1] @ Ti
                self.balancing = "gramian"
        self._T, self._Ti = T, Ti

        def sim(M: Array) -> Array:
            return np.asarray(Ti @ M @ T, dtype=float)

        if output_scale is None:
            lam = np.linalg.eigvals(A_ref)
            Ab, Bb, Cb = sim(A_ref), Ti @ B_ref, Cm @ T
            vals = [float(np.linalg.norm(Dm, 2))]
            for w in [0.0] + [abs(z) for z in lam] + [abs(z.imag) for z in lam]:
                try:
                    vals.append(_sigma_max(Ab, Bb, Cb, Dm, 1j * float(w)))
                except np.linalg.LinAlgError:
                    continue
            output_scale = max([v for v in vals if math.isfinite(v)] + [0.0])
            if output_scale <= 0.0:
                output_scale = 1.0
        if not (math.isfinite(output_scale) and output_scale > 0):
            raise ModelError(f"BoundedRealProblem: 'output_scale' must be a finite number > 0 "
                             f"(got {output_scale!r}).")
        self.output_scale = float(output_scale)
        self.solver = _solver_name(solver)
        self.shape = (n, m, p)
        self._A0, self._B0 = sim(A), Ti @ B
        self._At = {k: sim(M) for k, M in At.items()}
        self._Bt = {k: Ti @ M for k, M in Bt.items()}
        self._C, self._D = Cm @ T / self.output_scale, Dm / self.output_scale

        self.parameters = {k: cp.Parameter(name=k) for k in self.names}
        P = cp.Variable((n, n), symmetric=True, name="P")
        t = cp.Variable(name="t")
        AP = self._A0.T @ P
        for k, M in self._At.items():
            AP = AP + self.parameters[k] * (M.T @ P)
        PB = P @ self._B0
        for k, M in self._Bt.items():
            PB = PB + self.parameters[k] * (P @ M)
        blocks = cp.bmat([[AP + AP.T, PB, self._C.T],
                          [PB.T, -t * np.eye(m), self._D.T],
                          [self._C, self._D, -np.eye(p)]])
        size = n + m + p
        self._P, self._t = P, t
        self._problem = cp.Problem(cp.Minimize(t), [
            P >> 0, 0.5 * (blocks + blocks.T) << -BRL_MARGIN * np.eye(size)])
        if not self._problem.is_dpp():  # pragma: no cover - guards the construction above
            raise ModelError("BoundedRealProblem: the SDP is not DPP.")

    @property
    def problem(self) -> cp.Problem:
        """The compiled cvxpy problem (for inspection)."""
        return self._problem

    def matrices(self, **values: float) -> tuple[Array, Array, Array, Array]:
        """(A(θ), B(θ), C, D) on the original coordinates.

        Parameters
        ----------
        **values : float
            One finite value θ_k per parameter name of the problem (its
            ``names``), no other; none when it has no parameters.

        Returns
        -------
        A : ndarray
            (n, n) A₀ + Σ_k θ_k A_k [1/s].
        B : ndarray
            (n, m) B₀ + Σ_k θ_k B_k.
        C : ndarray
            (p, n), unscaled.
        D : ndarray
            (p, m), unscaled.

        Raises
        ------
        ModelError
            If a parameter is missing or unknown, or a value is not a
            finite number.
        """
        theta = self._values(values, "matrices")
        A = self._A0 + sum((theta[k] * M for k, M in self._At.items()), np.zeros_like(self._A0))
        B = self._B0 + sum((theta[k] * M for k, M in self._Bt.items()), np.zeros_like(self._B0))
        T, Ti = self._T, self._Ti
        return (T @ A @ Ti, T @ B, self._C @ Ti * self.output_scale,
                self._D * self.output_scale)

    def _values(self, values: Mapping[str, float], method: str = "solve") -> dict[str, float]:
        unknown = set(values) - set(self.names)
        missing = set(self.names) - set(values)
        if unknown or missing:
            raise ModelError(f"BoundedRealProblem.{method}: give exactly the parameters "
                             f"{list(self.names)} (unknown {sorted(unknown)}, missing "
                             f"{sorted(missing)}).")
        out: dict[str, float] = {}
        for k, v in values.items():
            if not (isinstance(v, int | float | np.floating) and math.isfinite(v)):
                raise ModelError(f"BoundedRealProblem.{method}: parameter {k!r} must be a finite "
                                 f"number (got {v!r}).")
            out[k] = float(v)
        return out

    def solve(self, **values: float) -> BoundedRealResult:
        """Solve at the given parameter values and certify γ in floating point.

        Parameters
        ----------
        **values : float
            One finite value θ_k per parameter name of the problem (its
            ``names``), no other; none when it has no parameters.

        Returns
        -------
        BoundedRealResult
            The level; γ = inf with the reason when the solver finds no certificate (an
            unstable A(θ) makes the SDP infeasible) or the check fails;
            a non-optimal status is reported in ``status`` and ``message``.

        Raises
        ------
        ModelError
            If a parameter is missing or unknown, or a value is not a
            finite number.
        """
        import cvxpy as cp

        theta = self._values(values)
        for k, v in theta.items():
            self.parameters[k].value = v
        solvers = [self.solver]
        if self.fallback and self.solver != cp.SCS and cp.SCS in cp.installed_solvers():
            solvers.append(str(cp.SCS))
        notes: list[str] = []
        result: BoundedRealResult | None = None
        for solver in solvers:
            start = time.perf_counter()
            options: dict[str, Any] = {"eps": 1e-9, "max_iters": 200_000} \
                if solver == cp.SCS else {}
            status = solve_quietly(self._problem, solver, **options)
            elapsed = time.perf_counter() - start
            result = self._certify(theta, status, elapsed, solver)
            if result.certified:
                break
            notes.append(f"{solver}: {result.message}")
        assert result is not None
        if notes:
            text = "; ".join(notes)
            result = replace(result, message=f"{result.message} (after {text})"
                             if result.certified else text)
        return result

    def _certify(self, theta: dict[str, float], status: str, elapsed: float, solver: str
                 ) -> BoundedRealResult:
        n, m, p = self.shape
        P = self._P.value
        t = self._t.value
        if P is None or t is None or status not in ("optimal", "optimal_inaccurate"):
            return BoundedRealResult(gamma=math.inf, gamma_solver=math.nan, P=None,
                                     status=status, solver=solver, solve_time=elapsed,
                                     parameters=theta,
                                     message=f"no certificate: solver status {status}")
        Pt = 0.5 * (np.asarray(P) + np.asarray(P).T)
        A = self._A0 + sum((theta[k] * M for k, M in self._At.items()), np.zeros((n, n)))
        B = self._B0 + sum((theta[k] * M for k, M in self._Bt.items()), np.zeros((n, m)))
        M0 = np.block([[A.T @ Pt + Pt @ A, Pt @ B, self._C.T],
                       [B.T @ Pt, np.zeros((m, m)), self._D.T],
                       [self._C, self._D, -np.eye(p)]])
        tcert = certified_level(M0, range(n, n + m))
        pos = float(np.min(np.linalg.eigvalsh(Pt))) > 0.0
        gamma_solver = math.sqrt(max(float(t), 0.0)) * self.output_scale
        if not (pos and math.isfinite(tcert)):
            return BoundedRealResult(gamma=math.inf, gamma_solver=gamma_solver, P=None,
                                     status=status, solver=solver, solve_time=elapsed,
                                     parameters=theta,
                                     message="the solver's P does not verify (P ≻ 0 and "
                                     "AᵀP + PA + CᵀC ≺ 0 checked in floating point)")
        # a hair above the Schur bound so that the strict LMI holds at γ itself
        gamma = math.sqrt(tcert) * (1.0 + 1e-12) * self.output_scale
        P_orig = self._Ti.T @ Pt @ self._Ti * self.output_scale ** 2
        note = "" if status == "optimal" else f" (solver status {status}; verified anyway)"
        return BoundedRealResult(gamma=gamma, gamma_solver=gamma_solver, P=P_orig,
                                 status=status, solver=solver, solve_time=elapsed,
                                 parameters=theta,
                                 message=f"certified ‖G‖∞ ≤ {gamma:.6g}{note}")


def bounded_real_gamma(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike | None = None,
                       *, solver: str | None = None) -> BoundedRealResult:
    """The smallest γ the bounded-real lemma certifies for ẋ = Ax + Bw, s = Cx + Dw.

    One solve of :class:`BoundedRealProblem` without parameters: minimise
    t = γ² over P ⪰ 0 with [[AᵀP + PA, PB, Cᵀ], [BᵀP, −tI, Dᵀ], [C, D, −I]]
    ⪯ −εI. The bounded-real lemma is exact (‖G‖∞ < γ ⇔ a P ≻ 0 exists), so
    γ approaches ‖G‖∞ to within the solver tolerance; the γ returned is
    recomputed from the solver's P in floating point, so it is an upper
    bound whatever the solver's accuracy. Continuous systems only.

    Parameters
    ----------
    A, B, C, D : array_like
        (n, n) [1/s], (n, m), (p, n), (p, m) (D None: 0).
    solver : str or None
        cvxpy solver (None: Clarabel, SCS as fallback).

    Returns
    -------
    BoundedRealResult
        The level γ, the matrix P (V = xᵀPx) and the solver status.

    Examples
    --------
    >>> res = bounded_real_gamma([[-1.0, 0.0], [0.0, -4.0]], np.eye(2), np.eye(2))
    >>> round(res.gamma, 5), res.status
    (1.0, 'optimal')
    """
    return BoundedRealProblem(A, B, C, D, solver=solver).solve()
