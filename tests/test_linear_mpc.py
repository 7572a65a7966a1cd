"""Tests of the MPC core (make_linear_mpc) against pinned cases and independent formulations."""

from __future__ import annotations

import re

import control as ct
import cvxpy as cp
import numpy as np
import pytest

from trainctl.controllers.base import Controller, Measurement
from trainctl.controllers.mpc import MPCConstraints, MPCController, make_linear_mpc, make_mpc
from trainctl.controllers.mpc.theory.mpc import MPCDesign
from trainctl.design import build_design
from trainctl.exceptions import DimensionError, ModelError
from trainctl.models import equilibrium, virtual_formation
from trainctl.scenario import load_scenario

PATHS = ["fast", "cvxpy"]

# A two-state, two-input plant: a damped oscillator driven by two actuators.
A2 = np.array([[0.9, 0.4], [-0.3, 0.8]])
B2 = np.array([[0.5, 0.1], [0.2, 0.6]])
Q_FULL = np.array([[2.0, 0.5], [0.5, 1.0]])
R_FULL = np.array([[1.0, 0.6], [0.6, 0.5]])  # not diagonal; positive definite
QF = np.array([[4.0, -1.0], [-1.0, 3.0]])


def mpt3_system():
    """The MPT3 regulation problem's double integrator (python-control's optimal_test)."""
    return ct.ss([[1, 1], [0, 1]], [[1], [0.5]], np.eye(2), 0, dt=1)


def independent(A, B, C, x0, *, P, M, Q, R, Qf=None, form="u", u_prev=None, ref=None,
                bounds=None, soft=None):
    """An independent, non-condensed formulation: explicit states, CLARABEL.

    bounds: {"u"|"du"|"x"|"y": (lo, hi)}; soft: {group: (w1, w2)} (slack penalties).
    Returns (inputs (P, nu), cost).
    """
    nx, nu = B.shape
    bounds, soft = bounds or {}, soft or {}
    x = cp.Variable((nx, P + 1))
    u = cp.Variable((nu, P))
    up = np.zeros(nu) if u_prev is None else np.asarray(u_prev, float)
    ref = np.zeros((P, C.shape[0])) if ref is None else ref
    cons = [x[:, 0] == x0]
    cost = 0
    for j in range(P):
        cons.append(x[:, j + 1] == A @ x[:, j] + B @ u[:, j])
        if j >= M:
            cons.append(u[:, j] == u[:, M - 1])
        err = C @ x[:, j + 1] - ref[j]
        cost += cp.quad_form(err, Q)
    for m in range(M):
        move = u[:, m] - (up if m == 0 else u[:, m - 1])
        cost += cp.quad_form(u[:, m] if form == "u" else move, R)
    if Qf is not None:
        cost += cp.quad_form(x[:, P], Qf)
    quantities = {"u": [u[:, m] for m in range(M)],
                  "du": [u[:, m] - (up if m == 0 else u[:, m - 1]) for m in range(M)],
                  "x": [x[:, j + 1] for j in range(P)],
                  "y": [C @ x[:, j + 1] for j in range(P)]}
    for key, (lo, hi) in bounds.items():
        for q in quantities[key]:
            if key in soft:
                s = cp.Variable(q.shape[0], nonneg=True)
                w1, w2 = soft[key]
                cost += w1 * cp.sum(s) + 0.5 * w2 * cp.sum_squares(s)
                cons += [q >= lo - s, q <= hi + s]
            else:
                cons += [q >= lo, q <= hi]
    prob = cp.Problem(cp.Minimize(cost), cons)
    prob.solve(solver=cp.CLARABEL)
    assert prob.status == cp.OPTIMAL
    return u.value.T, prob.value


