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
from typing import TYPE_CHECKING, cast

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from trainctl.analysis.check import Check
from trainctl.controllers.continuous.loops import Translation, hurwitz_check
from trainctl.controllers.continuous.sampled import SAMPLING_THRESHOLD
from trainctl.controllers.continuous.sampled import sampling_check as shared_sampling_check
from trainctl.controllers.potential.lyapunov import (
    LMI_MARGIN,
    LMI_MAX_STATES,
    bound_lmi,
    lyapunov_equation,
    lyapunov_lmi,
    spacing_bound,
)

if TYPE_CHECKING:
    from trainctl.controllers.potential.family import PotentialDesign
    from trainctl.sim import SimulationResult

__all__ = ["LMI_MARGIN", "LMI_MAX_STATES", "SAMPLING_THRESHOLD", "barrier_bound", "bound_lmi",
           "final_offset", "lyapunov_equation", "lyapunov_lmi", "potential_checks",
           "spacing_bound", "trajectory_checks"]

Array = NDArray[np.float64]


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
    return hurwitz_check(
        "potential_closed_loop", design.A_cl,
        unstable="closed loop unstable: max Re λ = {alpha:.4g} 1/s",
        stable="continuous closed loop Hurwitz: max Re λ = {alpha:.4g} 1/s",
        hint="raise speed_gain_per_s or lower the gains that excite the couplers",
        translation=Translation(
            message="velocities converge, a constant position offset remains "
            "(semisimple zero eigenvalue; other modes Re λ ≤ {alpha:.4g} 1/s)",
            hint="set position_gain > 0 to pin the cars to their reference positions",
            jordan_hint="set position_gain > 0"))


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
        return float(cast(float, design.settings.barrier))  # the barrier potential's Δ
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
