# Design checks of the potential family: stability, Lyapunov certificate, spacing bound, sampling.
"""The potential family's design checks (spec §2.3, §5 items 13–14).

``potential_closed_loop``
    Hurwitz test of the continuous linear closed loop. Without position
    pinning the head-position error p is a pure integrator of v̂_0 that
    nothing feeds back: a semisimple zero eigenvalue (rigid translation),
    reported as *warn* ("velocities converge, a constant position offset
    remains"); a zero eigenvalue in a Jordan block or Re λ > 0 fails.
``potential_lyapunov``
    A quadratic V = ξᵀPξ with V̇ ≤ 0 along the linear loop. Equal masses and
    a symmetric graph: the closed form of spec §2.3 item 3, checked
    numerically (AᵀP + PA ⪯ 0, LaSalle); otherwise (or when that check
    fails) an LMI solved with cvxpy: P ⪰ I, AᵀP + PA ⪯ −εI on the
    balanced matrix (:func:`lyapunov_lmi`); above :data:`LMI_MAX_STATES`
    states the Lyapunov equation instead (:func:`lyapunov_equation`).
    Unpinned loops are certified on [v̂, z] (the rigid mode removed). Pass
    when certified, warn when not.
``potential_spacing_bound``
    From V(t) ≤ V(0): |z_k(t)| ≤ √(V(0) · c_kᵀP⁻¹c_k) (the largest |z_k| on
    the level set of V through the scenario's initial errors), with the P
    that makes this smallest (:func:`bound_lmi`, an SDP, up to
    :data:`LMI_MAX_STATES` states; the certificate's P beyond), against the
    family's ``spacing_limit`` [m]. With the barrier and equal masses, the
    nonlinear energy instead (:func:`barrier_bound`): m U(z_k) ≤ V(0) gives
    |z_k| ≤ Δ √(1 − exp(−2V(0)/(mκ))) < Δ (the energy argument of (P2)
    needs the potential to act equally on both cars; with unequal masses
    m_i U' is not a gradient and only the linear bound is reported, as
    warn).
``potential_sampling``
    ω_max·T_c of the closed loop against :data:`SAMPLING_THRESHOLD` = 0.1 rad:
    the zero-order hold delays the law by about T_c/2, a phase lag of
    ω_max·T_c/2 ≤ 0.05 rad (3°) at the fastest mode, small enough to use the
    continuous analysis. The sampled loop (exact ZOH of the plant, the law
    held) is compared: its spectral radius against exp(max Re λ · T_c).
    Warn above the threshold while the sampled loop is stable, fail when it
    is not.
``potential_position``
    The offset from the reference position the train keeps for ever. With
    pinning every mode decays and the offset is 0 (pass). Without, the
    head-position error p is the rigid-translation mode: p(∞) = lᵀξ(0) with l
    the left null vector of A_cl scaled to l_p = 1 (the part of the initial
    errors the closed loop never removes), against ``position_tolerance_m``;
    fail above it.
``potential_linearisation``
    Spec §2.3 item 5: the neglected a2·v̂² term is below 10 % of the linear
    term (a1 + 2 a2 v_r)·v̂ when |v̂| < 0.1 (a1/a2 + 2 v_r). The design
    review judges the scenario's initial speed errors; after a simulation
    (:func:`trajectory_checks`) the largest |v̂| along the simulated
    trajectory replaces them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from trainctl.analysis.check import Check
from trainctl.controllers.continuous.sampled import SAMPLING_THRESHOLD, closed_loop_spectrum
from trainctl.controllers.continuous.sampled import sampling_check as shared_sampling_check

if TYPE_CHECKING:
    from trainctl.controllers.potential.family import PotentialDesign
    from trainctl.sim import SimulationResult

__all__ = ["LMI_MARGIN", "LMI_MAX_STATES", "SAMPLING_THRESHOLD", "barrier_bound", "bound_lmi",
           "final_offset", "lyapunov_equation", "lyapunov_lmi", "potential_checks",
           "spacing_bound", "trajectory_checks"]

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



def potential_checks(design: PotentialDesign) -> list[Check]:
    """The six checks (module docstring).

    Parameters
    ----------
    design : PotentialDesign
        The family's design.

    Returns
    -------
    list of Check
        In :data:`~trainctl.controllers.potential.family.CHECK_NAMES` order.

    Examples
    --------
    >>> from trainctl.controllers.potential.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-potential")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["potential"])
    >>> [(c.name, c.status) for c in potential_checks(design)]  # doctest: +NORMALIZE_WHITESPACE
    [('potential_closed_loop', 'pass'), ('potential_lyapunov', 'pass'),
     ('potential_spacing_bound', 'pass'), ('potential_sampling', 'pass'),
     ('potential_position', 'pass'), ('potential_linearisation', 'pass')]
    """
    certificate = design.certificate
    return [closed_loop_check(design), lyapunov_check(design, certificate),
            spacing_check(design, certificate), sampling_check(design),
            position_check(design), linearisation_check(design)]


def closed_loop_check(design: PotentialDesign) -> Check:
    """Hurwitz test; a semisimple zero eigenvalue (no pinning) warns."""
    lam, tol, zero, alpha, semisimple = closed_loop_spectrum(design.A_cl)
    details: dict[str, object] = {"max_real_part": alpha, "zero_eigenvalues": int(zero.sum()),
                                  "eigenvalues": [[float(x.real), float(x.imag)] for x in lam]}
    name = "potential_closed_loop"
    if alpha >= -tol:
        return Check(name=name, status="fail", value=alpha, threshold=0.0, unit="1/s",
                     message=f"closed loop unstable: max Re λ = {alpha:.4g} 1/s",
                     hint="raise speed_gain_per_s or lower the gains that excite the couplers",
                     details=details)
    if np.any(zero):
        if not semisimple:
            return Check(name=name, status="fail", value=0.0, threshold=0.0, unit="1/s",
                         message="zero eigenvalue in a Jordan block: the position error grows",
                         hint="set position_gain > 0", details=details)
        return Check(name=name, status="warn", value=0.0, threshold=0.0, unit="1/s",
                     message="velocities converge, a constant position offset remains "
                     f"(semisimple zero eigenvalue; other modes Re λ ≤ {alpha:.4g} 1/s)",
                     hint="set position_gain > 0 to pin the cars to their reference positions",
                     details=details)
    return Check(name=name, status="pass", value=alpha, threshold=0.0, unit="1/s",
                 message=f"continuous closed loop Hurwitz: max Re λ = {alpha:.4g} 1/s",
                 details=details)


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
    P = scipy.linalg.block_diag(np.diag(m), T.T @ Ks @ T)
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


def lyapunov_check(design: PotentialDesign, certificate: tuple[str, Array] | None) -> Check:
    """Pass when a closed-form or LMI certificate exists, warn when not."""
    name = "potential_lyapunov"
    if certificate is None:
        return Check(name=name, status="warn", value=None, threshold=None, unit="",
                     message="no quadratic Lyapunov certificate found (closed form does not "
                     "apply, LMI infeasible)",
                     hint="check potential_closed_loop; the simulation is the only evidence")
    kind, P = certificate
    where = ("on [v̂, z] (the rigid translation is the head-position integrator)"
             if P.shape[0] < design.A_cl.shape[0] else "on [v̂, z, p]")
    text = {"closed_form": "closed-form V of spec §2.3 (equal masses, symmetric graph), "
                           "V̇ ≤ 0 with LaSalle",
            "lmi": "LMI certificate AᵀP + PA ≺ 0 (cvxpy)",
            "equation": f"Lyapunov-equation certificate AᵀP + PA = −I (scipy; the LMI is not "
                        f"solved above {LMI_MAX_STATES} states)"}[kind]
    return Check(name=name, status="pass", value=None, threshold=None, unit="",
                 message=f"{text} {where}",
                 details={"kind": kind, "states": int(P.shape[0]),
                          "condition_number": float(np.linalg.cond(P))})


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
    try:
        problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    if problem.status != cp.OPTIMAL or Q.value is None:
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


def spacing_check(design: PotentialDesign, certificate: tuple[str, Array] | None) -> Check:
    """Spacing bound from V(0) against the spacing limit; the barrier band (spec §2.3 item 4)."""
    name, law = "potential_spacing_bound", design.law
    limit = float(design.settings.spacing_limit)
    xi0, n = design.initial_errors, law.n
    z0 = float(np.max(np.abs(xi0[n:2 * n - 1]), initial=0.0))
    delta = design.settings.barrier
    if delta is not None and z0 >= delta:
        return Check(name=name, status="fail", value=z0, threshold=float(delta), unit="m",
                     message=f"initial spacing deviation {z0:.4g} m outside the barrier's "
                     f"band |z| < Δ = {delta:g} m", hint="widen barrier_m or start closer")
    if certificate is None:
        return Check(name=name, status="warn", value=None, threshold=limit, unit="m",
                     message="no Lyapunov certificate, so no spacing bound",
                     hint="see potential_lyapunov")
    P = certificate[1]
    N = P.shape[0]
    rows = np.eye(n - 1, N, n)
    best = (bound_lmi(design.A_cl[:N, :N], xi0[:N], rows)
            if np.any(xi0) and N <= LMI_MAX_STATES else None)
    P = P if best is None else best
    bound = float(np.max(spacing_bound(P, xi0[:N], rows), initial=0.0))
    details = {"linear_bound": bound, "initial_max": z0, "limit": limit}
    equal = bool(np.allclose(law.mass, law.mass[0], rtol=1e-9))
    if delta is not None and equal:
        band = barrier_bound(design)
        details["barrier_bound"] = band
        status = "pass" if band <= limit else "fail"
        return Check(name=name, status=status, value=band, threshold=limit, unit="m",
                     message=f"barrier: m·U(z) ≤ V(0) keeps |z(t)| ≤ {band:.4g} m < Δ = "
                     f"{delta:g} m for all t (linear bound {bound:.4g} m)",
                     hint="" if status == "pass" else "narrow barrier_m or lower the initial "
                     "errors", details=details)
    status = "pass" if bound <= limit else "fail"
    note = (" (barrier invariance not proven: unequal masses)" if delta is not None else "")
    if status == "pass" and delta is not None:
        status = "warn"
    return Check(name=name, status=status, value=bound, threshold=limit, unit="m",
                 message=f"|z(t)| ≤ {bound:.4g} m from V(0) of the initial errors{note}",
                 hint="" if bound <= limit else "lower the initial errors or stiffen the law",
                 details=details)


def barrier_bound(design: PotentialDesign) -> float:
    """Largest |z_k(t)| [m] the barrier allows from the initial errors (equal masses).

    V = ½ v̂ᵀMv̂ + ½ x̂ᵀ(E diag(k) Eᵀ + K) x̂ + m Σ_k U(z_k) (the closed form of
    spec §2.3 item 3 with the barrier U in place of its quadratic part) does
    not increase along the unsaturated continuous loop, and every term is
    non-negative, so m U(z_k(t)) ≤ V(0): |z_k(t)| ≤ Δ √(1 − exp(−2V(0)/(mκ)))
    (:meth:`~trainctl.controllers.continuous.potentials.BarrierPotential.bound`), always
    below Δ, and the closer to it the larger V(0) is against m κ.

    Parameters
    ----------
    design : PotentialDesign
        A design with the barrier potential and equal masses.

    Returns
    -------
    float
        The bound [m]; Δ itself when an initial deviation is outside the band.

    Examples
    --------
    A stand-in design of two equal cars, 0.1 m/s either side of the
    reference at their nominal spacing: V(0)/m = ½(0.1² + 0.1²) = 0.01 m²/s²,
    so with κ = 0.02 m²/s² and Δ = 0.2 m the bound is
    0.2 √(1 − e^(−2·0.01/0.02)) = 0.2 √(1 − e^(−1)) ≈ 0.159 m.

    >>> from types import SimpleNamespace
    >>> from trainctl.controllers.continuous.potentials import BarrierPotential
    >>> law = SimpleNamespace(n=2, mass=np.full(2, 4e4), pinning=np.zeros(2),
    ...                       potential=BarrierPotential(kappa=0.02, delta=0.2))
    >>> design = SimpleNamespace(law=law, initial_errors=np.array([0.1, -0.1, 0.0, 0.0]),
    ...                          scenario=SimpleNamespace(train=SimpleNamespace(
    ...                              stiffness=np.array([1e7]))),
    ...                          settings=SimpleNamespace(barrier=0.2))
    >>> round(barrier_bound(design), 4)  # [m]
    0.159
    """
    from trainctl.controllers.continuous.sampled import cumulative, incidence

    law, train = design.law, design.scenario.train
    n, m = law.n, float(law.mass[0])
    xi0 = design.initial_errors
    v, z, p = xi0[:n], xi0[n:2 * n - 1], xi0[2 * n - 1]
    x = p - cumulative(n) @ z
    E = incidence(n)
    K = E @ np.diag(train.stiffness) @ E.T + np.diag(law.pinning)
    potential = law.potential
    barrier = float(np.sum(np.asarray(potential.energy(z), dtype=float)))
    if not math.isfinite(barrier):
        return float(design.settings.barrier)
    energy = 0.5 * m * float(v @ v) + 0.5 * float(x @ K @ x) + m * barrier
    return float(potential.bound(energy / m))


def sampling_check(design: PotentialDesign) -> Check:
    """ω_max·T_c against the threshold; the sampled loop's spectral radius."""
    return shared_sampling_check("potential_sampling", design.A_cl, design.sampled_matrix(),
                                 design.control_interval)


