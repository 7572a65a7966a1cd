"""The neighbourhood-local N-DMPC controller (strategy "ndmpc-local") against its closed form."""

from __future__ import annotations

import numpy as np
import pytest

from trainctl.controllers.base import Measurement, ReferencePreview
from trainctl.controllers.mpc import MPCConstraints, make_mpc
from trainctl.controllers.mpc.theory.local_iteration import (
    local_closed_loop,
    local_iteration,
    local_model,
    local_nash_gain,
    train_state_owner,
)
from trainctl.controllers.mpc.theory.mpc import MPCDesign
from trainctl.design import build_design
from trainctl.exceptions import ModelError
from trainctl.models import Coupler, Train, discretise, equilibrium, linearise
from trainctl.run.analysis import run_scenario
from trainctl.scenario import load_scenario

NONE = MPCConstraints(input_bounds=False)
V0 = 60.0


@pytest.fixture(scope="module")
def well():
    fam = build_design(load_scenario("crh2-dmpc-well-sampled")).family("mpc")
    return fam.scenario.train, fam.mpc, fam.model.design


def _design(d, *, P=6, M=2, form="u", r=1.0):
    return MPCDesign(A=d.A, B=d.B, C=d.C, prediction_horizon=P, control_horizon=M, form=form,
                     q=d.q, r=np.full(d.n_inputs, r), output_owner=d.output_owner,
                     neighbourhoods=d.neighbourhoods)


def _preview(P, dt):
    times = dt * np.arange(P + 1)
    return ReferencePreview(times=times, speed=np.full(times.size, V0),
                            acceleration=np.zeros(times.size))


def _run(train, d, model, x0, steps, dt=0.05):
    """Closed loop of the controller on the linear design model; deviation states per step."""
    ctl = make_mpc(train, d, dt=dt, strategy="ndmpc-local", constraints=NONE,
                   tolerance=1e-11, max_iterations=400, local_model=model)
    eq = equilibrium(train, V0)
    n = train.n_vehicles
    x, out, inputs = x0.copy(), [x0.copy()], []
    for k in range(steps):
        state = np.concatenate([V0 + x[:n], eq.elongations + x[n:], [0.0]])
        rec = ctl.step(k * dt, Measurement(state=state), _preview(d.prediction_horizon, dt))
        assert rec.status == "optimal" and rec.iterations < 400
        u = rec.inputs / 1e3 - eq.inputs / 1e3
        inputs.append(u)
        x = d.A @ x + d.B @ u
        out.append(x.copy())
    return np.array(out), np.array(inputs), ctl


@pytest.mark.parametrize("form", ["u", "du"])
def test_unconstrained_closed_loop_equals_the_closed_form(well, form):
    train, d0, sys = well
    d = _design(d0, form=form, r=1.0 if form == "u" else 50.0)
    model = local_model(d, sys.A, sys.B, 0.05, train_state_owner(4))
    it = local_iteration(d, model)
    assert it.rho < 0.9
    A_cl = local_closed_loop(d, local_nash_gain(it)[:it.n_plan])
    x0 = np.r_[0.3, 0.2, -0.1, 0.25, 1e-4, -5e-5, 2e-5]
    xs, us, _ = _run(train, d, model, x0, 6)
    xi = np.r_[x0, np.zeros(4)] if form == "du" else x0
    for k in range(1, 7):
        xi = A_cl @ xi
        np.testing.assert_allclose(xs[k], xi[:7], rtol=1e-7, atol=1e-10)
        if form == "du":
            np.testing.assert_allclose(us[k - 1], xi[7:], rtol=1e-7, atol=1e-9)


def chain(n):
    base = load_scenario("crh2-dmpc").train
    return Train(vehicles=tuple(base.vehicles[i % 4] for i in range(n)),
                 couplers=(Coupler(stiffness=1.0488e7, spacing=25.0),) * (n - 1))


