# Design checks of the synchronous family: delay-free stability, sampling, delay margin.
"""The synchronous family's design checks (spec §4.3 items 1 and 3).

``synchronous_closed_loop``
    Hurwitz test of the delay-free continuous loop A_cl = A₀ + B_r K_r
    (:mod:`trainctl.controllers.synchronous.law`): the whole train's speeds
    and couplers with the lead's speed feedback and the remotes following
    it with mass scaling, as with an instantaneous relay. Pass when every
    eigenvalue has Re λ < 0, fail otherwise.
``synchronous_sampling``
    ω_max·T_c of that loop against 0.1 rad and the spectral radius of the
    loop with the law held over each control interval
    (:func:`trainctl.controllers.continuous.sampled.sampling_check`).
``synchronous_delay_margin``
    The smallest uniform delay τ of the relay at which
    ẋ = A₀x + B_r K_r x(t − τ) loses stability
    (:func:`trainctl.analysis.delay.delay_margin`, two Padé orders), against
    the worst-case delay of the ``[network]`` section (the upper end of
    ``delay_range_s``, or ``delay_s``). Pass when the worst case is below
    the margin, fail when it reaches it (or when the loop is unstable
    without delay, margin 0). Without ``[network]`` the relay is
    instantaneous and there is nothing to compare: warn, with the margin.
    When the two Padé orders disagree by more than 1 % a pass is downgraded
    to warn. The margin is that of one constant delay on every remote link;
    delays drawn per message are a time-varying delay, which a
    constant-delay margin does not certify, and the relay is read at the
    control samples, which rounds each delay up to a whole number of
    intervals (the rounded worst case is in the details).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from trainctl.analysis.check import Check
from trainctl.controllers.continuous.delay import delay_margin_check
from trainctl.controllers.continuous.loops import hurwitz_check
from trainctl.controllers.continuous.sampled import sampling_check as shared_sampling_check

if TYPE_CHECKING:
    from trainctl.controllers.synchronous.family import SynchronousDesign

__all__ = ["closed_loop_check", "delay_check", "sampling_check", "synchronous_checks"]


def synchronous_checks(design: SynchronousDesign) -> list[Check]:
    """The three checks (module docstring).

    Parameters
    ----------
    design : SynchronousDesign
        The family's design.

    Returns
    -------
    list of Check
        In :data:`~trainctl.controllers.synchronous.family.CHECK_NAMES` order.

    Examples
    --------
    >>> from trainctl.controllers.synchronous.family import design_synchronous
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_synchronous(scenario, build_model(scenario), SynchronousSettings())
    >>> [(c.name, c.status) for c in synchronous_checks(design)]  # doctest: +NORMALIZE_WHITESPACE
    [('synchronous_closed_loop', 'pass'), ('synchronous_sampling', 'warn'),
     ('synchronous_delay_margin', 'warn')]
    """
    return [closed_loop_check(design), sampling_check(design), delay_check(design)]


def closed_loop_check(design: SynchronousDesign) -> Check:
    """Hurwitz test of the delay-free continuous loop.

    Parameters
    ----------
    design : SynchronousDesign
        The family's design.

    Returns
    -------
    Check
        The named check of the closed loop's stability, with its status, value and hint.

    Examples
    --------
    >>> from trainctl.controllers.synchronous.family import design_synchronous
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_synchronous(scenario, build_model(scenario), SynchronousSettings())
    >>> check = closed_loop_check(design)
    >>> check.status, round(check.value, 4), check.unit  # max Re λ, time constant 35.4 s
    ('pass', -0.0282, '1/s')
    """
    return hurwitz_check(
        "synchronous_closed_loop", design.loops.A_cl,
        unstable="delay-free closed loop not Hurwitz: max Re λ = {alpha:.4g} 1/s",
        stable="delay-free continuous closed loop Hurwitz: max Re λ = {alpha:.4g} 1/s "
        "(slowest mode, time constant {tau:.4g} s)",
        hint="lower speed_gain_per_s (the lead's loop excites the couplers)")


def sampling_check(design: SynchronousDesign) -> Check:
    """ω_max·T_c against 0.1 rad; the held loop's spectral radius.

    Parameters
    ----------
    design : SynchronousDesign
        The family's design.

    Returns
    -------
    Check
        The named check of sampling, with its status, value and hint.

    Examples
    --------
    The fastest mode (the couplers, ω_max ≈ 4.06 rad/s) turns by 0.406 rad
    in one 0.1 s interval, beyond the 0.1 rad rule; the held loop is stable,
    so the check warns.

    >>> from trainctl.controllers.synchronous.family import design_synchronous
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_synchronous(scenario, build_model(scenario), SynchronousSettings())
    >>> check = sampling_check(design)
    >>> check.status, round(check.value, 3), check.threshold
    ('warn', 0.406, 0.1)
    """
    return shared_sampling_check("synchronous_sampling", design.loops.A_cl,
                                 design.sampled_matrix(), design.control_interval)


def delay_check(design: SynchronousDesign) -> Check:
    """The relay's delay margin against the ``[network]`` worst-case delay.

    Parameters
    ----------
    design : SynchronousDesign
        The family's design.

    Returns
    -------
    Check
        The named check of the delay margin, with its status, value and hint.

    Examples
    --------
    Without ``[network]`` the relay is instantaneous: the margin is
    reported, with no delay to compare it with.

    >>> from trainctl.controllers.synchronous.family import design_synchronous
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_synchronous(scenario, build_model(scenario), SynchronousSettings())
    >>> check = delay_check(design)
    >>> check.status, round(check.value, 1), check.unit  # delay margin
    ('warn', 26.9, 's')
    """
    return delay_margin_check(
        "synchronous_delay_margin", design.delay, design.worst_delay,
        details={"worst_delay_sampled": design.worst_delay_sampled},
        closed_loop="synchronous_closed_loop", unconnected_subject=" of the relayed command",
        unconnected="the relay is instantaneous, nothing to compare",
        destabilises="the remotes' delayed copy of the lead's command can destabilise the train",
        unconnected_hint="add a [network] section with the radio link's delays",
        fail_hint="lower speed_gain_per_s, or shorten the link's delays")