def final_offset(A_cl: Array, xi0: Array) -> float:
    """p(∞) [m] of the continuous loop ξ̇ = A_cl ξ from ξ(0) = ξ0, the last state being p.

    Zero when every eigenvalue has Re λ < 0. Otherwise the zero eigenvalue
    must be simple with right eigenvector e_p (nothing feeds p back); then
    p(∞) = lᵀξ0 with l the left null vector of A_cl scaled to l_p = 1.

    Parameters
    ----------
    A_cl : ndarray
        Continuous closed loop [1/s], (N, N), the head-position error last.
    xi0 : ndarray
        Initial state, (N,).

    Returns
    -------
    float
        The final head-position error [m]; NaN when the zero eigenvalue is
        not simple or p does not span it.

    Examples
    --------
    >>> A = np.array([[-2.0, 0.0], [1.0, 0.0]])   # v̇ = -2v, ṗ = v: p(∞) = p0 + v0/2
    >>> final_offset(A, np.array([1.0, 0.25]))
    0.75
    """
    lam = np.linalg.eigvals(A_cl)
    scale = max(1.0, float(np.max(np.abs(lam))))
    if float(np.max(lam.real)) < -1e-9 * scale:
        return 0.0
    left = scipy.linalg.null_space(A_cl.T, rcond=1e-10)
    if left.shape[1] != 1 or abs(left[-1, 0]) < 1e-9 * float(np.linalg.norm(left)):
        return math.nan
    l_vec = left[:, 0] / left[-1, 0]
    return float(l_vec @ xi0)


