# Repeated runs of a scenario's strategies over other seeds, and over an ideal network.
"""Repetitions: one scenario's strategies run again with other seeds, summarised.

A run over a random network (delays drawn per message, losses, noise) is
one draw: a claim such as "under delay the speed deviation is 7.5 times the
ideal case's" needs the spread over many draws, not one lucky run.
``[simulation] repetitions = R`` runs every strategy R times, run r with
the seed ``seed + r`` for all its random streams (the network's, the
synchronous relay's, the measurement noise's); run 0 is the run the report
shows. ``[simulation] baseline_network`` adds, for every one of those runs,
one over a baseline network with the same seed, the denominator of its
deviation ratio: ``"ideal"``,
the scenario without its ``[network]`` (no delay, loss, noise or outage),
or ``"delay-free"``, its ``[network]`` with every delay 0 — the network's
draws do not depend on the delays (:mod:`trainctl.models.network`), so that run
has the same noise, losses and outages, message for message, and the
ratio isolates what the delays do.

Each run is reduced, where it ran, to a :class:`Repetition`: the
scenario's :class:`~trainctl.sim.metrics.Metrics` (judged after
``settle_time``, as in the main table) and the whole-run measures of
:class:`Deviation`. The time series are not kept: twenty runs of a long
scenario would hold gigabytes. Runs go to a process pool when one is given
(:func:`submit_repetitions`, one task per strategy), else run here; the
runs of one strategy share its design and run as one batch where the family
has a batched law (:func:`run_repetitions`,
:func:`trainctl.sim.batch.simulate_batch`; a batch holds at most
:data:`trainctl.run.simulate.BATCH_VALUES` numbers of time series at once,
and is summarised before the next starts). Each run depends only on its
scenario, strategy and seed, so the results are the same every way, bit
for bit.

Measures of a run (:func:`deviation`)
-------------------------------------
Per vehicle i, e_i = v_i − v_ref:

- ``rms_error``: the RMS of e_i over the samples of the whole run [m/s];
- ``max_error``: max |e_i| over the dense grid of the whole run [m/s];
- ``settling_time``: after the reference's last breakpoint t_last, the
  time until |e_i| stays within :data:`SETTLING_BAND` for the rest of the
  run [s] (0 if it never leaves the band after t_last; inf if it is outside
  at the end, or the run stopped early — diverged — or before t_last);
- ``max_coupler_force``: max |f| over the dense grid of the whole run [N].
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor, Future
from dataclasses import dataclass, replace
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.analysis.check import finite_or_none

if TYPE_CHECKING:
    from trainctl.design import Design
    from trainctl.scenario import Scenario
    from trainctl.sim.metrics import Metrics
    from trainctl.sim.results import SimulationResult

__all__ = ["BASELINE", "SETTLING_BAND", "Deviation", "Repetition", "baseline_index",
           "collect_repetitions", "deviation", "repetition_scenario", "run_repetition",
           "run_repetitions", "spread", "submit_repetitions"]

Array = NDArray[np.float64]

SETTLING_BAND = 0.1
"""Band of the settling time [m/s] (0.36 km/h): a fifth of the 0.5 m/s tracking tolerance of
the seed-003 cases, five times their noise-driven speed error (about 0.02 m/s)."""

BASELINE = -1
"""The ``index`` of repetition 0's baseline-network run; repetition r's is ``BASELINE - r``
(:func:`run_repetition`, :func:`baseline_index`)."""


def baseline_index(index: int) -> int:
    """The ``index`` of the baseline run paired with repetition ``index`` (and back).

    Parameters
    ----------
    index : int
        A repetition's index (>= 0) or a baseline's (< 0).

    Returns
    -------
    int
        The paired index, -1 - ``index``.

    Examples
    --------
    >>> baseline_index(0), baseline_index(3), baseline_index(-4)
    (-1, -4, 3)
    """
    return BASELINE - int(index)


@dataclass(frozen=True, kw_only=True)
class Deviation:
    """Whole-run measures of one run (module docstring), SI.

    Parameters
    ----------
    rms_error : ndarray
        RMS speed error per vehicle over the samples [m/s], shape (n,).
    max_error : ndarray
        Largest |speed error| per vehicle over the dense grid [m/s], shape (n,).
    settling_time : ndarray
        Per vehicle, time after the reference's last breakpoint until the
        error stays within :data:`SETTLING_BAND` [s] (inf: outside at the
        end), shape (n,).
    max_coupler_force : float
        Largest |coupler force| over the dense grid [N] (0 for one vehicle).
    since : float
        The reference's last breakpoint t_last [s].
    diverged : bool
        The run stopped early (diverged).

    Examples
    --------
    Two vehicles; the second was still outside the band at the end, so its
    settling time is infinite, written as None in JSON:

    >>> d = Deviation(rms_error=np.array([0.02, 0.03]), max_error=np.array([0.1, 0.2]),
    ...               settling_time=np.array([12.5, np.inf]), max_coupler_force=4.0e4,
    ...               since=100.0, diverged=False)
    >>> d.to_dict()["settling_time"]
    [12.5, None]
    """

    rms_error: Array
    max_error: Array
    settling_time: Array
    max_coupler_force: float
    since: float
    diverged: bool

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe (inf and nan as None).

        Returns
        -------
        dict of str to object
            Every field by name, arrays as lists of float: ``rms_error`` and
            ``max_error`` [m/s] per vehicle, ``settling_time`` [s] per vehicle
            (None where infinite), ``max_coupler_force`` [N], ``since`` [s] and
            ``diverged``.
        """
        return {"rms_error": _json_list(self.rms_error), "max_error": _json_list(self.max_error),
                "settling_time": _json_list(self.settling_time),
                "max_coupler_force": finite_or_none(self.max_coupler_force),
                "since": self.since, "diverged": self.diverged}


