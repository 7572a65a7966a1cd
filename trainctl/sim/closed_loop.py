# The closed loop: sample, measure, preview, call the controller, hold, advance.
"""The simulation loop joining a :class:`~trainctl.sim.Plant`, a controller and a reference.

At each sample k = 0 .. N-1 (t_k = k·T with T = ``controller.dt``) the loop

1. measures: the full state (when ``full_state``) and the speeds plus
   Gaussian noise of standard deviation ``measurement_noise`` [m/s] drawn
   from ``numpy.random.default_rng(seed)`` (one draw of n numbers per sample,
   whatever the noise level, so runs are reproducible);
2. previews the reference over ``preview_steps`` steps;
3. calls ``controller.step`` and records its :class:`StepRecord` (or, for a
   full-state law run without a network, its ``step_inputs``:
   :class:`~trainctl.controllers.base.PlainStep`, the same record without the
   per-step objects);
4. saturates the requested forces to each vehicle's envelope at its speed
   at t_k (:class:`~trainctl.models.ActuatorLimits`; unless ``saturation``
   is False), holds them over [t_k, t_{k+1}) and advances the plant,
   recording it on the dense grid between the samples;
5. stops when the plant diverges (below).

The controller keeps no history: the loop collects it. A controller that
raises has a bug and the exception propagates. An input vector with a
non-finite entry is replaced by the previous applied input (zeros at k = 0),
and the sample is recorded with status ``"error"`` and fallback
``"hold_previous_input"``.

Divergence: when some vehicle's speed error |v_i - v_ref| exceeds
``divergence_speed_error`` [m/s] at a point of the dense grid (or already at
t = 0), or the plant's state overflows, the run stops there. The result is
then shorter than ``duration``: it ends with the sample whose interval
diverged (or, after an overflow, with the last finite state), and
``meta["divergence"]`` (:attr:`SimulationResult.divergence`) names the
sample, the time, the signal, its value and the bound.
"""

from __future__ import annotations

import math
import os
import sys
import time as _time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_nonnegative, check_positive
from trainctl.controllers.base import Controller, Measurement, ReferencePreview, StepRecord
from trainctl.controllers.faults import finite
from trainctl.exceptions import (
    ConvergenceWarning,
    DimensionError,
    InaccurateSolutionWarning,
    ModelError,
)
from trainctl.models.actuator import SATURATION_TOLERANCE, ActuatorLimits
from trainctl.models.network.simulator import FATES, Network
from trainctl.models.plant import Plant
from trainctl.sim._lane import lane as _lane
from trainctl.sim._log import HOLD_FALLBACK, Log, dense_grid
from trainctl.sim.metrics import unconverged_steps
from trainctl.sim.reference import Reference, SpeedProfile
from trainctl.sim.results import SimulationResult, environment

__all__ = ["DIVERGENCE_SPEED_ERROR", "HOLD_FALLBACK", "simulate"]

