"""Tests of the train models against independent routes."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from scipy.integrate import solve_ivp

from tests.strategies import trains
from trainctl.exceptions import ModelError
from trainctl.models import (
    PRESETS,
    Coupler,
    Track,
    TrackSection,
    TractionEnvelope,
    Train,
    Vehicle,
    coach_subsystems,
    coupler_forces,
    crh2_half,
    discretise,
    equilibrium,
    linearise,
    neighbourhood,
    nonlinear_system,
    train_rhs,
)
from trainctl.units import (
    davis_book_literal,
    davis_from_unit_resistance_kmh,
    kmh_to_ms,
    unit_resistance_to_accel,
)

V300 = 300 / 3.6
MASS = np.array([42.8e3, 48e3, 46.5e3, 42e3])
K = 10488e3


def fd_jacobian(train, x0, u0, h_rel=1e-6):
    """Central finite differences of train_rhs wrt [v, delta] and u (vectorised)."""
    n = train.n_vehicles
    nx = 2 * n - 1
    xs = np.asarray(x0, dtype=float)
    hx = h_rel * np.maximum(np.abs(xs[:nx]), 1e-3)
    plus = np.repeat(xs[:, None], nx, axis=1)
    minus = plus.copy()
    plus[np.arange(nx), np.arange(nx)] += hx
    minus[np.arange(nx), np.arange(nx)] -= hx
    U = np.repeat(np.asarray(u0)[:, None], nx, axis=1)
    A = (train_rhs(train, plus, U) - train_rhs(train, minus, U))[:nx] / (2 * hx)
    # step on the force scale m·(1 m/s²): the rhs is linear in u, and a 1e-6 N step on an
    # unpowered vehicle (u0 ≈ 0) let rounding of the resistance terms reach 1e-6 relative
    hu = h_rel * np.maximum(np.abs(u0), [v.mass for v in train.vehicles])
    Up = np.repeat(np.asarray(u0, dtype=float)[:, None], n, axis=1)
    Um = Up.copy()
    Up[np.arange(n), np.arange(n)] += hu
    Um[np.arange(n), np.arange(n)] -= hu
    X = np.repeat(xs[:, None], n, axis=1)
    B = (train_rhs(train, X, Up) - train_rhs(train, X, Um))[:nx] / (2 * hu)
    return A, B


def rel_err(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


class TestUnits:
    def test_crh2_unit_resistance_at_300_kmh(self):
        """13.40 N/kN at 300 km/h is 0.1315 m/s² with the km/h reading (hand-checked)."""
        w = 0.8806 + 0.007444 * 300 + 0.0001143 * 300**2
        assert w == pytest.approx(13.4008, abs=1e-4)
        assert unit_resistance_to_accel(13.40) == pytest.approx(0.1315, abs=5e-5)
        a0, a1, a2 = davis_from_unit_resistance_kmh(0.8806, 0.007444, 0.0001143)
        v = kmh_to_ms(300)
        assert a0 + a1 * v + a2 * v**2 == pytest.approx(w * 9.81 / 1000, rel=1e-12)

    def test_davis_si_coefficients_match_hand_values(self):
        """The SI coefficients equal c·g/1000·3.6^k computed by hand (spec §1.4)."""
        a0, a1, a2 = davis_from_unit_resistance_kmh(0.8806, 0.007444, 0.0001143)
        np.testing.assert_allclose([a0, a1, a2], [8.63869e-3, 2.62892e-4, 1.45318e-5], rtol=2e-6)

    def test_book_literal_reading_is_physically_impossible(self):
        """The literal reading gives 2.295 m/s² at 300 km/h, as the spec computes."""
        a0, a1, a2 = davis_book_literal(0.8806, 0.007444, 0.0001143)
        assert a0 + a1 * V300 + a2 * V300**2 == pytest.approx(2.29468, abs=1e-5)


class TestCrh2Model:
    def test_coupler_frequencies_match_mass_spring_eigenproblem(self):
        """Coupler |lambda| equal sqrt(eig(M^-1 K)) of an independently built chain."""
        Kmat = K * (np.diag([1, 2, 2, 1]) - np.eye(4, k=1) - np.eye(4, k=-1))
        w2 = np.sort(np.linalg.eigvals(np.linalg.solve(np.diag(MASS), Kmat)).real)
        expected = np.sqrt(w2[1:])
        sys = linearise(crh2_half(), V300)
        lam = np.linalg.eigvals(sys.A)
        osc = np.sort(np.abs(lam[lam.imag > 1e-6]))
        np.testing.assert_allclose(osc, expected, rtol=1e-10)
        np.testing.assert_allclose(
            np.sort(lam[lam.imag > 0].imag), [11.9365, 21.6613, 27.7699], atol=1e-4
        )

    @pytest.mark.parametrize(
        ("method", "d"), [("jacobian", 2.68486e-3), ("book", 1.47388e-3)]
    )
    def test_per_coach_blocks_match_book_structure(self, method, d):
        """A_ii, A_ij, B_i, C_i equal seed 000's printed structure (p.299) entry by entry."""
        sub = coach_subsystems(crh2_half(), V300, method=method)
        for i in range(3):
            np.testing.assert_allclose(sub.A[i, i], [[-d, -K / MASS[i]], [1, 0]], rtol=1e-5)
            np.testing.assert_allclose(sub.A[i, i + 1], [[0, 0], [-1, 0]])
        np.testing.assert_allclose(sub.A[3, 3], [[-d, 0], [0, 0]], rtol=1e-5)
        for i in (1, 2, 3):
            np.testing.assert_allclose(sub.A[i, i - 1], [[0, K / MASS[i]], [0, 0]], rtol=1e-12)
        np.testing.assert_allclose(sub.A[0, 0][0, 1], -245.0467, atol=5e-5)
        np.testing.assert_allclose(sub.A[3, 2][0, 1], 249.7143, atol=5e-5)
        for i in range(4):
            np.testing.assert_allclose(sub.B[i], [[1 / MASS[i]], [0]], rtol=1e-15)
            np.testing.assert_allclose(sub.C[i], [[1, 0]])
        assert (0, 2) not in sub.A and (3, 1) not in sub.A

    def test_book_damping_omits_factor_two(self):
        """The book's secant damping is c1 + c2 v_r, the Jacobian's c1 + 2 c2 v_r."""
        a0, a1, a2 = davis_from_unit_resistance_kmh(0.8806, 0.007444, 0.0001143)
        jac = linearise(crh2_half(), V300).A[0, 0]
        book = linearise(crh2_half(), V300, method="book").A[0, 0]
        assert jac == pytest.approx(-(a1 + 2 * a2 * V300), rel=1e-14)
        assert book == pytest.approx(-(a1 + a2 * V300), rel=1e-14)

    def test_dummy_state_is_a_zero_eigenvalue(self):
        """The book's dummy state adds exactly one zero eigenvalue with a unit eigenvector."""
        sys = linearise(crh2_half(), V300, dummy_state=True)
        lam, vec = np.linalg.eig(sys.A)
        zero = np.flatnonzero(np.abs(lam) < 1e-12)
        assert zero.size == 1
        assert sys.state_labels[int(np.argmax(np.abs(vec[:, zero[0]])))] == "delta[3]"
        assert np.sum(np.abs(np.linalg.eigvals(linearise(crh2_half(), V300).A)) < 1e-12) == 0

    def test_neighbourhood_matrices_match_book(self):
        """Â_22, Â_23, Â_32 for n = 4 equal the book's block layout (p.297, p.300)."""
        sub = coach_subsystems(crh2_half(), V300)
        A = sub.A
        nb = neighbourhood(sub, 1)
        Z = np.zeros((2, 2))
        expected = np.block([
            [A[0, 0], A[0, 1], Z],
            [A[1, 0], A[1, 1], A[1, 2]],
            [Z, A[2, 1], A[2, 2]],
        ])
        np.testing.assert_array_equal(nb.A_hat, expected)
        np.testing.assert_array_equal(nb.couplings[3], np.vstack([Z, Z, A[2, 3]]))
        nb3 = neighbourhood(sub, 2)
        np.testing.assert_array_equal(nb3.couplings[0], np.vstack([A[1, 0], Z, Z]))
        np.testing.assert_array_equal(nb.B_hat, scipy.linalg.block_diag(*sub.B[:3]))
        assert nb.members == (0, 1, 2) and sorted(nb.couplings) == [3]


