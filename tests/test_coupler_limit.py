# Tests of the couplers' admissible force: the file key, the metrics, --strict, text, JSON, report.
"""``[train.coupler] max_force_kn``: parsed to N, validated, judged on every simulated run."""

from __future__ import annotations

import json
import math
import re
import tomllib
from pathlib import Path
from types import SimpleNamespace

import jsonschema
import numpy as np
import pytest

from trainctl.cli.main import main
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.models.vehicle import Coupler
from trainctl.run.analysis import AnalysisRun, run_scenario
from trainctl.run.strict import STRICT_KINDS, strict_failures
from trainctl.scenario import json_schema, parse_scenario
from trainctl.sim import SimulationResult, compute_metrics

MASS = 40e3
"""Mass of each coach of the test train [kg] (``mass_t = 40.0``)."""
STIFFNESS = 1e7
"""Coupler stiffness k [N/m] (``stiffness_kn_per_m = 10000.0``)."""
DAMPING = 5e4
"""Coupler damping d [N·s/m] (``damping_kn_s_per_m = 50.0``)."""
JOLT = 1.0
"""The rear coach's speed above the head's at t = 0 [m/s]."""
FREE_PEAK = JOLT * math.sqrt(STIFFNESS * MASS / 2)
"""Peak |f| of two free 40 t masses on an undamped spring after a 1 m/s jolt [N]: the relative
motion has reduced mass μ = m/2 and ω = √(k/μ); δ = (w0/ω) sin ωt peaks at k·w0/ω = w0·√(kμ),
about 447 kN."""

JOLT_TRAIN = """\
schema_version = 1
name = "Two coaches, a coupler jolt"
description = "2 coaches, the rear one 1 m/s faster at t = 0, LQR for 2 s"
[[train.vehicle]]
mass_t = 40.0
count = 2
davis_si = [0.01, 0.0, 1e-5]
max_traction_kn = 80.0
max_braking_kn = 80.0
[train.coupler]
stiffness_kn_per_m = 10000.0
damping_kn_s_per_m = 50.0
LIMIT
[model]
speed_kmh = 90.0
sample_time = 0.05
[controller]
family = "lqr"
r_per_kn2 = 0.1
[simulation]
duration = 2.0
strategies = ["centralised"]
initial_speed_errors = [0.0, 1.0]
tracking_tolerance = 5.0
[simulation.reference]
times = [0.0]
speeds_kmh = [90.0]
"""
"""Every design check passes; the coupler's force peaks near FREE_PEAK within 0.1 s, before
the controller's 80 kN forces can do much about it."""


def jolt_train(limit: str = "") -> str:
    """The jolt scenario with ``limit`` (a line such as ``max_force_kn = 200.0``) in its coupler."""
    return JOLT_TRAIN.replace("LIMIT", limit)


def write(tmp_path: Path, text: str) -> str:
    path = tmp_path / "jolt.toml"
    path.write_text(text, encoding="utf-8")
    return str(path)


def fails(text: str, *fragments: str) -> str:
    """The ScenarioError message of ``text``, which must hold every fragment."""
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, source="t.toml")
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    return message


THREE_LINKS = """\
schema_version = 1
name = "Four coaches"
description = "4 coaches, one coupler per link"
[[train.vehicle]]
mass_t = 40.0
count = 4
davis_si = [0.01, 0.0, 1e-5]
[[train.coupler]]
stiffness_kn_per_m = 10000.0
max_force_kn = 2250.0
[[train.coupler]]
stiffness_kn_per_m = 10000.0
[[train.coupler]]
SECOND
[model]
speed_kmh = 90.0
sample_time = 0.05
"""


