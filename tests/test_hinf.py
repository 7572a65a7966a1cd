"""H∞ norms, the bounded-real LMI, the consensus gains and delay certificates (seed 003).

Independent routes checked against each other: python-control/slycot ``linfnorm``
against the own Hamiltonian level set, both against closed forms and a frequency
sweep; the bounded-real SDP against both; the synthesised gains' certified γ
against the norm computed without the LMI; the Lyapunov–Krasovskii delay bound
against the exact π/(2a) and against the Padé margin of trainctl.analysis.delay.
"""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest
import scipy.linalg

from trainctl.analysis.delay import delay_abscissa, delay_margin
from trainctl.analysis.delay_lmi import (
    KrasovskiiProblem,
    delay_hinf_gamma,
    krasovskii_lmi,
    max_certified_delay,
)
from trainctl.analysis.hinf import (
    BoundedRealProblem,
    bounded_real_gamma,
    channel_norms,
    control_hinf_norm,
    hamiltonian_hinf_norm,
    hamiltonian_matrix,
    hinf_norm,
)
from trainctl.controllers.hinf.synthesis import consensus_loop, synthesise_gains
from trainctl.design import build_model
from trainctl.exceptions import DimensionError, ModelError
from trainctl.models.graphs import make_graph
from trainctl.scenario import load_scenario

# --------------------------------------------------------------------------------------------
# helpers


def _spectrum_block(rng: np.random.Generator, n: int, discrete: bool) -> np.ndarray:
    """A real block-diagonal matrix with stable eigenvalues (pairs, then a real one)."""
    J = np.zeros((n, n))
    k = 0
    while k < n:
        if k + 1 < n:
            if discrete:
                r, th = rng.uniform(0.3, 0.97), rng.uniform(0.1, 3.0)
                blk = r * np.array([[math.cos(th), math.sin(th)], [-math.sin(th), math.cos(th)]])
            else:
                s, w = -rng.uniform(0.05, 2.0), rng.uniform(0.2, 5.0)
                blk = np.array([[s, w], [-w, s]])
            J[k:k + 2, k:k + 2] = blk
            k += 2
        else:
            J[k, k] = rng.uniform(-0.9, 0.9) if discrete else -rng.uniform(0.1, 3.0)
            k += 1
    return J