def deviation(result: SimulationResult, since: float, band: float = SETTLING_BAND) -> Deviation:
    """The whole-run measures of a run (module docstring).

    Parameters
    ----------
    result : SimulationResult
        The run.
    since : float
        The reference's last breakpoint t_last [s]: settling is counted from it.
    band : float
        The settling band [m/s], > 0.

    Returns
    -------
    Deviation

    Examples
    --------
    A vehicle whose error decays as e^(−t/10) from 1 m/s enters a 0.1 m/s
    band at t = 10 ln 10 ≈ 23.03 s, the first point of a 0.1 s grid after it
    23.1 s:

    >>> from trainctl.sim.results import SimulationResult
    >>> t = np.linspace(0.0, 60.0, 601)
    >>> e = np.exp(-t / 10.0)
    >>> r = SimulationResult(time=t, states=np.vstack([20.0 + e, t]),
    ...     velocities=(20.0 + e)[None, :], coupler_forces=np.zeros((0, 601)),
    ...     inputs=np.zeros((1, 600)), reference_speed=np.full(601, 20.0),
    ...     reference_acceleration=np.zeros(601), statuses=("optimal",) * 600,
    ...     iterations=np.zeros(600, dtype=int), residuals=((),) * 600,
    ...     solve_times=np.zeros(600), fallbacks=("",) * 600, controller_name="c", seed=0,
    ...     dt=0.1)
    >>> d = deviation(r, since=0.0)
    >>> round(float(d.settling_time[0]), 1), round(float(d.max_error[0]), 3)
    (23.1, 1.0)
    """
    n = result.velocities.shape[0]
    e = result.velocities - result.reference_speed[None, :]
    rms = np.sqrt(np.mean(e * e, axis=1))
    t = np.asarray(result.dense_time, dtype=float)
    dense = result.dense_states[:n] - result.dense_reference_speed[None, :]
    peak = np.max(np.abs(dense), axis=1)
    diverged = result.meta.get("divergence") is not None
    if diverged or t[-1] < since:
        settling = np.full(n, math.inf)   # stopped early: it never settled
    else:
        outside = (t >= since)[None, :] & (np.abs(dense) > band)
        last = t.size - 1 - np.argmax(outside[:, ::-1], axis=1)   # last column outside
        after_last = t[np.minimum(last + 1, t.size - 1)] - since
        settling = np.where(~outside.any(axis=1), 0.0,
                            np.where(last == t.size - 1, math.inf, after_last))
    forces = result.dense_coupler_forces
    force = float(np.max(np.abs(forces))) if forces.size else 0.0
    return Deviation(rms_error=rms, max_error=peak, settling_time=settling,
                     max_coupler_force=force, since=float(since), diverged=diverged)