class TestEquilibrium:
    def test_tmmt_static_coupler_forces(self):
        """T-M-M-T traction gives f = [-5.627, -0.151, 5.521] kN, delta in mm (spec §1.2)."""
        eq = equilibrium(crh2_half(), V300)
        np.testing.assert_allclose(eq.coupler_forces / 1e3, [-5.627, -0.151, 5.521], atol=1e-3)
        np.testing.assert_allclose(eq.elongations * 1e3, [-0.537, -0.014, 0.526], atol=1e-3)
        np.testing.assert_allclose(eq.inputs / 1e3, [0, 11.7855, 11.7855, 0], atol=1e-3)
        assert eq.feasible

    def test_own_allocation_has_no_coupler_force(self):
        """Each coach supplying its own resistance (book eq. 12.8) loads no coupler."""
        eq = equilibrium(crh2_half(), V300, allocation="own")
        np.testing.assert_allclose(eq.coupler_forces, 0, atol=1e-9)
        np.testing.assert_allclose(eq.inputs / 1e3, [5.627, 6.310, 6.113, 5.521], atol=1e-3)

    @pytest.mark.parametrize("preset", sorted(PRESETS))
    def test_equilibrium_is_a_rest_point_of_the_nonlinear_model(self, preset):
        """At the equilibrium every acceleration and elongation rate vanishes."""
        train = PRESETS[preset]()
        eq = equilibrium(train, 20.0)
        dx = train_rhs(train, eq.state(position=0.0), eq.inputs)
        assert np.max(np.abs(dx[:-1])) < 1e-12
        assert dx[-1] == pytest.approx(20.0)

    def test_grade_is_carried_by_the_motor_coaches(self):
        """On a 10‰ climb the extra m·g·i/1000 is added to the traction total."""
        flat = equilibrium(crh2_half(), V300)
        climb = equilibrium(crh2_half(), V300, grade_permille=10.0)
        extra = MASS.sum() * 9.81 * 10 / 1000
        assert climb.inputs.sum() - flat.inputs.sum() == pytest.approx(extra, rel=1e-12)

    def test_acceleration_is_shared_like_a_grade(self):
        """A uniform acceleration a needs m·a more per coach, as a grade of a·1000/g ‰ does."""
        a = 0.3
        acc = equilibrium(crh2_half(), V300, acceleration=a)
        grade = equilibrium(crh2_half(), V300, grade_permille=a * 1000 / 9.81)
        np.testing.assert_allclose(acc.inputs, grade.inputs, rtol=1e-12)
        np.testing.assert_allclose(acc.coupler_forces, grade.coupler_forces, rtol=1e-9)
        x = acc.state(position=0.0)
        dv = train_rhs(crh2_half(), x, acc.inputs)[:4]
        np.testing.assert_allclose(dv, a, rtol=1e-9)  # every coach accelerates at a

    def test_trailers_only_group_is_rejected(self):
        """A coupled group without traction has no cruise equilibrium with shares."""
        car = Vehicle(mass=4e4, a0=0.01, a1=0, a2=0, traction_share=0.0)
        train = Train(vehicles=(car, car), couplers=(Coupler(stiffness=1e7),))
        with pytest.raises(ModelError, match="no traction"):
            equilibrium(train, 10.0)


