"""Tests of the analysis layer against independent routes."""

from __future__ import annotations

import control as ct
import cvxpy as cp
import numpy as np
import pytest

from trainctl.analysis.controllability import (
    analyse_controllability,
    analyse_observability,
    finite_horizon_gramian,
    kalman_matrix,
)
from trainctl.analysis.sampling import analyse_sampling
from trainctl.analysis.stability import analyse_stability
from trainctl.controllers.mpc.theory.iteration import (
    closed_loop_matrix,
    cooperative_iteration,
    finite_iteration_closed_loop,
    iteration_matrices,
    nash_gain,
    relaxation,
    spectral_radius,
    threshold_weight,
)
from trainctl.controllers.mpc.theory.mpc import MPCDesign, prediction
from trainctl.models import crh2_half, discretise, linearise

V300 = 300 / 3.6
ADJACENT = ((0, 1), (0, 1, 2), (1, 2, 3), (2, 3))


def crh2_design(T, form="u", r=10.0, P=4, M=2, neighbourhoods=ADJACENT):
    sysd = discretise(linearise(crh2_half(), V300), T)
    return MPCDesign(A=sysd.A, B=sysd.B * 1e3, C=sysd.C, prediction_horizon=P,
                     control_horizon=M, form=form, q=np.ones(4), r=np.full(4, float(r)),
                     output_owner=(0, 1, 2, 3), neighbourhoods=neighbourhoods)


class TestStability:
    def test_double_integrator_is_defective(self):
        """A Jordan block at 0 is marginal-defective."""
        res = analyse_stability(np.array([[0.0, 1.0], [0.0, 0.0]]))
        assert [m.status for m in res.modes] == ["marginal-defective"] * 2

    def test_decoupled_integrators_are_semisimple(self):
        """Two independent integrators are marginal-semisimple."""
        assert analyse_stability(np.zeros((2, 2))).status == "marginal-semisimple"

    def test_discrete_classes(self):
        """Discrete: |z| < 1 stable, z = 1 marginal, |z| > 1 unstable."""
        sys = ct.ss(np.diag([0.5, 1.0, 1.5]), np.eye(3), np.eye(3), 0, dt=0.1)
        assert [m.status for m in analyse_stability(sys).modes] == [
            "stable", "marginal-semisimple", "unstable"]

    def test_crh2_structural_modes_named(self):
        """The dummy state and the rigid-body mode are named; couplers stable."""
        res = analyse_stability(linearise(crh2_half(), V300, dummy_state=True), n_vehicles=4)
        names = sorted(m.name for m in res.modes)
        assert names.count("coupler") == 6 and "dummy" in names and "rigid-body" in names
        dummy = next(m for m in res.modes if m.name == "dummy")
        assert dummy.status == "marginal-semisimple" and dummy.direction == {"delta[3]": 1.0}