@dataclass(frozen=True, kw_only=True)
class Repetition:
    """One run of a strategy, summarised (module docstring).

    Parameters
    ----------
    strategy : str
        The strategy.
    index : int
        The repetition r (seed ``seed + r``), or ``BASELINE - r`` for the
        baseline-network run paired with it (the same seed).
    seed : int
        The seed the run used.
    metrics : Metrics
        As in the main table (after ``settle_time``).
    deviation : Deviation
        The whole-run measures.

    Examples
    --------
    The summary :func:`run_repetition` returns for the second run of a
    strategy (seed 0 + 1):

    >>> import trainctl
    >>> scenario = (trainctl.load_scenario("crh2-dmpc")
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0))
    >>> rep = run_repetition(scenario, "decentralised", None, 1)
    >>> rep.strategy, rep.index, rep.seed
    ('decentralised', 1, 1)
    >>> sorted(rep.to_dict())
    ['deviation', 'index', 'max_error_settled', 'rms_error_settled', 'seed', 'strategy']
    """

    strategy: str
    index: int
    seed: int
    metrics: Metrics
    deviation: Deviation

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe: strategy, index, seed, the deviation measures and the tracking metrics.

        Returns
        -------
        dict of str to object
            ``strategy``, ``index`` and ``seed``; ``deviation``, the
            :meth:`Deviation.to_dict` of the whole-run measures; and
            ``rms_error_settled`` and ``max_error_settled``, the metrics' RMS and
            largest speed errors per vehicle after ``settle_time`` [m/s], as
            lists.
        """
        m = self.metrics
        return {"strategy": self.strategy, "index": self.index, "seed": self.seed,
                "deviation": self.deviation.to_dict(),
                "rms_error_settled": _json_list(m.rms_error),
                "max_error_settled": _json_list(m.max_error)}


def _json_list(values: Array) -> list[float | None]:
    """``values`` as a list with None for every non-finite item (strict JSON has no nan or
    inf; a run that stopped before its settle time has no errors to measure)."""
    return [finite_or_none(x) for x in np.asarray(values, dtype=float).tolist()]


def last_breakpoint(scenario: Scenario) -> float:
    """The reference's last breakpoint time [s] (0 without ``[simulation]``)."""
    sim = scenario.simulation
    return 0.0 if sim is None else float(sim.reference_times[-1])


def run_repetition(scenario: Scenario, strategy: str, design: Design | None,
                   index: int) -> Repetition:
    """Run one strategy once more and summarise it (module docstring).

    Parameters
    ----------
    scenario : Scenario
        The scenario (with ``[simulation]``).
    strategy : str
        One of its strategies.
    design : Design or None
        The run's design (built here when None).
    index : int
        r >= 0: the seed ``scenario.seed + r``; ``BASELINE - r``
        (:func:`baseline_index`): the scenario over its baseline network
        (``[simulation] baseline_network``) with the seed of repetition r,
        so that a delay-free baseline has that repetition's noise draws.

    Returns
    -------
    Repetition

    Examples
    --------
    Run 1 of the decentralised law over the first 120 s of the CRH2
    scenario, with the seed 0 + 1. The reference's last breakpoint is at
    1200 s, after the run's end, so no vehicle has settled yet (inf):

    >>> import trainctl
    >>> scenario = (trainctl.load_scenario("crh2-dmpc")
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0))
    >>> rep = run_repetition(scenario, "decentralised", None, 1)
    >>> rep.seed, rep.deviation.since, rep.deviation.settling_time.tolist()
    (1, 1200.0, [inf, inf, inf, inf])
    >>> bool(np.all(rep.deviation.rms_error < 1.0))  # m/s, four vehicles
    True
    """
    from trainctl.run.simulate import _simulate_recorded

    run_scenario = repetition_scenario(scenario, index)
    result = _simulate_recorded(run_scenario, strategy, design)  # recorded in its metrics
    return summarise(result, scenario, strategy, index, int(run_scenario.seed))


