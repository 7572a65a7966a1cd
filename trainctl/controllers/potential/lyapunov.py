# Quadratic Lyapunov certificates and invariant-ellipsoid bounds of a continuous linear loop.
"""The Lyapunov certificates and spacing bounds behind the potential family's checks.

A closed-form P (spec §2.3 item 3, :func:`closed_form_certificate`), an LMI
certificate (:func:`lyapunov_lmi`, cvxpy) or the Lyapunov equation
(:func:`lyapunov_equation`, scipy) above :data:`LMI_MAX_STATES` states; the
bound on the outputs over the level set of V through the initial state
(:func:`spacing_bound`) and the P that makes it smallest (:func:`bound_lmi`).
Used by :mod:`trainctl.controllers.potential.checks`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

if TYPE_CHECKING:
    from trainctl.controllers.potential.family import PotentialDesign

__all__ = ["LMI_MARGIN", "LMI_MAX_STATES", "bound_lmi", "lyapunov_equation", "lyapunov_lmi",
           "spacing_bound"]

Array = NDArray[np.float64]

LMI_MAX_STATES = 40
"""Largest closed loop (states) whose certificate and spacing bound are SDPs in cvxpy.

Clarabel's cost grows steeply with the N(N+1)/2 unknowns of P (measured on
this machine, 16 vs 32 unequal cars: 32 states, 0.4 s for both SDPs; 64
states, 15 s for the certificate and 51 s for the bound). Larger loops are
certified by the Lyapunov equation AᵀP + PA = −I (:func:`lyapunov_equation`,
scipy, O(N³)), whose solution is positive definite exactly when A is
Hurwitz, and bounded with that P (a valid, less tight ellipsoid)."""


LMI_MARGIN = 1e-6
"""ε of the strict LMI AᵀP + PA ⪯ −εI with P ⪰ I (on the balanced matrix)."""


def closed_form_certificate(design: PotentialDesign) -> Array | None:
    """P of spec §2.3 item 3 on ξ = [v̂, z, p] when it applies and checks out, else None.

    V = ½ v̂ᵀMv̂ + ½ x̂ᵀ(E diag(k) Eᵀ + K + m κ E Eᵀ) x̂ with x̂ = 1·p − S z;
    it applies to equal masses and a symmetric consensus graph, and is kept
    only when AᵀP + PA ⪯ 0 holds numerically.
    """
    from trainctl.controllers.continuous.sampled import cumulative, incidence

    law, train = design.law, design.scenario.train
    m = law.mass
    if not (np.allclose(m, m[0], rtol=1e-9) and np.allclose(law.consensus, law.consensus.T)):
        return None
    n = law.n
    E = incidence(n)
    kappa = law.potential.curvature()
    Ks = E @ np.diag(train.stiffness) @ E.T + np.diag(law.pinning) + m[0] * kappa * E @ E.T
    T = np.hstack([-cumulative(n), np.ones((n, 1))])
    P: NDArray[np.float64] = scipy.linalg.block_diag(np.diag(m), T.T @ Ks @ T)
    Q = design.A_cl.T @ P + P @ design.A_cl
    scale = float(np.linalg.norm(P, 2) * np.linalg.norm(design.A_cl, 2))
    if float(np.max(np.linalg.eigvalsh(0.5 * (Q + Q.T)))) > 1e-9 * scale:
        return None
    return P


def lyapunov_lmi(A: Array, margin: float = LMI_MARGIN) -> Array | None:
    """P ≻ 0 with AᵀP + PA ≺ 0 from an SDP (cvxpy), or None when not certifiable.

    The matrix is balanced first (diagonal similarity D⁻¹AD, scipy), because
    speeds [m/s] and coupler deflections [m] differ by orders of magnitude
    (spec §5 item 7); the SDP asks P̃ ⪰ I and ÃᵀP̃ + P̃Ã ⪯ −εI, and the
    result P = D⁻ᵀP̃D⁻¹ is verified numerically.

    Parameters
    ----------
    A : ndarray
        Continuous state matrix [1/s], (N, N).
    margin : float
        ε [-] of the strict inequality.

    Returns
    -------
    ndarray or None
        P on the original coordinates, or None (solver not optimal, or the
        verification failed).

    Examples
    --------
    >>> P = lyapunov_lmi(np.array([[0.0, 1.0], [-4.0, -0.5]]))
    >>> bool(np.all(np.linalg.eigvalsh(P) > 0))
    True
    >>> lyapunov_lmi(np.array([[0.1, 0.0], [0.0, -1.0]])) is None
    True
    """
    import cvxpy as cp

    from trainctl.analysis.hinf import solve_quietly

    At, D = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    d = np.asarray(D[0], dtype=float)
    At = A * (1.0 / d)[:, None] * d[None, :]
    N = A.shape[0]
    P = cp.Variable((N, N), symmetric=True)
    lhs = At.T @ P + P @ At
    cons = [P >> np.eye(N), 0.5 * (lhs + lhs.T) << -margin * np.eye(N)]
    problem = cp.Problem(cp.Minimize(0), cons)
    # an inaccurate or failed solve is no certificate (None), not a warning
    if solve_quietly(problem, "CLARABEL") != cp.OPTIMAL or P.value is None:
        return None
    Pt = 0.5 * (P.value + P.value.T)
    Pd = Pt * (1.0 / d)[:, None] * (1.0 / d)[None, :]
    Q = A.T @ Pd + Pd @ A
    if np.min(np.linalg.eigvalsh(Pd)) <= 0 or np.max(np.linalg.eigvalsh(0.5 * (Q + Q.T))) >= 0:
        return None
    return np.asarray(Pd, dtype=float)


def lyapunov_equation(A: Array) -> Array | None:
    """P ≻ 0 solving AᵀP + PA = −I on the balanced matrix (scipy), or None when not Hurwitz.

    The solution of the Lyapunov equation with a positive definite right-hand
    side is positive definite exactly when A is Hurwitz, so it certifies
    what the LMI of :func:`lyapunov_lmi` certifies, at O(N³) cost; it is not
    the best P for any purpose. Balanced as :func:`lyapunov_lmi`; the result
    is verified (P ≻ 0, AᵀP + PA ≺ 0) in the original coordinates.

    Parameters
    ----------
    A : ndarray
        Continuous state matrix [1/s], (N, N).

    Returns
    -------
    ndarray or None
        P on the original coordinates.

    Examples
    --------
    >>> A = np.array([[0.0, 1.0], [-4.0, -0.5]])
    >>> P = lyapunov_equation(A)
    >>> bool(np.all(np.linalg.eigvalsh(A.T @ P + P @ A) < 0))
    True
    >>> lyapunov_equation(np.array([[0.1, 0.0], [0.0, -1.0]])) is None
    True
    """
    _, (d, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    d = np.asarray(d, dtype=float)
    At = A * (1.0 / d)[:, None] * d[None, :]
    try:
        Pt = scipy.linalg.solve_continuous_lyapunov(At.T, -np.eye(A.shape[0]))
    except (np.linalg.LinAlgError, ValueError):
        return None
    Pd = 0.5 * (Pt + Pt.T) * (1.0 / d)[:, None] * (1.0 / d)[None, :]
    if not np.all(np.isfinite(Pd)):
        return None
    Q = A.T @ Pd + Pd @ A
    if np.min(np.linalg.eigvalsh(Pd)) <= 0 or np.max(np.linalg.eigvalsh(0.5 * (Q + Q.T))) >= 0:
        return None
    return np.asarray(Pd, dtype=float)


def spacing_bound(P: Array, xi0: Array, rows: Array) -> Array:
    """max |c_kᵀξ| on {ξ : ξᵀPξ ≤ ξ₀ᵀPξ₀} for each row c_k: √(ξ₀ᵀPξ₀ · c_kᵀP⁺c_k).

    Parameters
    ----------
    P : ndarray
        Positive semidefinite, (N, N); P⁺ its pseudo-inverse (a singular P
        gives inf for rows outside its range).
    xi0 : ndarray
        Initial state, (N,).
    rows : ndarray
        (K, N).

    Returns
    -------
    ndarray
        (K,) bounds in the unit of the outputs.

    Examples
    --------
    >>> spacing_bound(np.diag([1.0, 4.0]), np.array([1.0, 0.0]), np.eye(2)).tolist()
    [1.0, 0.5]
    """
    energy = float(xi0 @ P @ xi0)
    Pinv = np.linalg.pinv(P)
    reach = np.einsum("kn,nm,km->k", rows, Pinv, rows)
    inside = np.linalg.norm(rows - rows @ Pinv @ P, axis=1) <= 1e-8 * np.linalg.norm(rows, axis=1)
    return np.where(inside, np.sqrt(np.maximum(energy * reach, 0.0)), np.inf)


def bound_lmi(A: Array, xi0: Array, rows: Array) -> Array | None:
    """The invariant ellipsoid through ξ₀ that bounds ``rows @ ξ`` best (cvxpy SDP).

    Minimises γ over P ≻ 0 with AᵀP + PA ⪯ 0 (V = ξᵀPξ non-increasing),
    ξ₀ᵀPξ₀ ≤ 1 and c_kᵀP⁻¹c_k ≤ γ for every row c_k, so that |c_kᵀξ(t)| ≤ √γ
    along the linear loop. Solved in Q = P⁻¹, where it is linear but for
    three cones: Q ⪰ 0, AQ + QAᵀ ⪯ 0, [[1, ξ₀ᵀ], [ξ₀, Q]] ⪰ 0, and c_kᵀQc_k ≤ γ
    (the same problem as the P form with one LMI block [[P, c_k], [c_kᵀ, γ]]
    per row; measured: 7.7 s against 0.36 s for a 12-car train, the per-row
    blocks couple every entry of P in each cone). On the balanced matrix,
    as :func:`lyapunov_lmi`.

    Parameters
    ----------
    A : ndarray
        Continuous state matrix [1/s], (N, N), with no eigenvalue in Re λ > 0.
    xi0 : ndarray
        Initial state, (N,).
    rows : ndarray
        The bounded outputs c_kᵀ, (K, N).

    Returns
    -------
    ndarray or None
        P on the original coordinates (verified: AᵀP + PA ⪯ 0 numerically),
        or None when the solver does not reach optimality or Q is singular.

    Examples
    --------
    >>> A = np.array([[0.0, 1.0], [-1.0, -0.1]])   # x'' + 0.1 x' + x = 0, energy ≤ E(0)
    >>> P = bound_lmi(A, np.array([0.0, 1.0]), np.array([[1.0, 0.0]]))
    >>> b = float(spacing_bound(P, np.array([0.0, 1.0]), np.array([[1.0, 0.0]]))[0])
    >>> 0.924 < b < 1.0  # true peak e^(-0.05·π/2) ≈ 0.924; the energy bound is 1
    True
    """
    import cvxpy as cp

    from trainctl.analysis.hinf import solve_quietly

    _, (d, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    d = np.asarray(d, dtype=float)
    At = A * (1.0 / d)[:, None] * d[None, :]
    x0, C = xi0 / d, rows * d[None, :]
    N = A.shape[0]
    Q, gamma = cp.Variable((N, N), symmetric=True), cp.Variable()
    lhs = At @ Q + Q @ At.T
    cons = [Q >> 0, 0.5 * (lhs + lhs.T) << 0,
            cp.bmat([[np.ones((1, 1)), x0[None, :]], [x0[:, None], Q]]) >> 0]
    cons += [cp.sum(cp.multiply(np.outer(c, c), Q)) <= gamma for c in C]
    problem = cp.Problem(cp.Minimize(gamma), cons)
    if solve_quietly(problem, "CLARABEL") != cp.OPTIMAL or Q.value is None:
        return None
    Qs = 0.5 * (Q.value + Q.value.T)
    w = np.linalg.eigvalsh(Qs)
    if w[0] <= 1e-12 * max(w[-1], 1e-300):
        return None
    Pt = np.linalg.inv(Qs)
    Pd = 0.5 * (Pt + Pt.T) * (1.0 / d)[:, None] * (1.0 / d)[None, :]
    M = A.T @ Pd + Pd @ A
    scale = float(np.linalg.norm(Pd, 2) * np.linalg.norm(A, 2))
    if np.max(np.linalg.eigvalsh(0.5 * (M + M.T))) > 1e-7 * scale:
        return None
    return np.asarray(Pd, dtype=float)
