# Design checks of the flocking family: parameters, closed loop, collision energy, range, actuators.
"""The flocking family's design checks (spec §3.4, §5 items 9–11 and 14).

``flocking_parameters``
    d_α, r_α, ρ_h(d_α/r_α), φ'(0), k_eff and the 90 % saturation band in
    the details; warn when ρ_h(d_α/r_α) < 0.5: the bump already attenuates
    the action at the desired gap, so the lattice spring k_eff is softer
    than φ'(0) suggests.
``flocking_closed_loop``
    Spectral abscissa of the continuous linear closed loop. Without the
    position term (c₁ = 0) the head-position error p is a pure integrator
    that nothing feeds back: a semisimple zero eigenvalue (rigid
    translation), reported as warn; a zero eigenvalue in a Jordan block or
    Re λ > 0 fails.
``flocking_sampling``
    ω_max·T_c of the linearised closed loop against 0.1 rad (the hold's
    phase lag at the fastest mode ≤ 3°,
    :data:`~trainctl.controllers.continuous.sampled.SAMPLING_THRESHOLD`),
    and the held loop's spectral radius (fail ≥ 1), as ``potential_sampling``.
    The lattice spring is linearised at the desired gap: nearer the
    collision barrier φ is steeper, so the margin matters.
``flocking_collision``
    H(0) = ½ Σ v̂_i² + Σ_k E(s_k) + ½ c₁ Σ x̂_i² [m²/s²] from the scenario's
    initial errors against the collision barrier E(0) = l·a_s·ψ_α(0)
    (:meth:`~trainctl.controllers.continuous.potentials.FlockingPotential.collision_energy_bound`)
    and its relative-speed equivalent √(2 E(0)). H does not increase along
    the unsaturated continuous loop (:mod:`~trainctl.controllers.flocking.law`),
    so H(0) < E(0) certifies that no gap reaches 0; fail ("uncertified")
    when H(0) >= E(0). After a simulation (:func:`trajectory_checks`) the
    smallest simulated gap joins the message, and a gap at or below 0 fails
    whatever the certificate said (the law saturated, or the loop left the
    certificate's assumptions).
``flocking_connectivity``
    Every gap at t = 0 within the interaction range r (fail otherwise: the
    pair neither attracts nor exchanges speeds, the formation splits). Along
    the trajectory: a design check does not see simulation results, so it
    uses the same energy argument: E is constant (= E(r)) beyond r, so
    H(0) < E(r) keeps every gap below r for all t; warn when t = 0 passes but
    H(0) >= E(r). After a simulation (:func:`trajectory_checks`) the
    simulated gaps decide: pass when the widest stays below r throughout,
    fail when it reaches r.
``flocking_actuators``
    Per train, the largest force the law can ask for about the feedforward:
    m_i (Σ_links max_s |φ(s)| over 0 <= s <= r + consensus c Σ_j g_ij Δv̂(0)
    + c₂ max|v̂(0)| + c₁ max|x̂(0)|), against its traction and braking limits
    at the cruise speed minus the feedforward; warn when it exceeds them
    (the law may saturate, and the collision certificate assumes it does not).
``flocking_braking_distance``
    The design-time worst case of virtual coupling: the formation at the
    cruise speed v, each gap the smaller of d and its initial gap, the leader
    braking at its strongest just after its last message before an outage of
    the assumed length T, the follower running on until it can have heard
    (T_c + τ, and T + τ more with an outage:
    :meth:`~trainctl.controllers.flocking.supervisor.BrakingSupervisor.design_lag`),
    then braking. Value: the smallest gap minus its relative braking distance
    (with the margin) [m]. Pass when >= 0; else fail without the supervisor
    (a leader braking during such an outage can be hit) and warn with it
    (the supervisor will brake: capacity is lost, safety kept). After a
    simulation (:func:`trajectory_checks`) the supervisor's rule is judged
    at every control step of the run (:func:`braking_margins`): a follower
    that ran on needs its run-on margin, one braking at full its brake-now
    margin; a negative one fails, whatever the design-time verdict, and the
    supervisor's activations join the message.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl.analysis.check import Check
from trainctl.controllers.continuous.loops import Translation, hurwitz_check
from trainctl.controllers.continuous.sampled import cumulative, sampling_check
from trainctl.models.braking import relative_braking_distance

if TYPE_CHECKING:
    from trainctl.controllers.flocking.family import FlockingDesign
    from trainctl.controllers.flocking.supervisor import BrakingSupervisor
    from trainctl.sim import SimulationResult

__all__ = ["SOFT_SPRING", "braking_distance_check", "braking_margins", "flocking_checks",
           "initial_energy", "trajectory_checks", "trajectory_gaps"]

Array = NDArray[np.float64]

SOFT_SPRING = 0.5
"""ρ_h(d_α/r_α) below which the lattice spring is reported as soft (warn)."""



def flocking_checks(design: FlockingDesign) -> list[Check]:
    """The seven checks (module docstring), in ``CHECK_NAMES`` order.

    Parameters
    ----------
    design : FlockingDesign
        The family's design.

    Returns
    -------
    list of Check
        The checks parameters, closed loop, sampling, collision, connectivity,
        actuators and braking distance.

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.family import design_flocking
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> design = design_flocking(scenario, build_model(scenario),
    ...                          scenario.controllers["flocking"])
    >>> [(c.name, c.status) for c in flocking_checks(design)][1:4]  # doctest: +NORMALIZE_WHITESPACE
    [('flocking_closed_loop', 'pass'), ('flocking_sampling', 'pass'),
     ('flocking_collision', 'pass')]
    """
    energy = initial_energy(design)
    return [parameters_check(design), closed_loop_check(design),
            sampling_check("flocking_sampling", design.A_cl, design.sampled_matrix(),
                           design.control_interval),
            collision_check(design, energy), connectivity_check(design, energy),
            actuators_check(design), braking_distance_check(design)]


def initial_errors(design: FlockingDesign) -> tuple[Array, Array, Array]:
    """(v̂(0) [m/s], z(0) [m], x̂(0) [m]) of the scenario; the leader starts at the head."""
    n = design.law.n
    xi = design.initial_errors
    z = xi[n:2 * n - 1]
    return xi[:n], z, xi[2 * n - 1] - cumulative(n) @ z


def initial_energy(design: FlockingDesign) -> float | None:
    """H(0) [m²/s²] of the scenario's initial errors; None when a gap starts negative.

    Parameters
    ----------
    design : FlockingDesign
        The family's design, with the scenario's initial state.

    Returns
    -------
    float or None
        The initial energy per unit mass [m²/s²], or None.

    Examples
    --------
    The four trains start at speed errors ±2 m/s, so the kinetic part alone
    is ½·4·2² = 8 m²/s²; the gaps' potential energy adds to it, and the
    total stays below the collision barrier E(0):

    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.family import design_flocking
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> design = design_flocking(scenario, build_model(scenario),
    ...                          scenario.controllers["flocking"])
    >>> H0 = initial_energy(design)
    >>> round(H0, 2), H0 > 8.0
    (14.28, True)
    >>> H0 < design.law.potential.collision_energy_bound().energy  # no gap can reach 0
    True
    """
    v, z, x = initial_errors(design)
    if np.any(design.law.gaps(z) < 0.0):
        return None
    return design.law.energy(v, z, x)


def parameters_check(design: FlockingDesign) -> Check:
    """d_α, r_α, ρ_h(d_α/r_α), k_eff; warn when ρ_h(d_α/r_α) < :data:`SOFT_SPRING`."""
    p = design.law.potential
    rho = float(p.adjacency(p.desired_gap))
    k_eff = p.stiffness()
    phi_slope = k_eff / max(rho, 1e-300) / (p.force_scale / p.length_scale) / float(
        (p.desired_gap / p.length_scale) / np.sqrt(1 + p.eps * (p.desired_gap / p.length_scale)
                                                   ** 2)) ** 2
    details: dict[str, object] = {
        "d_alpha": p.d_alpha, "r_alpha": p.r_alpha, "rho_h": rho, "phi_slope": phi_slope,
        "k_eff_per_s2": k_eff, "lattice_period_s": float(2 * np.pi / np.sqrt(k_eff)),
        "saturation_gap_m": p.saturation_gap(0.9), "desired_gap_m": p.desired_gap,
        "interaction_range_m": p.r}
    text = (f"d_α = {p.d_alpha:.4g}, r_α = {p.r_alpha:.4g}, ρ_h(d_α/r_α) = {rho:.3g}, "
            f"k_eff = {k_eff:.3g} 1/s²")
    if rho < SOFT_SPRING:
        return Check(name="flocking_parameters", status="warn", value=rho, threshold=SOFT_SPRING,
                     unit="", message=f"{text}: the bump already attenuates the action at the "
                     f"desired gap, so the lattice spring is {1 / rho:.2g}x softer than φ'(0) "
                     "suggests",
                     hint="raise bump_h or the interaction range so that d_α/r_α <= h",
                     details=details)
    return Check(name="flocking_parameters", status="pass", value=rho, threshold=SOFT_SPRING,
                 unit="", message=text, details=details)


def closed_loop_check(design: FlockingDesign) -> Check:
    """Hurwitz test; a semisimple zero eigenvalue (c₁ = 0) warns."""
    return hurwitz_check(
        "flocking_closed_loop", design.A_cl,
        unstable="linearised closed loop unstable: max Re λ = {alpha:.4g} 1/s",
        stable="linearised closed loop Hurwitz: spectral abscissa {alpha:.4g} 1/s "
        "(time constant {tau:.4g} s)",
        hint="raise speed_gain_per_s or consensus_gain_per_s", value_key="spectral_abscissa",
        translation=Translation(
            message="semisimple zero eigenvalue (translation of the whole formation, no "
            "position term): speeds and gaps converge, a position offset remains; other "
            "modes max Re λ = {alpha:.4g} 1/s",
            hint="set position_gain_per_s2 > 0 to track the virtual leader's slots",
            jordan_hint="set position_gain_per_s2 > 0"))


def collision_check(design: FlockingDesign, energy: float | None) -> Check:
    """H(0) against the collision barrier E(0); fail ("uncertified") when H(0) >= E(0)."""
    bound = design.law.potential.collision_energy_bound()
    details: dict[str, object] = {"initial_energy_m2_s2": energy, "bound_m2_s2": bound.energy,
                                  "bound_relative_speed_m_s": bound.relative_speed}
    name = "flocking_collision"
    if energy is None:
        return Check(name=name, status="fail", value=None, threshold=bound.energy,
                     unit="m²/s²", message="uncertified: a gap is negative at t = 0 (the "
                     "trains start overlapping)", hint="check initial_spacing_errors",
                     details=details)
    speed = float(np.sqrt(2.0 * energy))
    details["initial_energy_speed_m_s"] = speed
    text = (f"H(0) = {energy:.4g} m²/s² (≙ {speed:.3g} m/s) against the collision barrier "
            f"E(0) = {bound.energy:.4g} m²/s² (≙ {bound.relative_speed:.3g} m/s)")
    if energy >= bound.energy:
        return Check(name=name, status="fail", value=energy, threshold=bound.energy,
                     unit="m²/s²", message=f"uncertified: {text}; the energy test cannot "
                     "exclude a collision", hint="start closer to the formation, or raise "
                     "force_scale_m_s2 or b (a higher barrier)", details=details)
    return Check(name=name, status="pass", value=energy, threshold=bound.energy, unit="m²/s²",
                 message=f"collision-free (unsaturated law): {text}", details=details)


def connectivity_check(design: FlockingDesign, energy: float | None) -> Check:
    """Gaps within the range at t = 0, and along the trajectory by the energy argument."""
    p = design.law.potential
    _, z, _ = initial_errors(design)
    gaps = design.law.gaps(z)
    widest = float(np.max(gaps))
    at_range = float(p.energy(p.r))
    details: dict[str, object] = {"initial_gaps_m": gaps.tolist(), "range_m": p.r,
                                  "range_energy_m2_s2": at_range, "initial_energy_m2_s2": energy,
                                  "trajectory": "energy argument (simulations not seen)"}
    name = "flocking_connectivity"
    if widest >= p.r:
        return Check(name=name, status="fail", value=widest, threshold=p.r, unit="m",
                     message=f"a gap of {widest:.4g} m is at or beyond the interaction range "
                     f"{p.r:.4g} m at t = 0: that pair does not interact, the formation splits",
                     hint="raise interaction_range_m or start closer", details=details)
    if energy is None or energy >= at_range:
        return Check(name=name, status="warn", value=widest, threshold=p.r, unit="m",
                     message=f"every gap within the range at t = 0 (widest {widest:.4g} m < "
                     f"{p.r:.4g} m), but H(0) >= E(r) = {at_range:.4g} m²/s²: a gap may leave "
                     "the range later (check the simulation)", hint="", details=details)
    return Check(name=name, status="pass", value=widest, threshold=p.r, unit="m",
                 message=f"every gap within the range at t = 0 (widest {widest:.4g} m < "
                 f"{p.r:.4g} m) and for all t: H(0) = {energy:.4g} < E(r) = {at_range:.4g} m²/s²",
                 details=details)


def _pair_peak(design: FlockingDesign) -> float:
    """max |φ(s)| [m/s²] over 0 <= s <= r (dense grid plus the extremes' neighbourhood)."""
    p = design.law.potential
    s = np.linspace(0.0, p.r, 6001)
    return float(np.max(np.abs(np.asarray(p.acceleration(s)))))


def actuators_check(design: FlockingDesign) -> Check:
    """Largest law force per train against its envelope at the cruise speed."""
    from trainctl.models.envelope import EnvelopeBounds

    law, model = design.law, design.model
    n = law.n
    v, _, x = initial_errors(design)
    links = np.abs(np.diff(np.eye(n), axis=0)).sum(axis=0)   # 1 at the ends, 2 inside
    spread = float(np.ptp(v)) if n > 1 else 0.0
    consensus = law.consensus_gain * np.asarray(law.graph).sum(axis=1) * spread
    accel = (links * _pair_peak(design) + consensus + law.speed_gain * float(np.max(np.abs(v)))
             + law.position_gain * float(np.max(np.abs(x))))
    demand = law.mass * accel
    feed = np.asarray(model.equilibrium.inputs, dtype=float)
    low, high = EnvelopeBounds(model.train, enabled=True).at(np.full(n, model.settings.speed))
    room = np.minimum(high - feed, feed - low)
    ratio = demand / np.maximum(room, 1e-9)
    worst = int(np.argmax(ratio))
    details: dict[str, object] = {"demand_kn": (demand / 1e3).tolist(),
                                  "room_kn": (room / 1e3).tolist(),
                                  "pair_peak_m_s2": _pair_peak(design),
                                  "ratio": ratio.tolist()}
    text = (f"train {worst}: up to {demand[worst] / 1e3:.4g} kN about the feedforward against "
            f"{room[worst] / 1e3:.4g} kN of room in its envelope at the cruise speed")
    if ratio[worst] > 1.0:
        return Check(name="flocking_actuators", status="warn", value=float(ratio[worst]),
                     threshold=1.0, unit="", message=f"{text}: the law may saturate (the "
                     "collision certificate assumes it does not)",
                     hint="lower force_scale_m_s2, a and b, or the gains", details=details)
    return Check(name="flocking_actuators", status="pass", value=float(ratio[worst]),
                 threshold=1.0, unit="", message=text, details=details)


def _supervisor(design: FlockingDesign) -> BrakingSupervisor:
    """The design's braking supervisor (also when the settings leave it off)."""
    from trainctl.controllers.flocking.supervisor import supervisor_of

    return supervisor_of(design.scenario, design.settings, design.control_interval)


def braking_distance_check(design: FlockingDesign) -> Check:
    """``flocking_braking_distance`` at design time: the cruise worst case (module docstring).

    Parameters
    ----------
    design : FlockingDesign
        The family's design (settings, initial errors, control interval).

    Returns
    -------
    Check
        Value: the smallest gap minus its relative braking distance [m];
        pass when >= 0, else fail without the supervisor and warn with it.

    Examples
    --------
    heavy-haul-flocking cruises at 80 km/h (22.2 m/s) with no network: a
    follower needs v·T_c + 50 m = 72.2 m, and the smallest gap is 400 m:

    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.family import design_flocking
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> design = design_flocking(scenario, build_model(scenario),
    ...                          scenario.controllers["flocking"])
    >>> check = braking_distance_check(design)
    >>> check.status, round(check.value, 1), round(check.details["required_m"][0], 1)
    ('pass', 327.8, 72.2)
    """
    sup = _supervisor(design)
    law, n = design.law, design.law.n
    v = float(design.model.settings.speed)
    _, z, _ = initial_errors(design)
    gaps = np.minimum(law.gaps(z), law.potential.desired_gap)
    lag = sup.design_lag()
    follower = [sup.follower_deceleration(i, v) for i in range(1, n)]
    leader = [sup.leader_deceleration(i - 1) for i in range(1, n)]
    required = np.array([relative_braking_distance(
        v, v, follower_deceleration=follower[i - 1], leader_deceleration=leader[i - 1],
        delay=lag, margin=sup.margin) for i in range(1, n)])
    spare = gaps - required
    worst = int(np.argmin(spare))
    value = float(spare[worst])
    on = bool(design.settings.supervisor)
    details: dict[str, object] = {
        "speed_m_s": v, "gaps_m": gaps.tolist(), "required_m": required.tolist(),
        "follower_deceleration_m_s2": follower, "leader_deceleration_m_s2": leader,
        "lag_s": lag, "control_interval_s": sup.interval, "delay_s": sup.delay,
        "outage_s": sup.outage, "margin_m": sup.margin, "supervisor": on}
    outage = f" and a {sup.outage:g} s outage" if sup.outage > 0.0 else ""
    text = (f"follower {worst + 1}: gap {gaps[worst]:.4g} m against the relative braking "
            f"distance {required[worst]:.4g} m at {v * 3.6:.4g} km/h (leader braking at "
            f"{leader[worst]:.3g} m/s², the follower at {follower[worst]:.3g} m/s² after "
            f"{lag:.4g} s: T_c {sup.interval:g} s, delay {sup.delay:g} s{outage}; margin "
            f"{sup.margin:g} m)")
    name = "flocking_braking_distance"
    if value >= 0.0:
        return Check(name=name, status="pass", value=value, threshold=0.0, unit="m",
                     message=f"braking-safe at cruise: {text}", details=details)
    if on:
        return Check(name=name, status="warn", value=value, threshold=0.0, unit="m",
                     message=f"{text}: a leader braking then can be hit unless the follower "
                     "brakes; the supervisor will brake (capacity lost, safety kept)",
                     hint="raise the gap or shorten the outage to keep the formation "
                     "together through it", details=details)
    return Check(name=name, status="fail", value=value, threshold=0.0, unit="m",
                 message=f"{text}: a leader braking then can be hit, and no supervisor "
                 "brakes the follower", hint="raise the gap, shorten the outage "
                 "(supervisor_outage_s) or set supervisor = true", details=details)


def braking_margins(design: FlockingDesign,
                    result: SimulationResult) -> tuple[Array, NDArray[np.bool_]]:
    """The supervisor's rule judged at every control step of a simulation.

    The design's supervisor (on or not in the run) follows the recorded
    states step by step: where a follower's applied force was its full
    braking, its brake-now margin; elsewhere its run-on margin with the
    applied force (:mod:`~trainctl.controllers.flocking.supervisor`). With
    the supervisor on, a run-on step is one the supervisor let pass, so only
    a start that is already unsafe, or a plant that leaves the rule's
    assumptions, gives a negative margin.

    Parameters
    ----------
    design : FlockingDesign
        The family's design.
    result : SimulationResult
        A simulation of its scenario (the samples: states, applied inputs).

    Returns
    -------
    (ndarray, ndarray of bool)
        The margins [m], shape (n-1, N) (follower 1 first, one column per
        step), and where the follower braked at full.

    Examples
    --------
    One step of heavy-haul-flocking's formation cruising at 80 km/h, 500 m
    apart, no network: each follower may run on, with 500 m − 22.2 m/s × 1 s
    − 50 m to spare.

    >>> from types import SimpleNamespace
    >>> from trainctl.design import build_model
    >>> from trainctl.models import equilibrium
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.family import design_flocking
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> design = design_flocking(scenario, build_model(scenario),
    ...                          scenario.controllers["flocking"])
    >>> eq = equilibrium(scenario.train, 80 / 3.6)
    >>> x = eq.state(position=0.0)
    >>> result = SimpleNamespace(states=np.column_stack([x, x]), inputs=eq.inputs[:, None],
    ...                          time=np.array([0.0, 1.0]))
    >>> margins, braking = braking_margins(design, result)
    >>> margins.round(1).tolist(), bool(braking.any())
    ([[427.8], [427.8], [427.8]], False)
    """
    from trainctl.models.actuator import SATURATION_TOLERANCE

    sup = _supervisor(design)
    n = design.law.n
    states = np.asarray(result.states, dtype=float)
    inputs = np.asarray(result.inputs, dtype=float)
    times = np.asarray(result.time, dtype=float)
    steps = inputs.shape[1]
    margins = np.empty((n - 1, steps))
    braking = np.zeros((n - 1, steps), dtype=bool)
    for k in range(steps):
        t, x, u = float(times[k]), states[:, k], inputs[:, k]
        sup.observe(t, x)
        margins[:, k] = sup.run_on_margins(t, x, u)
        full = u[1:] <= sup.full_braking(x[:n])[1:] + SATURATION_TOLERANCE
        if full.any():
            braking[:, k] = full
            margins[full, k] = sup.brake_now_margins(t, x)[full]
    return margins, braking


def _braking_trajectory_check(design: FlockingDesign, strategy: str,
                              result: SimulationResult) -> Check:
    """``flocking_braking_distance`` with the simulated run (module docstring)."""
    from trainctl.controllers.faults import SUPERVISOR_BRAKING

    before = braking_distance_check(design)
    margins, braking = braking_margins(design, result)
    if not margins.size:
        return before
    follower, k = np.unravel_index(int(np.argmin(margins)), margins.shape)
    smallest, at = float(margins[follower, k]), float(result.time[k])
    activations = sum(f == SUPERVISOR_BRAKING for f in result.fallbacks)
    below = float(np.count_nonzero((margins < 0.0).any(axis=0)) * float(result.dt))
    seen: dict[str, object] = {
        "simulated_strategy": strategy, "simulated_min_margin_m": smallest,
        "simulated_min_margin_time_s": at, "simulated_min_margin_follower": int(follower) + 1,
        "simulated_time_below_s": below,
        "simulated_full_braking_steps": int(braking.any(axis=0).sum()),
        "supervisor_activations": int(activations)}
    sim_text = (f"simulated {strategy}: smallest margin {smallest:.4g} m (follower "
                f"{int(follower) + 1} at t = {at:g} s"
                + (f", below 0 for {below:g} s" if below else "")
                + f"); the supervisor braked at {activations} step(s)")
    details = {**before.details, **seen}
    if smallest < 0.0:
        return Check(name=before.name, status="fail", value=smallest, threshold=0.0, unit="m",
                     message=f"below the relative braking distance: {sim_text} "
                     f"({before.message})", hint=before.hint or "set supervisor = true, or "
                     "start with smaller speed errors or wider gaps", details=details)
    return Check(name=before.name, status=before.status, value=before.value,
                 threshold=before.threshold, unit=before.unit,
                 message=f"{before.message}; {sim_text}", hint=before.hint, details=details)


def trajectory_gaps(design: FlockingDesign, result: SimulationResult) -> tuple[float, float]:
    """(smallest, largest) gap [m] along a simulated result of the formation.

    Parameters
    ----------
    design : FlockingDesign
        The family's design (desired gap).
    result : SimulationResult
        A simulation of the scenario (states ``[v, delta, s]`` over time; the
        dense grid when recorded).

    Returns
    -------
    (float, float)
        The extremes of every gap over the recorded states [m]; the
        formation stayed connected when the largest is below the range.

    Examples
    --------
    A stand-in result with two recorded states of four trains: the gap
    deviations z (rows 4–6) are added to the desired gap of 500 m.

    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.family import design_flocking
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> design = design_flocking(scenario, build_model(scenario),
    ...                          scenario.controllers["flocking"])
    >>> from types import SimpleNamespace
    >>> states = np.zeros((8, 2))
    >>> states[4:7] = [[90.0, 0.0], [-100.0, -50.0], [90.0, 20.0]]
    >>> trajectory_gaps(design, SimpleNamespace(states=states, dense_states=None))
    (400.0, 590.0)
    """
    n = design.law.n
    dense = result.dense_states
    states = np.asarray(result.states if dense is None else dense, dtype=float)
    gaps = design.law.gaps(states[n:2 * n - 1])
    return float(np.min(gaps)), float(np.max(gaps))


def trajectory_checks(design: FlockingDesign, strategy: str,
                      result: SimulationResult) -> list[Check]:
    """``flocking_collision``, ``flocking_connectivity`` and ``flocking_braking_distance``.

    Parameters
    ----------
    design : FlockingDesign
        The family's design.
    strategy : str
        The simulated strategy's name.
    result : SimulationResult
        Its simulation on the nonlinear plant.

    Returns
    -------
    list of Check
        Replacing the design review's checks of the same names (module
        docstring).

    Examples
    --------
    With the stand-in result of :func:`trajectory_gaps` (gaps between 400 m
    and 590 m, inside the 600 m interaction range), the gap checks pass (the
    braking distance needs a full result: :func:`braking_margins`):

    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.family import design_flocking
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> design = design_flocking(scenario, build_model(scenario),
    ...                          scenario.controllers["flocking"])
    >>> from types import SimpleNamespace
    >>> states = np.zeros((8, 2))
    >>> states[4:7] = [[90.0, 0.0], [-100.0, -50.0], [90.0, 20.0]]
    >>> result = SimpleNamespace(states=states, dense_states=None, inputs=np.zeros((4, 0)),
    ...                          time=np.zeros(1), fallbacks=())
    >>> collision, connectivity, braking = trajectory_checks(design, "flocking", result)
    >>> collision.details["simulated_min_gap_m"], connectivity.status, connectivity.value
    (400.0, 'pass', 590.0)
    """
    p = design.law.potential
    smallest, widest = trajectory_gaps(design, result)
    energy = initial_energy(design)
    before = collision_check(design, energy)
    seen = {"simulated_strategy": strategy, "simulated_min_gap_m": smallest,
            "simulated_max_gap_m": widest}
    sim_text = f"simulated {strategy}: smallest gap {smallest:.4g} m"
    if smallest <= 0.0:
        collision = Check(name=before.name, status="fail", value=smallest, threshold=0.0,
                          unit="m", message=f"collision: {sim_text} ({before.message})",
                          hint=before.hint or "lower the initial errors or the gains that "
                          "saturate the law", details={**before.details, **seen})
    else:
        collision = Check(name=before.name, status=before.status, value=before.value,
                          threshold=before.threshold, unit=before.unit,
                          message=f"{before.message}; {sim_text}", hint=before.hint,
                          details={**before.details, **seen})
    details: dict[str, object] = {"range_m": p.r, "trajectory": "simulated", **seen}
    name = "flocking_connectivity"
    if widest >= p.r:
        connectivity = Check(name=name, status="fail", value=widest, threshold=p.r, unit="m",
                             message=f"{strategy}: a gap reaches {widest:.4g} m, at or beyond "
                             f"the interaction range {p.r:.4g} m: the formation splits",
                             hint="raise interaction_range_m, the gains or force_scale_m_s2",
                             details=details)
    else:
        connectivity = Check(name=name, status="pass", value=widest, threshold=p.r, unit="m",
                             message=f"every gap within the range along the simulated "
                             f"{strategy} run (widest {widest:.4g} m < {p.r:.4g} m)",
                             details=details)
    return [collision, connectivity, _braking_trajectory_check(design, strategy, result)]
