"""Tests of the design review and `trainctl analyse` as a design review."""

from __future__ import annotations

import functools
import json
import math
import re

import numpy as np
import pytest

from tests.test_analysis import crh2_design
from tests.test_seed003_cases import CASES as SEED003_CASES
from trainctl.cli.main import main
from trainctl.controllers.mpc.theory.dmpc import analyse_dmpc
from trainctl.controllers.mpc.theory.iteration import (
    iteration_matrices,
    spectral_radius,
    threshold_weight,
)
from trainctl.design.review import review_design
from trainctl.run.analysis import run_scenario
from trainctl.scenario import (
    builtin_scenario_text,
    builtin_scenarios,
    load_scenario,
    parse_scenario,
)


def book_text(controller_lines: dict[str, str]) -> str:
    """The crh2-dmpc built-in with some [controller] lines replaced and no [expected]."""
    text = builtin_scenario_text("crh2-dmpc").split("[expected]")[0]
    out = []
    for line in text.splitlines():
        key = line.split("=")[0].strip()
        out.append(f"{key} = {controller_lines.pop(key)}" if key in controller_lines else line)
    return "\n".join(out + [f"{k} = {v}" for k, v in controller_lines.items()]) + "\n"


@functools.cache
def unsimulated_run(name: str):
    """The built-in's run without simulations (its design review), once per process: the
    declared-status and the plausibility tests below read the same review."""
    return run_scenario(load_scenario(name), simulate=False)


class TestDeclaredExpectations:
    @pytest.mark.parametrize("name", [b.name for b in builtin_scenarios()])
    def test_every_check_has_the_status_its_scenario_declares(self, name):
        """Each built-in's [expected] table matches what the review finds."""
        run = unsimulated_run(name)
        assert run.unexpected_checks() == {}
        if name in SEED003_CASES:  # (moved here from tests/test_seed003_cases.py: one review)
            # each of seed 003's cases states an outcome for every check the review makes
            assert {c.name for c in run.review.checks} == set(run.scenario.expected)

    def test_well_sampled_variant_declares_every_check(self):
        """The well-sampled variant states an outcome for every check, all pass."""
        scenario = load_scenario("crh2-dmpc-well-sampled")
        checks = {c.name: c.status for c in review_design(scenario).checks}
        assert "string_stability" in checks
        assert set(scenario.expected) == set(checks)
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


@pytest.fixture(scope="module")
def analyse_output() -> str:
    """What ``trainctl analyse crh2-dmpc`` (simulations included) prints, run once."""
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["analyse", "crh2-dmpc"]) == 0
    return out.getvalue()


class TestCli:
    def test_analyse_prints_the_check_table(self, analyse_output):
        """The text output has every check with its status and hints."""
        out = analyse_output
        assert "Design checks:" in out and "ndmpc_convergence" in out and "hint:" in out

    def test_no_simulate_skips_the_runs(self, capsys, analyse_output):
        """--no-simulate prints the checks but no closed-loop table."""
        assert main(["analyse", "crh2-dmpc", "--no-simulate"]) == 0
        out = capsys.readouterr().out
        assert "Design checks:" in out and "Closed-loop simulations" not in out
        assert "Closed-loop simulations" in analyse_output

    def test_json_has_the_checks(self, capsys):
        """--json carries the same checks, statuses and hints."""
        assert main(["analyse", "crh2-dmpc", "--json", "--no-simulate"]) == 0
        data = json.loads(capsys.readouterr().out)
        by_name = {c["name"]: c for c in data["checks"]}
        assert by_name["sampling"]["status"] == "fail" and by_name["sampling"]["hint"]
        # T = 20 s: the middle coupler's peak gain (0.0155 m per m/s²) exceeds the first's
        assert data["failed_checks"] == ["sampling", "input_collapse", "string_stability"]


# -- feasibility where the train runs ------------------------------------------------------------
G = 9.81
KMH70 = 70 / 3.6

