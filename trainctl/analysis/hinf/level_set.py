# The H∞ norm by a Hamiltonian level set (Bruinsma & Steinbuch), trainctl's own route.
"""The H∞ norm by the Hamiltonian level-set iteration: continuous systems directly,
discrete ones through the Cayley transform.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import control as ct
import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from trainctl.analysis.hinf.balancing import _as_matrices, _balanced, _system_data
from trainctl.exceptions import ModelError, SolverError

__all__ = ["LEVEL_TOL", "hamiltonian_hinf_norm", "hamiltonian_matrix"]

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]

LEVEL_TOL = 1e-9
"""ε of the level set: the norm is bracketed in [γ_lb, (1 + 2ε) γ_lb]."""

IMAGINARY_TOL = 1e-6
"""|Re λ| ≤ this × ‖H‖₁ counts an eigenvalue of H(γ) as imaginary.

Generous on purpose: a spurious imaginary eigenvalue costs one evaluation of
σ̄ (which cannot raise the lower bound above the norm), a missed one would
stop the iteration early."""

MAX_LEVELS = 100
"""Iterations of the level set before it reports non-convergence."""


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
