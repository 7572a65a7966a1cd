# Step responses of a linear closed loop to grade steps: the whole train, or one vehicle.
"""Grade-step responses of a discrete closed loop of the train.

A 1 ‰ down-grade accelerates every vehicle by w = g·10⁻³ [m/s²] (a specific
force; an up-grade is the same with the opposite sign). On a strategy's
linear closed loop (``Design.closed_loop``, inputs ``w[i]`` [m/s²], outputs
``v[i]`` [m/s] and ``f[i]`` [kN]) :func:`analyse_grade_step` computes, with
:func:`control.step_response`,

- the *step responses*: a 1 ‰ grade step on one vehicle at a time (every
  input channel of the loop, scaled by g·10⁻³), and
- the *grade-step response*: the same step on every vehicle at once (by
  linearity, the sum of the step responses),

and their peaks: the largest speed deviation [m/s] and coupler force [kN].
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np
from numpy.typing import NDArray

from trainctl.exceptions import DimensionError
from trainctl.units import GRAVITY

__all__ = ["GRADE_STEP", "MAX_STEPS", "StepResult", "analyse_grade_step", "step_duration"]

Array = NDArray[np.float64]

GRADE_STEP = GRAVITY * 1e-3
"""Specific force of a 1 ‰ down-grade [m/s²]."""

MAX_STEPS = 4000
"""Most samples of a step response (long-lived loops are cut there)."""

SETTLE_CONSTANTS = 6.0
"""Step responses last this many time constants of the slowest decaying pole."""

SHOWN_POINTS = 300
"""Most samples :meth:`StepResult.curves` keeps for plotting."""


@dataclass(frozen=True, kw_only=True, eq=False)
class StepResult:
    """Grade-step responses of one closed loop (module docstring).

    Parameters
    ----------
    name : str
        The loop's name (the strategy).
    dt : float
        Sample time [s].
    time : ndarray
        Sample instants [s], shape (N+1,).
    speeds : ndarray
        Speed deviation of each vehicle after a 1 ‰ grade step on every
        vehicle [m/s], shape (n, N+1).
    forces : ndarray
        Coupler forces after it [kN], shape (n-1, N+1).
    head_speeds, head_forces : ndarray
        The same for the step on the head vehicle only.
    worst_vehicle : int
        The vehicle (0-based) whose own step gives the largest speed deviation.
    worst_speed, worst_force : float
        Largest speed deviation [m/s] and coupler force [kN] over the
        one-vehicle steps.

    Examples
    --------
    One vehicle, v(k+1) = 0.5 v(k) + 0.1 w(k) (T = 0.1 s): a 1 ‰ down-grade
    (w = g·10⁻³ m/s², g = 9.81 m/s²) settles at 0.1/(1 − 0.5)·g·10⁻³ = 1.962 mm/s.

    >>> loop = ct.ss([[0.5]], [[0.1]], [[1.0]], [[0.0]], 0.1, inputs=["w[0]"], outputs=["v[0]"])
    >>> res = analyse_grade_step(loop)
    >>> res.time.size, round(float(res.time[-1]), 6)  # 40 samples at least [s]
    (41, 4.0)
    >>> round(res.peak_speed * 1e3, 3), res.forces.shape  # [mm/s]; no coupler
    (1.962, (0, 41))
    >>> res.worst_vehicle, res.to_dict()["one_vehicle"]["worst_vehicle"]  # 0-based, 1-based
    (0, 1)
    """

    name: str
    dt: float
    time: Array
    speeds: Array
    forces: Array
    head_speeds: Array
    head_forces: Array
    worst_vehicle: int
    worst_speed: float
    worst_force: float

    @property
    def peak_speed(self) -> float:
        """Largest |speed deviation| after the grade step on every vehicle [m/s]."""
        return float(np.max(np.abs(self.speeds))) if self.speeds.size else 0.0

    @property
    def peak_force(self) -> float:
        """Largest |coupler force| after the grade step on every vehicle [kN]."""
        return float(np.max(np.abs(self.forces))) if self.forces.size else 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe peaks (vehicles numbered from 1, as in the report).

        Returns
        -------
        dict
            ``grade_permille`` (the step, 1 ‰), ``duration`` [s], for the
            step on every vehicle ``peak_speed`` [m/s], ``peak_force`` [kN]
            and ``final_speed`` (the largest absolute deviation at the last
            sample [m/s]), ``one_vehicle`` (``worst_vehicle`` 1-based, its
            ``peak_speed`` and ``peak_force``) and ``units``; non-finite
            numbers as None.
        """
        return {"grade_permille": 1.0, "duration": float(self.time[-1]),
                "peak_speed": _finite(self.peak_speed), "peak_force": _finite(self.peak_force),
                "final_speed": _finite(float(np.max(np.abs(self.speeds[:, -1])))),
                "one_vehicle": {"worst_vehicle": self.worst_vehicle + 1,
                                "peak_speed": _finite(self.worst_speed),
                                "peak_force": _finite(self.worst_force)},
                "units": {"speed": "m/s", "force": "kN", "duration": "s"}}

    def curves(self) -> dict[str, Any]:
        """JSON-safe time series, at most :data:`SHOWN_POINTS` samples (every k-th).

        Returns
        -------
        dict
            ``time`` [s]; ``speeds`` and ``head_speeds`` [m/s] (one list
            per vehicle), ``forces`` and ``head_forces`` [kN] (one list per
            coupler); values to 6 significant digits.
        """
        stride = max(1, math.ceil(self.time.size / SHOWN_POINTS))

        def rows(a: Array) -> list[list[float]]:
            return [[float(f"{x:.6g}") for x in row[::stride]] for row in a]

        return {"time": [float(f"{t:.6g}") for t in self.time[::stride]],
                "speeds": rows(self.speeds), "forces": rows(self.forces),
                "head_speeds": rows(self.head_speeds), "head_forces": rows(self.head_forces)}


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def step_duration(loops: Sequence[ct.StateSpace]) -> float:
    """A common step-response duration for loops shown side by side [s].

    :data:`SETTLE_CONSTANTS` time constants of the slowest decaying pole
    (poles on or outside the unit circle do not decay and are left out), at
    least 40 samples and at most :data:`MAX_STEPS`, of the loop with the
    longest need.

    Parameters
    ----------
    loops : sequence of control.StateSpace
        Discrete closed loops.

    Returns
    -------
    float
        Duration [s].

    Examples
    --------
    Six time constants of the slowest pole, at least 40 samples: a pole at
    z = 0.5 (τ = −T/ln 0.5 = 1.44 samples) needs the 40-sample minimum, one at
    z = 0.99 (τ = 99.5 samples) 6·99.5 → 597 samples.

    >>> fast = ct.ss([[0.5]], [[1.0]], [[1.0]], 0, 0.1)
    >>> slow = ct.ss([[0.99]], [[1.0]], [[1.0]], 0, 0.1)
    >>> round(step_duration([fast]), 6), round(step_duration([fast, slow]), 6)  # [s]
    (4.0, 59.7)
    """
    longest = 0.0
    for loop in loops:
        dt = float(loop.dt)
        radii = np.abs(np.linalg.eigvals(np.asarray(loop.A, dtype=float)))
        decaying = radii[radii < 1.0 - 1e-9]
        slowest = float(np.max(decaying)) if decaying.size else 0.0
        tau = -dt / math.log(slowest) if slowest > 0 else dt
        steps = min(max(math.ceil(SETTLE_CONSTANTS * tau / dt), 40), MAX_STEPS)
        longest = max(longest, steps * dt)
    return longest


