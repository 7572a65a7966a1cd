"""The energy account of a run (trainctl.sim.energy): hand cases, closing balances, errors."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import simpson

from trainctl.controllers.base import StepRecord
from trainctl.exceptions import ModelError
from trainctl.models import Track, TrackSection, Train
from trainctl.models.dynamics import vehicle_positions
from trainctl.models.vehicle import Vehicle
from trainctl.run.simulate import simulate_strategy
from trainctl.scenario import load_scenario
from trainctl.sim import Plant, SpeedProfile, simulate
from trainctl.sim.energy import EnergyAccount, energy_account
from trainctl.units import GRAVITY, JOULES_PER_KWH, j_to_kwh, kwh_to_j


class HeldForce:
    """Stand-in controller: the same forces at every sample."""

    name = "held"

    def __init__(self, inputs: np.ndarray, dt: float) -> None:
        self.inputs, self.dt = np.asarray(inputs, dtype=float), dt

    def reset(self) -> None:
        pass

    def step(self, t, measurement, reference) -> StepRecord:
        return StepRecord(inputs=self.inputs.copy())


def hilly(formula: str, step: float, start: float) -> Track:
    """Eight sections of ``step`` m from ``start``: climbs, descents and curves."""
    grades = [8.0, -12.0, 0.0, 5.0, -6.0, 12.0, -3.0, 0.0]
    radii = [math.inf, 1200.0, 800.0, math.inf, 2000.0, math.inf, 600.0, math.inf]
    return Track(sections=tuple(
        TrackSection(start=start + i * step, grade_permille=g, curve_radius=r)
        for i, (g, r) in enumerate(zip(grades, radii, strict=True))), formula=formula)


# One built-in scenario per controller family, shortened, on a hilly curved track laid
# where its vehicles run; the hinf train (subsystems 633 m long) slows from 70 to 60 km/h
# in 20 s, which needs its brakes, with its couplers' springs and dampers excited.
FAMILIES = {
    "mpc": ("crh2-dmpc", "ndmpc", 200.0, hilly("tbt", 500.0, 200.0), {}),
    "potential": ("crh2-potential", "consensus", 5.0, hilly("tbt", 20.0, -100.0), {}),
    "flocking": ("heavy-haul-flocking", "flocking", 200.0, hilly("tbt", 300.0, -3000.0), {}),
    "hinf": ("heavy-haul-hinf-ideal", "distributed", 60.0, hilly("ning2016", 250.0, -1950.0),
             {"simulation.initial_spacing_errors": [0.02, -0.02, 0.02],
              "simulation.reference.times": [0.0, 20.0, 40.0, 50.0],
              "simulation.reference.speeds_kmh": [70.0, 70.0, 60.0, 60.0]}),
}


def family_run(family: str, **changes: object):
    name, strategy, duration, track, extra = FAMILIES[family]
    scenario = (load_scenario(name).replace("simulation.settle_time", duration / 2)
                .replace("simulation.duration", duration))
    for key, value in {**extra, **changes}.items():
        scenario = scenario.replace(key, value)
    scenario = replace(scenario, track=track)
    return scenario, simulate_strategy(scenario, strategy, warn=False)


@pytest.fixture(scope="module")
def runs():
    return {family: family_run(family) for family in FAMILIES}


class TestTextbookCase:
    def test_constant_speed_up_a_constant_grade(self):
        """One 50 t vehicle holds 20 m/s up 6 ‰ for 100 s with u = Davis + m g i/1000."""
        m, a0, a1, a2, v, grade = 5.0e4, 0.01, 2.0e-4, 1.0e-5, 20.0, 6.0
        train = Train(vehicles=(Vehicle(mass=m, a0=a0, a1=a1, a2=a2),), couplers=())
        track = Track(sections=(TrackSection(start=-50.0, grade_permille=grade),))
        davis = m * (a0 + a1 * v + a2 * v**2)  # 1 400 N
        climb = m * GRAVITY * grade / 1000.0  # 2 943 N
        result = simulate(Plant(train=train, track=track), HeldForce([davis + climb], 10.0),
                          SpeedProfile(times=np.array([0.0]), speeds=np.array([v])),
                          duration=100.0, initial_state=[v, 0.0], preview_steps=1,
                          saturation=False)
        distance = v * 100.0
        account = energy_account(result, train, track)
        np.testing.assert_allclose(result.velocities, v, rtol=1e-12)
        np.testing.assert_allclose(account.total("traction_work"), (davis + climb) * distance,
                                   rtol=1e-12)
        # m g Δh with Δh = i/1000 · distance = 12 m.
        np.testing.assert_allclose(account.total("grade_work"), m * GRAVITY * 12.0, rtol=1e-12)
        np.testing.assert_allclose(account.total("running_loss"), davis * distance,
                                   rtol=1e-12)
        assert account.total("braking_work") == 0.0 and account.total("curve_work") == 0.0
        assert abs(account.kinetic_change) < 1e-6
        assert abs(account.residual) < 1e-9 * account.total("traction_work")
        # 4 343 N over 2 km for 50 t: 8 686 kJ / (50 t · 2 km).
        np.testing.assert_allclose(account.energy_per_tonne_km,
                                   (davis + climb) * distance / (50.0 * 2.0), rtol=1e-12)

    def test_line_antiderivative_by_hand(self):
        """R(p) section by section: TB/T i g/1000 and 600/R g/1000; ning2016 9.98 sin θ."""
        sections = (TrackSection(start=0.0, grade_permille=10.0),
                    TrackSection(start=100.0, grade_permille=-5.0, curve_radius=600.0))
        tbt = Track(sections=sections)
        g = GRAVITY / 1000.0
        # Before the first start its section extends backwards; the second section's
        # -5 ‰ and 600/600 N/kN of curve make -4 N/kN.
        expected = [-50.0 * 10.0 * g, 0.0, 100.0 * 10.0 * g, 100.0 * 10.0 * g - 50.0 * 4.0 * g]
        np.testing.assert_allclose(tbt.resistance_integral([-50.0, 0.0, 100.0, 150.0]),
                                   expected, rtol=1e-12)
        np.testing.assert_allclose(tbt.resistance_integral([150.0], part="curve"),
                                   [50.0 * 1.0 * g], rtol=1e-12)
        ning = Track(sections=sections, formula="ning2016")
        grade = 9.98 * (100.0 * math.sin(math.atan(0.01)) + 50.0 * math.sin(math.atan(-0.005)))
        np.testing.assert_allclose(ning.resistance_integral([150.0], part="grade"), [grade],
                                   rtol=1e-12)
        np.testing.assert_allclose(ning.resistance_integral([150.0], part="curve"),
                                   [50.0 * 0.04 * 0.5 * 1.83 / 600.0], rtol=1e-9)

    def test_energy_units(self):
        """3.6 MJ is one kWh, both ways."""
        assert JOULES_PER_KWH == 3.6e6
        assert j_to_kwh(3.6e6) == 1.0 and kwh_to_j(2.5) == 9.0e6


class TestBalance:
    @pytest.mark.parametrize("family", list(FAMILIES))
    def test_balance_closes_on_each_family(self, runs, family):
        """Input work = Δkinetic + Δspring + line work + losses, to 1e-7 of the work.

        The plant is accurate to ~1e-9 in speed (trainctl.models.plant), and the
        kinetic energy it carries is up to a few times the work of these runs, so
        ~1e-8 is what can be asked; measured 5e-11 .. 4e-9. 1e-7 leaves a margin of
        25 and still fails on any term larger than 1e-7 of the work: each term
        below is asserted to be larger.
        """
        scenario, result = runs[family]
        account = energy_account(result, scenario.train, scenario.track)
        work = account.total("traction_work") + account.total("braking_work")
        assert abs(account.residual) <= 1e-7 * work, (family, account.relative_residual)
        terms = {"braking": account.total("braking_work"),
                 "grade": abs(account.total("grade_work")),
                 "curve": account.total("curve_work"),
                 "running": account.total("running_loss")}
        if family in ("potential", "hinf"):  # started with deflected couplers
            terms["spring"] = abs(account.spring_change)
        if family == "hinf":  # the only built-in couplers with damping
            terms["damping"] = account.total("damping_loss")
        for name, value in terms.items():
            assert value > 1e-6 * work, (family, name, value)

    def test_virtual_links_store_no_spring_energy(self, runs):
        """Flocking's virtual links have k = d = 0, whatever their gap errors."""
        scenario, result = runs["flocking"]
        account = energy_account(result, scenario.train, scenario.track)
        assert np.any(result.states[4:7] != 0.0)
        assert not np.any(account.spring_start) and not np.any(account.spring_end)
        assert not np.any(account.damping_loss)

    def test_losses_agree_with_a_16_times_finer_grid(self, runs):
        """The kink terms at section crossings: the default grid's Davis losses equal the
        ones on a 16x finer grid to 1e-9 (Simpson alone errs by ~4e-8, the plain
        trapezoid at the crossings without the kink term by ~5e-9)."""
        scenario, result = runs["flocking"]
        coarse = energy_account(result, scenario.train, scenario.track)
        fine_scenario, fine = family_run("flocking", **{"simulation.output_interval": 0.003125})
        assert fine.dense_time.size > 15 * result.dense_time.size
        refined = energy_account(fine, fine_scenario.train, fine_scenario.track)
        np.testing.assert_allclose(coarse.running_loss, refined.running_loss, rtol=1e-9)

    def test_input_work_is_the_held_force_times_the_distance(self, runs):
        """Traction and braking work agree with ∫ u v dt on the dense grid (Simpson)."""
        scenario, result = runs["mpc"]
        account = energy_account(result, scenario.train, scenario.track)
        index = np.searchsorted(result.dense_time, result.time)
        traction = np.zeros(result.n_vehicles)
        braking = np.zeros(result.n_vehicles)
        for k in range(result.n_samples):
            span = slice(index[k], index[k + 1] + 1)
            distance = simpson(result.dense_velocities[:, span], x=result.dense_time[span])
            u = result.inputs[:, k]
            traction += np.where(u > 0, u * distance, 0.0)
            braking += np.where(u < 0, -u * distance, 0.0)
        np.testing.assert_allclose(account.traction_work, traction, rtol=1e-8)
        np.testing.assert_allclose(account.braking_work, braking, rtol=1e-8, atol=1e-3)