class TestScenarioKey:
    def test_kn_to_newtons_on_every_link(self) -> None:
        """2250 kN is 2 250 000 N, on each link of a single [train.coupler] table."""
        scenario = parse_scenario(jolt_train("max_force_kn = 2250.0"))
        assert [c.max_force for c in scenario.train.couplers] == [2_250_000.0]
        assert scenario.train.max_coupler_force.tolist() == [2_250_000.0]

    def test_omitted_is_no_limit(self) -> None:
        scenario = parse_scenario(jolt_train())
        assert scenario.train.couplers[0].max_force == math.inf

    def test_per_coupler(self) -> None:
        """[[train.coupler]]: the first link limited to 2250 kN, the second not, the third 12.5 kN
        (12 500 N)."""
        text = THREE_LINKS.replace("SECOND", "stiffness_kn_per_m = 10000.0\nmax_force_kn = 12.5")
        train = parse_scenario(text).train
        assert train.max_coupler_force.tolist() == [2.25e6, math.inf, 12_500.0]

    @pytest.mark.parametrize("value", ["0", "0.0", "-100.0", "inf", '"2250"', "true"])
    def test_bad_value_names_the_key(self, value: str) -> None:
        fails(jolt_train(f"max_force_kn = {value}"), "t.toml: ", "[train.coupler].max_force_kn",
              "must be", "> 0")

    def test_virtual_link_refuses_a_limit(self) -> None:
        text = jolt_train("max_force_kn = 100.0").replace(
            "stiffness_kn_per_m = 10000.0\ndamping_kn_s_per_m = 50.0", "virtual = true")
        message = fails(text, "[train.coupler].max_force_kn", "virtual", "got 100.0")
        assert "Remove max_force_kn" in message      # the hint

    def test_virtual_link_in_an_array_names_its_entry(self) -> None:
        text = THREE_LINKS.replace("SECOND", "virtual = true\nmax_force_kn = 100.0")
        fails(text, "[train.coupler][2].max_force_kn", "virtual")   # the third entry

    def test_cli_exit_2_names_the_key(self, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
        path = write(tmp_path, jolt_train("max_force_kn = -5.0"))
        assert main(["analyse", path, "--no-simulate"]) == 2
        err = capsys.readouterr().err
        assert err.startswith("trainctl: error: ") and "max_force_kn" in err
        assert "Traceback" not in err

    @pytest.mark.parametrize(("limit", "virtual", "valid"), [
        ("max_force_kn = 2250.0", False, True), ("", False, True), ("", True, True),
        ("max_force_kn = 0.0", False, False), ("max_force_kn = -1.0", False, False),
        ("max_force_kn = 100.0", True, False),
    ])
    def test_json_schema_agrees(self, limit: str, virtual: bool, valid: bool) -> None:
        """`trainctl schema` accepts and refuses what the parser does."""
        text = jolt_train(limit)
        if virtual:
            text = text.replace("stiffness_kn_per_m = 10000.0\ndamping_kn_s_per_m = 50.0",
                                "virtual = true")
        validator = jsonschema.Draft202012Validator(json_schema())
        errors = list(validator.iter_errors(tomllib.loads(text)))
        assert (errors == []) is valid, errors
        if valid:
            parse_scenario(text)
        else:
            with pytest.raises(ScenarioError, match="max_force_kn"):
                parse_scenario(text)

    def test_python_coupler_rules(self) -> None:
        assert Coupler(stiffness=STIFFNESS).max_force == math.inf
        with pytest.raises(ModelError, match="'max_force'"):
            Coupler(stiffness=STIFFNESS, max_force=0.0)
        with pytest.raises(ModelError, match="'max_force'"):
            Coupler(stiffness=STIFFNESS, max_force=-1.0)
        with pytest.raises(ModelError, match="virtual link.*'max_force'"):
            Coupler(stiffness=0.0, virtual=True, max_force=1e6)


def oscillation(points: int = 20_001
                ) -> tuple[SimulationResult, dict[str, float]]:
    """Two free 40 t coaches on an undamped 10 000 kN/m coupler, the rear 1 m/s faster at t = 0,
    over one period on a dense grid of ``points``; and the numbers by hand."""
    mu = MASS / 2
    omega = math.sqrt(STIFFNESS / mu)
    period = 2 * math.pi / omega
    t = np.linspace(0.0, period, points)
    delta = -(JOLT / omega) * np.sin(omega * t)          # the rear closes in: compression
    v_head = 25.0 + (JOLT / 2) * (1 - np.cos(omega * t))  # momentum: v_head + v_rear constant
    v_rear = 25.0 + JOLT - (JOLT / 2) * (1 - np.cos(omega * t))
    velocities = np.vstack([v_head, v_rear])
    states = np.vstack([velocities, delta, np.cumsum(v_head) * (t[1] - t[0])])
    samples = np.array([0, points - 1])
    result = SimulationResult(
        time=t[samples], states=states[:, samples], velocities=velocities[:, samples],
        coupler_forces=(STIFFNESS * delta)[None, samples], inputs=np.zeros((2, 1)),
        reference_speed=np.full(2, 25.0), reference_acceleration=np.zeros(2),
        statuses=("optimal",), iterations=np.array([1]), residuals=((),),
        solve_times=np.array([0.01]), fallbacks=("",), controller_name="free", seed=0,
        dt=period, dense_time=t, dense_states=states,
        dense_coupler_forces=(STIFFNESS * delta)[None, :],
        dense_reference_speed=np.full(points, 25.0))
    return result, {"peak": JOLT * math.sqrt(STIFFNESS * mu), "peak_time": period / 4,
                    "omega": omega}


class TestMetrics:
    def test_free_oscillation_over_a_limit(self) -> None:
        """|f| = P |sin ωt| is above L < P for (π - 2 arcsin(L/P)) / ω in each half period."""
        limit = 300e3
        result, hand = oscillation()
        m = compute_metrics(result, coupler_limits=[limit])
        peak, omega = hand["peak"], hand["omega"]
        assert peak == pytest.approx(447_214, rel=1e-5)          # √(1e7 · 2e4)
        assert m.coupler_peak_force[0] == pytest.approx(peak, rel=1e-7)
        assert m.coupler_peak_time[0] == pytest.approx(hand["peak_time"], rel=1e-3)
        assert m.coupler_ratio[0] == pytest.approx(peak / limit, rel=1e-7)
        above = 2 * (math.pi - 2 * math.asin(limit / peak)) / omega
        assert m.coupler_over_time[0] == pytest.approx(above, rel=1e-5)
        assert m.couplers_over_limit.tolist() == [0]
        verdict = m.coupler_verdict()
        assert verdict is not None and verdict["exceeded"] and verdict["coupler"] == 1
        assert verdict["limit"] == limit and verdict["couplers_over"] == [1]

    def test_free_oscillation_under_a_limit(self) -> None:
        result, hand = oscillation()
        m = compute_metrics(result, coupler_limits=[460e3])
        assert m.coupler_peak_force[0] < 460e3
        assert m.coupler_over_time[0] == 0.0 and m.couplers_over_limit.size == 0
        assert m.coupler_ratio[0] == pytest.approx(hand["peak"] / 460e3, rel=1e-7)
        verdict = m.coupler_verdict()
        assert verdict is not None and not verdict["exceeded"]

    def test_no_limit(self) -> None:
        result, hand = oscillation()
        m = compute_metrics(result)
        assert m.coupler_limit.tolist() == [math.inf] and m.coupler_verdict() is None
        assert m.coupler_peak_force[0] == pytest.approx(hand["peak"], rel=1e-7)
        assert m.to_dict()["coupler_limit"] == [None] and m.to_dict()["coupler_verdict"] is None

    def test_time_above_a_linear_ramp(self) -> None:
        """Linear f from -3 kN to 3 kN over 6 s against 2 kN: above for 1 s at each end."""
        t = np.array([0.0, 6.0])
        f = np.array([[-3000.0, 3000.0]])
        result = SimulationResult(
            time=t, states=np.array([[10.0, 10.0], [10.0, 10.0], [0.0, 0.0], [0.0, 60.0]]),
            velocities=np.full((2, 2), 10.0), coupler_forces=f, inputs=np.zeros((2, 1)),
            reference_speed=np.full(2, 10.0), reference_acceleration=np.zeros(2),
            statuses=("optimal",), iterations=np.array([1]), residuals=((),),
            solve_times=np.array([0.01]), fallbacks=("",), controller_name="ramp", seed=0,
            dt=6.0)
        m = compute_metrics(result, coupler_limits=[2000.0])
        assert m.coupler_over_time[0] == pytest.approx(2.0, rel=1e-12)
        assert m.coupler_peak_time[0] == 0.0                     # |−3 kN| first

    @pytest.mark.parametrize("limits", [[0.0], [-1.0], [1e3, 1e3], [math.nan], "x"])
    def test_bad_limits(self, limits: object) -> None:
        result, _ = oscillation(points=11)
        with pytest.raises(ModelError, match="'coupler_limits'"):
            compute_metrics(result, coupler_limits=limits)  # type: ignore[arg-type]


class TestStrictPolicy:
    @staticmethod
    def run_with(metrics: object) -> AnalysisRun:
        sim = SimpleNamespace(tracking_tolerance=1.0, settle_time=0.0,
                              max_saturation_time=math.inf)
        scenario = SimpleNamespace(simulation=sim, expected={})
        return AnalysisRun(scenario=scenario, design=None, summary=None,  # type: ignore[arg-type]
                           review=SimpleNamespace(checks=()),  # type: ignore[arg-type]
                           metrics={"ndmpc": metrics})  # type: ignore[dict-item]

    def test_kind_is_listed_before_expected(self) -> None:
        assert STRICT_KINDS.index("saturation") < STRICT_KINDS.index("coupler") \
            < STRICT_KINDS.index("expected")

    def test_worst_coupler_is_named(self) -> None:
        """Coupler 1 has no limit; coupler 2 is 20 % over 250 kN, coupler 3 10 % over 100 kN."""
        metrics = SimpleNamespace(
            max_error=np.zeros(4), coupler_peak_force=np.array([900e3, 300e3, 110e3]),
            coupler_limit=np.array([math.inf, 250e3, 100e3]),
            coupler_peak_time=np.array([1.0, 2.5, 3.0]), coupler_over_time=np.array([0, 0.4, 0.1]))
        failures = strict_failures(self.run_with(metrics))
        assert [(f.kind, f.name) for f in failures] == [("coupler", "ndmpc")]
        detail = failures[0].detail
        assert "2 coupler(s)" in detail and "coupler 2 at 300 kN, 20 % over its 250 kN" in detail
        assert "t = 2.5 s" in detail and "0.4 s" in detail

    @pytest.mark.parametrize("metrics", [
        SimpleNamespace(max_error=np.zeros(2), coupler_peak_force=np.array([250e3]),
                        coupler_limit=np.array([250e3])),       # at the limit: admissible
        SimpleNamespace(max_error=np.zeros(2), coupler_peak_force=np.array([9e9]),
                        coupler_limit=np.array([math.inf])),    # no limit
        SimpleNamespace(max_error=np.zeros(2)),                 # no record
    ])
    def test_no_reason(self, metrics: object) -> None:
        assert strict_failures(self.run_with(metrics)) == ()


def hand_forces(result: SimulationResult) -> np.ndarray:
    """Coupler forces f = k·δ + d·δ̇ from the dense states [v1, v2, δ, s], δ̇ = v1 - v2."""
    v1, v2, delta = result.dense_states[0], result.dense_states[1], result.dense_states[2]
    return STIFFNESS * delta + DAMPING * (v1 - v2)


@pytest.fixture(scope="module")
def jolt_run() -> AnalysisRun:
    """The jolt train simulated with a 200 kN limit."""
    return run_scenario(parse_scenario(jolt_train("max_force_kn = 200.0")))


class TestSimulatedRun:
    def test_peak_is_the_force_of_the_states(self, jolt_run: AnalysisRun) -> None:
        """The metrics' peak is max |k·δ + d·δ̇| on the dense grid, near the free jolt's."""
        result, m = jolt_run.simulations["centralised"], jolt_run.metrics["centralised"]
        f = np.abs(hand_forces(result))
        assert m.coupler_peak_force[0] == pytest.approx(f.max(), rel=1e-9)
        assert m.coupler_peak_time[0] == result.dense_time[np.argmax(f)]
        # Light damping (ζ ≈ 0.06) and 80 kN of control keep it within 20 % of the free peak.
        assert 0.8 * FREE_PEAK < f.max() < 1.2 * FREE_PEAK

    def test_flagged_over_200_kn(self, jolt_run: AnalysisRun) -> None:
        result, m = jolt_run.simulations["centralised"], jolt_run.metrics["centralised"]
        f = hand_forces(result)
        fine = np.linspace(result.dense_time[0], result.dense_time[-1], 400_001)
        above = np.mean(np.abs(np.interp(fine, result.dense_time, f)) > 200e3) * fine[-1]
        assert m.coupler_over_time[0] == pytest.approx(above, abs=1e-4)
        assert m.coupler_over_time[0] > 0
        kinds = [(f.kind, f.name) for f in jolt_run.strict_failures()]
        assert kinds == [("coupler", "centralised")]
        text = jolt_run.format_text()
        assert re.search(r"centralised: coupler 1 exceeded 200 kN by \d+ % at t = [\d.]+ s "
                         r"\(peak [\d.]+ kN\), above it for [\d.]+ s", text), text

    def test_cli_strict_over_the_limit_exits_1(self, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
        path = write(tmp_path, jolt_train("max_force_kn = 200.0"))
        assert main(["analyse", path, "--strict", "--json"]) == 1
        out, err = capsys.readouterr()
        data = json.loads(out[out.index("{"):])
        assert [(f["kind"], f["name"]) for f in data["strict_failures"]] == [
            ("coupler", "centralised")]
        verdict = data["simulations"]["centralised"]["coupler_verdict"]
        assert verdict["exceeded"] and verdict["coupler"] == 1 and verdict["limit"] == 200e3
        assert verdict["ratio"] > 0.8 * FREE_PEAK / 200e3
        assert "--strict: 1 reason: coupler centralised" in err

    def test_cli_strict_under_the_limit_exits_0(self, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
        path = write(tmp_path, jolt_train("max_force_kn = 2250.0"))
        assert main(["analyse", path, "--strict"]) == 0
        out = capsys.readouterr().out
        assert "centralised: coupler forces within their limits, the closest coupler 1 at" in out
        assert "of 2250 kN" in out and "(--strict exits 0)" in out

    def test_report_shows_the_verdict(self, jolt_run: AnalysisRun) -> None:
        from trainctl.report import build_report_context, collect_report_data, render_report

        data = collect_report_data(jolt_run, scenario_text=jolt_train("max_force_kn = 200.0"),
                                   command="trainctl report jolt.toml")
        html = render_report(build_report_context(data, generated_at="2025-01-01T00:00:00Z",
                                                  deterministic=True))
        assert "Coupler admissible force (max_force_kn)" in html
        assert re.search(r"Admissible force <span|Admissible force \[kN\]", html)
        assert re.search(r'<td class="num">200</td>', html)   # the scenario's coupler table
        assert re.search(r"exceeded: coupler 1 by [\d.]+ % of 200 kN at t = [\d.]+ s, for "
                         r"[\d.]+ s", html)