def analyse_grade_step(loop: ct.StateSpace, *, duration: float | None = None) -> StepResult:
    """Responses of a discrete closed loop to 1 ‰ grade steps.

    Parameters
    ----------
    loop : control.StateSpace
        Discrete closed loop: inputs ``w[i]`` [m/s²], outputs ``v[i]`` [m/s]
        then ``f[i]`` [kN].
    duration : float or None
        Length of the responses [s]; None: :func:`step_duration` of this loop.

    Returns
    -------
    StepResult
        Responses to the step on every vehicle and on the head vehicle, and
        the worst one-vehicle step.

    Raises
    ------
    DimensionError
        If ``loop`` is not discrete.

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> design = build_design(load_scenario("crh2-dmpc-well-sampled"))
    >>> res = analyse_grade_step(design.closed_loop("lqr.centralised"))
    >>> res.speeds.shape[0], res.peak_speed > 0, res.peak_speed < 1
    (4, True, True)
    """
    if not loop.isdtime(strict=True):
        raise DimensionError("analyse_grade_step: the closed loop must be discrete (dt > 0).")
    dt = float(loop.dt)
    if duration is None:
        duration = step_duration([loop])
    steps = max(1, min(round(duration / dt), MAX_STEPS))
    time = dt * np.arange(steps + 1, dtype=float)
    response = ct.step_response(loop, time, squeeze=False)
    out = np.asarray(response.outputs, dtype=float) * GRADE_STEP  # (outputs, inputs, time)
    labels = list(loop.output_labels)
    speed = [k for k, name in enumerate(labels) if name.startswith("v[")] or list(
        range(loop.ninputs))
    force = [k for k, name in enumerate(labels) if name.startswith("f[")] or [
        k for k in range(loop.noutputs) if k not in speed]
    every = out.sum(axis=1)
    peak_v = np.max(np.abs(out[speed]), axis=(0, 2))
    peak_f = np.max(np.abs(out[force]), axis=(0, 2)) if force else np.zeros(loop.ninputs)
    worst = int(np.argmax(peak_v))
    return StepResult(name=str(loop.name), dt=dt, time=time, speeds=every[speed],
                      forces=every[force], head_speeds=out[speed, 0],
                      head_forces=out[force, 0], worst_vehicle=worst,
                      worst_speed=float(peak_v[worst]), worst_force=float(np.max(peak_f)))