def position_check(design: PotentialDesign) -> Check:
    """The final offset from the reference position against ``position_tolerance``."""
    name, tol = "potential_position", float(design.settings.position_tolerance)
    if design.pinned:
        return Check(name=name, status="pass", value=0.0, threshold=tol, unit="m",
                     message="pinned to the reference position: the position errors decay "
                     "(no offset remains)")
    offset = final_offset(design.A_cl, design.initial_errors)
    if math.isnan(offset):
        return Check(name=name, status="warn", value=None, threshold=tol, unit="m",
                     message="the final position offset is undetermined (the zero eigenvalue "
                     "is not the head-position integrator alone)",
                     hint="set position_gain > 0")
    text = (f"no position pinning: the train settles {abs(offset):.4g} m "
            f"{'ahead of' if offset > 0 else 'behind'} its reference position and stays there "
            "(the rigid-translation part of the initial errors)")
    if abs(offset) > tol:
        return Check(name=name, status="fail", value=abs(offset), threshold=tol, unit="m",
                     message=f"{text}, more than position_tolerance_m = {tol:g} m",
                     hint="set position_gain > 0 to pin the cars to their reference positions",
                     details={"offset_m": offset})
    return Check(name=name, status="pass", value=abs(offset), threshold=tol, unit="m",
                 message=f"{text}, within position_tolerance_m = {tol:g} m",
                 details={"offset_m": offset})


