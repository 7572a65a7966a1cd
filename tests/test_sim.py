"""Tests of the closed-loop simulation: integrator, references, loop, results, metrics, plots."""

from __future__ import annotations

import json
import math
import pickle
import subprocess
import sys
from dataclasses import replace

import control as ct
import numpy as np
import pytest
from matplotlib.axes import Axes

from trainctl.controllers.base import Controller, Measurement, ReferencePreview, StepRecord
from trainctl.exceptions import (
    DimensionError,
    InaccurateSolutionWarning,
    MissingDependencyError,
    ModelError,
)
from trainctl.models import (
    Track,
    TrackSection,
    Train,
    coupler_forces,
    crh2_half,
    discretise,
    equilibrium,
    heavy_haul_1p2p1,
    linearise,
    virtual_formation,
)
from trainctl.plots.time import coupler_force_plot, input_plot, iterations_plot, velocity_plot
from trainctl.sim import (
    HOLD_FALLBACK,
    Plant,
    SimulationResult,
    SpeedProfile,
    compute_metrics,
    ramp_profile,
    simulate,
)


class ProportionalFeedforward:
    """Stand-in controller: equilibrium feedforward plus proportional speed feedback per coach.

    u_i = m_i (a0 + a1 v_r + a2 v_r² + a_r) + kp m_i (v_r - v_i), from the measured
    speeds (``outputs``), so that measurement noise reaches the inputs.
    """

    def __init__(self, train: Train, dt: float, kp: float, name: str = "p+ff") -> None:
        self.train, self.dt, self.kp, self.name = train, dt, kp, name
        self.resets = 0
        self.calls = 0
        self.seen_states: list[bool] = []
        self.nan_at: set[int] = set()

    def reset(self) -> None:
        self.resets += 1
        self.calls = 0

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        train = self.train
        m = train.mass
        a0, a1, a2 = train.davis
        vr, ar = reference.speed[0], reference.acceleration[0]
        assert measurement.outputs is not None
        u = m * (a0 + a1 * vr + a2 * vr**2 + ar) + self.kp * m * (vr - measurement.outputs)
        self.seen_states.append(measurement.state is not None)
        k = self.calls
        self.calls += 1
        if k in self.nan_at:
            u = u.copy()
            u[1] = math.nan
        return StepRecord(inputs=u, iterations=k % 3 + 1, residuals=(1.0, 0.5)[: k % 3],
                          solve_time=1e-4 * (k + 1))


def grade_track() -> Track:
    """Flat, then a 6 ‰ climb, a 4 ‰ descent on a 5 km curve, then flat again."""
    return Track(sections=(
        TrackSection(start=0.0),
        TrackSection(start=1000.0, grade_permille=6.0),
        TrackSection(start=4000.0, grade_permille=-4.0, curve_radius=5000.0),
        TrackSection(start=7000.0),
    ))


def replay_reference(plant: Plant, result: SimulationResult, rtol: float) -> np.ndarray:
    """Integrate the recorded inputs again with solve_ivp from the same initial state."""
    X = np.empty_like(result.states)
    X[:, 0] = result.states[:, 0]
    for k in range(result.n_samples):
        X[:, k + 1] = plant.advance_reference(X[:, k], result.inputs[:, k], result.dt, rtol=rtol)
    return X


