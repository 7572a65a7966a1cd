# A continuous-time law on the full state, sampled at its control interval, about the feedforward.
"""The controller of a continuous-time law on positions, gaps and speeds (potential, flocking).

u = ū(v_r, a_r) + û(v̂, z, x̂), clipped to the envelope: the law
(``law.force(v̂, z, x̂)``, continuous in time) runs every ``dt`` (the
family's ``control_interval``) and the force is held until the next call.
The reference position x̄_0(t) starts at the head's measured position at the
first step after :meth:`SampledLawController.reset` and follows the
reference speed (:class:`~trainctl.controllers.reference.ReferencePosition`,
with its accuracy at the reference's breakpoints); vehicle i's slot is x̄_0
minus the nominal centre distances ahead of it, so x̂_i = x̂_0 − Σ_{k<i} z_k.

Faults (:mod:`trainctl.controllers.faults`): a state that is not finite, a
state the law refuses (a subclass's ``_refuse``), a law that raises or a
force that is not finite gives the status ``"error"`` with the reason in
``info["reason"]`` and the cruise feedforward (fallback ``"feedforward"``),
clipped to the envelope at the measured speeds (at the reference speed when
they are not finite).
"""

from __future__ import annotations

import time
from typing import Any, ClassVar, Generic, Protocol, TypeVar

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import (
    Measurement,
    PlainStep,
    ReferencePreview,
    StepRecord,
    control_dt,
    documented_as,
)
from trainctl.controllers.continuous.resistance import line_resistance
from trainctl.controllers.faults import call_solver, fault_record, finite, non_finite_reason
from trainctl.controllers.reference import ReferencePosition, position_errors
from trainctl.exceptions import ModelError
from trainctl.models.dynamics import vehicle_positions
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.feedforward import ForceSplit
from trainctl.models.train import Train

__all__ = ["SampledLaw", "SampledLawController"]

Array = NDArray[np.float64]


class SampledLaw(Protocol):
    """A continuous-time law on the errors: ``force(v̂, z, x̂)`` [N] for n vehicles.

    Examples
    --------
    >>> from trainctl.controllers.potential.law import PotentialLaw
    >>> PotentialLaw.force.__name__
    'force'
    """

    @property
    def n(self) -> int:
        """Number of vehicles."""
        ...

    def force(self, v_err: Array, z: Array, x_err: Array) -> Array:
        """The law's feedback û [N] (no feedforward, no saturation).

        Parameters
        ----------
        v_err : ndarray
            Speed errors v̂ [m/s], shape (n,).
        z : ndarray
            Spacing deviations [m], shape (n-1,).
        x_err : ndarray
            Position errors x̂ [m], shape (n,).

        Returns
        -------
        ndarray
            The forces [N], shape (n,).
        """
        ...


LawT = TypeVar("LawT", bound=SampledLaw)


