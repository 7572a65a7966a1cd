# The dense QP path (DAQP) against the OSQP fast path and an independent CLARABEL solve.
"""DAQP on the identified QP data: same solutions, same statuses, warm start = cold start."""

from __future__ import annotations

import functools

import cvxpy as cp
import numpy as np
import pytest

from trainctl.controllers.base import Measurement, ReferencePreview
from trainctl.controllers.mpc import MPCConstraints, make_mpc
from trainctl.controllers.mpc.qp.dense import FastDAQP
from trainctl.controllers.mpc.qp.parametric import (
    DAQP_MAX_DECISIONS,
    QP_SOLVERS,
    ParametricQP,
    choose_solver,
)
from trainctl.controllers.mpc.qp.status import from_daqp
from trainctl.controllers.mpc.settings import QP_SOLVERS as SETTINGS_QP_SOLVERS
from trainctl.design import build_design
from trainctl.exceptions import ModelError
from trainctl.models import equilibrium
from trainctl.scenario import load_scenario

TOL_KN = 1e-6          # solutions agree to 1e-6 kN (1e-3 N)
STRATEGIES = ("centralised", "decentralised", "ndmpc", "cooperative")
SCENARIOS = ("crh2-dmpc", "crh2-dmpc-well-sampled")
# Tight enough that rate limits and envelope bounds are active and the coupler-force
# bound is violated (soft rows with positive slack) from the random states.
LIMITS = MPCConstraints(rate_limit=5e3, coupler_force_limit=5e3)
SPREAD, FORCE = 0.002, 5e3


@functools.cache
def scenario_design(name: str):
    scenario = load_scenario(name)
    return scenario, build_design(scenario).family("mpc").mpc


def preview(d, dt: float, v0: float) -> ReferencePreview:
    times = dt * np.arange(d.prediction_horizon + 1)
    return ReferencePreview(times=times, speed=np.full(times.size, v0),
                            acceleration=np.zeros(times.size))


def random_states(train, rng: np.random.Generator, count: int, v0: float = 50.0):
    """States about the equilibrium at v0.

    A common speed error of about 1 m/s, relative speeds of about ``SPREAD``
    [m/s] and coupler-force errors of about ``FORCE`` [N] (a relative speed
    of 1 m/s would stretch a coupler by metres over the horizon).
    """
    eq = equilibrium(train, v0)
    n = train.n_vehicles
    k = 1.0488e7  # coupler stiffness [N/m]
    return [np.concatenate([v0 + rng.normal(0.0, 1.0) + rng.normal(0.0, SPREAD, n),
                            eq.elongations + rng.normal(0.0, FORCE / k, n - 1), [0.0]])
            for _ in range(count)]


class Log:
    """Records every block QP's data and the dense path's solution."""

    def __init__(self, ctl) -> None:
        self.entries: list[tuple[int, np.ndarray, object]] = []
        for index, block in enumerate(ctl.blocks):
            original = block.qp.solve_data

            def record(data, _orig=original, _i=index):
                sol = _orig(data)
                self.entries.append((_i, data.copy(), sol))
                return sol

            block.qp.solve_data = record


def clarabel(fast, data: np.ndarray) -> np.ndarray:
    """The QP min ½xᵀPx + qᵀx, l ≤ Ax ≤ u of the identified data, solved by CLARABEL."""
    q, lower, upper = fast.qlu(data)
    P, A = fast.P.toarray(), fast.Amat.toarray()
    x = cp.Variable(P.shape[0])
    cons = []
    up, lo = np.isfinite(upper), np.isfinite(lower)
    if up.any():
        cons.append(A[up] @ x <= upper[up])
    if lo.any():
        cons.append(A[lo] @ x >= lower[lo])
    prob = cp.Problem(cp.Minimize(0.5 * cp.quad_form(x, cp.psd_wrap(0.5 * (P + P.T))) + q @ x),
                      cons)
    prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-11, tol_gap_rel=1e-11, tol_feas=1e-11,
               tol_ktratio=1e-9)
    assert prob.status == "optimal"
    return np.asarray(x.value)


