"""Tests of the design review and `trainctl analyse` as a design review."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from trainctl.analysis.dmpc import analyse_dmpc
from trainctl.analysis.iteration import iteration_matrices, spectral_radius, threshold_weight
from trainctl.analysis.review import review_design
from trainctl.cli import main
from trainctl.run import run_scenario
from trainctl.scenario import (
    builtin_scenario_text,
    builtin_scenarios,
    load_scenario,
    parse_scenario,
)

from .test_analysis import crh2_design


def book_text(controller_lines: dict[str, str]) -> str:
    """The crh2-dmpc built-in with some [controller] lines replaced and no [expected]."""
    text = builtin_scenario_text("crh2-dmpc").split("[expected]")[0]
    out = []
    for line in text.splitlines():
        key = line.split("=")[0].strip()
        out.append(f"{key} = {controller_lines.pop(key)}" if key in controller_lines else line)
    return "\n".join(out + [f"{k} = {v}" for k, v in controller_lines.items()]) + "\n"


class TestDeclaredExpectations:
    @pytest.mark.parametrize("name", [b.name for b in builtin_scenarios()])
    def test_every_check_has_the_status_its_scenario_declares(self, name):
        """Each built-in's [expected] table matches what the review finds."""
        run = run_scenario(load_scenario(name), simulate=False)
        assert run.unexpected_checks() == {}

    def test_well_sampled_variant_declares_every_check(self):
        """The well-sampled variant states an outcome for all twelve checks, all pass."""
        scenario = load_scenario("crh2-dmpc-well-sampled")
        names = {c.name for c in review_design(scenario).checks}
        assert set(scenario.expected) == names
        assert set(scenario.expected.values()) == {"pass"}


class TestBookSettings:
    def test_aliasing_is_flagged_with_the_numbers(self):
        """T = 20 s: sampling fails with ω_max·T ≈ 555 rad against π, hint gives a T."""
        check = review_design(load_scenario("crh2-dmpc")).check("sampling")
        assert check.status == "fail"
        assert check.value == pytest.approx(27.7699 * 20, rel=1e-5)
        assert check.threshold == pytest.approx(math.pi)
        assert "T < 0.0565 s" in check.hint and "555" in check.message

    def test_rho_r_star_and_closed_loop_radius_are_reported(self):
        """ρ(D0), R* and the closed-loop radius equal an independently built design's."""
        review = review_design(load_scenario("crh2-dmpc"))
        d = crh2_design(20.0, form="du", r=10.0)
        D0, _ = iteration_matrices(d)
        conv = review.check("ndmpc_convergence")
        assert conv.value == pytest.approx(spectral_radius(D0), rel=1e-10)
        assert conv.details["R_star"] == pytest.approx(threshold_weight(d), rel=1e-5)
        assert f"{threshold_weight(d):.4g} per kN²" in conv.message
        nash = review.check("closed_loop_nash")
        assert nash.value == pytest.approx(1.0, abs=1e-9)
        assert len(nash.details["unit_circle"]) == 3
        assert "internal-force" in nash.hint

    def test_diverging_iteration_gets_r_star_and_relaxation_hint(self):
        """R below R*: convergence fails, the hint names R* and a relaxation bound."""
        review = review_design(parse_scenario(book_text({"r_per_kn2": "1.0"})))
        conv = review.check("ndmpc_convergence")
        assert conv.status == "fail" and conv.value > 1
        assert "raise R above R* = 2.253 per kN²" in conv.hint and "relax with ω ≤" in conv.hint
        assert review.check("relaxation").status == "warn"

    def test_no_relaxation_for_tiny_weight(self):
        """R = 1e-6 per kN² at T = 20 s: an eigenvalue of D0 crosses Re = 1."""
        review = review_design(parse_scenario(book_text({"r_per_kn2": "1e-6"})))
        assert review.check("relaxation").status == "fail"
        assert "no relaxation exists" in review.check("relaxation").message
        assert "no relaxation factor helps" in review.check("ndmpc_convergence").hint

    def test_threshold_is_quoted_in_the_scenario_unit(self):
        """With r_per_n2 the same design reports R* per N² (= per kN² × 1e-6)."""
        text = book_text({"r_per_kn2": "1.0"}).replace("r_per_kn2 = 1.0", "r_per_n2 = 1e-6")
        conv = review_design(parse_scenario(text)).check("ndmpc_convergence")
        r_star_kn = threshold_weight(crh2_design(20.0, form="du", r=1.0))
        assert conv.details["R_star"] == pytest.approx(r_star_kn * 1e-6, rel=1e-5)
        assert "per N²" in conv.hint


class TestDMPCAnalysis:
    def test_result_is_serialisable_and_consistent(self):
        """to_dict is JSON-safe and its radii equal the matrices' spectral radii."""
        res = analyse_dmpc(crh2_design(1.0, form="u", r=0.01), iterations=3)
        data = json.loads(json.dumps(res.to_dict()))
        assert data["rho_d0"] == pytest.approx(res.rho_d0)
        radius = float(np.max(np.abs(np.linalg.eigvals(res.closed_loop_nash))))
        assert data["closed_loop_radius"]["nash"] == pytest.approx(radius)
        assert "ρ(D0)" in res._repr_html_()


class TestCli:
    def test_analyse_prints_the_check_table(self, capsys):
        """The text output has every check with its status and hints."""
        assert main(["analyse", "crh2-dmpc"]) == 0
        out = capsys.readouterr().out
        assert "Design checks:" in out and "ndmpc_convergence" in out and "hint:" in out

    def test_no_simulate_skips_the_runs(self, capsys):
        """--no-simulate prints the checks but no closed-loop table."""
        assert main(["analyse", "crh2-dmpc", "--no-simulate"]) == 0
        out = capsys.readouterr().out
        assert "Design checks:" in out and "Closed-loop simulations" not in out
        assert main(["analyse", "crh2-dmpc"]) == 0
        assert "Closed-loop simulations" in capsys.readouterr().out

    def test_json_has_the_checks(self, capsys):
        """--json carries the same checks, statuses and hints."""
        assert main(["analyse", "crh2-dmpc", "--json", "--no-simulate"]) == 0
        data = json.loads(capsys.readouterr().out)
        by_name = {c["name"]: c for c in data["checks"]}
        assert by_name["sampling"]["status"] == "fail" and by_name["sampling"]["hint"]
        assert data["failed_checks"] == ["sampling", "input_collapse"]
