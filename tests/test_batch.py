"""Batched Monte-Carlo (trainctl.sim.batch): every run of a batch equals its serial run,
bit for bit, computed live here against :func:`trainctl.run.simulate.simulate_strategy`."""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np
import pytest

import trainctl
from trainctl.models._plant_batch import advance_dense_batch
from trainctl.models.dynamics import equilibrium
from trainctl.models.graphs import REFERENCE, make_graph
from trainctl.models.network.schedule import plan
from trainctl.models.network.schema import Interruption, NetworkSettings
from trainctl.models.network.simulator import Network
from trainctl.models.plant import Plant
from trainctl.run.repetitions import BASELINE, repetition_scenario, run_repetition, run_repetitions
from trainctl.run.simulate import simulate_batch_strategy, simulate_strategy
from trainctl.sim.results import SimulationResult

WALL_CLOCK = {"solve_times"}


def assert_same(batched: SimulationResult, serial: SimulationResult) -> None:
    """Every field and meta entry equal bit for bit, but the wall-clock ones."""
    for f in fields(serial):
        if f.name in WALL_CLOCK or f.name == "meta":
            continue
        a, b = getattr(serial, f.name), getattr(batched, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape, f.name
            assert np.array_equal(a, b, equal_nan=True), f.name
        else:
            assert a == b, f.name
    meta_a = {k: v for k, v in serial.meta.items() if k != "wall_time"}
    meta_b = {k: v for k, v in batched.meta.items() if k != "wall_time"}
    assert meta_a == meta_b


def short(name: str, duration: float) -> trainctl.Scenario:
    return (trainctl.load_scenario(name).replace("simulation.settle_time", duration / 2)
            .replace("simulation.duration", duration))


@pytest.mark.parametrize("strategy", ["distributed", "synchronous.synchronous"])
def test_delay_batch_equals_serial_seed_by_seed(strategy: str) -> None:
    # two repetitions over the 0-2 s random delays and their delay-free baselines
    scenario = short("heavy-haul-hinf-delay", 40.0)
    indices = [0, 1, BASELINE, BASELINE - 1]
    runs = [repetition_scenario(scenario, i) for i in indices]
    batched = simulate_batch_strategy(runs, strategy)
    assert batched is not None
    for run, result in zip(runs, batched, strict=True):
        serial = simulate_strategy(run, strategy, warn=False)
        assert_same(result, serial)
    # the runs differ from each other (the seeds and the delays matter)
    assert not np.array_equal(batched[0].velocities, batched[1].velocities)
    assert not np.array_equal(batched[0].velocities, batched[2].velocities)


def test_delayed_own_speed_batch_equals_serial() -> None:
    # another networked scenario: a constant 1 s delay, each difference with the own speed
    # at the send time (the record of own speeds)
    scenario = short("heavy-haul-hinf-delayed-own-speed", 30.0)
    runs = [replace(scenario, seed=s) for s in (0, 7, 8)]
    batched = simulate_batch_strategy(runs, "distributed")
    assert batched is not None
    for run, result in zip(runs, batched, strict=True):
        assert_same(result, simulate_strategy(run, "distributed", warn=False))


@pytest.mark.parametrize("strategy", ["distributed", "synchronous.synchronous"])
def test_outage_and_losses_batch_equals_serial(strategy: str) -> None:
    # every link cut over 5-12 s, 20 % of the messages lost, delays in 0-1 s
    scenario = (short("heavy-haul-hinf-interruption", 20.0)
                .replace("network.interruption", [{"start": 5.0, "end": 12.0, "links": "all"}])
                .replace("network.loss_probability", 0.2)
                .replace("network.delay_range_s", [0.0, 1.0]))
    runs = [replace(scenario, seed=s) for s in (1, 2)]
    batched = simulate_batch_strategy(runs, strategy)
    assert batched is not None
    for run, result in zip(runs, batched, strict=True):
        assert_same(result, simulate_strategy(run, strategy, warn=False))
    if strategy == "distributed":
        counts = batched[0].meta["network"]
        assert counts["lost"] > 0 and counts["blocked"] > 0


def test_ideal_network_batch_equals_serial() -> None:
    # no [network]: the hinf law reads the measured speeds and the reference directly
    scenario = short("heavy-haul-hinf-ideal", 20.0)
    runs = [replace(scenario, seed=s) for s in (1, 2)]
    for strategy in scenario.simulation.strategies:
        batched = simulate_batch_strategy(runs, strategy)
        assert batched is not None
        for run, result in zip(runs, batched, strict=True):
            assert_same(result, simulate_strategy(run, strategy, warn=False))


def test_repetitions_batched_equal_serial_repetitions() -> None:
    scenario = short("heavy-haul-hinf-delay", 20.0)
    indices = [1, 2, BASELINE]
    batched = run_repetitions(scenario, "distributed", None, indices)
    for i, rep in zip(indices, batched, strict=True):
        assert rep.to_dict() == run_repetition(scenario, "distributed", None, i).to_dict()


def test_fallback_without_batched_law() -> None:
    # the MPC family has no batched law: serial runs, the same summaries
    scenario = (trainctl.load_scenario("crh2-dmpc").replace("simulation.settle_time", 60.0)
                .replace("simulation.duration", 120.0))
    runs = [replace(scenario, seed=s) for s in (1, 2)]
    assert simulate_batch_strategy(runs, "decentralised") is None
    reps = run_repetitions(scenario, "decentralised", None, [1, 2])
    assert [r.to_dict() for r in reps] == [run_repetition(scenario, "decentralised", None, i)
                                           .to_dict() for i in (1, 2)]


def test_fallback_on_divergence() -> None:
    # a bound every run exceeds at once: the serial loop stops each run, the batch declines
    scenario = short("heavy-haul-hinf-delay", 20.0).replace(
        "simulation.divergence_speed_error", 1e-9)
    runs = [replace(scenario, seed=s) for s in (3, 4)]
    assert simulate_batch_strategy(runs, "distributed") is None


def test_plant_batch_equals_serial_rows() -> None:
    # rows at many speeds (grid speed changes inside the interval), some next to the grade
    # change at 20 km (the serial crossing path), inputs off equilibrium
    scenario = trainctl.load_scenario("heavy-haul-hinf-delay")
    plant = Plant(train=scenario.train, track=scenario.track)
    n = scenario.train.n_vehicles
    rng = np.random.default_rng(1)
    states, inputs = [], []
    for r in range(48):
        eq = equilibrium(scenario.train, float(rng.uniform(0.5, 30.0)))
        where = 20000.0 + rng.uniform(-5.0, 2600.0) if r % 3 == 0 else rng.uniform(0, 30000)
        x = eq.state(position=float(where))
        x[:n] += rng.normal(0.0, 0.5, n)
        states.append(x)
        inputs.append(eq.inputs * rng.uniform(0.5, 1.5, n))
    X, U = np.array(states), np.array(inputs)
    # and rows about one speed, all with one grid speed (one propagator broadcast)
    eq = equilibrium(scenario.train, 15.0)
    same = np.tile(eq.state(position=1000.0), (8, 1))
    same[:, :n] += rng.uniform(-0.3, 0.3, (8, n))
    X = np.vstack([X, same])
    U = np.vstack([U, np.tile(eq.inputs, (8, 1)) * rng.uniform(0.9, 1.1, (8, n))])
    # heads just short of the grade change at 20 km, so that vehicles cross it within
    # 0.2 s (and, much farther, within one 20 s interval)
    cross = np.tile(equilibrium(scenario.train, 20.0).state(position=0.0), (6, 1))
    cross[:, 2 * n - 1] = 20000.0 - np.array([0.5, 1.0, 2.0, 60.0, 300.0, 380.0])
    X = np.vstack([X, cross])
    U = np.vstack([U, np.tile(equilibrium(scenario.train, 20.0).inputs, (6, 1))])
    from trainctl.models._plant_batch import _integrate

    crossed = _integrate(plant, X, U, 20.0, plant.substeps(20.0), 50)[1]
    assert crossed[-6:].all() and not crossed.all()
    for dt, every, inner in [(0.2, 1, 1), (1.0, 3, 1), (0.2, 1, 2), (20.0, 50, 1)]:
        batched = advance_dense_batch(plant, X, U, dt, every, inner)
        for r in range(X.shape[0]):
            serial = plant.advance_dense(X[r], U[r], dt, every, inner)[1]
            assert np.array_equal(batched[r], serial), (dt, every, inner, r)


def test_plan_equals_network() -> None:
    # delays, losses, noise and an outage: what the plan holds is what Network.messages gives
    settings = NetworkSettings(delay_range_s=[0.0, 0.7], loss_probability=0.3,
                               communication_noise_std=0.1,
                               interruptions=[Interruption(start=1.0, end=2.0, links=[[1, 0]])])
    graph = make_graph("bidirectional", 3, pinned="all")
    seed = np.random.SeedSequence([5, 1])
    times = 0.1 * np.arange(60)
    rng = np.random.default_rng(0)
    values = rng.uniform(10.0, 20.0, (times.size, 3))
    ref = rng.uniform(10.0, 20.0, times.size)
    net = Network(settings, graph, seed=seed)
    planned = plan(Network(settings, graph, seed=seed), times, (REFERENCE, 0, 1, 2))
    sent = np.array([[ref[k] if s == REFERENCE else values[k, s] for _, s in planned.links]
                     for k in range(times.size)])
    for k, t in enumerate(times.tolist()):
        net.send_all(t, values[k], reference=ref[k])
        got = net.messages(t)
        held, has = planned.held(k, sent)
        for m, link in enumerate(planned.links):
            if link in got:
                assert has[m] and held[m] == got[link].value
                assert times[planned.source[k, m]] == got[link].t_sent
            else:
                assert not has[m]
    log, mine = net.history(), planned.history(times.size, sent)
    assert np.array_equal(planned.held_noise_square(), log.held_noise_square(times))
    for f in fields(log):
        a, b = getattr(log, f.name), getattr(mine, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype, f.name
            assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), f.name
        else:
            assert a == b, f.name


@pytest.mark.parametrize("widths", [(4, 1, 2, 2, 1), (3,), (0, 2, 5)])
def test_draws_equal_the_generators_calls(widths: tuple[int, ...]) -> None:
    # the raw-stream decoding (slow-path normals included: ~1 % of the draws) against
    # the generator's own random((w, 2)) and standard_normal(w) calls
    from trainctl.models.network._draws import draws, draws_by_calls

    for seed in (np.random.SeedSequence([3, 1]), np.random.SeedSequence([9, 2]), 11):
        got = draws(seed, widths, 4000)
        assert got is not None
        want = draws_by_calls(np.random.default_rng(seed), widths, 4000)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
