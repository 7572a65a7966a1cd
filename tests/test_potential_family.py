"""Tests of the potential family (issue 11): Zhao & Wang's law, its closed loop and checks."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from trainctl.controllers.potential.family import FAMILY
from trainctl.controllers.potential.law import law_of
from trainctl.design import build_design
from trainctl.models.dynamics import train_rhs
from trainctl.models.feedforward import ForceSplit
from trainctl.run.analysis import simulate_strategy
from trainctl.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[1]


def _scenario(potential: dict[str, Any] | None = None, simulation: dict[str, Any] | None = None,
              equal_mass: float | None = None) -> Scenario:
    """The 4-car well-sampled CRH2 scenario with a [controller.potential] sub-table."""
    sc = load_scenario("crh2-dmpc-well-sampled")
    if equal_mass is not None:
        for i in range(4):
            sc = sc.replace(f"train.vehicle[{i}].mass_t", equal_mass)
    sc = sc.replace("controller.potential", {"control_interval": 0.005, **(potential or {})})
    sim = {"duration": 30.0, "strategies": ["potential.consensus"], "settle_time": 20.0,
           "reference": {"times": [0.0], "speeds_kmh": [288.0]},
           "plant_saturation": False, **(simulation or {})}
    return sc.replace("simulation", sim)


def _closed_loop_rhs(sc: Scenario, design: Any, xi: np.ndarray) -> np.ndarray:
    """Error dynamics of the nonlinear plant with the law (no saturation), ξ = [v̂, z, p]."""
    train, n = sc.train, sc.train.n_vehicles
    v_r = float(design.model.settings.speed)
    ff = ForceSplit(train)([v_r], [0.0])
    v, z, p = v_r + xi[:n], xi[n:2 * n - 1], xi[-1]
    state = np.concatenate([v, ff.elongations[0] + z, [p]])
    x_err = p - np.concatenate([[0.0], np.cumsum(z)])
    u = ff.inputs[0] + design.law.force(xi[:n], z, x_err)
    rhs = train_rhs(train, state, u)
    rhs[-1] -= v_r  # the reference position moves at v_r
    return rhs


@pytest.mark.parametrize("potential", ["quadratic", "barrier", "sigma"])
def test_linear_closed_loop_is_the_jacobian_of_the_nonlinear_one(potential: str) -> None:
    """A_cl equals a central finite-difference Jacobian at the equilibrium; poles match."""
    extra = {"pair_potential": potential, **({"barrier_m": 0.3} if potential == "barrier" else {})}
    sc = _scenario(extra)
    design = build_design(sc).family("potential")
    N = design.A_cl.shape[0]
    assert np.allclose(_closed_loop_rhs(sc, design, np.zeros(N)), 0.0, atol=1e-9)
    steps = np.where(np.arange(N) < 4, 1e-4, 1e-7)
    steps[-1] = 1e-4
    J = np.empty((N, N))
    for k in range(N):
        e = np.zeros(N)
        e[k] = steps[k]
        diff = _closed_loop_rhs(sc, design, e) - _closed_loop_rhs(sc, design, -e)
        J[:, k] = diff / (2 * steps[k])
    scale = np.abs(J).max(axis=0)
    assert np.allclose(J / scale, design.A_cl / scale, atol=1e-6)
    loop = FAMILY.closed_loop(design, "consensus")
    assert loop.dt == 0
    assert np.allclose(np.sort_complex(loop.poles()), np.sort_complex(np.linalg.eigvals(J)),
                       atol=1e-6 * np.abs(J).max())


def test_matches_the_closed_form_of_spec_2_2() -> None:
    """Equal masses, no coupler damping: eigenvalues of [[0, I], [-K, -C_v]] (spec §2.2)."""
    sc = _scenario({"position_gain": 0.2, "speed_gain_per_s": 0.4, "consensus_gain_per_s": 0.7,
                    "kappa_per_s2": 0.8}, equal_mass=45.0)
    design = build_design(sc).family("potential")
    n, m, k = 4, 45e3, 10488e3
    Ld = np.diag([1.0, 2, 2, 1]) - (np.eye(n, k=1) + np.eye(n, k=-1))
    Dd, Dv, Lv = 0.2 * np.eye(n), 0.4 * np.eye(n), 0.7 * Ld
    a0, a1, a2 = sc.train.davis[:, 0]
    v_r = sc.model.speed
    K = (k / m) * (Ld + Dd) + 0.8 * Ld
    Cv = (a1 + 2 * a2 * v_r) * np.eye(n) + Dv + Lv
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -Cv]])
    want = np.sort_complex(np.linalg.eigvals(A))
    got = np.sort_complex(np.linalg.eigvals(design.A_cl))
    assert np.allclose(got, want, atol=1e-8 * np.abs(want).max())
    names = {c.name: c for c in FAMILY.checks(design)}
    assert names["potential_lyapunov"].details["kind"] == "closed_form"


def _run(sc: Scenario) -> tuple[np.ndarray, np.ndarray]:
    res = simulate_strategy(sc, "potential.consensus")
    return np.asarray(res.dense_time), np.asarray(res.dense_states).T


def test_pinned_loop_converges() -> None:
    """With pinning: speeds to the reference, spacings and the position error to nominal."""
    sim = {"initial_speed_errors": [1.0, -1.0, 0.5, -0.5],
           "initial_spacing_errors": [0.005, -0.005, 0.005]}
    sc = _scenario({"input_bounds": False}, sim)
    t, x = _run(sc)
    v_r = sc.simulation.reference_speeds[0]
    start = x[0, 4:7] - np.array(sim["initial_spacing_errors"])
    assert np.abs(x[-1, :4] - v_r).max() < 1e-3
    assert np.abs(x[-1, 4:7] - start).max() < 1e-5
    assert abs(x[-1, 7] - v_r * t[-1]) < 1e-3
    assert np.abs(x[0, 4:7] - start).max() > 4e-3  # it did start off nominal


def test_unpinned_offset_is_the_rigid_mode_projection() -> None:
    """position_gain = 0: speeds converge; the head keeps the offset the analysis predicts."""
    sim = {"initial_speed_errors": [1.0, 0.5, 0.8, 0.2]}
    sc = _scenario({"input_bounds": False, "position_gain": 0.0}, sim)
    design = build_design(sc).family("potential")
    lam, left = np.linalg.eig(design.A_cl.T)
    w = np.real(left[:, np.argmin(np.abs(lam))])
    predicted = float(w @ design.initial_errors) / w[-1]
    t, x = _run(sc)
    v_r = sc.simulation.reference_speeds[0]
    offset = x[-1, 7] - v_r * t[-1]
    assert np.abs(x[-1, :4] - v_r).max() < 1e-3
    assert predicted > 0.5  # the common speed surplus leaves the train ahead
    assert offset == pytest.approx(predicted, rel=0.02)
    checks = {c.name: c for c in FAMILY.checks(design)}
    assert checks["potential_closed_loop"].status == "warn"
    assert "constant position offset" in checks["potential_closed_loop"].message
    position = checks["potential_position"]
    assert position.value == pytest.approx(predicted, rel=1e-9)
    assert position.status == ("fail" if predicted > 1.0 else "pass")
    assert f"{predicted:.4g} m ahead" in position.message


def test_barrier_keeps_the_spacing_inside_its_band() -> None:
    """(P2) with a small Δ: no deviation reaches Δ, while the quadratic law exceeds it.

    The barrier's energy scale m κ Δ² must exceed the initial energy for the
    band to be held in floating point (its log grows too slowly otherwise):
    κ = 200 1/s², Δ = 0.01 m against ±0.05 m/s speed errors.
    """
    delta = 0.01
    sim = {"duration": 2.0, "settle_time": 1.0, "initial_speed_errors": [0.05, -0.05, 0.05, -0.05],
           "initial_spacing_errors": [0.008, -0.008, 0.008]}
    common = {"input_bounds": False, "control_interval": 0.0005, "kappa_per_s2": 200.0}
    peaks, checks = {}, {}
    for name, extra in (("barrier", {"pair_potential": "barrier", "barrier_m": delta}),
                        ("quadratic", {})):
        sc = _scenario({**common, **extra}, sim, equal_mass=45.0)
        _, x = _run(sc)
        start = x[0, 4:7] - np.array(sim["initial_spacing_errors"])
        peaks[name] = float(np.abs(x[:, 4:7] - start).max())
        checks[name] = {c.name: c for c in FAMILY.checks(build_design(sc).family("potential"))}
    assert peaks["quadratic"] > delta
    assert peaks["barrier"] < delta
    # the energy bound of the check holds the simulated peak, inside the band
    bound = checks["barrier"]["potential_spacing_bound"].value
    assert peaks["barrier"] <= bound < delta
    assert bound > 0.5 * delta  # and it is not vacuous: the start is well inside


def test_barrier_bound_is_the_energy_level_set() -> None:
    """Two equal cars, no pinning, p irrelevant: m U(z) = V(0) solved by hand at the bound."""
    from trainctl.controllers.potential.checks import barrier_bound

    delta, kappa, m = 0.02, 50.0, 45e3
    sim = {"initial_speed_errors": [0.02, -0.02, 0.0, 0.0],
           "initial_spacing_errors": [0.005, 0.0, 0.0]}
    sc = _scenario({"pair_potential": "barrier", "barrier_m": delta, "kappa_per_s2": kappa,
                    "position_gain": 0.0}, sim, equal_mass=m / 1e3)
    design = build_design(sc).family("potential")
    k = sc.train.stiffness
    a = kappa * delta**2  # barrier strength [m²/s²]
    # V(0) = ½ m Σv̂² + ½ Σ k z² + m U(z): cars 3, 4 at rest, links 2, 3 undeflected
    V0 = 0.5 * m * 2 * 0.02**2 + 0.5 * k[0] * 0.005**2 - m * 0.5 * a * np.log(
        1 - (0.005 / delta) ** 2)
    z = barrier_bound(design)
    assert m * (-0.5 * a * np.log(1 - (z / delta) ** 2)) == pytest.approx(V0, rel=1e-9)


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "trainctl", *args], capture_output=True,
                          text=True, cwd=ROOT, env={"PYTHONPATH": str(ROOT), "PATH": ""},
                          timeout=600)


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_cli_reports_the_checks() -> None:
    """`trainctl analyse crh2-potential --json --no-simulate`: every check present, as declared."""
    out = _cli("analyse", "crh2-potential", "--json", "--no-simulate")
    assert out.returncode == 0, out.stderr
    checks = {c["name"]: c["status"] for c in json.loads(out.stdout)["checks"]}
    for name in FAMILY.check_names:
        assert checks[name] == "pass"
    assert "consensus" in json.loads(out.stdout)["frequency"]


@pytest.mark.parametrize(("key", "value", "match"), [
    ("kappa_per_s2", "-1.0", "kappa_per_s2"),
    ("pair_potential", '"barrier"', "barrier_m"),
    ("control_interval", "0.003", "control_interval"),
])
def test_bad_settings_exit_2(tmp_path: Path, key: str, value: str, match: str) -> None:
    """A wrong [controller] value of the family is a clean scenario error (exit 2)."""
    text = (ROOT / "analyses" / "crh2-potential.toml").read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if not ln.startswith(f"{key} ")]
    at = lines.index('family = "potential"                # primary family [paper]')
    lines.insert(at + 1, f"{key} = {value}")
    path = tmp_path / "bad.toml"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = _cli("analyse", str(path), "--no-simulate")
    assert out.returncode == 2, out.stdout + out.stderr
    assert match in out.stderr
    assert "Traceback" not in out.stderr


def test_initial_errors_are_checked_against_the_train() -> None:
    """initial_spacing_errors needs one entry per coupler."""
    from trainctl.exceptions import ScenarioError

    with pytest.raises(ScenarioError, match="initial_spacing_errors"):
        _scenario(simulation={"initial_spacing_errors": [0.01, 0.01]})


def test_law_of_uses_the_graph() -> None:
    """Consensus weights are consensus_gain times the [communication] adjacency."""
    sc = _scenario({"consensus_gain_per_s": 2.0})
    law = law_of(sc, sc.controllers["potential"])
    assert np.array_equal(law.consensus, 2.0 * sc.graph().adjacency)
    assert np.allclose(law.pinning, 0.1 * 10488e3 * sc.graph().pinning)


def test_spacing_bound_holds_the_linear_trajectory_and_is_tight() -> None:
    """crh2-potential: the SDP bound ≥ the true peak of |z(t)| (expm), and within 2x of it."""
    import scipy.linalg

    design = build_design(load_scenario("crh2-potential")).family("potential")
    check = {c.name: c for c in FAMILY.checks(design)}["potential_spacing_bound"]
    n, A, xi0 = design.law.n, design.A_cl, design.initial_errors
    step = scipy.linalg.expm(A * 0.002)
    x, peak = xi0.copy(), 0.0
    for _ in range(15000):  # 30 s, past the coupler transients
        peak = max(peak, float(np.abs(x[n:2 * n - 1]).max()))
        x = step @ x
    assert peak <= check.value
    assert check.value < 2.0 * peak


def test_bound_lmi_equals_the_per_row_lmi_form() -> None:
    """The Q = P⁻¹ form gives the optimum of the per-row form [[P, c], [cᵀ, γ]] ⪰ 0 (cvxpy)."""
    import cvxpy as cp

    from trainctl.controllers.potential.checks import bound_lmi, spacing_bound

    A = np.array([[0.0, 1.0, 0.0], [-2.0, -0.3, 1.0], [0.0, -1.0, -0.5]])
    xi0 = np.array([0.3, -0.2, 0.5])
    rows = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    P = bound_lmi(A, xi0, rows)
    ours = float(np.max(spacing_bound(P, xi0, rows))) ** 2
    Pv, g = cp.Variable((3, 3), symmetric=True), cp.Variable((1, 1))
    lhs = A.T @ Pv + Pv @ A
    cons = [Pv >> 0, 0.5 * (lhs + lhs.T) << 0, cp.quad_form(xi0, Pv) <= 1.0]
    cons += [cp.bmat([[Pv, c[:, None]], [c[None, :], g]]) >> 0 for c in rows]
    cp.Problem(cp.Minimize(g[0, 0]), cons).solve(solver=cp.SCS, eps=1e-9)
    assert ours == pytest.approx(float(g.value[0, 0]), rel=1e-4)


def test_long_trains_are_certified_by_the_lyapunov_equation() -> None:
    """Above LMI_MAX_STATES states the certificate is the Lyapunov equation's P, verified."""
    from trainctl.controllers.potential.checks import (
        LMI_MAX_STATES,
        lyapunov_equation,
        lyapunov_lmi,
    )

    sc = load_scenario("crh2-potential").replace("simulation", None)
    for i in range(8):
        sc = sc.replace(f"train.vehicle[{i}].count", 3)  # 24 cars, 48 states
    design = build_design(sc).family("potential")
    assert design.A_cl.shape[0] > LMI_MAX_STATES
    kind, P = design.certificate
    assert kind == "equation"
    Q = design.A_cl.T @ P + P @ design.A_cl
    assert np.linalg.eigvalsh(P).min() > 0 and np.linalg.eigvalsh(0.5 * (Q + Q.T)).max() < 0
    checks = {c.name: c for c in FAMILY.checks(design)}
    assert checks["potential_lyapunov"].status == "pass"
    assert "Lyapunov-equation" in checks["potential_lyapunov"].message
    assert checks["potential_spacing_bound"].value < np.inf
    # on a small loop both routes certify the same matrix
    small = build_design(load_scenario("crh2-potential")).family("potential").A_cl
    assert lyapunov_equation(small) is not None and lyapunov_lmi(small) is not None
    unstable = small + 2.0 * np.eye(small.shape[0])
    assert lyapunov_equation(unstable) is None and lyapunov_lmi(unstable) is None