HEAVY_HAUL_RUN = """
[controller]
form = "u"
prediction_horizon = 20
control_horizon = 5
r_per_kn2 = 1e-4

[simulation]
duration = 1600.0
strategies = ["centralised"]

[simulation.reference]
times = [0.0]
speeds_kmh = [70.0]
"""
"""The issue's case: heavy-haul-hinf exported, a u-form [controller] with T = 0.5 s and a
1600 s [simulation] holding 70 km/h (down the -12 ‰ section from 20 km)."""


def heavy_haul_text() -> str:
    """`trainctl export heavy-haul-hinf` with T = 0.5 s, the controller and the 1600 s run."""
    text = builtin_scenario_text("heavy-haul-hinf").split("[expected]")[0].split("# What the")[0]
    text = text.replace("sample_time = 0.1 ", "sample_time = 0.5 ")
    assert "sample_time = 0.5 " in text
    return text + HEAVY_HAUL_RUN


def ning_davis_accel(v: float) -> float:
    """The built-in's mixed SS4B + C80 unit resistance at v [m/s], per unit mass [m/s²]."""
    kmh = v * 3.6
    return (0.967207 + 0.00530401 * kmh + 0.000131921 * kmh**2) * G / 1000


class TestFeasibility:
    def test_heavy_haul_down_grade_fails_naming_section_and_forces(self):
        """Holding 70 km/h on -12 ‰: 5184 t × (resistance + 9.98 sin θ) ≈ -519.8 kN vs 380 kN."""
        check = review_design(parse_scenario(heavy_haul_text())).check("feasibility")
        need = 5184e3 * (ning_davis_accel(KMH70) + 9.98 * math.sin(math.atan(-0.012))) / 1e3
        assert need == pytest.approx(-519.8, abs=0.05)
        assert check.status == "fail"
        assert "section 2 (from 20000 m, grade -12 ‰" in check.message
        assert f"vehicle 1 needs {abs(need):.1f} kN braking, 380.0 kN available" in check.message
        first = check.details["first"]
        assert first["section"] == 2 and first["grade_permille"] == -12.0
        assert [v["vehicle"] for v in first["vehicles"]] == [1, 2, 3, 4]
        # With 3 of 4 subsystems on the grade each needs 5184 t × (d + 3/4 grade) ≈ -365 kN,
        # still within 380 kN: the limit is crossed when the tail enters, 3 × 632.8 m later.
        tail_enters = (20000 + 3 * 632.8) / KMH70
        assert first["time"] == pytest.approx(tail_enters, abs=0.1)
        assert first["vehicles"][0]["required_kn"] == pytest.approx(need, rel=1e-6)

    def test_heavy_haul_strict_exits_1(self, capsys, tmp_path):
        """`analyse --strict` on the down-grade case exits 1 and names the feasibility check."""
        path = tmp_path / "hh.toml"
        path.write_text(heavy_haul_text(), encoding="utf-8")
        assert main(["analyse", str(path), "--strict", "--no-simulate"]) == 1
        out, err = capsys.readouterr()
        assert "check feasibility" in err
        assert re.search(r"^  feasibility +FAIL", out, re.MULTILINE)

    def test_equilibrium_judges_braking_too(self):
        """Down a steep grade the force is braking: feasible only if within the braking limit."""
        from trainctl.models import Coupler, TractionEnvelope, Train, Vehicle, equilibrium

        env = TractionEnvelope(max_traction=50e3, max_braking=10e3)
        car = Vehicle(mass=40e3, a0=0.01, a1=0.0, a2=0.0, envelope=env)
        train = Train(vehicles=(car, car), couplers=(Coupler(stiffness=1e7),))
        mild, steep = (equilibrium(train, 20.0, grade_permille=g) for g in (-10.0, -30.0))
        # per car: 40 t × (0.01 - grade·g/1000): -3.524 kN and -11.372 kN against 10 kN
        np.testing.assert_allclose(mild.inputs, 40e3 * (0.01 - 10 * G / 1000), rtol=1e-12)
        np.testing.assert_allclose(steep.inputs, 40e3 * (0.01 - 30 * G / 1000), rtol=1e-12)
        assert mild.feasible and not steep.feasible
        np.testing.assert_allclose(steep.braking_limit, 10e3)

    def test_crh2_potential_cruise_is_feasible(self):
        """6 motor cars × 1200 kW / 83.3 m/s = 86.4 kN cover 358.6 t × 0.18755 m/s² = 67.3 kN."""
        review = review_design(load_scenario("crh2-potential"))
        check = review.check("feasibility")
        v = 300 / 3.6
        need = 358.6e3 * (0.01176 + 0.00077616 * v + 1.6e-5 * v**2)
        assert check.status == "pass"
        assert check.value == pytest.approx(need / 6 / (1.2e6 / v), rel=1e-9)

    def test_crh2_potential_with_the_old_motor_arrangement_fails(self):
        """T-M-M-T-T-M-M-T (4 × 1200 kW) needs 16.8 kN per motor car against 14.4 kN."""
        scenario = load_scenario("crh2-potential")
        for i in (3, 4):   # coaches 4 and 5 back to trailers
            for key, value in (("name", "T"), ("traction_share", 0.0),
                               ("max_traction_kn", 0.0), ("max_power_kw", None),
                               ("max_braking_power_kw", None)):
                scenario = scenario.replace(f"train.vehicle[{i}].{key}", value)
        assert scenario.train.name == "T-M-M-T-T-M-M-T"
        check = review_design(scenario).check("feasibility")
        v = 300 / 3.6
        need = 358.6e3 * (0.01176 + 0.00077616 * v + 1.6e-5 * v**2) / 4 / 1e3
        assert check.status == "fail"
        assert f"vehicle 2 needs {need:.1f} kN traction, 14.4 kN available" in check.message
        assert "vehicle 4" not in check.message and "vehicle 6" in check.message

    def test_acceleration_phase_beyond_the_power_limit_is_found(self):
        """A 0.3 m/s² ramp meets the motor coaches' 1.2 MW where m(d(v) + a)/2 = P/v."""
        from scipy.optimize import brentq

        text = book_text({}).replace("speeds_kmh = [72.0, 72.0, 216.0, 288.0, 288.0]",
                                     "speeds_kmh = [72.0, 72.0, 288.0, 288.0, 288.0]")
        text = text.replace("times = [0.0, 60.0, 460.0, 1020.0, 1200.0]",
                            "times = [0.0, 60.0, 260.0, 1020.0, 1200.0]")
        check = review_design(parse_scenario(text)).check("feasibility")
        a0, a1, a2 = 0.8806 * G / 1000, 0.007444 * G / 1000 * 3.6, 0.0001143 * G / 1000 * 3.6**2
        mass = (42.8 + 48 + 46.5 + 42) * 1e3

        def margin(v):
            return mass * (a0 + a1 * v + a2 * v * v + 0.3) / 2 - min(80e3, 1.2e6 / v)

        v_star = brentq(margin, 20.0, 80.0)
        assert check.status == "fail"
        first = check.details["first"]
        assert first["acceleration"] == pytest.approx(0.3)
        # the review evaluates 2001 instants over 1200 s (0.6 s apart) plus the events
        assert first["time"] == pytest.approx(60 + (v_star - 20) / 0.3, abs=0.61)
        assert first["vehicles"][0]["vehicle"] == 2

    def test_reference_motion_integrates_the_speed(self):
        """Head position = area under the piecewise-linear reference (trapezoids by hand)."""
        from trainctl.analysis.feasibility import reference_motion

        sim = load_scenario("crh2-dmpc").simulation
        v, a, s = reference_motion(sim, np.array([60.0, 460.0, 1200.0]))
        np.testing.assert_allclose(v, [20, 60, 80])
        np.testing.assert_allclose(a, [0.1, 20 / 560, 0.0])
        np.testing.assert_allclose(s, [1200, 1200 + 400 * 40, 1200 + 16000 + 560 * 70 + 180 * 80])


