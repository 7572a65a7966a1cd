# Running a scenario: everything `trainctl analyse` computes, in one result.
"""Run a scenario's analyses and simulations and collect them in one :class:`AnalysisRun`."""

from __future__ import annotations

import pickle
import threading
from collections.abc import Callable, Mapping
from concurrent.futures import Executor, Future
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from trainctl._validation import numerical_errors
from trainctl.analysis.check import DesignReview
from trainctl.analysis.summary import ModelSummary, model_summary
from trainctl.design.review import review_design, with_simulations

if TYPE_CHECKING:
    from trainctl.analysis.loops import ClosedLoopResponse
    from trainctl.controllers.base import Controller
    from trainctl.controllers.hinf.claims import Claim
    from trainctl.design import Design
    from trainctl.models.plant import Plant
    from trainctl.run.repetitions import Repetition
    from trainctl.run.strict import StrictFailure
    from trainctl.scenario import Scenario
    from trainctl.sim.metrics import Metrics
    from trainctl.sim.results import SimulationResult

__all__ = [
    "NETWORK_STREAM", "AnalysisRun", "make_controller", "run_scenario", "simulate_strategy",
    "submit_simulations",
]

NETWORK_STREAM = 1
"""Spawn key of the network's random stream: ``SeedSequence([seed, NETWORK_STREAM])``, apart
from the measurement noise's ``default_rng(seed)``, so the two are not correlated."""


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
        from trainctl.registry import get_family

        if self.simulations or self.scenario.simulation is None or not self.scenario.expected:
            return ()
        names = {name for family in self.scenario.controllers
                 for name in getattr(get_family(family), "trajectory_check_names", ())}
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
        """Seed 003's published claims against this run's numbers.

        Empty unless the scenario has the ``hinf`` family; computed once.
        """
        from trainctl.controllers.hinf.claims import paper_claims

        with numerical_errors(self.scenario.source):
            return tuple(paper_claims(self))

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


def _expected_text(run: AnalysisRun) -> str:
    skipped = run.unsimulated_checks
    declared = len(run.scenario.expected) - len(skipped)
    wrong = run.unexpected_checks()
    note = ("" if not skipped else f"\n  not compared without the simulation, which decides "
            f"them: {', '.join(skipped)}")
    if not wrong:
        return f"Expected outcomes ([expected]): all {declared} declared statuses match." + note
    lines = [f"Expected outcomes ([expected]): {len(wrong)} of {declared} declared "
             "statuses differ:"]
    lines += [f"  {name}: expected {want.upper()}, found {got.upper()}"
              for name, (want, got) in wrong.items()]
    return "\n".join(lines) + note


def frequency_dict(run: AnalysisRun) -> dict[str, object]:
    """The ``frequency`` entry of :meth:`AnalysisRun.to_dict`: numbers per strategy.

    Parameters
    ----------
    run : AnalysisRun
        The run.

    Returns
    -------
    dict
        Strategy → peak gains with their frequencies [rad/s], the bandwidth
        and the 1 ‰ grade-step peaks (:meth:`ClosedLoopResponse.to_dict`);
        empty without linear closed loops.
    """
    return {name: response.to_dict() for name, response in run.frequency.items()}


_NOTED = 8
"""Saturated vehicles (and overloaded couplers) listed one by one under the metrics table,
per strategy."""


def _metrics_table(run: AnalysisRun) -> str:
    sim = run.scenario.simulation
    assert sim is not None  # metrics exist only with a [simulation] section
    w = max([15] + [len(name) + 2 for name in run.metrics])
    plant = "nonlinear plant" + ("" if sim.plant_saturation else " without saturation")
    lines = [f"Closed-loop simulations ({sim.duration:g} s, {plant}; errors after "
             f"{sim.settle_time:g} s, tolerance {sim.tracking_tolerance:g} m/s; maxima "
             "between samples too):",
             f"  {'strategy':<{w}}{'RMS err':>9}{'max err':>9}{'max |f|':>9}{'energy':>9}"
             f"{'sat':>7}{'iters':>7}{'solve p50':>10}  statuses",
             f"  {'':<{w}}{'[m/s]':>9}{'[m/s]':>9}{'[kN]':>9}{'[kWh]':>9}{'[s]':>7}{'mean':>7}"
             f"{'[ms]':>10}"]
    notes = []
    for name, m in run.metrics.items():
        ok = "" if run.tracking_ok(name) else "  (tracking outside tolerance)"
        statuses = ", ".join(f"{k} {v}" for k, v in m.status_counts.items() if v)
        statuses += "".join(f"; {f} {c}" for f, c in m.fallback_counts.items())
        lines.append(f"  {name:<{w}}{_cell(float(np.sqrt(np.mean(m.rms_error**2))), 9, 3)}"
                     f"{_cell(float(np.max(m.max_error)), 9, 3)}"
                     f"{_cell(m.max_coupler_force / 1e3, 9, 2)}{_cell(m.energy, 9, 2)}"
                     f"{_cell(float(np.max(m.saturation_time)), 7, 0)}"
                     f"{m.iterations_mean:>7.1f}{m.solve_time_median * 1e3:>10.2f}  "
                     f"{statuses}{ok}")
        notes += _run_notes(name, m)
    return "\n".join(lines + notes)