# ----------------------------------------------------------------------------- integrator
@pytest.mark.parametrize(
    ("dt", "duration", "kp", "start", "v_tol", "f_tol"),
    [
        # Measured here: max |Δv| / max v ≈ 1e-10 (T = 0.05 s) and 3e-10 (T = 20 s); max |Δf| /
        # range(f) ≈ 5e-8 and 7e-7. Full 1200 s runs: ≈ 1e-9 and ≈ 5e-6 (see trainctl.models.plant).
        (0.05, 40.0, 0.5, 900.0, 5e-9, 2e-6),
        (20.0, 120.0, 0.05, 300.0, 5e-9, 2e-5),
    ],
)
def test_splitting_agrees_with_solve_ivp_over_a_closed_loop_run(
    dt: float, duration: float, kp: float, start: float, v_tol: float, f_tol: float
) -> None:
    """Closed loop over a grade change and a curve: splitting vs DOP853 at rtol 1e-9."""
    train = crh2_half()
    plant = Plant(train=train, track=grade_track())
    eq = equilibrium(train, 60.0)
    x0 = eq.state(position=start)
    x0[:4] += [0.02, -0.01, 0.0, 0.01]
    profile = SpeedProfile(times=(0.0, 60.0, 120.0), speeds=(60.0, 70.0, 66.0))
    result = simulate(plant, ProportionalFeedforward(train, dt, kp), profile,
                      duration=duration, initial_state=x0, preview_steps=2)
    # Every vehicle crossed at least one section boundary.
    assert result.states[-1, -1] - 100.0 > 1000.0 > start
    X = replay_reference(plant, result, rtol=1e-9)
    dv = np.abs(result.velocities - X[:4]).max() / np.abs(X[:4]).max()
    f_ref = coupler_forces(train, X)
    df = np.abs(result.coupler_forces - f_ref).max() / np.ptp(f_ref)
    assert dv < v_tol
    assert df < f_tol
    assert np.abs(result.states[-1] - X[-1]).max() < 1e-3  # head position [m]


def test_single_steps_agree_with_solve_ivp_for_damped_couplers() -> None:
    """The heavy-haul subsystems (damped couplers), a strong imbalance, flat and graded."""
    train = heavy_haul_1p2p1()
    eq = equilibrium(train, 20.0)
    u = eq.inputs + np.array([3e5, -2e5, 0.0, 1e5])
    for track in (None, Track(sections=(TrackSection(start=0.0),
                                        TrackSection(start=20.0, grade_permille=12.0)))):
        plant = Plant(train=train, track=track)
        x0 = eq.state(position=0.0)
        a, b = plant.advance(x0, u, 2.0), plant.advance_reference(x0, u, 2.0)
        assert np.abs(a[:4] - b[:4]).max() < 1e-9
        assert np.abs(coupler_forces(train, a) - coupler_forces(train, b)).max() < 1e-2


def test_near_simultaneous_crossings() -> None:
    """Sections 25.0001 m apart: all four coaches cross boundaries at almost the same instants."""
    train = crh2_half()
    track = Track(sections=tuple(
        TrackSection(start=25.0001 * i, grade_permille=5.0 * (-1) ** i) for i in range(40)
    ))
    plant = Plant(train=train, track=track)
    eq = equilibrium(train, 50.0)
    x0 = eq.state(position=25.0001 * 4)  # the head starts exactly on a boundary
    a, b = plant.advance(x0, eq.inputs, 10.0), plant.advance_reference(x0, eq.inputs, 10.0)
    assert a[-1] > 550.0
    # Measured: 1e-9 m/s and 0.3 mN.
    assert np.abs(a[:4] - b[:4]).max() < 5e-9
    assert np.abs(coupler_forces(train, a) - coupler_forces(train, b)).max() < 5e-3


@pytest.mark.parametrize(
    "train", [virtual_formation(n_trains=3), Train(vehicles=crh2_half().vehicles[:1], couplers=())]
)
def test_virtual_links_and_single_vehicles(train: Train) -> None:
    """Force-free virtual links (their delta drifts freely) and a lone vehicle, on a grade."""
    n = train.n_vehicles
    track = Track(sections=(TrackSection(start=0.0), TrackSection(start=30.0, grade_permille=-8.0)))
    plant = Plant(train=train, track=track)
    x0 = np.r_[np.linspace(20.0, 21.0, n), np.zeros(n - 1), 0.0]
    u = train.mass * np.linspace(0.05, -0.05, n)
    a, b = plant.advance(x0, u, 5.0), plant.advance_reference(x0, u, 5.0)
    assert np.abs(a - b).max() < 1e-8
    assert a[-1] > 100.0