class TestMPT3:
    @pytest.mark.parametrize("path", PATHS)
    def test_regulation_problem_through_the_public_api(self, path):
        """MPT3 regulation problem as pinned by python-control: u and J = 32.4898."""
        mpc = make_linear_mpc(mpt3_system(), Q=np.eye(2), R=1, prediction_horizon=4,
                              u_min=-1, u_max=1, x_min=-5, x_max=5, path=path)
        x0 = np.array([4.0, 0.0])
        sol = mpc.solve(x0)
        assert sol.status == "optimal"
        u = np.append(sol.inputs[:, 0], 0.0)  # the input at the last time point has no effect
        np.testing.assert_allclose(u, [-1, -1, 0.1393, 0.3361, 0], atol=1e-4)
        # python-control and MPT3 also count the (constant) stage cost of x(0).
        assert sol.cost + x0 @ x0 == pytest.approx(32.4898, abs=1e-4)
        np.testing.assert_allclose(sol.first_move, sol.inputs[0])
        np.testing.assert_allclose(sol.states[0], x0)
        assert np.all(np.abs(sol.states) <= 5 + 1e-6)


class TestIndependentFormulation:
    @pytest.mark.parametrize("path", PATHS)
    def test_state_bounds_terminal_weight_full_R(self, path, rng):
        """Full Q, non-diagonal R, terminal weight, active state bounds: the plan of CLARABEL."""
        C = np.array([[1.0, 0.0], [0.5, 1.0]])
        sysd = ct.ss(A2, B2, C, 0, dt=0.1)
        kw = {"P": 8, "M": 5, "Q": Q_FULL, "R": R_FULL, "Qf": QF}
        mpc = make_linear_mpc(sysd, Q=Q_FULL, R=R_FULL, prediction_horizon=8, control_horizon=5,
                              terminal_weight=QF, u_min=[-1.0, -2.0], u_max=[1.5, 2.0],
                              x_min=[-0.5, -np.inf], x_max=[3.0, 0.4], path=path)
        for x0 in (np.array([-1.0, 1.5]), np.array([2.0, -1.0]), rng.normal(size=2)):
            sol = mpc.solve(x0)
            expected, cost = independent(
                A2, B2, C, x0, **kw, bounds={"u": ([-1.0, -2.0], [1.5, 2.0]),
                                             "x": ([-0.5, -np.inf], [3.0, 0.4])})
            assert sol.status == "optimal"
            np.testing.assert_allclose(sol.inputs, expected, atol=1e-5)
            assert sol.cost == pytest.approx(cost, rel=1e-5, abs=1e-6)
            if x0[1] == 1.5:  # the bound x_2 <= 0.4 is active at the first step
                assert sol.states[1, 1] == pytest.approx(0.4, abs=1e-5)

    @pytest.mark.parametrize("path", PATHS)
    def test_infeasible_problem_reports_no_solution(self, path):
        """A state the hard bounds cannot recover from: status infeasible, NaN plan and cost."""
        mpc = make_linear_mpc(ct.ss(A2, B2, np.eye(2), 0, dt=0.1), Q=1.0, R=1.0,
                              prediction_horizon=4, u_min=-1.0, u_max=1.0, x_min=-0.5, path=path)
        sol = mpc.solve([-2.0, 0.3])
        assert sol.status == "infeasible"
        assert np.all(np.isnan(sol.inputs)) and np.isnan(sol.cost)

    @pytest.mark.parametrize("path", PATHS)
    def test_du_form_with_output_and_rate_bounds(self, path):
        """Δu-form, rate and output bounds and a reference: the plan of CLARABEL."""
        C = np.array([[1.0, 1.0]])
        sysd = ct.ss(A2, B2, C, 0, dt=0.1)
        ref = np.linspace(1.0, 2.0, 6)[:, None]
        u_prev = np.array([0.2, -0.1])
        mpc = make_linear_mpc(sysd, Q=3.0, R=R_FULL, prediction_horizon=6, control_horizon=3,
                              form="du", du_max=[0.3, 0.2], y_min=-1.0, y_max=1.6, path=path)
        sol = mpc.solve([0.5, 0.0], u_prev=u_prev, reference=ref)
        expected, cost = independent(A2, B2, C, np.array([0.5, 0.0]), P=6, M=3, Q=np.eye(1) * 3,
                                     R=R_FULL, form="du", u_prev=u_prev, ref=ref,
                                     bounds={"du": (-np.array([0.3, 0.2]), [0.3, 0.2]),
                                             "y": (-1.0, 1.6)})
        assert sol.status == "optimal"
        np.testing.assert_allclose(sol.inputs, expected, atol=1e-5)
        assert sol.cost == pytest.approx(cost, rel=1e-5)
        assert np.max(sol.outputs[1:]) == pytest.approx(1.6, abs=1e-5)  # the output bound binds
        moves = np.diff(np.vstack([u_prev, sol.inputs[:3]]), axis=0)
        np.testing.assert_allclose(sol.plan, moves, atol=1e-9)

    @pytest.mark.parametrize("path", PATHS)
    def test_soft_bounds_equal_the_penalised_formulation(self, path):
        """Soft state and input-rate bounds = slacks with w1 Σs + ½ w2 Σs² (CLARABEL)."""
        sysd = ct.ss(A2, B2, np.eye(2), 0, dt=0.1)
        mpc = make_linear_mpc(sysd, Q=np.eye(2), R=0.1, prediction_horizon=5, x_max=[0.5, 0.5],
                              du_max=0.5, soft={"x": (2.0, 10.0), "du": True}, path=path)
        x0, u_prev = np.array([2.0, 1.0]), np.zeros(2)
        sol = mpc.solve(x0, u_prev=u_prev)
        expected, cost = independent(A2, B2, np.eye(2), x0, P=5, M=5, Q=np.eye(2),
                                     R=0.1 * np.eye(2), u_prev=u_prev,
                                     bounds={"x": (-np.inf, [0.5, 0.5]), "du": (-0.5, 0.5)},
                                     soft={"x": (2.0, 10.0), "du": (1e3, 1e2)})
        assert sol.status == "optimal"
        assert sol.slack.max() > 1e-3  # the state bound is violated, at a price
        np.testing.assert_allclose(sol.inputs, expected, atol=1e-5)
        assert sol.cost == pytest.approx(cost, rel=1e-5)