# -- plausibility ---------------------------------------------------------------------------------
class TestPlausibility:
    @pytest.mark.parametrize("name", [b.name for b in builtin_scenarios()])
    def test_no_warning_on_any_builtin(self, name):
        """Every built-in's physical values are in their usual ranges."""
        check = unsimulated_run(name).review.check("plausibility")
        assert check.status == "pass", check.message

    @pytest.mark.parametrize(("key", "value", "expect"), [
        ("train.vehicle[0].mass_t", 42800.0, ["42800 t for one 25 m vehicle", "did you mean kg?",
                                              "(42800 kg = 42.8 t)"]),
        ("train.coupler.stiffness_kn_per_m", 10488000.0,
         ["stiffness_kn_per_m = 1.0488e+07", "did you mean N/m?", "= 10488 kN/m"]),
        ("train.coupler.max_force_kn", 2250000.0,
         ["max_force_kn = 2.25e+06", "did you mean N?", "= 2250 kN"]),
        ("train.vehicle[1].davis_si", [0.8806, 0.007444, 0.0001143],
         ["Give them as davis_n_per_kn_kmh"]),
        ("train.vehicle[1].max_power_kw", 1.2e6, ["did you mean W?"]),
        ("train.vehicle[1].max_traction_kn", 80000.0, ["did you mean N?"]),
        ("model.speed_kmh", 700.0, ["faster than any wheel–rail train"]),
    ])
    def test_each_unit_slip_is_named(self, key, value, expect):
        """Each slip warns, naming the value and the unit it was probably meant in."""
        scenario = load_scenario("crh2-dmpc").replace("expected", None).replace(key, value)
        check = review_design(scenario, ).check("plausibility")
        assert check.status == "warn"
        for text in expect:
            assert text in check.message
        assert check.value == 1.0

    def test_damping_slip_is_named(self):
        """500 kN·s/m typed as N·s/m (500000) on the heavy-haul couplers."""
        from trainctl.analysis.plausibility import plausibility_check

        scenario = load_scenario("heavy-haul-hinf").replace(
            "train.coupler.damping_kn_s_per_m", 500000.0)
        check = plausibility_check(scenario)
        assert check.status == "warn" and "couplers 1–3: damping_kn_s_per_m" in check.message
        assert "did you mean N·s/m? (500000 N·s/m = 500 kN·s/m)" in check.message

    @pytest.mark.parametrize(("key", "value", "expect"), [
        ("train.vehicle[1].max_traction_kn", 1e300, ["max_traction_kn = 1e+300 for one vehicle",
                                                     "usual 0–5000 kN"]),
        ("train.vehicle[1].max_traction_kn", 6000.0, ["max_traction_kn = 6000 for one vehicle"]),
        ("train.vehicle[1].adhesion", 5.0, ["adhesion = 5 ", "usual 0.01–0.5)"]),
        ("train.vehicle[1].adhesion", 0.6, ["adhesion = 0.6 "]),
        ("train.vehicle[0].length", 1e9, ["length = 1e+09 m for one vehicle"]),
        ("train.vehicle[0].length", 25000.0, ["length = 25000 m", "did you mean mm?"]),
        ("train.vehicle[0].length", 0.025, ["length = 0.025 m", "did you mean km?"]),
    ])
    def test_extremes_warn_once(self, key, value, expect):
        """Values no railway has, without a unit slip: one finding each, naming the key."""
        from trainctl.analysis.plausibility import plausibility_check

        scenario = load_scenario("crh2-dmpc").replace("expected", None).replace(key, value)
        check = plausibility_check(scenario)
        assert check.status == "warn"
        for text in expect:
            assert text in check.message, check.message
        assert check.value == 1.0, check.message

    def test_train_longer_than_any_run(self):
        """Vehicles of a usual length, but 2000 of them: a 50 km train warns once."""
        from trainctl.analysis.plausibility import plausibility_check

        scenario = load_scenario("crh2-dmpc").replace("expected", None).replace(
            "train.vehicle[0].count", 1997)
        check = plausibility_check(scenario)
        assert check.status == "warn" and check.value == 1.0, check.message
        assert check.message.startswith("the train is 50000 m long"), check.message

    def test_usual_extremes_pass(self):
        """Sanded rail (adhesion 0.5) and a 5 MN unit train are still plausible."""
        from trainctl.analysis.plausibility import plausibility_check

        scenario = load_scenario("heavy-haul-hinf").replace("expected", None)
        scenario = scenario.replace("train.vehicle[0].adhesion", 0.5).replace(
            "train.vehicle[0].max_traction_kn", 5000.0)
        check = plausibility_check(scenario)
        assert check.status == "pass", check.message

    def test_identical_vehicles_are_grouped(self):
        """Four unit trains with the same slip make one finding for vehicles 1–4."""
        scenario = load_scenario("heavy-haul-hinf").replace("train.vehicle[0].mass_t", 518400.0)
        check = review_design(scenario).check("plausibility")
        assert check.message.startswith("vehicles 1–4: mass_t = 518400")


