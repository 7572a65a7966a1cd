# Simulating one strategy of a scenario: its controller, its plant, its closed loop.
"""Build a strategy's controller and simulate it (:func:`simulate_strategy`), here or on a pool."""

from __future__ import annotations

import pickle
import threading
from collections.abc import Sequence
from concurrent.futures import Executor, Future
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from trainctl._validation import numerical_errors

if TYPE_CHECKING:
    from trainctl.controllers.base import Controller
    from trainctl.design import Design
    from trainctl.models.network.simulator import Network
    from trainctl.models.plant import Plant
    from trainctl.scenario import Scenario
    from trainctl.sim.reference import SpeedProfile
    from trainctl.sim.results import SimulationResult

__all__ = ["BATCH_VALUES", "NETWORK_STREAM", "batch_size", "make_controller",
           "simulate_batch_strategy", "simulate_strategy", "submit_simulations"]

NETWORK_STREAM = 1
"""Spawn key of the network's random stream: ``SeedSequence([seed, NETWORK_STREAM])``, apart
from the measurement noise's ``default_rng(seed)``, so the two are not correlated."""


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
    from trainctl.sim.closed_loop import simulate

    with numerical_errors(f"{scenario.source}: simulating {strategy!r}"):
        run = _prepare(scenario, strategy, design)
        return simulate(run.plant, run.controller, run.profile, duration=run.duration,
                        initial_state=run.state, seed=scenario.seed, network=run.network,
                        warn=warn, **run.options)


class _Run(NamedTuple):
    """One run of a strategy, ready for :func:`trainctl.sim.simulate` (or a batch of them)."""

    plant: Plant
    controller: Controller
    profile: SpeedProfile
    duration: float
    state: NDArray[np.float64]
    network: Network | None
    options: dict[str, Any]
    """The other keyword arguments of :func:`trainctl.sim.simulate`."""


def _prepare(scenario: Scenario, strategy: str, design: Design | None) -> _Run:
    """:func:`simulate_strategy`'s plant, controller (prepared for the scenario's network and
    seed), reference, initial state and network (inside its ``numerical_errors``)."""
    from trainctl.exceptions import ScenarioError
    from trainctl.models.dynamics import equilibrium
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
    controller = make_controller(scenario, strategy, design)
    prepare = getattr(controller, "prepare", None)
    if callable(prepare):
        prepare(scenario.network, int(scenario.seed))
    network = None
    if scenario.network is not None and getattr(controller, "uses_network", False):
        from trainctl.models.network.simulator import Network

        network = Network(scenario.network, scenario.graph(),
                          seed=np.random.SeedSequence([scenario.seed, NETWORK_STREAM]))
    options: dict[str, Any] = {
        "preview_steps": _preview_steps(controller), "measurement_noise": sim.measurement_noise,
        "full_state": getattr(controller, "needs_full_state", True),
        "saturation": sim.plant_saturation, "output_interval": sim.output_interval,
        "divergence_speed_error": sim.divergence_speed_error}
    return _Run(_shared_plant(Plant, scenario), controller, profile, sim.duration, state,
                network, options)


def simulate_batch_strategy(scenarios: Sequence[Scenario], strategy: str,
                            design: Design | None = None) -> list[SimulationResult] | None:
    """:func:`simulate_strategy` (``warn=False``) of one strategy for several runs at once.

    The scenarios differ only in their seed and ``[network]``; they run as
    batches (:func:`trainctl.sim.batch.simulate_batch`, at most
    :data:`BATCH_VALUES` dense numbers each), each result equal to its serial
    run bit for bit but for the wall-clock fields.

    Parameters
    ----------
    scenarios : sequence of Scenario
        The runs' scenarios.
    strategy : str
        A name from their ``[simulation] strategies``.
    design : Design or None
        Their design; built here (per run) when None.

    Returns
    -------
    list of SimulationResult or None
        One per scenario; None when the batch does not cover these runs (a
        family without a batched law, a run that diverges, ...): run them
        serially.

    Examples
    --------
    >>> from dataclasses import replace
    >>> from trainctl.scenario import load_scenario
    >>> sc = (load_scenario("heavy-haul-hinf-delay").replace("simulation.settle_time", 5.0)
    ...       .replace("simulation.duration", 10.0))
    >>> runs = [replace(sc, seed=3), replace(sc, seed=4)]
    >>> batch = simulate_batch_strategy(runs, "distributed")
    >>> serial = simulate_strategy(runs[1], "distributed", warn=False)
    >>> bool(np.array_equal(batch[1].dense_states, serial.dense_states))
    True
    """
    from trainctl.controllers.batch import BatchUnsupported
    from trainctl.sim.batch import simulate_batch

    if not scenarios:
        return []
    first = scenarios[0]
    with numerical_errors(f"{first.source}: simulating {strategy!r} in a batch"):
        runs = [_prepare(sc, strategy, design) for sc in scenarios]
        head = runs[0]
        if any(r.plant is not head.plant or r.options != head.options
               or r.duration != head.duration
               or not np.array_equal(r.profile.times, head.profile.times)
               or not np.array_equal(r.profile.speeds, head.profile.speeds) for r in runs):
            return None
        size = _batch_size(head)
        results: list[SimulationResult] = []
        try:
            for a in range(0, len(runs), size):
                chunk, seeds = runs[a : a + size], scenarios[a : a + size]
                results += simulate_batch(
                    head.plant, [r.controller for r in chunk], head.profile,
                    duration=head.duration, initial_states=[r.state for r in chunk],
                    seeds=[int(sc.seed) for sc in seeds], networks=[r.network for r in chunk],
                    warn=False, **head.options)
        except BatchUnsupported:
            return None
        return results


def batch_size(scenario: Scenario, strategy: str, design: Design | None = None) -> int:
    """How many runs of one strategy of this scenario one batch takes (:data:`BATCH_VALUES`).

    Parameters
    ----------
    scenario : Scenario
        One of the runs' scenarios (they differ in seed and network only).
    strategy : str
        The strategy.
    design : Design or None
        The design (built here when None).

    Returns
    -------
    int
        At least 1.

    Examples
    --------
    A 4-vehicle run of 1800 s at 0.2 s with 4 dense points per sample holds
    36 001 x 11 numbers of dense states and coupler forces:

    >>> from trainctl.scenario import load_scenario
    >>> batch_size(load_scenario("heavy-haul-hinf-delay"), "distributed")
    84
    """
    with numerical_errors(f"{scenario.source}: sizing a batch of {strategy!r}"):
        return _batch_size(_prepare(scenario, strategy, design))


BATCH_VALUES = 1 << 25
"""Most numbers of dense states and coupler forces [-] one batch holds (256 MB of float64);
a batch of longer runs is split."""


def _batch_size(run: _Run) -> int:
    """How many runs like ``run`` one batch takes (:data:`BATCH_VALUES`)."""
    from trainctl.sim._log import dense_grid

    dt = float(run.controller.dt)
    steps = max(1, round(run.duration / dt))
    n = run.plant.train.n_vehicles
    substeps = run.plant.substeps(dt)
    interval = run.options["output_interval"]
    every, inner = dense_grid(substeps, steps, n, dt, interval,
                              run.plant.fastest_rate if interval is None else 0.0)
    points = steps * run.plant.dense_offsets(dt, every, inner).size + 1
    return max(1, BATCH_VALUES // (points * (3 * n - 1)))


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


