"""Tests of the Kalman observer and output-feedback MPC on a grade."""

from __future__ import annotations

import numpy as np
import pytest

from trainctl.controllers.base import Measurement
from trainctl.controllers.mpc import MPCConstraints, make_mpc
from trainctl.controllers.mpc.observer import KalmanObserver, ObserverSettings
from trainctl.design import build_design
from trainctl.exceptions import ModelError
from trainctl.models import Track, TrackSection, crh2_half, equilibrium
from trainctl.scenario import load_scenario
from trainctl.sim import Plant, SpeedProfile, simulate

GRADE = 10.0                       # ‰, uphill everywhere
R_TRUE = GRADE * 9.81 / 1000       # its specific force [m/s²]


@pytest.fixture(scope="module")
def setup():
    scenario = load_scenario("crh2-dmpc-well-sampled")
    d = build_design(scenario).family("mpc").mpc
    track = Track(sections=(TrackSection(start=0.0, grade_permille=GRADE),))
    return scenario, d, Plant(train=scenario.train, track=track)


def run(setup, observer, noise=0.0, duration=60.0):
    scenario, d, plant = setup
    ctl = make_mpc(scenario.train, d, dt=scenario.model.sample_time, strategy="centralised",
                   constraints=MPCConstraints(), observer=observer, design_speed=50.0)
    x0 = equilibrium(scenario.train, 50.0).state(position=0.0)
    return ctl, simulate(plant, ctl, SpeedProfile(times=(0.0,), speeds=(50.0,)),
                         duration=duration, initial_state=x0, preview_steps=d.prediction_horizon,
                         measurement_noise=noise, seed=3, full_state=observer is None)


class TestKalmanObserver:
    def test_filter_gain_is_the_riccati_filter_gain(self):
        """The gain equals P Cᵀ(CPCᵀ + R)⁻¹ of an independently iterated Riccati recursion."""
        obs = KalmanObserver(crh2_half(), 0.1, 80.0, ObserverSettings())
        # Rebuild the augmented model and iterate the a-priori covariance to convergence.
        import control as ct

        from trainctl.models import discretise, linearise
        sys = linearise(crh2_half(), 80.0)
        b_r = np.zeros((7, 1))
        b_r[:4, 0] = -1.0
        dd = discretise(ct.ss(sys.A, np.hstack([sys.B, b_r]), sys.C, 0), 0.1)
        A = np.block([[dd.A, dd.B[:, 4:]], [np.zeros((1, 7)), np.ones((1, 1))]])
        C = np.hstack([dd.C, np.zeros((4, 1))])
        s = ObserverSettings()
        Q = np.diag([s.speed_noise**2] * 4 + [s.elongation_noise**2] * 3 + [s.disturbance_noise**2])
        R = np.eye(4) * s.measurement_noise**2
        P = np.eye(8)
        for _ in range(20000):
            K = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
            P = A @ (P - K @ C @ P) @ A.T + Q
        K = P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
        np.testing.assert_allclose(obs.gain, K, rtol=1e-6, atol=1e-10)

    def test_settings_are_validated(self):
        """Non-positive noise levels are rejected."""
        with pytest.raises(ModelError, match="'measurement_noise' must be > 0"):
            ObserverSettings(measurement_noise=0.0)

    def test_observer_needs_a_design_speed(self, setup):
        """make_mpc refuses an observer without the speed its gain is designed at."""
        scenario, d, _ = setup
        with pytest.raises(ModelError, match="design_speed"):
            make_mpc(scenario.train, d, dt=0.05, observer=ObserverSettings())


class TestOffsetFree:
    def test_state_feedback_without_disturbance_model_has_an_offset(self, setup):
        """Full state but no disturbance estimate: a 10‰ climb leaves a large speed error."""
        _, res = run(setup, None)
        assert np.mean(res.velocities[:, -200:] - 50.0) < -1.0

    def test_observer_estimates_the_grade_and_removes_the_offset(self, setup):
        """Speeds only: r̂ -> g·i/1000 and the speed error decays (offset-free)."""
        ctl, res = run(setup, ObserverSettings(measurement_noise=0.01, disturbance_noise=2e-2))
        assert ctl._disturbance == pytest.approx(R_TRUE, rel=1e-3)
        err = np.mean(res.velocities - 50.0, axis=0)
        assert abs(err[-1]) < 0.05 and abs(err[-1]) < abs(err[400])

    def test_noisy_speeds_give_an_unbiased_disturbance_estimate(self, setup):
        """With 0.05 m/s noise the disturbance estimate stays near the true grade force."""
        ctl, res = run(setup, ObserverSettings(measurement_noise=0.05, disturbance_noise=1e-3),
                       noise=0.05)
        assert ctl._disturbance == pytest.approx(R_TRUE, rel=0.2)
        assert np.all(np.isfinite(res.inputs))

    def test_controller_without_observer_needs_the_state(self, setup):
        """Full-state controllers refuse a measurement without the state."""
        scenario, d, _ = setup
        ctl = make_mpc(scenario.train, d, dt=0.05, strategy="centralised")
        with pytest.raises(ModelError, match="full-state measurement"):
            ctl.step(0.0, Measurement(outputs=np.full(4, 50.0)),
                     SpeedProfile(times=(0.0,), speeds=(50.0,)).preview(0.0, 0.05, 40))


class TestScenarioObserver:
    def test_kalman_observer_from_a_scenario_file(self):
        """[controller] observer = "kalman": the strategy runs on measured speeds only."""
        from trainctl.run.analysis import make_controller, simulate_strategy
        from trainctl.scenario import builtin_scenario_text, parse_scenario

        text = builtin_scenario_text("crh2-dmpc").replace(
            "[controller]\n", '[controller]\nobserver = "kalman"\n', 1).replace(
            "[simulation]\n", "[simulation]\nmeasurement_noise = 0.02\n", 1)
        scenario = parse_scenario(text)
        assert scenario.controller.observer == "kalman"
        assert not make_controller(scenario, "centralised").needs_full_state
        result = simulate_strategy(scenario, "centralised")
        error = np.abs(result.velocities[:, 10:] - result.reference_speed[10:])
        assert error.max() < scenario.simulation.tracking_tolerance

    def test_unknown_observer_is_rejected(self):
        """A misspelt observer name is a ScenarioError with a suggestion."""
        from trainctl.exceptions import ScenarioError
        from trainctl.scenario import builtin_scenario_text, parse_scenario

        text = builtin_scenario_text("crh2-dmpc").replace(
            "[controller]\n", '[controller]\nobserver = "kalman2"\n', 1)
        with pytest.raises(ScenarioError, match=r"\[controller\]\.observer"):
            parse_scenario(text)
