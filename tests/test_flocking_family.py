"""Tests of the flocking family (seed 002): linearisation, energy, certificate, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.test_cli import run_module
from trainctl.controllers.flocking.checks import trajectory_gaps
from trainctl.controllers.flocking.settings import FlockingSettings
from trainctl.design import build_design
from trainctl.design.review import review_design
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.models.dynamics import train_rhs
from trainctl.registry import get_family
from trainctl.run.analysis import simulate_strategy
from trainctl.scenario import load_scenario

ANALYSES = Path(__file__).resolve().parents[1] / "analyses"


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("heavy-haul-flocking")


@pytest.fixture(scope="module")
def design(scenario):
    return build_design(scenario).family("flocking")


def _closed_loop_rhs(design, xi: np.ndarray) -> np.ndarray:
    """ξ̇ of the nonlinear train (train_rhs) under the unsaturated law, ξ = [v̂, z, p]."""
    law, train = design.law, design.scenario.train
    n = law.n
    v_r = design.model.settings.speed
    v_err, z, p = xi[:n], xi[n:2 * n - 1], xi[2 * n - 1]
    x_err = p - np.concatenate([[0.0], np.cumsum(z)])
    state = np.concatenate([v_r + v_err, z, [0.0]])
    feed = train.mass * train.davis[0] + train.mass * (train.davis[1] * v_r
                                                       + train.davis[2] * v_r**2)
    u = feed + train.mass * law.acceleration(v_err, z, x_err)
    rhs = train_rhs(train, state, u)
    return np.concatenate([rhs[:2 * n - 1], [v_err[0]]])


def test_linear_closed_loop_is_the_jacobian_of_the_nonlinear_loop(design):
    n = design.law.n
    xi0 = np.zeros(2 * n)
    assert np.allclose(_closed_loop_rhs(design, xi0), 0.0, atol=1e-12)
    steps = np.concatenate([np.full(n, 1e-4), np.full(n - 1, 1e-2), [1e-2]])
    J = np.empty((2 * n, 2 * n))
    for k in range(2 * n):
        e = np.zeros(2 * n)
        e[k] = steps[k]
        J[:, k] = (_closed_loop_rhs(design, xi0 + e) - _closed_loop_rhs(design, xi0 - e)) / (
            2 * steps[k])
    scale = np.abs(J).max(axis=0, keepdims=True)
    assert np.allclose(design.A_cl, J, rtol=1e-5, atol=1e-7 * scale.max())
    loop = get_family("flocking").closed_loop(design, "flocking")
    assert loop.dt == 0 and "f[0]" not in loop.output_labels
    poles = np.sort_complex(np.asarray(loop.poles()))
    assert np.allclose(poles, np.sort_complex(np.linalg.eigvals(J)), atol=1e-6)


def _potential_table(potential):
    """E(s) by a cumulative trapezoid of the specific force from the desired gap [m²/s²]."""
    s = np.linspace(0.0, potential.r, 200_001)
    acc = np.asarray(potential.acceleration(s))
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1]) * np.diff(s))])
    cum -= np.interp(potential.desired_gap, s, cum)
    return s, cum


def test_energy_below_the_bound_never_increases_and_no_gap_closes(scenario):
    s = (scenario.replace("controller.input_bounds", False)
         .replace("controller.control_interval", 0.1)
         .replace("simulation.plant_saturation", False)
         .replace("simulation.strategies", ["flocking"])
         .replace("simulation.settle_time", 300.0)
         .replace("simulation.duration", 400.0))
    design = build_design(s).family("flocking")
    law = design.law
    result = simulate_strategy(s, "flocking")
    n, v_r = law.n, float(s.simulation.reference_speeds[0])
    x = np.asarray(result.states)
    t = np.asarray(result.time)
    z = x[n:2 * n - 1]
    gaps = law.potential.desired_gap + z
    grid, table = _potential_table(law.potential)
    pair = np.interp(np.minimum(gaps, law.potential.r), grid, table).sum(axis=0)
    leader = x[2 * n - 1, 0] + v_r * t
    x_err = (x[2 * n - 1] - leader)[None, :] - np.vstack([np.zeros_like(t), np.cumsum(z, axis=0)])
    H = 0.5 * ((x[:n] - v_r) ** 2).sum(axis=0) + pair + 0.5 * law.position_gain * (
        x_err**2).sum(axis=0)
    bound = law.potential.collision_energy_bound().energy
    assert H[0] < bound
    assert np.min(gaps) > 0.0
    assert trajectory_gaps(design, result)[0] > 0.0
    assert np.max(np.diff(H)) <= 1e-3 * H[0]
    assert H[-1] < 0.5 * H[0]


def test_start_above_the_bound_is_uncertified():
    s = load_scenario(str(ANALYSES / "heavy-haul-flocking-collision.toml"))
    check = review_design(s).check("flocking_collision")
    assert check.status == "fail" and "uncertified" in check.message
    assert check.value is not None and check.threshold is not None
    assert check.value >= check.threshold


def test_h_equal_one_refused_with_the_reason(tmp_path):
    text = (ANALYSES / "heavy-haul-flocking.toml").read_text(encoding="utf-8")
    path = tmp_path / "h1.toml"
    path.write_text(text.replace("bump_h = 0.2 ", "bump_h = 1.0 "), encoding="utf-8")
    assert "bump_h = 1.0" in path.read_text(encoding="utf-8")
    result = run_module("analyse", str(path))
    assert result.returncode == 2
    assert "bump_h" in result.stderr and "non-Lipschitz" in result.stderr
    assert "Traceback" not in result.stderr
    with pytest.raises(ModelError, match="bump_h"):
        FlockingSettings(bump_h=1.0)


def test_desired_gap_must_agree_with_the_coupler(scenario):
    with pytest.raises(ScenarioError, match="desired_gap_m"):
        build_design(scenario.replace("controller.desired_gap_m", 400.0))


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_analyse_json_has_the_checks_with_numbers():
    result = run_module("analyse", "heavy-haul-flocking", "--json")
    assert result.returncode == 0, result.stderr
    checks = {c["name"]: c for c in json.loads(result.stdout)["checks"]}
    params = checks["flocking_parameters"]["details"]
    assert params["d_alpha"] == pytest.approx((np.sqrt(11.0) - 1.0) / 0.1)
    assert params["k_eff_per_s2"] == pytest.approx(1.43e-3, rel=5e-3)
    assert checks["flocking_closed_loop"]["value"] < 0.0
    collision = checks["flocking_collision"]
    assert collision["value"] < collision["threshold"]
    assert collision["details"]["bound_relative_speed_m_s"] == pytest.approx(
        np.sqrt(2 * collision["threshold"]))
    assert checks["flocking_connectivity"]["value"] == pytest.approx(590.0)
    assert checks["flocking_actuators"]["value"] > 1.0


def test_held_loop_is_python_control_zoh_with_the_law(design):
    """Φ + Γ F of the sampling check equals c2d (zoh) of the open loop closed by F."""
    import control as ct

    T = design.control_interval
    sys = ct.c2d(ct.ss(design.A_open, design.B_open, np.eye(design.A_open.shape[0]), 0), T,
                 method="zoh")
    expected = sys.A + sys.B @ design.law.feedback()
    assert np.allclose(design.sampled_matrix(), expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(("interval", "status"), [(1.0, "pass"), (2.0, "warn"), (100.0, "fail")])
def test_sampling_check_verdicts(interval, status):
    """ω_max ≈ 0.071 rad/s: 1 s passes, 2 s (0.14 rad) warns, 100 s makes the held loop unstable."""
    from trainctl.controllers.flocking.family import FAMILY

    sc = load_scenario("heavy-haul-flocking").replace("controller.control_interval", interval)
    d = build_design(sc).family("flocking")
    check = {c.name: c for c in FAMILY.checks(d)}["flocking_sampling"]
    assert check.status == status
    lam = np.linalg.eigvals(d.A_cl)
    assert check.value == pytest.approx(np.abs(lam).max() * interval)
    rho = np.abs(np.linalg.eigvals(d.sampled_matrix())).max()
    assert (rho > 1.0) == (status == "fail")
