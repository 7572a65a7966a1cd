# Tests of the frequency-domain view and the grade-step responses of the closed loops.
"""trainctl.analysis.frequency / steps / loops, each checked by an independent route."""

from __future__ import annotations

import json
import math

import control as ct
import numpy as np
import pytest

from trainctl.analysis import (
    analyse_closed_loops,
    analyse_frequency,
    analyse_grade_step,
    bandwidth,
    loop_sensitivity,
)
from trainctl.analysis.steps import GRADE_STEP
from trainctl.design import build_design
from trainctl.exceptions import DimensionError
from trainctl.run.analysis import run_scenario
from trainctl.scenario import load_scenario


@pytest.fixture(scope="module")
def book():
    """crh2-dmpc's design (T = 20 s, Δu-form MPC with poles at z = 1)."""
    return build_design(load_scenario("crh2-dmpc"))


@pytest.fixture(scope="module")
def sampled():
    """crh2-dmpc-well-sampled's design (T = 0.05 s, MPC and LQR)."""
    return build_design(load_scenario("crh2-dmpc-well-sampled"))


def _svd(loop: ct.StateSpace, omega: np.ndarray, rows: list[int]) -> np.ndarray:
    """Singular values from python-control's frequency_response and numpy's SVD."""
    fresp = np.asarray(ct.frequency_response(loop, omega).complex)  # (ny, nu, nw)
    return np.linalg.svd(np.moveaxis(fresp[rows], -1, 0), compute_uv=False).T


def _lqr_sensitivity(design, strategy: str, omega: np.ndarray) -> tuple[np.ndarray, ...]:
    """S and T from the LQR gain: L = M⁻¹ K (zI - A)⁻¹ B M, S = (I + L)⁻¹, T = L S."""
    lqr = design.family("lqr")
    A, B, K = lqr.A, lqr.B, lqr.gains[strategy]
    M = np.diag(design.scenario.train.mass / 1e3)
    n = B.shape[1]
    S, T = [], []
    for w in omega:
        z = np.exp(1j * w * design.model.settings.sample_time)
        L = np.linalg.solve(M, K @ np.linalg.solve(z * np.eye(A.shape[0]) - A, B @ M))
        s = np.linalg.inv(np.eye(n) + L)
        S.append(np.linalg.svd(s, compute_uv=False))
        T.append(np.linalg.svd(L @ s, compute_uv=False))
    return np.array(S).T, np.array(T).T