class SampledLawController(Generic[LawT]):
    """A continuous-time law about the cruise feedforward, clipped (module docstring).

    Parameters
    ----------
    train : Train
        The train or formation (feedforward, envelopes).
    law : SampledLaw
        The law, for as many vehicles as the train has.
    dt : float
        Control interval [s], > 0.
    input_bounds : bool
        Clip each force to the vehicle's envelope at its measured speed.
    name : str or None
        Label; None: the class's ``default_name``.

    Examples
    --------
    >>> from trainctl.controllers.continuous.potentials import QuadraticPotential
    >>> from trainctl.controllers.potential.law import PotentialLaw
    >>> from trainctl.models import crh2_half, equilibrium
    >>> train = crh2_half()
    >>> law = PotentialLaw(mass=train.mass, pinning=np.zeros(4), speed_gain=0.5,
    ...                    consensus=np.zeros((4, 4)), potential=QuadraticPotential(0.5))
    >>> ctl = SampledLawController(train, law, dt=0.01)
    >>> eq = equilibrium(train, 80.0)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 80.0),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> rec.status, ctl.name, ctl.dt  # the raw elongations as z: the potential's subclass
    ('optimal', 'law', 0.01)
    """

    preview_steps = 1
    needs_full_state = True
    default_name: ClassVar[str] = "law"
    vehicles: ClassVar[tuple[str, str]] = ("vehicles", "train")
    """What the law's and the train's sizes count, for the message of a mismatch."""

    def __init__(self, train: Train, law: LawT, *, dt: float, input_bounds: bool = True,
                 name: str | None = None) -> None:
        where = type(self).__name__
        dt = control_dt(where, dt)
        if law.n != train.n_vehicles:
            units, whole = self.vehicles
            raise ModelError(f"{where}: the law is for {law.n} {units}, the {whole} has "
                             f"{train.n_vehicles}.")
        name = self.default_name if name is None else name
        self.train, self.law, self.dt = train, law, float(dt)
        self.input_bounds, self.name = bool(input_bounds), name
        self._split = ForceSplit(train, where=name)
        self._envelope = EnvelopeBounds(train, enabled=self.input_bounds)
        self._reference = ReferencePosition()

    def reset(self) -> None:
        """Forget the integrated reference position (the next step restarts it)."""
        self._reference.reset()

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """Feedforward plus the law, clipped to the envelope.

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
            The forces [N] per vehicle to hold over [t, t + dt), clipped to
            the envelope at the measured speeds, status ``"optimal"``, with
            ``info["saturated"]`` (and the subclass's own entries); or, on a
            fault (module docstring), the cruise feedforward [N] within the
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
        x = np.asarray(measurement.state, dtype=float)
        result = self._law_inputs(t, x, float(reference.speed[0]),
                                  float(reference.acceleration[0]), start)
        if isinstance(result, StepRecord):
            return result
        inputs, saturated, info = result
        return StepRecord(inputs=inputs, status="optimal", iterations=0,
                          solve_time=time.perf_counter() - start,
                          info={"saturated": saturated, **info})

    @documented_as(PlainStep.step_inputs)
    def step_inputs(self, t: float, state: Array, speed: float, acceleration: float,
                    out: Array) -> StepRecord | None:
        result = self._law_inputs(t, state, speed, acceleration, time.perf_counter())
        if isinstance(result, StepRecord):
            return result
        out[:] = result[0]
        return None

    def _law_inputs(self, t: float, x: Array, speed: float, accel: float,
                    start: float) -> tuple[Array, int, dict[str, Any]] | StepRecord:
        """The step's clipped inputs [N], how many the envelope cut and the law's info;
        or the fault's record (``start``: the step's clock reading)."""
        n = self.train.n_vehicles
        ff_inputs, ff_elongations = self._split.single(max(speed, 0.1), accel)
        reason = "" if finite(x) else non_finite_reason("state", x)
        if reason:
            return self._fallback(ff_inputs, np.full(n, speed), reason, start)
        line = getattr(self.law, "line", None)
        if line is not None:  # the law's line feedforward: m_i r(p_i) at each position
            ff_inputs = ff_inputs + self.train.mass * line_resistance(
                line, vehicle_positions(self.train, x), n)
        z = self._deviations(x[n:2 * n - 1], ff_elongations)
        head = x[2 * n - 1] - self._reference(t, speed, float(x[2 * n - 1]))
        x_err = position_errors(head, z)
        reason, info = self._refuse(z)
        if reason:
            return self._fallback(ff_inputs, x[:n], reason, start)
        force, reason = call_solver(self.law.force, x[:n] - speed, z, x_err)
        if force is None or not finite(np.asarray(force, dtype=float)):
            return self._fallback(ff_inputs, x[:n], reason or self._force_fault(z), start)
        inputs, saturated = self._envelope.clip(ff_inputs + force, x[:n])
        return inputs, saturated, info

    def _deviations(self, links: Array, elongations: Array) -> Array:
        """The law's spacing deviations z [m] from the plant's link states, given the
        feedforward's quasi-static elongations [m] (read-only)."""
        return links

    def _refuse(self, z: Array) -> tuple[str, dict[str, Any]]:
        """Why the law cannot act on ``z`` ("" when it can), and the step's extra info."""
        return "", {}

    def _force_fault(self, z: Array) -> str:
        """The reason of a force that is not finite (the law did not say)."""
        return "the law's force is not finite"

    def _fallback(self, feedforward: Array, speeds: Array, reason: str,
                  start: float) -> StepRecord:
        """The faulty step's record: the feedforward [N] within the envelope at ``speeds``."""
        inputs, _ = self._envelope.clip(np.asarray(feedforward, dtype=float), speeds)
        return fault_record(inputs, reason=reason, fallback="feedforward", start=start)