@pytest.mark.parametrize("dt", [0.05, 0.3, 20.0])
def test_linear_train_is_the_exact_zoh(dt: float) -> None:
    """a0 = a2 = 0 on flat track: advance() reproduces discretise(linearise(...)) exactly."""
    base = crh2_half()
    vehicles = tuple(replace(v, a0=0.0, a2=0.0) for v in base.vehicles)
    train = Train(vehicles=vehicles, couplers=base.couplers)
    speed = 70.0
    eq = equilibrium(train, speed)
    xe = eq.state()
    sysd = discretise(linearise(train, speed), dt)
    plant = Plant(train=train)
    rng = np.random.default_rng(3)
    x = eq.state(position=0.0)
    x[:4] += rng.normal(0.0, 0.05, 4)
    for _ in range(5):
        du = rng.normal(0.0, 2e4, 4)
        predicted = sysd.A @ (x[:-1] - xe) + sysd.B @ du
        x = plant.advance(x, eq.inputs + du, dt)
        err = x[:-1] - xe - predicted
        # Measured: speeds to ~1e-16 relative per substep (2e-14 at 400 substeps),
        # elongations to 2e-15 m (2e-14 m at 400 substeps, ~0.2 µN): rounding only.
        assert np.abs(err[:4]).max() < 1e-13 * speed
        assert np.abs(err[4:]).max() < 1e-11 * np.abs(x[4:7]).max()


def test_plant_validates_its_inputs() -> None:
    plant = Plant(train=crh2_half())
    with pytest.raises(ModelError, match="max_substep"):
        Plant(train=crh2_half(), max_substep=0.0)
    with pytest.raises(DimensionError, match="shape \\(8,\\)"):
        plant.advance(np.zeros(7), np.zeros(4), 1.0)
    with pytest.raises(DimensionError, match="inputs"):
        plant.advance(np.zeros(8), np.zeros(3), 1.0)
    with pytest.raises(ModelError, match="finite"):
        plant.advance(np.full(8, np.nan), np.zeros(4), 1.0)
    with pytest.raises(ModelError, match="'dt' must be > 0"):
        plant.advance(np.zeros(8), np.zeros(4), 0.0)
    assert plant.substeps(0.05) == 1
    assert plant.substeps(20.0) == 400
    assert plant.substeps(0.051) == 2


def test_plant_pickles_with_its_caches() -> None:
    """Plants go to worker processes: pickling keeps the caches and the results."""
    train = crh2_half()
    plant = Plant(train=train, track=grade_track())
    eq = equilibrium(train, 50.0)
    x = plant.advance(eq.state(position=990.0), eq.inputs, 1.0)
    clone = pickle.loads(pickle.dumps(plant))
    assert clone == plant and len(clone._cache) == len(plant._cache) > 0
    assert np.array_equal(clone.advance(eq.state(position=990.0), eq.inputs, 1.0), x)


def test_full_heavy_haul_chain_runs() -> None:
    """The 204-vehicle chain: a few samples in closed loop stay at the equilibrium."""
    train = heavy_haul_1p2p1(detail="full")
    eq = equilibrium(train, 20.0, allocation="own")
    plant = Plant(train=train)
    ctrl = ProportionalFeedforward(train, 0.05, 0.1)
    # The stand-in asks every wagon for its own resistance, which the wagons (no traction)
    # cannot give: without the plant's saturation the train stays at the equilibrium.
    result = simulate(plant, ctrl, ramp_profile(20.0, 20.0, 0.0, 1.0), duration=0.15,
                      initial_state=eq.state(position=0.0), preview_steps=0, saturation=False)
    assert result.velocities.shape == (204, 4)
    assert np.allclose(result.velocities, 20.0, rtol=1e-9)


