# The flocking controller: Olfati-Saber's law sampled at its control interval, clipped.
"""The flocking controller: u = ū(v_r, a_r) + m·a(v̂, z, x̂), clipped to the envelope.

The law (:mod:`trainctl.controllers.flocking.law`) is continuous in time; the
simulation calls :meth:`FlockingController.step` every ``dt`` (the family's
``control_interval``) and holds the force until the next call. The virtual
leader's position x̄_0(t) starts at the head's measured position at the
first step after :meth:`~FlockingController.reset` and follows the
reference speed (trapezoid between steps; exact on each linear piece of the
reference). Train i's slot is x̄_0 minus the nominal centre distances
ahead of it, so x̂_i = x̂_0 − Σ_{k<i} z_k.

Faults (:mod:`trainctl.controllers.faults`): a state that is not finite, two
trains that overlap, a law that raises or a force that is not finite gives
the status ``"error"`` with the reason in ``info["reason"]`` and the cruise
feedforward (fallback ``"feedforward"``), clipped to the envelope at the
measured speeds (at the reference speed when they are not finite).
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import Measurement, ReferencePreview, StepRecord
from trainctl.controllers.faults import call_solver, fault_record, non_finite_reason
from trainctl.controllers.flocking.law import FlockingLaw
from trainctl.controllers.reference import ReferencePosition, position_errors
from trainctl.exceptions import ModelError
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.feedforward import ForceSplit
from trainctl.models.train import Train

__all__ = ["FlockingController"]

Array = NDArray[np.float64]


class FlockingController:
    """Olfati-Saber's flocking law about the cruise feedforward (module docstring).

    Parameters
    ----------
    train : Train
        The formation: one vehicle per train, virtual links.
    law : FlockingLaw
        Gains and pair potential.
    dt : float
        Control interval [s], > 0.
    input_bounds : bool
        Clip each force to the train's envelope at its measured speed.
    name : str
        Label.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.law import law_of
    >>> from trainctl.models import equilibrium
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> law = law_of(scenario, scenario.controllers["flocking"])
    >>> ctl = FlockingController(scenario.train, law, dt=1.0)
    >>> eq = equilibrium(scenario.train, 22.0)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 22.0),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> bool(np.allclose(rec.inputs, eq.inputs)), rec.status
    (True, 'optimal')
    """

    preview_steps = 1
    needs_full_state = True

    def __init__(self, train: Train, law: FlockingLaw, *, dt: float,
                 input_bounds: bool = True, name: str = "flocking") -> None:
        if not dt > 0:
            raise ModelError(f"FlockingController: 'dt' must be > 0 s (got {dt!r}).")
        if law.n != train.n_vehicles:
            raise ModelError(f"FlockingController: the law is for {law.n} trains, the formation "
                             f"has {train.n_vehicles}.")
        self.train, self.law, self.dt = train, law, float(dt)
        self.input_bounds, self.name = bool(input_bounds), name
        self._split = ForceSplit(train, where=name)
        self._envelope = EnvelopeBounds(train, enabled=self.input_bounds)
        self._reference = ReferencePosition()

    def reset(self) -> None:
        """Forget the virtual leader's position (the next step restarts it)."""
        self._reference.reset()

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """Feedforward plus the law, clipped to the envelope.

        Parameters
        ----------
        t : float
            Simulation time [s]: the virtual leader's position x̄_0(t) is
            integrated up to it.
        measurement : Measurement
            The full plant state ``[v (n) [m/s], z (n-1) [m], s [m]]``
            (``measurement.state``, z the gap deviations of the virtual links;
            outputs and messages are not used).
        reference : ReferencePreview
            The reference; only its first sample (speed v_r [m/s] and
            acceleration [m/s²]) is used.

        Returns
        -------
        StepRecord
            The forces [N] per train to hold over [t, t + dt), clipped to the
            envelope at the measured speeds, status ``"optimal"``, with
            ``info["saturated"]`` and ``info["min_gap"]`` (the smallest gap
            [m]); or, on a fault (module docstring: a non-finite state, two
            trains overlapping, a law that raised or gave a non-finite
            force), the cruise feedforward [N] within the envelope, status
            ``"error"``, fallback ``"feedforward"`` and ``info["reason"]``.

        Raises
        ------
        ModelError
            If the measurement has no full state (``state`` is None).
        """
        start = time.perf_counter()
        if measurement.state is None:
            raise ModelError(f"{self.name}: needs full-state measurement (got state=None).")
        n = self.train.n_vehicles
        speed, accel = float(reference.speed[0]), float(reference.acceleration[0])
        ff = self._split([max(speed, 0.1)], [accel])
        x = np.asarray(measurement.state, dtype=float)
        reason = non_finite_reason("state", x)
        if reason:
            return self._fallback(ff.inputs[0], np.full(n, speed), reason, start)
        z = x[n:2 * n - 1]
        head = x[2 * n - 1] - self._reference(t, speed, float(x[2 * n - 1]))
        x_err = position_errors(head, z)
        gaps = self.law.gaps(z)
        if np.any(gaps < 0.0):
            return self._fallback(ff.inputs[0], x[:n], "two trains overlap (smallest gap "
                                  f"{float(np.min(gaps)):.4g} m)", start)
        force, reason = call_solver(self.law.force, x[:n] - speed, z, x_err)
        if force is None or not np.all(np.isfinite(force)):
            return self._fallback(ff.inputs[0], x[:n], reason or "the law's force is not finite",
                                  start)
        inputs = ff.inputs[0] + force
        inputs, saturated = self._envelope.clip(inputs, x[:n])
        return StepRecord(inputs=inputs, status="optimal", iterations=0,
                          solve_time=time.perf_counter() - start,
                          info={"saturated": saturated, "min_gap": float(np.min(gaps))})

    def _fallback(self, feedforward: Array, speeds: Array, reason: str,
                  start: float) -> StepRecord:
        """The faulty step's record: the feedforward [N] within the envelope at ``speeds``."""
        inputs, _ = self._envelope.clip(np.asarray(feedforward, dtype=float), speeds)
        return fault_record(inputs, reason=reason, fallback="feedforward", start=start)
