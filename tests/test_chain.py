"""Tests of the one chain definition (models.chain) and the one force split (models.feedforward)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings

from tests.strategies import trains
from trainctl.exceptions import DimensionError, ModelError
from trainctl.models import (
    PRESETS,
    Chain,
    Coupler,
    ForceSplit,
    Plant,
    Train,
    Vehicle,
    equilibrium,
    heavy_haul_1p2p1,
    linear_matrices,
    resistance_damping,
    train_rhs,
    virtual_formation,
)
from trainctl.units import permille_to_accel


def fd_jacobian_full(train, x0, u0, h_rel=1e-6):
    """Central finite differences of train_rhs wrt the whole state [v, delta, s] and u."""
    x0 = np.asarray(x0, dtype=float)
    u0 = np.asarray(u0, dtype=float)
    nx, n = x0.size, u0.size
    hx = h_rel * np.maximum(np.abs(x0), 1e-3)
    plus = np.repeat(x0[:, None], nx, axis=1)
    minus = plus.copy()
    plus[np.arange(nx), np.arange(nx)] += hx
    minus[np.arange(nx), np.arange(nx)] -= hx
    U = np.repeat(u0[:, None], nx, axis=1)
    A = (train_rhs(train, plus, U) - train_rhs(train, minus, U)) / (2 * hx)
    hu = h_rel * np.maximum(np.abs(u0), 1.0)
    Up = np.repeat(u0[:, None], n, axis=1)
    Um = Up.copy()
    Up[np.arange(n), np.arange(n)] += hu
    Um[np.arange(n), np.arange(n)] -= hu
    X = np.repeat(x0[:, None], n, axis=1)
    B = (train_rhs(train, X, Up) - train_rhs(train, X, Um)) / (2 * hu)
    return A, B


def random_chain(rng, n, *, dummy_state=False, position=False, virtual_every=0):
    """A chain of n vehicles with random parameters; every k-th link virtual when k > 0."""
    virtual = np.zeros(n - 1, dtype=bool)
    if virtual_every:
        virtual[virtual_every - 1 :: virtual_every] = True
    k = np.where(virtual, 0.0, rng.uniform(1e6, 5e7, n - 1))
    d = np.where(virtual, 0.0, rng.uniform(0.0, 1e5, n - 1))
    return Chain(mass=rng.uniform(1e4, 2e5, n), stiffness=k, damping=d, virtual=virtual,
                 speed_damping=rng.uniform(0.0, 1e-2, n), dummy_state=dummy_state,
                 position=position)


def chain_of_size(n):
    """Test trains: a lone vehicle, a coupled pair, 50 vehicles in 5 virtually linked units."""
    car = Vehicle(mass=5e4, a0=0.01, a1=2e-4, a2=2e-5)
    couplers = tuple(
        Coupler(stiffness=0.0, virtual=True) if (i + 1) % 10 == 0
        else Coupler(stiffness=2e7 + 1e5 * i, damping=3e4)
        for i in range(n - 1)
    )
    vehicles = tuple(Vehicle(mass=car.mass * (1 + 0.01 * i), a0=car.a0, a1=car.a1,
                             a2=car.a2 * (1 + 0.02 * i)) for i in range(n))
    return Train(vehicles=vehicles, couplers=couplers)


class TestChainMatrices:
    def test_two_vehicles_by_hand(self):
        """m = (2, 4) kg, k = 8 N/m, d = 1 N·s/m, c = (0.5, 0.25) /s: A, B written out."""
        chain = Chain(mass=[2.0, 4.0], stiffness=[8.0], damping=[1.0], virtual=[False],
                      speed_damping=[0.5, 0.25], position=True)
        A, B = chain.matrices()
        np.testing.assert_array_equal(A, [[-1.0, 0.5, -4.0, 0.0],
                                          [0.25, -0.5, 2.0, 0.0],
                                          [1.0, -1.0, 0.0, 0.0],
                                          [1.0, 0.0, 0.0, 0.0]])
        np.testing.assert_array_equal(B, [[0.5, 0.0], [0.0, 0.25], [0.0, 0.0], [0.0, 0.0]])
        assert chain.n_states == 4

    def test_dummy_state_is_a_zero_row_and_column(self):
        """Seed 000's dummy elongation sits between the elongations and the position."""
        rng = np.random.default_rng(1)
        plain = random_chain(rng, 4)
        dummy = Chain(**{f: getattr(plain, f) for f in
                         ("mass", "stiffness", "damping", "virtual", "speed_damping")},
                      dummy_state=True, position=True)
        A, B = dummy.matrices()
        assert A.shape == (9, 9) and B.shape == (9, 4)
        assert not A[7].any() and not A[:, 7].any()
        np.testing.assert_array_equal(A[:7, :7], plain.matrices()[0])
        assert A[8, 0] == 1.0

    @pytest.mark.parametrize("preset", sorted(PRESETS))
    def test_dense_a_equals_finite_difference_jacobian_of_train_rhs(self, preset):
        """Chain A (with the head row) = central FD Jacobian of the nonlinear model (≤ 1e-6)."""
        train = PRESETS[preset]()
        speed = 25.0
        eq = equilibrium(train, speed)
        chain = Chain.from_train(train, resistance_damping(train, speed), position=True)
        A, B = chain.matrices()
        A_fd, B_fd = fd_jacobian_full(train, eq.state(position=100.0), eq.inputs)
        assert np.linalg.norm(A - A_fd) <= 1e-6 * np.linalg.norm(A)
        assert np.linalg.norm(B - B_fd) <= 1e-6 * np.linalg.norm(B)

    def test_204_vehicle_chain_jacobian(self):
        """The full heavy-haul chain: dense A = FD Jacobian of train_rhs, 408 × 408."""
        train = heavy_haul_1p2p1(detail="full")
        eq = equilibrium(train, 19.44)
        A, _ = Chain.from_train(train, resistance_damping(train, 19.44), position=True).matrices()
        A_fd, _ = fd_jacobian_full(train, eq.state(position=0.0), eq.inputs)
        assert A.shape == (408, 408)
        assert np.linalg.norm(A - A_fd) <= 1e-6 * np.linalg.norm(A)

    @settings(deadline=None, max_examples=25)
    @given(trains())
    def test_random_trains_dense_a_equals_jacobian(self, train):
        """Random 2–50 vehicle trains: the chain's A is the nonlinear model's Jacobian."""
        eq = equilibrium(train, 30.0)
        A, _ = Chain.from_train(train, resistance_damping(train, 30.0), position=True).matrices()
        A_fd, _ = fd_jacobian_full(train, eq.state(position=0.0), eq.inputs)
        assert np.linalg.norm(A - A_fd) <= 1e-6 * np.linalg.norm(A)

    def test_linear_model_and_plant_use_the_chain(self):
        """linear_matrices and the plant's A, B are the chain's, bit for bit."""
        train = virtual_formation(n_trains=3)
        damp = resistance_damping(train, 30.0)
        for dummy in (False, True):
            A, B = linear_matrices(train, 30.0, dummy_state=dummy)
            Ac, Bc = Chain.from_train(train, damp, dummy_state=dummy).matrices()
            np.testing.assert_array_equal(A, Ac)
            np.testing.assert_array_equal(B, Bc)
        Ap, Bp = Plant(train=train)._linear
        Ac, Bc = Chain.from_train(train, train.davis[1], position=True).matrices()
        np.testing.assert_array_equal(Ap, Ac)
        np.testing.assert_array_equal(Bp, Bc)