class TestControllability:
    def test_dummy_state_uncontrollable_and_unobservable_by_pbh(self):
        """PBH finds exactly the dummy state's eigenvalue 0, in direction delta[3]."""
        sys = linearise(crh2_half(), V300, dummy_state=True)
        for res in (analyse_controllability(sys), analyse_observability(sys)):
            assert res.rank == 7
            assert len(res.modes) == 1
            mode = res.modes[0]
            assert abs(mode.eigenvalue) < 1e-12 and mode.direction == {"delta[3]": 1.0}

    def test_seven_state_model_controllable_and_observable_from_velocities(self):
        """Without the dummy the model is controllable and observable (rank 7, no PBH failure)."""
        sys = linearise(crh2_half(), V300)
        sys_kn = ct.ss(sys.A, sys.B * 1e3, sys.C, 0)
        for res in (analyse_controllability(sys_kn), analyse_observability(sys)):
            assert res.full_rank and not res.modes

    @pytest.mark.parametrize("name", ["crh2-dmpc", "crh2-dmpc-well-sampled", "heavy-haul-hinf",
                                      "crh2-potential", "heavy-haul-flocking"])
    def test_pbh_screen_changes_no_verdict(self, name, monkeypatch):
        """The Cholesky screen on and off: the same modes, margins and directions."""
        from trainctl.analysis import controllability as module
        from trainctl.design import build_design
        from trainctl.scenario import load_scenario

        model = build_design(load_scenario(name)).model
        systems = [model.select(model.design), model.select(model.discrete)]
        screened = [(analyse_controllability(s).modes, analyse_observability(s).modes)
                    for s in systems]
        monkeypatch.setattr(module._RankScreen, "clearly_full_rank", lambda self, value: False)
        plain = [(analyse_controllability(s).modes, analyse_observability(s).modes)
                 for s in systems]
        assert screened == plain

    def test_pbh_screen_proves_only_full_rank(self):
        """Never passes an uncontrollable eigenvalue; passes a well-controllable one."""
        from trainctl.analysis.controllability import _RankScreen

        sys = linearise(crh2_half(), V300, dummy_state=True)
        A, B = np.asarray(sys.A), np.asarray(sys.B)
        screen = _RankScreen(A, B, 1e-9)
        for value in np.linalg.eigvals(A):
            sv = np.linalg.svd(np.hstack([A - value * np.eye(A.shape[0]), B]), compute_uv=False)
            full = sv[A.shape[0] - 1] > 1e-9 * sv[0]
            assert full or not screen.clearly_full_rank(complex(value)), value
        # a hand case: x1' = -x1 + u, x2' = -2 x2 (x2 unreachable); and one reachable mode
        A2, B2 = np.diag([-1.0, -2.0]), np.array([[1.0], [0.0]])
        screen = _RankScreen(A2, B2, 1e-9)
        assert not screen.clearly_full_rank(-2.0)
        assert screen.clearly_full_rank(-1.0)

    def test_kalman_matrix_agrees_with_python_control(self):
        """kalman_matrix equals control.ctrb/obsv, and the ranks agree on a well-scaled model."""
        sys = discretise(linearise(crh2_half(), V300), 0.1)
        B_kn = sys.B * 1e3
        np.testing.assert_allclose(kalman_matrix(sys.A, B_kn), ct.ctrb(sys.A, B_kn), rtol=1e-14)
        np.testing.assert_allclose(
            kalman_matrix(sys.A.T, sys.C.T).T, ct.obsv(sys.A, sys.C), rtol=1e-14
        )
        sys_kn = ct.ss(sys.A, B_kn, sys.C, 0, dt=0.1)
        assert analyse_controllability(sys_kn).rank == np.linalg.matrix_rank(ct.ctrb(sys.A, B_kn))
        assert analyse_observability(sys).rank == np.linalg.matrix_rank(ct.obsv(sys.A, sys.C))

    def test_rank_is_invariant_under_similarity(self, rng):
        """A random similarity transform leaves rank and PBH verdicts unchanged."""
        sys = linearise(crh2_half(), V300, dummy_state=True)
        T = np.eye(8) + 0.1 * rng.normal(size=(8, 8))
        Ti = np.linalg.inv(T)
        moved = ct.ss(T @ sys.A @ Ti, T @ sys.B, sys.C @ Ti, 0)
        assert analyse_controllability(moved).rank == analyse_controllability(sys).rank == 7
        assert len(analyse_controllability(moved).uncontrollable) == 1

    def test_finite_horizon_gramian_equals_plain_sum_on_marginal_chain(self):
        """Doubling gives Σ A^k B Bᵀ (Aᵀ)^k for a chain with eigenvalue 1 (rigid body)."""
        sys = discretise(linearise(crh2_half(), V300, dummy_state=True), 0.5)
        A, B = sys.A, sys.B * 1e3
        for N in (1, 2, 7, 13, 64):
            plain = sum(np.linalg.matrix_power(A, k) @ B @ B.T @ np.linalg.matrix_power(A, k).T
                        for k in range(N))
            np.testing.assert_allclose(finite_horizon_gramian(A, B, N, discrete=True), plain,
                                       rtol=1e-10, atol=1e-12 * np.abs(plain).max())

    def test_continuous_gramian_equals_quadrature(self):
        """Van Loan's expm route equals numerical quadrature of e^{At}BBᵀe^{Aᵀt}."""
        from scipy.integrate import quad_vec
        from scipy.linalg import expm
        A = np.array([[0.0, 1.0], [0.0, 0.0]])
        B = np.array([[0.0], [1.0]])
        W, _ = quad_vec(lambda t: expm(A * t) @ B @ B.T @ expm(A * t).T, 0, 3.0, epsabs=1e-13)
        np.testing.assert_allclose(finite_horizon_gramian(A, B, 3.0, discrete=False), W, rtol=1e-10)
        np.testing.assert_allclose(W, [[9.0, 4.5], [4.5, 3.0]], rtol=1e-12)  # T³/3, T²/2, T


