# Tests of string stability: peak gains along the train against closed forms written here.
"""trainctl.analysis.string_stability, the d[i] outputs of the closed loops, the review check."""

from __future__ import annotations

import importlib
import json
import math

import control as ct
import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

from trainctl.analysis.string_stability import MIN_FIT, string_stability
from trainctl.cli.main import main
from trainctl.design import build_design
from trainctl.exceptions import DimensionError
from trainctl.scenario import load_scenario

# The module (trainctl.analysis re-exports the function under the same name).
string_stability_module = importlib.import_module("trainctl.analysis.string_stability")

KP, KD, KV = 1.0, 0.8, 0.6
"""Spacing gain [1/s²], relative-speed gain [1/s], the head's own speed gain [1/s]."""


def platoon(followers: int, headway: float, *, kv: float = KV) -> ct.StateSpace:
    """Double-integrator vehicles, each following its predecessor (written from scratch).

    States [x_0..x_N, v_0..v_N] (position and speed deviations, m and m/s);
    the head holds its speed, u_0 = -kv v_0 + w; follower i applies
    u_i = KP (x_{i-1} - x_i - h v_i) + KD (v_{i-1} - v_i). Outputs the
    spacing deviations d[i-1] = x_{i-1} - x_i [m].
    """
    n = followers + 1
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n, n] = -kv
    for i in range(1, n):
        A[n + i, i - 1], A[n + i, i] = KP, -KP
        A[n + i, n + i - 1], A[n + i, n + i] = KD, -KD - KP * headway
    B = np.zeros((2 * n, n))
    B[n:, :] = np.eye(n)
    C = np.zeros((followers, 2 * n))
    for i in range(followers):
        C[i, i], C[i, i + 1] = 1.0, -1.0
    return ct.ss(A, B, C, 0, inputs=[f"w[{i}]" for i in range(n)],
                 outputs=[f"d[{i}]" for i in range(followers)], name="platoon")


def closed_form(i: int, headway: float, w: np.ndarray | float, kv: float = KV) -> np.ndarray:
    """|D_i(jω)| from the head's disturbance: D_i = H^i D_0 (polynomials, numpy only).

    X_i = H X_{i-1} with H = (KD s + KP)/(s² + (KD + KP h) s + KP), so the
    spacings D_i = X_{i-1} - X_i obey D_{i+1} = H D_i, and the head's
    X_0 = W / (s (s + kv)) gives D_0 = (1 - H) X_0 = (s + KP h) / ((s + kv) den).
    """
    s = 1j * np.asarray(w, dtype=float)
    den = s**2 + (KD + KP * headway) * s + KP
    H = (KD * s + KP) / den
    D0 = (s + KP * headway) / ((s + kv) * den)
    return np.abs(H**i * D0)


def sup(f, top: float = 50.0) -> tuple[float, float]:
    """sup over ω ≥ 0 of f, by a dense grid refined with a bounded scalar search."""
    grid = np.concatenate([[0.0], np.logspace(-4, math.log10(top), 20001)])
    with np.errstate(invalid="ignore", divide="ignore"):
        values = np.nan_to_num(f(grid), nan=-np.inf)  # 0/0 at DC where a pole cancels
    k = int(np.argmax(values))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
    res = scipy.optimize.minimize_scalar(lambda x: -f(x), bounds=(lo, hi), method="bounded",
                                         options={"xatol": 1e-12})
    return max(float(values[k]), -float(res.fun)), float(res.x)


def h_infinity(headway: float) -> float:
    """‖H‖∞ of the predecessor law."""
    return sup(lambda w: closed_form(1, headway, w) / closed_form(0, headway, w))[0]