# ----------------------------------------------------------------------------- references
def test_speed_profile_values_slopes_and_preview() -> None:
    profile = SpeedProfile(times=(0.0, 100.0, 200.0), speeds=(0.0, 50.0, 50.0))
    t = np.array([-1.0, 0.0, 50.0, 100.0, 150.0, 200.0, 500.0])
    assert profile.speed(t).tolist() == [0.0, 0.0, 25.0, 50.0, 50.0, 50.0, 50.0]
    # At a breakpoint: the slope of the segment that starts there.
    assert profile.acceleration(t).tolist() == [0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 0.0]
    preview = profile.preview(95.0, 5.0, 3)
    assert preview.times.tolist() == [95.0, 100.0, 105.0, 110.0]
    assert preview.speed.tolist() == [47.5, 50.0, 50.0, 50.0]
    assert preview.acceleration.tolist() == [0.5, 0.0, 0.0, 0.0]
    assert profile.speed(50.0).shape == ()
    ramp = ramp_profile(10.0, 30.0, 20.0, 60.0)
    assert ramp.times == (0.0, 20.0, 60.0) and ramp.speeds == (10.0, 10.0, 30.0)
    assert json.loads(json.dumps(ramp.to_dict())) == ramp.to_dict()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"times": (0.0, 20.0, 10.0), "speeds": (0.0, 1.0, 2.0)}, "increase strictly"),
        ({"times": (0.0, 10.0, 10.0), "speeds": (0.0, 1.0, 2.0)}, "increase strictly"),
        ({"times": (0.0, 10.0), "speeds": (0.0, -1.0)}, ">= 0"),
        ({"times": (1.0, 10.0), "speeds": (0.0, 1.0)}, "start at 0"),
        ({"times": (0.0, 10.0), "speeds": (0.0,)}, "one value per time"),
        ({"times": (), "speeds": ()}, "at least one"),
        ({"times": (0.0, math.inf), "speeds": (0.0, 1.0)}, "finite"),
        ({"times": "0 10", "speeds": (0.0, 1.0)}, "1-D sequence"),
    ],
)
def test_speed_profile_rejects_bad_breakpoints(kwargs: dict, match: str) -> None:
    with pytest.raises(ModelError, match=match):
        SpeedProfile(**kwargs)


def test_ramp_profile_and_preview_validate() -> None:
    with pytest.raises(ModelError, match="ramp_end"):
        ramp_profile(0.0, 10.0, 50.0, 50.0)
    with pytest.raises(ModelError, match="v_end"):
        ramp_profile(0.0, -10.0, 0.0, 50.0)
    with pytest.raises(ModelError, match="steps"):
        ramp_profile(0.0, 10.0, 0.0, 50.0).preview(0.0, 1.0, -1)


# ----------------------------------------------------------------------------- the loop
@pytest.fixture(scope="module")
def crh2_run() -> tuple[SimulationResult, ProportionalFeedforward]:
    train = crh2_half()
    ctrl = ProportionalFeedforward(train, 1.0, 0.2)
    ctrl.nan_at = {5}
    eq = equilibrium(train, 40.0)
    # The stand-in asks the trailers for traction they do not have: these tests are about
    # the loop's bookkeeping, so the plant applies the requests as asked.
    with pytest.warns(InaccurateSolutionWarning) as caught:
        result = simulate(Plant(train=train, track=grade_track()), ctrl,
                          ramp_profile(40.0, 50.0, 5.0, 25.0), duration=30.0,
                          initial_state=eq.state(position=0.0), preview_steps=3,
                          measurement_noise=0.01, seed=7, saturation=False)
    ctrl.warnings = [(w.category, str(w.message), w.filename) for w in caught]
    return result, ctrl