class TestChainProduct:
    @pytest.mark.parametrize("n", [1, 2, 50])
    @pytest.mark.parametrize("dummy_state", [False, True])
    @pytest.mark.parametrize("position", [False, True])
    def test_structured_product_equals_dense_product(self, n, dummy_state, position):
        """A @ Y in O(n) equals the dense product on random vectors and matrices."""
        rng = np.random.default_rng(n)
        chain = random_chain(rng, n, dummy_state=dummy_state, position=position,
                             virtual_every=10 if n == 50 else 0)
        A, _ = chain.matrices()
        for Y in (rng.normal(size=chain.n_states), rng.normal(size=(chain.n_states, 6))):
            got = chain.product(Y)
            want = A @ Y
            assert got.shape == Y.shape
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())

    @pytest.mark.parametrize("n", [1, 2, 50])
    def test_train_rhs_is_the_chain_plus_own_forces(self, n):
        """With a2 = 0 and a0 = 0 on flat track, train_rhs(x, u) = A x + B u (virtual links too)."""
        train = chain_of_size(n)
        linear = Train(vehicles=tuple(Vehicle(mass=v.mass, a0=0.0, a1=v.a1, a2=0.0)
                                      for v in train.vehicles), couplers=train.couplers)
        A, B = Chain.from_train(linear, linear.davis[1], position=True).matrices()
        rng = np.random.default_rng(7)
        X = np.vstack([rng.uniform(10, 30, (n, 4)), rng.normal(0, 1e-3, (n - 1, 4)),
                       rng.uniform(0, 1e3, (1, 4))])
        U = rng.normal(0, 3e4, (n, 4))
        want = A @ X + B @ U
        np.testing.assert_allclose(train_rhs(linear, X, U), want, rtol=1e-12,
                                   atol=1e-12 * np.abs(want).max())

    def test_forces(self):
        """f = k delta + d (v_i - v_{i+1}) for states and stacks of states."""
        chain = Chain(mass=[1.0, 1.0, 1.0], stiffness=[10.0, 0.0], damping=[2.0, 0.0],
                      virtual=[False, True], speed_damping=[0.0] * 3)
        x = np.array([3.0, 2.0, 5.0, 0.1, 7.0])
        np.testing.assert_allclose(chain.forces(x), [10 * 0.1 + 2 * 1.0, 0.0])
        np.testing.assert_allclose(chain.forces(np.c_[x, 2 * x]), [[3.0, 6.0], [0.0, 0.0]])


