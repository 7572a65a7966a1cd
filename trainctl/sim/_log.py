# The history a closed loop collects: samples, requests, saturation and the dense grid.
"""The record :func:`trainctl.sim.simulate` keeps while it runs (private to the loop).

The dense grid splits every sample interval of length T into points spaced
Δ apart, ending on the next sample instant. The plant integrates in S =
``Plant.substeps(T)`` substeps of h = T / S; the grid takes either every
``every``-th substep boundary (Δ = every·h >= h) or ``inner`` points per
substep (Δ = h / inner < h, on the substep's exact linear flow). Δ is

- ``output_interval`` when given, rounded to a whole number of substeps or
  of points per substep;
- otherwise the substep h, refined so that the fastest mode of the plant
  (:attr:`Plant.fastest_rate`, ω) advances at most :data:`DENSE_PHASE_STEP`
  = 0.5 rad between points: inner = ceil(ω h / 0.5). A peak of that mode is
  then missed by at most 1 - cos(0.25) ≈ 3 % of its amplitude (CRH2: ω =
  27.8 rad/s, h = 0.05 s, 3 points per substep, Δ = 16.7 ms).

The grid is then coarsened (fewer inner points first, then a larger
``every``) until it holds at most :data:`MAX_DENSE_POINTS` points and
:data:`MAX_DENSE_VALUES` numbers (3n - 1 per point: states and coupler
forces), but never beyond the samples: the dense grid always holds every
sample instant, where its values equal the sampled ones.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import StepRecord
from trainctl.controllers.faults import finite
from trainctl.exceptions import DimensionError
from trainctl.models.dynamics import coupler_forces
from trainctl.models.plant import Plant
from trainctl.sim.reference import Reference

__all__ = [
    "DENSE_PHASE_STEP", "HOLD_FALLBACK", "MAX_DENSE_POINTS", "MAX_DENSE_VALUES", "Log",
    "dense_grid",
]

HOLD_FALLBACK = "hold_previous_input"
"""Fallback recorded when the loop replaced a non-finite input by the previous one."""

MAX_DENSE_POINTS = 200_000
"""Most points of a run's dense grid (the samples are kept beyond it)."""

MAX_DENSE_VALUES = 8_000_000
"""Most numbers of a run's dense states and coupler forces (64 MB of float64)."""

DENSE_PHASE_STEP = 0.5
"""Largest phase [rad] of the plant's fastest mode between default dense points."""

Array = NDArray[np.float64]