def _linearisation_limits(design: PotentialDesign) -> Array:
    """0.1 (a1/a2 + 2 v_r) per car [m/s] (inf where a2 = 0)."""
    _, a1, a2 = np.asarray(design.scenario.train.davis, dtype=float)
    v_r = float(design.model.settings.speed)
    with np.errstate(divide="ignore"):
        return np.asarray(np.where(a2 > 0, 0.1 * (a1 / np.where(a2 > 0, a2, 1.0) + 2 * v_r),
                                   np.inf), dtype=float)


def linearisation_check(design: PotentialDesign, result: SimulationResult | None = None,
                        strategy: str = "") -> Check:
    """|v̂| < 0.1 (a1/a2 + 2 v_r) for every car (spec §2.3 item 5).

    Parameters
    ----------
    design : PotentialDesign
        The family's design.
    result : SimulationResult or None
        A simulation of the law: judge the largest |v̂| along it (dense grid
        when recorded); None: the scenario's initial speed errors.
    strategy : str
        The simulated strategy's name (for the message).

    Returns
    -------
    Check
        ``potential_linearisation``.
    """
    name, n = "potential_linearisation", design.law.n
    limits = _linearisation_limits(design)
    if result is None:
        errors = np.abs(design.initial_errors[:n])
        where, t_worst = "initial", None
    else:
        t = result.time if result.dense_time is None else result.dense_time
        v = result.velocities if result.dense_time is None else result.dense_velocities
        v_ref = result.reference_speed if result.dense_time is None else \
            result.dense_reference_speed
        dev = np.abs(np.asarray(v, dtype=float) - np.asarray(v_ref, dtype=float)[None, :])
        errors = dev.max(axis=1)
        t_worst = float(t[int(np.argmax(dev.max(axis=0)))])
        where = f"along the simulated {strategy} run, largest"
    worst = float(np.max(errors))
    limit = float(np.min(limits))
    ok = bool(np.all(errors < limits))
    relation, share = ("<", "below") if ok else ("≥", "above")
    tail = ("(the simulated trajectory is not judged)" if result is None
            else f"(at t = {t_worst:.4g} s)")
    details: dict[str, object] = {"limits": [float(x) for x in limits],
                                  "largest_errors": [float(x) for x in errors],
                                  "judged": "initial errors" if result is None else "trajectory"}
    return Check(name=name, status="pass" if ok else "fail", value=worst, threshold=limit,
                 unit="m/s",
                 message=f"{where} |v̂| = {worst:.3g} m/s {relation} 0.1(a1/a2 + 2v_r) = "
                 f"{limit:.3g} m/s: the a2·v̂² term is {share} 10 % of the linear term {tail}",
                 hint="" if ok else "start closer to the reference",
                 details=details)