@pytest.fixture(scope="module", params=[(s, k) for s in SCENARIOS for k in STRATEGIES],
                ids=lambda p: f"{p[0]}-{p[1]}")
def solved(request):
    """A DAQP controller stepped from random states; every block QP's data and solution."""
    name, strategy = request.param
    scenario, d = scenario_design(name)
    dt = scenario.model.sample_time
    ctl = make_mpc(scenario.train, d, dt=dt, strategy=strategy, constraints=LIMITS,
                   tolerance=1e-4, qp_solver="daqp")
    log = Log(ctl)
    rng = np.random.default_rng(sum(map(ord, name + strategy)))
    for k, state in enumerate(random_states(scenario.train, rng, 4)):
        ctl.step(k * dt, Measurement(state=state), preview(d, dt, 50.0))
    return ctl, log.entries


class TestSameSolutions:
    def test_the_dense_path_is_used_with_soft_constraints(self, solved):
        ctl, entries = solved
        assert entries
        for block in ctl.blocks:
            assert block.qp.solver == "daqp" and block.qp.dense_path is not None
            assert block.qp.dense_path.soft, block.qp.dense_path.soft_reason

    def test_equal_to_the_osqp_fast_path(self, solved):
        """The OSQP fast path on the identical data gives the same decisions and slacks.

        Where the two differ by more than 1e-6 kN (OSQP stopped at its iteration
        limit, or its polished solution is off by about eps_rel times the data's
        size), the dense path agrees with CLARABEL (the worst ten cases are
        checked).
        """
        ctl, entries = solved
        apart = []
        for j, (i, data, sol) in enumerate(entries):
            ref = ctl.blocks[i].qp.fast_path.solve_vector(data)
            assert sol.status == "optimal"
            assert ref.status in ("optimal", "optimal_inaccurate", "max_iterations")
            gap = max(np.abs(sol.z - ref.z).max(), np.abs(sol.slack - ref.slack).max())
            if gap > TOL_KN:
                apart.append((gap, j))
        assert len(apart) <= max(2, 0.15 * len(entries))
        for _, j in sorted(apart, reverse=True)[:10]:
            i, data, sol = entries[j]
            fast = ctl.blocks[i].qp.fast_path
            x = clarabel(fast, data)
            np.testing.assert_allclose(sol.z, x[fast.z_index["z"]], rtol=0, atol=TOL_KN)

    def test_equal_to_clarabel(self, solved):
        """An independent interior-point solve of the same (P, q, A, l, u)."""
        ctl, entries = solved
        picks = np.random.default_rng(1).choice(len(entries), size=min(8, len(entries)),
                                                replace=False)
        for j in picks:
            i, data, sol = entries[j]
            fast = ctl.blocks[i].qp.fast_path
            x = clarabel(fast, data)
            np.testing.assert_allclose(sol.z, x[fast.z_index["z"]], rtol=0, atol=TOL_KN)
            np.testing.assert_allclose(sol.slack, x[fast.z_index["s"]], rtol=0, atol=TOL_KN)

    def test_constraints_are_active(self, solved):
        """The random states exercise the rows: soft violations and hard bounds at their limit."""
        ctl, entries = solved
        assert max(sol.slack.max(initial=0.0) for _, _, sol in entries) > 1e-3
        active = 0
        for i, data, sol in entries:
            dense = ctl.blocks[i].qp.dense_path
            lower, upper, _ = dense._bounds(data)
            x = np.zeros(dense.n_vars)
            x[dense._z_pos] = sol.z
            ax = np.concatenate([x[:dense.n_simple], dense.A @ x])[:dense._soft_first]
            hard_l, hard_u = lower[:dense._soft_first], upper[:dense._soft_first]
            active += int(np.sum(np.isclose(ax, hard_l, atol=1e-7) | np.isclose(ax, hard_u,
                                                                                atol=1e-7)))
        assert active > 0