class TestSampling:
    def test_book_sample_time_is_flagged_with_numbers(self):
        """T = 20 s: ω_max·T = 555 rad ≫ π and the input directions collapse."""
        res = analyse_sampling(linearise(crh2_half(), V300), 20.0, n_vehicles=4)
        assert not res.resolves_couplers
        assert res.omega_t == pytest.approx(27.7699 * 20, rel=1e-5)
        assert res.input_collapse < 1e-3
        good = analyse_sampling(linearise(crh2_half(), V300), 0.05, n_vehicles=4)
        assert good.resolves_couplers and good.input_collapse > 0.5


class TestMPCTheory:
    def test_prediction_matches_simulation(self, rng):
        """Y = Φx + S_u u(k-1) + G ΔU equals stepping the model forward."""
        for form in ("u", "du"):
            d = crh2_design(1.0, form=form, P=6, M=3)
            pred = prediction(d)
            x0, u_prev, U = rng.normal(size=7), rng.normal(size=4), rng.normal(size=12)
            moves = U.reshape(3, 4)
            x, u, ys = x0.copy(), u_prev.copy(), []
            for j in range(6):
                m = moves[min(j, 2)]
                u = m if form == "u" else (u + m if j < 3 else u)
                x = d.A @ x + d.B @ u
                ys.append(d.C @ x)
            Y = pred.Phi @ x0 + pred.Su @ u_prev + pred.G @ U
            np.testing.assert_allclose(Y, np.concatenate(ys), rtol=1e-10, atol=1e-12)

    @pytest.mark.parametrize("T", [0.1, 1.0, 20.0])
    @pytest.mark.parametrize("form", ["u", "du"])
    def test_rho_d0_predicts_iteration_of_local_optimisation_problems(self, T, form, rng):
        """ρ(D0) equals the contraction/growth rate of iterating local QPs solved by cvxpy."""
        weights = {0.1: (1e-5, 1e-4, 1e-3), 1.0: (1e-3, 1e-2, 1.0), 20.0: (0.3, 3.0, 30.0)}[T]
        for r in weights:
            d = crh2_design(T, form=form, r=r)
            D0, D1 = iteration_matrices(d)
            rho = spectral_radius(D0)
            if rho > 0.15:
                rate = _observed_rate(d, rng)
            else:  # converges to solver precision in a few sweeps: measure the sweep operator
                rate = spectral_radius(_observed_sweep_operator(d))
            assert rate == pytest.approx(rho, rel=0.05, abs=1e-6), (T, form, r, rho, rate)

    def test_cooperative_fixed_point_is_centralised_optimum(self, rng):
        """Convex-combination cooperative DMPC converges to H⁻¹GᵀQe (≤ 1e-8)."""
        d = crh2_design(20.0, form="u", r=0.01)
        pred = prediction(d)
        e = rng.normal(size=pred.G.shape[0])
        Tm, c = cooperative_iteration(d)
        assert spectral_radius(Tm) < 1
        U = np.zeros(pred.G.shape[1])
        for _ in range(20000):
            U_next = Tm @ U + c @ e
            if np.linalg.norm(U_next - U) < 1e-14:
                break
            U = U_next
        U_c = pred.centralised_gain() @ e
        assert np.linalg.norm(U - U_c) <= 1e-8 * max(1.0, np.linalg.norm(U_c))

    def test_ndmpc_with_all_neighbours_equals_centralised(self, rng):
        """Neighbourhood = all coaches: the Nash point is the centralised optimum."""
        d = crh2_design(1.0, form="du", r=0.1, neighbourhoods=((0, 1, 2, 3),) * 4)
        pred = prediction(d)
        D0, D1 = iteration_matrices(d, pred)
        e = rng.normal(size=pred.G.shape[0])
        np.testing.assert_allclose(
            nash_gain(D0, D1) @ e, pred.centralised_gain() @ e, rtol=1e-8, atol=1e-12
        )

    def test_threshold_weight_separates_convergence(self):
        """ρ(D0) < 1 just above R* and ≥ 1 just below."""
        d = crh2_design(20.0)
        r_star = threshold_weight(d)
        assert spectral_radius(iteration_matrices(d.with_r(r_star * 1.001))[0]) < 1
        assert spectral_radius(iteration_matrices(d.with_r(r_star * 0.999))[0]) >= 1

    def test_small_weight_at_book_sample_time_diverges_towards_n_minus_1(self):
        """At T = 20 s and tiny R, ρ(D0) approaches n - 1 = 3 (spec §1.6)."""
        D0, _ = iteration_matrices(crh2_design(20.0, r=1e-6))
        assert 2.99 < spectral_radius(D0) < 3.01
        assert not relaxation(D0).exists  # an eigenvalue has crossed Re = 1

    def test_relaxation_rate_matches_relaxed_iteration_matrix(self):
        """The reported rate is ρ((1-ω)I + ωD0), and it is < 1."""
        d = crh2_design(20.0, r=0.3)
        D0, _ = iteration_matrices(d)
        res = relaxation(D0)
        assert spectral_radius(D0) > 1 and res.exists and res.rate < 1
        relaxed = (1 - res.omega_best) * np.eye(D0.shape[0]) + res.omega_best * D0
        assert spectral_radius(relaxed) == pytest.approx(res.rate, rel=1e-9)

    def test_no_relaxation_when_an_eigenvalue_has_real_part_above_one(self):
        """An eigenvalue with Re ≥ 1 means no ω in (0, 1] converges."""
        assert not relaxation(np.diag([1.2, -0.5])).exists

    def test_du_form_velocity_outputs_leave_unit_eigenvalues(self):
        """Δu-form with velocity outputs: 3 closed-loop eigenvalues at 1 (internal forces)."""
        d = crh2_design(1.0, form="du", r=0.1)
        D0, D1 = iteration_matrices(d)
        lam = np.linalg.eigvals(closed_loop_matrix(d, nash_gain(D0, D1)))
        assert np.sum(np.abs(lam - 1) < 1e-8) == 3

    def test_centralised_gain_matches_dlqr_for_long_horizon(self):
        """With P = M = 60 on a well-damped 2-car train, the MPC gain equals control.dlqr's."""
        from trainctl.models import Coupler, Train, Vehicle
        car = Vehicle(mass=4e4, a0=0.01, a1=1e-3, a2=1e-5)
        train = Train(vehicles=(car, car), couplers=(Coupler(stiffness=1e6, damping=2e5),))
        sysd = discretise(linearise(train, 20.0), 0.5)
        B, q = sysd.B * 1e3, np.array([1e3, 1e3, 1e5])
        d = MPCDesign(A=sysd.A, B=B, C=np.eye(3), prediction_horizon=60, control_horizon=60,
                      form="u", q=q, r=np.ones(2), output_owner=(0, 1, 0),
                      neighbourhoods=((0, 1), (0, 1)))
        pred = prediction(d)
        K_mpc = pred.first_move @ pred.centralised_gain() @ pred.Phi
        # The MPC stage cost starts at x(k+1); dlqr's extra x(k) term does not change the gain.
        K_lqr, S, _ = ct.dlqr(sysd.A, B, np.diag(q), np.eye(2))
        np.testing.assert_allclose(K_mpc, K_lqr, rtol=1e-9, atol=1e-12)
        S_dare, _, _ = ct.dare(sysd.A, B, np.diag(q), np.eye(2))
        np.testing.assert_allclose(S, S_dare, rtol=1e-10)

    def test_finite_iterations_converge_to_nash_closed_loop(self):
        """Many iterations per sample give the Nash closed-loop spectral radius."""
        d = crh2_design(20.0, r=10.0)
        D0, D1 = iteration_matrices(d)
        nash = spectral_radius(closed_loop_matrix(d, nash_gain(D0, D1)))
        many = spectral_radius(finite_iteration_closed_loop(d, D0, D1, 60))
        assert many == pytest.approx(nash, rel=1e-8)