def _repetitions_table(run: AnalysisRun) -> str:
    """Each strategy's whole-run measures over its repetitions (median [min, max]) and its
    baseline-network run."""
    from trainctl.run.repetitions import SETTLING_BAND, spread

    sim = run.scenario.simulation
    assert sim is not None
    w = max([15] + [len(name) + 2 for name in run.metrics])
    lines = [f"Repetitions ({sim.repetitions} runs per strategy, seeds {run.scenario.seed} to "
             f"{run.scenario.seed + sim.repetitions - 1}; whole run, vehicle 1; median "
             f"[min, max]; settling: within {SETTLING_BAND:g} m/s after t = "
             f"{sim.reference_times[-1]:g} s):",
             f"  {'strategy':<{w}}{'RMS err [m/s]':>26}{'max err [m/s]':>26}"
             f"{'settling [s]':>26}{'max |f| [kN]':>26}"]

    def cell(values: list[float], scale: float = 1.0) -> str:
        if not values:
            return f"{'-':>26}"
        x = spread(np.asarray(values) * scale)
        return f"{x['median']:>10.4g} [{x['min']:.3g}, {x['max']:.3g}]".rjust(26)

    for name in run.metrics:
        reps = list(run.repetitions.get(name, ()))
        lines.append(f"  {name:<{w}}"
                     + cell([float(r.deviation.rms_error[0]) for r in reps])
                     + cell([float(r.deviation.max_error[0]) for r in reps])
                     + cell([float(r.deviation.settling_time[0]) for r in reps])
                     + cell([r.deviation.max_coupler_force for r in reps], 1e-3))
        if name in run.baseline:
            base = [r.deviation for r in run.baseline[name]]
            label = f"  {sim.baseline_network} network"
            lines.append(f"  {label:<{w}}" + cell([float(d.rms_error[0]) for d in base])
                         + cell([float(d.max_error[0]) for d in base])
                         + cell([float(d.settling_time[0]) for d in base])
                         + cell([d.max_coupler_force for d in base], 1e-3))
    return "\n".join(lines)


def _claims_text(run: AnalysisRun) -> str:
    """The paper's claims, trainctl's numbers and the verdicts."""
    lines = ["Paper claims (Ning et al. 2016) against this run:"]
    for c in run.claims:
        lines.append(f"  {c.case} {c.claim}: paper {c.paper}; trainctl {c.trainctl} — "
                     f"{c.verdict.upper()}")
    return "\n".join(lines)


def _cell(x: float, width: int, decimals: int) -> str:
    """``x`` right-aligned in ``width`` with ``decimals``, or in 3 significant digits
    when that would not fit."""
    text = f"{x:>{width}.{decimals}f}"
    return text if len(text) <= width else f" {x:>{width - 1}.3g}"


def _run_notes(name: str, m: Metrics) -> list[str]:
    """Lines under the table for a strategy whose run diverged or saturated, and the
    verdict of the couplers' admissible forces when the train has some."""
    notes = []
    if m.divergence is not None:
        notes.append(f"  {name}: DIVERGED: {m.divergence.get('message', '')}")
    saturated = np.flatnonzero(m.saturation_time > 0)
    for i in saturated[:_NOTED]:
        braking = m.braking_saturation_time[i]
        side = ("braking" if braking == m.saturation_time[i] else
                "traction" if braking == 0 else "traction and braking")
        notes.append(f"  {name}: vehicle {i + 1} saturated ({side}) for "
                     f"{m.saturation_time[i]:g} s, first at t = {m.first_saturation_time[i]:g} s, "
                     f"head at {m.first_saturation_position[i]:.0f} m")
    if saturated.size > _NOTED:
        notes.append(f"  {name}: ... and {saturated.size - _NOTED} more vehicles saturated")
    return notes + _coupler_notes(name, m)


