"""The closed loop's fast path: the one-sample plant map and the batched loop inputs.

:class:`trainctl.models._plant_sample.SampleMap` must give the states of
:meth:`Plant.advance_dense` (the exact integrator) on samples without a section
boundary, and hand every sample where a vehicle may reach one (a grade change, a
curve, the head or a trailing vehicle, forward or backward) to that integrator.
The loop's batched noise and previews must give what the per-sample calls give, and a
law's plain step (``step_inputs``, no per-step objects) what its ``step`` gives.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from trainctl.controllers.base import StepRecord
from trainctl.controllers.faults import finite
from trainctl.models import crh2_half, equilibrium
from trainctl.models.dynamics import vehicle_positions
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.feedforward import ForceSplit
from trainctl.models.plant import Plant
from trainctl.models.track import Track, TrackSection
from trainctl.models.vehicle import envelope_limit
from trainctl.sim import closed_loop, simulate
from trainctl.sim.reference import SpeedProfile, ramp_profile

DT = 0.05


def _state(train, speed: float, head: float, rng: np.random.Generator) -> np.ndarray:
    x = equilibrium(train, speed).state(position=head)
    n = train.n_vehicles
    x[:n] += rng.normal(0.0, 0.3, n)
    x[n : 2 * n - 1] += rng.normal(0.0, 2e-3, n - 1)
    return x


def _inputs(train, speed: float, rng: np.random.Generator) -> np.ndarray:
    return equilibrium(train, speed).inputs + rng.normal(0.0, 5e3, train.n_vehicles)


def _both(plant: Plant, x: np.ndarray, u: np.ndarray, inner: int) -> tuple[np.ndarray, ...]:
    """(fast block, exact states, fallbacks taken) of one sample."""
    fast = plant.sample_map(DT, inner)
    assert fast is not None
    block = np.empty((x.size, inner))
    fast.advance(x, u, block)
    _, exact = plant.advance_dense(x, u, DT, 1, inner)
    return block, exact, fast.fallbacks


LEVEL_TRACKS = {
    "flat": None,
    "uniform grade": Track(sections=(TrackSection(start=0.0, grade_permille=6.0),)),
    "sections far away": Track(sections=(
        TrackSection(start=0.0, grade_permille=3.0),
        TrackSection(start=5000.0, grade_permille=-4.0, curve_radius=3000.0))),
}


@pytest.mark.parametrize("name", list(LEVEL_TRACKS))
@pytest.mark.parametrize("inner", [1, 3])
def test_sample_map_equals_the_exact_integrator_without_boundaries(name: str,
                                                                   inner: int) -> None:
    train = crh2_half()
    plant = Plant(train=train, track=LEVEL_TRACKS[name])
    rng = np.random.default_rng(7)
    for speed in (0.5, 20.0, 50.0, 50.9, 83.0):  # grid speeds v̄ on both sides of odd speeds
        for _ in range(5):
            x, u = _state(train, speed, 1000.0, rng), _inputs(train, speed, rng)
            block, exact, fallbacks = _both(plant, x, u, inner)
            assert fallbacks == 0
            scale = np.abs(exact).max(axis=1, keepdims=True)
            assert np.all(np.abs(block - exact) <= 1e-12 * scale)
            np.testing.assert_array_equal(block, exact)  # the same operations: bit for bit


def test_sample_map_without_quadratic_drag() -> None:
    base = crh2_half()
    train = dataclasses.replace(base, vehicles=tuple(
        dataclasses.replace(v, a2=0.0) for v in base.vehicles))
    plant = Plant(train=train)
    assert not plant._quadratic
    rng = np.random.default_rng(3)
    x, u = _state(train, 40.0, 0.0, rng), _inputs(train, 40.0, rng)
    block, exact, fallbacks = _both(plant, x, u, 3)
    assert fallbacks == 0
    np.testing.assert_array_equal(block, exact)


def test_sample_map_only_for_one_substep_on_dense_propagators() -> None:
    plant = Plant(train=crh2_half())
    assert plant.sample_map(DT) is not None
    assert plant.sample_map(0.2) is None  # four substeps: v̄ may change between them
    assert Plant(train=crh2_half(), propagation="banded").sample_map(DT) is None


# Boundary kinds. CRH2 at ~50 m/s moves ~2.5 m per sample; vehicles are ~25 m apart.
BOUNDARIES = {
    # ((vehicle, distance ahead of it [m], grade [‰], curve radius [m]) per boundary, speed)
    "grade change ahead of the head": (((0, 1.0, -8.0, np.inf),), 50.0),
    "curve ahead of the head": (((0, 1.0, 0.0, 1200.0),), 50.0),
    "grade change ahead of the tail": (((3, 0.5, 10.0, np.inf),), 50.0),
    "several boundaries in one sample": (((0, 0.5, 5.0, np.inf), (0, 1.5, -5.0, 800.0)), 50.0),
    "backward over a boundary": (((3, -0.2, 6.0, np.inf),), -5.0),
    "close but not across": ((), 50.0),  # placed in the test
}


@pytest.mark.parametrize("kind", list(BOUNDARIES))
@pytest.mark.parametrize("inner", [1, 3])
def test_a_sample_with_a_boundary_falls_back_to_the_exact_integrator(kind: str,
                                                                      inner: int) -> None:
    later, speed = BOUNDARIES[kind]
    train = crh2_half()
    rng = np.random.default_rng(11)
    x = equilibrium(train, abs(speed)).state(position=1000.0)
    x[: train.n_vehicles] = speed + rng.normal(0.0, 0.05, train.n_vehicles)
    p = vehicle_positions(train, x)
    plant = Plant(train=train, track=Track(sections=(TrackSection(start=0.0),) + tuple(
        TrackSection(start=float(p[i]) + ahead, grade_permille=grade, curve_radius=radius)
        for i, ahead, grade, radius in later)))
    u = _inputs(train, abs(speed), rng)
    if kind == "close but not across":  # within the tracker's slack of the head's end
        moved = Plant(train=train).advance(x, u, DT)[-1] - x[-1]
        plant = Plant(train=train, track=Track(sections=(
            TrackSection(start=0.0),
            TrackSection(start=float(x[-1] + moved) + 1e-7, grade_permille=6.0))))
    block, exact, fallbacks = _both(plant, x, u, inner)
    assert fallbacks == 1
    np.testing.assert_array_equal(block, exact)
    # Without the fallback the boundary's jump of line resistance would be missed
    # (a crossing) or the same (none): the map's own arithmetic, for comparison.
    fast = plant.sample_map(DT, inner)
    assert fast is not None
    fast._may_cross = lambda *args: False  # type: ignore[method-assign]
    missed = np.empty_like(block)
    fast.advance(x, u, missed)
    assert np.array_equal(missed, exact) == (kind == "close but not across")


def test_a_saturated_input_is_held_over_the_sample_on_the_fast_map() -> None:
    """Saturation is applied at the sample's start, so the held input is constant: the
    map (no fallback) equals the integrator with the clipped force."""
    train = crh2_half()
    plant = Plant(train=train)
    x = equilibrium(train, 60.0).state(position=0.0)
    low, high = EnvelopeBounds(train, enabled=True).at(x[:4])
    u = np.where(np.arange(4) % 2 == 0, low, high)  # every force on its limit
    block, exact, fallbacks = _both(plant, x, u, 3)
    assert fallbacks == 0
    np.testing.assert_array_equal(block, exact)


class _Proportional:
    """Feedforward plus a stiff speed feedback: it saturates after a speed step."""

    dt, name, preview_steps = DT, "p", 0

    def __init__(self, train) -> None:
        self.split = ForceSplit(train)

    def reset(self) -> None:
        pass

    def step(self, t, measurement, reference):
        ff = self.split([max(float(reference.speed[0]), 0.1)], [reference.acceleration[0]])
        v = measurement.outputs
        return StepRecord(inputs=ff.inputs[0] + 4e5 * (reference.speed[0] - v))


class _Wrapped:
    """A SpeedProfile behind the Reference protocol only (the per-sample preview route)."""

    def __init__(self, profile: SpeedProfile) -> None:
        self.profile = profile

    def speed(self, t):
        return self.profile.speed(t)

    def acceleration(self, t):
        return self.profile.acceleration(t)

    def preview(self, t, dt, steps):
        return self.profile.preview(t, dt, steps)


def _run(plant: Plant, reference, duration: float, noise: float):
    train = plant.train
    x0 = equilibrium(train, 20.0).state(position=900.0)
    return simulate(plant, _Proportional(train), reference, duration=duration,
                    initial_state=x0, preview_steps=3, measurement_noise=noise, seed=5,
                    warn=False)


def _assert_same(a, b) -> None:
    for field in dataclasses.fields(a):
        value = getattr(a, field.name)
        if field.name == "solve_times" or field.name == "meta":
            continue
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(value, getattr(b, field.name), err_msg=field.name)
        else:
            assert value == getattr(b, field.name), field.name


def test_closed_loop_with_crossings_and_saturation_equals_the_exact_path(
        monkeypatch: pytest.MonkeyPatch) -> None:
    train = crh2_half()
    track = Track(sections=(TrackSection(start=0.0),
                            TrackSection(start=1000.0, grade_permille=8.0),
                            TrackSection(start=1100.0, grade_permille=-5.0,
                                         curve_radius=1500.0)))
    reference = ramp_profile(20.0, 30.0, 1.0, 6.0)
    taken: list[int] = []
    original = Plant.sample_map

    def counted(self, dt, inner=1):
        fast = original(self, dt, inner)
        assert fast is not None
        advance = fast.advance

        def tracked(x, u, block):
            before = fast.fallbacks
            advance(x, u, block)
            taken.append(fast.fallbacks - before)
        fast.advance = tracked  # type: ignore[method-assign]
        return fast

    monkeypatch.setattr(Plant, "sample_map", counted)
    fast = _run(Plant(train=train, track=track), reference, 12.0, 0.01)
    assert len(taken) == 240 and 0 < sum(taken) < 240  # crossings on the exact path
    assert np.count_nonzero(fast.saturation) > 0
    monkeypatch.setattr(Plant, "sample_map", lambda self, dt, inner=1: None)
    exact = _run(Plant(train=train, track=track), reference, 12.0, 0.01)
    _assert_same(fast, exact)


def test_batched_noise_and_previews_equal_the_per_sample_calls(
        monkeypatch: pytest.MonkeyPatch) -> None:
    plant = Plant(train=crh2_half())
    profile = ramp_profile(20.0, 25.0, 2.0, 20.0)
    batched = _run(plant, profile, 30.0, 0.05)  # 600 samples: three chunks
    assert closed_loop._Batch.CHUNK < 600
    monkeypatch.setattr(closed_loop._Batch, "CHUNK", 1)  # one draw of n per sample
    per_sample = _run(plant, _Wrapped(profile), 30.0, 0.05)  # preview() per sample
    _assert_same(batched, per_sample)


def test_previews_rows_are_the_previews() -> None:
    profile = SpeedProfile(times=(0.0, 3.0, 7.5), speeds=(0.0, 30.0, 12.0))
    starts = DT * np.arange(200, dtype=np.float64)
    times, speed, accel = profile.previews(starts, DT, 8)
    for k in range(starts.size):
        one = profile.preview(float(starts[k]), DT, 8)
        np.testing.assert_array_equal(times[k], one.times)
        np.testing.assert_array_equal(speed[k], one.speed)
        np.testing.assert_array_equal(accel[k], one.acceleration)


def test_force_split_single_is_row_zero_of_the_call() -> None:
    rng = np.random.default_rng(2)
    for allocation in ("shares", "own"):
        split = ForceSplit(crh2_half(), allocation=allocation)
        for _ in range(50):
            v, a = rng.uniform(0.1, 90.0), rng.uniform(-1.0, 1.0)
            inputs, elongations = split.single(v, a)
            q = split([v], [a])
            np.testing.assert_array_equal(inputs, q.inputs[0])
            np.testing.assert_array_equal(elongations, q.elongations[0])
            again = split.single(v, a)  # the kept pair, read-only
            assert again[0] is inputs and not inputs.flags.writeable


def test_envelope_at_one_speed_per_vehicle_equals_the_envelope_limits() -> None:
    train = crh2_half()
    bounds, other = EnvelopeBounds(train, enabled=True), EnvelopeBounds(train, enabled=True)
    cases = (np.full(4, 80.0), np.array([0.0, 0.05, -3.0, 40.0]),
             np.array([np.nan, 1.0, 2.0, 3.0]))
    for speeds in cases + cases[::-1]:  # the kept bounds of the last speeds, then others
        low, high = bounds.at(speeds)
        again = other.at(speeds.copy())
        assert again[0] is low and again[1] is high and not high.flags.writeable
        for i, vehicle in enumerate(train.vehicles):
            env = vehicle.envelope
            np.testing.assert_array_equal(high[i], envelope_limit(
                speeds[i], env.max_traction, env.max_power, env.adhesion, vehicle.mass))
            np.testing.assert_array_equal(-low[i], env.braking_limit(speeds[i],
                                                                     mass=vehicle.mass))


def test_finite() -> None:
    assert finite(np.array([1.0, -2.0]))
    assert finite(np.array([1e300, 1e300]))
    assert not finite(np.array([1.0, np.nan]))
    assert not finite(np.array([-np.inf, 1.0]))
    assert not finite(np.array([[1.0, np.inf]]))
    assert finite(np.empty(0))


class _FlakyLaw:
    """A potential law that raises on its 40th to 44th calls (a fault on the plain path)."""

    def __init__(self, law) -> None:
        self.law, self.n, self.calls = law, law.n, 0

    def force(self, v_err, z, x_err):
        self.calls += 1
        if 40 <= self.calls < 45:
            raise RuntimeError("lost the law")
        return self.law.force(v_err, z, x_err)


def _plain_laws(train):
    """An LQR law whose feedback raises on some calls, and a sampled potential law."""
    from trainctl.controllers.continuous.controller import SampledLawController
    from trainctl.controllers.continuous.potentials import QuadraticPotential
    from trainctl.controllers.lqr.controller import LQRController
    from trainctl.controllers.potential.law import PotentialLaw

    gain = np.zeros((4, 7))
    gain[np.arange(4), np.arange(4)] = 40.0  # kN per m/s: saturates after the ramp's start
    lqr = LQRController(train, gain, dt=DT)
    feedback, calls = lqr._feedback, [0]

    def flaky(deviation):
        calls[0] += 1
        if calls[0] % 97 == 0:
            raise RuntimeError("lost the gain")
        return feedback(deviation)

    lqr._feedback = flaky  # type: ignore[method-assign]
    law = PotentialLaw(mass=train.mass, pinning=np.full(4, 0.02), speed_gain=0.5,
                       consensus=np.zeros((4, 4)), potential=QuadraticPotential(0.5))
    return {"lqr": (lqr, calls), "potential": (SampledLawController(train, _FlakyLaw(law),
                                                                    dt=DT), None)}


@pytest.mark.parametrize("kind", ["lqr", "potential"])
def test_the_plain_path_records_what_step_records(kind: str,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """``step_inputs`` (no per-step objects) against ``step``: every array and record the
    same, faults included, on a track with crossings and saturation."""
    train = crh2_half()
    track = Track(sections=(TrackSection(start=0.0),
                            TrackSection(start=1000.0, grade_permille=8.0),
                            TrackSection(start=1100.0, grade_permille=-5.0,
                                         curve_radius=1500.0)))
    reference = ramp_profile(20.0, 30.0, 1.0, 6.0)
    x0 = equilibrium(train, 20.0).state(position=900.0)

    def run(plain: bool):
        controller, calls = _plain_laws(train)[kind]
        used = []
        original = type(controller).step_inputs

        def counted(self, *args):
            used.append(1)
            return original(self, *args)

        monkeypatch.setattr(type(controller), "step_inputs", counted)
        if not plain:  # the loop's rule: a step set on the instance is called as such
            controller.step = controller.step
        result = simulate(Plant(train=train, track=track), controller, reference,
                          duration=12.0, initial_state=x0, preview_steps=1, warn=False)
        monkeypatch.setattr(type(controller), "step_inputs", original)
        return result, len(used)

    fast, used_fast = run(True)
    slow, used_slow = run(False)
    assert used_fast == 240 and used_slow == 0
    assert "error" in fast.statuses and "optimal" in fast.statuses
    assert np.count_nonzero(fast.saturation) > 0
    _assert_same(fast, slow)


def test_a_subclass_that_overrides_step_alone_is_called_through_step() -> None:
    from trainctl.controllers.lqr.controller import LQRController

    class Doubled(LQRController):
        def step(self, t, measurement, reference):
            record = super().step(t, measurement, reference)
            return dataclasses.replace(record, inputs=2.0 * record.inputs)

    train = crh2_half()
    ctl = Doubled(train, np.zeros((4, 7)), dt=DT, input_bounds=False)
    assert closed_loop._plain_step(ctl) is None
    assert closed_loop._plain_step(LQRController(train, np.zeros((4, 7)), dt=DT)) is not None
    result = simulate(Plant(train=train), ctl, ramp_profile(20.0, 20.0, 0.0, 1.0),
                      duration=0.5, preview_steps=0,
                      initial_state=equilibrium(train, 20.0).state(position=0.0),
                      warn=False)
    np.testing.assert_allclose(result.requested_inputs[:, 0], 2.0 * equilibrium(train, 20.0).inputs,
                               rtol=1e-12)


def test_non_finite_plain_inputs_are_held_as_on_the_step_path() -> None:
    """A ``step_inputs`` that writes NaN gets what ``step`` returning NaN gets: the previous
    input held, status "error" and the hold fallback."""

    class Flaky:
        dt, name, preview_steps, needs_full_state = DT, "flaky", 0, True

        def __init__(self, train) -> None:
            self.inputs, self.calls = equilibrium(train, 20.0).inputs, 0

        def reset(self) -> None:
            self.calls = 0

        def _inputs(self):
            self.calls += 1
            return np.full(4, np.nan) if self.calls % 5 == 0 else self.inputs

        def step(self, t, measurement, reference):
            return StepRecord(inputs=self._inputs())

        def step_inputs(self, t, state, speed, acceleration, out):
            out[:] = self._inputs()

    train = crh2_half()
    x0 = equilibrium(train, 20.0).state(position=0.0)
    runs = []
    for plain in (True, False):
        ctl = Flaky(train)
        assert (closed_loop._plain_step(ctl) is not None) is True
        if not plain:
            ctl.step = ctl.step
        runs.append(simulate(Plant(train=train), ctl, ramp_profile(20.0, 20.0, 0.0, 1.0),
                             duration=1.0, preview_steps=0, initial_state=x0, warn=False))
    assert runs[0].statuses.count("error") == 4
    assert set(runs[0].fallbacks) == {"", closed_loop.HOLD_FALLBACK}
    _assert_same(*runs)
