"""Delays in the linear analysis (trainctl.analysis.delay), against closed forms and simulation."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

from trainctl.analysis.delay import (
    consensus_delay_bound,
    delay_abscissa,
    delay_margin,
    discrete_delay_loop,
    held_data_age,
    pade_loop,
)
from trainctl.design import build_model
from trainctl.exceptions import DimensionError, ModelError
from trainctl.scenario import load_scenario


@pytest.mark.parametrize("a", [0.5, 2.0])
def test_pure_delay_margin_is_pi_over_2a(a: float) -> None:
    """ẋ = −a x(t − τ): characteristic s + a e^{−sτ} = 0 crosses at ω = a, τ = π/(2a)."""
    res = delay_margin([[0.0]], [[1.0]], [[-a]], tau_max=10.0)
    assert res.margin == pytest.approx(math.pi / (2 * a), rel=1e-5)
    assert res.crossing_frequency == pytest.approx(a, rel=1e-4)
    assert res.agree


@pytest.mark.parametrize(("b", "a"), [(1.0, 2.0), (0.2, 1.0), (0.0, 3.0)])
def test_damped_delay_margin_closed_form(b: float, a: float) -> None:
    """ẋ = −b x − a x(t − τ), a > b: ω = √(a² − b²), τ* = arccos(−b/a)/ω."""
    omega = math.sqrt(a * a - b * b)
    res = delay_margin([[-b]], [[1.0]], [[-a]], tau_max=10.0)
    assert res.margin == pytest.approx(math.acos(-b / a) / omega, rel=1e-5)
    assert res.margins[1] == pytest.approx(res.margins[0], rel=1e-3)


def test_delay_independent_stability_is_infinite() -> None:
    """a < b: stable for every delay."""
    res = delay_margin([[-2.0]], [[1.0]], [[-1.0]], tau_max=20.0)
    assert math.isinf(res.margin) and res.agree
    assert res.to_dict()["margin"] is None


def test_unstable_without_delay_has_zero_margin() -> None:
    assert delay_margin([[1.0]], [[1.0]], [[-0.5]], tau_max=1.0).margin == 0.0


def test_pade_loop_poles_approach_the_exact_root() -> None:
    """At τ = 1, ẋ = −x(t−1): the rightmost root of s + e^{−s} = 0 is −0.3181 ± 1.3372j."""
    lam = np.linalg.eigvals(np.asarray(pade_loop([[0.0]], [[1.0]], [[-1.0]], 1.0, 10).A))
    top = lam[np.argmax(lam.real)]
    assert top.real == pytest.approx(-0.318132, abs=1e-5)
    assert abs(top.imag) == pytest.approx(1.337236, abs=1e-5)


def test_consensus_bound_closed_form() -> None:
    """Path of 3 pinned at every node: L + I has eigenvalues 1, 2, 4, so τ < π/(2·0.1·4)."""
    L = np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]) + np.eye(3)
    assert consensus_delay_bound(0.1 * L) == pytest.approx(math.pi / (2 * 0.1 * 4.0))
    with pytest.raises(DimensionError, match="symmetric"):
        consensus_delay_bound([[1.0, 2.0], [0.0, 1.0]])


def _heavy_haul(kappa: float = 0.1):
    """heavy-haul-hinf: the leader-following speed law u = −M κ (B + L) v(t − τ) [kN]."""
    sc = load_scenario("heavy-haul-hinf")
    model = build_model(sc)
    sys = model.design  # no dummy state, inputs in kN
    A0, B = np.asarray(sys.A, dtype=float), np.asarray(sys.B, dtype=float)
    n, N = model.n_vehicles, A0.shape[0]
    graph = sc.graph()
    Lp = kappa * (np.asarray(graph.laplacian()) + np.asarray(graph.pinning_matrix()))
    K = -np.diag(model.train.mass) @ Lp @ np.eye(n, N) / 1e3
    return A0, B, K, Lp


def test_full_train_margin_is_far_below_the_consensus_bound() -> None:
    """κ = 0.1 1/s: the coupler modes cut the margin to about 0.6 s against π/(2λ_max) ≈ 3.6 s."""
    A0, B, K, Lp = _heavy_haul()
    res = delay_margin(A0, B, K, tau_max=5.0)
    bound = consensus_delay_bound(Lp)
    assert bound == pytest.approx(math.pi / (2 * np.linalg.eigvalsh(Lp).max()))
    assert 3.0 < bound < 4.0
    assert 0.4 < res.margin < 0.8 and res.margin < bound / 4
    assert res.agree
    # the crossing mode is a coupler mode, not a consensus one (ω ≫ λ_max)
    assert res.crossing_frequency > 5 * np.linalg.eigvalsh(Lp).max()


@pytest.mark.parametrize(("factor", "stable"), [(0.9, True), (1.1, False)])
def test_margin_confirmed_by_simulating_the_sampled_delay_system(factor: float,
                                                                  stable: bool) -> None:
    """The buffered sampled loop (delay = 50 samples) decays at 0.9× and grows at 1.1×."""
    A0, B, K, _ = _heavy_haul()
    margin = delay_margin(A0, B, K, tau_max=5.0).margin
    d = 50
    tau = factor * margin
    dt = tau / d
    sysd = ct.c2d(ct.ss(A0, B, np.eye(A0.shape[0]), 0), dt, method="zoh")
    loop = discrete_delay_loop(sysd.A, sysd.B, np.zeros_like(K), K, d, dt)
    rho = np.abs(np.linalg.eigvals(np.asarray(loop.A))).max()
    assert (rho < 1.0) == stable
    x = np.zeros(loop.nstates)
    x[0] = 1.0  # the head 1 m/s off
    A = np.asarray(loop.A)
    steps = int(round(300.0 / dt))
    early = late = 0.0
    for k in range(steps):
        x = A @ x
        if k < steps // 2:
            early = max(early, float(np.abs(x[:4]).max()))
        else:
            late = max(late, float(np.abs(x[:4]).max()))
    assert (late < early) == stable


def test_discrete_loop_without_delay_and_the_buffer() -> None:
    """d = 0 is the plain loop; d = 1 delays the feedback by exactly one sample."""
    Ad, Bd = np.array([[1.0]]), np.array([[0.5]])
    plain = discrete_delay_loop(Ad, Bd, [[0.0]], [[-1.0]], 0, 1.0)
    assert np.allclose(plain.A, [[0.5]])
    one = discrete_delay_loop(Ad, Bd, [[0.0]], [[-1.0]], 1, 1.0)
    # x+ = x + 0.5 y, y+ = -x: characteristic z² − z + 0.5
    assert np.allclose(np.sort_complex(np.linalg.eigvals(np.asarray(one.A))),
                       np.sort_complex(np.roots([1.0, -1.0, 0.5])))


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(DimensionError, match="A0 must be"):
        pade_loop(np.zeros((2, 2)), np.ones((3, 1)), np.ones((1, 2)), 1.0)
    with pytest.raises(ModelError, match="'tau'"):
        delay_abscissa([[0.0]], [[1.0]], [[-1.0]], -1.0)
    with pytest.raises(ModelError, match="'order'"):
        pade_loop([[0.0]], [[1.0]], [[-1.0]], 1.0, order=0)
    with pytest.raises(ModelError, match="'tau_max'"):
        delay_margin([[0.0]], [[1.0]], [[-1.0]], tau_max=0.0)
    with pytest.raises(ModelError, match="'delay_steps'"):
        discrete_delay_loop([[1.0]], [[1.0]], [[0.0]], [[-1.0]], -1, 1.0)
    age = held_data_age(0.2, (0.0, 2.0))
    assert age.quantile(1.0) <= 2.2
    for q in (0.0, 1.5, -0.1, math.nan, True):
        with pytest.raises(ModelError, match=r"DataAge.quantile: 'q' must be a probability"):
            age.quantile(q)


@pytest.mark.parametrize("order", [1, 4, 8, 12])
@pytest.mark.parametrize("tau", [0.013, 0.5, 3.7])
def test_scaled_pade_realisation_is_control_pade_at_each_delay(tau: float, order: int) -> None:
    """The delay-τ approximant is realised from the 1 s one (A/τ, B/τ, C, D); its response
    equals the transfer function of ``control.pade(τ, q)`` itself at every frequency."""
    import control as ct

    from trainctl.analysis.delay import _pade_ss

    A, B, C, D = _pade_ss(tau, order)
    num, den = ct.pade(tau, order)
    for w in np.geomspace(1e-3, 1e3, 25) / tau:
        s = 1j * w
        realised = (C @ np.linalg.solve(s * np.eye(order) - A, B) + D)[0, 0]
        direct = np.polyval(num, s) / np.polyval(den, s)
        assert abs(realised - direct) <= 1e-11 * max(1.0, abs(direct))
