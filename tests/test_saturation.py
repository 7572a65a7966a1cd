"""Actuator limits in the plant: every controller's forces saturated and recorded per vehicle."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from trainctl.controllers.base import StepRecord
from trainctl.exceptions import DimensionError, InaccurateSolutionWarning, ScenarioError
from trainctl.models import ActuatorLimits, Plant, crh2_half, equilibrium
from trainctl.run.analysis import run_scenario
from trainctl.scenario import builtin_scenario_text, load_scenario, parse_scenario
from trainctl.sim import SimulationResult, compute_metrics, ramp_profile, simulate


def envelope(train, speeds) -> tuple[np.ndarray, np.ndarray]:
    """Braking (negative) and traction limits [N] per vehicle, from each TractionEnvelope."""
    low = np.array([-float(veh.envelope.braking_limit(v, mass=veh.mass))
                    for veh, v in zip(train.vehicles, speeds, strict=True)])
    high = np.array([float(veh.envelope.traction_limit(v, mass=veh.mass))
                     for veh, v in zip(train.vehicles, speeds, strict=True)])
    return low, high


class TenTimes:
    """Toy controller: 10x the strongest traction limit on every vehicle for the first
    ``switch`` samples, then -10x the strongest braking limit."""

    def __init__(self, train, dt: float, switch: int) -> None:
        self.train, self.dt, self.switch, self.name = train, dt, switch, "ten-times"
        self.k = 0

    def reset(self) -> None:
        self.k = 0

    def step(self, t, measurement, reference) -> StepRecord:
        low, high = envelope(self.train, measurement.state[:self.train.n_vehicles])
        n = self.train.n_vehicles
        ask = np.full(n, 10.0 * high.max()) if self.k < self.switch else np.full(n, 10 * low.min())
        self.k += 1
        return StepRecord(inputs=ask)


class TestActuatorLimits:
    def test_requests_are_cut_to_each_vehicles_envelope_at_its_speed(self):
        """Motor cars to their power limit at their own speed, trailers to zero traction."""
        train = crh2_half()
        limits = ActuatorLimits(train)
        speeds = np.array([60.0, 70.0, 80.0, 30.0])
        low, high = envelope(train, speeds)
        applied, side = limits.apply(np.full(4, 1e6), speeds)
        assert applied.tolist() == high.tolist() and side.tolist() == [1, 1, 1, 1]
        assert high[0] == high[3] == 0.0 and high[1] > high[2]     # 1.2 MW / v
        applied, side = limits.apply(np.full(4, -1e7), speeds)
        assert applied.tolist() == low.tolist() and side.tolist() == [-1, -1, -1, -1]

    def test_requests_within_the_envelope_or_its_tolerance_pass_unchanged(self):
        """Unchanged within 1 N; a force held at a (non-zero) limit still counts as saturated."""
        train = crh2_half()
        limits = ActuatorLimits(train)
        speeds = np.full(4, 80.0)
        low, high = envelope(train, speeds)
        ask = np.array([0.5, high[1] + 0.9, 0.5 * high[2], low[3] - 0.5])  # solver noise
        applied, side = limits.apply(ask, speeds)
        assert applied.tolist() == ask.tolist() and side.tolist() == [0, 1, 0, -1]
        applied, side = limits.apply(np.array([0.0, 1e3, -1e3, -0.5]), speeds)
        assert not side.any()  # the trailers coast at their zero traction limit
        off = ActuatorLimits(train, enabled=False)
        applied, side = off.apply(np.full(4, 1e9), speeds)
        assert applied.tolist() == [1e9] * 4 and not side.any()
        with pytest.raises(DimensionError, match="one per vehicle"):
            limits.apply(np.zeros(3), speeds)


@pytest.fixture(scope="module")
def ten_times() -> tuple[SimulationResult, np.ndarray]:
    """10 samples of 2 s: 6 asking 10x traction, 4 asking 10x braking."""
    train = crh2_half()
    x0 = equilibrium(train, 50.0).state(position=100.0)
    result = simulate(Plant(train=train), TenTimes(train, 2.0, 6),
                      ramp_profile(50.0, 50.0, 0.0, 1.0), duration=20.0, initial_state=x0,
                      preview_steps=0)
    return result, x0


class TestPlantSaturation:
    def test_a_controller_asking_ten_times_the_envelope_is_saturated(self, ten_times):
        """The plant applies each vehicle's envelope at its speed at the sample, not the request."""
        result, _ = ten_times
        train = crh2_half()
        for k in range(result.n_samples):
            low, high = envelope(train, result.velocities[:, k])
            expected = high if k < 6 else low
            np.testing.assert_array_equal(result.inputs[:, k], expected)
            assert np.all(np.abs(result.requested_inputs[:, k]) >= 9.9 * np.abs(expected).max())
        assert result.meta["plant_saturation"] is True

    def test_saturation_is_recorded_per_vehicle(self, ten_times):
        """Flags +1 then -1 on every vehicle (trailers asked for traction they lack too)."""
        result, x0 = ten_times
        assert result.saturation.dtype == np.int8
        assert (result.saturation[:, :6] == 1).all() and (result.saturation[:, 6:] == -1).all()
        m = compute_metrics(result)
        assert m.saturated
        assert m.saturation_time.tolist() == [20.0] * 4
        assert m.braking_saturation_time.tolist() == [8.0] * 4
        assert m.first_saturation_time.tolist() == [0.0] * 4
        assert m.first_saturation_position.tolist() == [x0[-1]] * 4
        data = json.loads(json.dumps(m.to_dict()))
        assert data["saturation_time"] == [20.0] * 4 and data["diverged"] is False

    def test_analyse_flags_the_saturated_vehicles(self, ten_times):
        """The analyse table's sat column, a line per vehicle, and the JSON."""
        result, _ = ten_times
        scenario = load_scenario("crh2-dmpc")
        run = run_scenario(scenario, simulate=False)
        run = replace(run, simulations={"ten-times": result},
                      metrics={"ten-times": compute_metrics(result)})
        text = run.format_text()
        assert "vehicle 1 saturated (traction and braking) for 20 s, first at t = 0 s" in text
        row = next(line for line in text.splitlines() if line.startswith("  ten-times "))
        assert row.split()[5] == "20"  # the sat [s] column
        data = json.loads(json.dumps(run.to_dict()))["simulations"]["ten-times"]
        assert data["saturation_time"] == [20.0] * 4 and data["plant_saturation"] is True

    def test_without_saturation_the_requests_are_applied(self):
        train = crh2_half()
        x0 = equilibrium(train, 50.0).state(position=0.0)
        result = simulate(Plant(train=train), TenTimes(train, 2.0, 2),
                          ramp_profile(50.0, 50.0, 0.0, 1.0), duration=4.0, initial_state=x0,
                          preview_steps=0, saturation=False)
        assert np.array_equal(result.inputs, result.requested_inputs)
        assert not result.saturation.any() and result.meta["plant_saturation"] is False
        assert not compute_metrics(result).saturated

    def test_a_non_finite_request_is_held_then_saturated(self):
        """The held previous input is saturated at the new speed like any request."""

        class NaNAfterFirst(TenTimes):
            def step(self, t, measurement, reference):
                record = super().step(t, measurement, reference)
                return record if self.k == 1 else StepRecord(inputs=np.full(4, math.nan))

        train = crh2_half()
        x0 = equilibrium(train, 50.0).state(position=0.0)
        with pytest.warns(InaccurateSolutionWarning, match=r"2 of 3 samples .*\(error 2\)"):
            result = simulate(Plant(train=train), NaNAfterFirst(train, 2.0, 10),
                              ramp_profile(50.0, 50.0, 0.0, 1.0), duration=6.0,
                              initial_state=x0, preview_steps=0)
        assert result.statuses == ("optimal", "error", "error")
        assert np.array_equal(result.requested_inputs[:, 1], result.inputs[:, 0])
        for k in range(3):
            np.testing.assert_array_equal(result.inputs[:, k],
                                          envelope(train, result.velocities[:, k])[1])


