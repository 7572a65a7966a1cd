"""Tests of the synchronous family (seed 003's centralised baseline): law, relay, checks, CLI."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import scipy.optimize

from tests.test_cli import assert_refused, run_module
from trainctl.controllers.base import Measurement, ReferencePreview
from trainctl.controllers.synchronous.law import law_of
from trainctl.controllers.synchronous.relay import RELAY_STREAM, relay_graph
from trainctl.controllers.synchronous.settings import SynchronousSettings
from trainctl.design import build_design
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.models.dynamics import train_rhs
from trainctl.registry import get_family
from trainctl.run.analysis import NETWORK_STREAM, simulate_strategy
from trainctl.scenario import Scenario, builtin_scenario_text, load_scenario
from trainctl.sim.results import SimulationResult

FAMILY = get_family("synchronous")


def _scenario(controller: dict[str, Any] | None = None, *,
              simulation: dict[str, Any] | None = None,
              network: dict[str, Any] | None = None) -> Scenario:
    """heavy-haul-hinf (4 locomotive subsystems of 5184 t) with family = "synchronous"."""
    sc = load_scenario("heavy-haul-hinf").replace(
        "controller", {"family": "synchronous", **(controller or {})})
    if network is not None:
        sc = sc.replace("network", network)
    if simulation is not None:
        sim = {"duration": 60.0, "strategies": ["synchronous"], "settle_time": 30.0,
               "reference": {"times": [0.0], "speeds_kmh": [70.0]}, "plant_saturation": False,
               **simulation}
        sc = sc.replace("simulation", sim)
    return sc


def _feedback(sc: Scenario, result: SimulationResult) -> np.ndarray:
    """Each vehicle's applied specific force minus its own resistance at its speed [m/s²], (n, N).

    The resistance is the Davis law per unit mass, computed here from the
    train's coefficients and the simulated sample speeds (the speeds the
    controller measured: no measurement noise in these runs).
    """
    train = sc.train
    v = np.asarray(result.velocities)[:, :-1]
    a0, a1, a2 = (c[:, None] for c in train.davis)
    return np.asarray(result.inputs) / train.mass[:, None] - (a0 + a1 * v + a2 * v * v)


# -- the linear closed loop ---------------------------------------------------------------------


def _controller_rhs(design: Any, xi: np.ndarray) -> np.ndarray:
    """x̂' of the nonlinear train under the controller's own step (instantaneous relay)."""
    train, n = design.scenario.train, design.law.n
    v_r = float(design.model.settings.speed)
    controller = FAMILY.make(design, "synchronous")
    controller.reset()
    preview = ReferencePreview(times=np.zeros(1), speed=np.full(1, v_r),
                               acceleration=np.zeros(1))
    u = controller.step(0.0, Measurement(outputs=v_r + xi[:n]), preview).inputs
    state = np.concatenate([v_r + xi[:n], xi[n:], [0.0]])
    return np.asarray(train_rhs(train, state, u)[:2 * n - 1])


@pytest.mark.parametrize(("name", "lead"), [("heavy-haul-hinf", 0),
                                            ("crh2-dmpc-well-sampled", 2)])
def test_linear_closed_loop_is_the_jacobian_of_the_nonlinear_one(name: str, lead: int) -> None:
    """A_cl equals a central finite-difference Jacobian of plant + controller at the cruise.

    heavy-haul-hinf: four equal subsystems led from the head; the CRH2 cars:
    unequal masses, led by the third car (a remote ahead of the lead too).
    """
    sc = load_scenario(name)
    settings = {"input_bounds": False, "lead": lead}
    sc = (sc.replace("controller", {"family": "synchronous", **settings})
          if sc.controllers == {} else sc.replace("controller.synchronous", settings))
    design = build_design(sc).family("synchronous")
    N = design.loops.A_cl.shape[0]
    n = design.law.n
    assert np.allclose(_controller_rhs(design, np.zeros(N)), 0.0, atol=1e-9)
    steps = np.where(np.arange(N) < n, 1e-4, 1e-7)
    J = np.empty((N, N))
    for k in range(N):
        e = np.zeros(N)
        e[k] = steps[k]
        J[:, k] = (_controller_rhs(design, e) - _controller_rhs(design, -e)) / (2 * steps[k])
    scale = np.abs(J).max(axis=0)
    assert np.allclose(J / scale, design.loops.A_cl / scale, atol=1e-6)
    # what the law adds to the plant: −κ v̂_lead on every speed row, the feedforward's slope
    kappa = sc.controllers["synchronous"].speed_gain
    davis, v_r = sc.train.davis, float(design.model.settings.speed)
    law_part = -kappa * np.outer(np.ones(n), np.eye(n)[lead]) + np.diag(davis[1] + 2 * davis[2]
                                                                        * v_r)
    assert np.allclose(J[:n, :n] - design.loops.A_open[:n, :n], law_part, atol=1e-6)
    assert np.allclose(J[:n, n:], design.loops.A_open[:n, n:], rtol=1e-6)
    loop = FAMILY.closed_loop(design, "synchronous")
    assert loop.dt == 0
    assert loop.input_labels == [f"w[{i}]" for i in range(n)]
    assert loop.output_labels[:n + 1] == [f"v[{i}]" for i in range(n)] + ["f[0]"]
    # matched as sets: sorting by real part first orders these lightly damped pairs by rounding
    poles, eigs = loop.poles(), np.linalg.eigvals(J)
    rows, cols = scipy.optimize.linear_sum_assignment(np.abs(poles[:, None] - eigs[None, :]))
    assert np.allclose(poles[rows], eigs[cols], atol=1e-6 * np.abs(J).max())


def test_delay_free_loop_is_hurwitz_and_the_rigid_mode_decays_at_kappa() -> None:
    """Equal subsystems: the rigid speed mode is −κ exactly; the coupler modes stay damped."""
    design = build_design(_scenario({"speed_gain_per_s": 0.2})).family("synchronous")
    lam = np.linalg.eigvals(design.loops.A_cl)
    assert np.max(lam.real) < 0
    assert np.min(np.abs(lam + 0.2)) < 1e-9
    check = {c.name: c for c in FAMILY.checks(design)}["synchronous_closed_loop"]
    assert check.status == "pass"
    assert check.value == pytest.approx(float(np.max(lam.real)))


# -- simulations on the nonlinear plant ---------------------------------------------------------


def test_tracks_a_speed_step_without_network() -> None:
    """Starting 0.5 m/s too fast: every subsystem's error decays as (1 − κT)^k, the rigid mode.

    The four subsystems are equal and start with the same error, so the
    couplers stay unloaded and the lead's sampled loop is the whole train's:
    v̂_{k+1} = (1 − κT) v̂_k up to the resistance's change within a sample.
    The plant saturates to the envelopes (the braking asked stays inside them).
    """
    sc = _scenario(simulation={"duration": 120.0, "settle_time": 60.0,
                               "initial_speed_error": 0.5, "plant_saturation": True})
    assert sc.network is None
    result = simulate_strategy(sc, "synchronous")
    err = np.asarray(result.velocities) - np.asarray(result.reference_speed)[None, :]
    kappa, T = 0.1, 0.1
    predicted = 0.5 * (1.0 - kappa * T) ** np.arange(err.shape[1])
    assert np.abs(err - predicted[None, :]).max() < 2e-3 * 0.5
    late = np.asarray(result.time) >= 60.0
    assert np.abs(err[:, late]).max() < 2e-3  # 0.5 e^{-6} = 1.2e-3 m/s
    assert abs(err[0, 0] - 0.5) < 1e-12
    assert int(np.count_nonzero(result.saturation)) == 0


def test_constant_delay_relays_the_lead_command_d_samples_late() -> None:
    """delay_s = 0.5 s = 5 samples: remote i applies m_i × the lead's command of step k − 5.

    Exact, from the applied forces (no saturation anywhere): a remote's force
    minus its resistance, per unit mass, is the lead's of five samples
    earlier; before the first arrival it is its resistance alone.
    """
    d = 5
    sim = {"initial_speed_error": -0.3,
           "reference": {"times": [0.0, 10.0, 20.0], "speeds_kmh": [70.0, 70.0, 72.0]}}
    sc = _scenario({"input_bounds": False}, simulation=sim, network={"delay_s": 0.5})
    result = simulate_strategy(sc, "synchronous")
    a = _feedback(sc, result)
    scale = np.abs(a).max()
    assert scale > 0.02  # the lead's command moves: the comparison can fail
    for i in (1, 2, 3):
        assert np.allclose(a[i, d:], a[0, :-d], rtol=0, atol=1e-9 * scale)
        assert np.allclose(a[i, :d], 0.0, atol=1e-9 * scale)
        # and not the undelayed command
        assert np.abs(a[i, d:] - a[0, d:]).max() > 1e-4


def test_interruption_holds_the_last_command_and_resumes() -> None:
    """Link lead → remote 3 (index 2) cut over [20, 40) s: remote 3 holds, the others follow.

    With no delay a remote applies the lead's command of the same sample;
    the cut remote keeps the command of t = 19.9 s (its force changes only
    with its own resistance) and follows again from t = 40 s.
    """
    sim = {"initial_speed_error": -0.3,
           "reference": {"times": [0.0, 25.0, 35.0], "speeds_kmh": [70.0, 70.0, 72.0]}}
    network = {"interruption": [{"start": 20.0, "end": 40.0, "links": [[2, 0]]}]}
    sc = _scenario({"input_bounds": False}, simulation=sim, network=network)
    result = simulate_strategy(sc, "synchronous")
    a = _feedback(sc, result)
    t = np.asarray(result.time)[:-1]
    window = (t >= 20.0 - 1e-9) & (t < 40.0 - 1e-9)
    before = int(np.flatnonzero(window)[0]) - 1
    after = ~window & (t > 20.0)
    scale = np.abs(a).max()
    assert np.ptp(a[0, window]) > 0.03  # the lead's command changes during the outage
    assert np.allclose(a[2, window], a[0, before], rtol=0, atol=1e-9 * scale)
    assert np.allclose(a[2, after], a[0, after], rtol=0, atol=1e-9 * scale)
    assert np.allclose(a[2, t < 20.0 - 1e-9], a[0, t < 20.0 - 1e-9], rtol=0, atol=1e-9 * scale)
    for i in (1, 3):
        assert np.allclose(a[i], a[0], rtol=0, atol=1e-9 * scale)
    # the held force is constant up to the remote's own resistance change
    v = np.asarray(result.velocities)[2, :-1][window]
    davis = sc.train.davis[:, 2]
    resistance = sc.train.mass[2] * (davis[0] + davis[1] * v + davis[2] * v * v)
    held = np.asarray(result.inputs)[2, window] - resistance
    assert np.ptp(held) < 1e-9 * np.abs(held).max()
    assert np.ptp(np.asarray(result.inputs)[2, window]) > 0  # its resistance did change


def test_same_seed_same_run_and_the_relay_has_its_own_stream() -> None:
    """Random delays, losses, noise and an outage: the same seed repeats the run exactly."""
    network = {"delay_range_s": [0.0, 2.0], "loss_probability": 0.2,
               "communication_noise_std": 0.002,
               "interruption": {"start": 10.0, "end": 15.0}}
    sim = {"duration": 30.0, "settle_time": 20.0, "initial_speed_error": -0.2,
           "measurement_noise": 0.01}
    sc = _scenario(simulation=sim, network=network)
    first, second = (simulate_strategy(sc, "synchronous") for _ in range(2))
    assert np.array_equal(first.inputs, second.inputs)
    assert np.array_equal(first.states, second.states)
    other = simulate_strategy(sc.replace("seed", 4), "synchronous")
    assert not np.array_equal(first.inputs, other.inputs)
    assert RELAY_STREAM != NETWORK_STREAM
    # the relay's first draws are those of SeedSequence([seed, RELAY_STREAM])
    design = build_design(sc).family("synchronous")
    relay = design.make_relay()
    expected = np.random.default_rng(np.random.SeedSequence([3, RELAY_STREAM])).random((3, 2))
    relay.relay(0.0, 0.01)
    log = relay.network.history()
    lo, hi = 0.0, 2.0
    assert np.allclose(log.delay, lo + (hi - lo) * expected[:, 0])
    assert log.receiver.tolist() == [1, 2, 3] and set(log.sender) == {0}


def test_relay_graph_is_a_star_from_the_lead() -> None:
    g = relay_graph(4, 1)
    assert g.adjacency.tolist() == [[0, 1, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0], [0, 1, 0, 0]]
    assert not np.any(g.pinning)


# -- the delay margin ---------------------------------------------------------------------------


def test_delay_margin_is_the_rigid_mode_closed_form() -> None:
    """κ = 0.1: the lead's undelayed share a = κ/4, the remotes' delayed b = 3κ/4 of the rigid mode.

    v̇ = −a v − b v(t − τ) loses stability at τ* = arccos(−a/b)/√(b² − a²);
    the stiff couplers move the full train's margin by well under 1 %.
    """
    design = build_design(_scenario()).family("synchronous")
    a, b = 0.1 / 4, 0.3 / 4
    closed_form = math.acos(-a / b) / math.sqrt(b * b - a * a)
    assert design.delay.margin == pytest.approx(closed_form, rel=0.01)
    assert design.delay.crossing_frequency == pytest.approx(math.sqrt(b * b - a * a), rel=0.01)
    assert design.delay.agree


@pytest.mark.parametrize(("hi", "status"), [(2.0, "pass"), (30.0, "fail"), (None, "warn")])
def test_delay_margin_check_against_the_network(hi: float | None, status: str) -> None:
    """heavy-haul-hinf, κ = 0.1: margin ≈ 27 s; GSM-R's 2 s passes, 30 s fails, none warns."""
    network = None if hi is None else {"delay_range_s": [0.0, hi]}
    design = build_design(_scenario(network=network)).family("synchronous")
    check = {c.name: c for c in FAMILY.checks(design)}["synchronous_delay_margin"]
    assert check.status == status, check.message
    assert 25.0 < check.value < 29.0
    assert check.threshold == hi
    if status == "fail":
        assert check.value <= hi


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_small_margin_fails_gsmr_and_is_confirmed_by_simulation() -> None:
    """κ = 1 1/s: a coupler mode crosses at about 0.19 s, so 2 s fails; simulated at T = 0.01 s,
    a 0.1 s delay decays and a 0.3 s delay grows (coupler forces over 150 s)."""
    controller = {"speed_gain_per_s": 1.0, "input_bounds": False, "control_interval": 0.01}
    design = build_design(_scenario(controller, network={"delay_range_s": [0.0, 2.0]})
                          ).family("synchronous")
    check = {c.name: c for c in FAMILY.checks(design)}["synchronous_delay_margin"]
    assert check.status == "fail"
    margin = check.value
    assert 0.15 < margin < 0.25
    assert check.details["crossing_frequency"] > 1.0  # a coupler mode, not the rigid one
    sim = {"duration": 150.0, "initial_speed_errors": [0.1, 0.0, 0.0, 0.0]}
    ratios = {}
    for tau in (0.1, 0.3):
        sc = _scenario(controller, simulation=sim, network={"delay_s": tau})
        result = simulate_strategy(sc, "synchronous")
        f, t = np.abs(np.asarray(result.coupler_forces)), np.asarray(result.time)
        ratios[tau] = f[:, t > 130.0].max() / f[:, t < 20.0].max()
    assert ratios[0.1] < 0.3 < 2.0 < ratios[0.3]