# -- the MPC family's review()-grade checks --------------------------------------------------------
def well_sampled(**changes: object):
    """crh2-dmpc-well-sampled without [expected], with [controller] keys changed."""
    scenario = load_scenario("crh2-dmpc-well-sampled").replace("expected", None)
    for key, value in changes.items():
        scenario = scenario.replace(f"controller.{key}", value)
    return scenario


def unconstrained_centralised_loop(design):
    """u-form centralised closed loop, built column by column by simulating unit moves."""
    A, B, C = design.A, design.B, design.C
    P, M = design.prediction_horizon, design.control_horizon
    nx, nu = B.shape
    ny = C.shape[0]
    G = np.zeros((P * ny, M * nu))
    Phi = np.zeros((P * ny, nx))
    for col in range(M * nu):          # response to one unit decision variable
        x = np.zeros(nx)
        for step in range(P):
            u = np.zeros(nu)
            u[col % nu] = 1.0 if min(step, M - 1) == col // nu else 0.0
            x = A @ x + B @ u
            G[step * ny:(step + 1) * ny, col] = C @ x
    x = np.eye(nx)
    for step in range(P):
        x = A @ x
        Phi[step * ny:(step + 1) * ny] = C @ x
    Q = np.diag(np.tile(design.q, P))
    H = G.T @ Q @ G + np.diag(np.tile(design.r, M))
    K = np.linalg.solve(H, G.T @ Q @ Phi)[:nu]
    return A - B @ K, H