def test_simulation_records_every_sample(crh2_run) -> None:
    result, ctrl = crh2_run
    n, N = 4, 30
    assert ctrl.resets == 1 and ctrl.calls == N
    assert result.time.shape == (N + 1,) and result.time[-1] == 30.0
    assert result.states.shape == (2 * n, N + 1)
    assert result.velocities.shape == (n, N + 1)
    assert result.coupler_forces.shape == (n - 1, N + 1)
    assert result.inputs.shape == (n, N)
    assert result.reference_speed.shape == result.reference_acceleration.shape == (N + 1,)
    assert len(result.statuses) == len(result.residuals) == len(result.fallbacks) == N
    assert result.iterations.shape == result.solve_times.shape == (N,)
    assert result.iterations.tolist()[:4] == [1, 2, 3, 1]
    assert result.residuals[:3] == ((), (1.0,), (1.0, 0.5))
    assert result.reference_speed[-1] == 50.0 and result.reference_acceleration[10] == 0.5
    assert all(ctrl.seen_states)
    assert result.controller_name == "p+ff" and result.seed == 7 and result.dt == 1.0
    assert result.meta["n_vehicles"] == 4 and result.meta["substeps_per_sample"] == 20
    assert result.meta["plant_saturation"] is False and result.divergence is None
    assert np.array_equal(result.requested_inputs, result.inputs)
    assert not result.saturation.any() and result.saturation.dtype == np.int8
    # The dense grid: 3 points in each of the 20 substeps of a 1 s sample (the 27.8 rad/s
    # coupler mode turns by 0.46 rad in 50 / 3 ms), the samples among them.
    assert result.meta["dense_points_per_sample"] == 60 and result.dense_time.shape == (1801,)
    assert np.array_equal(result.dense_time[result.dense_sample_index], result.time)
    assert np.array_equal(result.dense_states[:, ::60], result.states)
    # Tracks the ramp; on the 6 ‰ climb the proportional law leaves ~0.22 m/s.
    assert np.abs(result.velocities[:, -1] - 50.0).max() < 0.3


def test_non_finite_input_is_replaced_by_the_previous_one(crh2_run) -> None:
    result, _ = crh2_run
    assert result.statuses[5] == "error" and result.fallbacks[5] == HOLD_FALLBACK
    assert np.array_equal(result.inputs[:, 5], result.inputs[:, 4])
    assert result.statuses.count("error") == 1
    assert set(result.statuses) - {"error"} == {"optimal"}


def test_solver_trouble_is_warned_once_per_run(crh2_run) -> None:
    """The one "error" sample (a NaN input held) is warned once, at the caller's line;
    its status and fallback are what the result records."""
    result, ctrl = crh2_run
    assert ctrl.warnings == [(
        InaccurateSolutionWarning,
        "simulate: 1 of 30 samples of 'p+ff' were not solved to optimality (error 1); "
        "1 applied a fallback (result.fallbacks). See result.status_counts().",
        __file__)]
    assert result.status_counts()["error"] == 1


def test_measurement_noise_is_reproducible() -> None:
    train = crh2_half()
    eq = equilibrium(train, 40.0, allocation="own")  # what the stand-in controller holds
    plant = Plant(train=train)

    def run(seed: int, noise: float) -> SimulationResult:
        return simulate(plant, ProportionalFeedforward(train, 2.0, 0.2),
                        ramp_profile(40.0, 40.0, 0.0, 1.0), duration=10.0,
                        initial_state=eq.state(position=0.0), preview_steps=1,
                        measurement_noise=noise, seed=seed, saturation=False)

    a, b, c, quiet = run(1, 0.05), run(1, 0.05), run(2, 0.05), run(1, 0.0)
    assert np.array_equal(a.inputs, b.inputs) and np.array_equal(a.states, b.states)
    assert not np.allclose(a.inputs, c.inputs)
    assert not np.allclose(a.inputs, quiet.inputs)
    assert np.allclose(quiet.velocities, 40.0, rtol=1e-9)


