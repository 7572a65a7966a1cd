# Running a scenario: everything `trainctl analyse` computes, in one result.
"""Run a scenario's analyses and simulations and collect them in one :class:`AnalysisRun`.

:func:`run_scenario` is here; the result is :mod:`trainctl.run.result`'s, its
text tables :mod:`trainctl.run.tables`', one strategy's simulation
:mod:`trainctl.run.simulate`'s (re-exported here).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from concurrent.futures import Executor, Future
from typing import TYPE_CHECKING

from trainctl._validation import numerical_errors
from trainctl.analysis.summary import model_summary
from trainctl.design.review import review_design, with_simulations
from trainctl.run.result import AnalysisRun
from trainctl.run.simulate import (
    NETWORK_STREAM,
    _simulate_recorded,
    make_controller,
    simulate_strategy,
    submit_simulations,
)

if TYPE_CHECKING:
    from trainctl.design import Design
    from trainctl.run.repetitions import Repetition
    from trainctl.scenario import Scenario
    from trainctl.sim.metrics import Metrics
    from trainctl.sim.results import SimulationResult

__all__ = [
    "NETWORK_STREAM", "AnalysisRun", "make_controller", "run_scenario", "simulate_strategy",
    "submit_simulations",
]


def run_scenario(
    scenario: Scenario,
    *,
    simulate: bool = True,
    executor: Executor | None = None,
    pending: Mapping[str, Future[SimulationResult]] | None = None,
    on_simulated: Callable[[str], None] | None = None,
    design: Design | None = None,
    pending_repetitions: Mapping[tuple[str, int], Future[Repetition]] | None = None,
) -> AnalysisRun:
    """Run the model summary, the design review and the scenario's simulations.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    simulate : bool
        Run the ``[simulation]`` strategies (when the scenario has them).
    executor : concurrent.futures.Executor or None
        Run the strategies there, side by side, while this process does the
        analysis; None runs them here, one after the other. Results are the
        same either way.
    pending : mapping of str to Future or None
        Simulations already submitted with :func:`submit_simulations`
        (overrides ``executor``).
    on_simulated : callable or None
        Called with the strategy name as each simulation finishes (progress).
    design : Design or None
        The design when already built (:func:`trainctl.design.build_design`);
        built here, once, when None.
    pending_repetitions : mapping or None
        The ``[simulation]``'s extra runs (repetitions, baseline network)
        already submitted with :func:`trainctl.run.repetitions.submit_repetitions`;
        None: submitted to ``executor`` when given, else run here.

    Returns
    -------
    AnalysisRun
        Summary, review, simulation results and metrics.

    Notes
    -----
    Solver trouble in the simulations (samples not solved to optimality,
    iterations stopped unconverged) is recorded in each run's metrics
    (``status_counts``, ``iteration_limit_steps``) and from there in the
    report and the sweep's rows; it is not also warned
    (``simulate_strategy(..., warn=False)``).

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> run = run_scenario(load_scenario("crh2-dmpc"), simulate=False)
    >>> "sampling" in run.failed_checks, run.unexpected_checks()
    (True, {})
    """
    from trainctl.design import build_design

    sims: dict[str, SimulationResult] = {}
    metrics: dict[str, Metrics] = {}
    sim = scenario.simulation if simulate else None
    with numerical_errors(scenario.source):
        if design is None:
            design = build_design(scenario)
        if sim is not None and pending is None and executor is not None:
            pending = submit_simulations(scenario, executor, design)
        if sim is not None and pending_repetitions is None and executor is not None:
            from trainctl.run.repetitions import submit_repetitions

            pending_repetitions = submit_repetitions(scenario, executor, design)
        summary = model_summary(scenario, design.model)
        review = review_design(scenario, design)
    if sim is not None:
        from trainctl.sim.metrics import compute_metrics

        for strategy in sim.strategies:
            if pending is not None:
                sims[strategy] = pending[strategy].result()
            else:
                sims[strategy] = _simulate_recorded(scenario, strategy, design)
            metrics[strategy] = compute_metrics(
                sims[strategy], settle_time=sim.settle_time,
                regen_efficiency=sim.regen_efficiency,
                coupler_limits=scenario.train.max_coupler_force, train=scenario.train,
                track=scenario.track, cost=scenario.cost)
            if on_simulated is not None:
                on_simulated(strategy)
        with numerical_errors(scenario.source):
            review = with_simulations(review, design, sims)
            from trainctl.run.repetitions import collect_repetitions

            repetitions, baseline = collect_repetitions(scenario, design, sims,
                                                        pending=pending_repetitions)
        return AnalysisRun(scenario=scenario, design=design, summary=summary, review=review,
                           simulations=sims, metrics=metrics, repetitions=repetitions,
                           baseline=baseline)
    return AnalysisRun(scenario=scenario, design=design, summary=summary, review=review,
                       simulations=sims, metrics=metrics)

