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
    (:func:`trainctl.controllers.sampled.sampling_check`).
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
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ...analysis.check import Check
from ..sampled import closed_loop_spectrum
from ..sampled import sampling_check as shared_sampling_check

if TYPE_CHECKING:
    from .family import HinfDesign

__all__ = ["closed_loop_check", "connectivity_check", "delay_check", "hinf_checks",
           "sampling_check"]


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
    """The four checks (module docstring).

    Parameters
    ----------
    design : HinfDesign
        The family's design.

    Returns
    -------
    list of Check
        In :data:`~trainctl.controllers.hinf.family.CHECK_NAMES` order.
    """
    return [closed_loop_check(design), sampling_check(design), delay_check(design),
            connectivity_check(design)]


def closed_loop_check(design: HinfDesign) -> Check:
    """Hurwitz test of the delay-free continuous loop."""
    spectrum = closed_loop_spectrum(design.loops.A_cl)
    lam = spectrum.eigenvalues
    alpha = float(max(lam.real))
    unreached = design.graph.unreached()
    details: dict[str, object] = {"max_real_part": alpha,
                                  "eigenvalues": [[float(x.real), float(x.imag)] for x in lam],
                                  "unreached_vehicles": [i + 1 for i in unreached]}
    name = "hinf_closed_loop"
    if alpha >= -spectrum.tol:
        tree = ("" if not unreached else
                f"; the [communication] graph has no spanning tree rooted at the reference "
                f"(it does not reach {_vehicles(unreached)}), which leader-following "
                "consensus needs")
        hint = ("pin more vehicles or add links so that the reference reaches every vehicle"
                if unreached else "lower kappa_p_per_s and kappa_c_per_s")
        return Check(name=name, status="fail", value=alpha, threshold=0.0, unit="1/s",
                     message=f"delay-free closed loop not Hurwitz: max Re λ = {alpha:.4g} 1/s"
                     + tree, hint=hint, details=details)
    note = ("" if not unreached else
            f"; the graph does not reach {_vehicles(unreached)}, the couplers carry the "
            "pinning to them")
    return Check(name=name, status="pass", value=alpha, threshold=0.0, unit="1/s",
                 message=f"delay-free continuous closed loop Hurwitz: max Re λ = {alpha:.4g} 1/s "
                 f"(slowest mode, time constant {-1.0 / alpha:.4g} s){note}",
                 details=details)


def sampling_check(design: HinfDesign) -> Check:
    """ω_max·T_c against 0.1 rad; the held loop's spectral radius."""
    return shared_sampling_check("hinf_sampling", design.loops.A_cl,
                                 design.sampled_matrix(), design.control_interval)


def _bound_text(design: HinfDesign, margin: float) -> str:
    """The first-order consensus bound and how the full margin compares with it."""
    bound = design.consensus_bound
    if bound is None:
        return ("; the first-order consensus bound π/(2λ_max(κ_p P + κ_c L)) needs an "
                "undirected graph")
    text = f"; first-order consensus bound π/(2λ_max(κ_p P + κ_c L)) = {bound:.4g} s"
    if math.isfinite(margin) and margin < bound:
        text += (f", {bound / margin:.3g}× the full margin: the coupler modes make the full "
                 "margin smaller")
    return text


def delay_check(design: HinfDesign) -> Check:
    """The full loop's delay margin against the ``[network]`` worst-case delay."""
    name = "hinf_delay_margin"
    res = design.delay
    margin = res.margin
    worst = design.worst_delay
    details: dict[str, object] = {**res.to_dict(), "worst_delay": worst,
                                  "consensus_bound": design.consensus_bound,
                                  "own_speed": design.law.own_speed}
    shown = (f"{margin:.4g} s" if math.isfinite(margin)
             else f"above {res.tau_max:g} s (stable up to the end of the search)")
    crossing = ("" if math.isnan(res.crossing_frequency)
                else f", crossing at {res.crossing_frequency:.3g} rad/s")
    orders = ("" if res.agree else
              f"; the Padé orders {res.orders[0]} and {res.orders[1]} disagree "
              f"({res.margins[0]:.4g} s against {res.margins[1]:.4g} s)")
    bound = _bound_text(design, margin)
    what = ("every pinning and consensus difference" if design.law.own_speed == "delayed"
            else "the neighbours' speeds")
    if margin == 0.0:
        return Check(name=name, status="fail", value=0.0, threshold=worst, unit="s",
                     message="the loop is unstable without delay: no delay margin",
                     hint="see hinf_closed_loop", details=details)
    if worst is None:
        return Check(name=name, status="warn", value=margin, threshold=None, unit="s",
                     message=f"delay margin of the full coupled loop {shown}{crossing}{bound}; "
                     "no [network]: the data arrive when sent, nothing to compare" + orders,
                     hint="add a [network] section with the radio links' delays",
                     details=details)
    if worst >= margin:
        return Check(name=name, status="fail", value=margin, threshold=worst, unit="s",
                     message=f"delay margin of the full coupled loop {shown}{crossing} ≤ the "
                     f"[network] worst-case delay {worst:g} s: delayed data in {what} can "
                     f"destabilise the train{bound}" + orders,
                     hint="lower kappa_p_per_s and kappa_c_per_s, or shorten the links' delays",
                     details=details)
    status = "pass" if res.agree else "warn"
    return Check(name=name, status=status, value=margin, threshold=worst, unit="s",
                 message=f"delay margin of the full coupled loop {shown}{crossing} > the "
                 f"[network] worst-case delay {worst:g} s{bound}" + orders,
                 hint="" if res.agree else "raise the Padé orders to settle the margin",
                 details=details)


def connectivity_check(design: HinfDesign) -> Check:
    """Joint connectivity after every interruption window of ``[network]``."""
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
