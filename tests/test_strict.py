"""Tests of `--strict`: the policy in trainctl.run.strict, its report in analyse text and JSON."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from trainctl.cli.main import main
from trainctl.run.analysis import AnalysisRun, run_scenario
from trainctl.run.strict import strict_failures
from trainctl.scenario import builtin_scenario_text, load_scenario

TIGHT_TRACKING = """
schema_version = 1
name = "Two coaches, tight tolerance"
description = "2 coaches, u-form MPC, a 1 m/s initial error judged against 1 cm/s"
[[train.vehicle]]
mass_t = 40.0
count = 2
davis_si = [0.01, 0.0, 1e-5]
max_traction_kn = 80.0
max_braking_kn = 80.0
[train.coupler]
stiffness_kn_per_m = 10000.0
[model]
speed_kmh = 90.0
sample_time = 0.05
[controller]
form = "u"
prediction_horizon = 40
control_horizon = 5
r_per_kn2 = 0.1
[simulation]
duration = 5.0
strategies = ["centralised"]
initial_speed_error = 1.0
tracking_tolerance = 0.01
[simulation.reference]
times = [0.0]
speeds_kmh = [90.0]
"""
"""Every design check passes; the speed error starts at 1 m/s and the tolerance is 0.01 m/s."""


def write(tmp_path: Path, text: str, name: str = "s.toml") -> str:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return str(path)


def analyse_json(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, dict, str]:
    """Exit status, JSON document and stderr of ``analyse --json``.

    The JSON document is read from its first line ("{"): until solver chatter is silenced
    at the source, OSQP may print "Polishing not needed" lines before it.
    """
    code = main(["analyse", *args, "--json"])
    out, err = capsys.readouterr()
    return code, json.loads(out[out.index("{\n"):] if not out.startswith("{") else out), err


class TestStrictExitStatus:
    def test_failed_check_exits_1(self, capsys):
        """The book's T = 20 s fails sampling, input_collapse and string_stability."""
        code, data, err = analyse_json(["crh2-dmpc", "--strict", "--no-simulate"], capsys)
        assert code == 1
        assert [(f["kind"], f["name"]) for f in data["strict_failures"]] == [
            ("check", "sampling"), ("check", "input_collapse"), ("check", "string_stability")]
        assert ("--strict: 3 reasons: check sampling; check input_collapse; "
                "check string_stability") in err

    def test_missed_tracking_exits_1_with_every_check_passing(self, capsys, tmp_path):
        """A 1 m/s initial error against a 0.01 m/s tolerance: one 'tracking' reason."""
        path = write(tmp_path, TIGHT_TRACKING)
        code, data, err = analyse_json([path, "--strict"], capsys)
        assert code == 1
        assert data["failed_checks"] == []
        assert [(f["kind"], f["name"]) for f in data["strict_failures"]] == [
            ("tracking", "centralised")]
        error = data["simulations"]["centralised"]["max_error"]
        assert max(error) > 0.01 and "tracking centralised" in err
        assert main(["analyse", path]) == 0          # without --strict: exit 0

    def test_heavy_coach_misses_tracking(self, capsys, tmp_path):
        """The issue's slip: a 480 t coach cannot follow the book's ramp (about 35 m/s off)."""
        scenario = (load_scenario("crh2-dmpc").replace("expected", None)
                    .replace("simulation.strategies", ["centralised"]))
        run = run_scenario(scenario.replace("train.vehicle[0].mass_t", 480.0))
        reasons = {f.kind: f for f in run.strict_failures()}
        assert "tracking" in reasons and "feasibility" in {
            f.name for f in run.strict_failures() if f.kind == "check"}
        assert float(np.max(run.metrics["centralised"].max_error)) > 30
        assert "exceeds the tracking_tolerance 1 m/s" in reasons["tracking"].detail

    def test_expected_mismatch_exits_1_and_is_shown(self, capsys, tmp_path):
        """Declaring sampling = "fail" on the well-sampled design: one 'expected' reason."""
        text = builtin_scenario_text("crh2-dmpc-well-sampled").replace(
            'sampling = "pass" ', 'sampling = "fail" ')
        path = write(tmp_path, text)
        code, data, err = analyse_json([path, "--strict", "--no-simulate"], capsys)
        assert code == 1
        assert data["unexpected_checks"] == {"sampling": {"expected": "fail", "found": "pass"}}
        assert [(f["kind"], f["name"]) for f in data["strict_failures"]] == [
            ("expected", "sampling")]
        assert "expected sampling" in err
        assert main(["analyse", path, "--no-simulate"]) == 0
        out = capsys.readouterr().out
        assert "1 of 21 declared statuses differ:\n  sampling: expected FAIL, found PASS" in out
        assert "Strict: 1 reason --strict exits 1 for:" in out

    def test_well_sampled_is_strict_clean(self, capsys):
        """crh2-dmpc-well-sampled: every check passes as declared, --strict exits 0."""
        code, data, err = analyse_json(["crh2-dmpc-well-sampled", "--strict", "--no-simulate"],
                                       capsys)
        assert code == 0 and data["strict_failures"] == [] and data["unexpected_checks"] == {}
        assert err == ""
        assert main(["analyse", "crh2-dmpc-well-sampled", "--no-simulate"]) == 0
        out = capsys.readouterr().out
        assert "all 21 declared statuses match" in out and "(--strict exits 0)" in out


class TestSaturationPolicy:
    @staticmethod
    def run_with(seconds, limit):
        """A run whose metrics record per-vehicle saturation seconds (a stand-in)."""
        sim = SimpleNamespace(tracking_tolerance=1.0, settle_time=0.0, max_saturation_time=limit)
        scenario = SimpleNamespace(simulation=sim, expected={})
        metrics = SimpleNamespace(max_error=np.zeros(3), saturation_time=seconds)
        review = SimpleNamespace(checks=())
        return AnalysisRun(scenario=scenario, design=None, summary=None, review=review,
                           metrics={"ndmpc": metrics})

    def test_vehicle_saturated_too_long_is_a_reason(self):
        """Vehicles 2 and 3 saturated 12 s and 30 s against 10 s allowed: one reason, vehicle 3."""
        failures = strict_failures(self.run_with([0.0, 12.0, 30.0], 10.0))
        assert [(f.kind, f.name) for f in failures] == [("saturation", "ndmpc")]
        assert "2 vehicle(s)" in failures[0].detail and "vehicle 3 for 30 s" in failures[0].detail

    @pytest.mark.parametrize(("seconds", "limit"), [
        ([0.0, 5.0, 10.0], 10.0),      # within the limit
        ([0.0, 50.0, 10.0], None),     # no limit declared
        (None, 10.0),                  # metrics without a saturation record
        ("not a record", 10.0),
    ])
    def test_no_reason_without_a_violation_or_record(self, seconds, limit):
        """Nothing to judge, or nothing over the limit: no saturation reason."""
        assert strict_failures(self.run_with(seconds, limit)) == ()
