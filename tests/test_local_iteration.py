"""Tests of neighbourhood-local N-DMPC (trainctl.controllers.mpc.theory.local_iteration).

Independent routes: the local QPs iterated one coach at a time with their own
step-by-step prediction (sampled by quadrature, not by the augmented matrix
exponential) and solved by least squares; a hand-derived two-coach case;
centralised MPC for all-coach neighbourhoods.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad_vec
from scipy.linalg import expm

from trainctl.controllers.mpc.theory.iteration import spectral_radius
from trainctl.controllers.mpc.theory.local_iteration import (
    coach_predictions,
    local_closed_loop,
    local_iteration,
    local_model,
    local_nash_gain,
    local_prediction_error,
    local_threshold_weight,
    train_state_owner,
)
from trainctl.controllers.mpc.theory.mpc import MPCDesign, prediction
from trainctl.design import build_design
from trainctl.exceptions import ModelError
from trainctl.scenario import load_scenario


@pytest.fixture(scope="module")
def well():
    fam = build_design(load_scenario("crh2-dmpc-well-sampled")).family("mpc")
    return fam.mpc, fam.model.design, fam.scenario.model.sample_time


def _model(design, sys, dt, hold="foh", substeps=1, boundary="state"):
    return local_model(design, sys.A, sys.B, dt, train_state_owner(design.n_inputs), hold=hold,
                       substeps=substeps, boundary=boundary)


def _small(design, P=6, M=2, r=None):
    """The design with a shorter horizon (same discrete model and weights)."""
    return MPCDesign(A=design.A, B=design.B, C=design.C, prediction_horizon=P, control_horizon=M,
                     form=design.form, q=design.q, r=design.r if r is None else np.full(4, r),
                     output_owner=design.output_owner, neighbourhoods=design.neighbourhoods)


# -- independent route: the local QPs, coach by coach --------------------------------------------

class LocalCoach:
    """Coach i's local problem, built from the continuous blocks without the module's code."""

    def __init__(self, design, A, B, dt, owner, i, hold, substeps=1, boundary="state"):
        so = np.asarray(owner)
        mem = design.neighbourhoods[i]
        n = design.n_inputs
        self.i, self.design, self.N = i, design, substeps
        self.S = np.array([s for s in range(A.shape[0]) if so[s] in mem])
        if boundary == "force":  # the train's rear boundary coupler (state n + c) is exchanged
            self.S = np.array([s for s in self.S if not (
                s >= n and so[s] != i and so[s] + 1 not in mem)])
        self.R = np.array([r for r, o in enumerate(design.output_owner) if o in mem])
        self.O = np.array([s for s in range(A.shape[0]) if s not in self.S
                           and (np.any(A[self.S, s]) or np.any(design.C[self.R, s]))], dtype=int)
        self.own = np.flatnonzero(so == i)
        a, b, e = A[np.ix_(self.S, self.S)], B[self.S], A[np.ix_(self.S, self.O)]
        dt = dt / substeps
        # Sampling by quadrature: z(k+1) = e^{aT} z + ∫ e^{a(T-s)} (b u + e w(s)) ds.
        self.Ad = expm(a * dt)
        self.Bd = quad_vec(lambda s: expm(a * (dt - s)) @ b, 0, dt, epsabs=1e-13)[0]
        if hold == "zoh":
            self.E0 = quad_vec(lambda s: expm(a * (dt - s)) @ e, 0, dt, epsabs=1e-13)[0]
            self.E1 = np.zeros_like(self.E0)
        else:
            self.E0 = quad_vec(lambda s: expm(a * (dt - s)) @ e * (1 - s / dt), 0, dt,
                               epsabs=1e-13)[0]
            self.E1 = quad_vec(lambda s: expm(a * (dt - s)) @ e * (s / dt), 0, dt,
                               epsabs=1e-13)[0]

    def inputs(self, U, u_prev):
        """Inputs of every coach at steps 0..P-1 from the plan (moves) U."""
        d = self.design
        n, M, P = d.n_inputs, d.control_horizon, d.prediction_horizon
        moves = U.reshape(M, n)
        if d.form == "du":
            moves = u_prev + np.cumsum(moves, axis=0)
        return np.array([moves[min(t, M - 1)] for t in range(P)])

    def simulate(self, x, u_prev, U, X):
        """Member outputs and own states over the horizon (X: predicted states, (P·N, nx))."""
        d = self.design
        P, N = d.prediction_horizon, self.N
        u = self.inputs(U, u_prev)
        outer = np.vstack([x[None, :], X])[:, self.O]       # z_O at the fine samples 0..P·N
        z = x[self.S].copy()
        ys, zs = [], []
        for t in range(P * N):
            z = self.Ad @ z + self.Bd @ u[t // N] + self.E0 @ outer[t] + self.E1 @ outer[t + 1]
            full = np.zeros(d.A.shape[0])
            full[self.S], full[self.O] = z, outer[t + 1]
            if (t + 1) % N == 0:
                ys.append(d.C[self.R] @ full)
            zs.append(full[self.own])
        return np.concatenate(ys), np.array(zs)

    def best(self, x, u_prev, U, X):
        """Minimise the neighbourhood cost over the own moves (least squares on the residual)."""
        d = self.design
        n, M, P = d.n_inputs, d.control_horizon, d.prediction_horizon
        cols = np.arange(M) * n + self.i
        q = np.sqrt(np.tile(d.q[self.R], P))

        def residual(own):
            trial = U.copy()
            trial[cols] = own
            y, _ = self.simulate(x, u_prev, trial, X)
            return np.concatenate([q * y, np.sqrt(d.r[self.i]) * own])

        r0 = residual(np.zeros(M))
        J = np.column_stack([residual(np.eye(M)[m]) - r0 for m in range(M)])
        own = np.linalg.lstsq(J, -r0, rcond=None)[0]
        trial = U.copy()
        trial[cols] = own
        return own, self.simulate(x, u_prev, trial, X)[1]


def iterate(design, sys, dt, x, u_prev, iterations, hold="foh", record=False, substeps=1,
            boundary="state"):
    n, nx = design.n_inputs, design.A.shape[0]
    M, P = design.control_horizon, design.prediction_horizon
    owner = train_state_owner(n)
    coaches = [LocalCoach(design, np.asarray(sys.A), np.asarray(sys.B), dt, owner, i, hold,
                          substeps, boundary) for i in range(n)]
    U, X = np.zeros(M * n), np.zeros((P * substeps, nx))
    history = []
    for _ in range(iterations):
        U_new, X_new = U.copy(), X.copy()
        for c in coaches:
            own, zs = c.best(x, u_prev, U, X)
            U_new[np.arange(M) * n + c.i] = own
            X_new[:, c.own] = zs
        U, X = U_new, X_new
        if record:
            history.append(np.concatenate([U, X.ravel()]))
    return (U, X, history) if record else (U, X)


# -- tests ---------------------------------------------------------------------------------------

def test_all_coach_neighbourhoods_give_centralised_mpc(well):
    design, sys, dt = well
    n = design.n_inputs
    full = design.with_neighbourhoods([tuple(range(n))] * n)
    it = local_iteration(full, _model(full, sys, dt))
    pred = prediction(full)
    Kc = pred.centralised_gain()
    expected = np.hstack([-Kc @ pred.Phi, -Kc @ pred.Su])
    got = local_nash_gain(it)[:it.n_plan]
    assert np.abs(got - expected).max() < 1e-9 * np.abs(expected).max()
    assert np.allclose(local_prediction_error(full, _model(full, sys, dt)), 0.0, atol=1e-12)


@pytest.mark.parametrize(("hold", "substeps", "boundary"),
                         [("foh", 1, "state"), ("zoh", 1, "state"), ("foh", 3, "force")])
def test_fixed_point_equals_iterated_local_qps(well, hold, substeps, boundary):
    design, sys, dt = well
    small = _small(design, r=60.0)  # above R* of the local iteration: it converges
    it = local_iteration(small, _model(small, sys, dt, hold, substeps, boundary))
    assert it.rho < 0.9
    rng = np.random.default_rng(3)
    x = rng.normal(size=small.A.shape[0]) * np.r_[np.ones(4), np.full(3, 1e-4)]
    u_prev = rng.normal(size=4)
    U, X = iterate(small, sys, dt, x, u_prev, 300, hold, substeps=substeps, boundary=boundary)
    xi = local_nash_gain(it) @ np.concatenate([x, u_prev])
    assert np.allclose(U, xi[:it.n_plan], rtol=1e-7, atol=1e-9 * np.abs(U).max())
    assert np.allclose(X.ravel(), xi[it.n_plan:], rtol=1e-7, atol=1e-9 * np.abs(X).max())


def test_rho_equals_measured_contraction(well):
    design, sys, dt = well
    small = _small(design, r=0.02)  # just above R* ≈ 0.0102: slow, complex dominant pair
    it = local_iteration(small, _model(small, sys, dt))
    assert 0.8 < it.rho < 0.95
    rng = np.random.default_rng(5)
    x = rng.normal(size=small.A.shape[0]) * np.r_[np.ones(4), np.full(3, 1e-4)]
    *_, hist = iterate(small, sys, dt, x, np.zeros(4), 121, record=True)
    diffs = [np.linalg.norm(b - a) for a, b in zip(hist[:-1], hist[1:], strict=True)]
    span = 100  # the geometric mean over many iterations averages out the complex pair's beat
    measured = (diffs[119] / diffs[119 - span]) ** (1 / span)
    assert diffs[119] > 1e-9 * diffs[0]  # still far above rounding
    assert measured == pytest.approx(it.rho, rel=5e-3)


def test_du_form_fixed_point_equals_iterated_local_qps(well):
    design, sys, dt = well
    small = MPCDesign(A=design.A, B=design.B, C=design.C, prediction_horizon=5,
                      control_horizon=2, form="du", q=design.q, r=np.full(4, 200.0),
                      output_owner=design.output_owner, neighbourhoods=design.neighbourhoods)
    it = local_iteration(small, _model(small, sys, dt))
    assert it.rho < 0.95
    rng = np.random.default_rng(7)
    x = rng.normal(size=small.A.shape[0]) * np.r_[np.ones(4), np.full(3, 1e-4)]
    u_prev = rng.normal(size=4)
    U, _ = iterate(small, sys, dt, x, u_prev, 600)
    xi = local_nash_gain(it) @ np.concatenate([x, u_prev])
    assert np.allclose(U, xi[:it.n_plan], rtol=1e-6, atol=1e-9 * np.abs(U).max())


def test_two_coach_case_by_hand():
    # dz0/dt = b u0 + c z1, dz1/dt = b u1 + c z0; neighbourhoods {i}; P = 2, M = 1, u-form, ZOH.
    b, c, T, q, r = 0.7, 0.3, 0.5, 2.0, 0.4
    Ac, Bc = np.array([[0.0, c], [c, 0.0]]), b * np.eye(2)
    big = np.zeros((4, 4))
    big[:2, :2], big[:2, 2:] = Ac * T, Bc * T
    Md = expm(big)
    design = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
                       control_horizon=1, form="u", q=np.full(2, q), r=np.full(2, r),
                       output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    it = local_iteration(design, local_model(design, Ac, Bc, T, (0, 1), hold="zoh"))
    beta, gamma = b * T, c * T
    den = 5 * q * beta**2 + r
    kappa = 2 * q * beta**2 * gamma / den
    # Coach i: u_i = -qβ(3 a_i + 2γ X_j(1))/den with a_i = z_i + γ z_j; X_i(1) = a_i + β u_i.
    assert it.rho == pytest.approx(kappa, rel=1e-12)
    z = 1.3
    a0 = z * (1 + gamma)
    s = a0 * (2 * q * beta**2 + r) / (den + 2 * q * beta**2 * gamma)
    u = -q * beta * (3 * a0 + 2 * gamma * s) / den
    xi = local_nash_gain(it) @ np.array([z, z, 0.0, 0.0])
    assert xi[:2] == pytest.approx([u, u], rel=1e-12)
    assert xi[2:4] == pytest.approx([s, s], rel=1e-12)          # X(1) = [z0(k+1), z1(k+1)]
    assert xi[4:6] == pytest.approx([s + gamma * s + beta * u] * 2, rel=1e-12)


def test_closed_loop_of_the_fixed_point(well):
    design, sys, dt = well
    small = _small(design, r=60.0)
    model = _model(small, sys, dt)
    it = local_iteration(small, model)
    gain = local_nash_gain(it)[:it.n_plan]
    A_cl = local_closed_loop(small, gain)
    # Step the loop: x(k+1) = A x + B u with u the first move of the iterated local QPs.
    rng = np.random.default_rng(11)
    x = rng.normal(size=7) * np.r_[np.ones(4), np.full(3, 1e-4)]
    U, _ = iterate(small, sys, dt, x, np.zeros(4), 300)
    x_next = small.A @ x + small.B @ U[:4]
    assert np.allclose(A_cl @ x, x_next, rtol=1e-7, atol=1e-10)


def test_threshold_weight_is_where_rho_crosses_one(well):
    design, sys, dt = well
    small = _small(design)
    model = _model(small, sys, dt)
    r_star = local_threshold_weight(small, model, rtol=1e-6)
    coaches = coach_predictions(small, model)
    assert local_iteration(small, model, coaches, r=r_star * 1.001).rho < 1
    assert local_iteration(small, model, coaches, r=r_star * 0.999).rho > 1


def test_local_model_refuses_a_mismatched_continuous_model(well):
    design, sys, dt = well
    with pytest.raises(ModelError, match="zero-order hold"):
        local_model(design, sys.A, 2 * np.asarray(sys.B), dt, train_state_owner(4))
    with pytest.raises(ModelError, match="hold"):
        local_model(design, sys.A, sys.B, dt, train_state_owner(4), hold="tustin")
    assert spectral_radius(np.zeros((0, 0))) == 0.0


@pytest.mark.parametrize(("hold", "order"), [("foh", 2), ("zoh", 1)])
def test_prediction_error_falls_with_the_order_of_the_hold(well, hold, order):
    design, sys, dt = well
    small = _small(design)
    e1 = local_prediction_error(small, _model(small, sys, dt, hold, 4))
    e2 = local_prediction_error(small, _model(small, sys, dt, hold, 8))
    assert np.all(e1 > 0)
    assert e1 / e2 == pytest.approx(np.full(4, 2.0**order), rel=0.05)