def _random_system(seed: int, n: int, m: int, p: int, *, discrete: bool = False,
                   dt: float = 0.1) -> ct.StateSpace:
    """Stable, D ≠ 0, eigenvector matrix of moderate condition (not ct.rss's extremes)."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    V = Q @ (np.eye(n) + 0.3 * rng.normal(size=(n, n)))
    A = V @ _spectrum_block(rng, n, discrete) @ np.linalg.inv(V)
    B, C, D = rng.normal(size=(n, m)), rng.normal(size=(p, n)), rng.normal(size=(p, m))
    return ct.ss(A, B, C, D, dt) if discrete else ct.ss(A, B, C, D)


def _sweep(sys: ct.StateSpace, points: int = 4000) -> float:
    """max σ̄ on a frequency grid: a lower bound of the norm that shares no code with either."""
    A, B, C, D = (np.asarray(M, dtype=float) for M in (sys.A, sys.B, sys.C, sys.D))
    if sys.isctime():
        z = 1j * np.concatenate([[0.0], np.logspace(-3, 3, points)])
    else:
        z = np.exp(1j * np.linspace(0.0, math.pi, points))
    n = A.shape[0]
    return max(float(np.linalg.norm(C @ np.linalg.solve(s * np.eye(n) - A, B) + D, 2))
               for s in z)


@pytest.fixture(scope="module")
def heavy_haul():
    sc = load_scenario("heavy-haul-hinf")
    return sc, build_model(sc)


@pytest.fixture(scope="module")
def loop(heavy_haul):
    sc, model = heavy_haul
    return consensus_loop(model, sc.graph())


# --------------------------------------------------------------------------------------------
# closed forms


@pytest.mark.parametrize(("k", "a"), [(2.0, 4.0), (0.3, 0.01), (5.0, 50.0)])
def test_first_order_lag_is_k_over_a_at_dc(k: float, a: float) -> None:
    res = hinf_norm(ct.tf([k], [1.0, a]))
    assert res.control == pytest.approx(k / a, rel=1e-9)
    assert res.hamiltonian == pytest.approx(k / a, rel=1e-9)
    assert res.hamiltonian_frequency == pytest.approx(0.0, abs=1e-9)
    assert res.agree and res.stable


@pytest.mark.parametrize("zeta", [0.01, 0.05, 0.2, 0.5])
def test_second_order_resonance_closed_form(zeta: float) -> None:
    """1/(s² + 2ζs + 1): peak 1/(2ζ√(1 − ζ²)) at ω = √(1 − 2ζ²)."""
    res = hinf_norm(ct.tf([1.0], [1.0, 2 * zeta, 1.0]))
    peak = 1.0 / (2 * zeta * math.sqrt(1 - zeta ** 2))
    assert res.control == pytest.approx(peak, rel=1e-8)
    assert res.hamiltonian == pytest.approx(peak, rel=1e-8)
    assert res.hamiltonian_frequency == pytest.approx(math.sqrt(1 - 2 * zeta ** 2), rel=1e-5)
    assert res.control_frequency == pytest.approx(math.sqrt(1 - 2 * zeta ** 2), rel=1e-5)


def test_overdamped_second_order_peaks_at_dc() -> None:
    res = hinf_norm(ct.tf([1.0], [1.0, 1.6, 1.0]))  # ζ = 0.8 > 1/√2
    assert res.hamiltonian == pytest.approx(1.0, rel=1e-9) and res.agree


@pytest.mark.parametrize(("a", "at_nyquist"), [(0.8, False), (-0.8, True)])
def test_discrete_first_order_closed_form(a: float, at_nyquist: bool) -> None:
    """k/(z − a): k/(1 − |a|), at z = 1 for a > 0 and at z = −1 (θ = π) for a < 0."""
    dt = 0.5
    res = hinf_norm(ct.tf([1.5], [1.0, -a], dt))
    assert res.hamiltonian == pytest.approx(1.5 / (1 - abs(a)), rel=1e-9)
    assert res.agree
    expected = math.pi / dt if at_nyquist else 0.0
    assert res.hamiltonian_frequency == pytest.approx(expected, abs=1e-6)


def test_hamiltonian_eigenvalues_mark_the_level_crossings() -> None:
    """1/(s + 1) crosses the level 0.5 at ω = √3 (|G| = 1/√(1 + ω²))."""
    lam = np.linalg.eigvals(hamiltonian_matrix([[-1.0]], [[1.0]], [[1.0]], None, 0.5))
    assert np.allclose(np.sort(np.abs(lam.imag)), [math.sqrt(3)] * 2)
    assert np.allclose(lam.real, 0.0, atol=1e-12)
    # above the peak (1 at DC): no imaginary eigenvalue
    lam = np.linalg.eigvals(hamiltonian_matrix([[-1.0]], [[1.0]], [[1.0]], None, 1.01))
    assert np.all(np.abs(lam.real) > 1e-3)


# --------------------------------------------------------------------------------------------
# the two routes on random, ill-scaled and heavy-haul systems


@pytest.mark.parametrize(("seed", "n", "m", "p"), [(1, 2, 1, 1), (2, 5, 2, 3), (3, 8, 3, 2),
                                                   (4, 7, 4, 4), (5, 3, 2, 2)])
@pytest.mark.parametrize("discrete", [False, True])
def test_random_systems_routes_agree(seed: int, n: int, m: int, p: int, discrete: bool) -> None:
    sys = _random_system(seed, n, m, p, discrete=discrete)
    res = hinf_norm(sys)
    assert res.stable and res.agree, res.message
    assert abs(res.control - res.hamiltonian) <= 1e-4 * res.control
    # a dense sweep never exceeds the norm and comes close to it
    sweep = _sweep(sys)
    assert sweep <= res.hamiltonian * (1 + 1e-9)
    assert sweep >= 0.95 * res.hamiltonian
    # σ̄ at the reported peak frequency is the norm
    z = (np.exp(1j * res.hamiltonian_frequency * sys.dt) if discrete
         else 1j * res.hamiltonian_frequency)
    A, B, C, D = (np.asarray(M) for M in (sys.A, sys.B, sys.C, sys.D))
    G = C @ np.linalg.solve(z * np.eye(n) - A, B) + D
    assert np.linalg.norm(G, 2) == pytest.approx(res.hamiltonian, rel=1e-8)


def test_ill_scaled_states_and_outputs_agree() -> None:
    """States scaled by 10^±5 and outputs by 1e-4 / 1 / 1e3: the norm is that of the scaled G."""
    rng = np.random.default_rng(7)
    base = _random_system(11, 6, 2, 3)
    T = np.diag(10.0 ** rng.uniform(-5, 5, 6))
    Sy = np.diag([1e-4, 1.0, 1e3])
    A = np.linalg.solve(T, np.asarray(base.A) @ T)
    sys = ct.ss(A, np.linalg.solve(T, base.B), Sy @ base.C @ T, Sy @ base.D)
    res = hinf_norm(sys)
    ref = hinf_norm(ct.ss(base.A, base.B, Sy @ base.C, Sy @ base.D))  # unscaled states
    assert res.agree
    assert res.hamiltonian == pytest.approx(ref.hamiltonian, rel=1e-7)


def test_heavy_haul_plant_in_mixed_units(heavy_haul) -> None:
    """The design model: inputs kN, outputs speeds [m/s] and coupler forces [kN]."""
    _, model = heavy_haul
    res = hinf_norm(model.design)
    assert res.agree and res.stable
    # the peak is a coupler mode on a force output: ~18 kN per kN against 0.057 m/s per kN
    # (the speeds' DC gain 1/(Σ M c) through the resistance damping)
    cn = channel_norms(model.design)
    assert cn.agree
    assert np.max(cn.gamma[4:]) > 100 * np.max(cn.gamma[:4])
    c = -float(np.max(np.linalg.eigvals(np.asarray(model.design.A)).real))
    assert np.max(cn.gamma[:4]) == pytest.approx(1e3 / (model.train.mass.sum() * c), rel=1e-6)
    modes = np.abs(np.linalg.eigvals(np.asarray(model.design.A)).imag)
    assert min(abs(res.frequency - w) for w in modes) < 0.05 * res.frequency


@pytest.mark.parametrize(("kp", "kc"), [(0.1, 0.1), (0.5, 0.0), (0.02, 0.2)])
def test_heavy_haul_closed_loop_routes_agree(loop, kp: float, kc: float) -> None:
    sys = loop.system(kp, kc)
    res = hinf_norm(sys)
    assert res.agree and abs(res.control - res.hamiltonian) <= 1e-4 * res.control
    resd = hinf_norm(ct.c2d(sys, 0.1))
    assert resd.agree
    assert resd.hamiltonian == pytest.approx(res.hamiltonian, rel=1e-2)  # ZOH, peak at DC


def test_unstable_systems_have_infinite_norm() -> None:
    for sys in (ct.tf([1.0], [1.0, -1.0]), ct.tf([1.0], [1.0, 0.0]),  # growing; integrator
                ct.tf([1.0], [1.0, -1.2], 0.1), ct.tf([1.0], [1.0, 0.0, 1.0])):  # |z| > 1; ζ = 0
        res = hinf_norm(sys)
        assert math.isinf(res.norm) and not res.stable and res.agree
        assert "infinite" in res.message
        assert math.isinf(control_hinf_norm(sys)[0])
        assert math.isinf(hamiltonian_hinf_norm(sys)[0])


def test_feedthrough_dominates() -> None:
    """G = 3 + 1/(s + 10): peak at DC 3.1 (σ̄(D) = 3 is the high-frequency limit)."""
    res = hinf_norm(ct.ss([[-10.0]], [[1.0]], [[1.0]], [[3.0]]))
    assert res.hamiltonian == pytest.approx(3.1, rel=1e-10) and res.agree
    res = hinf_norm(ct.ss([[-10.0]], [[1.0]], [[-1.0]], [[3.0]]))  # 3 − 1/(s + 10): sup at ∞
    assert res.hamiltonian == pytest.approx(3.0, rel=1e-8) and res.agree


def test_channel_norms_layout_and_agreement() -> None:
    G = ct.ss(np.diag([-1.0, -2.0]), np.eye(2), [[1.0, 0.0], [1.0, 1.0]], 0,
              inputs=["w0", "w1"], outputs=["s0", "s1"])
    res = channel_norms(G)
    assert np.allclose(res.gamma, [[1.0, 0.0], [1.0, 0.5]])  # [output, input]
    assert np.allclose(res.per_input, [math.sqrt(2.0), 0.5])
    assert res.inputs == ("w0", "w1") and res.outputs == ("s0", "s1") and res.agree


# --------------------------------------------------------------------------------------------
# bounded-real lemma


def _check_brl_certificate(A, B, C, D, res) -> None:
    """Recompute the LMI with the returned P and γ: it must hold (strictly, up to rounding)."""
    P = res.P
    assert P is not None and np.min(np.linalg.eigvalsh(P)) > 0
    g = res.gamma * (1 + 1e-7)
    M = np.block([[A.T @ P + P @ A + C.T @ C, P @ B + C.T @ D],
                  [B.T @ P + D.T @ C, D.T @ D - g ** 2 * np.eye(B.shape[1])]])
    scale = np.linalg.norm(M, 2)
    assert np.max(np.linalg.eigvalsh(0.5 * (M + M.T))) <= 1e-9 * scale


@pytest.mark.parametrize(("seed", "n", "m", "p"), [(21, 2, 1, 1), (22, 4, 2, 3), (23, 6, 3, 2),
                                                   (24, 7, 2, 2)])
def test_bounded_real_gamma_equals_the_norm(seed: int, n: int, m: int, p: int) -> None:
    sys = _random_system(seed, n, m, p)
    A, B, C, D = (np.asarray(M, dtype=float) for M in (sys.A, sys.B, sys.C, sys.D))
    res = bounded_real_gamma(A, B, C, D)
    norm = hinf_norm(sys).control
    assert res.certified and res.status == "optimal", res.message
    assert res.gamma >= norm * (1 - 1e-9)          # a certificate is never below the norm
    assert res.gamma <= norm * (1 + 1e-5)          # and the lemma is exact
    _check_brl_certificate(A, B, C, D, res)


def test_bounded_real_gamma_on_the_heavy_haul_loop(loop) -> None:
    A, B, C, D = loop.matrices(0.1, 0.1)
    res = bounded_real_gamma(A, B, C, D)
    norm = hinf_norm(loop.system(0.1, 0.1)).control
    assert norm <= res.gamma <= norm * (1 + 1e-6)
    _check_brl_certificate(A, B, C, D, res)


def test_bounded_real_gamma_refuses_an_unstable_system() -> None:
    res = bounded_real_gamma([[0.1]], [[1.0]], [[1.0]])
    assert not res.certified and math.isinf(res.gamma) and res.P is None
    assert "no certificate" in res.message


def test_parametric_problem_is_dpp_and_matches_fresh_solves(loop) -> None:
    prob = BoundedRealProblem(loop.A0, loop.Bf, loop.C, None,
                              A_terms={"kp": loop.Ap, "kc": loop.Ac},
                              B_terms={"kp": loop.Bp, "kc": loop.Bc},
                              reference={"kp": 0.1, "kc": 0.1})
    assert prob.problem.is_dpp()
    for kp, kc in [(0.05, 0.0), (0.3, 0.2)]:
        again = prob.solve(kp=kp, kc=kc)
        fresh = bounded_real_gamma(*loop.matrices(kp, kc))
        assert again.gamma == pytest.approx(fresh.gamma, rel=1e-6)
        assert np.allclose(prob.matrices(kp=kp, kc=kc)[0], loop.matrices(kp, kc)[0])
    with pytest.raises(ModelError, match=r"^BoundedRealProblem\.solve: .*missing \['kc'\]"):
        prob.solve(kp=0.1)
    with pytest.raises(ModelError, match=r"^BoundedRealProblem\.matrices: parameter 'kc'"):
        prob.matrices(kp=0.1, kc=math.nan)


# --------------------------------------------------------------------------------------------
# consensus gains


def test_consensus_loop_structure(heavy_haul, loop) -> None:
    sc, model = heavy_haul
    n = model.n_vehicles
    assert loop.channels[:4] == ("f[0]", "f[1]", "f[2]", "f[3]")
    assert loop.units()[0] == "1 m/s²" and loop.units()[5] == "1 m/s"
    # the law per unit mass: κ_p A_p + κ_c A_c = −[(κ_p B + κ_c L); 0] on the speeds
    G = sc.graph()
    Acl = loop.matrices(0.2, 0.3)[0] - loop.A0
    expected = np.zeros_like(Acl)
    expected[:n, :n] = -(0.2 * G.pinning_matrix() + 0.3 * G.laplacian())
    assert np.allclose(Acl, expected, atol=1e-12)
    # the law in kN through the design B is the same thing (test_delay's loop)
    K = -np.diag(model.train.mass) @ (0.2 * G.pinning_matrix() + 0.3 * G.laplacian()) \
        @ np.eye(n, loop.n_states) / 1e3
    assert np.allclose(np.asarray(model.design.B) @ K, Acl)


def test_synthesis_certifies_what_the_independent_norm_finds(loop) -> None:
    res = synthesise_gains(loop, kp_bounds=(0.01, 0.2), kc_bounds=(0.0, 0.2), grid=(5, 5),
                           max_evaluations=30)
    assert res.consistent and res.norm.agree and res.channels.agree
    assert res.norm.norm <= res.gamma <= res.norm.norm * (1 + 1e-4)
    assert res.gamma <= np.min(res.gamma_grid) * (1 + 1e-12)
    for j, name in enumerate(res.channels.inputs):
        cert = res.channel_certificates[name]
        assert res.channels.per_input[j] <= cert.gamma * (1 + 1e-9) + 1e-12
        assert cert.gamma <= res.channels.per_input[j] * (1 + 1e-4) + 1e-9
    # with the couplers the train is rigid at DC: κ_c only adds link noise to the tracking
    # error, and κ_p lowers the force gain ≈ 1/κ_p, so the search ends at κ_p max, κ_c = 0
    assert res.kp == pytest.approx(0.2) and res.kc == pytest.approx(0.0, abs=1e-9)


def test_reference_noise_floor_at_dc(loop) -> None:
    """A common reference noise passes with κ_p/(κ_p + c) → 1, whatever the gains."""
    c = -float(np.max(np.linalg.eigvals(loop.A0).real))  # the rigid mode: resistance damping
    cols = loop.columns("reference")
    for kp, kc in [(0.05, 0.0), (0.2, 0.1), (1.0, 1.0)]:
        A, B, C, D = loop.matrices(kp, kc)
        g = hinf_norm(ct.ss(A, B[:, cols], C, D[:, cols])).norm
        assert g >= kp / (kp + c) * (1 - 1e-9)
        assert g > 0.98


def test_disagreement_output_removes_the_common_mode(heavy_haul, loop) -> None:
    sc, model = heavy_haul
    dis = consensus_loop(model, sc.graph(), output="disagreement")
    for kp, kc in [(0.1, 0.1), (0.2, 0.0)]:
        assert hinf_norm(dis.system(kp, kc)).norm < hinf_norm(loop.system(kp, kc)).norm
    # the disagreement rows sum to zero: a common speed error is invisible
    assert np.allclose(dis.C.sum(axis=0), 0.0)


def test_scaling_scales_the_channel_gamma(heavy_haul, loop) -> None:
    sc, model = heavy_haul
    scaled = consensus_loop(model, sc.graph(), scaling={"force": 0.05}, output_scale=0.5)
    cols = loop.columns("force")
    g1 = hinf_norm(ct.ss(*(M[:, cols] if k in (1, 3) else M
                           for k, M in enumerate(loop.matrices(0.1, 0.1))))).norm
    g2 = hinf_norm(ct.ss(*(M[:, cols] if k in (1, 3) else M
                           for k, M in enumerate(scaled.matrices(0.1, 0.1))))).norm
    assert g2 == pytest.approx(g1 * 0.05 / 0.5, rel=1e-9)
    assert scaled.units()[0] == "0.05 m/s²"


def test_delay_dependent_synthesis_bounds_the_pade_norms(loop) -> None:
    res = synthesise_gains(loop, kp_bounds=(0.05, 0.2), kc_bounds=(0.0, 0.1), grid=(2, 2),
                           refine=False, tau_max=0.3)
    assert res.tau_max == 0.3 and res.certificate.certified
    assert res.consistent
    assert res.norm.norm <= res.gamma
    assert len(res.pade_norms) == 4 and all(r.agree for _, r in res.pade_norms)
    assert all(r.norm <= res.gamma for _, r in res.pade_norms)


# --------------------------------------------------------------------------------------------
# delay certificates


@pytest.mark.parametrize("a", [0.5, 2.0])
def test_lk_delay_for_pure_delay_is_below_the_exact_bound(a: float) -> None:
    """ẋ = −a x(t − τ): exact π/(2a); Jensen's LMI gives √2/a (constant), 1/a (varying)."""
    exact = math.pi / (2 * a)
    const = max_certified_delay([[0.0]], [[-a]], rel_tol=1e-4)
    vary = max_certified_delay([[0.0]], [[-a]], delay="varying", rel_tol=1e-4)
    assert 0.85 * exact < const.tau < exact
    assert 0.6 * exact < vary.tau <= const.tau * (1 + 1e-3)
    assert const.tau == pytest.approx(math.sqrt(2) / a, rel=1e-3)
    assert const.tau_failed > const.tau and const.certificate is not None
    assert const.solves > 5