class TestController:
    def test_daqp_and_osqp_controllers_apply_the_same_inputs(self):
        """Closed loop of N-DMPC: the same forces to 1e-3 N and the same iteration counts."""
        scenario, d = scenario_design("crh2-dmpc-well-sampled")
        dt = scenario.model.sample_time
        limits = MPCConstraints(rate_limit=5e3, coupler_force_limit=50e3)
        ctls = {s: make_mpc(scenario.train, d, dt=dt, strategy="ndmpc", constraints=limits,
                            tolerance=1e-4, qp_solver=s) for s in ("osqp", "daqp")}
        eq = equilibrium(scenario.train, 50.0)
        n = scenario.train.n_vehicles
        for k, error in enumerate((1.0, 0.5, -0.8)):  # every coach fast or slow [m/s]
            state = np.concatenate([np.full(n, 50.0 + error), eq.elongations, [0.0]])
            recs = {s: c.step(k * dt, Measurement(state=state), preview(d, dt, 50.0))
                    for s, c in ctls.items()}
            np.testing.assert_allclose(recs["daqp"].inputs, recs["osqp"].inputs, rtol=0,
                                       atol=1e-3)
            assert recs["daqp"].status == recs["osqp"].status == "optimal"

    @pytest.mark.parametrize("solver", ["auto", "osqp", "daqp"])
    def test_the_scenario_key_reaches_every_qp(self, solver):
        """[controller] qp_solver builds the family's controller on that solver."""
        from trainctl.run.analysis import make_controller
        from trainctl.scenario import builtin_scenario_text, parse_scenario

        text = builtin_scenario_text("crh2-dmpc").replace(
            "[controller]\n", f'[controller]\nqp_solver = "{solver}"\n', 1)
        scenario = parse_scenario(text)
        ctl = make_controller(scenario, "ndmpc", build_design(scenario))
        expected = "osqp" if solver == "osqp" else "daqp"  # auto: 2 decisions per coach
        assert ctl.qp_solver == solver
        for block in ctl.blocks:
            assert block.qp.solver == expected
            assert (block.qp.dense_path is not None) == (expected == "daqp")

    def test_auto_takes_daqp_for_small_qps(self):
        assert choose_solver("auto", DAQP_MAX_DECISIONS) == "daqp"
        assert choose_solver("auto", DAQP_MAX_DECISIONS + 1) == "osqp"
        assert QP_SOLVERS == SETTINGS_QP_SOLVERS

    def test_an_unknown_solver_is_refused(self):
        with pytest.raises(ModelError, match="'solver' must be one of"):
            ParametricQP(np.eye(2), np.eye(2), np.zeros((0, 2)), solver="gurobi")
        scenario, d = scenario_design("crh2-dmpc")
        with pytest.raises(ModelError, match="'qp_solver' must be one of"):
            make_mpc(scenario.train, d, dt=scenario.model.sample_time, qp_solver="qpoases")


class TestLinearMPC:
    def test_the_core_on_daqp_equals_osqp(self):
        """The MPC core (make_linear_mpc) with qp_solver="daqp", soft state bounds active."""
        import control as ct

        from trainctl.controllers.mpc import make_linear_mpc

        sysd = ct.ss([[1, 1], [0, 1]], [[0.5], [1]], np.eye(2), 0, dt=1)
        kw = dict(Q=np.eye(2), R=0.1, prediction_horizon=8, u_min=-1, u_max=1, du_max=0.5,
                  form="du", x_min=[-5, -1], x_max=[5, 1], soft={"x": (10.0, 1.0)})
        mpcs = {s: make_linear_mpc(sysd, qp_solver=s, **kw) for s in ("osqp", "daqp")}
        qp = mpcs["daqp"].block.qp
        assert qp.dense_path.soft
        seen = []
        solve_data = qp.solve_data

        def record(data):
            seen.append(data.copy())
            return solve_data(data)

        qp.solve_data = record
        for x0 in ([4.0, 0.0], [-3.0, 1.5], [0.5, -2.0]):
            a, b = (mpcs[s].solve(x0, u_prev=[0.0]) for s in ("daqp", "osqp"))
            assert a.status == b.status == "optimal"
            x = clarabel(qp.fast_path, seen[-1])[qp.fast_path.z_index["z"]]
            # the same data on the dense path (a fresh workspace) and on the OSQP fast path
            z_dense = FastDAQP(qp.fast_path).solve_vector(seen[-1]).z
            z_osqp = mpcs["osqp"].block.qp.fast_path.solve_vector(seen[-1]).z
            np.testing.assert_allclose(z_dense, x, rtol=0, atol=TOL_KN)
            # OSQP agrees, or it is the one off CLARABEL (its polishing can fail: 1e-3 here)
            assert (np.abs(z_dense - z_osqp).max() <= TOL_KN
                    or np.abs(z_osqp - x).max() > TOL_KN)
            if np.abs(z_osqp - x).max() <= TOL_KN:
                np.testing.assert_allclose(a.inputs, b.inputs, rtol=0, atol=TOL_KN)
        with pytest.raises(ModelError, match="'qp_solver' must be one of"):
            make_linear_mpc(sysd, qp_solver="x", **kw)