def trajectory_checks(design: PotentialDesign, strategy: str,
                      result: SimulationResult) -> list[Check]:
    """The checks a simulation of the law decides: ``potential_linearisation`` on its trajectory.

    Parameters
    ----------
    design : PotentialDesign
        The family's design.
    strategy : str
        The simulated strategy's name.
    result : SimulationResult
        Its simulation on the nonlinear plant.

    Returns
    -------
    list of Check
        Replacing the design review's checks of the same names.

    Examples
    --------
    A stand-in result in which every car keeps within 0.5 m/s of the
    reference, far below the linearisation limit 0.1 (a1/a2 + 2 v_r):

    >>> from trainctl.controllers.potential.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-potential")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["potential"])
    >>> from types import SimpleNamespace
    >>> t = np.array([0.0, 1.0])
    >>> v_ref = np.full(2, design.model.settings.speed)
    >>> result = SimpleNamespace(time=t, dense_time=None, reference_speed=v_ref,
    ...                          velocities=v_ref + np.array([[0.5], [-0.5]] * 4))
    >>> [check] = trajectory_checks(design, "potential", result)
    >>> check.name, check.status, check.value  # largest |v̂| [m/s]
    ('potential_linearisation', 'pass', 0.5)
    """
    return [linearisation_check(design, result, strategy)]