class TestRegeneration:
    @pytest.mark.parametrize("eta", [0.0, 0.6, 1.0])
    def test_regenerated_is_the_efficiency_times_the_braking_work(self, runs, eta):
        """Regenerated = η × Σ -u Δp over the braking intervals; net = traction - that."""
        scenario, result = runs["potential"]
        account = energy_account(result, scenario.train, scenario.track, regen_efficiency=eta)
        p = vehicle_positions(scenario.train, result.states)
        # Independently: vehicle by vehicle, interval by interval.
        braking = [sum(-result.inputs[i, k] * (p[i, k + 1] - p[i, k])
                       for k in range(result.n_samples) if result.inputs[i, k] < 0)
                   for i in range(result.n_vehicles)]
        np.testing.assert_allclose(account.regenerated, eta * np.array(braking), rtol=1e-9)
        np.testing.assert_allclose(account.total("net_energy"),
                                   account.total("traction_work") - eta * sum(braking),
                                   rtol=1e-12)
        assert sum(braking) > 0
        if eta > 0:
            assert account.total("net_energy") < account.total("traction_work")

    def test_to_dict_is_json_and_in_kwh(self, runs):
        """to_dict: JSON without NaN; the kWh totals are the joule totals / 3.6e6."""
        scenario, result = runs["hinf"]
        account = energy_account(result, scenario.train, scenario.track, regen_efficiency=0.8)
        d = json.loads(json.dumps(account.to_dict(), allow_nan=False))
        assert d["kwh"]["net_energy"] == pytest.approx(d["totals"]["net_energy"] / 3.6e6)
        assert d["totals"]["residual"] == pytest.approx(account.residual)
        assert len(d["traction_work"]) == 4 and len(d["damping_loss"]) == 3
        assert isinstance(account, EnergyAccount)