class TestContinuousChain:
    """A homogeneous predecessor-following platoon against its closed form."""

    @pytest.mark.parametrize("headway", [0.0, 1.5])
    def test_peaks_equal_the_closed_form(self, headway: float) -> None:
        """γ_i = sup_ω |H^i D_0| evaluated here, to 1e-6."""
        res = string_stability(platoon(6, headway))
        chain = res.chains["d"]
        want = [sup(lambda w, i=i: closed_form(i, headway, w)) for i in range(6)]
        np.testing.assert_allclose(chain.gains, [g for g, _ in want], rtol=1e-6)
        for got, (_, at) in zip(chain.frequencies, want, strict=True):
            assert got == pytest.approx(at, rel=1e-3, abs=1e-6)
        assert res.dt is None and "f" not in res.chains

    def test_constant_spacing_is_string_unstable(self) -> None:
        """h = 0: |H| > 1 below √(2 KP), the peaks grow, the check fails."""
        res = string_stability(platoon(6, 0.0))
        chain = res.chains["d"]
        assert h_infinity(0.0) > 1.05
        assert np.all(np.diff(chain.gains) > 0)
        assert not chain.non_increasing and not res.string_stable
        assert res.max_ratio == pytest.approx(float(np.max(chain.gains[1:] / chain.gains[:-1])))
        assert res.max_ratio > 1

    def test_time_headway_is_string_stable(self) -> None:
        """2 KD h + KP h² ≥ 2 makes |H| ≤ 1 (= 1 at DC): peaks do not grow, the check passes."""
        headway = 1.5
        assert 2 * KD * headway + KP * headway**2 >= 2
        assert h_infinity(headway) == pytest.approx(1.0, abs=1e-9)
        res = string_stability(platoon(6, headway))
        assert res.string_stable and res.chains["d"].non_increasing
        assert res.max_ratio <= 1 + 1e-6

    def test_growth_rate_tends_to_the_peak_of_h(self) -> None:
        """A long train: the fitted factor per vehicle = the closed form's, → ‖H‖∞."""
        followers = 40
        res = string_stability(platoon(followers, 0.0))
        want = np.array([sup(lambda w, i=i: closed_form(i, 0.0, w))[0] for i in range(followers)])
        tail = want[followers // 2:]
        fit = math.exp(np.polyfit(np.arange(tail.size), np.log(tail), 1)[0])
        assert res.chains["d"].growth_rate == pytest.approx(fit, rel=1e-6)
        assert res.chains["d"].growth_rate == pytest.approx(h_infinity(0.0), rel=5e-3)
        assert res.chains["d"].growth_rate > 1

    def test_long_train_message_shows_the_ends_and_the_growth(self) -> None:
        """40 followers: the check names 40 channels, lists 5 peaks and the fitted growth."""
        from trainctl.analysis.string_stability import _judge

        res = string_stability(platoon(40, 0.0))
        check = _judge(res, "toy")
        d = res.chains["d"]
        assert check.status == "fail"
        assert "(40 channels; growth " in check.message
        assert f"growth {d.growth_rate:.4g} per vehicle" in check.message
        assert f"{d.gains[0]:.3g}, {d.gains[1]:.3g}, {d.gains[2]:.3g}, …, " in check.message
        assert f"{d.gains[10]:.3g}," not in check.message
        short = _judge(string_stability(platoon(6, 0.0)), "toy").message
        assert "growth" not in short and "…" not in short

    def test_short_train_has_no_growth_rate(self) -> None:
        """Fewer than MIN_FIT channels: no fit (NaN, None in JSON)."""
        res = string_stability(platoon(MIN_FIT - 1, 0.0))
        assert math.isnan(res.chains["d"].growth_rate)
        assert res.to_dict()["chains"]["d"]["growth_rate_per_vehicle"] is None

    def test_integrator_seen_is_infinite(self) -> None:
        """No speed control at the head (kv = 0): D_0 = (s + KP h)/(s den), infinite at DC."""
        res = string_stability(platoon(4, 1.5, kv=0.0))
        chain = res.chains["d"]
        assert np.all(np.isinf(chain.gains)) and np.all(chain.frequencies == 0)
        assert not res.finite and not res.string_stable and math.isnan(res.max_ratio)
        json.dumps(res.to_dict(), allow_nan=False)

    def test_integrator_unseen_is_finite(self) -> None:
        """kv = 0 with h = 0: the s = 0 poles cancel in D_i = H^i/den, finite peaks."""
        sys = platoon(4, 0.0, kv=0.0)
        assert np.any(np.abs(sys.poles()) < 1e-9)
        res = string_stability(sys)
        want = [sup(lambda w, i=i: closed_form(i, 0.0, w, kv=0.0))[0] for i in range(4)]
        np.testing.assert_allclose(res.chains["d"].gains, want, rtol=1e-6)

    def test_wrong_input_is_refused(self) -> None:
        """An input the loop lacks, or an unknown family, is a DimensionError."""
        with pytest.raises(DimensionError, match="w\\[9\\]"):
            string_stability(platoon(3, 0.0), input="w[9]")
        with pytest.raises(DimensionError, match="families"):
            string_stability(platoon(3, 0.0), outputs=("x",))


class TestDiscreteChain:
    """The same platoon sampled with a zero-order hold: the sup runs up to π/T."""

    @pytest.mark.parametrize("dt", [0.05, 2.0])
    def test_peaks_equal_the_resolvent(self, dt: float) -> None:
        """γ_i = sup over [0, π/T] of |C (e^{jωT} I - A_d)⁻¹ B_d| (scipy expm, numpy solve)."""
        sys = platoon(4, 0.0)
        A, B, C = (np.asarray(m) for m in (sys.A, sys.B[:, [0]], sys.C))
        nx = A.shape[0]
        M = scipy.linalg.expm(np.block([[A, B], [np.zeros((1, nx + 1))]]) * dt)
        Ad, Bd = M[:nx, :nx], M[:nx, nx:]

        def gain(i: int, w):
            ws = np.atleast_1d(w)
            out = [abs((C[i] @ np.linalg.solve(np.exp(1j * x * dt) * np.eye(nx) - Ad, Bd))[0])
                   for x in ws]
            return np.array(out) if np.ndim(w) else out[0]

        res = string_stability(ct.c2d(sys, dt))
        nyquist = math.pi / dt
        assert res.dt == dt and res.omega[-1] == pytest.approx(nyquist)
        assert np.all(res.chains["d"].frequencies <= nyquist * (1 + 1e-12))
        for i in range(4):
            grid = np.linspace(1e-6 * nyquist, nyquist, 4001)  # z = 1 is a (hidden) pole
            values = gain(i, grid)
            k = int(np.argmax(values))
            lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
            best = scipy.optimize.minimize_scalar(lambda x, i=i: -gain(i, x), bounds=(lo, hi),
                                                  method="bounded", options={"xatol": 1e-12})
            assert res.chains["d"].gains[i] == pytest.approx(
                max(values[k], -best.fun), rel=1e-6)

    def test_fast_sampling_approaches_the_continuous_peaks(self) -> None:
        """T = 0.01 s: ZOH peaks within 1 % of the closed form's."""
        res = string_stability(ct.c2d(platoon(4, 0.0), 0.01))
        want = [sup(lambda w, i=i: closed_form(i, 0.0, w))[0] for i in range(4)]
        np.testing.assert_allclose(res.chains["d"].gains, want, rtol=1e-2)


@pytest.fixture(scope="module")
def sampled():
    """crh2-dmpc-well-sampled's design (T = 0.05 s, MPC and LQR)."""
    return build_design(load_scenario("crh2-dmpc-well-sampled"))


class TestSpacingOutputs:
    """The d[i] outputs of the MPC and LQR closed loops."""

    @pytest.mark.parametrize("strategy", ["centralised", "ndmpc", "lqr.decentralised"])
    def test_forces_are_the_coupler_law_on_the_spacings(self, sampled, strategy: str) -> None:
        """Along a grade-step response f = (k d + c (v_i - v_{i+1})) / 1000 kN at every sample."""
        loop = sampled.closed_loop(strategy)
        labels = list(loop.output_labels)
        n = loop.ninputs
        assert labels[-(n - 1):] == [f"d[{i}]" for i in range(n - 1)]
        assert labels[:2 * n - 1] == [f"v[{i}]" for i in range(n)] + [
            f"f[{i}]" for i in range(n - 1)]
        train = sampled.scenario.train
        k, c = np.asarray(train.stiffness), np.asarray(train.damping)
        t = np.arange(200) * loop.dt
        y = np.asarray(ct.forced_response(loop, t, np.vstack([np.full(t.size, 0.01),
                                                               np.zeros((n - 1, t.size))]),
                                          ).outputs)
        v, f, d = y[:n], y[n:2 * n - 1], y[2 * n - 1:]
        want = (k[:, None] * d + c[:, None] * (v[:-1] - v[1:])) / 1e3
        np.testing.assert_allclose(f, want, rtol=1e-9, atol=1e-9 * np.abs(f).max())
        assert np.abs(d).max() > 0

    def test_dc_gain_of_spacings_is_force_over_stiffness(self, sampled) -> None:
        """At DC the coupler moves no more: f[i] = k d[i] / 1000 for every disturbance."""
        loop = sampled.closed_loop("lqr.centralised")
        n = loop.ninputs
        G = np.asarray(loop.dcgain())
        k = np.asarray(sampled.scenario.train.stiffness)
        np.testing.assert_allclose(G[n:2 * n - 1], k[:, None] * G[2 * n - 1:] / 1e3,
                                   rtol=1e-8, atol=1e-12)


class TestModalEvaluation:
    """The refinement's modal evaluation against python-control's, channel by channel."""

    @pytest.mark.parametrize("strategy", ["ndmpc", "lqr.decentralised"])
    def test_peaks_equal_the_python_control_route(self, sampled, strategy, monkeypatch) -> None:
        """Modal (default) and python-control (modal refused) peaks agree to 1e-9."""
        loop = sampled.closed_loop(strategy)
        fast = string_stability(loop)
        monkeypatch.setattr(string_stability_module._Modal, "MAX_COND", 0.0)
        slow = string_stability(loop)
        for q in fast.chains:
            np.testing.assert_allclose(fast.chains[q].gains, slow.chains[q].gains, rtol=1e-9)
            np.testing.assert_allclose(fast.chains[q].frequencies, slow.chains[q].frequencies,
                                       rtol=1e-6, atol=1e-9)

    def test_channel_gain_equals_the_resolvent(self, sampled) -> None:
        """|c (e^{jωT} I − A)⁻¹ b + d| by a dense solve at frequencies off the grid."""
        loop = sampled.closed_loop("ndmpc")
        A, B = np.asarray(loop.A), np.asarray(loop.B)[:, 0]
        C, D = np.asarray(loop.C), np.asarray(loop.D)[:, 0]
        modal = string_stability_module._Modal.build(loop, B, C, D)
        assert modal is not None
        for w in (0.013, 0.7, 9.1, 50.0):
            z = np.exp(1j * w * loop.dt)
            want = np.abs(C @ np.linalg.solve(z * np.eye(A.shape[0]) - A, B) + D)
            for k, value in enumerate(want):  # the channel exists only where they agree
                channel = modal.channel(k, np.array([w]), np.array([value]))
                assert channel is not None, (w, k)
                assert channel.gain(w) == pytest.approx(value, rel=1e-10, abs=1e-14)

    def test_disagreeing_channel_falls_back(self, sampled) -> None:
        """A grid value the modal route does not reproduce: no modal channel."""
        loop = sampled.closed_loop("ndmpc")
        modal = string_stability_module._Modal.build(
            loop, np.asarray(loop.B)[:, 0], np.asarray(loop.C), np.asarray(loop.D)[:, 0])
        assert modal is not None
        assert modal.channel(0, np.array([1.0]), np.array([1.0])) is None  # |G_0(1)| ≠ 1


class TestReviewAndJson:
    """The review check and the numbers of ``analyse --json``."""

    def test_check_in_analyse_json(self, capsys) -> None:
        """analyse --json: the check judges MPC centralised; numbers for every strategy."""
        assert main(["analyse", "crh2-dmpc-well-sampled", "--json", "--no-simulate"]) == 0
        out = json.loads(capsys.readouterr().out)
        check = next(c for c in out["checks"] if c["name"] == "string_stability")
        assert check["status"] in ("pass", "warn", "fail") and check["threshold"] == 1.0
        chains = check["details"]["chains"]
        gains = chains["d"]["peak_gains"]
        assert len(gains) == 3 and all(g > 0 for g in gains)
        ratio = max(max(b / a for a, b in zip(c["peak_gains"][:-1], c["peak_gains"][1:],
                                                strict=True))
                    for c in chains.values())
        assert check["value"] == pytest.approx(ratio)
        assert check["status"] == ("pass" if ratio <= 1 + 1e-6 else "fail")
        for strategy, entry in out["frequency"].items():
            string = entry["string_stability"]
            assert set(string["chains"]) == {"d", "f"}, strategy
            assert len(string["chains"]["f"]["peak_frequencies"]) == 3
        # forces and spacings of one coupler share the peak's frequency (f ≈ k d at low c)
        f = out["frequency"]["lqr.centralised"]["string_stability"]["chains"]
        np.testing.assert_allclose(f["d"]["peak_frequencies"], f["f"]["peak_frequencies"],
                                   rtol=1e-3)