def pair(H, C, F, **kw):
    """The same QP on both fast-path solvers."""
    return (ParametricQP(H, C, F, solver="osqp", **kw), ParametricQP(H, C, F, solver="daqp", **kw))


class TestStatuses:
    def test_exit_flags(self):
        assert [from_daqp(f) for f in (2, 1, -1, -2, -3, -4, -5, -6, -7, -8, 99)] == [
            "optimal", "optimal", "infeasible", "error", "error", "max_iterations", "error",
            "error", "max_iterations", "error", "error"]

    def test_infeasible_across_rows(self):
        """z0 + z1 <= -1 with z >= 0: DAQP's own infeasibility detection, as OSQP's."""
        C = np.array([[1.0, 1.0], [1.0, 0.0], [0.0, 1.0]])
        for qp in pair(np.eye(2), C, np.zeros((0, 2))):
            sol = qp.solve(np.zeros(2), np.array([-np.inf, 0.0, 0.0]),
                           np.array([-1.0, np.inf, np.inf]))
            assert sol.status == "infeasible", qp.solver

    def test_contradicting_bounds_of_one_row(self):
        """lb > ub on a hard row: infeasible on both solvers; the next solve is fine."""
        C = np.array([[1.0, -1.0], [1.0, 0.0]])
        for qp in pair(np.eye(2), C, np.ones((1, 2))):
            bad = qp.solve(np.zeros(2), np.array([1.0, -5.0]), np.array([0.5, 5.0]),
                           np.array([-1.0]), np.array([1.0]))
            assert bad.status == "infeasible", qp.solver
            good = qp.solve(np.array([1.0, -2.0]), np.array([-1.0, -5.0]), np.array([1.0, 5.0]),
                            np.array([-1.0]), np.array([1.0]))
            assert good.status == "optimal"
        osqp, daqp = pair(np.eye(2), C, np.ones((1, 2)))
        args = (np.array([1.0, -2.0]), np.array([-1.0, -5.0]), np.array([1.0, 5.0]),
                np.array([-1.0]), np.array([1.0]))
        np.testing.assert_allclose(daqp.solve(*args).z, osqp.solve(*args).z, atol=TOL_KN)

    def test_nan_data_is_an_error_on_both(self):
        for qp in pair(np.eye(2), np.eye(2), np.zeros((0, 2))):
            sol = qp.solve(np.array([np.nan, 0.0]), -np.ones(2), np.ones(2))
            assert sol.status == "error" and np.isnan(sol.z).all()

    def test_unconstrained(self):
        """No rows at all: solved by a Cholesky factor, as OSQP solves it."""
        H = np.array([[2.0, 0.5], [0.5, 1.0]])
        g = np.array([1.0, -3.0])
        for qp in pair(H, np.zeros((0, 2)), np.zeros((0, 2))):
            sol = qp.solve(g)
            assert sol.status == "optimal"
            np.testing.assert_allclose(sol.z, np.linalg.solve(H, -g), rtol=0, atol=TOL_KN)

    def test_iteration_limit(self):
        qp = ParametricQP(np.eye(3), np.eye(3), np.zeros((0, 3)), solver="osqp")
        dense = FastDAQP(qp.fast_path, settings={"iter_limit": 1})
        data = qp.fast_path.compose({"g": np.array([-5.0, 5.0, -5.0]), "lb": -np.ones(3),
                                     "ub": np.ones(3), "hl": np.zeros(0), "hu": np.zeros(0)})
        assert dense.solve_vector(data).status == "max_iterations"