class TestSingularValues:
    """Singular values and peaks against python-control's frequency_response."""

    @pytest.mark.parametrize("strategy", ["centralised", "decentralised", "ndmpc"])
    def test_book_loops(self, book, strategy: str) -> None:
        """σ(G_wv), σ(G_wf) equal the SVD of frequency_response on the same StateSpace."""
        loop = book.closed_loop(strategy)
        res = analyse_frequency(loop, plant=book.model.discrete)
        n = loop.ninputs
        np.testing.assert_allclose(res.speed_sigma, _svd(loop, res.omega, list(range(n))),
                                   rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(res.force_sigma,
                                   _svd(loop, res.omega, list(range(n, 2 * n - 1))),
                                   rtol=1e-9, atol=1e-12)
        assert res.omega[-1] == pytest.approx(math.pi / 20.0)

    @pytest.mark.parametrize("strategy", ["ndmpc", "lqr.centralised", "lqr.decentralised"])
    def test_peaks_are_the_largest_gain(self, sampled, strategy: str) -> None:
        """Each peak is σ_max at its frequency and no smaller than on a dense grid."""
        loop = sampled.closed_loop(strategy)
        res = analyse_frequency(loop, plant=sampled.model.discrete)
        dense = np.linspace(1e-4, math.pi / loop.dt, 40001)
        n = loop.ninputs
        for peak, rows in ((res.speed_peak, list(range(n))),
                           (res.force_peak, list(range(n, 2 * n - 1)))):
            at = _svd(loop, np.array([max(peak.frequency, 1e-12)]), rows)[0, 0]
            if peak.frequency > 0:
                assert peak.gain == pytest.approx(at, rel=1e-9)
            else:  # the DC gain
                dc = np.linalg.svd(np.asarray(loop.dcgain())[rows], compute_uv=False)[0]
                assert peak.gain == pytest.approx(dc, rel=1e-9)
            assert peak.gain >= _svd(loop, dense, rows)[0].max() * (1 - 1e-6)


class TestSensitivity:
    """S and T at the plant input."""

    @pytest.mark.parametrize("strategy", ["centralised", "decentralised"])
    def test_equal_the_lqr_loop_transfer(self, sampled, strategy: str) -> None:
        """From the closed-loop matrices alone = (I + L)⁻¹ and L(I + L)⁻¹ from the gain."""
        loop = sampled.closed_loop(f"lqr.{strategy}")
        res = analyse_frequency(loop, plant=sampled.model.discrete)
        S, T = _lqr_sensitivity(sampled, strategy, res.omega)
        np.testing.assert_allclose(res.sensitivity_sigma, S, rtol=1e-7, atol=1e-10)
        np.testing.assert_allclose(res.complementary_sigma, T, rtol=1e-7, atol=1e-10)
        assert res.sensitivity_peak.gain >= S[0].max()

    def test_s_plus_t_is_identity(self, book) -> None:
        """S + T = I at every frequency (MPC loops with controller states)."""
        S, T = loop_sensitivity(book.closed_loop("ndmpc"), book.model.discrete)
        for w in (1e-4, 1e-2, 0.15):
            z = np.exp(1j * w * 20.0)
            np.testing.assert_allclose(S(z) + T(z), np.eye(4), atol=1e-9)

    def test_not_state_feedback_is_refused(self, sampled) -> None:
        """A loop whose disturbance does not enter through the plant's B has no S, T."""
        loop = sampled.closed_loop("lqr.centralised")
        B = np.asarray(loop.B).copy()
        B[-1, 0] += 1.0  # a disturbance on an elongation: not an input disturbance
        odd = ct.ss(loop.A, B, loop.C, loop.D, loop.dt, outputs=loop.output_labels)
        assert loop_sensitivity(odd, sampled.model.discrete) is None
        res = analyse_frequency(odd, plant=sampled.model.discrete)
        assert res.sensitivity_sigma is None and math.isnan(res.bandwidth)
        assert res.to_dict()["sensitivity_peak"] is None


@pytest.mark.parametrize("dt", [0.1, 0.3, 0.03, 0.05, 20.0])
def test_grid_ends_at_nyquist_without_passing_it(dt: float) -> None:
    """The last grid point times T is π up to rounding and never above it (python-control
    warns above Nyquist; logspace alone lands one rounding above for T = 0.1 s)."""
    from trainctl.analysis.sensitivity import frequency_grid

    w = frequency_grid(dt)
    assert w[-1] * dt <= math.pi
    assert w[-1] == pytest.approx(math.pi / dt, rel=1e-15)
    assert np.all(np.diff(w) > 0)
    ct.ss([[0.5]], [[1.0]], [[1.0]], 0, dt).frequency_response(w)  # no warning (an error here)


class TestBandwidth:
    """bandwidth(): python-control's definition, on the unit circle for discrete systems."""

    @pytest.mark.parametrize("sys", [
        ct.ss([[-1.0]], [[1.0]], [[1.0]], 0),
        ct.tf2ss(ct.tf([0.1], [1, 0.1]) * ct.tf([1], [1, 0.002, 1])),
        ct.tf2ss(ct.tf([2, 1], [1, 3, 2])),
    ])
    def test_continuous_equals_python_control(self, sys) -> None:
        """Continuous systems: exactly control.bandwidth."""
        assert bandwidth(sys) == pytest.approx(float(ct.bandwidth(sys)), rel=1e-9)

    @pytest.mark.parametrize("a", [0.5, 0.9, 0.999])
    def test_discrete_first_order_closed_form(self, a: float) -> None:
        """G = (1-a)/(z-a), DC gain 1: |G| = d = 10^(-3/20) at cos θ = (1 + a² - (1-a)²/d²)/(2a)."""
        dt = 0.1
        sys = ct.ss([[a]], [[1 - a]], [[1.0]], 0, dt)
        drop = 10 ** (-3 / 20)  # -3 dB, not exactly 1/√2
        cos = (1 + a * a - (1 - a) ** 2 / drop**2) / (2 * a)
        assert bandwidth(sys) == pytest.approx(math.acos(cos) / dt, rel=1e-8)

    def test_discrete_loop_by_definition(self, sampled) -> None:
        """The common-mode T falls 3 dB below its DC gain first at the bandwidth."""
        loop = sampled.closed_loop("lqr.centralised")
        res = analyse_frequency(loop, plant=sampled.model.discrete)
        _, T = loop_sensitivity(loop, sampled.model.discrete)
        n = loop.ninputs
        common = ct.ss(T.A, np.asarray(T.B) @ np.ones((n, 1)),
                       np.ones((1, n)) @ np.asarray(T.C) / n, 0, loop.dt)
        dc = abs(float(np.squeeze(common.dcgain())))
        mag = lambda w: np.abs(np.squeeze(ct.frequency_response(common, w).complex))  # noqa: E731
        assert mag(np.array([res.bandwidth])) == pytest.approx(dc * 10 ** (-3 / 20), rel=1e-6)
        below = np.linspace(1e-5, res.bandwidth * (1 - 1e-6), 2000)
        assert np.all(mag(below) > dc * 10 ** (-3 / 20))
        if _python_control_dt_bandwidth_fixed():
            assert res.bandwidth == pytest.approx(float(ct.bandwidth(common)), rel=1e-6)

    def test_pole_at_one_is_nan(self, book) -> None:
        """The book's Δu-form loops have poles at z = 1: infinite DC gain, no bandwidth."""
        res = analyse_frequency(book.closed_loop("centralised"), plant=book.model.discrete)
        assert math.isnan(res.bandwidth) and res.to_dict()["bandwidth"] is None

    def test_refuses_mimo(self, sampled) -> None:
        """A MIMO system is a DimensionError."""
        with pytest.raises(DimensionError, match="SISO"):
            bandwidth(sampled.closed_loop("ndmpc"))


def _python_control_dt_bandwidth_fixed() -> bool:
    """True once control.bandwidth evaluates discrete systems on the unit circle (PR #1212)."""
    sys = ct.ss([[0.5]], [[0.5]], [[1.0]], 0, 0.1)
    try:
        return abs(float(ct.bandwidth(sys)) - bandwidth(sys)) < 1e-6 * bandwidth(sys)
    except Exception:  # noqa: BLE001 - python-control 0.10 fails on discrete systems
        return False


class TestGradeStep:
    """Grade-step responses against control.forced_response."""

    @pytest.mark.parametrize("strategy", ["ndmpc", "lqr.decentralised"])
    def test_uniform_and_head_steps(self, sampled, strategy: str) -> None:
        """The step on every vehicle and on the head equal forced responses to constant w."""
        loop = sampled.closed_loop(strategy)
        res = analyse_grade_step(loop, duration=20.0)
        n = loop.ninputs
        every = ct.forced_response(loop, res.time, np.full((n, res.time.size), GRADE_STEP))
        head = np.zeros((n, res.time.size))
        head[0] = GRADE_STEP
        one = ct.forced_response(loop, res.time, head)
        np.testing.assert_allclose(res.speeds, every.outputs[:n], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(res.forces, every.outputs[n:2 * n - 1], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(res.head_speeds, one.outputs[:n], rtol=1e-9, atol=1e-15)
        assert res.peak_speed == pytest.approx(np.abs(every.outputs[:n]).max(), rel=1e-12)

    def test_settles_at_the_dc_gain(self, sampled) -> None:
        """A stable loop settles at G(1)·w (final-value theorem), within e⁻⁶ after 6 τ."""
        loop = sampled.closed_loop("lqr.centralised")
        res = analyse_grade_step(loop)
        final = np.asarray(loop.dcgain()) @ np.full(loop.ninputs, GRADE_STEP)
        np.testing.assert_allclose(res.speeds[:, -1], final[: loop.ninputs],
                                   rtol=math.exp(-6) * 1.1)

    def test_continuous_loop_refused(self) -> None:
        """A continuous system is a DimensionError."""
        with pytest.raises(DimensionError, match="discrete"):
            analyse_grade_step(ct.ss([[-1.0]], [[1.0]], [[1.0]], 0))


class TestRun:
    """analyse --json: the ``frequency`` numbers of every strategy."""

    def test_to_dict_has_every_strategy(self) -> None:
        """Strategies in order, strict JSON (no NaN), vehicles numbered from 1."""
        run = run_scenario(load_scenario("crh2-dmpc"), simulate=False)
        out = run.to_dict()["frequency"]
        assert list(out) == ["centralised", "decentralised", "ndmpc"]
        json.dumps(out, allow_nan=False)
        for entry in out.values():
            assert entry["speed_error_peak"]["gain"] > 0
            assert entry["grade_step"]["one_vehicle"]["worst_vehicle"] in range(1, 5)

    def test_no_controller_is_empty(self) -> None:
        """Without a controller there are no closed loops."""
        assert analyse_closed_loops(build_design(load_scenario("heavy-haul-hinf"))) == {}