# -- checks, report, settings and the command line ----------------------------------------------


def test_sampling_check_and_report_table() -> None:
    """T = 0.1 s against the 4 rad/s coupler mode warns; 0.02 s passes. The report's rows."""
    design = build_design(_scenario(network={"delay_range_s": [0.0, 2.0]})).family("synchronous")
    checks = {c.name: c for c in FAMILY.checks(design)}
    assert tuple(checks) == FAMILY.check_names
    assert checks["synchronous_sampling"].status == "warn"
    fine = build_design(_scenario({"control_interval": 0.02})).family("synchronous")
    assert {c.name: c for c in FAMILY.checks(fine)}["synchronous_sampling"].status == "pass"
    data = FAMILY.report_data(design)
    json.dumps(data)
    rows = {r["name"]: r["value"] for r in data["rows"]}
    assert rows["Speed gain κ [1/s]"] == "0.1"
    assert rows["Lead locomotive"] == "vehicle 1"
    assert rows["Control interval [s]"] == "0.1"
    assert rows["Network worst-case delay [s]"] == "2"
    assert float(rows["Delay margin [s]"]) == pytest.approx(design.delay.margin, rel=1e-3)
    assert len(data["spectra"]["synchronous"]) == design.loops.A_cl.shape[0]


def test_report_page_has_the_family_section() -> None:
    """The rendered report carries the family's section with its quantity table."""
    from trainctl.report import build_report_context, collect_report_data, render_report
    from trainctl.run.analysis import run_scenario

    sc = _scenario(network={"delay_range_s": [0.0, 2.0]})
    run = run_scenario(sc, simulate=False)
    data = collect_report_data(run, scenario_text="", command="test")
    html = render_report(build_report_context(data, generated_at="2025-01-01T00:00:00Z",
                                              deterministic=True))
    assert FAMILY.title in html
    assert "Delay margin [s]" in html and "Network worst-case delay [s]" in html
    assert "lead locomotive (vehicle 1)" in html


