"""Seed 000 closed loops: the scenario's strategies on the nonlinear plant."""

from __future__ import annotations

import json

import numpy as np
import pytest

from trainctl.exceptions import InaccurateSolutionWarning
from trainctl.models import Plant
from trainctl.run.analysis import run_scenario
from trainctl.scenario import load_scenario

pytestmark = pytest.mark.e2e  # a long end-to-end run (make test-e2e): whole pipelines


@pytest.fixture(scope="module")
def book_run():
    return run_scenario(load_scenario("crh2-dmpc"))


@pytest.fixture(scope="module")
def fast_run():
    return run_scenario(load_scenario("crh2-dmpc-well-sampled"))


class TestSeed000:
    @pytest.mark.parametrize("fixture", ["book_run", "fast_run"])
    def test_every_strategy_tracks_within_the_stated_tolerance(self, fixture, request):
        """After the scenario's settle time every coach is within tracking_tolerance."""
        book_run = request.getfixturevalue(fixture)
        sim = book_run.scenario.simulation
        assert set(book_run.metrics) == set(sim.strategies)
        assert {"centralised", "decentralised", "ndmpc"} <= set(sim.strategies)
        for name, m in book_run.metrics.items():
            assert np.max(m.max_error) <= sim.tracking_tolerance, name
            assert book_run.tracking_ok(name)

    @pytest.mark.parametrize("fixture", ["book_run", "fast_run"])
    def test_traction_and_coupler_forces_stay_within_bounds(self, fixture, request):
        """Inputs lie in each coach's envelope at the reference speed; |f| <= 500 kN."""
        book_run = request.getfixturevalue(fixture)
        train = book_run.scenario.train
        limit = book_run.scenario.controller.coupler_force_limit
        for name, res in book_run.simulations.items():
            v_ref = res.reference_speed[:-1]
            up = np.array([[v.envelope.traction_limit(s, mass=v.mass) for s in v_ref]
                           for v in train.vehicles])
            down = np.array([[v.envelope.braking_limit(s, mass=v.mass) for s in v_ref]
                             for v in train.vehicles])
            assert np.all(res.inputs <= up + 1.0), name      # 1 N of solver tolerance
            assert np.all(res.inputs >= -down - 1.0), name
            assert np.all(res.inputs[[0, 3]] <= 1.0), name    # trailers brake only
            assert np.max(np.abs(res.coupler_forces)) <= limit, name
            assert set(res.statuses) <= {"optimal", "optimal_inaccurate"}, name
            # Within the envelope at the actual speed too: the plant cut nothing.
            assert not res.saturation.any(), name
            assert np.array_equal(res.requested_inputs, res.inputs), name

    def test_resolving_the_couplers_tracks_far_better(self, book_run, fast_run):
        """T = 0.05 s tracks the same profile with a far smaller error than the book's 20 s."""
        for name in ("centralised", "decentralised", "ndmpc"):
            assert np.max(fast_run.metrics[name].max_error) < 0.1 * np.max(
                book_run.metrics[name].max_error)

    def test_metrics_are_reported(self, book_run):
        """The JSON of the run carries metrics per strategy; the text has the table."""
        data = json.loads(json.dumps(book_run.to_dict()))
        assert set(data["simulations"]) == {"centralised", "decentralised", "ndmpc"}
        assert data["simulations"]["ndmpc"]["tracking_ok"] is True
        assert "Closed-loop simulations" in book_run.format_text()

    def test_plant_integrator_agrees_with_solve_ivp_over_the_full_run(self, book_run):
        """Replaying the N-DMPC inputs: splitting integrator = solve_ivp (rtol 1e-9), 1200 s."""
        res = book_run.simulations["ndmpc"]
        plant = Plant(train=book_run.scenario.train)
        x_split = x_ref = res.states[:, 0]
        for k in range(res.inputs.shape[1]):
            x_split = plant.advance(x_split, res.inputs[:, k], res.dt)
            x_ref = plant.advance_reference(x_ref, res.inputs[:, k], res.dt, rtol=1e-9)
        n = 4
        np.testing.assert_allclose(x_split[:n], x_ref[:n], rtol=1e-7)
        forces_split = 1.0488e7 * x_split[n:2 * n - 1]
        forces_ref = 1.0488e7 * x_ref[n:2 * n - 1]
        np.testing.assert_allclose(forces_split, forces_ref, atol=1e-3 * np.ptp(res.coupler_forces))
        np.testing.assert_allclose(x_split, res.states[:, -1], rtol=1e-12)  # the run used it


def test_infeasible_scenario_records_statuses_falls_back_and_completes():
    """Start at 20 m/s asked to accelerate at 0.8 m/s²: the feedforward exceeds the 60 kN
    power limit by more than the 1 kN/step rate limit allows. The run completes, the
    infeasible samples are recorded and the declared fallback (shifted plan) is applied."""
    from trainctl.run.analysis import simulate_strategy
    from trainctl.scenario import builtin_scenario_text, parse_scenario

    text = builtin_scenario_text("crh2-dmpc")
    text = text.replace("[controller]\n", "[controller]\nrate_limit_kn = 1.0\n", 1)
    text = text.replace("times = [0.0, 60.0, 460.0, 1020.0, 1200.0]", "times = [0, 60, 1200]")
    text = text.replace("speeds_kmh = [72.0, 72.0, 216.0, 288.0, 288.0]",
                        "speeds_kmh = [72, 244.8, 244.8]")
    scenario = parse_scenario(text)
    assert scenario.simulation.reference_times == (0.0, 60.0, 1200.0)
    with pytest.warns(InaccurateSolutionWarning, match="infeasible"):
        result = simulate_strategy(scenario, "ndmpc")
    assert len(result.statuses) == 60 and np.all(np.isfinite(result.inputs))
    assert result.statuses[0] == "infeasible" and result.fallbacks[0] == "shifted plan"
    assert "fallback" not in result.statuses


class TestBaselines:
    """The LQR baseline beside the MPC strategies on the well-sampled CRH2 scenario."""

    def test_lqr_tracks_and_is_compared_in_the_report(self, fast_run):
        """Analyse text and the report's table, spectra and sections hold the LQR runs."""
        from trainctl.report import build_report_context, collect_report_data

        strategies = list(fast_run.scenario.simulation.strategies)
        assert {"lqr.centralised", "lqr.decentralised"} <= set(strategies)
        for name in ("lqr.centralised", "lqr.decentralised"):
            assert fast_run.tracking_ok(name)
            assert name in fast_run.format_text()
        data = collect_report_data(fast_run, scenario_text="")
        context = build_report_context(data, deterministic=True)
        for table in context["controllers"]["tables"]:  # metrics, solver, linear loops
            assert [row["cells"][0] for row in table["rows"]] == strategies, table["key"]
        assert {"LQR centralised", "LQR decentralised", "N-DMPC (Nash)"} <= set(data.spectra)
        assert "family-lqr" in [s["id"] for s in context["sections"]]
