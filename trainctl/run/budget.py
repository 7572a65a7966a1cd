# What a run will cost before it starts: steps, time and memory, and the budget it must fit.
"""Estimate a scenario's run (steps, seconds, memory) and hold it to a budget.

Scenario keys have hard limits (:mod:`trainctl.declare.limits`), but values inside
them can still combine into a run of days: 500 vehicles, a horizon of 2000
steps, a million samples. :func:`estimate_run` predicts, from the scenario
alone and before anything is built, how many controller steps the run takes
(samples × strategies) and its work (samples × vehicles × prediction
horizon, the size of what each step solves), and from those a rough time
and memory; :func:`check_budget` refuses a run whose estimate exceeds a time
budget (``trainctl analyse/report --max-time``, default
:data:`DEFAULT_MAX_TIME`) or the machine's memory.

The time model is an order-of-magnitude one, calibrated on a 2-core machine
(trainctl 0.x, OSQP 1.1, DAQP 0.7). This module holds the shared part: the
design review grows like states⁴ for the modal and controllability checks
(one dense factorisation per eigenvalue) and each recorded sample costs the
plant's substeps. Each family prices the rest through its hooks
(:class:`~trainctl.controllers.hooks.FamilyHooks`): its design and review
(``design_cost``: MPC's iteration analyses, :mod:`trainctl.controllers.mpc.cost`;
the H∞ family's semidefinite programs, :mod:`trainctl.controllers.hinf.cost`),
the size of what each step solves (``cost_horizons``) and one strategy's
build and steps at its control interval (``strategy_seconds``: MPC's QPs;
an explicit law's evaluation, :mod:`trainctl.controllers.continuous.cost`);
this module only sums them. :func:`strategy_seconds` is the one estimate of
a strategy's cost (the report orders its pooled simulations by it) and
:func:`estimate_run` the one count of a run's steps and seconds (the pool
decides by its simulation seconds, :func:`trainctl.run.pool.estimated_seconds`).
Recalibrated on the 204-vehicle chain
(``benchmarks/scenarios/heavy-haul-204-ndmpc.toml`` on the idle machine:
review 104 s on one BLAS thread, 600 s of decentralised MPC 2.9 s and of
local N-DMPC 22.6 s) with the CRH2 built-ins' estimates unchanged. Expect
it within a factor of 3 or so; it is meant to tell a minute from an hour
from a week.

Examples
--------
>>> from trainctl.scenario import load_scenario
>>> est = estimate_run(load_scenario("crh2-dmpc"))
>>> est.samples, est.controller_steps, est.work
(60, 180, 2880)
>>> est.seconds < 60 < DEFAULT_MAX_TIME
True
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from trainctl.exceptions import TrainctlError

if TYPE_CHECKING:
    from trainctl.scenario import Scenario

__all__ = [
    "DEFAULT_MAX_TIME", "PRINT_ESTIMATE_FROM", "BudgetError", "RunEstimate", "check_budget",
    "estimate_run", "format_bytes", "format_duration", "parse_duration", "physical_memory",
    "strategy_seconds", "total_estimate",
]

DEFAULT_MAX_TIME = 3600.0
"""Default time budget of ``trainctl analyse`` and ``report`` [s]: an hour. The built-ins are
estimated at seconds to a few minutes."""

PRINT_ESTIMATE_FROM = 20.0
"""Runs estimated at this many seconds or more print their estimate first [s]."""

# Calibration (seconds), see the module docstring; each family's own model is in the family
# (its cost hooks, trainctl.controllers.hooks.FamilyHooks).
_BASE = 0.3                 # scenario, model and review overhead
_MODAL = 4e-10              # × states⁴: modal, controllability, observability checks (the PBH
                            # test's Cholesky screen and the Kalman SVD; 408 states: ~12 s)
_SUBSTEP = 1e-4             # × (1 + n / 256) per plant substep and its recording (banded
                            # from 128 vehicles: 204 vehicles ~90 µs measured)
_BATCHED_RUN = 0.1          # a batched repetition's share of a run alone (heavy-haul-hinf-delay's
                            # 80 runs, 2026-12-02: 0.053 measured, benchmarks/batch_mc.py)
_BYTES_PER_ROW = 8 * 6      # result arrays: bytes per sample and vehicle (plus dense grids)


class BudgetError(TrainctlError, ValueError):
    """A run whose estimate exceeds the time budget or the machine's memory.

    Examples
    --------
    ``crh2-dmpc`` is estimated at several seconds, so a one-second budget
    refuses it:

    >>> from trainctl.scenario import load_scenario
    >>> estimate = estimate_run(load_scenario("crh2-dmpc"))
    >>> estimate.seconds > 1.0
    True
    >>> try:
    ...     check_budget(estimate, max_time=1.0)
    ... except BudgetError as exc:
    ...     print(str(exc).split(", over")[0].split(": ", 1)[1])
    the run is estimated at about 9.3 s
    >>> issubclass(BudgetError, ValueError)
    True
    """


@dataclass(frozen=True, kw_only=True)
class RunEstimate:
    """The predicted cost of running one or more scenarios.

    Parameters
    ----------
    label : str
        The scenario's source (or several, joined).
    vehicles : int
        Vehicles of the (largest) train.
    horizon : int
        Largest MPC prediction horizon P (1 without MPC).
    samples : int
        Samples per simulated strategy (0 without simulations).
    strategies : int
        Simulated strategies.
    controller_steps : int
        ``samples × strategies × runs``, summed over scenarios.
    work : int
        ``controller_steps × vehicles × horizon``, summed over scenarios.
    design_seconds : float
        Estimated time of the design stage and review [s].
    simulation_seconds : float
        Estimated time of the simulations, run one after the other [s].
    memory_bytes : float
        Estimated peak memory of the largest stage [bytes].
    dominant : str
        What costs most, in words (for messages).
    runs : int
        Runs of each strategy: the ``[simulation]`` repetitions, twice as many
        with a baseline network (:mod:`trainctl.run.repetitions`); the largest
        over scenarios for a total.

    Examples
    --------
    >>> estimate = RunEstimate(
    ...     label="toy", vehicles=2, horizon=1, samples=100, strategies=1,
    ...     controller_steps=100, work=200, design_seconds=0.5, simulation_seconds=1.5,
    ...     memory_bytes=2e6, dominant="the simulations")
    >>> estimate.seconds  # 0.5 s + 1.5 s
    2.0
    >>> estimate.describe()
    '100 samples × 1 strategies = 100 controller steps (2 vehicles): about 2 s, 2 MB'
    """

    label: str
    vehicles: int
    horizon: int
    samples: int
    strategies: int
    controller_steps: int
    work: int
    design_seconds: float
    simulation_seconds: float
    memory_bytes: float
    dominant: str
    runs: int = 1

    @property
    def seconds(self) -> float:
        """Estimated total time [s]."""
        return self.design_seconds + self.simulation_seconds

    def describe(self) -> str:
        """One line: steps, sizes, time and memory.

        Returns
        -------
        str
            The controller steps (``samples × strategies × runs`` where that
            product is the count, as for one scenario; else the count and the
            strategies; "design review only" without simulations), the
            vehicles and horizon P (when > 1),
            the estimated total time and the peak memory, e.g. ``"... (4
            vehicles, P = 4): about 9.6 s, 0.1 MB"``.

        Examples
        --------
        >>> from trainctl.scenario import load_scenario
        >>> estimate_run(load_scenario("crh2-dmpc")).describe().split(":")[0]
        '60 samples × 3 strategies = 180 controller steps (4 vehicles, P = 4)'
        """
        runs = f" × {self.runs} runs" if self.runs > 1 else ""
        if self.strategies and self.samples * self.strategies * self.runs \
                == self.controller_steps:
            steps = (f"{self.samples} samples × {self.strategies} strategies{runs} = "
                     f"{self.controller_steps} controller steps")
        elif self.strategies:
            steps = (f"{self.controller_steps} controller steps of {self.strategies} "
                     "strategies")
        else:
            steps = "design review only"
        size = f"{self.vehicles} vehicles" + (f", P = {self.horizon}" if self.horizon > 1 else "")
        return (f"{steps} ({size}): about {format_duration(self.seconds)}, "
                f"{format_bytes(self.memory_bytes)}")

    def to_dict(self) -> dict[str, object]:
        """JSON-safe fields, with ``seconds``.

        Returns
        -------
        dict of str to object
            Every field by name, plus ``seconds``, the estimated total time [s];
            times in [s], ``memory_bytes`` in [bytes].
        """
        return {"label": self.label, "vehicles": self.vehicles, "horizon": self.horizon,
                "samples": self.samples, "strategies": self.strategies,
                "controller_steps": self.controller_steps, "work": self.work,
                "design_seconds": self.design_seconds,
                "simulation_seconds": self.simulation_seconds, "seconds": self.seconds,
                "memory_bytes": self.memory_bytes, "dominant": self.dominant,
                "runs": self.runs}


def estimate_run(scenario: Scenario, *, simulate: bool = True) -> RunEstimate:
    """Predict the steps, time and memory of running a scenario.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario (nothing is built).
    simulate : bool
        Include the ``[simulation]`` strategies.

    Returns
    -------
    RunEstimate
        The estimate.

    Examples
    --------
    ``crh2-dmpc``: 1200 s / 20 s = 60 samples for each of 3 strategies, with
    4 vehicles and P = 4, so work = 180 × 4 × 4 = 2880; its result arrays take
    60 samples × 4 vehicles × 48 bytes × 3 strategies = 34560 bytes:

    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> est = estimate_run(scenario)
    >>> est.samples, est.strategies, est.controller_steps, est.work, est.memory_bytes
    (60, 3, 180, 2880, 34560.0)
    >>> review = estimate_run(scenario, simulate=False)  # the design review only
    >>> review.controller_steps, review.simulation_seconds
    (0, 0.0)
    >>> review.design_seconds == est.design_seconds
    True
    """
    n = scenario.train.n_vehicles
    horizon, _ = _horizons(scenario)
    design, memory, dominant = _design_cost(n, scenario)
    sim = scenario.simulation if simulate else None
    samples = sim.n_steps(scenario.model.sample_time) if sim is not None else 0
    strategies = tuple(sim.strategies) if sim is not None else ()
    seconds = 0.0
    # Each strategy runs once per repetition, and as often over a baseline network when asked
    # (trainctl.run.repetitions); only the runs shown keep their time series in memory.
    runs = 1 if sim is None else sim.repetitions * (1 + int(
        sim.baseline_network is not None and scenario.network is not None))
    for strategy in strategies:
        seconds += _runs(scenario, strategy, runs) * strategy_seconds(scenario, strategy,
                                                                     samples=samples)
    memory = max(memory, float(samples) * n * _BYTES_PER_ROW * max(1, len(strategies)))
    if seconds > design:
        dominant = (f"the simulations: {samples * len(strategies) * runs} controller steps "
                    "([simulation].duration / [model].sample_time, × strategies"
                    + (", × runs of each)" if runs > 1 else ")"))
    return RunEstimate(
        label=str(scenario.source), vehicles=n, horizon=horizon, samples=samples,
        strategies=len(strategies), controller_steps=samples * len(strategies) * runs,
        work=samples * len(strategies) * runs * n * horizon, design_seconds=design,
        simulation_seconds=seconds, memory_bytes=memory, dominant=dominant, runs=runs)


def total_estimate(estimates: Iterable[RunEstimate]) -> RunEstimate:
    """The estimate of several runs one after the other (``report --all``).

    Parameters
    ----------
    estimates : iterable of RunEstimate
        One per scenario.

    Returns
    -------
    RunEstimate
        Sums of steps, work and times; the largest sizes and memory; the
        dominant part of the most expensive run.

    Examples
    --------
    The full ``crh2-dmpc`` run (60 samples × 3 strategies) and a half-length
    one (30 × 3) total 180 + 90 = 270 controller steps:

    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> full, half = (estimate_run(scenario),
    ...               estimate_run(scenario.replace("simulation.duration", 600.0)))
    >>> total = total_estimate([full, half])
    >>> total.controller_steps, total.strategies, total.samples
    (270, 6, 60)
    >>> bool(abs(total.seconds - (full.seconds + half.seconds)) < 1e-9)
    True
    """
    items = list(estimates)
    if not items:
        raise ValueError("total_estimate: 'estimates' must not be empty")
    worst = max(items, key=lambda e: e.seconds)
    return replace(
        worst,
        label=", ".join(e.label for e in items),
        vehicles=max(e.vehicles for e in items), horizon=max(e.horizon for e in items),
        samples=max(e.samples for e in items), strategies=sum(e.strategies for e in items),
        controller_steps=sum(e.controller_steps for e in items),
        work=sum(e.work for e in items),
        design_seconds=sum(e.design_seconds for e in items),
        simulation_seconds=sum(e.simulation_seconds for e in items),
        memory_bytes=max(e.memory_bytes for e in items), runs=max(e.runs for e in items))


def check_budget(estimate: RunEstimate, max_time: float) -> None:
    """Refuse a run estimated over ``max_time`` seconds or over the machine's memory.

    Parameters
    ----------
    estimate : RunEstimate
        From :func:`estimate_run` or :func:`total_estimate`.
    max_time : float
        Time budget [s]; ``math.inf`` for none.

    Raises
    ------
    BudgetError
        Naming the estimate, the budget and what dominates.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> check_budget(estimate_run(load_scenario("crh2-dmpc")), DEFAULT_MAX_TIME)
    """
    memory = physical_memory()
    if memory is not None and estimate.memory_bytes > memory:
        raise BudgetError(
            f"{estimate.label}: the run would need about {format_bytes(estimate.memory_bytes)} "
            f"of memory, more than this machine's {format_bytes(memory)}; most of it goes to "
            f"{estimate.dominant}. Estimate: {estimate.describe()}. Make the train, the "
            "horizon or the run shorter.")
    if estimate.seconds > max_time:
        raise BudgetError(
            f"{estimate.label}: the run is estimated at about {format_duration(estimate.seconds)},"
            f" over the time budget of {format_duration(max_time)}; most of it goes to "
            f"{estimate.dominant}. Estimate: {estimate.describe()}. Give --max-time "
            f"{_suggest(estimate.seconds)} to run it anyway, or make the train, the horizon or "
            "the run shorter.")


def physical_memory() -> float | None:
    """Total physical memory [bytes], or None where unknown.

    Returns
    -------
    float or None
        The machine's physical memory [bytes]; None where the system does not say.

    Examples
    --------
    On Linux it is the page size times the number of physical pages:

    >>> import os
    >>> memory = physical_memory()
    >>> memory == os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    True
    >>> format_bytes(memory).split()[-1] in ("MB", "GB", "TB")
    True
    """
    try:
        return float(os.sysconf("SC_PAGE_SIZE")) * float(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):  # pragma: no cover - not POSIX
        return None


def format_duration(seconds: float) -> str:
    """A duration in the largest fitting unit.

    Parameters
    ----------
    seconds : float
        Duration [s]; inf reads "no limit".

    Returns
    -------
    str
        The duration in s, min, h or days.

    Examples
    --------
    >>> format_duration(42), format_duration(150), format_duration(5400), format_duration(3e5)
    ('42 s', '2.5 min', '1.5 h', '3.5 days')
    >>> format_duration(float("inf"))
    'no limit'
    """
    if math.isinf(seconds):
        return "no limit"
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.2g} {unit}"
    return f"{seconds:.2g} s" if seconds < 10 else f"{seconds:.0f} s"


def format_bytes(size: float) -> str:
    """A memory size in MB, GB or TB (decimal).

    Parameters
    ----------
    size : float
        Size [bytes].

    Returns
    -------
    str
        The size with two significant digits and its unit.

    Examples
    --------
    >>> format_bytes(2.5e6), format_bytes(3e10)
    ('2.5 MB', '30 GB')
    """
    for unit, scale in (("TB", 1e12), ("GB", 1e9)):
        if size >= scale:
            return f"{size / scale:.2g} {unit}"
    return f"{max(size / 1e6, 0.1):.2g} MB"


def parse_duration(text: str) -> float:
    """A time budget from ``"3600"``, ``"90s"``, ``"30min"``, ``"2h"``, ``"1d"`` or ``"inf"``.

    Parameters
    ----------
    text : str
        A positive number with an optional unit s, min, h or d (seconds by
        default); ``inf`` or ``none`` for no budget.

    Returns
    -------
    float
        Seconds.

    Raises
    ------
    ValueError
        For anything else.

    Examples
    --------
    >>> parse_duration("90"), parse_duration("30min"), parse_duration("2h"), parse_duration("none")
    (90.0, 1800.0, 7200.0, inf)
    """
    value = text.strip().lower()
    if value in ("inf", "none"):
        return math.inf
    for suffix, scale in (("min", 60.0), ("s", 1.0), ("h", 3600.0), ("d", 86400.0)):
        if value.endswith(suffix):
            value, factor = value[: -len(suffix)].strip(), scale
            break
    else:
        factor = 1.0
    seconds = float(value) * factor
    if not (seconds > 0 and math.isfinite(seconds)):
        raise ValueError(f"must be a positive duration (got {text!r})")
    return seconds


# --------------------------------------------------------------------------- the model


def _families(scenario: Scenario) -> list[tuple[Any, Any, list[str]]]:
    """Each controller family of the scenario: (family, settings, its simulated strategies)."""
    from trainctl.design.stage import split_strategy
    from trainctl.registry import get_family

    simulated: dict[str, list[str]] = {}
    if scenario.simulation is not None:
        for strategy in scenario.simulation.strategies:
            family, name = split_strategy(scenario, strategy)
            simulated.setdefault(family, []).append(name)
    return [(get_family(name), settings, simulated.get(name, []))
            for name, settings in scenario.controllers.items()]


def _horizons(scenario: Scenario) -> tuple[int, int]:
    """The largest prediction and control horizons of the scenario's controllers (1 if none)."""
    from trainctl.controllers.hooks import family_hook

    horizon = moves = 1
    for family, settings, _ in _families(scenario):
        p, m = family_hook(family, "cost_horizons")(settings)
        horizon, moves = max(horizon, p), max(moves, m)
    return horizon, moves


