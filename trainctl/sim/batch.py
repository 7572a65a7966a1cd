# Many runs of one design in one loop: the closed loop over (runs x states) arrays.
"""R runs of :func:`trainctl.sim.simulate` at once, equal to R serial calls bit for bit.

The runs share the plant, the reference, the duration and the controller's
law; they differ in their seeds (measurement noise, network, a controller's
own relay) and in their networks' settings (a repetition's delayed network
and its delay-free baseline). :func:`simulate_batch` runs their samples in
lockstep:

- measurement noise: each run's ``default_rng(seed)`` drawn for the whole
  run at once (the same numbers as one draw of n per sample);
- the network: each run's :class:`~trainctl.models.network.Network` planned in
  advance (:mod:`trainctl.models.network.schedule`: its draws and, per
  sample and link, which message is held), its values read per sample;
- the controller: its batched law (``controller.batched(controllers)``,
  a :class:`BatchLaw`) on (R, n) arrays;
- the plant: :func:`trainctl.models._plant_batch.advance_dense_batch`.

Every arithmetic operation is the serial loop's, elementwise on the rows, or
a per-row BLAS call of the same kind, so each run's result is its serial
result bit for bit (``tests/test_batch.py``), except the wall-clock
``solve_times`` and ``meta["wall_time"]`` (the batch's time shared evenly).

What the batch does not cover raises :class:`BatchUnsupported` before or
during the run, and the caller runs serially: a controller without a batched
law, a run that diverges or overflows, a measurement or a law that is not
finite (the serial loop's fault records), a network with vector values.
"""

from __future__ import annotations

import copy
import math
import time as _time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import Controller
from trainctl.controllers.batch import BatchLaw, BatchUnsupported, Messages
from trainctl.models._plant_batch import advance_dense_batch
from trainctl.models.actuator import SATURATION_TOLERANCE
from trainctl.models.dynamics import vehicle_positions
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.graphs import REFERENCE
from trainctl.models.network.schedule import Plan, plan
from trainctl.models.network.simulator import Network
from trainctl.models.plant import Plant
from trainctl.models.vehicle import envelope_limit
from trainctl.sim._log import Log, dense_grid
from trainctl.sim.closed_loop import (
    _check_arguments,
    _check_options,
    _iteration_limit,
    _track_meta,
    _warn_solver_trouble,
)
from trainctl.sim.reference import Reference
from trainctl.sim.results import SimulationResult, environment

__all__ = ["BatchLaw", "BatchUnsupported", "Messages", "simulate_batch"]

Array = NDArray[np.float64]