def _local_problems(d, pred):
    """One cvxpy problem per coach: its neighbourhood cost over its own moves."""
    G = pred.G
    problems = []
    for i, cols in enumerate(pred.columns):
        mask = np.array([o in d.neighbourhoods[i] for o in d.output_owner], dtype=float)
        w = np.sqrt(np.tile(d.q * mask, d.prediction_horizon))
        Ui = cp.Variable(len(cols))
        rhs = cp.Parameter(G.shape[0])
        cost = cp.sum_squares(cp.multiply(w, G[:, cols] @ Ui - rhs)) + d.r[i] * cp.sum_squares(Ui)
        problems.append((cp.Problem(cp.Minimize(cost)), Ui, rhs, cols))
    return problems


def _sweep(problems, G, U, e):
    """One Jacobi sweep: every coach re-solves its local problem given the others' plan."""
    new = U.copy()
    for prob, Ui, rhs, cols in problems:
        others = U.copy()
        others[cols] = 0.0
        rhs.value = e - G @ others
        prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-14, tol_gap_rel=1e-14, tol_feas=1e-14)
        new[cols] = Ui.value
    return new


def _observed_sweep_operator(d):
    """The linear map U -> sweep(U) - sweep(0), measured column by column with cvxpy."""
    pred = prediction(d)
    problems = _local_problems(d, pred)
    nd = pred.G.shape[1]
    e = np.zeros(pred.G.shape[0])
    base = _sweep(problems, pred.G, np.zeros(nd), e)
    return np.column_stack([_sweep(problems, pred.G, col, e) - base for col in np.eye(nd)])