def test_lk_certificate_verifies_independently() -> None:
    """Rebuild Ξ from the returned P, Q, R in the original coordinates."""
    A, Ad = np.array([[0.0, 1.0], [-2.0, -0.3]]), np.array([[0.0, 0.0], [-0.5, -0.5]])
    h = 0.4
    cert = krasovskii_lmi(A, Ad, h)
    assert cert.certified
    P, Q, R = cert.P, cert.Q, cert.R
    X = np.block([[P @ A + A.T @ P + Q - R, P @ Ad + R, h * A.T @ R],
                  [Ad.T @ P + R, -Q - R, h * Ad.T @ R],
                  [h * R @ A, h * R @ Ad, -R]])
    assert np.max(np.linalg.eigvalsh(0.5 * (X + X.T))) < 0
    assert min(np.linalg.eigvalsh(P).min(), np.linalg.eigvalsh(R).min()) > 0


def test_lk_result_is_strict_json_after_one_solve() -> None:
    """ẋ = −2x − x(t − τ) is stable for every delay: certified at the upper end at once,
    one solve, no re-solve time (nan in the result, None in its JSON)."""
    import json

    res = max_certified_delay([[-2.0]], [[-1.0]], tau_upper=0.5)
    assert res.solves == 1 and res.tau == 0.5 and math.isnan(res.resolve_time)
    d = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert d["resolve_time"] is None and d["tau"] == 0.5 and d["tau_failed"] is None