class TestMPCReviewChecks:
    def test_short_horizon_fails_with_the_numbers(self):
        """T = 0.05 s, P = 4: P·T = 0.2 s against the closed-loop speed time constant."""
        from trainctl.design import build_design

        scenario = well_sampled(coupler_force_steps=None, control_horizon=2, prediction_horizon=4)
        check = review_design(scenario).check("prediction_horizon")
        A_cl, _ = unconstrained_centralised_loop(build_design(scenario).families["mpc"].mpc)
        lam, vec = np.linalg.eig(A_cl)
        rigid = np.argmax(np.abs(vec[:4].sum(axis=0)) / np.linalg.norm(vec, axis=0))
        tau = -0.05 / math.log(abs(lam[rigid]))
        assert check.status == "fail"
        assert check.value == pytest.approx(0.2 / tau, rel=1e-6)
        assert check.details["tau_s"] == pytest.approx(tau, rel=1e-6) and tau > 100
        assert "P·T = 4 × 0.05 s = 0.2 s" in check.message and "lengthen" in check.hint

    def test_qp_hessian_condition_number(self):
        """cond(GᵀQG + R) equals the one of an independently built Hessian; tiny R warns."""
        from trainctl.design import build_design

        scenario = load_scenario("crh2-dmpc-well-sampled")
        check = review_design(scenario).check("qp_conditioning")
        _, H = unconstrained_centralised_loop(build_design(scenario).families["mpc"].mpc)
        assert check.status == "pass"
        assert check.value == pytest.approx(np.linalg.cond(H), rel=1e-8)
        tiny = review_design(parse_scenario(book_text({"r_per_kn2": "1e-9"})))
        bad = tiny.check("qp_conditioning")
        assert bad.status == "warn" and bad.value > 1e6 and "raise R" in bad.hint

    def test_rate_limit_below_the_feedforward_jump_warns(self):
        """At t = 60 s the reference's 0.1 m/s² starts: the motor coaches' force jumps by
        179.3 t × 0.1 m/s² / 2 = 8.965 kN in one sample, above a 0.2 kN rate limit."""
        check = review_design(well_sampled(rate_limit_kn=0.2)).check(
            "rate_limit_conflict")
        assert check.status == "warn"
        assert check.details["jump"]["kn"] == pytest.approx(179.3 * 0.1 / 2, rel=2e-3)
        assert check.details["jump"]["vehicle"] == 2
        assert check.details["jump"]["time"] == pytest.approx(59.95)

    def test_rate_limit_below_the_steady_ramp_fails(self):
        """On the 0.1 m/s² ramp the force grows by m (a1 + 2 a2 v) a T / 2 per sample."""
        check = review_design(well_sampled(rate_limit_kn=0.0005)).check(
            "rate_limit_conflict")
        a1, a2 = 0.007444 * G / 1000 * 3.6, 0.0001143 * G / 1000 * 3.6**2
        ramp = 179.3e3 * (a1 + 2 * a2 * 60.0) * 0.1 * 0.05 / 2 / 1e3
        assert check.status == "fail"
        assert check.details["steady"]["kn"] == pytest.approx(ramp, rel=1e-3)

    def test_coupler_bound_below_the_static_forces_fails(self):
        """Before 460 s (60 m/s, 0.1 m/s²) the head trailer pulls f1 = 42.8 t × (d + a)."""
        check = review_design(well_sampled(coupler_force_limit_kn=5.0)).check(
            "coupler_force_conflict")
        a0, a1, a2 = 0.8806 * G / 1000, 0.007444 * G / 1000 * 3.6, 0.0001143 * G / 1000 * 3.6**2
        f1 = 42.8 * (a0 + a1 * 60 + a2 * 3600 + 0.1)
        assert check.status == "fail"
        assert check.value == pytest.approx(f1, rel=1e-6)
        assert check.details["coupler"] == 1
        ok = review_design(load_scenario("crh2-dmpc-well-sampled")).check(
            "coupler_force_conflict")
        assert ok.status == "pass" and ok.value == pytest.approx(f1, rel=1e-6)