class TestEqualityRows:
    def test_equalities_and_one_sided_rows(self):
        """A general cvxpy problem on FastOSQP: equality rows (DAQP sense 5), rows of one side."""
        import cvxpy as cvx

        from trainctl.controllers.mpc.qp.fast import FastOSQP

        rng = np.random.default_rng(7)
        M = rng.normal(size=(4, 4))
        z, p, b, cap = cvx.Variable(4), cvx.Parameter(4), cvx.Parameter(), cvx.Parameter(2)
        E = rng.normal(size=(2, 4))
        problem = cvx.Problem(cvx.Minimize(cvx.sum_squares(M @ z) + p @ z),
                              [cvx.sum(z) == b, E @ z <= cap, z >= -2])
        fast = FastOSQP(problem, {"p": p, "b": b, "cap": cap}, z, None, name="eq")
        dense = FastDAQP(fast)
        assert fast.n_eq >= 1 and 5 in dense._sense0  # (sum_squares adds equality rows too)
        for _ in range(5):
            values = {"p": rng.normal(size=4) * 5, "b": rng.normal(), "cap": rng.normal(size=2)}
            data = fast.compose(values)
            a, ref = dense.solve_vector(data), fast.solve_vector(data)
            x = clarabel(fast, data)
            assert a.status == ref.status == "optimal"
            np.testing.assert_allclose(a.z, x[fast.z_index["z"]], rtol=0, atol=TOL_KN)
            np.testing.assert_allclose(a.z, ref.z, rtol=0, atol=TOL_KN)
            assert abs(a.z.sum() - values["b"]) < 1e-9


class TestSoftRows:
    def random_qp(self, rng, nz=6, nh=4, ns=10):
        M = rng.normal(size=(nz, nz))
        H = M @ M.T + 0.1 * np.eye(nz)
        C = rng.normal(size=(nh, nz))
        F = rng.normal(size=(ns, nz)) * rng.uniform(0.1, 10.0, size=(ns, 1))
        return H, C, F

    @pytest.mark.parametrize("weights", [(1e3, 1e2), (0.0, 1.0), (5.0, 2.0),
                                         (np.linspace(0, 3, 10), np.linspace(1, 4, 10))])
    def test_soft_constraints_equal_the_slack_model(self, weights):
        """Violated soft rows: DAQP soft constraints = DAQP with slacks = OSQP = CLARABEL."""
        rng = np.random.default_rng(3)
        H, C, F = self.random_qp(rng)
        osqp, daqp = pair(H, C, F, soft_linear=weights[0], soft_quadratic=weights[1])
        assert daqp.dense_path.soft, daqp.dense_path.soft_reason
        slack_form = FastDAQP(osqp.fast_path, soft=False)
        assert not slack_form.soft and slack_form.soft_reason == "soft=False"
        violated = compared = 0
        push = 50.0 + 5.0 * np.max(weights[0])  # costs that outweigh the violation penalty
        for _ in range(10):
            g = rng.normal(size=6) * push
            args = (g, -np.full(4, 3.0), np.full(4, 3.0), -np.abs(rng.normal(size=10)),
                    np.abs(rng.normal(size=10)))
            a, b = daqp.solve(*args), osqp.solve(*args)
            data = osqp.fast_path.compose(dict(zip(("g", "lb", "ub", "hl", "hu"), args,
                                                   strict=True)))
            c = slack_form.solve_vector(data)
            x = clarabel(osqp.fast_path, data)
            # OSQP may stop at its iteration limit on these; compared where it solved.
            for sol in (b, c) if b.status == "optimal" else (c,):
                np.testing.assert_allclose(a.z, sol.z, rtol=0, atol=TOL_KN)
                np.testing.assert_allclose(a.slack, sol.slack, rtol=0, atol=TOL_KN)
            compared += b.status == "optimal"
            np.testing.assert_allclose(a.z, x[osqp.fast_path.z_index["z"]], rtol=0, atol=TOL_KN)
            # CLARABEL (interior point) places a slack at a kink of the penalty only to ~1e-5
            np.testing.assert_allclose(a.slack, x[osqp.fast_path.z_index["s"]], rtol=0,
                                       atol=1e-4)
            violated += int(a.slack.max() > 1e-3)
        assert violated >= 5 and compared >= 5

    def test_crossed_soft_bounds_take_the_slack_form(self):
        """hl > hu on a soft row: one shared slack, not DAQP's two; solved with the slacks."""
        rng = np.random.default_rng(4)
        H, C, F = self.random_qp(rng)
        osqp, daqp = pair(H, C, F)
        hl, hu = -np.ones(10), np.ones(10)
        hl[2], hu[2] = 0.5, -0.5
        args = (rng.normal(size=6), -np.full(4, 3.0), np.full(4, 3.0), hl, hu)
        a, b = daqp.solve(*args), osqp.solve(*args)
        assert daqp.dense_path.slack_solves == 1
        np.testing.assert_allclose(a.z, b.z, atol=TOL_KN)
        np.testing.assert_allclose(a.slack, b.slack, atol=TOL_KN)


