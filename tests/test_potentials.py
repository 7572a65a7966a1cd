# Tests of the pair potentials against hand computations and independent routes.
"""Potentials: hand-computed values, finite differences, independent quadrature, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from trainctl.controllers.continuous.potentials import (
    BarrierPotential,
    FlockingPotential,
    PairPotential,
    QuadraticPotential,
    SigmaNormPotential,
    bump,
    phi,
    phi_alpha,
    psi_alpha,
    sigma1,
    sigma_grad,
    sigma_norm,
)
from trainctl.exceptions import ModelError

# A small normalised set (Olfati-Saber-like: d = 7, r = 1.2 d, eps = 0.1):
# d_alpha = (sqrt(1 + 0.1*49) - 1)/0.1, r_alpha = (sqrt(1 + 0.1*70.56) - 1)/0.1.
D_A = (math.sqrt(5.9) - 1.0) / 0.1
R_A = (math.sqrt(8.056) - 1.0) / 0.1
KW = {"d_alpha": D_A, "r_alpha": R_A, "h": 0.2, "a": 1.0, "b": 5.0}


def _central(f, x: float, step: float) -> float:
    return (f(x + step) - f(x - step)) / (2.0 * step)


def _trapezoid_psi(z: float, n: int = 1_000_001) -> float:
    """psi_alpha(z) by a trapezoid rule on n points (independent of quad)."""
    s = np.linspace(D_A, min(z, R_A), n)
    w = s / R_A
    rho = np.where(w < 0.2, 1.0, np.where(w <= 1.0, 0.5 * (1 + np.cos(np.pi * (w - 0.2) / 0.8)), 0))
    c = 4.0 / math.sqrt(20.0)                    # |a - b| / sqrt(4ab), a = 1, b = 5
    y = s - D_A + c
    values = rho * 0.5 * (6.0 * y / np.sqrt(1.0 + y * y) - 4.0)
    return float(np.trapezoid(values, s))


# ------------------------------------------------------------------ primitives, by hand

def test_sigma_norm_and_gradient_hand_values() -> None:
    assert sigma_norm(0.0, 0.1) == 0.0
    assert sigma_norm(4.0, 0.5) == pytest.approx(4.0, rel=1e-15)   # (sqrt(9) - 1)/0.5
    assert sigma_norm(-4.0, 0.5) == pytest.approx(4.0, rel=1e-15)
    assert sigma_grad(4.0, 0.5) == pytest.approx(4.0 / 3.0, rel=1e-15)
    assert sigma_grad(-4.0, 0.5) == pytest.approx(-4.0 / 3.0, rel=1e-15)
    assert sigma1(1.0) == pytest.approx(1.0 / math.sqrt(2.0), rel=1e-15)


def test_sigma_grad_is_derivative_of_sigma_norm() -> None:
    for z in (-3.0, 0.3, 2.0, 40.0):
        fd = _central(lambda x: sigma_norm(x, 0.1), z, 1e-5)
        assert sigma_grad(z, 0.1) == pytest.approx(fd, rel=1e-8)


def test_bump_branches() -> None:
    assert bump(-0.1, 0.2) == 0.0
    assert bump(0.0, 0.2) == 1.0
    assert bump(0.1, 0.2) == 1.0
    assert bump(0.2, 0.2) == pytest.approx(1.0, abs=1e-15)       # cos(0)
    assert bump(0.6, 0.2) == pytest.approx(0.5, abs=1e-15)       # midpoint of [h, 1]
    assert bump(0.4, 0.2) == pytest.approx(0.5 * (1 + math.sqrt(0.5)), rel=1e-14)  # cos(pi/4)
    assert bump(1.0, 0.2) == pytest.approx(0.0, abs=1e-15)       # cos(pi)
    assert bump(1.2, 0.2) == 0.0


def test_vectorised_shapes_and_scalars() -> None:
    z = np.array([[0.1, 0.6], [1.2, 0.4]])
    out = bump(z, 0.2)
    assert isinstance(out, np.ndarray) and out.shape == (2, 2)
    assert out[0, 1] == pytest.approx(0.5)
    assert isinstance(sigma_norm(1.0, 0.1), float)
    psi = psi_alpha(np.array([D_A, R_A + 1.0]), **KW)
    assert isinstance(psi, np.ndarray) and psi.shape == (2,) and psi[0] == 0.0


def test_phi_zero_at_zero_with_unsigned_shift_only() -> None:
    a, b = 1.0, 5.0
    assert phi(0.0, a, b) == pytest.approx(0.0, abs=1e-14)
    signed_c = (a - b) / math.sqrt(4 * a * b)                      # the signed variant
    signed = 0.5 * ((a + b) * sigma1(signed_c) + (a - b))
    assert signed == pytest.approx(-4.0, rel=1e-12)                # = a - b, not 0
    assert phi(50.0, a, b) == pytest.approx(a, abs=2e-3)           # attraction level
    assert phi(-50.0, a, b) == pytest.approx(-b, abs=2e-3)         # repulsion level


@pytest.mark.parametrize(("a", "b"), [(1.0, 5.0), (1.0, 1.0), (2.0, 3.0)])
def test_phi_slope_at_zero(a: float, b: float) -> None:
    c2 = (a - b) ** 2 / (4 * a * b)
    expected = 0.5 * (a + b) * (1.0 + c2) ** -1.5
    assert _central(lambda z: phi(z, a, b), 0.0, 1e-5) == pytest.approx(expected, rel=1e-8)


def test_phi_alpha_zero_at_d_alpha_and_cut_off() -> None:
    assert phi_alpha(D_A, **KW) == pytest.approx(0.0, abs=1e-14)
    assert phi_alpha(R_A, **KW) == pytest.approx(0.0, abs=1e-14)
    assert phi_alpha(R_A + 0.5, **KW) == 0.0
    assert phi_alpha(0.5 * D_A, **KW) < 0.0 < phi_alpha(0.5 * (D_A + R_A), **KW)


# ------------------------------------------------------------------ psi_alpha

def test_psi_alpha_minimum_monotone_and_flat_beyond_range() -> None:
    assert psi_alpha(D_A, **KW) == 0.0
    below = np.asarray(psi_alpha(np.linspace(0.0, D_A, 15), **KW))
    above = np.asarray(psi_alpha(np.linspace(D_A, R_A, 15), **KW))
    assert np.all(np.diff(below) < 0.0)          # decreasing towards d_alpha
    assert np.all(np.diff(above) > 0.0)          # increasing away from it
    assert np.all(below[:-1] > 0.0) and np.all(above[1:] > 0.0)
    far = np.asarray(psi_alpha([R_A, R_A + 1.0, 10 * R_A], **KW))
    assert far[1] == far[0] and far[2] == far[0]


@pytest.mark.parametrize("z", [0.0, 3.0, 0.2 * R_A, 12.0, D_A + 0.7, D_A + 2.5, R_A])
def test_psi_alpha_against_trapezoid(z: float) -> None:
    expected = _trapezoid_psi(z)
    assert psi_alpha(z, **KW) == pytest.approx(expected, rel=1e-9, abs=1e-11)


@pytest.mark.parametrize("z", [1.0, 5.0, D_A - 0.5, D_A + 0.5, 0.5 * (D_A + R_A)])
def test_psi_alpha_derivative_is_phi_alpha(z: float) -> None:
    fd = _central(lambda x: psi_alpha(x, **KW), z, 1e-4)
    assert fd == pytest.approx(phi_alpha(z, **KW), rel=1e-6, abs=1e-8)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 30.0))
def test_psi_alpha_non_negative(z: float) -> None:
    assert psi_alpha(z, **KW) >= 0.0


# ------------------------------------------------------------------ FlockingPotential

def test_default_set_is_spec_section_3_5() -> None:
    p = FlockingPotential()
    assert (p.desired_gap, p.r, p.length_scale, p.eps, p.h, p.a, p.b, p.force_scale) == (
        500.0, 600.0, 50.0, 0.1, 0.2, 1.0, 1.0, 0.05)


def test_spec_ratios_by_hand() -> None:
    # §3.5 set: d~ = 10, r~ = 12. sqrt(11) = 3.3166248, sqrt(15.4) = 3.9242834
    # -> d_alpha = 23.166248, r_alpha = 29.242834, ratio = 0.7922026;
    # (0.7922026 - 0.2)/0.8 = 0.7402532, pi - pi*0.7402532 = 0.8160186,
    # cos(0.8160186) = 0.6851268 (series to x^8) -> rho = (1 - 0.6851268)/2 = 0.1574366.
    p = FlockingPotential()
    assert p.d_alpha == pytest.approx(23.166248, abs=1e-6)
    assert p.r_alpha == pytest.approx(29.242834, abs=1e-6)
    assert p.d_alpha / p.r_alpha == pytest.approx(0.7922026, abs=1e-7)
    assert p.adjacency(500.0) == pytest.approx(0.1574366, abs=1e-7)
    # Spec §3.4 item 3 quotes "≈ 0.78" and "≈ 0.18": those are Olfati-Saber's d = 7
    # (normalised), r = 8.4: d_alpha = 14.289916, r_alpha = 18.383094, ratio 0.7773401,
    # (0.7773401 - 0.2)/0.8 = 0.7216751, cos(pi*0.7216751) = -0.6414700 -> rho = 0.1792650.
    q = FlockingPotential(desired_gap=7.0, length_scale=1.0)
    assert q.d_alpha / q.r_alpha == pytest.approx(0.78, abs=0.005)   # spec's 2 digits
    assert q.adjacency(7.0) == pytest.approx(0.18, abs=0.005)
    assert q.d_alpha / q.r_alpha == pytest.approx(0.7773401, abs=1e-7)
    assert q.adjacency(7.0) == pytest.approx(0.1792650, abs=1e-7)


def test_stiffness_hand_value_and_finite_difference() -> None:
    p = FlockingPotential()
    # a_s/l * rho * phi'(0) * sigma_eps(10)^2 = 1e-3 * 0.1574366 * 1 * 100/11
    assert p.stiffness() == pytest.approx(1e-3 * 0.1574366 * 100.0 / 11.0, rel=1e-6)
    for q in (p, FlockingPotential(a=1.0, b=4.0, desired_gap=800.0, length_scale=25.0)):
        fd = _central(lambda s, q=q: q.acceleration(s), q.desired_gap, 1e-3)
        assert q.stiffness() == pytest.approx(fd, rel=1e-6)
        assert q.stiffness() > 0.0


@pytest.mark.parametrize("gap", [5.0, 120.0, 300.0, 480.0, 510.0, 540.0, 590.0])
def test_energy_derivative_is_rear_train_acceleration(gap: float) -> None:
    p = FlockingPotential()
    fd = _central(lambda s: p.energy(s), gap, 1e-3)
    assert fd == pytest.approx(p.acceleration(gap), rel=1e-6, abs=1e-12)
    # the same as -dE/dx_rear with s = x_front - x_rear - L (L = 1300 m)
    x_front, length = 10_000.0, 1300.0
    x_rear = x_front - length - gap
    fd_x = _central(lambda x: p.energy(x_front - x - length), x_rear, 1e-3)
    assert -fd_x == pytest.approx(p.acceleration(gap), rel=1e-6, abs=1e-12)


def test_sign_convention_follower_pushed_back_when_too_close() -> None:
    p = FlockingPotential()
    gaps = np.array([50.0, 250.0, 450.0, 499.0])
    assert np.all(np.asarray(p.acceleration(gaps)) < 0.0)
    gaps = np.array([501.0, 530.0, 590.0])
    assert np.all(np.asarray(p.acceleration(gaps)) > 0.0)
    assert p.acceleration([0.0, 500.0, 600.0, 900.0]).tolist() == [0.0, 0.0, 0.0, 0.0]


def test_acceleration_bounded_by_force_scale() -> None:
    p = FlockingPotential(a=1.0, b=2.0)
    gaps = np.linspace(0.0, 700.0, 2001)
    # |a_s phi_alpha sigma_eps| <= a_s * max(a, b) * |sigma_eps| (rho <= 1, |phi| < b)
    slope = (gaps / 50.0) / np.sqrt(1 + 0.1 * (gaps / 50.0) ** 2)
    assert np.all(np.abs(p.acceleration(gaps)) <= 0.05 * 2.0 * slope + 1e-15)


def test_energy_zero_at_desired_gap_and_flat_beyond_range() -> None:
    p = FlockingPotential()
    assert p.energy(500.0) == 0.0
    e = np.asarray(p.energy([600.0, 650.0, 5000.0]))
    assert e[0] > 0.0 and e[1] == e[0] and e[2] == e[0]


def test_collision_bound_against_trapezoid() -> None:
    p = FlockingPotential()
    z = np.linspace(0.0, p.d_alpha, 1_000_001)
    w = z / p.r_alpha
    rho = np.where(w < 0.2, 1.0, 0.5 * (1 + np.cos(np.pi * (w - 0.2) / 0.8)))
    y = z - p.d_alpha                                  # a = b = 1: phi = sigma_1
    psi0 = -float(np.trapezoid(rho * y / np.sqrt(1 + y * y), z))
    bound = p.collision_energy_bound()
    assert bound.energy == pytest.approx(50.0 * 0.05 * psi0, rel=1e-9)
    assert bound.relative_speed == pytest.approx(math.sqrt(2 * 50.0 * 0.05 * psi0), rel=1e-9)


def test_saturation_gap_hand_value_and_root_finding() -> None:
    # sigma_1(w) = 0.9 -> w = 0.9/sqrt(0.19) = 2.064742; z = 23.166248 + 2.064742 = 25.230990;
    # x = sqrt(((1 + 2.523099)^2 - 1)/0.1) = 10.68275 -> gap 534.14 m (spec §3.3: "34 m").
    p = FlockingPotential()
    assert p.saturation_gap(0.9) == pytest.approx(34.14, abs=0.01)
    assert p.saturation_gap(0.9) == pytest.approx(34.0, abs=0.5)
    # spec §3.3 for l = 25 m: 16.5 m
    assert FlockingPotential(length_scale=25.0).saturation_gap(0.9) == pytest.approx(16.5, abs=0.1)
    # independent route: a root of phi(||s/l||_sigma - d_alpha) - level on each side
    q = FlockingPotential(a=1.0, b=3.0, desired_gap=400.0, length_scale=40.0)

    def action(s: float) -> float:
        return phi(sigma_norm(s / 40.0, 0.1) - q.d_alpha, 1.0, 3.0)

    ahead = brentq(lambda s: action(s) - 0.8, 400.0, 2000.0, xtol=1e-10) - 400.0
    behind = 400.0 - brentq(lambda s: action(s) + 0.8 * 3.0, 0.0, 400.0, xtol=1e-10)
    assert q.saturation_gap(0.8) == pytest.approx(ahead, rel=1e-9)
    assert q.saturation_gap(0.8, side="repulsion") == pytest.approx(behind, rel=1e-9)
    assert q.saturation_gap(0.999999, side="repulsion") == math.inf


def test_adjacency_values() -> None:
    p = FlockingPotential()
    # gap 100 m: ||2||_sigma = (sqrt(1.4) - 1)/0.1 = 1.83 = 0.063 r_alpha < h -> flat part, 1
    assert p.adjacency([0.0, 100.0]).tolist() == [1.0, 1.0]
    assert p.adjacency(600.0) == pytest.approx(0.0, abs=1e-15)
    assert p.adjacency(700.0) == 0.0


# ------------------------------------------------------------------ validation

@pytest.mark.parametrize(("kwargs", "name"), [
    ({"h": 1.0}, "'h'"),
    ({"h": 0.0}, "'h'"),
    ({"h": -0.2}, "'h'"),
    ({"a": 5.0, "b": 1.0}, "'b'"),
    ({"a": 0.0}, "'a'"),
    ({"desired_gap": 0.0}, "'desired_gap'"),
    ({"desired_gap": -5.0}, "'desired_gap'"),
    ({"interaction_range": 400.0}, "'interaction_range'"),
    ({"length_scale": 0.0}, "'length_scale'"),
    ({"eps": -0.1}, "'eps'"),
    ({"force_scale": 0.0}, "'force_scale'"),
    ({"eps": math.nan}, "'eps'"),
])
def test_flocking_rejects_bad_parameters(kwargs: dict[str, float], name: str) -> None:
    with pytest.raises(ModelError, match=name):
        FlockingPotential(**kwargs)


def test_h_one_is_explained() -> None:
    with pytest.raises(ModelError, match="discontinuous indicator"):
        bump(0.5, 1.0)
    with pytest.raises(ModelError, match="non-Lipschitz"):
        FlockingPotential(h=1.0)


def test_primitives_reject_bad_parameters() -> None:
    with pytest.raises(ModelError, match="'eps'"):
        sigma_norm(1.0, 0.0)
    with pytest.raises(ModelError, match="'b'"):
        phi(0.0, 2.0, 1.0)
    with pytest.raises(ModelError, match="'r_alpha'"):
        phi_alpha(1.0, d_alpha=3.0, r_alpha=3.0)
    with pytest.raises(ModelError, match="'d_alpha'"):
        psi_alpha(1.0, d_alpha=-1.0, r_alpha=3.0)


def test_negative_gap_is_refused() -> None:
    p = FlockingPotential()
    for method in (p.acceleration, p.energy, p.adjacency):
        with pytest.raises(ModelError, match="'gap'"):
            method([10.0, -1.0])
    with pytest.raises(ModelError, match="'gap'"):
        SigmaNormPotential(p).gradient(-600.0)


# ------------------------------------------------------------------ seed 001 potentials

def _potentials() -> list[PairPotential]:
    return [QuadraticPotential(0.5), BarrierPotential(kappa=2.0, delta=0.8),
            BarrierPotential.with_stiffness(0.5, 0.3), SigmaNormPotential(FlockingPotential())]


@pytest.mark.parametrize("pot", _potentials(), ids=lambda p: type(p).__name__)
def test_gradient_and_curvature_are_finite_differences(pot: PairPotential) -> None:
    assert isinstance(pot, PairPotential)
    scale = 100.0 if isinstance(pot, SigmaNormPotential) else 0.1
    for z in (-2.5 * scale, -0.7 * scale, 0.3 * scale, 1.9 * scale):
        fd = _central(pot.energy, z, 1e-5 * scale)
        assert pot.gradient(z) == pytest.approx(fd, rel=1e-6, abs=1e-13)
    step = 1e-3 * scale
    second = (pot.energy(step) - 2 * pot.energy(0.0) + pot.energy(-step)) / step**2
    assert pot.curvature() == pytest.approx(second, rel=1e-5)


def test_quadratic_hand_values() -> None:
    p = QuadraticPotential(0.5)
    assert p.energy(2.0) == 1.0 and p.gradient(-2.0) == -1.0 and p.curvature() == 0.5
    assert p.bound(1.0) == pytest.approx(2.0)


def test_barrier_hand_values_and_outside_policy() -> None:
    p = BarrierPotential(kappa=2.0, delta=1.0)
    assert p.energy(0.5) == pytest.approx(math.log(4.0 / 3.0), rel=1e-14)
    assert p.gradient(0.5) == pytest.approx(2.0 * 0.5 / 0.75, rel=1e-14)
    assert p.curvature() == 2.0
    out_e = np.asarray(p.energy([-1.0, 1.0, 3.0]))
    out_g = np.asarray(p.gradient([-1.0, 1.0, 3.0]))
    assert np.all(np.isposinf(out_e)) and np.all(np.isnan(out_g))
    assert BarrierPotential.with_stiffness(0.5, 0.3).curvature() == pytest.approx(0.5)


@pytest.mark.parametrize("pot", _potentials(), ids=lambda p: type(p).__name__)
def test_bound_reaches_the_budget(pot: PairPotential) -> None:
    budget = 0.01
    z = pot.bound(budget)
    assert 0.0 < z < math.inf
    # the budget is used up at +z or at -z (an uneven potential reaches it on one side) ...
    gaps = [abs(pot.energy(z) - budget), abs(pot.energy(-z) - budget)]
    assert min(gaps) <= 1e-8 * budget
    # ... and no larger deviation is within the budget on either side
    assert pot.energy(1.001 * z) > budget and pot.energy(-1.001 * z) > budget
    assert pot.bound(0.0) == 0.0


@settings(max_examples=60, deadline=None)
@given(st.floats(1e-6, 1e6), st.floats(0.01, 10.0), st.floats(1e-3, 10.0))
@example(budget=2.0, delta=1.0, kappa=0.125)   # z within 6e-15 of the barrier
def test_barrier_bound_inside_band(budget: float, delta: float, kappa: float) -> None:
    p = BarrierPotential(kappa=kappa, delta=delta)
    z = p.bound(budget)
    assert 0.0 <= z <= delta
    if z < delta:
        # Near the barrier U is ill-conditioned in z: a rounding of z (eps·delta) moves U by
        # about kappa·eps / (1 − (z/delta)²), which the tolerance allows for.
        gap = -math.expm1(2.0 * math.log(z / delta)) if z > 0 else 1.0
        slack = 4.0 * kappa * np.finfo(float).eps / gap
        assert p.energy(z) == pytest.approx(budget, rel=1e-6, abs=slack)


def test_sigma_norm_potential_bound_limits() -> None:
    flock = FlockingPotential()
    p = SigmaNormPotential(flock)
    far = float(flock.energy(600.0))
    assert p.bound(far * 1.01) == math.inf
    collision = flock.collision_energy_bound().energy
    assert collision > far
    big = 0.5 * far
    z = p.bound(big)
    assert 0.0 < z < 100.0 and p.energy(z) == pytest.approx(big, rel=1e-8)  # attraction side
    assert p.energy(-z) > big                               # the repulsion side is steeper
    # a budget above the collision barrier but below the far-field energy cannot exist here
    # (collision > far); with a tiny range the far field is the cheaper escape:
    near = SigmaNormPotential(FlockingPotential(interaction_range=501.0))
    assert near.bound(float(near.flocking.energy(501.0)) * 1.001) == math.inf


def test_budget_must_be_non_negative() -> None:
    with pytest.raises(ModelError, match="'energy_budget'"):
        QuadraticPotential(1.0).bound(-1.0)
    with pytest.raises(ModelError, match="'kappa'"):
        BarrierPotential(kappa=0.0, delta=1.0)
    with pytest.raises(ModelError, match="'delta'"):
        BarrierPotential(kappa=1.0, delta=-1.0)


def test_sigma_norm_potential_bound_with_collision_reachable() -> None:
    # short desired gap, long range: the far field (r) costs more than a collision (gap 0)
    flock = FlockingPotential(desired_gap=100.0, interaction_range=2000.0)
    p = SigmaNormPotential(flock)
    collision = flock.collision_energy_bound().energy
    far = float(flock.energy(2000.0))
    assert collision < far
    budget = min(2.0 * collision, 0.5 * (collision + far))
    z = p.bound(budget)
    # gap 0 is reachable (deviation -100 m); the attraction side reaches its own root
    ahead = brentq(lambda x: p.energy(x) - budget, 0.0, 1900.0, xtol=1e-10)
    assert z == pytest.approx(max(ahead, 100.0), rel=1e-9)
    small = 0.5 * collision
    z_small = p.bound(small)
    assert z_small < 100.0
    assert min(abs(p.energy(z_small) - small), abs(p.energy(-z_small) - small)) <= 1e-8 * small


def test_saturation_gap_rejects_bad_arguments() -> None:
    p = FlockingPotential()
    for fraction in (0.0, 1.0, -0.5, math.nan):
        with pytest.raises(ModelError, match="'fraction'"):
            p.saturation_gap(fraction)
    with pytest.raises(ModelError, match="'side'"):
        p.saturation_gap(0.9, side="both")  # type: ignore[arg-type]