class TestTrainMPCIsTheCore:
    def test_unconstrained_centralised_plan_equals_the_core(self, rng):
        """The train MPC's centralised plan = the core's on the design model (no bounds)."""
        scenario = load_scenario("crh2-dmpc")
        train, d = scenario.train, build_design(scenario).family("mpc").mpc
        T = scenario.model.sample_time
        ctl = make_mpc(train, d, dt=T, strategy="centralised",
                       constraints=MPCConstraints(input_bounds=False))
        core = make_linear_mpc(ct.ss(d.A, d.B, d.C, 0, dt=T), Q=d.q, R=d.r,
                               prediction_horizon=d.prediction_horizon,
                               control_horizon=d.control_horizon, form=d.form)
        eq = equilibrium(train, 60.0)
        x = eq.state(position=0.0)
        x[:4] += rng.normal(scale=0.3, size=4)
        times = T * np.arange(d.prediction_horizon + 1)
        from trainctl.controllers.base import ReferencePreview
        ctl.step(0.0, Measurement(state=x), ReferencePreview(
            times=times, speed=np.full(times.size, 60.0), acceleration=np.zeros(times.size)))
        x_dev = np.concatenate([x[:4] - 60.0, x[4:7] - eq.elongations])
        sol = core.solve(x_dev, u_prev=np.zeros(4))  # ũ(k-1) = 0 at the first step
        np.testing.assert_allclose(ctl._plan, sol.plan.ravel(), atol=1e-6)


class TestController:
    def test_adapter_follows_the_protocol_and_regulates(self):
        """The adapter is a Controller; in closed loop it keeps the bounds and regulates."""
        sysd = mpt3_system()
        mpc = make_linear_mpc(sysd, Q=np.eye(2), R=1, prediction_horizon=4, u_min=-1, u_max=1,
                              x_min=-5, x_max=5, du_max=0.8)
        ctl = mpc.controller()
        assert isinstance(ctl, Controller) and ctl.dt == 1.0
        x, prev = np.array([4.0, 0.0]), np.zeros(1)
        for k in range(25):
            rec = ctl.step(float(k), Measurement(state=x), None)
            assert rec.status == "optimal" and abs(rec.inputs[0]) <= 1 + 1e-6
            assert abs(rec.inputs[0] - prev[0]) <= 0.8 + 1e-6
            prev = rec.inputs
            x = sysd.A @ x + sysd.B @ rec.inputs
        assert np.linalg.norm(x) < 1e-2

    def test_infeasible_step_falls_back_to_the_shifted_plan(self):
        """A state outside the hard bounds: status 'infeasible', the last plan's next input."""
        mpc = make_linear_mpc(mpt3_system(), Q=np.eye(2), R=1, prediction_horizon=4, u_min=-1,
                              u_max=1, x_min=-5, x_max=5)
        ctl = mpc.controller()
        good = ctl.step(0.0, Measurement(state=np.array([4.0, 0.0])), None)
        bad = ctl.step(1.0, Measurement(state=np.array([40.0, 9.0])), None)
        assert good.status == "optimal"
        assert (bad.status, bad.fallback) == ("infeasible", "shifted plan")
        plan = mpc.solve([4.0, 0.0]).inputs
        np.testing.assert_allclose(bad.inputs, plan[1], atol=1e-6)