def repetition_scenario(scenario: Scenario, index: int) -> Scenario:
    """The scenario run ``index`` simulates (:func:`run_repetition`): its seed, its network.

    Parameters
    ----------
    scenario : Scenario
        The scenario (with ``[simulation]``).
    index : int
        A repetition r >= 0 or a baseline ``BASELINE - r``.

    Returns
    -------
    Scenario
        With the seed ``seed + r``; a baseline over the baseline network.

    Examples
    --------
    >>> import trainctl
    >>> scenario = trainctl.load_scenario("heavy-haul-hinf-delay")
    >>> run = repetition_scenario(scenario, baseline_index(2))
    >>> run.seed, run.network.delay_range_s
    (5, None)
    """
    sim = scenario.simulation
    assert sim is not None
    if index <= BASELINE:
        return replace(baseline_scenario(scenario), seed=int(scenario.seed) + baseline_index(index))
    return replace(scenario, seed=int(scenario.seed) + int(index))


def run_repetitions(scenario: Scenario, strategy: str, design: Design | None,
                    indices: Sequence[int]) -> list[Repetition]:
    """:func:`run_repetition` for several runs of one strategy, as one batch when it can.

    The runs share the design, so they go through
    :func:`trainctl.run.simulate.simulate_batch_strategy` (one plant and one
    law over (runs x states) arrays, each run's own network plan), whose
    results equal the serial runs' bit for bit; where the batch does not
    cover them (a family without a batched law, a run that diverges, ...)
    each runs serially.

    Parameters
    ----------
    scenario : Scenario
        The scenario (with ``[simulation]``).
    strategy : str
        One of its strategies.
    design : Design or None
        The runs' design (built here when None).
    indices : sequence of int
        The runs (:func:`run_repetition`'s ``index``).

    Returns
    -------
    list of Repetition
        One per index, in order.

    Examples
    --------
    Repetition 1 and the baseline of repetition 0 of the synchronous
    baseline, batched, equal their serial runs:

    >>> import trainctl
    >>> scenario = (trainctl.load_scenario("heavy-haul-hinf-delay")
    ...             .replace("simulation.settle_time", 10.0)
    ...             .replace("simulation.duration", 20.0))
    >>> reps = run_repetitions(scenario, "synchronous.synchronous", None, [1, BASELINE])
    >>> one = run_repetition(scenario, "synchronous.synchronous", None, BASELINE)
    >>> [r.seed for r in reps], bool(np.array_equal(reps[1].deviation.rms_error,
    ...                                              one.deviation.rms_error))
    ([4, 3], True)
    """
    from trainctl.design import build_design
    from trainctl.run.simulate import batch_size, simulate_batch_strategy

    indices = [int(i) for i in indices]
    if len(indices) < 2:
        return [run_repetition(scenario, strategy, design, i) for i in indices]
    if design is None:
        design = build_design(scenario)
    scenarios = [repetition_scenario(scenario, i) for i in indices]
    size = batch_size(scenarios[0], strategy, design)
    out: list[Repetition] = []
    for a in range(0, len(indices), size):  # each batch summarised before the next runs
        chunk, runs = indices[a : a + size], scenarios[a : a + size]
        results = simulate_batch_strategy(runs, strategy, design) if len(chunk) > 1 else None
        if results is None:
            out += [run_repetition(scenario, strategy, design, i) for i in chunk]
        else:
            out += [summarise(result, scenario, strategy, i, int(sc.seed))
                    for result, sc, i in zip(results, runs, chunk, strict=True)]
    return out


