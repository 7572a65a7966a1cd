# A state-feedback controller of the train: cruise feedforward, a gain, the envelope.
"""The LQR controller: u = u_ff(v_ref, a_ref) - K x̃, saturated to the envelope.

x̃ = [v - v_ref; delta - delta_ff] is the deviation from the quasi-static
feedforward of the reference (:class:`~trainctl.models.feedforward.ForceSplit`
at the reference speed and acceleration, traction shares within coupled
groups, as :func:`trainctl.models.equilibrium` and the MPC use); the
gain K acts in design units (inputs in kN). With ``input_bounds`` each
vehicle's force is clipped to its traction/braking envelope at its measured
speed, so the controller never asks for more than the vehicle has.

Faults (:mod:`trainctl.controllers.faults`): a state that is not finite, or
a feedback evaluation that raises or is not finite, gives the status
``"error"`` with the reason in ``info["reason"]`` and the feedforward of the
reference (fallback ``"feedforward"``), clipped to the envelope at the
measured speeds (at the reference speed when they are not finite).
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import (
    LinearLaw,
    Measurement,
    PlainStep,
    ReferencePreview,
    StepRecord,
    control_dt,
    documented_as,
)
from trainctl.controllers.faults import call_solver, fault_record, finite, non_finite_reason
from trainctl.exceptions import DimensionError, ModelError
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.feedforward import ForceSplit
from trainctl.models.train import Train

__all__ = ["FEEDFORWARD", "LQRController"]

FEEDFORWARD = "feedforward"
"""Fallback of a faulty step: the feedforward of the reference, within the envelope."""

Array = NDArray[np.float64]
KN = 1e3


class LQRController:
    """Static state feedback about the cruise feedforward (module docstring).

    Parameters
    ----------
    train : Train
        The train (feedforward and envelopes).
    gain : ndarray
        K, shape (n, 2n-1): input deviations [kN] per design-state deviation
        (speeds [m/s], elongations [m]).
    dt : float
        Sample time [s], > 0.
    input_bounds : bool
        Clip each force to the vehicle's envelope at its measured speed.
    name : str
        Label.

    Examples
    --------
    >>> from trainctl.models import crh2_half, equilibrium
    >>> train = crh2_half()
    >>> ctl = LQRController(train, np.zeros((4, 7)), dt=0.1)
    >>> eq = equilibrium(train, 80.0)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 80.0),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> bool(np.allclose(rec.inputs, eq.inputs)), rec.status
    (True, 'optimal')
    """

    preview_steps = 0
    needs_full_state = True

    def __init__(self, train: Train, gain: Array, *, dt: float, input_bounds: bool = True,
                 name: str = "lqr") -> None:
        n = train.n_vehicles
        K = np.asarray(gain, dtype=float)
        if K.shape != (n, 2 * n - 1):
            raise DimensionError(f"LQRController: 'gain' must have shape {(n, 2 * n - 1)} for "
                                 f"{n} vehicles (got {K.shape}).")
        if not np.all(np.isfinite(K)):
            raise ModelError("LQRController: 'gain' must be finite.")
        self.train, self.gain, self.dt = train, K, control_dt("LQRController", dt)
        self.input_bounds, self.name = bool(input_bounds), name
        self._split = ForceSplit(train, where=name)
        self._envelope = EnvelopeBounds(train, enabled=self.input_bounds)
        self._deviation = np.empty(2 * n - 1)

    def reset(self) -> None:
        """Nothing to forget: the law is static."""

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """Feedforward minus K times the deviation, clipped to the envelope.

        Parameters
        ----------
        t : float
            Time of the sample [s] (the law is static: unused).
        measurement : Measurement
            Must hold the full state ``[v (n) [m/s], delta (n-1) [m], s [m]]``.
        reference : ReferencePreview
            The reference; only its first speed [m/s] and acceleration
            [m/s²] are used.

        Returns
        -------
        StepRecord
            Force per vehicle [N], status ``"optimal"``, and in ``info``
            ``"saturated"``, how many forces the envelope cut; on a fault
            (module docstring) status ``"error"``, fallback ``"feedforward"``
            and ``info["reason"]``.

        Raises
        ------
        ModelError
            If the measurement has no state.
        """
        start = time.perf_counter()
        if measurement.state is None:
            raise ModelError(f"{self.name}: needs full-state measurement (got state=None).")
        result = self._law_inputs(np.asarray(measurement.state, dtype=float),
                                  float(reference.speed[0]), float(reference.acceleration[0]),
                                  start)
        if isinstance(result, StepRecord):
            return result
        inputs, saturated = result
        return StepRecord(inputs=inputs, status="optimal", iterations=0,
                          solve_time=time.perf_counter() - start,
                          info={"saturated": saturated})

    @documented_as(PlainStep.step_inputs)
    def step_inputs(self, t: float, state: NDArray[np.float64], speed: float,
                    acceleration: float, out: NDArray[np.float64]) -> StepRecord | None:
        result = self._law_inputs(state, speed, acceleration, time.perf_counter())
        if isinstance(result, StepRecord):
            return result
        out[:] = result[0]
        return None

    def linear_law(self) -> LinearLaw:
        """The law as data, for the loop's compiled lane.

        Returns
        -------
        LinearLaw
            K [kN per unit deviation], the feedforward and the envelope
            (:class:`~trainctl.controllers.base.LinearLaw`).
        """
        return LinearLaw(gain=np.ascontiguousarray(self.gain, dtype=float), scale=KN,
                         split=self._split, envelope=self._envelope)

    def _law_inputs(self, x: NDArray[np.float64], speed: float, accel: float,
                    start: float) -> tuple[NDArray[np.float64], int] | StepRecord:
        """The step's clipped inputs [N] and how many the envelope cut; or the fault's
        record (``start``: the step's clock reading)."""
        n = self.train.n_vehicles
        ff_inputs, ff_elongations = self._split.single(max(speed, 0.1), accel)
        reason = "" if finite(x) else non_finite_reason("state", x)
        if reason:
            return self._fallback(ff_inputs, np.full(n, speed), reason, start)
        deviation = self._deviation  # [x[:n] - v_ref, delta - delta_ff], kept
        np.subtract(x[:n], speed, out=deviation[:n])
        np.subtract(x[n : 2 * n - 1], ff_elongations, out=deviation[n:])
        feedback, reason = call_solver(self._feedback, deviation)
        if feedback is None or not finite(feedback):
            return self._fallback(ff_inputs, x[:n], reason or "the feedback is not finite",
                                  start)
        return self._envelope.clip(ff_inputs - feedback, x[:n])

    def _feedback(self, deviation: NDArray[np.float64]) -> NDArray[np.float64]:
        """K x̃ [N]: the law's correction (the step's solver boundary)."""
        return KN * (self.gain @ deviation)

    def _fallback(self, feedforward: NDArray[np.float64], speeds: NDArray[np.float64],
                  reason: str, start: float) -> StepRecord:
        """The faulty step's record: the feedforward [N] within the envelope at ``speeds``."""
        inputs, _ = self._envelope.clip(np.asarray(feedforward, dtype=float), speeds)
        return fault_record(inputs, reason=reason, fallback=FEEDFORWARD, start=start)