def simulate_batch(
    plant: Plant,
    controllers: Sequence[Controller],
    reference: Reference,
    *,
    duration: float,
    initial_states: Sequence[Array],
    preview_steps: int,
    measurement_noise: float = 0.0,
    seeds: Sequence[int],
    full_state: bool = True,
    saturation: bool = True,
    output_interval: float | None = None,
    divergence_speed_error: float = math.inf,
    networks: Sequence[Network | None],
    warn: bool = True,
) -> list[SimulationResult]:
    """R runs of :func:`trainctl.sim.simulate` at once (module docstring).

    Run r has ``controllers[r]``, ``initial_states[r]``, ``seeds[r]`` and
    ``networks[r]``; the other arguments are shared, as :func:`~trainctl.sim.simulate`
    takes them.

    Parameters
    ----------
    plant : Plant
        The plant.
    controllers : sequence of Controller
        One per run, of one class with a ``batched`` law, prepared for its run.
    reference : Reference
        The reference.
    duration : float
        Simulated time [s].
    initial_states : sequence of ndarray
        One ``[v, delta, s]`` per run.
    preview_steps : int
        Reference preview horizon P.
    measurement_noise : float
        Speed-measurement noise [m/s].
    seeds : sequence of int
        One noise seed per run.
    full_state : bool
        The controllers read the true state.
    saturation : bool
        Saturate the forces to the envelopes.
    output_interval : float or None
        Dense-grid spacing [s].
    divergence_speed_error : float
        Divergence bound [m/s] (a run that reaches it raises
        :class:`BatchUnsupported`).
    networks : sequence of Network or None
        One per run (all None or none None).
    warn : bool
        Warn about solver trouble per run.

    Returns
    -------
    list of SimulationResult
        Run r's result, equal to the serial call's bit for bit but for the
        wall-clock fields.

    Raises
    ------
    BatchUnsupported
        When these runs need the serial loop (module docstring).

    Examples
    --------
    Two seeds of the distributed law over the 0-2 s random delays, batched,
    equal their serial runs:

    >>> from dataclasses import replace
    >>> from trainctl.run.simulate import _prepare, simulate_strategy
    >>> from trainctl.scenario import load_scenario
    >>> sc = (load_scenario("heavy-haul-hinf-delay").replace("simulation.settle_time", 5.0)
    ...       .replace("simulation.duration", 10.0))
    >>> runs = [_prepare(replace(sc, seed=s), "distributed", None) for s in (3, 4)]
    >>> results = simulate_batch(runs[0].plant, [r.controller for r in runs], runs[0].profile,
    ...                          duration=10.0, initial_states=[r.state for r in runs],
    ...                          seeds=[3, 4], networks=[r.network for r in runs],
    ...                          **runs[0].options)
    >>> serial = simulate_strategy(replace(sc, seed=4), "distributed")
    >>> bool(np.array_equal(results[1].velocities, serial.velocities))
    True
    """
    R = len(controllers)
    if not (R == len(initial_states) == len(seeds) == len(networks)) or R == 0:
        raise ValueError("simulate_batch: one controller, state, seed and network per run.")
    batched = getattr(controllers[0], "batched", None)
    if not callable(batched) or any(type(c) is not type(controllers[0]) for c in controllers):
        raise BatchUnsupported("the controller has no batched law")
    if (networks[0] is None) != all(net is None for net in networks):
        raise BatchUnsupported("some runs have a network and some not")
    checked = [_check_arguments(plant, c, reference, duration=duration, initial_state=x0,
                                preview_steps=preview_steps, measurement_noise=measurement_noise,
                                seed=seed)
               for c, x0, seed in zip(controllers, initial_states, seeds, strict=True)]
    dt, steps, noise = checked[0][:3]
    if any(c[0] != dt or c[1] != steps for c in checked):
        raise BatchUnsupported("the runs' control intervals differ")
    law: BatchLaw | None = batched(list(controllers))
    if law is None:
        raise BatchUnsupported("the controller's settings have no batched law")
    interval, bound = _check_options(output_interval, divergence_speed_error)
    n = plant.train.n_vehicles
    substeps = plant.substeps(dt)
    every, inner = dense_grid(substeps, steps, n, dt, interval,
                              plant.fastest_rate if interval is None else 0.0)
    logs = [Log(plant, reference, steps, dt, c[3], every=every, inner=inner) for c in checked]
    wall = _time.perf_counter()
    for c in controllers:
        c.reset()
    plans = None
    if networks[0] is not None:
        plans = [plan(net, logs[0].times[:-1], (REFERENCE, *range(n)))
                 for net in networks if net is not None]
    rng_draws = np.stack([np.random.default_rng(int(seed)).standard_normal((steps, n))
                          for seed in seeds])
    engine = _Engine(plant, law, reference, logs, dt=dt, noise=noise, horizon=int(preview_steps),
                     full_state=full_state, saturation=bool(saturation), bound=bound,
                     plans=plans, draws=rng_draws)
    engine.run()
    wall = (_time.perf_counter() - wall) / R
    results = []
    versions = environment()  # the same for every run (reading package metadata costs ~40 ms)
    for r, (controller, log) in enumerate(zip(controllers, logs, strict=True)):
        engine.fill(r, log)
        meta: dict[str, Any] = copy.deepcopy(versions)
        meta.update({
            "train": plant.train.name, "n_vehicles": n, "track": _track_meta(plant),
            "max_substep": plant.max_substep,
            "plant_propagators": "banded" if plant._banded else "dense",
            "substeps_per_sample": substeps, "duration": steps * dt,
            "preview_steps": int(preview_steps), "measurement_noise": noise,
            "full_state": bool(full_state), "plant_saturation": bool(saturation),
            "saturation_tolerance": SATURATION_TOLERANCE, "output_interval": interval,
            "dense_spacing": log.spacing, "dense_points_per_sample": log.per,
            "divergence_speed_error": bound if math.isfinite(bound) else None,
            "divergence": None, "wall_time": wall, **_iteration_limit(controller),
        })
        if plans is not None:
            meta["network"] = plans[r].counts()
        to_dict = getattr(reference, "to_dict", None)
        if callable(to_dict):
            meta["reference"] = to_dict()
        arrays = log.result_arrays(plant, reference)
        if plans is not None:
            arrays["held_noise_square"] = plans[r].held_noise_square()
        result = SimulationResult(**arrays, controller_name=str(controller.name),
                                  seed=int(seeds[r]), dt=dt, meta=meta)
        if warn:
            _warn_solver_trouble(result)
        results.append(result)
    return results