class TestLinearisation:
    @pytest.mark.parametrize("preset", sorted(PRESETS))
    def test_jacobian_equals_finite_differences(self, preset):
        """A and B equal central finite differences of the nonlinear model (≤ 1e-6)."""
        train = PRESETS[preset]()
        eq = equilibrium(train, 25.0)
        A_fd, B_fd = fd_jacobian(train, eq.state(position=0.0), eq.inputs)
        sys = linearise(train, 25.0)
        assert rel_err(sys.A, A_fd) <= 1e-6
        assert rel_err(sys.B, B_fd) <= 1e-6

    def test_full_heavy_haul_chain_jacobian(self):
        """The 204-vehicle 1+2+1 chain (damped couplers, mixed Davis) linearises exactly."""
        from trainctl.models import heavy_haul_1p2p1
        train = heavy_haul_1p2p1(detail="full")
        eq = equilibrium(train, 19.44)
        A_fd, B_fd = fd_jacobian(train, eq.state(position=0.0), eq.inputs)
        sys = linearise(train, 19.44)
        assert sys.nstates == 407
        assert rel_err(sys.A, A_fd) <= 1e-6 and rel_err(sys.B, B_fd) <= 1e-6

    def test_book_literal_preset_jacobian(self):
        """The literal Davis reading also linearises exactly."""
        train = crh2_half(davis_reading="book_literal")
        eq = equilibrium(train, V300)
        A_fd, _ = fd_jacobian(train, eq.state(position=0.0), eq.inputs)
        assert rel_err(linearise(train, V300).A, A_fd) <= 1e-6
        assert linearise(train, V300).A[0, 0] == pytest.approx(-2.6494e-2, rel=1e-4)

    def test_force_output_equals_coupler_forces(self):
        """The 'force' output row equals coupler_forces of the deviation state."""
        train = PRESETS["heavy_haul_1p2p1"]()
        sys = linearise(train, 20.0, outputs=("v", "force"))
        x = np.random.default_rng(1).normal(size=sys.nstates)
        np.testing.assert_allclose((sys.C @ x)[4:], coupler_forces(train, x), rtol=1e-12)

    def test_interconnection_equals_monolithic_model(self):
        """control.interconnect of the coach subsystems equals linearise() after reordering."""
        for dummy in (True, False):
            train = PRESETS["heavy_haul_1p2p1"]()  # has coupler damping
            sub = coach_subsystems(train, 20.0, dummy_state=dummy)
            inter = sub.interconnection()
            mono = linearise(train, 20.0, dummy_state=dummy)
            order = [mono.state_labels.index(lab.split("_", 1)[1]) for lab in inter.state_labels]
            P = np.eye(mono.nstates)[order]
            np.testing.assert_allclose(inter.A, P @ mono.A @ P.T, rtol=1e-13, atol=1e-13)
            np.testing.assert_allclose(inter.B, P @ mono.B, rtol=1e-13)
            np.testing.assert_allclose(inter.C, mono.C @ P.T)

    def test_nonlinear_system_is_a_python_control_system(self):
        """nonlinear_system() linearises (python-control) to the same A at equilibrium."""
        train = crh2_half()
        eq = equilibrium(train, V300)
        lin = nonlinear_system(train).linearize(eq.state(position=0.0), eq.inputs)
        np.testing.assert_allclose(lin.A[:7, :7], linearise(train, V300).A, rtol=1e-5, atol=1e-6)

    @settings(deadline=None, max_examples=25)
    @given(trains())
    def test_random_trains_have_documented_dimensions_and_exact_jacobian(self, train):
        """Random 2–50 vehicle trains: 2n-1 states, n inputs, Jacobian = FD."""
        n = train.n_vehicles
        sys = linearise(train, 30.0)
        assert (sys.nstates, sys.ninputs, sys.noutputs) == (2 * n - 1, n, n)
        assert linearise(train, 30.0, dummy_state=True).nstates == 2 * n
        eq = equilibrium(train, 30.0)
        A_fd, B_fd = fd_jacobian(train, eq.state(position=0.0), eq.inputs)
        assert rel_err(sys.A, A_fd) <= 1e-6 and rel_err(sys.B, B_fd) <= 1e-6