class TestChainValidation:
    def test_virtual_links_carry_no_force(self):
        with pytest.raises(ModelError, match="virtual link"):
            Chain(mass=[1.0, 1.0], stiffness=[5.0], damping=[0.0], virtual=[True],
                  speed_damping=[0.0, 0.0])

    @pytest.mark.parametrize("field, value", [("stiffness", [1.0, 2.0]), ("damping", []),
                                              ("speed_damping", [0.0])])
    def test_shapes(self, field, value):
        kwargs = dict(mass=[1.0, 1.0], stiffness=[5.0], damping=[0.0], virtual=[False],
                      speed_damping=[0.0, 0.0])
        kwargs[field] = value
        with pytest.raises(DimensionError, match=field):
            Chain(**kwargs)

    def test_masses_and_product_rows(self):
        with pytest.raises(ModelError, match="mass"):
            Chain(mass=[1.0, -1.0], stiffness=[5.0], damping=[0.0], virtual=[False],
                  speed_damping=[0.0, 0.0])
        chain = Chain(mass=[1.0], stiffness=[], damping=[], virtual=[], speed_damping=[0.0])
        with pytest.raises(DimensionError, match="rows"):
            chain.product(np.zeros(3))


class TestForceSplit:
    def test_two_vehicles_by_hand(self):
        """Shares (1, 0): the motor car pulls the trailer, the coupler carries its need."""
        motor = Vehicle(mass=2e4, a0=0.01, a1=1e-3, a2=1e-5, traction_share=1.0)
        trailer = Vehicle(mass=3e4, a0=0.02, a1=2e-3, a2=2e-5, traction_share=0.0)
        train = Train(vehicles=(motor, trailer), couplers=(Coupler(stiffness=1e7),))
        v, a = 20.0, 0.1
        w = np.array([2e4 * (0.01 + 1e-3 * v + 1e-5 * v * v + a),
                      3e4 * (0.02 + 2e-3 * v + 2e-5 * v * v + a)])
        q = ForceSplit(train)([v], [a])
        np.testing.assert_allclose(q.inputs[0], [w.sum(), 0.0], rtol=1e-14)
        np.testing.assert_allclose(q.coupler_forces[0], [w[1]], rtol=1e-13)
        np.testing.assert_allclose(q.elongations[0], [w[1] / 1e7], rtol=1e-13)
        np.testing.assert_allclose(q.resistance[0], w, rtol=1e-14)

    def test_virtual_links_split_the_train_into_groups(self):
        """Each group supplies its own need; virtual links carry no force and no elongation."""
        train = chain_of_size(50)
        q = ForceSplit(train)(np.linspace(5.0, 30.0, 7), np.linspace(-0.2, 0.3, 7))
        for group in train.groups:
            idx = list(group)
            np.testing.assert_allclose(q.inputs[:, idx].sum(axis=1),
                                       q.resistance[:, idx].sum(axis=1), rtol=1e-13)
        assert not q.coupler_forces[:, train.virtual].any()
        assert not q.elongations[:, train.virtual].any()

    def test_vectorised_rows_equal_single_pairs(self):
        """Every row of a vectorised call is bit-identical to the call for its pair alone."""
        train = PRESETS["heavy_haul_1p2p1"]()
        split = ForceSplit(train)
        speeds, accels = np.array([3.0, 19.0, 27.5]), np.array([0.05, 0.0, -0.3])
        q = split(speeds, accels)
        for k in range(3):
            one = split(speeds[k : k + 1], accels[k : k + 1])
            for name in ("inputs", "coupler_forces", "elongations", "resistance"):
                np.testing.assert_array_equal(getattr(q, name)[k], getattr(one, name)[0])

    def test_equilibrium_is_the_split_at_one_speed(self):
        """equilibrium() returns the split's forces at its speed (cruise, and on a grade)."""
        train = PRESETS["crh2_8car"]()
        for grade in (0.0, 6.0):
            eq = equilibrium(train, 50.0, grade_permille=grade)
            line = None if grade == 0.0 else np.full(8, permille_to_accel(grade))
            q = ForceSplit(train)([50.0], [0.0], line)
            np.testing.assert_allclose(eq.inputs, q.inputs[0], rtol=1e-12)
            np.testing.assert_allclose(eq.coupler_forces, q.coupler_forces[0], rtol=1e-9,
                                       atol=1e-9)

    def test_own_allocation_loads_no_coupler(self):
        q = ForceSplit(PRESETS["crh2_half"](), allocation="own")([40.0, 80.0], [0.0, 0.2])
        np.testing.assert_array_equal(q.inputs, q.resistance)
        assert not q.coupler_forces.any()

    def test_errors(self):
        car = Vehicle(mass=4e4, a0=0.01, a1=0, a2=0, traction_share=0.0)
        train = Train(vehicles=(car, car), couplers=(Coupler(stiffness=1e7),))
        with pytest.raises(ModelError, match="no traction"):
            ForceSplit(train)
        with pytest.raises(ModelError, match="allocation"):
            ForceSplit(train, allocation="even")
        assert ForceSplit(train, allocation="own")([10.0], [0.0]).inputs.shape == (1, 2)


def test_plant_lives_in_models_and_sim_reexports_it():
    """Controllers use trainctl.models.Plant; trainctl.sim keeps offering the same class."""
    import trainctl.sim
    import trainctl.sim.plant
    from trainctl.controllers.mpc.observer import KalmanObserver

    assert trainctl.sim.Plant is Plant and trainctl.sim.plant.Plant is Plant
    assert KalmanObserver.__init__.__globals__["Plant"] is Plant


def test_controllers_do_not_import_sim():
    """The observer and the MPC controller load no part of trainctl.sim (data-flow direction)."""
    import subprocess
    import sys

    code = ("import sys, trainctl.controllers.mpc.observer, trainctl.controllers.mpc.controller; "
            "print(sorted(m for m in sys.modules if m.startswith('trainctl.sim')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
