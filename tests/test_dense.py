"""Between-sample truth: the plant's dense output, the dense grid of a run and its metrics."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from trainctl.controllers.base import StepRecord
from trainctl.exceptions import DimensionError, ModelError
from trainctl.models import (
    Plant,
    Track,
    TrackSection,
    coupler_forces,
    crh2_half,
    equilibrium,
    heavy_haul_1p2p1,
    train_rhs,
)
from trainctl.run.analysis import simulate_strategy
from trainctl.scenario import load_scenario
from trainctl.sim import (
    MAX_DENSE_POINTS,
    MAX_DENSE_VALUES,
    SimulationResult,
    compute_metrics,
    dense_grid,
    ramp_profile,
    simulate,
)


def crossing_track() -> Track:
    """Grade and curve changes that the train crosses within a 20 s interval from 800 m."""
    return Track(sections=(
        TrackSection(start=0.0),
        TrackSection(start=1000.0, grade_permille=6.0),
        TrackSection(start=1300.0, grade_permille=-4.0, curve_radius=5000.0),
        TrackSection(start=1500.0),
    ))


def start_state() -> tuple[np.ndarray, np.ndarray]:
    """A state off the equilibrium (relative speeds, a stretched coupler) and a 30 % push."""
    eq = equilibrium(crh2_half(), 60.0)
    x = eq.state(position=800.0)
    x[:4] += [0.3, -0.1, 0.0, 0.2]
    x[4] += 1e-4
    return x, 1.3 * eq.inputs


class TestPlantDenseOutput:
    @pytest.mark.parametrize("track", [None, crossing_track()], ids=["flat", "crossings"])
    @pytest.mark.parametrize(("every", "inner"), [(1, 1), (7, 1), (1, 3)])
    def test_dense_states_agree_with_solve_ivp(self, track, every, inner):
        """The returned states equal a DOP853 integration (rtol 1e-11) to those times.

        Over 6 s from 800 m at 60 m/s every vehicle crosses the grade change at 1000 m.
        """
        plant = Plant(train=crh2_half(), track=track)
        x, u = start_state()
        offsets, states = plant.advance_dense(x, u, 6.0, every, inner)
        assert offsets[-1] == 6.0 and np.all(np.diff(offsets) > 0)
        pick = np.arange(offsets.size)
        reference, now, at = [], x, 0.0
        for t in offsets[pick]:  # restarting solve_ivp at each picked time is exact
            now, at = plant.advance_reference(now, u, t - at, rtol=1e-11), t
            reference.append(now)
        reference = np.column_stack(reference)
        assert np.ptp(states[:4, pick] - states[:4, :1]) > 0.1  # the speeds moved
        assert np.abs(states[:4, pick] - reference[:4]).max() < 2e-7           # m/s
        forces = coupler_forces(plant.train, states[:, pick])
        assert np.abs(forces - coupler_forces(plant.train, reference)).max() < 0.05  # N
        assert np.abs(states[-1, pick] - reference[-1]).max() < 1e-6           # m

    @pytest.mark.parametrize("track", [None, crossing_track()], ids=["flat", "crossings"])
    def test_recording_leaves_the_integration_unchanged(self, track):
        """The last dense state is advance()'s result bit for bit, whatever is recorded."""
        plant = Plant(train=crh2_half(), track=track)
        x, u = start_state()
        end = plant.advance(x, u, 20.0)
        for every, inner in [(1, 1), (3, 1), (1, 4)]:
            _, states = plant.advance_dense(x, u, 20.0, every, inner)
            assert np.array_equal(states[:, -1], end)
        assert np.array_equal(plant.advance(x, u, 20.0), end)

    def test_offsets_and_arguments(self):
        plant = Plant(train=crh2_half())
        assert plant.dense_offsets(1.0, every=7).tolist() == pytest.approx(
            [0.35, 0.7, 1.0], rel=1e-12)
        assert plant.dense_offsets(0.05, inner=3).tolist() == pytest.approx(
            [0.05 / 3, 0.1 / 3, 0.05], rel=1e-12)
        x, u = start_state()
        with pytest.raises(ModelError, match="'every' must be an int >= 1"):
            plant.advance_dense(x, u, 1.0, every=0)
        with pytest.raises(ModelError, match="'every' must be 1 with inner"):
            plant.advance_dense(x, u, 1.0, every=2, inner=2)

    def test_fastest_rate_is_the_largest_eigenvalue_of_the_chain(self):
        """CRH2: 27.77 rad/s, the ω_max the sampling check names; one vehicle: no coupler."""
        assert Plant(train=crh2_half()).fastest_rate == pytest.approx(27.7699, abs=1e-3)
        single = heavy_haul_1p2p1()
        assert Plant(train=single).fastest_rate > 0