# -- API edges ---------------------------------------------------------------------------------
class TestReviewAPI:
    def test_unknown_check_raises_trainctl_error_with_suggestion(self):
        """check('sampling_time') lists the checks and suggests 'sampling'; also a KeyError."""
        import trainctl
        from trainctl.exceptions import UnknownNameError

        review = review_design(load_scenario("crh2-potential"))
        with pytest.raises(UnknownNameError, match=r"Did you mean 'sampling'\?") as err:
            review.check("sampling_time")
        assert isinstance(err.value, KeyError) and isinstance(err.value, trainctl.TrainctlError)
        assert str(err.value).startswith("the review of ")
        assert "Checks: open_loop_stability, controllability" in str(err.value)
        with pytest.raises(KeyError):
            review.check("nope")

    def test_observability_has_its_own_result(self):
        """A hand-made pair: x2 never reaches the output, so eigenvalue -2 is unobservable."""
        import control as ct

        from trainctl.analysis import ObservabilityResult, analyse_observability

        sys = ct.ss([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [1.0]], [[1.0, 0.0]], 0,
                    states=["x1", "x2"])
        res = analyse_observability(sys)
        assert isinstance(res, ObservabilityResult) and res.kind == "observability"
        assert res.rank == np.linalg.matrix_rank(ct.obsv(sys.A, sys.C)) == 1
        assert [m.eigenvalue for m in res.unobservable] == [-2.0]
        assert res.unobservable[0].direction == {"x2": 1.0}
        data = res.to_dict()
        assert data["kind"] == "observability" and "unobservable" in data
        assert "uncontrollable" not in data and "unobservable mode" in res._repr_html_()

    def test_sampling_hint_uses_the_pass_threshold(self):
        """The T the hint quotes passes the sampling check; the book's T fails it."""
        import re

        book = load_scenario("crh2-dmpc")
        hint = review_design(book).check("sampling").hint
        quoted = float(re.search(r"T < ([0-9.]+) s", hint).group(1))
        fixed = book.replace("simulation", None).replace("expected", None).replace(
            "model.sample_time", quoted)
        check = review_design(fixed).check("sampling")
        assert check.status == "pass" and check.value < math.pi / 2
        just_above = fixed.replace("model.sample_time", quoted * 1.002)
        assert review_design(just_above).check("sampling").status == "warn"