class _Engine:
    """The lockstep loop over the samples of R runs (arrays (R, ...))."""

    def __init__(self, plant: Plant, law: BatchLaw, reference: Reference, logs: list[Log], *,
                 dt: float, noise: float, horizon: int, full_state: bool, saturation: bool,
                 bound: float, plans: list[Plan] | None, draws: Array) -> None:
        self.plant, self.law, self.reference, self.logs = plant, law, reference, logs
        self.dt, self.noise, self.horizon, self.bound = dt, noise, horizon, bound
        self.full_state, self.saturation = full_state, saturation
        self.plans, self.draws = plans, draws
        log = logs[0]
        R, n, K = len(logs), log.n, log.steps
        self.R, self.n, self.K, self.per = R, n, K, log.per
        self.every, self.inner = log.every, log.inner
        self.states = np.empty((R, 2 * n, K + 1))
        self.states[:, :, 0] = np.stack([lg.states[:, 0] for lg in logs])
        self.dense = np.empty((R, 2 * n, K * self.per + 1)) if self.per > 1 else None
        if self.dense is not None:
            self.dense[:, :, 0] = self.states[:, :, 0]
        self.inputs = np.empty((R, n, K))
        self.requested = np.empty((R, n, K))
        self.side = np.zeros((R, n, K), dtype=np.int8)
        self.solve_times = np.zeros(K)
        self.sent = np.empty((R, 0, 0))
        if plans is not None:
            links = plans[0].links
            if any(p.links != links for p in plans):
                raise BatchUnsupported("the runs' networks have different links")
            self.links = links
            self.sent = np.empty((R, K, len(links)))
            self.source = np.stack([p.source for p in plans])
            self.held_noise = np.stack([p.noise for p in plans])
            self.from_reference = np.array([s == REFERENCE for _, s in links])
            self.sender_col = np.array([0 if s == REFERENCE else int(s) for _, s in links])
        self.bounds = EnvelopeBounds(plant.train, enabled=True)
        if self.bounds.envelopes is None:
            raise BatchUnsupported("the train has envelopes of another kind")

    def run(self) -> None:
        """Every sample of every run (raises :class:`BatchUnsupported` on divergence)."""
        log, n, dt, R = self.logs[0], self.n, self.dt, self.R
        self._check_speed(-1)
        times = log.times
        self.law.start(times[:-1])
        rows = np.arange(R)[:, None]
        for k in range(self.K):
            clock = _time.perf_counter()
            t = float(times[k])
            x = self.states[:, :, k]
            measured = x[:, :n] + self.noise * self.draws[:, k]
            messages = None
            if self.plans is not None:
                ref = float(self.reference.speed(t))
                sent = self.sent[:, k]
                sent[:] = np.where(self.from_reference, ref, measured[:, self.sender_col])
                src = self.source[:, k]
                has = src >= 0
                idx = np.where(has, src, 0)
                cols = np.arange(src.shape[1])[None, :]
                values = self.sent[rows, idx, cols] + self.held_noise[rows, idx, cols]
                messages = Messages(self.links, np.where(has, values, np.nan),
                                    np.where(has, log.times[idx], np.nan))
            positions = vehicle_positions(self.plant.train, x.T).T
            preview = self.reference.preview(t, dt, self.horizon)
            u = np.array(self.law.step(k, t, x, measured, positions, messages, preview),
                         dtype=float)
            if u.shape != (R, n) or not np.isfinite(u).all():
                raise BatchUnsupported("a law's inputs are not finite")
            self.solve_times[k] = (_time.perf_counter() - clock) / R
            self.requested[:, :, k] = u
            applied, side = self._apply(u, x[:, :n])
            self.inputs[:, :, k] = applied
            self.side[:, :, k] = side
            try:
                with np.errstate(over="raise", invalid="raise"):
                    states = advance_dense_batch(self.plant, x, applied, dt, self.every,
                                                 self.inner)
            except (FloatingPointError, OverflowError, ValueError) as err:
                raise BatchUnsupported(f"the plant overflowed ({err})") from None
            if self.dense is not None:
                self.dense[:, :, k * self.per + 1 : (k + 1) * self.per + 1] = states
            self.states[:, :, k + 1] = states[:, :, -1]
            self._check_speed(k)

    def _apply(self, u: Array, speeds: Array) -> tuple[Array, NDArray[np.int8]]:
        """:meth:`~trainctl.models.ActuatorLimits.apply` on every row."""
        u = u.copy()
        side = np.zeros(u.shape, dtype=np.int8)
        if not self.saturation:
            return u, side
        force, power, adhesion, mass = self.bounds.envelopes  # type: ignore[misc]
        limits = envelope_limit(speeds[None], force, power, adhesion, mass)
        low, high = -limits[0], limits[1]
        tol = SATURATION_TOLERANCE
        over, under = u > high + tol, u < low - tol
        u[over], u[under] = high[over], low[under]
        side[over | ((high > tol) & (u >= high - tol))] = 1
        side[under | ((low < -tol) & (u <= low + tol))] = -1
        return u, side

    def _check_speed(self, k: int) -> None:
        """Raise :class:`BatchUnsupported` when a run's speed error exceeds the bound in
        sample k's interval (k = -1: at t = 0): the serial loop stops that run there."""
        if not math.isfinite(self.bound):
            return
        log, n = self.logs[0], self.n
        if self.dense is None:
            cols = slice(0, 1) if k < 0 else slice(k + 1, k + 2)
            block = self.states[:, :n, cols]
        else:
            cols = slice(0, 1) if k < 0 else slice(k * self.per + 1, (k + 1) * self.per + 1)
            block = self.dense[:, :n, cols]
        error = np.abs(block - log.dense_reference[cols])
        if np.max(error) > self.bound or not np.isfinite(error).all():
            raise BatchUnsupported("a run diverged")

    def fill(self, r: int, log: Log) -> None:
        """Copy run r's arrays into its :class:`Log` (as the serial loop leaves it)."""
        K = self.K
        log.states[:] = self.states[r]
        if self.dense is not None:
            log.dense_states[:] = self.dense[r]
        log.inputs[:] = self.inputs[r]
        log.requested[:] = self.requested[r]
        log.saturation[:] = self.side[r]
        log.statuses[:] = ["optimal"] * K
        log.iterations[:] = 0
        log.residuals[:] = [()] * K
        log.solve_times[:] = self.solve_times
        log.fallbacks[:] = [""] * K