class TestWarmStart:
    def test_warm_equals_cold(self, solved):
        """Each QP of the sequence, warm-started, equals a fresh workspace's solve."""
        ctl, entries = solved
        warm = {i: FastDAQP(block.qp.fast_path) for i, block in enumerate(ctl.blocks)}
        iters = {"warm": 0, "cold": 0}
        for i, data, _ in entries:
            a = warm[i].solve_vector(data)
            cold = FastDAQP(ctl.blocks[i].qp.fast_path)
            b = cold.solve_vector(data)
            np.testing.assert_allclose(a.z, b.z, rtol=0, atol=1e-9)
            np.testing.assert_allclose(a.slack, b.slack, rtol=0, atol=1e-9)
            assert a.status == b.status == "optimal"
            iters["warm"] += a.iterations
            iters["cold"] += b.iterations
        # Not asserted: from random states the previous working set may be a worse start
        # than the empty one (the benchmark measures the closed-loop sequence).
        assert iters["warm"] > 0 and iters["cold"] > 0

    def test_an_empty_working_set_gives_the_same_solution(self, solved):
        ctl, entries = solved
        dense = {i: FastDAQP(block.qp.fast_path) for i, block in enumerate(ctl.blocks)}
        for i, data, sol in entries[:40]:
            dense[i].clear_working_set()
            cold = dense[i].solve_vector(data)
            np.testing.assert_allclose(cold.z, sol.z, rtol=0, atol=1e-9)

    def test_reset_gives_a_fresh_workspace_bit_for_bit(self, solved):
        ctl, entries = solved
        i0 = entries[0][0]
        used = FastDAQP(ctl.blocks[i0].qp.fast_path)
        for i, data, _ in entries[:20]:
            if i == i0:
                used.solve_vector(data)
        used.reset()
        fresh = FastDAQP(ctl.blocks[i0].qp.fast_path)
        data = entries[-1][1] if entries[-1][0] == i0 else entries[0][1]
        a, b = used.solve_vector(data), fresh.solve_vector(data)
        np.testing.assert_array_equal(a.z, b.z)
        assert a.iterations == b.iterations


def test_a_clone_has_its_own_dense_workspace():
    """A cloned DAQP QP solves with its own workspace: the original's solves leave it alone."""
    from trainctl.controllers.mpc.qp.parametric import ParametricQP

    H = np.array([[2.0, 0.5], [0.5, 1.0]])
    C = np.eye(2)
    qp = ParametricQP(H, C, np.zeros((0, 2)), name="a", solver="daqp")
    twin = qp.clone(name="b")
    assert twin.dense_path is not None and twin.dense_path is not qp.dense_path
    lb, ub = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    a = qp.solve(g=np.array([-4.0, 0.0]), lb=lb, ub=ub)
    b = twin.solve(g=np.array([0.0, 3.0]), lb=lb, ub=ub)
    # independent routes: the box-constrained minimisers by hand
    np.testing.assert_allclose(a.z, [1.0, -0.5], atol=1e-9)
    np.testing.assert_allclose(b.z, [0.25, -1.0], atol=1e-9)