def test_output_feedback_gets_no_state() -> None:
    train = crh2_half()
    ctrl = ProportionalFeedforward(train, 1.0, 0.1)
    simulate(Plant(train=train), ctrl, ramp_profile(30.0, 30.0, 0.0, 1.0), duration=3.0,
             initial_state=equilibrium(train, 30.0).state(position=0.0), preview_steps=0,
             full_state=False)
    assert ctrl.seen_states == [False, False, False]
    assert isinstance(ctrl, Controller)


def test_simulate_rejects_bad_settings() -> None:
    train = crh2_half()
    plant = Plant(train=train)
    x0 = equilibrium(train, 30.0).state(position=0.0)
    ctrl = ProportionalFeedforward(train, 0.3, 0.1)
    profile = ramp_profile(30.0, 30.0, 0.0, 1.0)
    with pytest.raises(ModelError, match="multiple of controller.dt"):
        simulate(plant, ctrl, profile, duration=1.0, initial_state=x0, preview_steps=1)
    assert simulate(plant, ctrl, profile, duration=0.9, initial_state=x0,
                    preview_steps=1).n_samples == 3
    with pytest.raises(ModelError, match="duration"):
        simulate(plant, ctrl, profile, duration=-0.3, initial_state=x0, preview_steps=1)
    with pytest.raises(DimensionError, match="initial_state"):
        simulate(plant, ctrl, profile, duration=0.9, initial_state=x0[:-1], preview_steps=1)
    with pytest.raises(ModelError, match="preview_steps"):
        simulate(plant, ctrl, profile, duration=0.9, initial_state=x0, preview_steps=-1)
    with pytest.raises(ModelError, match="measurement_noise"):
        simulate(plant, ctrl, profile, duration=0.9, initial_state=x0, preview_steps=1,
                 measurement_noise=-1.0)
    with pytest.raises(ModelError, match="Controller"):
        simulate(plant, object(), profile, duration=0.9, initial_state=x0,  # type: ignore[arg-type]
                 preview_steps=1)


def test_controller_errors_propagate() -> None:
    train = crh2_half()

    class Broken(ProportionalFeedforward):
        def step(self, t, measurement, reference):
            raise RuntimeError("bug in the controller")

    class WrongShape(ProportionalFeedforward):
        def step(self, t, measurement, reference):
            return StepRecord(inputs=np.zeros(3))

    x0 = equilibrium(train, 30.0).state(position=0.0)
    for cls, err in ((Broken, RuntimeError), (WrongShape, DimensionError)):
        with pytest.raises(err):
            simulate(Plant(train=train), cls(train, 1.0, 0.1), ramp_profile(30.0, 30.0, 0.0, 1.0),
                     duration=2.0, initial_state=x0, preview_steps=0)


# ----------------------------------------------------------------------------- results
def test_save_and_load_round_trip_exactly(crh2_run, tmp_path) -> None:
    result, _ = crh2_run
    path = result.save(tmp_path / "run")
    assert sorted(p.name for p in path.iterdir()) == ["arrays.npz", "result.json"]
    with np.load(path / "arrays.npz", allow_pickle=False) as data:
        assert np.array_equal(data["states"], result.states)
    loaded = SimulationResult.load(path)
    for name in ("time", "states", "velocities", "coupler_forces", "inputs", "reference_speed",
                 "reference_acceleration", "iterations", "solve_times"):
        a, b = getattr(loaded, name), getattr(result, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    for name in ("statuses", "residuals", "fallbacks", "controller_name", "seed", "dt", "meta"):
        assert getattr(loaded, name) == getattr(result, name), name
    assert loaded.meta["versions"]["numpy"] == np.__version__
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "result.json").write_text('{"format": "other"}')
    with pytest.raises(ModelError, match="format"):
        SimulationResult.load(tmp_path / "bad")


