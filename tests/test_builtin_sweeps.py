"""The built-in sweeps: their points as documented, and the N-DMPC convergence acceptance.

``crh2-dmpc-convergence-sweep`` sets the design check ``ndmpc_convergence``
(the certificate ρ(D0) < 1 of the unconstrained Jacobi iteration) against
what the simulated controller's iteration does within its iteration limit;
``heavy-haul-hinf-delay-sweep`` turns seed 003's case-(c) deviation ratio
into a distribution over network seeds for each delay bound (100 runs of
1800 s: only its points and one shortened point run here).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from trainctl.cli.main import main
from trainctl.run.pool import worker_pool
from trainctl.scenario import Scenario, load_scenario
from trainctl.sweep import METRICS, SweepDefinition, SweepPoint, point_rows, run_point, sweep_rows

README = Path(__file__).resolve().parents[1] / "analyses" / "README.md"
CRH2 = "crh2-dmpc-convergence-sweep"
HEAVY = "heavy-haul-hinf-delay-sweep"
R = "controller.r_per_kn2"
DT = "model.sample_time"
DELAY = "network.delay_range_s"
WEIGHTS = [0.05, 0.1, 0.3, 1.0]   # per kN², as the file and analyses/README.md say
SAMPLE_TIMES = [0.05, 0.1]        # s
BOUNDS = [0.0, 0.5, 1.0, 1.5, 2.0]  # s
SEEDS = list(range(3, 23))        # scenario seed 3, sweep seeds = 20


def sweep_of(scenario: Scenario) -> SweepDefinition:
    assert scenario.sweep is not None, f"{scenario.source} has no [sweep]"
    return scenario.sweep


class TestPoints:
    """Both built-ins validate into the points their comments and the README document."""

    def test_crh2_points(self, capsys: pytest.CaptureFixture[str]) -> None:
        """4 weights × 2 sample times, the weight slowest; every point validates."""
        scenario = load_scenario(CRH2)
        sweep = sweep_of(scenario)
        points = sweep.points(scenario.seed)
        assert sweep.keys == (R, DT)
        assert [(p[R], p[DT]) for p in points] == [(r, t) for r in WEIGHTS for t in SAMPLE_TIMES]
        scenarios = sweep.validate(scenario)
        assert [s.controller.input_weight for s in scenarios] == [p[R] for p in points]
        assert [s.model.sample_time for s in scenarios] == [p[DT] for p in points]
        assert main(["sweep", CRH2, "--dry-run"]) == 0
        out = capsys.readouterr().out
        assert "8 valid sweep points" in out
        assert "controller.r_per_kn2" in out and "model.sample_time" in out

    def test_heavy_haul_points(self, capsys: pytest.CaptureFixture[str]) -> None:
        """5 delay bounds × seeds 3..22, the seed fastest; one run per point, each with its
        delay-free baseline; the base point is the paper's case (c)."""
        scenario = load_scenario(HEAVY)
        case_c = load_scenario("heavy-haul-hinf-delay")
        sweep = sweep_of(scenario)
        points = sweep.points(scenario.seed)
        assert sweep.keys == (DELAY, "seed") and sweep.seeds == 20
        assert [(p[DELAY], p["seed"]) for p in points] == [
            ([0.0, d], s) for d in BOUNDS for s in SEEDS]
        assert scenario.network is not None and case_c.network is not None
        assert scenario.network.delay_bounds() == case_c.network.delay_bounds() == (0.0, 2.0)
        scenarios = sweep.validate(scenario)
        assert len(scenarios) == 100
        for point, s in zip(points, scenarios, strict=True):
            assert s.network is not None and s.simulation is not None
            assert s.network.delay_bounds() == (0.0, point[DELAY][1])
            assert s.seed == point["seed"]
            assert s.simulation.repetitions == 1
            assert s.simulation.baseline_network == "delay-free"
        assert main(["sweep", HEAVY, "--dry-run"]) == 0
        assert "100 valid sweep points" in capsys.readouterr().out

    def test_heavy_haul_is_case_c_but_for_the_repetitions(self) -> None:
        """Apart from the repetitions the base point is heavy-haul-hinf-delay's scenario."""
        base = load_scenario(HEAVY).replace("sweep", None)
        case_c = load_scenario("heavy-haul-hinf-delay")
        for key, value in (("name", case_c.name), ("description", case_c.description),
                           ("simulation.repetitions", 20)):
            base = base.replace(key, value)
        assert base.document == case_c.document

    def test_readme_lists_both(self) -> None:
        """analyses/README.md names both sweeps with their keys."""
        text = " ".join(README.read_text(encoding="utf-8").split())
        for name in (CRH2, HEAVY, R, DT, DELAY, "seeds = 20"):
            assert name in text


def test_zero_delay_point_has_ratio_one() -> None:
    """A point without delay, shortened to 30 s, is its own delay-free baseline: ratio 1.

    The sweep's ``metric.deviation_ratio`` pairs run 0 with the baseline run of the same
    seed; with delays drawn in [0, 0] s the two runs are the same run.
    """
    scenario = load_scenario(HEAVY)
    point = sweep_of(scenario).points(scenario.seed)[7]
    assert point[DELAY] == [0.0, 0.0] and point["seed"] == 10
    short = sweep_of(scenario).validate(scenario)[7]
    short = short.replace("simulation.settle_time", 15.0).replace("simulation.duration", 30.0)
    rows = point_rows(point, "k", run_point(short))
    assert [r["strategy"] for r in rows] == ["distributed", "synchronous.synchronous"]
    for row in rows:
        assert row["metric.deviation_ratio"] == pytest.approx(1.0, rel=1e-12)
        assert row["metric.converged"] is None and row["metric.iteration_limit_steps"] is None