class TestDenseGrid:
    def test_default_resolves_the_fastest_mode(self):
        """ω h / inner <= 0.5 rad with the fewest points: CRH2 at h = 0.05 s takes 3."""
        assert dense_grid(400, 60, 4, 20.0, None, 27.77) == (1, 3)
        assert dense_grid(1, 24000, 4, 0.05, None, 27.77) == (1, 3)
        assert dense_grid(400, 60, 4, 20.0, None, 10.0) == (1, 1)      # 0.5 rad exactly
        assert dense_grid(400, 60, 4, 20.0, None, 0.0) == (1, 1)

    def test_output_interval_rounds_to_substeps(self):
        assert dense_grid(400, 60, 4, 20.0, 1.0, 0.0) == (20, 1)
        assert dense_grid(400, 60, 4, 20.0, 0.01, 0.0) == (1, 5)
        assert dense_grid(400, 60, 4, 20.0, 100.0, 0.0) == (400, 1)    # the samples only

    @pytest.mark.parametrize(("samples", "n"), [(24000, 4), (60, 204), (10**6, 4)])
    def test_caps_keep_the_samples(self, samples, n):
        """At most 200 000 points and 8e6 numbers, unless the samples alone need more."""
        substeps = 400
        every, inner = dense_grid(substeps, samples, n, 20.0, None, 27.77)
        points = samples * (substeps * inner if inner > 1 else (substeps - 1) // every + 1) + 1
        if every < substeps:
            assert points <= MAX_DENSE_POINTS
            assert points * (3 * n - 1) <= MAX_DENSE_VALUES
        else:
            assert (every, inner) == (substeps, 1)


class HeldInputs:
    """Stand-in controller: the equilibrium inputs of the reference, stepped by 5 % each sample."""

    def __init__(self, dt: float) -> None:
        self.dt, self.name, self.k = dt, "held", 0
        self.train = crh2_half()

    def reset(self) -> None:
        self.k = 0

    def step(self, t, measurement, reference) -> StepRecord:
        eq = equilibrium(self.train, float(reference.speed[0]))
        self.k += 1
        return StepRecord(inputs=eq.inputs * (1.0 + 0.05 * (-1) ** self.k))


@pytest.fixture(scope="module")
def held_run() -> SimulationResult:
    """10 samples of 2 s of HeldInputs on CRH2."""
    train = crh2_half()
    x0 = equilibrium(train, 60.0).state(position=0.0)
    return simulate(Plant(train=train), HeldInputs(2.0), ramp_profile(60.0, 60.0, 0.0, 1.0),
                    duration=20.0, initial_state=x0, preview_steps=0)


class TestRunDenseGrid:

    def test_dense_grid_holds_the_samples_and_their_values(self, held_run):
        """40 substeps of 50 ms x 3 points per sample; dense values at the samples equal them."""
        assert held_run.meta["dense_points_per_sample"] == 120
        assert held_run.dense_time.shape == (10 * 120 + 1,)
        assert held_run.dense_time[held_run.dense_sample_index].tolist() == held_run.time.tolist()
        cols = held_run.dense_sample_index
        assert np.array_equal(held_run.dense_states[:, cols], held_run.states)
        assert np.array_equal(held_run.dense_coupler_forces[:, cols], held_run.coupler_forces)
        assert np.array_equal(held_run.dense_reference_speed[cols], held_run.reference_speed)
        assert np.array_equal(held_run.dense_velocities, held_run.dense_states[:4])

    def test_dense_states_are_the_plant_between_samples(self, held_run):
        """Re-advancing each sample with advance_dense gives the dense columns exactly."""
        plant = Plant(train=crh2_half())
        for k in (0, 4, 9):
            _, states = plant.advance_dense(held_run.states[:, k], held_run.inputs[:, k],
                                            held_run.dt, 1, 3)
            assert np.array_equal(held_run.dense_states[:, k * 120 + 1:(k + 1) * 120 + 1], states)

    def test_output_interval(self):
        train = crh2_half()
        x0 = equilibrium(train, 60.0).state(position=0.0)
        coarse = simulate(Plant(train=train), HeldInputs(2.0), ramp_profile(60.0, 60.0, 0.0, 1.0),
                          duration=4.0, initial_state=x0, preview_steps=0, output_interval=0.5)
        assert np.diff(coarse.dense_time) == pytest.approx(np.full(8, 0.5))
        with pytest.raises(ModelError, match="output_interval"):
            simulate(Plant(train=train), HeldInputs(2.0), ramp_profile(60.0, 60.0, 0.0, 1.0),
                     duration=4.0, initial_state=x0, preview_steps=0, output_interval=0.0)

    def test_save_and_load_keep_the_dense_arrays(self, held_run, tmp_path):
        loaded = SimulationResult.load(held_run.save(tmp_path / "held_run"))
        for name in ("dense_time", "dense_states", "dense_coupler_forces", "dense_reference_speed",
                     "requested_inputs", "saturation"):
            assert np.array_equal(getattr(loaded, name), getattr(held_run, name)), name
        assert loaded.saturation.dtype == np.int8

    def test_a_run_saved_without_the_new_arrays_loads_with_defaults(self, held_run, tmp_path):
        """A run saved before the dense grid existed: dense = samples, requests = inputs."""
        path = held_run.save(tmp_path / "old")
        with np.load(path / "arrays.npz") as data:
            old = {name: data[name] for name in data.files
                   if not name.startswith("dense_") and name not in ("requested_inputs",
                                                                     "saturation")}
        np.savez(path / "arrays.npz", **old)
        loaded = SimulationResult.load(path)
        assert np.array_equal(loaded.dense_time, held_run.time)
        assert np.array_equal(loaded.requested_inputs, held_run.inputs)
        assert not loaded.saturation.any()

    def test_result_checks_the_dense_arrays(self, held_run):
        with pytest.raises(DimensionError, match="dense_states"):
            replace(held_run, dense_states=held_run.dense_states[:, :-1])
        with pytest.raises(DimensionError, match="hold every sample"):
            replace(held_run, dense_time=held_run.dense_time + 1e-3)
        with pytest.raises(DimensionError, match="saturation"):
            replace(held_run, saturation=np.full(held_run.inputs.shape, 2))


class TestDenseMetrics:
    def test_maxima_are_taken_between_the_samples(self):
        """A coupler-force peak, a speed error and a jerk between samples count; RMS does not."""
        time = np.array([0.0, 1.0, 2.0])
        dense_time = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
        v = np.array([[10.0, 10.0, 10.0], [10.0, 10.0, 10.0]])
        dense_v = np.array([[10.0, 10.5, 10.0, 10.0, 10.0], [10.0, 10.0, 10.0, 9.0, 10.0]])
        states = np.vstack([v, np.zeros((1, 3)), np.zeros((1, 3))])
        dense_states = np.vstack([dense_v, np.zeros((1, 5)), np.zeros((1, 5))])
        forces = np.zeros((1, 5))
        forces[0, 3] = -7e3
        result = SimulationResult(
            time=time, states=states, velocities=v, coupler_forces=np.zeros((1, 3)),
            inputs=np.zeros((2, 2)), reference_speed=np.full(3, 10.0),
            reference_acceleration=np.zeros(3), statuses=("optimal",) * 2,
            iterations=np.ones(2, dtype=int), residuals=((), ()), solve_times=np.zeros(2),
            fallbacks=("", ""), controller_name="hand", seed=0, dt=1.0, dense_time=dense_time,
            dense_states=dense_states, dense_coupler_forces=forces,
            dense_reference_speed=np.full(5, 10.0))
        m = compute_metrics(result)
        assert m.max_error.tolist() == [0.5, 1.0]
        assert m.rms_error.tolist() == [0.0, 0.0]
        assert m.max_coupler_force == 7e3
        # head: accelerations +1, -1, 0, 0 m/s² on 0.5 s steps; jerks -4, +2, 0 m/s³
        assert m.max_jerk == pytest.approx(4.0)
        assert json.loads(json.dumps(m.to_dict()))["max_coupler_force"] == 7e3


def replay_max_coupler_force(train, result, points: int) -> float:
    """Max |f| of the recorded inputs re-integrated with solve_ivp on train_rhs, t_eval grid."""
    n = train.n_vehicles
    x = result.states[:, 0].copy()
    peak = 0.0
    for k in range(result.n_samples):
        u = result.inputs[:, k]
        sol = solve_ivp(lambda t, y, u=u: train_rhs(train, y, u), (0.0, result.dt), x,
                        method="DOP853", rtol=1e-8,
                        atol=1e-8 * np.r_[np.ones(n), np.full(n - 1, 1e-5), 1.0],
                        t_eval=np.linspace(0.0, result.dt, points))
        assert sol.success
        peak = max(peak, float(np.abs(coupler_forces(train, sol.y)).max()))
        x = sol.y[:, -1]
    return peak


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_book_run_max_coupler_force_equals_a_fine_solve_ivp_replay():
    """T = 20 s N-DMPC: max |f| over the dense grid = solve_ivp on a 5 ms grid (1e-3 rel.),
    while the samples alone miss about 10 % of it."""
    scenario = load_scenario("crh2-dmpc")
    result = simulate_strategy(scenario, "ndmpc")
    metrics = compute_metrics(result, settle_time=scenario.simulation.settle_time)
    replay = replay_max_coupler_force(scenario.train, result, 4001)
    assert metrics.max_coupler_force == pytest.approx(replay, rel=1e-3)
    assert np.abs(result.coupler_forces).max() < 0.95 * replay