def _mpc(**kw):
    args = {"Q": np.eye(2), "R": 1.0, "prediction_horizon": 4}
    args.update(kw)
    sysd = args.pop("sysd", mpt3_system())
    return make_linear_mpc(sysd, **args)


class TestBadInputs:
    @pytest.mark.parametrize(("kw", "error", "match"), [
        ({"Q": np.eye(3)}, DimensionError,
         "'Q' weights the 2 outputs and must be an (2, 2) matrix, a length-2 diagonal or a "
         "scalar (got shape (3, 3))"),
        ({"R": np.ones((1, 2))}, DimensionError, "'R' weights the 1 inputs"),
        ({"terminal_weight": np.eye(3)}, DimensionError, "'terminal_weight' weights the 2 states"),
        ({"u_min": [-1.0, -1.0]}, DimensionError,
         "'u_min' bounds the 1 inputs and must be a scalar or a length-1 vector (got shape (2,))"),
        ({"x_max": np.ones((2, 2))}, DimensionError, "'x_max' bounds the 2 states"),
        ({"Q": [[1.0, 2.0], [2.0, 1.0]]}, ModelError,
         "'Q' must be positive semidefinite (got smallest eigenvalue -1)"),
        ({"R": -1.0}, ModelError, "'R' must be positive semidefinite"),
        ({"Q": [[1.0, 0.5], [0.0, 1.0]]}, ModelError, "'Q' must be symmetric"),
        ({"control_horizon": 5}, ModelError,
         "'control_horizon' must be an int with 1 <= M <= P = 4 (got M = 5)"),
        ({"prediction_horizon": 0}, ModelError, "'prediction_horizon' must be an int >= 1"),
        ({"prediction_horizon": 2.5}, ModelError, "'prediction_horizon' must be an int"),
        ({"form": "delta"}, ModelError, "'form' must be one of ('u', 'du')"),
        ({"u_min": 1.0, "u_max": -1.0}, ModelError, "'u_min' must not exceed 'u_max'"),
        ({"du_max": -0.1}, ModelError, "'du_max' must be >= 0"),
        ({"soft": {"z": True}}, ModelError, "the keys of 'soft' must be among"),
        ({"soft": {"x": True}}, ModelError, "soft['x'] is given but no x bound is"),
        ({"x_max": 5.0, "soft": {"x": (1.0, 0.0)}}, ModelError, "soft['x'] must be True"),
        ({"path": "osqp"}, ModelError, "'path' must be one of ('fast', 'cvxpy')"),
        ({"sysd": ct.ss([[0, 1], [0, 0]], [[0], [1]], np.eye(2), 0)}, ModelError,
         "'sysd' must be discrete-time with a sample time dt > 0 (got dt = 0, a continuous-time "
         "system)"),
        ({"sysd": ct.ss([[1, 1], [0, 1]], [[1], [0.5]], np.eye(2), [[1], [0]], dt=1)},
         ModelError, "'sysd' must have no direct feedthrough, D = 0"),
    ])
    def test_make_linear_mpc_rejects(self, kw, error, match):
        """Each bad argument raises a trainctl error naming it, what must hold and what it got."""
        with pytest.raises(error, match=re.escape(f"make_linear_mpc: {match}")):
            _mpc(**kw)

    def test_a_matrix_is_not_a_system(self):
        """A bare matrix is a TypeError with the fix: control.ss(A, B, C, 0, dt=T)."""
        with pytest.raises(TypeError, match=re.escape("control.ss(A, B, C, 0, dt=T)")):
            make_linear_mpc(np.eye(2), Q=1, R=1, prediction_horizon=2)

    @pytest.mark.parametrize(("kw", "error", "match"), [
        ({"x": [1.0, 2.0, 3.0]}, DimensionError,
         "'x' must be a vector of the 2 states (got shape (3,))"),
        ({"x": [1.0, np.nan]}, ModelError, "'x' must not contain NaN"),
        ({"x": [1.0, 0.0], "reference": np.ones((3, 2))}, DimensionError,
         "'reference' must have length ny = 2 or shape (P, ny) = (4, 2) (got shape (3, 2))"),
        ({"x": [1.0, 0.0], "u_prev": [0.0, 0.0]}, DimensionError,
         "'u_prev' must be a vector of the 1 inputs"),
    ])
    def test_solve_rejects(self, kw, error, match):
        """solve() checks the state, reference and previous input."""
        mpc = _mpc()
        with pytest.raises(error, match=re.escape(f"mpc.solve: {match}")):
            mpc.solve(**kw)

    def test_du_form_needs_the_previous_input(self):
        """The Δu-form without u_prev says which input it needs and how to start."""
        mpc = _mpc(form="du")
        with pytest.raises(ModelError, match=re.escape("'u_prev', the input applied at the "
                                                       "previous sample, is required")):
            mpc.solve([1.0, 0.0])

    def test_column_vectors_are_accepted(self):
        """A state given as a column (nx, 1) is the same state."""
        mpc = _mpc()
        a, b = mpc.solve([[4.0], [0.0]]), mpc.solve([4.0, 0.0])
        np.testing.assert_allclose(a.inputs, b.inputs, atol=1e-9)