def test_heavy_haul_lk_delay_is_below_the_pade_margin(loop) -> None:
    """κ_p = κ_c = 0.1 1/s: LK 0.43 s against the Padé margin 0.57 s (test_delay)."""
    A, Ad = loop.delay_matrices(0.1, 0.1)
    K = -(0.1 * loop.pinning + 0.1 * loop.laplacian) @ np.eye(4, loop.n_states)
    pade = delay_margin(A, loop.E, K, tau_max=5.0)
    lk = max_certified_delay(A, Ad, rel_tol=1e-3)
    assert lk.tau < pade.margin
    assert lk.tau > 0.6 * pade.margin
    # the loop is indeed stable at the certified delay (an independent look)
    assert delay_abscissa(A, loop.E, K, lk.tau) < 0
    assert max_certified_delay(A, Ad, delay="varying").tau <= lk.tau * (1 + 2e-3)


def test_lk_is_dpp_in_tau_and_refuses_an_unstable_loop() -> None:
    prob = KrasovskiiProblem([[0.0]], [[-1.0]])
    assert prob.problem.is_dpp() and prob.h.value is None
    assert prob.certify(1.0).certified and not prob.certify(1.5).certified
    res = max_certified_delay([[0.5]], [[-0.2]])  # A + A_d = 0.3: unstable without delay
    assert res.tau == 0.0 and res.certificate is None