def dense_grid(substeps: int, samples: int, n_vehicles: int, dt: float,
               output_interval: float | None, fastest_rate: float) -> tuple[int, int]:
    """``(every, inner)`` of the dense grid (module docstring).

    Parameters
    ----------
    substeps : int
        Plant substeps per sample, S >= 1.
    samples : int
        Samples of the run, N.
    n_vehicles : int
        Vehicles n.
    dt : float
        Sample time T [s].
    output_interval : float or None
        Wanted spacing of the dense grid [s]; None: resolve ``fastest_rate``.
    fastest_rate : float
        The plant's fastest mode ω [rad/s] (:attr:`Plant.fastest_rate`).

    Returns
    -------
    (int, int)
        Substeps between grid points (1..S; S: the samples only) and grid
        points per substep (>= 1; > 1 only with ``every`` = 1).

    Examples
    --------
    >>> dense_grid(400, 60, 4, 20.0, None, 27.77)   # the book's T = 20 s: 16.7 ms
    (1, 3)
    >>> dense_grid(400, 60, 4, 20.0, 1.0, 27.77), dense_grid(1, 24000, 4, 0.05, None, 27.77)
    ((20, 1), (1, 3))
    >>> dense_grid(400, 24000, 4, 20.0, None, 27.77)  # capped: 8 points a sample
    (50, 1)
    """
    h = dt / substeps
    if output_interval is None:
        inner = max(1, math.ceil(fastest_rate * h / DENSE_PHASE_STEP - 1e-9))
        every = 1
    elif output_interval < h:
        inner, every = max(1, round(h / output_interval)), 1
    else:
        inner, every = 1, max(1, round(output_interval / h))
    cap = min(MAX_DENSE_POINTS, MAX_DENSE_VALUES // max(3 * n_vehicles - 1, 1))
    per = (cap - 1) // max(samples, 1)  # points per sample interval the cap allows
    inner = max(1, min(inner, per // substeps))
    if inner == 1:
        every = max(every, math.ceil(substeps / per) if per >= 1 else substeps)
    return min(every, substeps), inner


class Log:
    """The loop's history: states, requested and applied inputs, records, dense grid.

    The dense grid's times and the reference speed there are laid out at the
    start (every interval has the same points); the states fill in as the
    plant advances.
    """

    def __init__(self, plant: Plant, reference: Reference, steps: int, dt: float, x0: Array, *,
                 every: int, inner: int) -> None:
        n = plant.train.n_vehicles
        self.n, self.steps, self.dt = n, steps, dt
        self.times = dt * np.arange(steps + 1, dtype=np.float64)
        self.states = np.empty((2 * n, steps + 1))
        self.states[:, 0] = x0
        self.inputs = np.empty((n, steps))
        self.requested = np.empty((n, steps))
        self.saturation = np.zeros((n, steps), dtype=np.int8)
        self.statuses: list[str] = []
        self.iterations = np.empty(steps, dtype=np.int64)
        self.residuals: list[tuple[float, ...]] = []
        self.solve_times = np.empty(steps)
        self.fallbacks: list[str] = []
        self.every, self.inner, self.done = every, inner, steps
        offsets = plant.dense_offsets(dt, every, inner)
        self.per = offsets.size
        if self.per > 1:
            self.dense_time = (self.times[:-1, None] + offsets).ravel()
            self.dense_time = np.insert(self.dense_time, 0, 0.0)
            self.dense_time[self.per :: self.per] = self.times[1:]  # the samples exactly
            self.dense_states = np.empty((2 * n, steps * self.per + 1))
            self.dense_states[:, 0] = x0
        else:
            self.dense_time, self.dense_states = self.times, self.states
        self.dense_reference = np.asarray(reference.speed(self.dense_time), dtype=float)
        self.fast = plant.sample_map(dt, self.per) if every == 1 else None
        """The one-substep sample path (:meth:`Plant.sample_map`; None: advance_dense)."""
        self.spacing = float(offsets[0])
        """Spacing of the dense grid [s] (the last point of an interval may be closer)."""

    def record(self, k: int, t: float, name: str, record: StepRecord,
               previous: Array) -> Array:
        """Check and store step k's record; return the request (held if not finite)."""
        if not isinstance(record, StepRecord):
            raise TypeError(
                f"simulate: {name!r}.step must return a StepRecord "
                f"(got {type(record).__name__} at t={t!r} s)."
            )
        u = np.array(record.inputs, dtype=float)
        if u.shape != (self.n,):
            raise DimensionError(
                f"simulate: {name!r}.step must return inputs of shape ({self.n},) "
                f"(got {u.shape} at t={t!r} s)."
            )
        status, fallback = str(record.status), str(record.fallback)
        if not finite(u):
            u = previous.copy()
            status, fallback = "error", HOLD_FALLBACK
        self.requested[:, k] = u
        self.statuses.append(status)
        self.iterations[k] = int(record.iterations)
        self.residuals.append(tuple(map(float, record.residuals)))
        self.solve_times[k] = float(record.solve_time)
        self.fallbacks.append(fallback)
        return u

    def record_plain(self, k: int, inputs: Array, solve_time: float) -> Array:
        """Store step k of the plain path: finite ``inputs`` [N], status ``"optimal"``, no
        iteration, residual or fallback; return the request (a view of the record)."""
        requested = self.requested[:, k]
        requested[:] = inputs
        self.statuses.append("optimal")
        self.iterations[k] = 0
        self.residuals.append(())
        self.solve_times[k] = solve_time
        self.fallbacks.append("")
        return requested

    def advance(self, plant: Plant, k: int, applied: Array, side: NDArray[np.int8]) -> None:
        """Store the applied inputs of step k and advance the plant to sample k + 1."""
        self.inputs[:, k] = applied
        self.saturation[:, k] = side
        x = self.states[:, k]
        if self.fast is not None and finite(x):  # else the plant's checks raise
            if self.per == 1:
                block = self.states[:, k + 1 : k + 2]
                self.fast.advance(x, applied, block)
                return
            block = self.dense_states[:, k * self.per + 1 : (k + 1) * self.per + 1]
            self.fast.advance(x, applied, block)
            self.states[:, k + 1] = block[:, -1]
            return
        if self.per == 1:
            self.states[:, k + 1] = plant.advance(x, applied, self.dt)
            return
        _, states = plant.advance_dense(x, applied, self.dt, self.every, self.inner)
        self.dense_states[:, k * self.per + 1 : (k + 1) * self.per + 1] = states
        self.states[:, k + 1] = states[:, -1]

    def speed_error(self, k: int) -> tuple[float, int, int]:
        """Largest |v_i - v_ref| over the dense points in (t_k, t_{k+1}] (k = -1: at t = 0),
        with its vehicle and dense column."""
        cols = slice(0, 1) if k < 0 else slice(k * self.per + 1, (k + 1) * self.per + 1)
        error = np.abs(self.dense_states[: self.n, cols] - self.dense_reference[cols])
        flat = int(error.argmax())  # np.argmax's method, without its wrapper (per sample)
        i, j = divmod(flat, error.shape[1])
        return float(error[i, j]), i, (cols.start or 0) + j

    def stop(self, done: int) -> None:
        """End the record after ``done`` samples (the plant diverged)."""
        self.done = done
        del self.statuses[done:], self.residuals[done:], self.fallbacks[done:]

    def result_arrays(self, plant: Plant, reference: Reference) -> dict[str, Any]:
        """The collected arrays, cut to the samples done, as SimulationResult fields."""
        n, done = self.n, self.done
        times, states = self.times[: done + 1], self.states[:, : done + 1]
        out: dict[str, Any] = {
            "time": times, "states": states, "velocities": states[:n].copy(),
            "coupler_forces": _forces(plant, states),
            "inputs": self.inputs[:, :done], "requested_inputs": self.requested[:, :done],
            "saturation": self.saturation[:, :done],
            "reference_speed": np.asarray(reference.speed(times), dtype=float),
            "reference_acceleration": np.asarray(reference.acceleration(times), dtype=float),
            "statuses": tuple(self.statuses), "iterations": self.iterations[:done],
            "residuals": tuple(self.residuals), "solve_times": self.solve_times[:done],
            "fallbacks": tuple(self.fallbacks),
        }
        if self.per > 1:
            points = done * self.per + 1
            dense = self.dense_states[:, :points]
            out.update(dense_time=self.dense_time[:points], dense_states=dense,
                       dense_coupler_forces=_forces(plant, dense),
                       dense_reference_speed=self.dense_reference[:points])
        return out


def _forces(plant: Plant, states: Array) -> Array:
    n = plant.train.n_vehicles
    return coupler_forces(plant.train, states) if n > 1 else np.zeros((0, states.shape[1]))
