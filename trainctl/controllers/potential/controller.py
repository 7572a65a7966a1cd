# The potential-function consensus controller: Zhao & Wang's law sampled at its control interval.
"""The potential controller: u = ū(v_r, a_r) + û(x̂, v̂, z), clipped to the envelope.

The law (:mod:`trainctl.controllers.potential.law`) is continuous in time;
the simulation calls :meth:`PotentialController.step` every ``dt`` (the
family's ``control_interval``) and holds the force until the next call.

The reference position x̄_0(t) starts at the head's measured position at the
first step after :meth:`~PotentialController.reset` and follows the reference
speed (:class:`~trainctl.controllers.reference.ReferencePosition`, with its
accuracy at the reference's breakpoints).

Faults (:mod:`trainctl.controllers.faults`): a state that is not finite, a
law that raises, or a force that is not finite (a spacing deviation left the
potential's domain) gives the status ``"error"`` with the reason in
``info["reason"]`` and the cruise feedforward (fallback ``"feedforward"``),
clipped to the envelope at the measured speeds (at the reference speed when
they are not finite).
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import Measurement, ReferencePreview, StepRecord
from trainctl.controllers.faults import call_solver, fault_record, non_finite_reason
from trainctl.controllers.potential.law import PotentialLaw
from trainctl.controllers.reference import ReferencePosition, position_errors
from trainctl.exceptions import ModelError
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.feedforward import ForceSplit
from trainctl.models.train import Train

__all__ = ["PotentialController"]

Array = NDArray[np.float64]


class PotentialController:
    """Zhao & Wang's four-term law about the cruise feedforward (module docstring).

    Parameters
    ----------
    train : Train
        The train (feedforward, envelopes).
    law : PotentialLaw
        Gains and pair potential.
    dt : float
        Control interval [s], > 0.
    input_bounds : bool
        Clip each force to the vehicle's envelope at its measured speed.
    name : str
        Label.

    Examples
    --------
    >>> from trainctl.models import crh2_half, equilibrium
    >>> from trainctl.controllers.continuous.potentials import QuadraticPotential
    >>> train = crh2_half()
    >>> law = PotentialLaw(mass=train.mass, pinning=np.zeros(4), speed_gain=0.5,
    ...                    consensus=np.zeros((4, 4)), potential=QuadraticPotential(0.5))
    >>> ctl = PotentialController(train, law, dt=0.01)
    >>> eq = equilibrium(train, 80.0)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 80.0),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> bool(np.allclose(rec.inputs, eq.inputs)), rec.status
    (True, 'optimal')
    """

    preview_steps = 1
    needs_full_state = True

    def __init__(self, train: Train, law: PotentialLaw, *, dt: float,
                 input_bounds: bool = True, name: str = "consensus") -> None:
        if not dt > 0:
            raise ModelError(f"PotentialController: 'dt' must be > 0 s (got {dt!r}).")
        if law.n != train.n_vehicles:
            raise ModelError(f"PotentialController: the law is for {law.n} cars, the train has "
                             f"{train.n_vehicles}.")
        self.train, self.law, self.dt = train, law, float(dt)
        self.input_bounds, self.name = bool(input_bounds), name
        self._split = ForceSplit(train, where=name)
        self._envelope = EnvelopeBounds(train, enabled=self.input_bounds)
        self._reference = ReferencePosition()

    def reset(self) -> None:
        """Forget the integrated reference position (the next step restarts it)."""
        self._reference.reset()

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """Feedforward plus the four terms, clipped to the envelope.

        Parameters
        ----------
        t : float
            Simulation time [s]: the reference position x̄_0(t) is integrated
            up to it.
        measurement : Measurement
            The full plant state ``[v (n) [m/s], delta (n-1) [m], s [m]]``
            (``measurement.state``; outputs and messages are not used).
        reference : ReferencePreview
            The reference; only its first sample (speed v_r [m/s] and
            acceleration [m/s²]) is used.

        Returns
        -------
        StepRecord
            The forces [N] per car to hold over [t, t + dt), clipped to the
            envelope at the measured speeds (``info["saturated"]``), status
            ``"optimal"``; or, on a fault (module docstring: a non-finite
            state, a law that raised, a spacing deviation that left the
            potential's domain), the cruise feedforward [N] within the
            envelope, status ``"error"``, fallback ``"feedforward"`` and
            ``info["reason"]``.

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
        z = x[n:2 * n - 1] - ff.elongations[0]
        head = x[2 * n - 1] - self._reference(t, speed, float(x[2 * n - 1]))
        x_err = position_errors(head, z)
        force, reason = call_solver(self.law.force, x[:n] - speed, z, x_err)
        if force is None or not np.all(np.isfinite(force)):
            reason = reason or ("a spacing deviation left the potential's domain "
                                f"(max |z| = {float(np.max(np.abs(z))):.4g} m)")
            return self._fallback(ff.inputs[0], x[:n], reason, start)
        inputs = ff.inputs[0] + force
        inputs, saturated = self._envelope.clip(inputs, x[:n])
        return StepRecord(inputs=inputs, status="optimal", iterations=0,
                          solve_time=time.perf_counter() - start,
                          info={"saturated": saturated})

    def _fallback(self, feedforward: Array, speeds: Array, reason: str,
                  start: float) -> StepRecord:
        """The faulty step's record: the feedforward [N] within the envelope at ``speeds``."""
        inputs, _ = self._envelope.clip(np.asarray(feedforward, dtype=float), speeds)
        return fault_record(inputs, reason=reason, fallback="feedforward", start=start)