def _coupler_notes(name: str, m: Metrics) -> list[str]:
    """Couplers above their admissible force, or the closest one's margin when none is."""
    worst = m.worst_coupler
    if worst is None:
        return []
    over = m.couplers_over_limit
    if not over.size:
        return [f"  {name}: coupler forces within their limits, the closest coupler {worst + 1} "
                f"at {100 * m.coupler_ratio[worst]:.0f} % of {m.coupler_limit[worst] / 1e3:g} kN "
                f"(t = {m.coupler_peak_time[worst]:.4g} s)"]
    order = over[np.argsort(-m.coupler_ratio[over], kind="stable")]
    notes = [f"  {name}: coupler {i + 1} exceeded {m.coupler_limit[i] / 1e3:g} kN by "
             f"{100 * (m.coupler_ratio[i] - 1):.0f} % at t = {m.coupler_peak_time[i]:.4g} s "
             f"(peak {m.coupler_peak_force[i] / 1e3:.4g} kN), above it for "
             f"{m.coupler_over_time[i]:.4g} s" for i in order[:_NOTED]]
    if over.size > _NOTED:
        notes.append(f"  {name}: ... and {over.size - _NOTED} more couplers above their limits")
    return notes


def make_controller(scenario: Scenario, strategy: str, design: Design | None = None) -> Controller:
    """The scenario's controller for one strategy (QPs and gains built once here).

    Parameters
    ----------
    scenario : Scenario
        A scenario with a ``[controller]`` section.
    strategy : str
        A name from ``[simulation] strategies``: a strategy of the primary
        family (``"ndmpc"``) or ``"family.strategy"`` (``"lqr.centralised"``).
    design : Design or None
        The run's design (:func:`trainctl.design.build_design`); built here
        when None.

    Returns
    -------
    Controller
        Ready for :func:`trainctl.sim.simulate`.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> ctl = make_controller(load_scenario("crh2-dmpc"), "ndmpc")
    >>> type(ctl).__name__, ctl.name
    ('MPCController', 'ndmpc')
    """
    from trainctl.design import build_design
    from trainctl.registry import get_family

    if design is None:
        design = build_design(scenario)
    family, name = design.resolve(strategy)
    controller = get_family(family).make(design.family(family), name)
    controller.name = strategy
    return controller


def simulate_strategy(
    scenario: Scenario, strategy: str, design: Design | None = None, *, warn: bool = True
) -> SimulationResult:
    """Simulate one strategy of the scenario's ``[simulation]`` on the nonlinear plant.

    The train starts at the feedforward equilibrium of the reference at t = 0
    (speed, acceleration) with every vehicle off by ``initial_speed_error``
    plus its ``initial_speed_errors`` entry, and every coupler's elongation
    off by its ``initial_spacing_errors`` entry.
    A controller with ``uses_network = True`` in a scenario with a
    ``[network]`` section receives its neighbours' and the reference's
    speeds through :class:`trainctl.models.network.Network` (its generator seeded
    with ``SeedSequence([seed, NETWORK_STREAM])``); a controller with a
    network of its own (a ``prepare(network, seed)`` method, e.g. the
    synchronous family's relay) gets the scenario's ``[network]`` and seed.
    The plant saturates the forces to the envelopes (``plant_saturation``),
    records the dense grid (``output_interval``) and stops a diverging run
    (``divergence_speed_error``), as the ``[simulation]`` table says.

    Parameters
    ----------
    scenario : Scenario
        A scenario with ``[controller]`` and ``[simulation]`` sections.
    strategy : str
        A name from ``[simulation] strategies``.
    design : Design or None
        The run's design; built here when None.
    warn : bool
        Warn once about solver trouble (:func:`trainctl.sim.simulate`'s
        Warns); False records it in the result only.

    Returns
    -------
    SimulationResult
        Time series, statuses, iterations and solve times.

    Examples
    --------
    The CRH2 reference holds 20 m/s until 60 s, then ramps at
    (60 − 20) m/s / 400 s = 0.1 m/s²: 22 m/s at 80 s, 34 m/s at 200 s.

    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("crh2-dmpc").replace("simulation.duration", 200.0)
    >>> res = simulate_strategy(sc, "centralised")
    >>> res.time[[0, 4, -1]].tolist(), res.reference_speed[[0, 4, -1]].tolist()  # [s], [m/s]
    ([0.0, 80.0, 200.0], [20.0, 22.0, 34.0])
    >>> res.velocities[:, 0].tolist()  # every coach starts on the reference [m/s]
    [20.0, 20.0, 20.0, 20.0]
    >>> bool(abs(res.velocities[:, -1] - 34.0).max() < 1.0)
    True
    """
    from trainctl.exceptions import ScenarioError
    from trainctl.models.dynamics import equilibrium
    from trainctl.sim.closed_loop import simulate
    from trainctl.sim.plant import Plant
    from trainctl.sim.reference import SpeedProfile

    sim = scenario.simulation
    if sim is None:
        raise ScenarioError(f"{scenario.source}: there is no [simulation] section to run.")
    profile = SpeedProfile(times=np.asarray(sim.reference_times, dtype=float),
                           speeds=np.asarray(sim.reference_speeds, dtype=float))
    v0 = float(profile.speed(0.0))
    start = equilibrium(scenario.train, max(v0, 0.1), acceleration=float(profile.acceleration(0.0)))
    state = start.state(position=0.0)
    n = scenario.train.n_vehicles
    speed_offsets, spacing_offsets = sim.initial_offsets(n)
    state[:n] = v0 + speed_offsets
    state[n:2 * n - 1] += spacing_offsets
    with numerical_errors(f"{scenario.source}: simulating {strategy!r}"):
        controller = make_controller(scenario, strategy, design)
        prepare = getattr(controller, "prepare", None)
        if callable(prepare):
            prepare(scenario.network, int(scenario.seed))
        network = None
        if scenario.network is not None and getattr(controller, "uses_network", False):
            from trainctl.models.network.simulator import Network

            network = Network(scenario.network, scenario.graph(),
                              seed=np.random.SeedSequence([scenario.seed, NETWORK_STREAM]))
        return simulate(_shared_plant(Plant, scenario), controller, profile,
                        duration=sim.duration, initial_state=state,
                        preview_steps=_preview_steps(controller),
                        measurement_noise=sim.measurement_noise, seed=scenario.seed,
                        full_state=getattr(controller, "needs_full_state", True),
                        saturation=sim.plant_saturation, output_interval=sim.output_interval,
                        divergence_speed_error=sim.divergence_speed_error, network=network,
                        warn=warn)