class TestSimulationKeys:
    def scenario(self, *lines: str):
        text = builtin_scenario_text("crh2-dmpc")
        return parse_scenario(text.replace("[simulation]\n",
                                           "[simulation]\n" + "\n".join(lines) + "\n", 1))

    def test_defaults(self):
        sim = load_scenario("crh2-dmpc").simulation
        assert sim.plant_saturation is True and sim.max_saturation_time == math.inf
        assert sim.output_interval is None and sim.divergence_speed_error == 50.0

    def test_keys_are_read(self):
        sim = self.scenario("plant_saturation = false", "max_saturation_time = 30",
                            "output_interval = 0.5", "divergence_speed_error = 20").simulation
        assert (sim.plant_saturation, sim.max_saturation_time, sim.output_interval,
                sim.divergence_speed_error) == (False, 30.0, 0.5, 20.0)

    @pytest.mark.parametrize(("line", "match"), [
        ("plant_saturation = 1", r"\[simulation\]\.plant_saturation must be true or false"),
        ("max_saturation_time = -1", r"max_saturation_time must be a number >= 0"),
        ("output_interval = 0", r"output_interval must be a number > 0"),
        ("divergence_speed_error = 0", r"divergence_speed_error must be a number > 0"),
        ("initial_speed_error = 60", r"initial_speed_error must be smaller in magnitude than "
                                     r"\[simulation\]\.divergence_speed_error = 50\.0 m/s"),
    ])
    def test_bad_values_are_refused(self, line, match):
        with pytest.raises(ScenarioError, match=match):
            self.scenario(line)

    def test_the_run_and_its_text_say_when_saturation_is_off(self):
        scenario = self.scenario("plant_saturation = false")
        scenario = replace(scenario, simulation=replace(scenario.simulation, duration=100.0,
                                                        settle_time=0.0,
                                                        strategies=("centralised",)))
        run = run_scenario(scenario)
        assert run.simulations["centralised"].meta["plant_saturation"] is False
        assert "nonlinear plant without saturation" in run.format_text()
        assert run.to_dict()["simulations"]["centralised"]["plant_saturation"] is False