def test_a_failing_rank_check_names_a_few_modes_and_keeps_all_in_details():
    """12 virtually coupled trains, no controller: 11 unobservable gaps; 4 named, 11 stored."""
    text = builtin_scenario_text("heavy-haul-flocking").split("\n[controller")[0]
    text = re.sub(r"^count = 4 ", "count = 12 ", text, count=1, flags=re.M)
    text = re.sub(r"^initial_(speed|spacing)_errors\s*=.*$", "", text, flags=re.M)
    review = review_design(parse_scenario(text))
    check = review.check("observability")
    assert check.status == "fail"
    assert check.message.count("δ") == 4 and "(11 modes in all)" in check.message
    assert len(check.details["unobservable"]) == 11


@pytest.mark.slow
def test_heavy_haul_down_grade_run_records_braking_saturation():
    """The same case, grade moved to 1 km, 400 s, a tight tuning: braking saturates.

    The review says the subsystems need about 520 kN of braking against 380 kN once the
    whole train is on the -12 ‰ section. With the issue's weight (R = 1e-4 per kN²,
    a 10 s horizon) the MPC brakes too gently to reach the limit and settles at a
    24 m/s error; with R = 1e-7 it asks for all the braking there is. The run's
    saturation record must show braking saturation of every subsystem, first after the
    head reached the grade (t > 1000 m / 70 km/h ≈ 51 s), and no traction saturation.
    """
    from trainctl.run.analysis import simulate_strategy
    from trainctl.sim.metrics import compute_metrics

    text = heavy_haul_text().replace("start = 20000.0 ", "start = 1000.0 ")
    text = text.replace("duration = 1600.0", "duration = 400.0")
    text = text.replace("r_per_kn2 = 1e-4", "r_per_kn2 = 1e-7")
    assert "start = 1000.0 " in text and "duration = 400.0" in text and "1e-7" in text
    scenario = parse_scenario(text)
    assert review_design(scenario).check("feasibility").status == "fail"
    metrics = compute_metrics(simulate_strategy(scenario, "centralised"))
    assert np.all(metrics.braking_saturation_time > 0.0)
    assert np.array_equal(metrics.saturation_time, metrics.braking_saturation_time)
    assert np.all(metrics.first_saturation_time > 1000.0 / KMH70)