def zoh_by_eigendecomposition(A, B, T):
    lam, V = np.linalg.eig(A)
    Vinv = np.linalg.inv(V)
    phi = np.where(np.abs(lam) > 1e-14, np.expm1(lam * T) / np.where(lam == 0, 1, lam), T)
    Ad = (V * np.exp(lam * T)) @ Vinv
    Bd = (V * phi) @ Vinv @ B
    return Ad.real, Bd.real


def zoh_by_integration(A, B, T):
    nx, nu = B.shape

    def rhs(t, y):
        M = y.reshape(nx, nx + nu)
        out = A @ M
        out[:, nx:] += B
        return out.ravel()

    y0 = np.hstack([np.eye(nx), np.zeros((nx, nu))]).ravel()
    sol = solve_ivp(rhs, (0, T), y0, method="DOP853", rtol=1e-12, atol=1e-14)
    M = sol.y[:, -1].reshape(nx, nx + nu)
    return M[:, :nx], M[:, nx:]


class TestDiscretisation:
    @pytest.mark.parametrize("T", [0.1, 20.0])
    def test_zoh_matches_eigendecomposition_and_integration(self, T):
        """python-control ZOH = eigendecomposition route = solve_ivp over one sample."""
        sys = linearise(crh2_half(), V300)
        A, B = sys.A, sys.B * 1e3  # u in kN for comparable magnitudes
        sysd = discretise(ct.ss(A, B, sys.C, 0), T)
        Ad_e, Bd_e = zoh_by_eigendecomposition(A, B, T)
        np.testing.assert_allclose(sysd.A, Ad_e, atol=1e-10)
        np.testing.assert_allclose(sysd.B, Bd_e, atol=1e-10)
        Ad_i, Bd_i = zoh_by_integration(A, B, T)
        np.testing.assert_allclose(sysd.A, Ad_i, atol=1e-8)
        np.testing.assert_allclose(sysd.B, Bd_i, atol=1e-8)

    def test_book_sample_time_gives_spec_moduli(self):
        """At T = 20 s: rigid |z| = e^{-dT}, coupler |z| = e^{-dT/2} (spec §1.4)."""
        sysd = discretise(linearise(crh2_half(), V300), 20.0)
        mod = np.sort(np.abs(np.linalg.eigvals(sysd.A)))
        np.testing.assert_allclose(mod[0], 0.947719, atol=1e-6)
        np.testing.assert_allclose(mod[1:], 0.973509, atol=1e-6)
        np.testing.assert_allclose(sysd.B[:4, :] * 1e3, 0.1085, atol=6e-4)

    def test_discretise_returns_new_system_and_keeps_names(self):
        """The continuous system is untouched; signal names carry over."""
        sys = linearise(crh2_half(), V300)
        A0 = sys.A.copy()
        sysd = discretise(sys, 0.05, method="tustin")
        assert sys.dt == 0 and sysd.dt == 0.05
        np.testing.assert_array_equal(sys.A, A0)
        assert sysd.state_labels == sys.state_labels and sysd.input_labels == sys.input_labels

    @pytest.mark.parametrize(("kwargs", "match"), [
        ({"dt": 0.0}, "'dt' must be > 0"),
        ({"dt": math.nan}, "'dt' must be finite"),
        ({"dt": 0.1, "method": "euler"}, "Forward Euler is not offered"),
    ])
    def test_bad_arguments_are_rejected(self, kwargs, match):
        """Non-positive or NaN sample times and forward Euler raise ModelError."""
        with pytest.raises(ModelError, match=match):
            discretise(linearise(crh2_half(), V300), **kwargs)

    @settings(deadline=None, max_examples=25)
    @given(trains(max_vehicles=30))
    def test_stable_modes_map_inside_the_unit_circle(self, train):
        """Every continuous mode with Re < 0 discretises to |z| < 1."""
        sys = linearise(train, 30.0)
        lam = np.linalg.eigvals(sys.A)
        assert np.all(lam.real < 0)
        sysd = discretise(sys, 0.1)
        assert np.max(np.abs(np.linalg.eigvals(sysd.A))) < 1