class TestBadInput:
    @pytest.mark.parametrize("eta", [1.5, -0.1])
    def test_efficiency_outside_zero_one(self, runs, eta):
        """regen_efficiency must lie in [0, 1]."""
        scenario, result = runs["mpc"]
        message = f"energy_account: 'regen_efficiency' must be in [0, 1] (got {eta!r})."
        with pytest.raises(ModelError, match=re.escape(message)):
            energy_account(result, scenario.train, regen_efficiency=eta)

    def test_efficiency_not_a_number(self, runs):
        """A NaN efficiency is refused."""
        scenario, result = runs["mpc"]
        with pytest.raises(ModelError, match=re.escape("energy_account: 'regen_efficiency'")):
            energy_account(result, scenario.train, regen_efficiency=math.nan)

    def test_result_of_another_train(self, runs):
        """A 4-coach run with the 8-car train is refused, naming both sizes."""
        _, result = runs["mpc"]
        eight, _ = runs["potential"]
        message = ("energy_account: 'result' must be a run of the train's 8 vehicles, with "
                   "states [v, delta, s] of 16 rows (got a run of 4 vehicles, 8 state rows).")
        with pytest.raises(ModelError, match=re.escape(message)):
            energy_account(result, eight.train)

    def test_track_of_the_wrong_type(self, runs):
        """track must be a Track or None."""
        scenario, result = runs["mpc"]
        with pytest.raises(ModelError, match=re.escape("must be a Track or None (got str)")):
            energy_account(result, scenario.train, "flat")  # type: ignore[arg-type]


