# The closed loop: sample, measure, preview, call the controller, hold, advance.
"""The simulation loop joining a :class:`~trainctl.sim.Plant`, a controller and a reference.

At each sample k = 0 .. N-1 (t_k = k·T with T = ``controller.dt``) the loop

1. measures: the full state (when ``full_state``) and the speeds plus
   Gaussian noise of standard deviation ``measurement_noise`` [m/s] drawn
   from ``numpy.random.default_rng(seed)`` (one draw of n numbers per sample,
   whatever the noise level, so runs are reproducible);
2. previews the reference over ``preview_steps`` steps;
3. calls ``controller.step`` and records its :class:`StepRecord`;
4. holds the inputs over [t_k, t_{k+1}) and advances the plant.

The controller keeps no history: the loop collects it. A controller that
raises has a bug and the exception propagates. An input vector with a
non-finite entry is replaced by the previous applied input (zeros at k = 0),
and the sample is recorded with status ``"error"`` and fallback
``"hold_previous_input"``.
"""

from __future__ import annotations

import math
import time as _time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_nonnegative, check_positive
from ..controllers.base import Controller, Measurement, StepRecord
from ..exceptions import DimensionError, ModelError
from ..models.dynamics import coupler_forces
from ..models.plant import Plant
from .reference import Reference
from .results import SimulationResult, environment

__all__ = ["HOLD_FALLBACK", "simulate"]

HOLD_FALLBACK = "hold_previous_input"
"""Fallback recorded when the loop replaced a non-finite input by the previous one."""


def simulate(
    plant: Plant,
    controller: Controller,
    reference: Reference,
    *,
    duration: float,
    initial_state: ArrayLike,
    preview_steps: int,
    measurement_noise: float = 0.0,
    seed: int = 0,
    full_state: bool = True,
) -> SimulationResult:
    """Run ``controller`` in closed loop with ``plant`` for ``duration`` seconds.

    Parameters
    ----------
    plant : Plant
        The nonlinear train (and track) to control.
    controller : Controller
        Any object following :class:`trainctl.controllers.base.Controller`;
        ``reset()`` is called first, then ``step()`` once per sample.
    reference : Reference
        The reference, e.g. a :class:`~trainctl.sim.SpeedProfile`.
    duration : float
        Simulated time [s], a positive multiple of ``controller.dt`` (within
        1e-9 relative).
    initial_state : array_like
        ``[v (n) [m/s], delta (n-1) [m], s [m]]`` at t = 0.
    preview_steps : int
        Horizon P of the reference preview (P + 1 samples), >= 0.
    measurement_noise : float
        Standard deviation of the speed-measurement noise [m/s], >= 0.
    seed : int
        Seed of the noise generator.
    full_state : bool
        Give the controller the true state in ``Measurement.state`` (else None).

    Returns
    -------
    SimulationResult
        States, inputs, reference and per-step records.

    Raises
    ------
    ModelError
        On invalid settings (duration not a multiple of dt, negative noise, ...).
    DimensionError
        When the initial state or a controller's inputs have the wrong shape.

    Examples
    --------
    >>> import numpy as np
    >>> from trainctl.controllers.base import StepRecord
    >>> from trainctl.models import crh2_half, equilibrium
    >>> from trainctl.sim import Plant, ramp_profile
    >>> train = crh2_half()
    >>> class Hold:
    ...     dt, name = 1.0, "hold"
    ...     def reset(self): pass
    ...     def step(self, t, measurement, reference):
    ...         return StepRecord(inputs=equilibrium(train, 50.0).inputs)
    >>> x0 = equilibrium(train, 50.0).state(position=0.0)
    >>> result = simulate(Plant(train=train), Hold(), ramp_profile(50.0, 50.0, 0.0, 1.0),
    ...                   duration=3.0, initial_state=x0, preview_steps=2)
    >>> result.velocities.shape, result.statuses
    ((4, 4), ('optimal', 'optimal', 'optimal'))
    >>> bool(np.allclose(result.velocities, 50.0))
    True
    """
    dt, steps, noise, x = _check_arguments(plant, controller, reference, duration=duration,
                                           initial_state=initial_state,
                                           preview_steps=preview_steps,
                                           measurement_noise=measurement_noise, seed=seed)
    n = plant.train.n_vehicles
    rng = np.random.default_rng(int(seed))
    log = _Log(n, steps, dt, x)
    previous = np.zeros(n)
    horizon = int(preview_steps)
    wall = _time.perf_counter()
    controller.reset()
    for k in range(steps):
        t = float(log.times[k])
        x = log.states[:, k]
        measured = x[:n] + noise * rng.standard_normal(n)
        measurement = Measurement(state=x.copy() if full_state else None, outputs=measured)
        record = controller.step(t, measurement, reference.preview(t, dt, horizon))
        u = log.record(k, t, controller.name, record, previous)
        log.states[:, k + 1] = plant.advance(x, u, dt)
        previous = u
    wall = _time.perf_counter() - wall
    meta: dict[str, Any] = environment()
    meta.update({
        "train": plant.train.name,
        "n_vehicles": n,
        "track": _track_meta(plant),
        "max_substep": plant.max_substep,
        "substeps_per_sample": plant.substeps(dt),
        "duration": steps * dt,
        "preview_steps": int(preview_steps),
        "measurement_noise": noise,
        "full_state": bool(full_state),
        "wall_time": wall,
    })
    to_dict = getattr(reference, "to_dict", None)
    if callable(to_dict):
        meta["reference"] = to_dict()
    return log.result(plant, controller, reference, seed=int(seed), meta=meta)