def baseline_scenario(scenario: Scenario) -> Scenario:
    """The scenario over its baseline network (``[simulation] baseline_network``).

    ``"ideal"``: without ``[network]``; ``"delay-free"``: its ``[network]``
    with no delay (``delay_s`` and ``delay_range_s`` unset).
    """
    sim = scenario.simulation
    kind = None if sim is None else sim.baseline_network
    if kind is None or scenario.network is None:
        return scenario
    if kind == "ideal":
        return replace(scenario, network=None)
    return replace(scenario, network=replace(scenario.network, delay_s=None,
                                             delay_range_s=None))


def summarise(result: SimulationResult, scenario: Scenario, strategy: str, index: int,
              seed: int) -> Repetition:
    """A run's :class:`Repetition` (its metrics and whole-run measures)."""
    from trainctl.sim.metrics import compute_metrics

    sim = scenario.simulation
    assert sim is not None
    metrics = compute_metrics(result, settle_time=sim.settle_time,
                              regen_efficiency=sim.regen_efficiency)
    return Repetition(strategy=strategy, index=int(index), seed=int(seed), metrics=metrics,
                      deviation=deviation(result, last_breakpoint(scenario)))


def planned_runs(scenario: Scenario) -> list[tuple[str, int]]:
    """(strategy, index) of every extra run the ``[simulation]`` asks for, in order.

    Repetitions 1 .. R−1 of each strategy, then the baseline-network run of
    every repetition 0 .. R−1 (only when the scenario has a ``[network]``;
    without one run 0 is already ideal).
    """
    sim = scenario.simulation
    if sim is None:
        return []
    runs: list[tuple[str, int]] = [(s, r) for s in sim.strategies
                                   for r in range(1, sim.repetitions)]
    if sim.baseline_network is not None and scenario.network is not None:
        runs += [(s, BASELINE - r) for s in sim.strategies for r in range(sim.repetitions)]
    return runs


def submit_repetitions(scenario: Scenario, executor: Executor, design: Design | None = None
                       ) -> dict[tuple[str, int], Future[Repetition]]:
    """Start every extra run (:func:`planned_runs`) on an executor.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    executor : concurrent.futures.Executor
        A process pool (:func:`trainctl.run.pool.process_pool`) or another executor.
    design : Design or None
        The run's design, sent along.

    Returns
    -------
    dict
        (strategy, index) → future of its :class:`Repetition`.

    Examples
    --------
    ``repetitions = 2`` of one strategy asks for one extra run, repetition 1
    (run 0 is the main run); without ``[network]`` there is no baseline run:

    >>> from concurrent.futures import ThreadPoolExecutor
    >>> import trainctl
    >>> scenario = (trainctl.load_scenario("crh2-dmpc")
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0)
    ...             .replace("simulation.strategies", ["decentralised"])
    ...             .replace("simulation.repetitions", 2))
    >>> with ThreadPoolExecutor(max_workers=1) as pool:
    ...     futures = submit_repetitions(scenario, pool)
    ...     seeds = {key: f.result().seed for key, f in futures.items()}
    >>> seeds
    {('decentralised', 1): 1}
    """
    futures: dict[tuple[str, int], Future[Repetition]] = {}
    for strategy, indices in _by_strategy(planned_runs(scenario)).items():
        batch = executor.submit(run_repetitions, scenario, strategy, design, indices)
        mine = {r: Future[Repetition]() for r in indices}
        futures.update({(strategy, r): f for r, f in mine.items()})
        batch.add_done_callback(partial(_hand_out, mine))
    return futures