class TestMetrics:
    def test_compute_metrics_carries_the_account_given_the_train(self, runs):
        """compute_metrics(train=, track=) holds the account, in to_dict too; without, None."""
        from trainctl.sim import compute_metrics

        scenario, result = runs["hinf"]
        metrics = compute_metrics(result, regen_efficiency=0.7, train=scenario.train,
                                  track=scenario.track)
        account = energy_account(result, scenario.train, scenario.track, regen_efficiency=0.7)
        assert metrics.energy_account is not None
        np.testing.assert_array_equal(metrics.energy_account.regenerated, account.regenerated)
        d = json.loads(json.dumps(metrics.to_dict(), allow_nan=False))
        assert d["energy_account"]["totals"]["net_energy"] == pytest.approx(
            account.total("net_energy"))
        assert "energy_kwh" in d  # the trapezoid estimate stays
        assert compute_metrics(result).energy_account is None
        assert compute_metrics(result).to_dict()["energy_account"] is None


class TestReportFigure:
    @pytest.mark.parametrize("family", ["potential", "hinf"])
    def test_cumulative_energy_ends_at_the_account_net_energy(self, runs, family):
        """The report's energy figure ends each curve at the account's net energy (η = 0.6).

        Both runs brake (so η matters); the account is the independent route.
        """
        from trainctl.report.figures_time import time_figures

        scenario, result = runs[family]
        scenario = replace(scenario, simulation=replace(scenario.simulation,
                                                        regen_efficiency=0.6))
        figures = {}

        def make(key, title, caption, figure):
            figures[key] = figure
            return key

        keys = list(time_figures(scenario, {"run": result}, make))
        assert "energy" in keys and keys.index("energy") == keys.index("input") + 1
        account = energy_account(result, scenario.train, scenario.track, regen_efficiency=0.6)
        assert account.total("braking_work") > 1e-3 * account.total("traction_work")
        drawn = figures["energy"].axes[1].lines[0].get_ydata()
        np.testing.assert_allclose(drawn[-1] * JOULES_PER_KWH, account.total("net_energy"),
                                   rtol=1e-9)
        assert drawn[0] == 0.0

    def test_interval_work_sums_to_the_account(self, runs):
        """interval_work: (n, N) arrays, >= 0, traction where u > 0, braking where u < 0."""
        from trainctl.sim.energy import interval_work

        scenario, result = runs["potential"]
        traction, braking = interval_work(result, scenario.train)
        assert traction.shape == braking.shape == result.inputs.shape
        assert np.all(traction >= 0) and np.all(braking[result.inputs < 0] >= 0)
        assert not np.any(traction[result.inputs <= 0]) and not np.any(
            braking[result.inputs >= 0])
        account = energy_account(result, scenario.train, scenario.track)
        np.testing.assert_array_equal(traction.sum(axis=1), account.traction_work)
        np.testing.assert_array_equal(braking.sum(axis=1), account.braking_work)
