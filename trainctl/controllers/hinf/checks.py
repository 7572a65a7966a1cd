# Design checks of the hinf family: delay-free stability, sampling, delay margin, connectivity.
"""The hinf family's design checks (spec §4.3 items 1, 3 and 4).

``hinf_closed_loop``
    Hurwitz test of the delay-free continuous loop A_cl = A + B F
    (:mod:`trainctl.controllers.hinf.law`): speeds and couplers with the
    pinning and consensus feedback on current data (an ideal network).
    Pass when every eigenvalue has Re λ < 0 (asymptotic tracking of a
    constant reference, w = 0), fail otherwise; a failing message says
    when the ``[communication]`` graph has no spanning tree rooted at the
    reference (the vehicles it does not reach), which leaderless speed
    consensus needs.
``hinf_sampling``
    ω_max·T_c of that loop against 0.1 rad and the spectral radius of the
    loop with the law held over each control interval
    (:func:`trainctl.controllers.continuous.sampled.sampling_check`).
``hinf_delay_margin``
    The smallest uniform delay τ of every message at which the *full*
    coupled loop ẋ = A₀x + B K x(t − τ) loses stability
    (:func:`trainctl.analysis.delay.delay_margin`, two Padé orders), against
    the worst-case delay of the ``[network]`` section (the upper end of
    ``delay_range_s``, or ``delay_s``). Pass when the worst case is below
    the margin, fail when it reaches it (or when the loop is unstable
    without delay, margin 0); without ``[network]`` warn, with the margin.
    When the two Padé orders disagree by more than 1 % a pass becomes a
    warn. The message also gives the first-order consensus bound
    π/(2 λ_max(κ_p P + κ_c L)) (:func:`trainctl.analysis.delay.consensus_delay_bound`,
    undirected graphs only), which ignores the couplers: their modes make
    the full margin smaller (spec §4.3 item 3). The margin is that of one
    constant delay; delays drawn per message are time-varying, which it
    does not certify. Against ``delay_range_s`` the comparison is
    conservative: a receiver holds the newest message by send time, so with
    a speed sent every sample the age of the data it acts on is mostly far
    below the range's upper end (for [0, 2] s and 0.1 s samples: about
    0.5 s on average, 1.2 s at the 99th percentile).
``hinf_connectivity``
    The interruption windows of ``[network]`` over the run
    (:func:`trainctl.analysis.connectivity.joint_connectivity`, run length
    the ``[simulation]`` duration): pass when no window cuts a vehicle off
    from the reference, or every vehicle cut off is reached again after its
    window (the graph is jointly connected afterwards, so tracking is
    restored); fail when one is not (a cut lasting to the end of the run),
    or when the graph itself leaves a vehicle unreached. Vehicles are
    numbered from 1 in the message. Without ``[simulation]`` the run is
    taken to last beyond the last window.
``hinf_gamma``
    The certified H∞ gain γ of the gains in use (synthesised or given) from
    the scaled disturbances (force per unit mass, reference and link noise;
    ``force_scale_m_s2``, ``noise_scale_m_s``) to the scaled performance
    output (``output_scale_m_s``), against 1, the paper's requirement
    (spec §4.2): the bounded-real lemma delay-free, or the
    Lyapunov–Krasovskii LMI for every constant delay in [0, τ_max] with
    ``delay_certificate_s`` (:mod:`trainctl.controllers.hinf.synthesis`). Pass
    when γ <= 1, fail when γ > 1, naming the channel groups whose own γ
    exceeds 1 and saying that the verdict depends on the scaling (with the
    tracking output a common reference noise reaches the speed errors with
    gain 1 at DC whatever the gains, so equal noise and output scales leave
    γ >= 1); fail also when nothing is certified because the loop is
    unstable (the independent norm is infinite, delay-free or at a Padé
    delay in the range); warn when the SDP certified nothing although the
    independent norms are finite (solver trouble or the LMI's conservatism,
    recorded), when a requested synthesis certified nothing, or when an
    independent norm exceeds the certified γ. The independent closed-loop
    norm (:func:`~trainctl.analysis.hinf.hinf_norm`, and the Padé loops
    with a delay range) stands beside γ in the message and the details.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from trainctl.analysis.check import Check
from trainctl.controllers.continuous.delay import delay_margin_check
from trainctl.controllers.continuous.loops import hurwitz_check
from trainctl.controllers.continuous.sampled import sampling_check as shared_sampling_check

if TYPE_CHECKING:
    from trainctl.controllers.hinf.family import HinfDesign

__all__ = ["closed_loop_check", "connectivity_check", "delay_check", "gamma_check",
           "hinf_checks", "sampling_check"]

GROUP_NAMES = {"force": "force", "reference": "reference-noise", "link": "link-noise"}
"""Channel groups in words."""


def _vehicles(indices: tuple[int, ...] | list[int]) -> str:
    """Vehicles numbered from 1: ``"vehicle 2"``, ``"vehicles 2, 3 and 4"``.

    Examples
    --------
    >>> _vehicles((1,)), _vehicles([1, 2, 3])
    ('vehicle 2', 'vehicles 2, 3 and 4')
    """
    numbers = [str(int(i) + 1) for i in indices]
    if len(numbers) == 1:
        return f"vehicle {numbers[0]}"
    return f"vehicles {', '.join(numbers[:-1])} and {numbers[-1]}"


def hinf_checks(design: HinfDesign) -> list[Check]:
    """The five checks (module docstring).

    Parameters
    ----------
    design : HinfDesign
        The family's design.

    Returns
    -------
    list of Check
        In :data:`~trainctl.controllers.hinf.family.CHECK_NAMES` order.

    Examples
    --------
    >>> from trainctl.controllers.hinf.family import design_hinf
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_hinf(scenario, build_model(scenario), HinfSettings())
    >>> [(c.name, c.status) for c in hinf_checks(design)]  # doctest: +NORMALIZE_WHITESPACE
    [('hinf_closed_loop', 'pass'), ('hinf_sampling', 'warn'), ('hinf_delay_margin', 'warn'),
     ('hinf_connectivity', 'pass'), ('hinf_gamma', 'fail')]
    """
    return [closed_loop_check(design), sampling_check(design), delay_check(design),
            connectivity_check(design), gamma_check(design)]


def closed_loop_check(design: HinfDesign) -> Check:
    """Hurwitz test of the delay-free continuous loop.

    Parameters
    ----------
    design : HinfDesign
        The family's design.

    Returns
    -------
    Check
        The named check of the closed loop's stability, with its status, value and hint.

    Examples
    --------
    Every vehicle is pinned with κ_p = 0.1 1/s, so the slowest mode (all
    speeds together) decays at -κ_p:

    >>> from trainctl.controllers.hinf.family import design_hinf
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_hinf(scenario, build_model(scenario), HinfSettings())
    >>> check = closed_loop_check(design)
    >>> check.status, round(check.value, 4), check.unit  # max Re λ
    ('pass', -0.1, '1/s')
    """
    unreached = design.graph.unreached()
    tree = ("" if not unreached else
            f"; the [communication] graph has no spanning tree rooted at the reference "
            f"(it does not reach {_vehicles(unreached)}), which leader-following "
            "consensus needs")
    hint = ("pin more vehicles or add links so that the reference reaches every vehicle"
            if unreached else "lower kappa_p_per_s and kappa_c_per_s")
    note = ("" if not unreached else
            f"; the graph does not reach {_vehicles(unreached)}, the couplers carry the "
            "pinning to them")
    return hurwitz_check(
        "hinf_closed_loop", design.loops.A_cl,
        unstable="delay-free closed loop not Hurwitz: max Re λ = {alpha:.4g} 1/s",
        stable="delay-free continuous closed loop Hurwitz: max Re λ = {alpha:.4g} 1/s "
        "(slowest mode, time constant {tau:.4g} s)", hint=hint,
        unstable_note=tree, stable_note=note,
        details={"unreached_vehicles": [i + 1 for i in unreached]})


def sampling_check(design: HinfDesign) -> Check:
    """ω_max·T_c against 0.1 rad; the held loop's spectral radius.

    Parameters
    ----------
    design : HinfDesign
        The family's design.

    Returns
    -------
    Check
        The named check of sampling, with its status, value and hint.

    Examples
    --------
    The fastest mode, ω_max = 4.06 rad/s, turns by 0.406 rad in one 0.1 s
    interval: beyond the 0.1 rad rule, so the check warns.

    >>> from trainctl.controllers.hinf.family import design_hinf
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_hinf(scenario, build_model(scenario), HinfSettings())
    >>> check = sampling_check(design)
    >>> check.status, round(check.value, 3), check.threshold, check.unit
    ('warn', 0.406, 0.1, 'rad')
    """
    return shared_sampling_check("hinf_sampling", design.loops.A_cl,
                                 design.sampled_matrix(), design.control_interval)


def _bound_text(design: HinfDesign, margin: float) -> str:
    """The first-order consensus bound and how the full margin compares with it."""
    bound = design.consensus_bound
    if bound is None:
        return ("; the first-order consensus bound π/(2λ_max(κ_p P + κ_c L)) needs an "
                "undirected graph")
    text = f"; first-order consensus bound π/(2λ_max(κ_p P + κ_c L)) = {bound:.4g} s"
    if math.isfinite(margin) and 0.0 < margin < bound:   # a zero margin has no ratio
        text += (f", {bound / margin:.3g}× the full margin: the coupler modes make the full "
                 "margin smaller")
    return text


def delay_check(design: HinfDesign) -> Check:
    """The full loop's delay margin against the ``[network]`` worst-case delay.

    Parameters
    ----------
    design : HinfDesign
        The family's design.

    Returns
    -------
    Check
        The named check of the delay margin, with its status, value and hint.

    Examples
    --------
    The scenario has no ``[network]`` section: the margin is reported, with
    no worst-case delay to compare it with.

    >>> from trainctl.controllers.hinf.family import design_hinf
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_hinf(scenario, build_model(scenario), HinfSettings())
    >>> check = delay_check(design)
    >>> check.status, round(check.value, 2), check.unit  # delay margin
    ('warn', 0.57, 's')
    """
    what = ("every pinning and consensus difference" if design.law.own_speed == "delayed"
            else "the neighbours' speeds")
    return delay_margin_check(
        "hinf_delay_margin", design.delay, design.worst_delay,
        details={"consensus_bound": design.consensus_bound, "own_speed": design.law.own_speed},
        closed_loop="hinf_closed_loop", subject=" of the full coupled loop",
        unconnected="the data arrive when sent, nothing to compare",
        destabilises=f"delayed data in {what} can destabilise the train",
        note=_bound_text(design, design.delay.margin),
        unconnected_hint="add a [network] section with the radio links' delays",
        fail_hint="lower kappa_p_per_s and kappa_c_per_s, or shorten the links' delays")


def connectivity_check(design: HinfDesign) -> Check:
    """Joint connectivity after every interruption window of ``[network]``.

    Parameters
    ----------
    design : HinfDesign
        The family's design.

    Returns
    -------
    Check
        The named check of connectivity, with its status, value and hint.

    Examples
    --------
    >>> from trainctl.controllers.hinf.family import design_hinf
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_hinf(scenario, build_model(scenario), HinfSettings())
    >>> check = connectivity_check(design)  # no [network]: no interruption window
    >>> check.status, check.value, check.unit
    ('pass', 0.0, 'vehicles')
    """
    name = "hinf_connectivity"
    windows = design.connectivity
    unreached = design.graph.unreached()
    details: dict[str, object] = {"windows": [w.to_dict() for w in windows],
                                  "duration": design.run_length,
                                  "unreached_vehicles": [i + 1 for i in unreached]}
    if unreached:
        return Check(name=name, status="fail", value=float(len(unreached)), threshold=0.0,
                     unit="vehicles",
                     message=f"the reference does not reach {_vehicles(unreached)} over the "
                     "[communication] graph even without an interruption",
                     hint="pin more vehicles or add links", details=details)
    cut = [w for w in windows if w.cut_off]
    lost = [w for w in cut if not w.recovered]
    length = ("" if design.scenario.simulation is not None
              else " (no [simulation]: the run is taken to last beyond the last window)")
    if not windows:
        return Check(name=name, status="pass", value=0.0, threshold=0.0, unit="vehicles",
                     message="no interruption window: the reference reaches every vehicle "
                     "over the [communication] graph throughout", details=details)
    if lost:
        text = "; ".join(
            f"window {w.window + 1} [{w.start:g}, {w.end:g}) s cuts off "
            f"{_vehicles(w.cut_off)}, not reached again before the run ends at "
            f"{design.run_length:g} s" for w in lost)
        vehicles = sorted({i for w in lost for i in w.cut_off})
        return Check(name=name, status="fail", value=float(len(vehicles)), threshold=0.0,
                     unit="vehicles",
                     message=f"not jointly connected after an outage: {text}; their tracking "
                     "is not restored" + length,
                     hint="end the interruption before the run does, or keep another path "
                     "from the reference to the vehicles it cuts off", details=details)
    if not cut:
        return Check(name=name, status="pass", value=0.0, threshold=0.0, unit="vehicles",
                     message=f"{len(windows)} interruption window(s), none cuts a vehicle off "
                     "from the reference" + length, details=details)
    text = "; ".join(f"window {w.window + 1} [{w.start:g}, {w.end:g}) s cuts off "
                     f"{_vehicles(w.cut_off)}, reached again from {w.recovery_time:g} s"
                     for w in cut)
    return Check(name=name, status="pass", value=0.0, threshold=0.0, unit="vehicles",
                 message=f"jointly connected after every outage: {text}; tracking is restored "
                 "after each window" + length, details=details)


def _g(x: float) -> str:
    return f"{x:.4g}" if math.isfinite(x) else "∞"


def _near(x: float) -> str:
    """γ of a group, ``"≈ 1, on the DC floor"`` just above 1."""
    return "≈ 1, on the DC floor" if 1.0 < x < 1.001 else _g(x)


def gamma_check(design: HinfDesign) -> Check:
    """The certified γ of the gains in use against 1, per group, with the independent norms.

    Parameters
    ----------
    design : HinfDesign
        The family's design.

    Returns
    -------
    Check
        The named check of the certified γ, with its status, value and hint.

    Examples
    --------
    With a force disturbance of 1 m/s² per unit mass and pinning
    κ_p = 0.1 1/s, the speed error settles at 1/κ_p = 10 m/s per 1 m/s²:
    γ ≈ 10 > 1, so the check fails.

    >>> from trainctl.controllers.hinf.family import design_hinf
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_hinf(scenario, build_model(scenario), HinfSettings())
    >>> check = gamma_check(design)
    >>> check.status, round(check.value, 1), check.threshold
    ('fail', 10.1, 1.0)
    """
    name = "hinf_gamma"
    res = design.gamma
    s = design.settings
    gamma = res.gamma
    groups = {g: c.gamma for g, c in res.group_certificates.items()}
    scaling = {"force_m_s2": float(s.force_scale), "noise_m_s": float(s.noise_scale),
               "output_m_s": float(s.output_scale)}
    pade = [(tau, r.norm) for tau, r in res.pade_norms]
    details: dict[str, object] = {
        "gamma": gamma if math.isfinite(gamma) else None,
        "groups": {g: (v if math.isfinite(v) else None) for g, v in groups.items()},
        "norm": res.norm.norm if math.isfinite(res.norm.norm) else None,
        "pade_norms": [[tau, v if math.isfinite(v) else None] for tau, v in pade],
        "scaling": scaling, "performance": s.performance, "kappa_p": design.law.kappa_p,
        "kappa_c": design.law.kappa_c, "gains": design.gains_source,
        "delay_certificate": res.tau_max, "own_speed": design.law.own_speed,
        "trouble": list(res.trouble), "synthesis_error": design.synthesis_error,
        "synthesis": res.to_dict(), "consistent": res.consistent}
    where = ("delay-free" if res.tau_max is None
             else f"for every constant delay in [0, {res.tau_max:g}] s")
    scale_text = (f"scaling: force {s.force_scale:g} m/s², noise {s.noise_scale:g} m/s, output "
                  f"{s.output_scale:g} m/s ({s.performance})")
    gains = (f"κ_p = {design.law.kappa_p:.4g}, κ_c = {design.law.kappa_c:.4g} 1/s "
             f"({design.gains_source})")
    per_group = ", ".join(f"{GROUP_NAMES[g]} {_g(v)}" for g, v in groups.items())
    independent = f"independent closed-loop ‖T‖∞ {_g(res.norm.norm)} without delay"
    if pade:
        independent += (", Padé loops " + ", ".join(f"{_g(v)} at {tau:.3g} s"
                                                    for tau, v in pade))
    trouble = ("" if not res.trouble else
               f"; a solver status other than optimal at {len(res.trouble)} solve(s) (unstable "
               "or uncertifiable points of a search, inaccurate solves), each recorded in the "
               "details' trouble")
    failed = ("" if not design.synthesis_error else
              f"; the requested synthesis certified nothing ({design.synthesis_error}), so the "
              "given gains are used")
    hint_scale = ("set force_scale_m_s2, noise_scale_m_s and output_scale_m_s to the "
                  "disturbance and error sizes that matter")
    if not math.isfinite(gamma):
        unstable = not math.isfinite(res.norm.norm) or any(not math.isfinite(v)
                                                           for _, v in pade)
        statuses = sorted({res.certificate.status})
        if unstable:
            at = ("without delay" if not math.isfinite(res.norm.norm) else
                  "at " + ", ".join(f"{tau:.3g} s" for tau, v in pade if not math.isfinite(v)))
            return Check(name=name, status="fail", value=math.inf, threshold=1.0, unit="-",
                         message=f"no γ certified {where} at {gains}: the loop is unstable "
                         f"{at} (‖T‖∞ = ∞); {scale_text}{failed}{trouble}",
                         hint="lower kappa_p_per_s and kappa_c_per_s (or their bounds), or "
                         "shorten delay_certificate_s", details=details)
        return Check(name=name, status="warn", value=math.inf, threshold=1.0, unit="-",
                     message=f"the SDP certified no γ {where} at {gains} (solver status "
                     f"{', '.join(statuses)}: solver trouble or the LMI's conservatism) although "
                     f"the {independent} are finite; {scale_text}{failed}{trouble}",
                     hint="see the details' trouble; a shorter delay_certificate_s may be "
                     "certified", details=details)
    consistent = "" if res.consistent else (
        "; an independent norm EXCEEDS the certified γ (a certificate that does not hold)")
    status_extra = "warn" if (design.synthesis_error or not res.consistent) else None
    text = (f"certified γ = {gamma:.4g} {where} at {gains} (per group: {per_group}); "
            f"{independent}; {scale_text}")
    if gamma <= 1.0:
        return Check(name=name, status=status_extra or "pass", value=gamma, threshold=1.0,
                     unit="-", message=f"{text} ≤ 1{failed}{consistent}{trouble}",
                     hint="" if status_extra is None else "see the message", details=details)
    over = [g for g, v in groups.items() if v > 1.0]
    over_text = (" and ".join(f"the {GROUP_NAMES[g]} channels (γ {_near(groups[g])})"
                              for g in over) if over else
                 "no group alone, only the channels together")
    floor = ""
    if (s.performance == "tracking"
            and groups.get("reference", 0.0) >= 0.99 * s.noise_scale / s.output_scale):
        floor = (f"; at DC the tracking error follows a noise common to every received "
                 f"reference with gain 1 whatever the gains, so the reference-noise channels "
                 f"cannot get below ≈ {s.noise_scale / s.output_scale:.3g} (noise scale / "
                 "output scale)")
    return Check(name=name, status="fail", value=gamma, threshold=1.0, unit="-",
                 message=f"{text} > 1: exceeded by {over_text}; the verdict depends on the "
                 f"scaling, which the paper does not give{floor}{failed}{consistent}{trouble}",
                 hint=hint_scale if not s.synthesise else
                 f"{hint_scale}, or widen kappa_p_bounds_per_s", details=details)
