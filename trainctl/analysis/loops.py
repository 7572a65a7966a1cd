# Every linear closed loop of a run, in the frequency and the time domain.
"""The frequency-domain view and the grade-step responses of a run's strategies.

:func:`analyse_closed_loops` takes each strategy's linear closed loop from the
run's design (``Design.closed_loop``) and returns its
:class:`~trainctl.analysis.frequency.FrequencyResult` (with the run's
discrete design model as the plant, for S and T), its
:class:`~trainctl.analysis.steps.StepResult` and its
:class:`~trainctl.analysis.string_stability.StringStabilityResult`. ``trainctl analyse --json``
prints their numbers under ``frequency``; the report draws their curves.

A family whose closed loop is continuous (dt = 0, e.g. the potential
family's) is sampled first (:func:`as_discrete`: zero-order hold on the
disturbance at ``[model].sample_time``), so that every loop is analysed on
the same unit circle; below the Nyquist frequency π/T its response is the
continuous one up to the hold. Such a loop is not state feedback around the
discrete plant, so it has no S and T (:func:`~trainctl.analysis.sensitivity.loop_sensitivity`
returns None for it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import control as ct

from trainctl.analysis.frequency import FrequencyResult, analyse_frequency
from trainctl.analysis.steps import StepResult, analyse_grade_step, step_duration
from trainctl.analysis.string_stability import StringStabilityResult, string_stability

if TYPE_CHECKING:
    from trainctl.design import Design

__all__ = ["ClosedLoopResponse", "analyse_closed_loops", "as_discrete", "loop_strategies"]


@dataclass(frozen=True, kw_only=True, eq=False)
class ClosedLoopResponse:
    """Frequency and grade-step responses of one strategy's linear closed loop.

    Parameters
    ----------
    strategy : str
        The strategy (as ``[simulation] strategies`` names it).
    frequency : FrequencyResult
        Singular values, sensitivities, peaks and bandwidth.
    steps : StepResult
        Responses to 1 ‰ grade steps.
    string : StringStabilityResult or None
        Peak gains from the head's disturbance along the train (None with a
        single vehicle).

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> design = build_design(load_scenario("crh2-dmpc"))
    >>> res = analyse_closed_loops(design, ["centralised"])["centralised"]
    >>> res.strategy, res.frequency.dt, res.string is not None  # T = 20 s, 4 coaches
    ('centralised', 20.0, True)
    >>> d = res.to_dict()
    >>> d["sample_time"], d["grade_step"]["grade_permille"]
    (20.0, 1.0)
    """

    strategy: str
    frequency: FrequencyResult
    steps: StepResult
    string: StringStabilityResult | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe numbers: frequency peaks, bandwidth, ``grade_step``, ``string_stability``.

        Returns
        -------
        dict
            The entries of :meth:`FrequencyResult.to_dict
            <trainctl.analysis.frequency.FrequencyResult.to_dict>`, plus
            ``grade_step`` (the step responses' numbers) and
            ``string_stability`` (None with a single vehicle).
        """
        string = None if self.string is None else self.string.to_dict()
        return {**self.frequency.to_dict(), "grade_step": self.steps.to_dict(),
                "string_stability": string}

    def curves(self) -> dict[str, Any]:
        """JSON-safe curves for the report: ``frequency``, ``steps`` and ``string``.

        Returns
        -------
        dict
            ``frequency``, ``steps`` and ``string``: each result's
            ``curves()`` (``string`` None with a single vehicle).
        """
        string = None if self.string is None else self.string.curves()
        return {"frequency": self.frequency.curves(), "steps": self.steps.curves(),
                "string": string}


def loop_strategies(design: Design) -> tuple[str, ...]:
    """The strategies whose loops a run analyses.

    Parameters
    ----------
    design : Design
        The run's design.

    Returns
    -------
    tuple of str
        ``[simulation] strategies`` when the scenario has them, else every
        strategy of its controller families (other than the primary family's
        as ``"family.strategy"``); empty without a controller.

    Examples
    --------
    >>> import dataclasses
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("crh2-potential")
    >>> loop_strategies(build_design(sc))  # as listed in [simulation]
    ('consensus', 'mpc.ndmpc', 'lqr.centralised')

    Without a ``[simulation]``, every strategy of every family, the
    secondary families' prefixed; without a controller, none:

    >>> loop_strategies(build_design(dataclasses.replace(sc, simulation=None)))[:3]
    ('consensus', 'mpc.centralised', 'mpc.decentralised')
    >>> loop_strategies(build_design(load_scenario("heavy-haul-hinf")))
    ()
    """
    from trainctl.registry import get_family

    sim = design.scenario.simulation
    if sim is not None:
        return tuple(sim.strategies)
    names: list[str] = []
    for k, family in enumerate(design.families):
        prefix = "" if k == 0 else f"{family}."
        names += [prefix + s for s in get_family(family).strategies]
    return tuple(names)


def analyse_closed_loops(
    design: Design, strategies: Sequence[str] | None = None
) -> dict[str, ClosedLoopResponse]:
    """Frequency and grade-step responses of each strategy's linear closed loop.

    Parameters
    ----------
    design : Design
        The run's design (:func:`trainctl.design.build_design`).
    strategies : sequence of str or None
        The strategies; None: :func:`loop_strategies`.

    Returns
    -------
    dict of str to ClosedLoopResponse
        By strategy, in order; strategies whose loop is not linear (the
        family's ``closed_loop`` returns None) are left out. The step
        responses share one duration (:func:`~trainctl.analysis.steps.step_duration`).

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> loops = analyse_closed_loops(build_design(load_scenario("crh2-dmpc")))
    >>> list(loops), loops["ndmpc"].frequency.dt
    (['centralised', 'decentralised', 'ndmpc'], 20.0)
    """
    names = loop_strategies(design) if strategies is None else tuple(strategies)
    dt = float(design.model.settings.sample_time)
    loops = {name: design.closed_loop(name) for name in names}
    linear = {name: as_discrete(loop, dt) for name, loop in loops.items() if loop is not None}
    if not linear:
        return {}
    duration = step_duration(list(linear.values()))
    plant = design.model.discrete
    return {name: ClosedLoopResponse(strategy=name,
                                     frequency=analyse_frequency(loop, plant=plant),
                                     steps=analyse_grade_step(loop, duration=duration),
                                     string=_string(loops[name]))
            for name, loop in linear.items()}


def _string(loop: Any) -> StringStabilityResult | None:
    """:func:`string_stability` from the head's disturbance, when there is a train to judge."""
    if loop.ninputs < 2 or "w[0]" not in loop.input_labels:
        return None
    return string_stability(loop)


def as_discrete(loop: ct.StateSpace, dt: float) -> ct.StateSpace:
    """A discrete loop as it is; a continuous one sampled at ``dt`` (zero-order hold).

    Parameters
    ----------
    loop : control.StateSpace
        A closed loop (``Design.closed_loop``).
    dt : float
        Sample time [s], > 0, for a continuous loop.

    Returns
    -------
    control.StateSpace
        Discrete, with the loop's signal names.

    Examples
    --------
    >>> sys = ct.ss([[-1.0]], [[1.0]], [[1.0]], 0, inputs="w[0]", outputs="v[0]")
    >>> d = as_discrete(sys, 0.1)
    >>> d.dt, round(float(d.A[0, 0]), 6), d.output_labels
    (0.1, 0.904837, ['v[0]'])
    """
    if loop.isdtime(strict=True):
        return loop
    return ct.sample_system(loop, dt, method="zoh", name=str(loop.name))