def test_delay_hinf_bounds_the_delayed_norm() -> None:
    """ẋ = −2x − x(t − τ) + w: sup_ω |1/(jω + 2 + e^{−jωτ})| ≤ certified γ(τ_max)."""
    w = np.concatenate([[0.0], np.logspace(-3, 3, 4000)])
    for h in (0.01, 0.5, 2.0):
        res = delay_hinf_gamma([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], None, h)
        for tau in (h / 2, h):
            exact = np.max(1.0 / np.abs(1j * w + 2.0 + np.exp(-1j * w * tau)))
            assert exact <= res.gamma * (1 + 1e-9)
        assert res.gamma >= 1 / 3
    assert delay_hinf_gamma([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], None, 0.01).gamma \
        == pytest.approx(1 / 3, rel=1e-2)


def test_delay_hinf_on_heavy_haul_covers_the_pade_loop(loop) -> None:
    A, Ad = loop.delay_matrices(0.1, 0.0)
    _, Bw, C, D = loop.matrices(0.1, 0.0)
    res = delay_hinf_gamma(A, Ad, Bw, C, D, 0.5)
    assert res.certified
    for tau in (0.25, 0.5):
        assert hinf_norm(loop.delayed_system(0.1, 0.0, tau)).norm <= res.gamma
    assert hinf_norm(loop.system(0.1, 0.0)).norm <= res.gamma


