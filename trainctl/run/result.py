# The result of running a scenario: the review, the simulations, their JSON and their text.
"""The result of :func:`~trainctl.run.run_scenario`: one :class:`AnalysisRun`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from trainctl._validation import numerical_errors
from trainctl.analysis.check import DesignReview
from trainctl.analysis.summary import ModelSummary
from trainctl.run.tables import (
    _claims_text,
    _expected_text,
    _metrics_table,
    _repetitions_table,
    frequency_dict,
)

if TYPE_CHECKING:
    from trainctl.analysis.claims import Claim
    from trainctl.analysis.loops import ClosedLoopResponse
    from trainctl.design import Design
    from trainctl.run.repetitions import Repetition
    from trainctl.run.strict import StrictFailure
    from trainctl.scenario import Scenario
    from trainctl.sim.metrics import Metrics
    from trainctl.sim.results import SimulationResult

__all__ = ["AnalysisRun"]


@dataclass(frozen=True, kw_only=True)
class AnalysisRun:
    """The results of running one scenario.

    Parameters
    ----------
    scenario : Scenario
        The scenario that was run.
    design : Design
        Its design model and controller designs (built once).
    summary : ModelSummary
        Model summary (vehicles, equilibrium, modes, sampling).
    review : DesignReview
        The named design checks; those a family judges on its simulated
        trajectory (:func:`~trainctl.design.review.with_simulations`)
        after the simulations.
    simulations : mapping of str to SimulationResult
        Closed-loop runs by strategy (empty without ``[simulation]``).
    metrics : mapping of str to Metrics
        Their metrics, by strategy.
    repetitions : mapping of str to tuple of Repetition
        ``[simulation] repetitions > 1``: every run of each strategy,
        summarised, run 0 (the one in ``simulations``) first
        (:mod:`trainctl.run.repetitions`); empty otherwise.
    baseline : mapping of str to tuple of Repetition
        ``[simulation] baseline_network``: each strategy's runs over the
        baseline network, one per repetition with its seed, summarised;
        empty otherwise.

    Examples
    --------
    The CRH2 scenario with a 200 s run of one strategy:

    >>> from trainctl.run import run_scenario
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("crh2-dmpc").replace("simulation.duration", 200.0)
    >>> run = run_scenario(sc.replace("simulation.strategies", ("centralised",)))
    >>> list(run.simulations), run.review.check("sampling").status
    (['centralised'], 'fail')
    >>> run.tracking_ok("centralised"), run.unexpected_checks()  # within 1 m/s after 100 s
    (True, {})
    """

    scenario: Scenario
    design: Design
    summary: ModelSummary
    review: DesignReview
    simulations: Mapping[str, SimulationResult] = field(default_factory=dict)
    metrics: Mapping[str, Metrics] = field(default_factory=dict)
    repetitions: Mapping[str, tuple[Repetition, ...]] = field(default_factory=dict)
    baseline: Mapping[str, tuple[Repetition, ...]] = field(default_factory=dict)

    def tracking_ok(self, strategy: str) -> bool:
        """True when the strategy's max speed error after settling is within tolerance.

        Parameters
        ----------
        strategy : str
            A strategy name as ``[simulation] strategies`` writes it.

        Returns
        -------
        bool
            True when the largest speed error of any vehicle after
            ``settle_time`` (:attr:`~trainctl.sim.metrics.Metrics.max_error`)
            is <= ``[simulation] tracking_tolerance`` [m/s]; False when the
            strategy was not simulated or the scenario has no ``[simulation]``.
        """
        sim = self.scenario.simulation
        if sim is None or strategy not in self.metrics:
            return False
        return float(np.max(self.metrics[strategy].max_error)) <= sim.tracking_tolerance

    @property
    def failed_checks(self) -> tuple[str, ...]:
        """Names of failed design checks (one reason for `--strict`; see strict_failures)."""
        return self.review.failed_checks

    @property
    def unsimulated_checks(self) -> tuple[str, ...]:
        """Declared checks that a simulation decides, in a run that did not simulate.

        ``[expected]`` declares the verdict after the ``[simulation]``
        (:func:`~trainctl.design.review.with_simulations`); a run without
        it (``--no-simulate``) has only the design-time verdict, which is
        not compared.
        """
        from trainctl.controllers.hooks import family_hook
        from trainctl.registry import get_family

        if self.simulations or self.scenario.simulation is None or not self.scenario.expected:
            return ()
        names = {name for family in self.scenario.controllers
                 for name in family_hook(get_family(family), "trajectory_check_names")}
        return tuple(name for name in self.scenario.expected if name in names)

    def unexpected_checks(self) -> dict[str, tuple[str, str]]:
        """Checks whose status differs from the scenario's ``[expected]`` table.

        Checks that only a simulation decides are not compared in a run
        without one (:attr:`unsimulated_checks`).

        Returns
        -------
        dict
            Check name → (expected, found).
        """
        found = {c.name: c.status for c in self.review.checks}
        skip = set(self.unsimulated_checks)
        return {name: (want, found.get(name, "missing"))
                for name, want in self.scenario.expected.items()
                if name not in skip and found.get(name) != want}

    @cached_property
    def frequency(self) -> dict[str, ClosedLoopResponse]:
        """Frequency and grade-step responses of each strategy's linear closed loop.

        Computed once, on first use (:func:`trainctl.analysis.analyse_closed_loops`).
        """
        from trainctl.analysis.loops import analyse_closed_loops

        return analyse_closed_loops(self.design)

    @cached_property
    def claims(self) -> tuple[Claim, ...]:
        """The published claims this run decides, with trainctl's numbers and verdicts.

        Each family's ``claims`` hook (:class:`~trainctl.controllers.hooks.FamilyHooks`;
        e.g. seed 003's, :mod:`trainctl.controllers.hinf.claims`), in the order
        of the design's families; empty for most; computed once.
        """
        from trainctl.controllers.hooks import family_hook
        from trainctl.registry import get_family

        with numerical_errors(self.scenario.source):
            return tuple(claim for name in self.design.families
                         for claim in family_hook(get_family(name), "claims")(self))

    def strict_failures(self) -> tuple[StrictFailure, ...]:
        """Every reason ``trainctl analyse --strict`` exits 1 (see :mod:`trainctl.run.strict`).

        Returns
        -------
        tuple of StrictFailure
            Failed checks, strategies outside their tracking tolerance,
            vehicles saturated too long, couplers above their admissible
            force, ``[expected]`` mismatches; empty
            when the run is strict-clean.
        """
        from trainctl.run.strict import strict_failures

        return strict_failures(self)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict: the summary, the review, ``[expected]`` and the strict verdict.

        Returns
        -------
        dict of str to object
            The model summary's entries
            (:meth:`~trainctl.analysis.summary.ModelSummary.to_dict`), then
            ``checks``, ``failed_checks``, ``expected``,
            ``unexpected_checks`` and ``unsimulated_checks``; when simulated,
            ``simulations`` (each strategy's metrics with ``tracking_ok`` and
            ``plant_saturation``); ``repetitions``, ``baseline_network`` and
            ``claims`` when there are any; ``strict_failures`` and
            ``frequency`` (:func:`frequency_dict`).
        """
        out = self.summary.to_dict()
        out["checks"] = self.review.to_dict()["checks"]
        out["failed_checks"] = list(self.failed_checks)
        out["expected"] = dict(self.scenario.expected)
        out["unexpected_checks"] = {name: {"expected": want, "found": got}
                                    for name, (want, got) in self.unexpected_checks().items()}
        out["unsimulated_checks"] = list(self.unsimulated_checks)
        if self.metrics:
            sim = self.scenario.simulation
            saturation = True if sim is None else sim.plant_saturation
            out["simulations"] = {
                name: {**m.to_dict(), "tracking_ok": self.tracking_ok(name),
                       "plant_saturation": saturation}
                for name, m in self.metrics.items()}
        if self.repetitions:
            out["repetitions"] = {name: [r.to_dict() for r in reps]
                                  for name, reps in self.repetitions.items()}
        if self.baseline:
            out["baseline_network"] = {name: [r.to_dict() for r in runs]
                                       for name, runs in self.baseline.items()}
        if self.claims:
            out["claims"] = [c.to_dict() for c in self.claims]
        out["strict_failures"] = [f.to_dict() for f in self.strict_failures()]
        out["frequency"] = frequency_dict(self)
        return out

    def format_text(self) -> str:
        """The text ``trainctl analyse`` prints.

        Returns
        -------
        str
            The model summary and the design review, then (when present) the
            ``[expected]`` comparison, the metrics table, the repetitions
            table and the published claims, and last the strict verdict.
        """
        from trainctl.run.strict import format_strict

        text = self.summary.format_text() + "\n\n" + self.review.format_text()
        if self.scenario.expected:
            text += "\n\n" + _expected_text(self)
        if self.metrics:
            text += "\n\n" + _metrics_table(self)
        if self.repetitions or self.baseline:
            text += "\n\n" + _repetitions_table(self)
        if self.claims:
            text += "\n\n" + _claims_text(self)
        return text + "\n\n" + format_strict(self.strict_failures())


