"""Tests of the MPC family against closed forms and independent formulations."""

from __future__ import annotations

import math

import cvxpy as cp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trainctl.controllers.base import Measurement, ReferencePreview
from trainctl.controllers.mpc import MPCConstraints, make_mpc
from trainctl.controllers.mpc.qp.parametric import ParametricQP
from trainctl.controllers.mpc.theory.iteration import (
    cooperative_iteration,
    iteration_matrices,
    nash_gain,
)
from trainctl.controllers.mpc.theory.mpc import MPCDesign, prediction
from trainctl.design import build_design
from trainctl.models import equilibrium
from trainctl.models.envelope import EnvelopeBounds
from trainctl.scenario import load_scenario

NONE = MPCConstraints(input_bounds=False)


@pytest.fixture(scope="module")
def book():
    scenario = load_scenario("crh2-dmpc")
    return scenario, build_design(scenario).family("mpc").mpc


@pytest.fixture(scope="module")
def fast():
    scenario = load_scenario("crh2-dmpc-well-sampled")
    return scenario, build_design(scenario).family("mpc").mpc


def preview(design, dt, v0=60.0, accel=0.0):
    times = dt * np.arange(design.prediction_horizon + 1)
    return ReferencePreview(times=times, speed=v0 + accel * times,
                            acceleration=np.full(times.size, accel))


def perturbed_state(train, v0, rng, dv=0.5, ddelta=2e-4, relative=0.01):
    """Equilibrium at v0 plus a common speed error, small relative speeds and elongations.

    Coaches on stiff couplers cannot differ much in speed: 1 m/s of relative speed
    swings a 10488 kN/m coupler by ~900 kN, so the perturbation is mostly common.
    """
    x = equilibrium(train, v0).state(position=0.0)
    n = train.n_vehicles
    x[:n] += rng.normal(scale=dv) + rng.normal(scale=relative, size=n)
    x[n:2 * n - 1] += rng.normal(scale=ddelta, size=n - 1)
    return x


def deviation(train, x, v0):
    eq = equilibrium(train, v0)
    n = train.n_vehicles
    return np.concatenate([x[:n] - v0, x[n:2 * n - 1] - eq.elongations])