class TestParameters:
    def test_envelope_limits(self):
        """min(force, P/v, mu m g) with each limit active in turn."""
        env = TractionEnvelope(max_traction=80e3, max_power=1.2e6)
        np.testing.assert_allclose(
            env.traction_limit([1.0, 83.333], mass=1e5), [80e3, 1.2e6 / 83.333]
        )
        slippery = TractionEnvelope(max_traction=80e3, max_power=1.2e6, adhesion=0.05)
        assert slippery.traction_limit(1.0, mass=1e5) == pytest.approx(0.05 * 1e5 * 9.81)
        assert TractionEnvelope(max_traction=0.0).traction_limit(10.0, mass=1e3) == 0.0

    @pytest.mark.parametrize(("factory", "match"), [
        (lambda: Vehicle(mass=-1.0, a0=0, a1=0, a2=0), "'mass' must be a finite number >= 1 "),
        (lambda: Vehicle(mass=math.inf, a0=0, a1=0, a2=0), "'mass' must be a finite number"),
        (lambda: Coupler(stiffness=0.0), "'stiffness' must be > 0"),
        (lambda: Coupler(stiffness=1.0, virtual=True), "virtual link transmits no force"),
        (lambda: Train(vehicles=(crh2_half().vehicles[0],) * 2, couplers=()), "needs 1 couplers"),
        (lambda: TractionEnvelope(max_power=0.0), "'max_power' must be a number > 0, or inf"),
        (
            lambda: Track(sections=(TrackSection(start=5.0), TrackSection(start=1.0))),
            "increase strictly",
        ),
    ])
    def test_invalid_parameters_raise_model_error(self, factory, match):
        """Invalid physical parameters raise ModelError naming the parameter."""
        with pytest.raises(ModelError, match=match):
            factory()

    def test_track_formulas(self):
        """TB/T: (i + 600/R)·g/1000; Ning 2016: 9.98 sin(atan(i/1000)) + 0.04·0.5·wb/R."""
        sec = (TrackSection(start=0.0, grade_permille=12.0, curve_radius=800.0),)
        tbt = Track(sections=sec).resistance_per_mass(10.0)
        assert tbt == pytest.approx((12 + 0.75) * 9.81 / 1000, rel=1e-14)
        ning = Track(sections=sec, formula="ning2016", wheelbase=1.83).resistance_per_mass(10.0)
        assert ning == pytest.approx(9.98 * math.sin(math.atan(0.012)) + 0.04 * 0.5 * 1.83 / 800)

    def test_grade_acts_on_each_vehicle_at_its_position(self):
        """Vehicles behind a grade change feel the grade only once they reach it."""
        train = crh2_half()
        track = Track(
            sections=(TrackSection(start=0.0), TrackSection(start=100.0, grade_permille=10.0))
        )
        x = np.concatenate([np.full(4, 50.0), np.zeros(3), [110.0]])  # head at 110 m, spacing 25 m
        flat = train_rhs(train, x, np.zeros(4))
        hill = train_rhs(train, x, np.zeros(4), track)
        np.testing.assert_allclose(flat[:4] - hill[:4], [0.0981, 0.0, 0.0, 0.0], atol=1e-15)


class TestBuiltinScenariosMatchPresets:
    @pytest.mark.parametrize(("name", "preset"), [
        ("crh2-dmpc", "crh2_half"), ("crh2-potential", "crh2_8car"),
        ("heavy-haul-hinf", "heavy_haul_1p2p1"), ("heavy-haul-flocking", "virtual_formation"),
    ])
    def test_scenario_file_and_preset_build_the_same_train(self, name, preset):
        """The explicit TOML parameters equal the Python preset's.

        Masses, Davis coefficients, couplers and envelopes are compared.
        """
        from trainctl.scenario import load_scenario
        a, b = load_scenario(name).train, PRESETS[preset]()
        np.testing.assert_allclose(a.mass, b.mass, rtol=1e-12)
        np.testing.assert_allclose(a.davis, b.davis, rtol=1e-5)  # files print 6 digits
        np.testing.assert_allclose(a.stiffness, b.stiffness, rtol=1e-12)
        np.testing.assert_allclose(a.damping, b.damping, rtol=1e-12)
        np.testing.assert_allclose(a.spacing, b.spacing, rtol=1e-12)
        np.testing.assert_array_equal(a.traction_share, b.traction_share)
        assert [v.envelope for v in a.vehicles] == [v.envelope for v in b.vehicles]