DIVERGENCE_SPEED_ERROR = 50.0
"""Default speed error [m/s] beyond which the loop stops a diverging run."""


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
    saturation: bool = True,
    output_interval: float | None = None,
    divergence_speed_error: float = DIVERGENCE_SPEED_ERROR,
    network: Network | None = None,
    warn: bool = True,
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
    saturation : bool
        Saturate every requested force to the vehicle's envelope at its
        speed (:class:`~trainctl.models.ActuatorLimits`); False applies the
        requests as asked (a linear-analysis study).
    output_interval : float or None
        Spacing of the dense grid between the samples [s], rounded to whole
        substeps of the plant or of points per substep; None: fine enough
        for the plant's fastest mode. Capped as :func:`trainctl.sim.dense_grid`
        documents.
    divergence_speed_error : float
        Stop the run when a vehicle's speed error exceeds this [m/s], > 0
        (inf: only an overflow stops it).
    network : Network or None
        The communication network of networked controllers
        (:class:`trainctl.models.network.Network`, reset here): at every sample
        each vehicle sends its measured speed [m/s] and the reference sends
        its speed, then ``Measurement.messages`` holds what every vehicle
        has received by then (``{(receiver, sender): (t_sent, value)}``).
        None: no network (``messages`` is None). The network draws from its
        own generator, so adding one leaves the measurement noise unchanged;
        ``meta["network"]`` counts the delivered, lost and blocked messages and
        holds ``noise_square_sum``, Σ n² over the delivered messages' noise;
        the result's ``held_noise_square`` is, per sample, Σ n² of the values
        the controller held.
    warn : bool
        Warn once per run about solver trouble (see Warns); False for a
        caller that records it from the result instead (the CLI, reports,
        sweeps and repetitions do).

    Returns
    -------
    SimulationResult
        States, requested and applied inputs, saturation flags, the dense
        grid, reference and per-step records.

    Raises
    ------
    ModelError
        On invalid settings (duration not a multiple of dt, negative noise, ...).
    DimensionError
        When the initial state or a controller's inputs have the wrong shape.

    Warns
    -----
    InaccurateSolutionWarning
        Once per run when some samples' QPs were not solved to optimality
        (statuses other than ``"optimal"``; the result's ``status_counts()``);
        not with ``warn=False``.
    ConvergenceWarning
        Once per run when some steps of an iterating strategy stopped at its
        iteration limit unconverged (see Notes); not with ``warn=False``.

    Notes
    -----
    A controller whose strategy iterates within a step (N-DMPC) may say how
    far: its ``iteration_limit`` (most iterations per step) and
    ``iteration_tolerance`` (the change, in the unit of its residuals, below
    which a step has converged) are copied to ``meta["iteration_limit"]``
    and ``meta["iteration_tolerance"]`` (both None when it has none), from
    which :func:`~trainctl.sim.compute_metrics` counts the steps that
    stopped at the limit.

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
    >>> result.velocities.shape, result.statuses, result.dense_time.size
    ((4, 4), ('optimal', 'optimal', 'optimal'), 181)
    >>> bool(np.allclose(result.velocities, 50.0)), int(np.count_nonzero(result.saturation))
    (True, 0)
    """
    dt, steps, noise, x = _check_arguments(plant, controller, reference, duration=duration,
                                           initial_state=initial_state,
                                           preview_steps=preview_steps,
                                           measurement_noise=measurement_noise, seed=seed)
    interval, bound = _check_options(output_interval, divergence_speed_error)
    n = plant.train.n_vehicles
    substeps = plant.substeps(dt)
    every, inner = dense_grid(substeps, steps, n, dt, interval,
                              plant.fastest_rate if interval is None else 0.0)
    log = Log(plant, reference, steps, dt, x, every=every, inner=inner)
    actuators = ActuatorLimits(plant.train, enabled=bool(saturation))
    wall = _time.perf_counter()
    controller.reset()
    if network is not None:
        network.reset()
    divergence = _run(plant, controller, reference, log, actuators, rng=np.random.default_rng(
        int(seed)), noise=noise, horizon=int(preview_steps), full_state=full_state, bound=bound,
        network=network)
    wall = _time.perf_counter() - wall
    meta: dict[str, Any] = environment()
    meta.update({
        "train": plant.train.name,
        "n_vehicles": n,
        "track": _track_meta(plant),
        "max_substep": plant.max_substep,
        "plant_propagators": "banded" if plant._banded else "dense",
        "substeps_per_sample": substeps,
        "duration": steps * dt,
        "preview_steps": int(preview_steps),
        "measurement_noise": noise,
        "full_state": bool(full_state),
        "plant_saturation": bool(saturation),
        "saturation_tolerance": SATURATION_TOLERANCE,
        "output_interval": interval,
        "dense_spacing": log.spacing,
        "dense_points_per_sample": log.per,
        "divergence_speed_error": bound if math.isfinite(bound) else None,
        "divergence": divergence,
        "wall_time": wall,
        **_iteration_limit(controller),
    })
    history = network.history() if network is not None else None
    if history is not None:
        fates = history.fate
        meta["network"] = {fate: int(np.count_nonzero(fates == fate)) for fate in FATES}
        # Σ n² over the delivered messages: with one message per link and sample, each held
        # for one interval, dt·Σ n² is the energy ∫‖w(t)‖² dt of the noise the controller read.
        delivered = fates == "delivered"
        meta["network"]["noise_square_sum"] = float(np.sum(history.noise[delivered] ** 2))
    to_dict = getattr(reference, "to_dict", None)
    if callable(to_dict):
        meta["reference"] = to_dict()
    arrays = log.result_arrays(plant, reference)
    if history is not None:
        arrays["held_noise_square"] = history.held_noise_square(np.asarray(arrays["time"])[:-1])
    result = SimulationResult(**arrays, controller_name=str(controller.name), seed=int(seed),
                              dt=dt, meta=meta)
    if warn:
        _warn_solver_trouble(result)
    return result


def _outside_level() -> int:
    """The ``stacklevel`` of a warning issued by this function's caller that names the first
    frame outside the trainctl package (the user's line, through simulate_strategy or
    not); Python 3.12's ``skip_file_prefixes`` does this, 3.11 has to count."""
    package = str(Path(__file__).parents[1]) + os.sep
    frame, level = sys._getframe(1), 1
    while frame.f_back is not None and frame.f_code.co_filename.startswith(package):
        frame, level = frame.f_back, level + 1
    return level


def _warn_solver_trouble(result: SimulationResult) -> None:
    """One warning per kind of trouble of a finished run: steps whose iteration stopped
    at its limit unconverged (:class:`~trainctl.exceptions.ConvergenceWarning`) and
    samples whose QP was not solved to optimality otherwise
    (:class:`~trainctl.exceptions.InaccurateSolutionWarning`; an unconverged step's
    ``"max_iterations"`` status is the first kind, warned once). The result records
    both (``status_counts()``, ``residuals``); the warnings make them seen."""
    samples = len(result.statuses)
    name = result.controller_name
    level = _outside_level()
    limit, tolerance = result.meta["iteration_limit"], result.meta["iteration_tolerance"]
    unconverged = unconverged_steps(result)
    if any(unconverged):
        warnings.warn(
            f"simulate: {sum(unconverged)} of {samples} steps of {name!r} stopped at the "
            f"iteration limit {limit} with a change above the tolerance {tolerance:g}; "
            "raise the limit or check the convergence condition (the design review's "
            "DMPC checks). See result.residuals.",
            ConvergenceWarning, stacklevel=level)
    counts: dict[str, int] = {}
    fallbacks = 0
    for status, stopped, fallback in zip(result.statuses, unconverged, result.fallbacks,
                                         strict=True):
        if status != "optimal" and not (stopped and status == "max_iterations"):
            counts[status] = counts.get(status, 0) + 1
            fallbacks += bool(fallback)
    if counts:
        listed = ", ".join(f"{status} {count}" for status, count in counts.items())
        applied = f"; {fallbacks} applied a fallback (result.fallbacks)" if fallbacks else ""
        warnings.warn(
            f"simulate: {sum(counts.values())} of {samples} samples of {name!r} were not "
            f"solved to optimality ({listed}){applied}. See result.status_counts().",
            InaccurateSolutionWarning, stacklevel=level)


def _iteration_limit(controller: Controller) -> dict[str, Any]:
    """``meta``'s ``iteration_limit`` and ``iteration_tolerance``: a controller's
    optional attributes of those names (an iterating strategy's iterations per step and
    the change, in its residuals' unit, below which a step has converged), else None."""
    limit = getattr(controller, "iteration_limit", None)
    tolerance = getattr(controller, "iteration_tolerance", None)
    if limit is None or tolerance is None:
        return {"iteration_limit": None, "iteration_tolerance": None}
    return {"iteration_limit": int(limit), "iteration_tolerance": float(tolerance)}


def _run(plant: Plant, controller: Controller, reference: Reference, log: Log,
         actuators: ActuatorLimits, *, rng: np.random.Generator, noise: float, horizon: int,
         full_state: bool, bound: float,
         network: Network | None = None) -> dict[str, Any] | None:
    """The loop over the samples; returns the divergence record (None: ran to the end)."""
    n = log.n
    divergence = _speed_divergence(log, bound, -1)
    if divergence is not None:
        log.stop(0)
        return divergence
    previous = np.zeros(n)
    batch = _Batch(plant, reference, log, rng, noise, horizon)
    plain = _plain_step(controller) if network is None and full_state else None
    out, state = np.empty(n), np.empty(2 * n)
    clock = _time.perf_counter
    lane = _lane(controller, log, actuators, bound) if plain is not None and batch.profile \
        else None
    k = -1
    while k + 1 < log.steps:
        k += 1
        t = float(log.times[k])
        if lane is not None:  # the compiled samples (sim._lane), chunk by chunk
            batch.reference_at(k, t)
            k, code = lane.run(k, batch.start, batch.speeds[:, 0], batch.accelerations[:, 0])
            if code == lane.kernel.DIVERGED:
                log.stop(k + 1)
                return _speed_divergence(log, bound, k)
            if k > 0:
                previous = log.inputs[:, k - 1].copy()
            if code == lane.kernel.DONE:
                k -= 1  # the next chunk's first sample comes next
                continue
            t = float(log.times[k])  # a sample for the Python path
        x = log.states[:, k]
        if plain is not None:  # the plain path (controllers.base.PlainStep)
            speed, acceleration = batch.reference_at(k, t)
            state[:] = x  # the controller's to read (rewritten next sample)
            start = clock()
            record = plain(t, state, speed, acceleration, out)
            if record is None and finite(out):
                requested = log.record_plain(k, out, clock() - start)
            else:  # a fault's record, or inputs that are not finite (held as for step)
                record = record or StepRecord(inputs=out.copy(), solve_time=clock() - start)
                requested = log.record(k, t, controller.name, record, previous)
        else:
            measured, preview, positions = batch.sample(k, t, x)
            messages = None
            if network is not None:
                network.send_all(t, measured, reference=float(reference.speed(t)))
                messages = network.messages(t)
            measurement = Measurement(state=x.copy() if full_state else None,
                                      outputs=measured, messages=messages, positions=positions)
            record = controller.step(t, measurement, preview)
            requested = log.record(k, t, controller.name, record, previous)
        applied, side = actuators.apply(requested, x[:n])
        try:
            with np.errstate(over="raise", invalid="raise"):
                log.advance(plant, k, applied, side)
        except (FloatingPointError, OverflowError, ValueError) as err:
            log.stop(k)
            return _divergence(k, t, "state", None, math.nan, bound,
                               f"the plant's state overflowed ({err})")
        divergence = _speed_divergence(log, bound, k)
        if divergence is not None:
            log.stop(k + 1)
            return divergence
        previous = applied
    return None


def _plain_step(controller: Controller) -> Any:
    """The controller's bound ``step_inputs`` (:class:`~trainctl.controllers.base.PlainStep`)
    when it stands for its ``step``: defined by the class that defines ``step``, and
    ``step`` not replaced on the instance; else None (the loop calls ``step``)."""
    kind = type(controller)
    own = getattr(controller, "__dict__", {})
    if "step" in own or "step_inputs" in own:
        return None
    owner = {name: next((c for c in kind.__mro__ if name in vars(c)), None)
             for name in ("step", "step_inputs")}
    if owner["step_inputs"] is None or owner["step_inputs"] is not owner["step"]:
        return None
    return controller.step_inputs  # type: ignore[attr-defined]


class _Batch:
    """What the loop can take for many samples at once, in chunks of :attr:`CHUNK`
    samples: the measurement noise (the generator draws the same numbers in one call
    of (chunk, n) as in chunk calls of n) and, for a :class:`SpeedProfile`, the
    reference previews (:meth:`SpeedProfile.previews`, row for row the same as
    ``preview``). Per sample only views of them are handed out."""

    CHUNK = 256

    def __init__(self, plant: Plant, reference: Reference, log: Log,
                 rng: np.random.Generator, noise: float, horizon: int) -> None:
        self.reference, self.log, self.rng = reference, log, rng
        self.noise, self.horizon, self.n = noise, horizon, log.n
        kind = type(reference)
        self.profile = isinstance(reference, SpeedProfile) and all(
            getattr(kind, name) is getattr(SpeedProfile, name)
            for name in ("preview", "speed", "acceleration"))
        self.spacing = plant.train.spacing
        self.behind = np.zeros(self.n)
        self.start = -self.CHUNK  # first sample of the current chunk
        self.draws = np.empty((0, self.n))
        self.times = self.speeds = self.accelerations = self.draws

    def _chunk(self, k: int) -> None:
        log = self.log
        stop = min(k + self.CHUNK, log.steps)
        self.start = k
        self.draws = self.noise * self.rng.standard_normal((stop - k, self.n))
        if self.profile:
            self.times, self.speeds, self.accelerations = self.reference.previews(  # type: ignore[attr-defined]
                log.times[k:stop], log.dt, self.horizon)

    def reference_at(self, k: int, t: float) -> tuple[float, float]:
        """Sample k's reference speed [m/s] and acceleration [m/s²]: the first entries
        of :meth:`sample`'s preview (the chunk's noise is drawn all the same)."""
        row = k - self.start
        if row >= self.draws.shape[0]:
            self._chunk(k)
            row = 0
        if self.profile:
            return float(self.speeds[row, 0]), float(self.accelerations[row, 0])
        preview = self.reference.preview(t, self.log.dt, self.horizon)
        return float(preview.speed[0]), float(preview.acceleration[0])

    def sample(self, k: int, t: float,
               x: NDArray[np.float64]) -> tuple[NDArray[np.float64], ReferencePreview,
                                                NDArray[np.float64]]:
        """Sample k's measured speeds, reference preview and vehicle positions."""
        n = self.n
        row = k - self.start
        if row >= self.draws.shape[0]:
            self._chunk(k)
            row = 0
        measured = x[:n] + self.draws[row]
        if self.profile:
            preview = ReferencePreview(times=self.times[row], speed=self.speeds[row],
                                       acceleration=self.accelerations[row])
        else:
            preview = self.reference.preview(t, self.log.dt, self.horizon)
        # vehicle_positions(train, x) for one state, its operations into a kept buffer.
        (self.spacing + x[n : 2 * n - 1]).cumsum(out=self.behind[1:])
        positions: NDArray[np.float64] = x[2 * n - 1] - self.behind
        return measured, preview, positions


def _speed_divergence(log: Log, bound: float, k: int) -> dict[str, Any] | None:
    """The divergence record when a speed error in sample k's interval (k = -1: at t = 0)
    exceeds ``bound``, else None."""
    if not math.isfinite(bound):
        return None
    peak, i, column = log.speed_error(k)
    if not peak > bound:
        return None
    t = float(log.dense_time[column])
    error = float(log.dense_states[i, column] - log.dense_reference[column])
    return _divergence(max(k, 0), t, f"v[{i}]", i + 1, error, bound,
                       f"the speed error of vehicle {i + 1}, v[{i}] - v_ref = "
                       f"{error:.6g} m/s at t = {t:.6g} s, exceeds divergence_speed_error = "
                       f"{bound:g} m/s")


def _divergence(k: int, t: float, signal: str, vehicle: int | None, value: float,
                bound: float, what: str) -> dict[str, Any]:
    """The JSON-safe divergence record of ``meta["divergence"]``."""
    return {"sample": k, "time": t, "signal": signal, "vehicle": vehicle,
            "value": value if math.isfinite(value) else None,
            "bound": bound if math.isfinite(bound) else None,
            "message": f"simulate: the plant diverged in sample {k} (t = {t:.6g} s): {what}; "
                       "the run stopped there."}


def _check_options(output_interval: float | None,
                   divergence_speed_error: float) -> tuple[float | None, float]:
    """Validate the dense-grid and divergence options of :func:`simulate`."""
    where = "simulate"
    interval = (None if output_interval is None
                else check_positive(where, "output_interval", output_interval))
    if isinstance(divergence_speed_error, bool) or not isinstance(
            divergence_speed_error, int | float | np.integer | np.floating) \
            or not divergence_speed_error > 0:
        raise ModelError(f"{where}: 'divergence_speed_error' must be a number > 0 or inf "
                         f"(got {divergence_speed_error!r}).")
    return interval, float(divergence_speed_error)


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