def chain_design(n, P=6, M=2, r=1.0):
    train = chain(n)
    sys = linearise(train, 50.0, outputs=("v", "force"))
    scale = np.concatenate([np.ones(n), np.full(n - 1, 1e-3)])
    sysd = discretise(sys, 0.05)
    d = MPCDesign(A=sysd.A, B=sysd.B * 1e3, C=scale[:, None] * sysd.C, prediction_horizon=P,
                  control_horizon=M, form="u",
                  q=np.concatenate([np.full(n, 10.0), np.full(n - 1, 0.01)]), r=np.full(n, r),
                  output_owner=tuple(range(n)) + tuple(range(n - 1)),
                  neighbourhoods=tuple(tuple(j for j in (i - 1, i, i + 1) if 0 <= j < n)
                                       for i in range(n)))
    model = local_model(d, sys.A, sys.B * 1e3, 0.05, train_state_owner(n))
    return train, d, model


def test_identical_coaches_share_one_qp_and_qp_size_is_independent_of_length():
    sizes = {}
    for n in (4, 12):
        train, d, model = chain_design(n)
        ctl = make_mpc(train, d, dt=0.05, strategy="ndmpc-local",
                       constraints=MPCConstraints(rate_limit=5e3, coupler_force_limit=50e3),
                       local_model=model)
        blocks = ctl.problem.blocks
        sizes[n] = {(b.qp.nz, b.qp.nh, b.qp.ns) for b in blocks}
        if n == 12:
            # ends (2 coaches each side) and the 4 interior T-M-M-T patterns
            assert ctl.problem.distinct <= 8 < n
            assert len({id(b.qp.fast_path) for b in blocks}) == n  # own workspaces
            assert len({id(b.qp.problem) for b in blocks}) == ctl.problem.distinct
    assert sizes[4] <= sizes[12]
    assert max(s[0] for s in sizes[12]) == 2          # M own moves, whatever the length


def test_trajectories_before_any_state_are_refused_clearly():
    """The held start needs a measured state: asking before the first sources() says so."""
    train, d, model = chain_design(4)
    ctl = make_mpc(train, d, dt=0.05, strategy="ndmpc-local", local_model=model)
    with pytest.raises(RuntimeError, match=r"no state yet; call sources\(\) or parameters"):
        ctl.problem.initial_trajectories()


def test_long_train_unconstrained_equals_the_closed_form():
    n = 12
    train, d, model = chain_design(n, r=2.0)
    it = local_iteration(d, model)
    assert it.rho < 0.95
    A_cl = local_closed_loop(d, local_nash_gain(it)[:it.n_plan])
    rng = np.random.default_rng(2)
    x0 = np.r_[0.3 + 0.05 * rng.normal(size=n), 1e-5 * rng.normal(size=n - 1)]
    ctl = make_mpc(train, d, dt=0.05, strategy="ndmpc-local", constraints=NONE,
                   tolerance=1e-11, max_iterations=400, local_model=model)
    eq = equilibrium(train, 50.0)
    x = x0.copy()
    times = 0.05 * np.arange(d.prediction_horizon + 1)
    prev = ReferencePreview(times=times, speed=np.full(times.size, 50.0),
                            acceleration=np.zeros(times.size))
    for k in range(3):
        state = np.concatenate([50.0 + x[:n], eq.elongations + x[n:], [0.0]])
        rec = ctl.step(k * 0.05, Measurement(state=state), prev)
        x_next = d.A @ x + d.B @ (rec.inputs / 1e3 - eq.inputs / 1e3)
        np.testing.assert_allclose(x_next, A_cl @ x, rtol=1e-7, atol=1e-10)
        x = x_next


def test_needs_the_local_model(well):
    train, d0, _ = well
    with pytest.raises(ModelError, match="local_model"):
        make_mpc(train, _design(d0), dt=0.05, strategy="ndmpc-local")


def test_constrained_run_tracks_on_the_well_sampled_train():
    """crh2-dmpc-well-sampled with P = 10 (ρ(D0_local) ≈ 0.62) and 5 kN/step, 50 kN limits."""
    sc = (load_scenario("crh2-dmpc-well-sampled")
          .replace("controller.coupler_force_steps", [1, 2, 3, 4, 5, 10])
          .replace("controller.prediction_horizon", 10)
          .replace("controller.rate_limit_kn", 5.0)
          .replace("controller.coupler_force_limit_kn", 50.0)
          .replace("simulation.settle_time", 40.0)
          .replace("simulation.duration", 80.0)
          .replace("simulation.strategies", ["ndmpc-local"]))
    run = run_scenario(sc)
    res, m = run.simulations["ndmpc-local"], run.metrics["ndmpc-local"]
    assert np.max(m.max_error) <= 0.01                  # m/s, on the 0.1 m/s² ramp
    assert set(res.statuses) == {"optimal"}
    assert np.max(np.abs(res.coupler_forces)) <= 50e3
    assert np.max(np.abs(np.diff(res.inputs, axis=1))) <= 5e3 + 1.0