_PLANTS = threading.local()


def _shared_plant(plant_class: type[Plant], scenario: Scenario) -> Plant:
    """The plant of this scenario's train and track, shared by its strategies in this thread.

    A :class:`~trainctl.models.Plant` caches its propagators (matrix
    exponentials per substep and linearisation speed); the strategies of one
    scenario simulate the same train on the same track, so the second and
    later ones find them computed. Every cache entry is a pure function of
    its key, so a shared plant gives the same bits as a fresh one. The key
    is the pickled train and track (a process-pool worker receives a fresh
    copy of the scenario with each task); each thread keeps only the last
    plant, so the caches' memory stays that of one plant.
    """
    key = pickle.dumps((scenario.train, scenario.track), protocol=pickle.HIGHEST_PROTOCOL)
    last: tuple[bytes, Plant] | None = getattr(_PLANTS, "last", None)
    if last is not None and last[0] == key and type(last[1]) is plant_class:
        return last[1]
    plant = plant_class(train=scenario.train, track=scenario.track)
    _PLANTS.last = (key, plant)
    return plant


def _preview_steps(controller: Controller) -> int:
    """Samples of reference preview a controller reads (its horizon P; 1 without one)."""
    steps: int | None = getattr(controller, "preview_steps", None)
    if steps is None:
        steps = int(getattr(controller, "P", 1))
    return steps


def submit_simulations(
    scenario: Scenario, executor: Executor, design: Design | None = None
) -> dict[str, Future[SimulationResult]]:
    """Start every ``[simulation]`` strategy of a scenario on an executor.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario (no ``[simulation]``: nothing is submitted).
    executor : concurrent.futures.Executor
        Where to run :func:`simulate_strategy`: a process pool
        (:func:`trainctl.run.pool.process_pool`), a Dask executor, ...
    design : Design or None
        The run's design, sent along so that the workers do not rebuild it.

    Returns
    -------
    dict of str to Future
        Strategy → future of its :class:`~trainctl.sim.SimulationResult`.

    Examples
    --------
    A thread pool stands in for a process pool here:

    >>> from concurrent.futures import ThreadPoolExecutor
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("crh2-dmpc").replace("simulation.duration", 200.0)
    >>> with ThreadPoolExecutor(max_workers=1) as pool:
    ...     futures = submit_simulations(sc, pool)
    ...     results = {name: f.result() for name, f in futures.items()}
    >>> list(results), results["ndmpc"].controller_name
    (['centralised', 'decentralised', 'ndmpc'], 'ndmpc')
    """
    if scenario.simulation is None:
        return {}
    return {strategy: executor.submit(_simulate_recorded, scenario, strategy, design)
            for strategy in scenario.simulation.strategies}


def _simulate_recorded(scenario: Scenario, strategy: str,
                       design: Design | None) -> SimulationResult:
    """:func:`simulate_strategy` recording its solver trouble without warning (a pool's
    task; the caller's metrics carry it). An argument, not a warnings filter: filters are
    process-wide, and threads of a Dask worker run several simulations at once."""
    return simulate_strategy(scenario, strategy, design, warn=False)


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
                coupler_limits=scenario.train.max_coupler_force)
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