# --------------------------------------------------------------------------------------------
# bad inputs


def test_bad_inputs_are_refused_with_clear_errors(heavy_haul, loop) -> None:
    sc, model = heavy_haul
    with pytest.raises(ModelError, match="'sys' must be a control.StateSpace"):
        hinf_norm("G")  # type: ignore[arg-type]
    with pytest.raises(DimensionError, match=r"'B' must have n = 2 rows.*\(3, 1\)"):
        bounded_real_gamma(np.eye(2), np.ones((3, 1)), np.ones((1, 2)))
    with pytest.raises(DimensionError, match=r"'D' must be \(p, m\) = \(1, 1\)"):
        bounded_real_gamma(-np.eye(2), np.ones((2, 1)), np.ones((1, 2)), np.ones((2, 2)))
    with pytest.raises(ModelError, match="'A' must be finite"):
        bounded_real_gamma([[math.nan]], [[1.0]], [[1.0]])
    with pytest.raises(ModelError, match=r"'gamma' must exceed σ̄\(D\) = 2"):
        hamiltonian_matrix([[-1.0]], [[1.0]], [[1.0]], [[2.0]], 1.5)
    with pytest.raises(DimensionError, match="'A_d' must have the shape of A"):
        max_certified_delay(np.zeros((2, 2)), np.zeros((3, 3)))
    with pytest.raises(ModelError, match="'tau_max' must be a finite number >= 0 s"):
        krasovskii_lmi([[0.0]], [[-1.0]], -1.0)
    with pytest.raises(ModelError, match="'delay' must be one of"):
        krasovskii_lmi([[0.0]], [[-1.0]], 1.0, delay="fast")
    with pytest.raises(ModelError, match="'A_d' is zero"):
        max_certified_delay([[-1.0]], [[0.0]])
    with pytest.raises(ModelError, match="'output' must be one of"):
        consensus_loop(model, sc.graph(), output="speed")
    with pytest.raises(ModelError, match="'scaling' entry must be a finite number > 0"):
        consensus_loop(model, sc.graph(), scaling={"force": -1.0})
    with pytest.raises(DimensionError, match=r"'scaling' must be a mapping by group or one "
                                             r"number per channel \(14 channels"):
        consensus_loop(model, sc.graph(), scaling=[1.0, 2.0])
    with pytest.raises(DimensionError, match="one node per vehicle"):
        consensus_loop(model, make_graph("bidirectional", 3))
    with pytest.raises(ModelError, match="'kp_bounds' must satisfy 0 <= lo <= hi"):
        synthesise_gains(loop, kp_bounds=(0.5, 0.1))
    with pytest.raises(ModelError, match="'tau_max' must be None or a finite number"):
        synthesise_gains(loop, tau_max=-1.0)
    with pytest.raises(ModelError, match="'solver' must be an installed cvxpy solver"):
        bounded_real_gamma([[-1.0]], [[1.0]], [[1.0]], solver="NOPE")


def test_gramian_balancing_keeps_the_bound_exact_for_a_non_normal_system() -> None:
    """A strongly non-normal A (transient growth ~1e3): the SDP still lands on the norm."""
    A = np.array([[-1.0, 1e3], [0.0, -2.0]])
    B, C = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])
    norm = hinf_norm(ct.ss(A, B, C, 0)).control
    assert norm == pytest.approx(500.0, rel=1e-9)  # 1e3/((s + 1)(s + 2)) at DC
    res = bounded_real_gamma(A, B, C)
    assert res.gamma == pytest.approx(norm, rel=1e-6)
    # the Gramians of the balanced realisation are equal (what the SDP works on)
    prob = BoundedRealProblem(A, B, C, None)
    assert prob.balancing == "gramian"
    Ab, Bb, Cb = prob._A0, prob._B0, prob._C * prob.output_scale
    Wc = scipy.linalg.solve_continuous_lyapunov(Ab, -Bb @ Bb.T)
    Wo = scipy.linalg.solve_continuous_lyapunov(Ab.T, -Cb.T @ Cb)
    assert np.allclose(Wc, Wo, rtol=1e-8, atol=1e-10)