def test_design_review_reports_both_formulations():
    """With ndmpc-local simulated, the convergence and Nash-loop checks carry the local numbers."""
    from trainctl.controllers.mpc.family import FAMILY
    from trainctl.controllers.mpc.theory.dmpc import analyse_local_dmpc
    from trainctl.controllers.mpc.theory.iteration import spectral_radius

    sc = load_scenario("crh2-dmpc-well-sampled")
    plain = build_design(sc).family("mpc")
    assert not plain.simulates_local
    assert "local" not in dict(FAMILY.checks(plain)[0].details)
    fam = build_design(sc.replace("simulation.strategies", ["ndmpc", "ndmpc-local"])).family("mpc")
    checks = {c.name: c for c in FAMILY.checks(fam)}
    it = local_iteration(fam.mpc, fam.local)
    conv = checks["ndmpc_convergence"]
    assert conv.details["local"]["rho_d0"] == pytest.approx(it.rho, rel=1e-9)
    assert conv.details["rho_D0"] == pytest.approx(fam.analysis.rho_d0)
    # P = 40 at R = 0.2: the global iteration converges (0.61), the local one diverges (1.41)
    assert fam.analysis.rho_d0 < 1 <= it.rho and conv.status == "warn"
    assert "ndmpc-local" in conv.message and "ndmpc-local" in conv.hint
    nash = checks["closed_loop_nash"]
    radius = spectral_radius(local_closed_loop(fam.mpc, local_nash_gain(it)[:it.n_plan]))
    assert nash.details["local"]["closed_loop_radius"] == pytest.approx(radius, rel=1e-12)
    res = analyse_local_dmpc(fam.mpc, fam.local, iterations=fam.settings.iterations)
    assert res.rho_d0 == pytest.approx(it.rho, rel=1e-9) and not res.converges
    fixed = checks["closed_loop_iterations"].details["local"]["closed_loop_iterations_radius"]
    assert fixed == pytest.approx(res.closed_loop_iterations_radius, rel=1e-12)
    assert res.closed_loop_iterations.shape[0] == 7 + it.D0.shape[0]
    loop = FAMILY.closed_loop(fam, "ndmpc-local")
    np.testing.assert_allclose(loop.A, res.closed_loop_nash)


def test_design_review_gives_the_local_threshold_weight():
    """The local R* in the check: ρ(D0_local) crosses 1 there, by direct evaluation beside it."""
    import re

    from trainctl.controllers.mpc.family import FAMILY

    sc = load_scenario("crh2-dmpc").replace("simulation.strategies", ["ndmpc", "ndmpc-local"])
    fam = build_design(sc).family("mpc")
    conv = {c.name: c for c in FAMILY.checks(fam)}["ndmpc_convergence"]
    found = re.search(r"local formulation \(ndmpc-local\): ρ\(D0\) = [0-9.]+, "
                      r"R\* = ([0-9.]+) per kN²", conv.message)
    assert found, conv.message
    r_star = float(found.group(1))                     # per kN², the design unit of CRH2
    assert conv.details["local"]["threshold_weight"] == pytest.approx(r_star, rel=1e-3)
    below = local_iteration(fam.mpc, fam.local, r=r_star * 0.99).rho
    above = local_iteration(fam.mpc, fam.local, r=r_star * 1.01).rho
    assert below > 1 > above
    # the scenario's R lies between the global R* (2.25) and the local one: the local one warns
    assert np.all((fam.analysis.threshold_weight < fam.mpc.r) & (fam.mpc.r < r_star))   # R = 10
    assert conv.status == "warn" and f"raise R above its R* = {r_star:.4g}" in conv.hint