@pytest.mark.parametrize(("base_seed", "base_rms", "ratio"), [
    (5, 0.004, 5.0), (6, 0.004, None), (5, 0.0, None)])
def test_deviation_ratio_pairs_run_0_with_its_seed(base_seed: int, base_rms: float,
                                                   ratio: float | None) -> None:
    """Vehicle 1's whole-run RMS error of run 0 over the baseline run with its seed."""
    def run(index: int, seed: int, rms: float) -> dict[str, Any]:
        return {"index": index, "seed": seed, "deviation": {"rms_error": [rms, 1.0]}}

    summary = {"simulations": {"distributed": {}},
               "repetitions": {"distributed": [run(0, 5, 0.02), run(1, 6, 0.5)]},
               "baseline_network": {"distributed": [run(-1, base_seed, base_rms)]}}
    (row,) = point_rows(SweepPoint(0, {}), "k", summary)
    assert row["metric.deviation_ratio"] == (None if ratio is None else pytest.approx(ratio))


def check(row: dict[str, Any], name: str) -> tuple[str, float]:
    return row[f"check.{name}.status"], row[f"check.{name}.value"]


Swept = tuple[list[SweepPoint], list[Scenario], list[dict[str, Any]]]


@pytest.fixture(scope="module")
def sweep() -> Swept:
    """The CRH2 convergence sweep run on 2 workers: its points, scenarios and rows."""
    scenario = load_scenario(CRH2)
    points = sweep_of(scenario).points(scenario.seed)
    scenarios = sweep_of(scenario).validate(scenario)
    with worker_pool(2) as pool:
        rows = sweep_rows(points, scenarios, executor=pool)
    return points, scenarios, rows


class TestConvergenceAcceptance:
    """Predicted against simulated: ρ(D0) < 1 exactly where the iteration converged."""

    def test_no_constraint_can_be_active(
        self, sweep: Swept) -> None:
        """Every point's QPs are unconstrained and its plant applies the forces as asked."""
        _, scenarios, rows = sweep
        for s in scenarios:
            ctl, sim = s.controller, s.simulation
            assert sim is not None and sim.strategies == ("ndmpc",)
            assert ctl.input_bounds is False
            assert math.isinf(ctl.rate_limit) and math.isinf(ctl.coupler_force_limit)
            assert sim.plant_saturation is False
        for row in rows:
            assert check(row, "rate_limit_conflict")[0] == "pass"
            assert check(row, "coupler_force_conflict")[0] == "pass"

    def test_certificate_predicts_the_iteration(
        self, sweep: Swept) -> None:
        """Both verdicts occur; ρ(D0) < 1: converged at every step within max_iterations
        (and the run tracks); ρ(D0) > 1: some step stopped at the limit unconverged."""
        points, scenarios, rows = sweep
        assert len(rows) == len(points) == 8
        assert {f"metric.{m}" for m in METRICS} <= set(rows[0])
        rhos = [check(row, "ndmpc_convergence")[1] for row in rows]
        assert min(rhos) < 1 < max(rhos)
        assert sum(rho < 1 for rho in rhos) >= 2 and sum(rho > 1 for rho in rhos) >= 2
        for point, s, row, rho in zip(points, scenarios, rows, rhos, strict=True):
            where = f"point {point.index} ({point.label()}, ρ(D0) = {rho:.3f})"
            assert row["strategy"] == "ndmpc", where
            assert row[R] == point[R] and row[DT] == point[DT], where
            assert check(row, "ndmpc_convergence")[0] == ("pass" if rho < 1 else "fail"), where
            limit = s.controller.max_iterations
            if rho < 1:
                assert row["metric.converged"] is True, where
                assert row["metric.iteration_limit_steps"] == 0, where
                assert row["metric.iterations_mean"] < limit, where
                assert row["metric.diverged"] is False, where
                assert row["metric.tracking_ok"] is True, where
            else:
                assert row["metric.converged"] is False, where
                assert row["metric.iteration_limit_steps"] >= 1, where

    def test_converging_points_stay_inside_the_envelope(
        self, sweep: Swept) -> None:
        """Run again with the plant saturating to the envelopes, the converging points are
        unchanged and never saturate: their forces never reached a traction or braking limit."""
        points, scenarios, rows = sweep
        converging = [(p, s, row) for p, s, row in zip(points, scenarios, rows, strict=True)
                      if row["metric.converged"]]
        assert converging
        with worker_pool(2) as pool:
            futures = [pool.submit(run_point, s.replace("simulation.plant_saturation", True))
                       for _, s, _ in converging]
            summaries = [f.result() for f in futures]
        for (point, _, row), summary in zip(converging, summaries, strict=True):
            assert not any(summary["simulations"]["ndmpc"]["saturation_time"]), point.index
            (again,) = point_rows(point, row["point_key"], summary)
            for name in ("rms_error", "max_error", "max_coupler_force", "iteration_limit_steps"):
                assert again[f"metric.{name}"] == row[f"metric.{name}"], (point.index, name)
