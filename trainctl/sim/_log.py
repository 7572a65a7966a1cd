# The history a closed loop collects: samples, requests, saturation and the dense grid.
"""The record :func:`trainctl.sim.simulate` keeps while it runs (private to the loop).

The dense grid: the plant's substeps of length h = T / S (S =
``Plant.substeps(T)``), every ``every``-th substep boundary of each sample
interval and always its end, the next sample instant. ``every`` is 1 by
default, or the whole number of substeps nearest ``output_interval`` [s].
It is then raised until the grid holds at most :data:`MAX_DENSE_POINTS`
points and :data:`MAX_DENSE_VALUES` numbers (3n - 1 per point: the states
and the coupler forces), but never beyond S: the dense grid always holds the
samples. With S = 1 (T no longer than the plant's substep) the dense grid is
the samples.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..controllers.base import StepRecord
from ..exceptions import DimensionError
from ..models._plant_integrate import dense_indices
from ..models.dynamics import coupler_forces
from ..models.plant import Plant
from .reference import Reference

__all__ = ["HOLD_FALLBACK", "MAX_DENSE_POINTS", "MAX_DENSE_VALUES", "Log", "dense_every"]

HOLD_FALLBACK = "hold_previous_input"
"""Fallback recorded when the loop replaced a non-finite input by the previous one."""

MAX_DENSE_POINTS = 200_000
"""Most points of a run's dense grid (the samples are kept beyond it)."""

MAX_DENSE_VALUES = 8_000_000
"""Most numbers of a run's dense states and coupler forces (64 MB of float64)."""

Array = NDArray[np.float64]


def dense_every(substeps: int, samples: int, n_vehicles: int, dt: float,
                output_interval: float | None) -> int:
    """Substeps between the points of the dense grid (module docstring).

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
        Wanted spacing of the dense grid [s]; None: every substep.

    Returns
    -------
    int
        ``every`` in 1..S (S: the samples only).

    Examples
    --------
    >>> dense_every(400, 60, 4, 20.0, None), dense_every(400, 60, 4, 20.0, 1.0)
    (1, 20)
    >>> dense_every(400, 24000, 4, 20.0, None)  # 8 points per sample: 192 001 <= 200 000
    50
    """
    every = 1 if output_interval is None else max(1, round(output_interval * substeps / dt))
    cap = min(MAX_DENSE_POINTS, MAX_DENSE_VALUES // max(3 * n_vehicles - 1, 1))
    per = (cap - 1) // max(samples, 1)  # points per sample interval the cap allows
    every = max(every, math.ceil(substeps / per) if per >= 1 else substeps)
    return min(every, substeps)


class Log:
    """The loop's history: states, requested and applied inputs, records, dense grid."""

    def __init__(self, n: int, steps: int, dt: float, x0: Array, *, substeps: int,
                 every: int) -> None:
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
        self.every, self.done = every, steps
        self.per = dense_indices(substeps, every).size if every < substeps else 1
        if self.per > 1:
            self.dense_time = np.empty(steps * self.per + 1)
            self.dense_time[0] = 0.0
            self.dense_states = np.empty((2 * n, steps * self.per + 1))
            self.dense_states[:, 0] = x0

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
        if not np.isfinite(u).all():
            u = previous.copy()
            status, fallback = "error", HOLD_FALLBACK
        self.requested[:, k] = u
        self.statuses.append(status)
        self.iterations[k] = int(record.iterations)
        self.residuals.append(tuple(map(float, record.residuals)))
        self.solve_times[k] = float(record.solve_time)
        self.fallbacks.append(fallback)
        return u

    def advance(self, plant: Plant, k: int, applied: Array, side: NDArray[np.int8]) -> None:
        """Store the applied inputs of step k and advance the plant to sample k + 1."""
        self.inputs[:, k] = applied
        self.saturation[:, k] = side
        x = self.states[:, k]
        if self.per == 1:
            self.states[:, k + 1] = plant.advance(x, applied, self.dt)
            return
        offsets, states = plant.advance_dense(x, applied, self.dt, self.every)
        cols = slice(k * self.per + 1, (k + 1) * self.per + 1)
        self.dense_time[cols] = self.times[k] + offsets
        self.dense_time[(k + 1) * self.per] = self.times[k + 1]
        self.dense_states[:, cols] = states
        self.states[:, k + 1] = states[:, -1]

    def segment(self, k: int) -> tuple[Array, Array]:
        """Times [s] and states of the dense points in (t_k, t_{k+1}] (the sample alone
        without a dense grid)."""
        if self.per == 1:
            return self.times[k + 1 : k + 2], self.states[:, k + 1 : k + 2]
        cols = slice(k * self.per + 1, (k + 1) * self.per + 1)
        return self.dense_time[cols], self.dense_states[:, cols]

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
                       dense_reference_speed=np.asarray(
                           reference.speed(self.dense_time[:points]), dtype=float))
        return out


def _forces(plant: Plant, states: Array) -> Array:
    n = plant.train.n_vehicles
    return coupler_forces(plant.train, states) if n > 1 else np.zeros((0, states.shape[1]))