def _design_cost(n: int, scenario: Scenario) -> tuple[float, float, str]:
    """Seconds and peak bytes of the design stage and review, and what dominates."""
    from trainctl.controllers.hooks import family_hook

    states = 2 * n
    modal = _MODAL * float(states) ** 4
    seconds = _BASE + modal
    memory = 10 * 8 * float(states) ** 2
    dominant, largest = f"the design review of {n} vehicles ({states} states; [train] vehicles)", \
        modal
    for family, settings, strategies in _families(scenario):
        cost = family_hook(family, "design_cost")(scenario, settings, strategies)
        if cost is None:
            continue
        seconds += cost.seconds
        memory = max(memory, cost.memory_bytes)
        if cost.seconds > largest:
            dominant, largest = cost.dominant, cost.seconds
    return seconds, memory, dominant


def strategy_seconds(scenario: Scenario, strategy: str, *, samples: int | None = None) -> float:
    """The budget's estimate of building and simulating one strategy once [s].

    The one estimate of a strategy's cost: the budget sums it, the report
    and the pool order their simulations by it. The plant's share is the
    budget's; the controller's is the family's
    (:meth:`~trainctl.controllers.hooks.FamilyHooks.strategy_seconds`), at the
    strategy's control interval (:func:`trainctl.design.stage.strategy_interval`).

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    strategy : str
        A name from ``[simulation] strategies``.
    samples : int or None
        Recorded samples; None: ``[simulation] duration / [model] sample_time``.

    Returns
    -------
    float
        Seconds [s].

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> strategy_seconds(scenario, "ndmpc") > strategy_seconds(scenario, "decentralised")
    True
    """
    from trainctl.controllers.hooks import StrategyRun, family_hook
    from trainctl.design.stage import split_strategy, strategy_interval
    from trainctl.registry import get_family
    from trainctl.sim.plant import Plant

    sample_time = scenario.model.sample_time
    if samples is None:
        sim = scenario.simulation
        samples = sim.n_steps(sample_time) if sim is not None else 0
    n = scenario.train.n_vehicles
    family, name = split_strategy(scenario, strategy)
    substeps = Plant(train=scenario.train).substeps(sample_time)
    run = StrategyRun(scenario=scenario, settings=scenario.controllers[family], strategy=name,
                      samples=samples, sample_time=sample_time,
                      interval=strategy_interval(scenario, strategy), substeps=substeps,
                      plant_seconds=_SUBSTEP * (1 + n / 256) * substeps)
    return float(family_hook(get_family(family), "strategy_seconds")(run))


def _runs(scenario: Scenario, strategy: str, runs: int) -> float:
    """The runs of a strategy in units of one run: ``runs``, or, where the family's law
    runs batched (``batches_repetitions``), the first run and :data:`_BATCHED_RUN` of each
    further one."""
    from trainctl.design.stage import split_strategy
    from trainctl.registry import get_family

    if runs <= 1 or not getattr(get_family(split_strategy(scenario, strategy)[0]),
                                "batches_repetitions", False):
        return float(runs)
    return 1.0 + (runs - 1) * _BATCHED_RUN


def _suggest(seconds: float) -> str:
    """A ``--max-time`` value comfortably above ``seconds``."""
    hours = math.ceil(seconds * 1.5 / 3600.0)
    return f"{hours}h" if hours < 48 else f"{math.ceil(hours / 24)}d"