def test_lead_is_checked_against_the_train() -> None:
    with pytest.raises(ScenarioError, match=r"lead.*from 0 to 3"):
        _scenario({"lead": 4})
    with pytest.raises(ScenarioError, match="lead must be a vehicle index from 0 to 3"):
        law_of(_scenario(), SynchronousSettings(lead=4))
    with pytest.raises(ModelError, match="lead"):
        SynchronousSettings(lead=-1)


def _file(tmp_path: Path, *lines: str) -> Path:
    text = builtin_scenario_text("heavy-haul-hinf")
    path = tmp_path / "sync.toml"
    path.write_text(text + "\n[controller]\nfamily = \"synchronous\"\n" + "\n".join(lines)
                    + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(("line", "match"), [
    ("speed_gain_per_s = -0.1", "speed_gain_per_s"),
    ("lead = 4", "lead"),
    ("lead = 0.5", "lead"),
    ("control_interval = 0.0", "control_interval"),
    ("speed_gain = 0.1", "speed_gain"),
])
def test_bad_settings_exit_2(tmp_path: Path, line: str, match: str,
                             capsys: pytest.CaptureFixture[str]) -> None:
    """A wrong [controller] value of the family is a clean scenario error (exit 2)."""
    assert_refused(_file(tmp_path, line), match, capsys)


def test_cli_analyse_json(tmp_path: Path) -> None:
    """`trainctl analyse FILE --json`: the three checks with their numbers, the frequency loop."""
    path = _file(tmp_path, "", "[network]", "delay_range_s = [0.0, 2.0]")
    result = run_module("analyse", str(path), "--json", "--no-simulate")
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    checks = {c["name"]: c for c in out["checks"]}
    assert checks["synchronous_closed_loop"]["status"] == "pass"
    assert checks["synchronous_sampling"]["status"] == "warn"
    margin = checks["synchronous_delay_margin"]
    assert margin["status"] == "pass" and margin["threshold"] == 2.0
    assert 25.0 < margin["value"] < 29.0
    assert "string_stability" in checks
    assert "synchronous" in out["frequency"]
