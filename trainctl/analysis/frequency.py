# Frequency-domain view of a linear closed loop: disturbance gains, S and T, bandwidth.
"""Singular values of a discrete closed loop of the train over frequency.

The input is a strategy's linear closed loop (``Design.closed_loop``): a
discrete ``control.StateSpace`` from a specific-force disturbance per
vehicle ``w[i]`` [m/s²] (a grade: a 1 ‰ down-grade is w = g·10⁻³ on every
vehicle) to the speed deviations ``v[i]`` [m/s] and the coupler forces
``f[i]`` [kN]. :func:`analyse_frequency` returns, on a logarithmic grid up
to the Nyquist frequency π/T:

- the singular values of the disturbance → speed-error transfer G_wv
  [(m/s) per (m/s²) = s] and of the disturbance → coupler-force transfer
  G_wf [kN per (m/s²)], with their peaks (largest σ_max) and frequencies;
- the input sensitivity S and complementary sensitivity T (below), their
  peaks, and the bandwidth.

S and T are defined, and computed from the closed-loop matrices, in
:mod:`trainctl.analysis.sensitivity`; so is the bandwidth (python-control's
definition, evaluated on the unit circle).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from trainctl.analysis.sensitivity import (
    UNIT_CIRCLE_TOL,
    bandwidth,
    frequency_grid,
    loop_sensitivity,
)
from trainctl.exceptions import DimensionError

__all__ = ["FrequencyResult", "Peak", "analyse_frequency"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Peak:
    """The largest singular value of a transfer over frequency.

    Parameters
    ----------
    gain : float
        max over ω of σ_max(G(e^{jωT})), in the transfer's unit.
    frequency : float
        Where it occurs [rad/s].

    Examples
    --------
    >>> import control as ct
    >>> # One vehicle, v(k+1) = 0.5 v(k) + T w(k) with T = 0.1 s: G(z) = T/(z - 0.5).
    >>> loop = ct.ss([[0.5]], [[0.1]], [[1.0]], [[0.0]], 0.1, inputs=["w[0]"], outputs=["v[0]"],
    ...              name="toy")
    >>> res = analyse_frequency(loop)
    >>> # |G| is largest at DC: T/(1 - 0.5) = 0.2 s.
    >>> res.speed_peak
    Peak(gain=0.2, frequency=0.0)
    >>> res.speed_peak.to_dict()
    {'gain': 0.2, 'frequency': 0.0}
    """

    gain: float
    frequency: float

    def to_dict(self) -> dict[str, float | None]:
        """JSON-safe dict (non-finite values as None).

        Returns
        -------
        dict of str to float or None
            ``gain`` (in the transfer's unit) and ``frequency`` [rad/s].
        """
        return {"gain": _finite(self.gain), "frequency": _finite(self.frequency)}


@dataclass(frozen=True, kw_only=True, eq=False)
class FrequencyResult:
    """Frequency-domain view of one discrete closed loop (module docstring).

    Parameters
    ----------
    name : str
        The loop's name (the strategy).
    dt : float
        Sample time T [s].
    omega : ndarray
        Frequencies [rad/s], up to π/T.
    speed_sigma : ndarray
        Singular values of G_wv, shape (k, len(omega)) [s = (m/s) per (m/s²)].
    force_sigma : ndarray
        Singular values of G_wf [kN per (m/s²)]; zero rows without couplers.
    sensitivity_sigma, complementary_sigma : ndarray or None
        Singular values of S and T [-]; None when the loop is not state
        feedback around a known plant.
    speed_peak, force_peak : Peak
        Peaks of G_wv and G_wf.
    sensitivity_peak, complementary_peak : Peak or None
        Peaks of S and T.
    bandwidth : float
        Of the common-mode T [rad/s] (NaN: infinite DC gain or no S/T; inf:
        no 3 dB drop below the Nyquist frequency).

    Examples
    --------
    >>> import control as ct
    >>> # One vehicle, v(k+1) = 0.5 v(k) + T w(k) with T = 0.1 s: G(z) = T/(z - 0.5).
    >>> loop = ct.ss([[0.5]], [[0.1]], [[1.0]], [[0.0]], 0.1, inputs=["w[0]"], outputs=["v[0]"],
    ...              name="toy")
    >>> res = analyse_frequency(loop)
    >>> round(res.nyquist, 4)  # π/T [rad/s]
    31.4159
    >>> # At the Nyquist frequency z = -1: |G| = 0.1/1.5 s.
    >>> round(float(res.speed_sigma[0, -1]), 4)
    0.0667
    >>> res.sensitivity_peak is None, res.bandwidth_note  # no plant given
    (True, 'no S and T: the loop is not state feedback around the plant')
    """

    name: str
    dt: float
    omega: Array
    speed_sigma: Array
    force_sigma: Array
    sensitivity_sigma: Array | None
    complementary_sigma: Array | None
    speed_peak: Peak
    force_peak: Peak
    sensitivity_peak: Peak | None
    complementary_peak: Peak | None
    bandwidth: float

    @property
    def nyquist(self) -> float:
        """The Nyquist frequency π/T [rad/s]."""
        return math.pi / self.dt

    @property
    def bandwidth_note(self) -> str:
        """Why there is no finite bandwidth ("" when there is one)."""
        if math.isfinite(self.bandwidth):
            return ""
        if self.complementary_sigma is None:
            return "no S and T: the loop is not state feedback around the plant"
        if math.isinf(self.bandwidth):
            return "the common-mode T does not drop 3 dB below the Nyquist frequency"
        return "infinite DC gain: a closed-loop pole at z = 1"

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe numbers: peaks (gain, frequency [rad/s]) and the bandwidth.

        Returns
        -------
        dict
            ``sample_time`` [s], ``omega_range`` (first and last frequency
            [rad/s]), the peaks ``speed_error_peak``,
            ``coupler_force_peak``, ``sensitivity_peak`` and
            ``complementary_sensitivity_peak`` (each :meth:`Peak.to_dict`,
            None when absent), ``bandwidth`` [rad/s] (None when not
            finite), ``bandwidth_note`` and ``units`` (the unit of each
            entry).
        """
        def peak(p: Peak | None) -> dict[str, float | None] | None:
            return None if p is None else p.to_dict()

        return {
            "sample_time": self.dt,
            "omega_range": [float(self.omega[0]), float(self.omega[-1])],
            "speed_error_peak": peak(self.speed_peak),
            "coupler_force_peak": peak(self.force_peak),
            "sensitivity_peak": peak(self.sensitivity_peak),
            "complementary_sensitivity_peak": peak(self.complementary_peak),
            "bandwidth": _finite(self.bandwidth),
            "bandwidth_note": self.bandwidth_note,
            "units": {"speed_error_peak": "(m/s)/(m/s²)", "coupler_force_peak": "kN/(m/s²)",
                      "sensitivity_peak": "-", "complementary_sensitivity_peak": "-",
                      "frequency": "rad/s", "bandwidth": "rad/s"},
        }

    def curves(self) -> dict[str, Any]:
        """JSON-safe arrays for plotting: ``omega`` and the singular values of each transfer.

        Returns
        -------
        dict
            ``omega`` [rad/s]; ``speed`` [(m/s) per (m/s²)], ``force``
            [kN per (m/s²)], ``sensitivity`` and ``complementary`` [-]: the
            singular values, one list per singular value over ``omega``
            (None for S and T when absent); ``nyquist`` and ``bandwidth``
            [rad/s] (None when not finite). Values rounded to 6 significant
            digits.
        """
        def rows(a: Array | None) -> list[list[float]] | None:
            return None if a is None else [_short(row) for row in a]

        return {"omega": _short(self.omega), "speed": rows(self.speed_sigma),
                "force": rows(self.force_sigma), "sensitivity": rows(self.sensitivity_sigma),
                "complementary": rows(self.complementary_sigma),
                "nyquist": self.nyquist, "bandwidth": _finite(self.bandwidth)}


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _short(values: Array) -> list[float]:
    """Values to 6 significant digits (plenty for a plot; a third of the JSON)."""
    return [float(f"{x:.6g}") for x in values]


def analyse_frequency(
    loop: ct.StateSpace,
    *,
    plant: ct.StateSpace | None = None,
    omega: Array | None = None,
) -> FrequencyResult:
    """Singular values, peaks, sensitivities and bandwidth of a discrete closed loop.

    Parameters
    ----------
    loop : control.StateSpace
        Discrete closed loop (``Design.closed_loop``): inputs ``w[i]``
        [m/s²], outputs ``v[i]`` [m/s] then ``f[i]`` [kN].
    plant : control.StateSpace or None
        The discrete plant the loop closes (the run's ``design.model.discrete``),
        for S and T; None reports the disturbance transfers only.
    omega : ndarray or None
        Frequencies [rad/s]; None: :func:`frequency_grid` plus the angles of
        the loop's poles (so that no lightly damped resonance falls between
        grid points).

    Returns
    -------
    FrequencyResult
        Singular values over ``omega`` and their peaks.

    Raises
    ------
    DimensionError
        If ``loop`` is not discrete.

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> design = build_design(load_scenario("crh2-dmpc-well-sampled"))
    >>> res = analyse_frequency(design.closed_loop("lqr.centralised"),
    ...                         plant=design.model.discrete)
    >>> res.speed_sigma.shape[0], res.sensitivity_peak.gain > 1, round(res.bandwidth, 3)
    (4, True, 0.157)
    """
    if not loop.isdtime(strict=True):
        raise DimensionError("analyse_frequency: the closed loop must be discrete (dt > 0).")
    dt = float(loop.dt)
    w = _loop_grid(loop) if omega is None else np.asarray(omega, dtype=float)
    speed, force = _output_rows(loop)
    parts = {"speed": _rows(loop, speed), "force": _rows(loop, force)}
    pair = loop_sensitivity(loop, plant) if plant is not None else None
    if pair is not None:
        parts["sensitivity"], parts["complementary"] = pair
    sigma = {key: _sigma(sys, w) for key, sys in parts.items()}
    peaks = {key: _peak(parts[key], w, s) for key, s in sigma.items()}
    band = math.nan
    if pair is not None:
        n = loop.ninputs
        T = pair[1]
        common = ct.ss(T.A, np.asarray(T.B) @ np.ones((n, 1)),
                       np.ones((1, n)) @ np.asarray(T.C) / n, 0, dt)
        band = bandwidth(common)
    return FrequencyResult(
        name=str(loop.name), dt=dt, omega=w, speed_sigma=sigma["speed"],
        force_sigma=sigma["force"], sensitivity_sigma=sigma.get("sensitivity"),
        complementary_sigma=sigma.get("complementary"), speed_peak=peaks["speed"],
        force_peak=peaks["force"], sensitivity_peak=peaks.get("sensitivity"),
        complementary_peak=peaks.get("complementary"), bandwidth=band)


def _loop_grid(loop: ct.StateSpace) -> Array:
    """:func:`frequency_grid` with the loop's pole frequencies |arg λ|/T inside its span."""
    grid = frequency_grid(float(loop.dt))
    angles = np.abs(np.angle(np.linalg.eigvals(np.asarray(loop.A, dtype=float)))) / loop.dt
    inside = angles[(angles > grid[0]) & (angles < grid[-1])]
    return np.unique(np.concatenate([grid, np.round(inside, 12)]))


def _output_rows(loop: ct.StateSpace) -> tuple[list[int], list[int]]:
    """Rows of the speed outputs ``v[i]`` and the coupler-force outputs ``f[i]``."""
    labels = list(loop.output_labels)
    speed = [k for k, name in enumerate(labels) if name.startswith("v[")]
    force = [k for k, name in enumerate(labels) if name.startswith("f[")]
    if not speed:  # unlabelled: n speeds, then the forces
        n = loop.ninputs
        speed, force = list(range(n)), list(range(n, loop.noutputs))
    return speed, force


def _rows(loop: ct.StateSpace, rows: list[int]) -> ct.StateSpace:
    C, D = np.asarray(loop.C, dtype=float), np.asarray(loop.D, dtype=float)
    if not rows:  # no couplers: a zero transfer keeps the shapes uniform
        return ct.ss(loop.A, loop.B, np.zeros((1, loop.nstates)), np.zeros((1, loop.ninputs)),
                     loop.dt)
    return ct.ss(loop.A, loop.B, C[rows], D[rows], loop.dt)


def _sigma(sys: ct.StateSpace, omega: Array) -> Array:
    """Singular values, shape (min(ny, nu), len(omega)), largest first."""
    response = ct.singular_values_response(sys, omega)
    return np.asarray(response.magnitude, dtype=float).reshape(-1, len(omega))


def _sigma_max(sys: ct.StateSpace, w: float) -> float:
    G = np.atleast_2d(np.asarray(sys(np.exp(1j * w * float(sys.dt))), dtype=complex))
    return float(np.linalg.svd(G, compute_uv=False)[0])


def _peak(sys: ct.StateSpace, omega: Array, sigma: Array) -> Peak:
    """The largest σ_max: the grid's, refined between its neighbours, or the DC gain's.

    The DC gain (ω = 0) counts when it is finite (no pole at z = 1); a peak
    at the grid's lowest frequency otherwise bounds a gain that keeps rising.
    """
    top = sigma[0]
    k = int(np.argmax(top))
    best = Peak(float(top[k]), float(omega[k]))
    poles = np.linalg.eigvals(np.asarray(sys.A, dtype=float))
    if k == 0 and not np.any(np.abs(poles - 1.0) < UNIT_CIRCLE_TOL):
        dc = _sigma_max(sys, 0.0)
        if math.isfinite(dc) and dc > best.gain:
            return Peak(dc, 0.0)
    lo, hi = float(omega[max(k - 1, 0)]), float(omega[min(k + 1, omega.size - 1)])
    if hi > lo:
        res = scipy.optimize.minimize_scalar(lambda w: -_sigma_max(sys, w), bounds=(lo, hi),
                                             method="bounded", options={"xatol": 1e-9 * hi})
        if res.success and -float(res.fun) > best.gain:
            best = Peak(-float(res.fun), float(res.x))
    return best
