# The compiled lane of the closed loop: a static linear law's samples in one call each chunk.
"""The closed loop's compiled lane (private; needs the optional numba).

A controller that is a :class:`~trainctl.controllers.base.LinearLaw` (LQR),
run without a network, with full state, on a plant whose samples are one
substep of :class:`~trainctl.models._plant_sample.SampleMap` on a track
without sections (level, or one grade), has its samples run by
:func:`trainctl.sim._lane_kernel.run_chunk`, chunk by chunk of the loop's
reference chunks; the kernel's operations are the Python path's, so the
records are the same bit for bit. It hands back every sample it does not
handle (a fault, an overflow), and the loop does that one its own way.

When: ``TRAINCTL_COMPILED=0`` never, ``=1`` always; by default for runs of at
least :data:`MIN_SAMPLES` samples (the first compilation on a machine costs some
3 s and is then kept in numba's cache; loading it some 0.3 s, the time the
Python path takes for some 7 000 samples of the 4-coach train).
"""

from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.models._plant_propagators import SPEED_GRID

if TYPE_CHECKING:
    from trainctl.controllers.base import LinearLaw
    from trainctl.models.actuator import ActuatorLimits
    from trainctl.sim._log import Log

__all__ = ["MIN_SAMPLES", "Lane", "lane"]

Array = NDArray[np.float64]

MIN_SAMPLES = 10_000
"""Runs shorter than this take the Python path unless ``TRAINCTL_COMPILED=1``."""

_GRID = 96
"""Grid speeds the lane's table holds: ±95 · SPEED_GRID [m/s] (outside: the Python path)."""


def _kernel() -> Any:
    """The compiled kernel module, or None when numba is not installed."""
    try:
        from trainctl.sim import _lane_kernel
    except ImportError:
        return None
    return _lane_kernel


def _linear_law(controller: Any) -> LinearLaw | None:
    """``controller.linear_law()`` when the class that defines ``step`` defines it and
    the instance replaces none of its class's methods (a law patched on the instance is
    run the Python way)."""
    kind = type(controller)
    if any(callable(getattr(kind, name, None)) for name in getattr(controller, "__dict__", {})):
        return None
    owner = {name: next((c for c in kind.__mro__ if name in vars(c)), None)
             for name in ("step", "step_inputs", "linear_law")}
    if owner["linear_law"] is None or len(set(owner.values())) != 1:
        return None
    law: LinearLaw = controller.linear_law()
    return law


def lane(controller: Any, log: Log, actuators: ActuatorLimits, bound: float) -> Lane | None:
    """The lane for this run, or None (module docstring: when it applies)."""
    choice = os.environ.get("TRAINCTL_COMPILED", "").strip()
    if choice == "0" or (choice != "1" and log.steps < MIN_SAMPLES):
        return None
    fast = log.fast
    if fast is None or fast.track is not None:
        return None
    law = _linear_law(controller)
    if law is None:
        return None
    n = log.n
    bounds = [law.envelope, actuators._bounds]
    if any(b.envelopes is None or b.n != n for b in bounds):
        return None
    if law.gain.shape != (n, 2 * n - 1):
        return None
    kernel = _kernel()
    if kernel is None:
        return None
    return Lane(kernel, law, log, actuators, bound)


class Lane:
    """The compiled samples of one run (:func:`lane`)."""

    def __init__(self, kernel: Any, law: LinearLaw, log: Log, actuators: ActuatorLimits,
                 bound: float) -> None:
        fast = log.fast
        assert fast is not None
        n = log.n
        self.kernel, self.law, self.log, self.fast = kernel, law, log, fast
        self.limits = np.ascontiguousarray(
            [np.broadcast_to(np.stack(b._at), (3, 2, n)) for b in (law.envelope,
                                                                   actuators._bounds)],
            dtype=float)
        self.clip_on, self.actuate_on = bool(law.envelope.enabled), bool(actuators.enabled)
        self.tol = float(actuators.tolerance)
        self.davis0 = np.ascontiguousarray(np.broadcast_to(fast.davis0, (n,)), dtype=float)
        self.grade = (np.empty(0) if fast.grade is None else
                      np.ascontiguousarray(np.broadcast_to(fast.grade, (n,)), dtype=float))
        self.half = np.ascontiguousarray(np.broadcast_to(fast.half, (n,)), dtype=float)
        self.bound = float(bound)
        inner = fast.inner
        self.g0 = -(_GRID - 1)
        size = 2 * _GRID - 1
        self.steps = np.zeros((size, 2 * n, 3 * n - 1))
        self.flows = np.zeros((size, max(inner - 1, 1) * 2 * n, 3 * n - 1))
        self.drags = np.zeros((size, n))
        self.have = np.zeros(size, dtype=np.bool_)
        self.dense = log.dense_states if log.per > 1 else log.states
        self._chunk: tuple[int, Array, Array, Array] | None = None

    def grow(self, k: int) -> bool:
        """Add sample k's grid speed to the table; False when it lies outside it."""
        vbar = (float(SPEED_GRID * round(float(self.log.states[0, k]) / SPEED_GRID))
                if self.fast.quadratic else 0.0)  # SampleMap.advance's grid speed
        j = round(vbar / SPEED_GRID) - self.g0
        if not 0 <= j < self.have.size:
            return False
        step, flows, drag = self.fast._at(vbar)
        self.steps[j] = step
        if flows is not None:
            self.flows[j] = flows
        self.drags[j] = drag
        self.have[j] = True
        return True

    def run(self, k: int, first: int, speeds: Array, accelerations: Array) -> tuple[int, int]:
        """Samples k .. of the reference chunk that starts at sample ``first`` (its speeds
        [m/s] and accelerations [m/s²]); returns (the first sample not done, the
        kernel's code: DONE at the chunk's end, PYTHON for a sample to do the Python
        way, DIVERGED for a sample done whose interval diverged)."""
        kernel, log, law = self.kernel, self.log, self.law
        if self._chunk is None or self._chunk[0] != first:
            ff = law.split(np.maximum(speeds, 0.1), accelerations)
            self._chunk = (first, np.ascontiguousarray(speeds, dtype=float),
                           np.ascontiguousarray(ff.inputs, dtype=float),
                           np.ascontiguousarray(ff.elongations, dtype=float))
        _, vref, inputs, elongations = self._chunk
        stop = first + vref.size
        while True:
            row = k - first
            clock = time.perf_counter()
            end, code = kernel.run_chunk(
                k, stop, log.states, self.dense, log.requested, log.inputs, log.saturation,
                log.dense_reference, vref[row:], inputs[row:], elongations[row:], law.gain,
                law.scale, self.limits, self.clip_on, self.actuate_on, self.tol, self.davis0,
                self.grade, self.fast.quadratic, self.half, SPEED_GRID, self.steps,
                self.flows, self.drags, self.have, self.g0, log.per, self.bound)
            self._records(k, end + 1 if code == kernel.DIVERGED else end,
                          time.perf_counter() - clock)
            if code == kernel.GRID and self.grow(end):
                k = end
                continue
            return end, (kernel.PYTHON if code == kernel.GRID else code)

    def _records(self, k0: int, k1: int, elapsed: float) -> None:
        """The plain path's records of samples k0 .. k1-1 (the time shared out)."""
        count = k1 - k0
        if count <= 0:
            return
        log = self.log
        log.statuses.extend(["optimal"] * count)
        log.iterations[k0:k1] = 0
        log.residuals.extend([()] * count)
        log.solve_times[k0:k1] = elapsed / count
        log.fallbacks.extend([""] * count)