def _by_strategy(runs: Sequence[tuple[str, int]]) -> dict[str, list[int]]:
    """The planned runs' indices per strategy, in order."""
    out: dict[str, list[int]] = {}
    for strategy, index in runs:
        out.setdefault(strategy, []).append(index)
    return out


def _hand_out(futures: Mapping[int, Future[Repetition]], batch: Future[list[Repetition]]) -> None:
    """Set each run's future from its batch's (its result or its exception); a cancelled
    batch (an interrupted command) cancels its runs."""
    if batch.cancelled():
        for future in futures.values():
            future.cancel()
        return
    error = batch.exception()
    for k, (_, future) in enumerate(futures.items()):
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(batch.result()[k])


def collect_repetitions(
    scenario: Scenario, design: Design | None, main: Mapping[str, SimulationResult], *,
    pending: Mapping[tuple[str, int], Future[Repetition]] | None = None,
) -> tuple[dict[str, tuple[Repetition, ...]], dict[str, tuple[Repetition, ...]]]:
    """Every strategy's repetitions (run 0 from ``main``) and its baseline-network run.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    design : Design or None
        The run's design.
    main : mapping of str to SimulationResult
        Run 0 of every strategy (the runs shown).
    pending : mapping or None
        Futures from :func:`submit_repetitions`; None: the extra runs run here.

    Returns
    -------
    (repetitions, baseline)
        Strategy → its runs in index order (empty when ``repetitions`` is
        1 and there is no baseline run), strategy → the baseline-network run
        of each of them, in the same order.

    Examples
    --------
    Run 0 comes from ``main``; repetition 1 runs here. Without noise or a
    network the two seeds give the same trajectory, so the same RMS error:

    >>> from trainctl.run.analysis import simulate_strategy
    >>> import trainctl
    >>> scenario = (trainctl.load_scenario("crh2-dmpc")
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0)
    ...             .replace("simulation.strategies", ["decentralised"])
    ...             .replace("simulation.repetitions", 2))
    >>> main = {"decentralised": simulate_strategy(scenario, "decentralised")}
    >>> reps, baseline = collect_repetitions(scenario, None, main)
    >>> [r.seed for r in reps["decentralised"]], baseline
    ([0, 1], {})
    >>> first, second = reps["decentralised"]
    >>> bool(np.allclose(first.deviation.rms_error, second.deviation.rms_error))
    True
    """
    runs = planned_runs(scenario)
    if not runs:
        return {}, {}
    done: dict[tuple[str, int], Repetition] = {}
    if pending is not None:
        done = {key: pending[key].result() for key in runs}
    else:
        for strategy, indices in _by_strategy(runs).items():
            batch = run_repetitions(scenario, strategy, design, indices)
            done.update({(strategy, r): rep for r, rep in zip(indices, batch, strict=True)})
    sim = scenario.simulation
    assert sim is not None
    reps: dict[str, tuple[Repetition, ...]] = {}
    baseline: dict[str, tuple[Repetition, ...]] = {}
    for strategy, result in main.items():
        first = summarise(result, scenario, strategy, 0, int(scenario.seed))
        reps[strategy] = (first, *(done[(strategy, r)] for r in range(1, sim.repetitions)))
        if (strategy, BASELINE) in done:
            baseline[strategy] = tuple(done[(strategy, baseline_index(r))]
                                       for r in range(sim.repetitions))
    return reps, baseline


def spread(values: Any) -> dict[str, float]:
    """Median, min and max of some numbers (inf kept), JSON-safe as floats.

    Parameters
    ----------
    values : array_like
        The numbers.

    Returns
    -------
    dict
        ``median``, ``min``, ``max`` and ``count``.

    Examples
    --------
    >>> spread([3.0, 1.0, 2.0])
    {'median': 2.0, 'min': 1.0, 'max': 3.0, 'count': 3}
    """
    x = np.asarray(values, dtype=float)
    return {"median": float(np.median(x)), "min": float(np.min(x)), "max": float(np.max(x)),
            "count": int(x.size)}