def test_cvxpy_path_with_shared_problems_equals_the_fast_path():
    """Clones share the cvxpy problem: re-solving it per coach gives the fast path's plan."""
    train, d, model = chain_design(12, r=2.0)
    eq = equilibrium(train, 50.0)
    x = np.r_[np.full(12, 0.3), np.zeros(11)]
    state = np.concatenate([50.0 + x[:12], eq.elongations, [0.0]])
    times = 0.05 * np.arange(d.prediction_horizon + 1)
    prev = ReferencePreview(times=times, speed=np.full(times.size, 50.0),
                            acceleration=np.zeros(times.size))
    limits = MPCConstraints(rate_limit=5e3, coupler_force_limit=50e3)
    out = {}
    for path in ("fast", "cvxpy"):
        ctl = make_mpc(train, d, dt=0.05, strategy="ndmpc-local", constraints=limits,
                       tolerance=1e-7, max_iterations=200, local_model=model, path=path)
        rec = ctl.step(0.0, Measurement(state=state), prev)
        assert rec.status in ("optimal", "optimal_inaccurate")
        out[path] = rec.inputs / 1e3
    np.testing.assert_allclose(out["fast"], out["cvxpy"], atol=1e-4)


@pytest.mark.parametrize(("form", "r"), [("u", 1.0), ("du", 50.0)])
def test_fixed_iteration_count_closed_loop_equals_the_controller(well, form, r):
    """L = 3 iterations per sample from the shifted plans and trajectories, as the controller."""
    from trainctl.controllers.mpc.theory.local_iteration import local_finite_iteration_closed_loop

    train, d0, sys = well
    d = _design(d0, form=form, r=r)
    model = local_model(d, sys.A, sys.B, 0.05, train_state_owner(4))
    it = local_iteration(d, model)
    A_cl = local_finite_iteration_closed_loop(d, it, 3)
    ctl = make_mpc(train, d, dt=0.05, strategy="ndmpc-local", constraints=NONE, tolerance=0.0,
                   max_iterations=3, local_model=model)
    eq = equilibrium(train, V0)
    x = np.r_[0.3, 0.2, -0.1, 0.25, 1e-4, -5e-5, 2e-5]
    # first sample: no previous plan, trajectories held at the measured state
    aug = np.concatenate([x, np.zeros(4)] if form == "du" else [x])
    aug = np.concatenate([aug, np.zeros(it.n_plan), np.tile(x, d.prediction_horizon)])
    for k in range(4):
        state = np.concatenate([V0 + x[:4], eq.elongations + x[4:], [0.0]])
        rec = ctl.step(k * 0.05, Measurement(state=state), _preview(d.prediction_horizon, 0.05))
        u = rec.inputs / 1e3 - eq.inputs / 1e3
        x = d.A @ x + d.B @ u
        aug = A_cl @ aug
        np.testing.assert_allclose(aug[:7], x, rtol=1e-7, atol=1e-10)
        if form == "du":
            np.testing.assert_allclose(aug[7:11], u, rtol=1e-6, atol=1e-7)  # OSQP eps 1e-6


def test_infeasible_step_is_recorded_and_falls_back(well):
    """A bound that drops faster than the rate limit allows: status recorded, fallback used."""
    train, d0, sys = well
    d = _design(d0, P=10, M=5, r=2.0)
    model = local_model(d, sys.A, sys.B, 0.05, train_state_owner(4))
    ctl = make_mpc(train, d, dt=0.05, strategy="ndmpc-local",
                   constraints=MPCConstraints(rate_limit=100.0), max_iterations=5,
                   local_model=model)
    x = equilibrium(train, 20.0).state(position=0.0)
    times = 0.05 * np.arange(11)
    ramp = ReferencePreview(times=times, speed=20.0 + 0.6 * times,
                            acceleration=np.full(times.size, 0.6))
    first = ctl.step(0.0, Measurement(state=x), ramp)
    # Jump the reference to 83 m/s: the power limit cuts the bound from ~60 to 14.4 kN.
    jump = ReferencePreview(times=times + 0.05, speed=np.full(times.size, 83.0),
                            acceleration=np.zeros(times.size))
    second = ctl.step(0.05, Measurement(state=x), jump)
    assert second.status == "infeasible" and second.fallback == "shifted plan"
    assert np.all(np.isfinite(second.inputs))
    assert first.status in ("optimal", "max_iterations")
    third = ctl.step(0.1, Measurement(state=x), jump)  # the exchange carries on
    assert np.all(np.isfinite(third.inputs))