def test_views_dict_pandas_time_response(crh2_run) -> None:
    result, _ = crh2_run
    summary = result.to_dict()
    assert json.loads(json.dumps(summary))["status_counts"]["error"] == 1
    assert summary["n_samples"] == 30
    frame = result.to_pandas()
    assert frame.shape[0] == 31 and frame.index.name == "time"
    assert frame["v[2]"].to_numpy().tolist() == result.velocities[2].tolist()
    assert frame["f[0]"].iloc[3] == result.coupler_forces[0, 3]
    assert frame["u[1]"].iloc[4] == result.inputs[1, 4] and math.isnan(frame["u[1]"].iloc[-1])
    assert frame["status"].iloc[5] == "error"
    response = result.to_time_response()
    assert isinstance(response, ct.TimeResponseData)
    assert response.outputs.shape == (4, 31) and response.inputs.shape == (4, 31)
    assert response.output_labels == ["v[0]", "v[1]", "v[2]", "v[3]"]


def test_to_pandas_without_pandas(crh2_run, monkeypatch) -> None:
    result, _ = crh2_run
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(MissingDependencyError, match=r"pip install 'trainctl-toolbox\[pandas\]'"):
        result.to_pandas()


def test_result_checks_shapes(crh2_run) -> None:
    result, _ = crh2_run
    with pytest.raises(DimensionError, match="inputs"):
        replace(result, inputs=result.inputs[:, :-1])
    with pytest.raises(DimensionError, match="statuses"):
        replace(result, statuses=result.statuses[:-1])


# ----------------------------------------------------------------------------- metrics
def hand_result(
    velocities: np.ndarray, inputs: np.ndarray, reference: np.ndarray, dt: float
) -> SimulationResult:
    n, cols = velocities.shape
    steps = cols - 1
    states = np.vstack([velocities, np.zeros((n - 1, cols)), np.zeros((1, cols))])
    return SimulationResult(
        time=dt * np.arange(cols), states=states, velocities=velocities,
        coupler_forces=np.zeros((n - 1, cols)), inputs=inputs, reference_speed=reference,
        reference_acceleration=np.zeros(cols),
        statuses=("optimal",) * (steps - 1) + ("infeasible",),
        iterations=np.arange(1, steps + 1), residuals=((),) * steps,
        solve_times=np.linspace(0.01, 0.1, steps),
        fallbacks=("",) * (steps - 1) + ("shifted plan",),
        controller_name="hand", seed=0, dt=dt,
    )


def test_energy_of_a_constant_force_on_a_linear_speed() -> None:
    """u = 2 kN on each of 2 vehicles while v goes 10 → 30 m/s linearly over 100 s."""
    t = np.arange(11) * 10.0
    v = np.vstack([10.0 + 0.2 * t, 10.0 + 0.2 * t])
    result = hand_result(v, np.full((2, 10), 2000.0), v[0], 10.0)
    # Work = F · distance = 2000 N · (10 + 30)/2 m/s · 100 s per vehicle.
    expected_kwh = 2 * 2000.0 * 20.0 * 100.0 / 3.6e6
    metrics = compute_metrics(result)
    assert metrics.energy == pytest.approx(expected_kwh, rel=1e-14)
    assert metrics.motoring_energy == pytest.approx(expected_kwh, rel=1e-14)
    assert metrics.braking_energy == 0.0
    # Braking on the second vehicle: 70 % is recovered.
    braking = compute_metrics(hand_result(v, np.vstack([np.full(10, 2000.0),
                                                        np.full(10, -2000.0)]), v[0], 10.0),
                              regen_efficiency=0.7)
    assert braking.energy == pytest.approx(0.3 * expected_kwh / 2, rel=1e-14)
    assert braking.braking_energy == pytest.approx(expected_kwh / 2, rel=1e-14)