class TestFeedforward:
    @pytest.mark.parametrize("name", ["crh2-dmpc", "heavy-haul-flocking"])
    def test_vectorised_feedforward_equals_equilibrium(self, name):
        """The controller's feedforward over a preview equals equilibrium() point by point."""
        scenario = load_scenario(name)
        train = scenario.train
        n = train.n_vehicles
        d = MPCDesign(A=np.eye(2 * n - 1), B=np.zeros((2 * n - 1, n)),
                      C=np.eye(n, 2 * n - 1), prediction_horizon=2, control_horizon=1,
                      form="u", q=np.ones(n), r=np.ones(n), output_owner=tuple(range(n)),
                      neighbourhoods=tuple((i,) for i in range(n)))
        ctl = make_mpc(train, d, dt=1.0, strategy="decentralised", constraints=NONE)
        speeds, accels = np.array([10.0, 30.0, 60.0]), np.array([0.2, 0.0, -0.1])
        u_ff, f_ff, elong = ctl._feedforward(speeds, accels)
        for k, (v, a) in enumerate(zip(speeds, accels, strict=True)):
            eq = equilibrium(train, v, acceleration=a)
            np.testing.assert_allclose(u_ff[k] * 1e3, eq.inputs, rtol=1e-12)
            np.testing.assert_allclose(f_ff[k] * 1e3, eq.coupler_forces, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(elong, equilibrium(train, 10.0, acceleration=0.2).elongations,
                                   rtol=1e-9, atol=1e-15)


class TestReferenceProblem:
    @pytest.mark.parametrize("path", ["fast", "cvxpy"])
    def test_mpt3_regulation_problem(self, path):
        """MPT3 example as pinned in python-control's tests: u and cost 32.4898."""
        A = np.array([[1.0, 1.0], [0.0, 1.0]])
        B = np.array([[1.0], [0.5]])
        d = MPCDesign(A=A, B=B, C=np.eye(2), prediction_horizon=4, control_horizon=4, form="u",
                      q=np.ones(2), r=np.ones(1), output_owner=(0, 0), neighbourhoods=((0,),))
        pred = prediction(d)
        x0 = np.array([4.0, 0.0])
        free = pred.Phi @ x0
        hard = np.vstack([np.eye(4), pred.G])  # |u| <= 1, |x_1..x_4| <= 5
        qp = ParametricQP(2 * pred.hessian(), hard, np.zeros((0, 4)), name="mpt3")
        sol = qp.solve(2 * pred.G.T @ free, np.concatenate([-np.ones(4), -5 - free]),
                       np.concatenate([np.ones(4), 5 - free]), path=path)
        u = np.append(sol.z, 0.0)  # the input at the last time point has no effect
        np.testing.assert_allclose(u, [-1, -1, 0.1393, 0.3361, 0], atol=1e-4)
        cost = pred.cost(sol.z, -free) + x0 @ x0
        assert cost == pytest.approx(32.4898, abs=1e-4)


class TestUnconstrained:
    @pytest.mark.parametrize("fixture", ["book", "fast"])
    def test_ndmpc_converges_to_closed_form_nash(self, fixture, request, rng):
        """Iterated local QPs reach (I - D0)⁻¹ D1 e (≤ 1e-6 kN)."""
        scenario, d = request.getfixturevalue(fixture)
        ctl = make_mpc(scenario.train, d, dt=scenario.model.sample_time, strategy="ndmpc",
                       constraints=NONE, max_iterations=500, tolerance=1e-10)
        x = perturbed_state(scenario.train, 60.0, rng)
        ctl.step(0.0, Measurement(state=x), preview(d, scenario.model.sample_time))
        pred = prediction(d)
        D0, D1 = iteration_matrices(d, pred)
        e = -pred.Phi @ deviation(scenario.train, x, 60.0)
        np.testing.assert_allclose(ctl._plan, nash_gain(D0, D1) @ e, atol=1e-6)

    def test_cooperative_equals_centralised(self, book, rng):
        """Cooperative DMPC converges to centralised MPC's inputs."""
        scenario, d = book
        T = scenario.model.sample_time
        x = perturbed_state(scenario.train, 60.0, rng)
        coop = make_mpc(scenario.train, d, dt=T, strategy="cooperative", constraints=NONE,
                        max_iterations=2000, tolerance=1e-11)
        cent = make_mpc(scenario.train, d, dt=T, strategy="centralised", constraints=NONE)
        a = coop.step(0.0, Measurement(state=x), preview(d, T))
        b = cent.step(0.0, Measurement(state=x), preview(d, T))
        np.testing.assert_allclose(a.inputs / 1e3, b.inputs / 1e3, atol=1e-6)
        rho = np.max(np.abs(np.linalg.eigvals(cooperative_iteration(d)[0])))
        assert a.iterations < 2000 and rho < 1


def sparse_centralised(scenario, d, x_dev, u_ff, f_ff, lb, ub, u_prev, limits):
    """An independent, non-condensed formulation of constrained centralised MPC (CLARABEL)."""
    train = scenario.train
    n, P, M = train.n_vehicles, d.prediction_horizon, d.control_horizon
    nf = n - 1
    from trainctl.models import linearise
    Cf = np.asarray(linearise(train, 1.0, outputs=("force",)).C) / 1e3
    x = cp.Variable((d.A.shape[0], P + 1))
    u = cp.Variable((n, M))
    s = cp.Variable((nf, P), nonneg=True)
    cons = [x[:, 0] == x_dev]
    cost = 0
    for j in range(P):
        uj = u[:, min(j, M - 1)]
        cons.append(x[:, j + 1] == d.A @ x[:, j] + d.B @ uj)
        y = d.C @ x[:, j + 1]
        cost += cp.sum(cp.multiply(d.q, cp.square(y)))
        f = f_ff[j] + Cf @ x[:, j + 1]
        cons += [f <= limits["force"] + s[:, j], f >= -limits["force"] - s[:, j]]
    cost += 1e3 * cp.sum(s) + 0.5 * 1e2 * cp.sum_squares(s)
    for m in range(M):
        cost += cp.sum(cp.multiply(d.r, cp.square(u[:, m])))
        cons += [u_ff[m] + u[:, m] >= lb[m], u_ff[m] + u[:, m] <= ub[m]]
        prev = u_prev if m == 0 else u_ff[m - 1] + u[:, m - 1]
        cons += [cp.abs(u_ff[m] + u[:, m] - prev) <= limits["rate"]]
    prob = cp.Problem(cp.Minimize(cost), cons)
    prob.solve(solver=cp.CLARABEL)
    assert prob.status == cp.OPTIMAL
    return u_ff[0] + u.value[:, 0]


class TestConstrained:
    def test_centralised_equals_independent_formulation(self, fast, rng):
        """Constrained centralised MPC = sparse formulation by a second solver (≤ 1e-5 kN)."""
        scenario, d = fast
        train, T = scenario.train, scenario.model.sample_time
        cons = MPCConstraints(rate_limit=3e3, coupler_force_limit=6e3)
        for trial in range(4):
            ctl = make_mpc(train, d, dt=T, strategy="centralised", constraints=cons)
            v0, acc = 30.0 + 10 * trial, 0.1  # cruise traction stays inside the power limit
            x = perturbed_state(train, v0, rng, dv=1.0)
            ref = preview(d, T, v0=v0, accel=acc)
            rec = ctl.step(0.0, Measurement(state=x), ref)
            ffs = [equilibrium(train, v, acceleration=acc) for v in ref.speed]
            u_ff = np.array([e.inputs for e in ffs]) / 1e3
            f_ff = np.array([e.coupler_forces for e in ffs])[1:] / 1e3
            lb, ub = ctl._bounds(ref.speed[: d.control_horizon])
            x_dev = np.concatenate([x[:4] - v0, x[4:7] - ffs[0].elongations])
            expected = sparse_centralised(
                scenario, d, x_dev, u_ff, f_ff, lb.reshape(-1, 4), ub.reshape(-1, 4),
                u_ff[0], {"rate": 3.0, "force": 6.0})
            assert rec.status == "optimal"
            np.testing.assert_allclose(rec.inputs / 1e3, expected, atol=1e-5)

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_fast_path_equals_cvxpy_path_over_a_closed_loop(self, fast, rng):
        """Fast path and plain cvxpy re-solve give the same inputs over 30 steps (≤ 1e-6 kN)."""
        scenario, d = fast
        train, T = scenario.train, scenario.model.sample_time
        cons = MPCConstraints(rate_limit=5e3, coupler_force_limit=20e3)
        ctls = [make_mpc(train, d, dt=T, strategy="ndmpc", constraints=cons, path=p)
                for p in ("fast", "cvxpy")]
        sysd = d  # the design model is the plant here (deviation dynamics, kN)
        x = perturbed_state(train, 50.0, rng, dv=1.0)
        x_dev = deviation(train, x, 50.0)
        eq = equilibrium(train, 50.0)
        for k in range(30):
            state = np.concatenate([50.0 + x_dev[:4], eq.elongations + x_dev[4:], [0.0]])
            recs = [c.step(k * T, Measurement(state=state), preview(d, T, v0=50.0)) for c in ctls]
            np.testing.assert_allclose(recs[0].inputs / 1e3, recs[1].inputs / 1e3, atol=1e-6)
            x_dev = sysd.A @ x_dev + sysd.B @ ((recs[0].inputs - eq.inputs) / 1e3)


_BOUNDED: dict[str, object] = {}


def _bounded_controller(strategy):
    """One controller per strategy for the property test (QPs are built once, then reset)."""
    if strategy not in _BOUNDED:
        scenario = load_scenario("crh2-dmpc-well-sampled")
        d = build_design(scenario).family("mpc").mpc
        _BOUNDED[strategy] = make_mpc(
            scenario.train, d, dt=scenario.model.sample_time, strategy=strategy,
            max_iterations=20, constraints=MPCConstraints(rate_limit=2e3, coupler_force_limit=50e3))
    ctl = _BOUNDED[strategy]
    ctl.reset()
    return ctl


@settings(deadline=None, max_examples=15)
@given(dv=st.floats(-3.0, 3.0), v0=st.floats(25.0, 80.0), accel=st.floats(-0.3, 0.3),
       strategy=st.sampled_from(["centralised", "ndmpc", "decentralised"]))
def test_inputs_respect_envelope_and_rate_bounds(dv, v0, accel, strategy):
    """Every solved step's inputs lie in the envelope at the reference speed and within the
    rate limit of the last input; a fallback lies in the actuators' envelope at the measured
    speed and within the rate limit of the input applied where that envelope allows."""
    ctl = _bounded_controller(strategy)
    d, train, T, rate = ctl.design, ctl.train, ctl.dt, 2.0
    x = equilibrium(train, v0).state(position=0.0)
    x[:4] += dv
    low, high = (b / 1e3 for b in EnvelopeBounds(train, enabled=True).at(x[:4]))  # [kN]
    prev = applied = None
    for k in range(5):
        ref = preview(d, T, v0=v0 + accel * k * T, accel=accel)
        rec = ctl.step(k * T, Measurement(state=x), ref)
        u = rec.inputs / 1e3
        if rec.fallback:
            assert np.all(u >= low - 1e-4) and np.all(u <= high + 1e-4)
            if applied is not None:
                lo, hi = np.maximum(applied - rate, low), np.minimum(applied + rate, high)
                meets = lo <= hi
                assert np.all(u[meets] >= lo[meets] - 1e-4)
                assert np.all(u[meets] <= hi[meets] + 1e-4)
                nearest = np.where(applied + rate < low, low, high)
                assert np.allclose(u[~meets], nearest[~meets], atol=1e-4)
        else:
            lb, ub = ctl._bounds(ref.speed[:1])
            assert np.all(u >= lb - 1e-4) and np.all(u <= ub + 1e-4)
            if prev is not None:
                assert np.max(np.abs(u - prev)) <= rate * (1 + 1e-4) + 1e-6
        prev, applied = u, np.clip(u, low, high)


def test_infeasible_step_is_recorded_and_falls_back(fast):
    """A bound that drops faster than the rate limit allows: status recorded, fallback used."""
    scenario, d = fast
    train, T = scenario.train, scenario.model.sample_time
    ctl = make_mpc(train, d, dt=T, strategy="ndmpc",
                   constraints=MPCConstraints(rate_limit=100.0), max_iterations=5)
    x = equilibrium(train, 20.0).state(position=0.0)
    first = ctl.step(0.0, Measurement(state=x), preview(d, T, v0=20.0, accel=0.6))
    # Jump the reference to 83 m/s: the power limit cuts the bound from ~60 to 14.4 kN.
    second = ctl.step(T, Measurement(state=x), preview(d, T, v0=83.0))
    assert second.status == "infeasible"
    assert second.fallback == "shifted plan"
    assert np.all(np.isfinite(second.inputs))
    assert first.status in ("optimal", "max_iterations")
    assert math.isfinite(second.solve_time)


def test_force_steps_select_the_bounded_prediction_steps(fast):
    """Bounding forces at k of the P steps gives k rows per adjacent coupler in each QP."""
    scenario, d = fast
    steps = (1, 2, 10, 40)
    ctl = make_mpc(scenario.train, d, dt=scenario.model.sample_time, strategy="ndmpc",
                   constraints=MPCConstraints(coupler_force_limit=500e3, force_steps=steps))
    assert [b.qp.ns for b in ctl.blocks] == [4, 8, 8, 4]  # end coaches have one coupler
    full = make_mpc(scenario.train, d, dt=scenario.model.sample_time, strategy="centralised",
                    constraints=MPCConstraints(coupler_force_limit=500e3))
    assert full.blocks[0].qp.ns == 3 * d.prediction_horizon


def _random_qp_data(rng, nz, nh, ns, infeasible=False):
    """Random QP data for ParametricQP.solve (some infinite bounds, optionally infeasible)."""
    g = rng.normal(size=nz)
    lb, ub = -rng.uniform(0.5, 2.0, nh), rng.uniform(0.5, 2.0, nh)
    lb[rng.random(nh) < 0.2] = -np.inf
    ub[rng.random(nh) < 0.2] = np.inf
    if infeasible:
        lb[0], ub[0] = 1.0, -1.0
    hl, hu = -rng.uniform(0.0, 0.5, ns), rng.uniform(0.0, 0.5, ns)
    return g, lb, ub, hl, hu


class TestOSQPRoutes:
    """The fast path calls OSQP's compiled solver directly (fastqp.osqp_runner)."""

    @staticmethod
    def _pair(rng, nz=6, nh=9, ns=4):
        A = rng.normal(size=(nz, nz))
        H = A @ A.T + 0.1 * np.eye(nz)
        C, F = rng.normal(size=(nh, nz)), rng.normal(size=(ns, nz))
        internal = ParametricQP(H, C, F, name="internal")
        public = ParametricQP(H, C, F, name="public")
        assert public.fast_path is not None
        public.fast_path.use_public_route()
        return internal, public

    def test_internal_route_equals_public_route(self, rng):
        """Same data through both routes: identical solutions, statuses and iterations."""
        statuses = set()
        for trial in range(4):
            internal, public = self._pair(rng, nz=4 + trial, nh=2 * (4 + trial), ns=trial)
            assert public.fast_path is not None and public.fast_path.route == "public"
            for k in range(6):  # a warm-started sequence, as in a closed loop
                data = _random_qp_data(rng, internal.nz, internal.nh, internal.ns,
                                       infeasible=k == 4)
                a, b = internal.solve(*data), public.solve(*data)
                statuses.add(a.status)
                assert (a.status, a.iterations) == (b.status, b.iterations)
                np.testing.assert_array_equal(a.z, b.z)
                np.testing.assert_array_equal(a.slack, b.slack)
                if a.status == "optimal":
                    ref = internal.solve(*data, path="cvxpy")
                    np.testing.assert_allclose(a.z, ref.z, atol=1e-4)
        assert {"optimal", "infeasible"} <= statuses

    def test_installed_osqp_takes_the_internal_route(self, rng):
        """Guards the speed-up: fails if an OSQP release no longer offers the internals.

        Results stay right then (the public update/solve are used); adapt
        ``osqp_runner`` to the new interface to get the speed back.
        """
        internal, _ = self._pair(rng)
        assert internal.fast_path is not None and internal.fast_path.route == "internal"


def test_stock_envelopes_give_the_per_vehicle_bounds(fast):
    """The broadcast envelope evaluation equals each vehicle's traction/braking_limit."""
    import dataclasses

    from trainctl.models.vehicle import TractionEnvelope

    class Envelope(TractionEnvelope):
        """A subclass: the controller must call its methods one vehicle at a time."""

    scenario, d = fast
    speeds = np.array([0.0, 5.0, 30.0, 60.0, 83.0])
    trains = [scenario.train]
    vehicles = [dataclasses.replace(v, envelope=Envelope(**dataclasses.asdict(v.envelope)))
                for v in scenario.train.vehicles]
    trains.append(dataclasses.replace(scenario.train, vehicles=tuple(vehicles)))
    for train in trains:
        ctl = make_mpc(train, d, dt=scenario.model.sample_time, strategy="centralised")
        lb, ub = ctl._bounds(speeds)
        up = np.column_stack([v.envelope.traction_limit(speeds, mass=v.mass)
                              for v in train.vehicles])
        down = np.column_stack([v.envelope.braking_limit(speeds, mass=v.mass)
                                for v in train.vehicles])
        np.testing.assert_array_equal(ub, up.ravel() / 1e3)
        np.testing.assert_array_equal(lb, -down.ravel() / 1e3)
    assert ctl._input_bounds.envelopes is None  # the subclass took the per-vehicle path