def _check_arguments(
    plant: Plant, controller: Controller, reference: Reference, *, duration: float,
    initial_state: ArrayLike, preview_steps: int, measurement_noise: float, seed: int,
) -> tuple[float, int, float, NDArray[np.float64]]:
    """Validate :func:`simulate`'s arguments; return (dt, steps, noise, initial state)."""
    where = "simulate"
    if not isinstance(plant, Plant):
        raise ModelError(
            f"{where}: 'plant' must be a trainctl.sim.Plant (got {type(plant).__name__})."
        )
    if not isinstance(controller, Controller):
        raise ModelError(
            f"{where}: 'controller' must follow trainctl.controllers.base.Controller "
            f"(attributes dt and name, methods reset() and step()) "
            f"(got {type(controller).__name__})."
        )
    if not isinstance(reference, Reference):
        raise ModelError(
            f"{where}: 'reference' must provide speed(t), acceleration(t) and "
            f"preview(t, dt, steps) (got {type(reference).__name__}). Use a SpeedProfile."
        )
    dt = check_positive(where, "controller.dt", controller.dt)
    duration = check_positive(where, "duration", duration)
    steps = round(duration / dt)
    if steps < 1 or abs(steps * dt - duration) > 1e-9 * duration:
        raise ModelError(
            f"{where}: 'duration' must be a positive multiple of controller.dt = {dt!r} s "
            f"(got {duration!r} s = {duration / dt:.6g} samples). "
            f"Use e.g. duration={max(steps, 1) * dt!r}."
        )
    if isinstance(preview_steps, bool) or not isinstance(preview_steps, int | np.integer) \
            or preview_steps < 0:
        raise ModelError(f"{where}: 'preview_steps' must be an int >= 0 (got {preview_steps!r}).")
    noise = check_nonnegative(where, "measurement_noise", measurement_noise)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise ModelError(f"{where}: 'seed' must be an int (got {seed!r}).")
    n = plant.train.n_vehicles
    x = np.array(initial_state, dtype=float)
    if x.shape != (2 * n,):
        raise DimensionError(
            f"{where}: 'initial_state' must have shape ({2 * n},) = [v ({n}), delta ({n - 1}), s] "
            f"(got {x.shape})."
        )
    if not np.all(np.isfinite(x)):
        raise ModelError(f"{where}: 'initial_state' must be finite (got {x.tolist()}).")
    return dt, steps, noise, x


class _Log:
    """The history the loop collects: states, inputs and the controller's step records."""

    def __init__(self, n: int, steps: int, dt: float, x0: NDArray[np.float64]) -> None:
        self.n, self.steps, self.dt = n, steps, dt
        self.times = dt * np.arange(steps + 1, dtype=np.float64)
        self.states = np.empty((2 * n, steps + 1))
        self.states[:, 0] = x0
        self.inputs = np.empty((n, steps))
        self.statuses: list[str] = []
        self.iterations = np.empty(steps, dtype=np.int64)
        self.residuals: list[tuple[float, ...]] = []
        self.solve_times = np.empty(steps)
        self.fallbacks: list[str] = []

    def record(self, k: int, t: float, name: str, record: StepRecord,
               previous: NDArray[np.float64]) -> NDArray[np.float64]:
        """Check and store step k's record; return the input to apply (held if not finite)."""
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
        self.inputs[:, k] = u
        self.statuses.append(status)
        self.iterations[k] = int(record.iterations)
        self.residuals.append(tuple(map(float, record.residuals)))
        self.solve_times[k] = float(record.solve_time)
        self.fallbacks.append(fallback)
        return u

    def result(self, plant: Plant, controller: Controller, reference: Reference, *, seed: int,
               meta: dict[str, Any]) -> SimulationResult:
        """The collected history as a :class:`SimulationResult`."""
        n, states, times = self.n, self.states, self.times
        forces = (coupler_forces(plant.train, states) if n > 1
                  else np.zeros((0, self.steps + 1)))
        return SimulationResult(
            time=times,
            states=states,
            velocities=states[:n].copy(),
            coupler_forces=forces,
            inputs=self.inputs,
            reference_speed=np.asarray(reference.speed(times), dtype=float),
            reference_acceleration=np.asarray(reference.acceleration(times), dtype=float),
            statuses=tuple(self.statuses),
            iterations=self.iterations,
            residuals=tuple(self.residuals),
            solve_times=self.solve_times,
            fallbacks=tuple(self.fallbacks),
            controller_name=str(controller.name),
            seed=seed,
            dt=self.dt,
            meta=meta,
        )


def _track_meta(plant: Plant) -> list[dict[str, object]] | None:
    if plant.track is None:
        return None
    return [
        {
            "start": s.start,
            "grade_permille": s.grade_permille,
            "curve_radius": None if math.isinf(s.curve_radius) else s.curve_radius,
            "formula": plant.track.formula,
        }
        for s in plant.track.sections
    ]