def _observed_rate(d, rng, iterations=14):
    """Iterate each coach's local unconstrained problem with cvxpy; return growth rate."""
    pred = prediction(d)
    G, e = pred.G, rng.normal(size=pred.G.shape[0])
    U = rng.normal(size=G.shape[1])
    problems = _local_problems(d, pred)
    diffs = []
    for _ in range(iterations):
        new = _sweep(problems, G, U, e)
        diffs.append(np.linalg.norm(new - U))
        U = new
        if diffs[-1] < 1e-7 * diffs[0] and len(diffs) >= 4:
            break  # further iterates are at solver precision
    k = 1 if len(diffs) < 8 else len(diffs) // 2
    return (diffs[-1] / diffs[k]) ** (1.0 / (len(diffs) - 1 - k))


class TestModelSummaryText:
    def test_long_train_shows_the_ends_of_the_mode_table(self):
        """204 vehicles (205 distinct modes): the text shows 24 rows and says how many it
        left out; the JSON keeps every mode."""
        from pathlib import Path

        from trainctl.analysis.summary import model_summary
        from trainctl.scenario import load_scenario

        path = Path(__file__).resolve().parents[1] / "benchmarks" / "scenarios"
        summary = model_summary(load_scenario(str(path / "heavy-haul-204-ndmpc.toml")))
        lines = summary.format_text().splitlines()
        start = lines.index("Modes (continuous):") + 2
        end = lines.index("Sampling:") - 1
        table = lines[start:end]
        assert len(summary.modes) == 205 and len(table) == 25
        assert table[12].strip() == "... 181 more modes (analyse --json lists every mode)"
        assert table[0].split()[0] == summary.modes[0].kind
        assert float(table[-1].split()[2]) == pytest.approx(summary.modes[-1].eigenvalue.imag,
                                                            abs=1e-4)
        assert len(summary.to_dict()["modes"]) == 205


def test_stability_of_a_system_without_states_is_strict_json() -> None:
    """No modes: stable, spectral abscissa -inf, written as null (strict JSON has no inf)."""
    import json

    result = analyse_stability(np.zeros((0, 0)))
    assert result.status == "stable" and result.spectral_abscissa == -np.inf
    d = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    assert d["spectral_abscissa"] is None and d["modes"] == []