def test_tracking_jerk_and_solver_statistics_by_hand() -> None:
    ref = np.full(5, 20.0)
    v = np.array([[20.0, 21.0, 19.0, 20.0, 22.0],
                  [20.0, 20.0, 20.0, 20.0, 20.0]])
    result = hand_result(v, np.zeros((2, 4)), ref, 2.0)
    metrics = compute_metrics(result)
    assert metrics.rms_error.tolist() == pytest.approx([math.sqrt((1 + 1 + 0 + 4) / 5), 0.0])
    assert metrics.max_error.tolist() == [2.0, 0.0]
    late = compute_metrics(result, settle_time=4.0)
    assert late.rms_error[0] == pytest.approx(math.sqrt((1 + 0 + 4) / 3))
    # Head accelerations 0.5, -1, 0.5, 1 m/s²; jerks -0.75, 0.75, 0.25 m/s³.
    assert metrics.max_jerk == pytest.approx(0.75)
    assert metrics.rms_jerk == pytest.approx(math.sqrt((0.5625 * 2 + 0.0625) / 3))
    assert metrics.iterations_mean == 2.5 and metrics.iterations_max == 4
    assert metrics.solve_time_median == pytest.approx(0.055)
    assert metrics.solve_time_max == pytest.approx(0.1)
    assert metrics.status_counts["optimal"] == 3 and metrics.status_counts["infeasible"] == 1
    assert metrics.fallback_counts == {"shifted plan": 1}
    d = json.loads(json.dumps(metrics.to_dict()))
    assert d["max_error"] == [2.0, 0.0]
    with pytest.raises(ModelError, match="settle_time"):
        compute_metrics(result, settle_time=100.0)
    with pytest.raises(ModelError, match="regen_efficiency"):
        compute_metrics(result, regen_efficiency=1.5)


def test_metrics_of_a_simulation(crh2_run) -> None:
    result, _ = crh2_run
    metrics = compute_metrics(result, settle_time=10.0)
    assert metrics.rms_error.shape == (4,) and np.all(metrics.rms_error < 0.5)
    # The largest coupler force lies between the samples (the dense grid's 50 ms substeps).
    assert metrics.max_coupler_force == np.abs(result.dense_coupler_forces).max()
    assert metrics.max_coupler_force > 1.2 * np.abs(result.coupler_forces).max() > 0
    assert metrics.energy > 0 and metrics.status_counts["error"] == 1
    assert metrics.fallback_counts == {HOLD_FALLBACK: 1} and not metrics.saturated


# ----------------------------------------------------------------------------- plots
def test_plots_return_labelled_axes(crh2_run) -> None:
    result, _ = crh2_run
    cases = [
        (velocity_plot(result), "speed [m/s]"),
        (coupler_force_plot(result, bounds=(-20e3, 20e3)), "coupler force [kN]"),
        (input_plot(result, bounds=(-40e3, 80e3)), "force [kN]"),
        (iterations_plot(result), "iterations [-]"),
    ]
    for ax, ylabel in cases:
        assert isinstance(ax, Axes)
        assert ax.get_xlabel() == "time [s]" and ax.get_ylabel() == ylabel
        assert ax.figure.canvas.manager is None  # a bare Figure, not a pyplot window
    ax = result.plot("coupler_force")
    assert ax.get_ylabel() == "coupler force [kN]"
    existing = velocity_plot(result).figure.add_subplot(2, 1, 2)
    assert result.plot("input", ax=existing) is existing
    with pytest.raises(ModelError, match="kind"):
        result.plot("energy")


def test_import_does_not_load_pandas() -> None:
    code = ("import sys, trainctl.sim; "
            "print(sorted(m for m in ('pandas', 'trainctl.plots.time') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_to_pandas_without_pandas_names_the_extra(monkeypatch):
    """With pandas unavailable, to_pandas raises MissingDependencyError with the install hint."""
    import sys

    from trainctl.exceptions import MissingDependencyError
    from trainctl.sim.results import SimulationResult

    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas -> ImportError
    result = SimulationResult.__new__(SimulationResult)
    with pytest.raises(MissingDependencyError, match=r"trainctl-toolbox\[pandas\]"):
        result.to_pandas()