class TestTrainMPCPointsToTheCore:
    @staticmethod
    def _design():
        return MPCDesign(A=np.array([[1.0, 1.0], [0.0, 1.0]]), B=np.array([[1.0], [0.5]]),
                         C=np.eye(2), prediction_horizon=4, control_horizon=2, form="u",
                         q=np.ones(2), r=np.ones(1), output_owner=(0, 0),
                         neighbourhoods=((0,),))

    def test_make_mpc_on_a_non_train_design(self):
        """make_mpc with a 2-state design for a 1-vehicle train names make_linear_mpc."""
        with pytest.raises(ModelError, match=re.escape(
                "make_mpc: the train MPC needs a design model of this train's deviation "
                "dynamics, 1 state(s) [v (n = 1); delta (n-1)] and 1 input(s), one force per "
                "vehicle (got 2 state(s) and 1 input(s)). For an MPC on any other discrete "
                "(A, B) model use trainctl.controllers.mpc.make_linear_mpc(")) as info:
            make_mpc(virtual_formation(n_trains=1), self._design(), dt=1.0)
        assert "dummy" not in str(info.value)  # not the position state's hint

    def test_mpc_controller_fails_when_built_not_in_step(self):
        """MPCController refuses the design at construction, not with a numpy error in step()."""
        with pytest.raises(ModelError, match=re.escape("MPCController: the train MPC needs")):
            MPCController(virtual_formation(n_trains=1), self._design(), np.zeros((0, 2)),
                          dt=1.0, strategy="centralised", constraints=MPCConstraints())

    def test_design_with_the_dummy_state_gets_that_hint(self):
        """A train design with the trailing dummy state still gets the dummy-state hint."""
        from trainctl.models import discretise, linearise

        scenario = load_scenario("crh2-dmpc")
        sysd = discretise(linearise(scenario.train, 60.0, dummy_state=True), 1.0)
        d = MPCDesign(A=sysd.A, B=sysd.B, C=np.eye(4, 8), prediction_horizon=3,
                      control_horizon=2, form="u", q=np.ones(4), r=np.ones(4),
                      output_owner=(0, 1, 2, 3), neighbourhoods=((0,), (1,), (2,), (3,)))
        with pytest.raises(ModelError, match=re.escape("build the design without it")):
            make_mpc(scenario.train, d, dt=1.0)
