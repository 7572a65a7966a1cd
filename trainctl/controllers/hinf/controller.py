# The distributed H∞ cooperative controller: the law on the speeds received over the network.
"""The hinf controller: u_i = m_i a_i + R_i(v_i), clipped to the envelope.

At every sample (the family's ``control_interval``) each vehicle records
its own measured speed, reads what it holds from the network
(``Measurement.messages``: ``{(receiver, sender): Received(t_sent,
value)}``, :meth:`trainctl.models.network.Network.messages`), forms the pinning
and consensus differences of :mod:`trainctl.controllers.hinf.law` and
applies its mass times the command plus its own resistance at its measured
speed. The forces are held until the next sample.

Own speeds at a send time
-------------------------
With ``own_speed = "delayed"`` vehicle i compares a value sent at t_s with
its own measured speed at t_s: the newest of its recorded samples at or
before t_s (within :data:`trainctl.models.network.ARRIVAL_TOLERANCE`). The
simulation sends every speed at a control sample, so that is exactly its
measurement at t_s; a message stamped before the first recorded sample
(a hand-built one) is compared with the oldest record. The record starts
empty at :meth:`HinfController.reset` and keeps every sample of the run.

The law reads the measured speeds (``Measurement.outputs``, with the
simulation's measurement noise; the true speeds when only the state is
given), the messages and, for the line feedforward, each vehicle's
position (``Measurement.positions``); no coupler elongation.
Without messages (None: no ``[network]``) it uses the measured speeds and
the reference now, an ideal network.

Faults (:mod:`trainctl.controllers.faults`): a measured speed that is not
finite, a law that raises or forces that are not finite give the status
``"error"`` with the reason in ``info["reason"]`` and the law's feedforward
of the reference, each vehicle's mass times the reference acceleration plus
its resistance at the reference speed (fallback ``"feedforward"``), clipped
to the envelope at the measured speeds (at the reference speed when they are
not finite).
"""

from __future__ import annotations

import bisect
import math
import time
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import (
    Measurement,
    ReferencePreview,
    StepRecord,
    control_dt,
    measured_speeds,
)
from trainctl.controllers.continuous.resistance import feedforward_fallback
from trainctl.controllers.faults import call_solver, non_finite_reason
from trainctl.controllers.hinf.law import HinfLaw
from trainctl.exceptions import ModelError
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.network import ARRIVAL_TOLERANCE, REFERENCE
from trainctl.models.train import Train

if TYPE_CHECKING:
    from trainctl.controllers.hinf.batch import HinfBatch

__all__ = ["HinfController"]

Array = NDArray[np.float64]


class HinfController:
    """The distributed robust H∞ cooperative law over the network (module docstring).

    Parameters
    ----------
    train : Train
        The train (envelopes).
    law : HinfLaw
        Gains, graph, masses and resistance coefficients.
    dt : float
        Control interval [s], > 0.
    input_bounds : bool
        Clip each force to the vehicle's envelope at its measured speed.
    name : str
        Label.

    Examples
    --------
    >>> from trainctl.models import equilibrium
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.hinf.law import law_of
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> ctl = HinfController(scenario.train, law_of(scenario, HinfSettings()), dt=0.1)
    >>> ctl.reset()
    >>> eq = equilibrium(scenario.train, 19.5)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 19.5),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(outputs=np.full(4, 19.5)), ref)
    >>> bool(np.allclose(rec.inputs, eq.inputs)), rec.status
    (True, 'optimal')
    """

    preview_steps = 1
    needs_full_state = False
    uses_network = True
    """The simulation's network carries every measured speed and the reference's speed."""

    def __init__(self, train: Train, law: HinfLaw, *, dt: float, input_bounds: bool = True,
                 name: str = "distributed") -> None:
        dt = control_dt("HinfController", dt)
        if law.n != train.n_vehicles:
            raise ModelError(f"HinfController: the law is for {law.n} vehicles; the train has "
                             f"{train.n_vehicles}.")
        self.train, self.law, self.dt = train, law, float(dt)
        self.input_bounds, self.name = bool(input_bounds), name
        self._envelope = EnvelopeBounds(train, enabled=self.input_bounds)
        self._links = [(i, j) for i in range(law.n) for j in range(law.n)
                       if law.adjacency[i, j] > 0]
        self._times: list[float] = []
        self._speeds: list[Array] = []

    @staticmethod
    def batched(controllers: list[Any]) -> HinfBatch:
        """The law of these controllers (one per run) over R runs at once.

        For :func:`trainctl.sim.batch.simulate_batch` (:mod:`trainctl.controllers.hinf.batch`).

        Parameters
        ----------
        controllers : list
            One controller of this class per run.

        Returns
        -------
        HinfBatch
        """
        from trainctl.controllers.hinf.batch import HinfBatch

        return HinfBatch(controllers)

    def reset(self) -> None:
        """Forget the record of the vehicles' own measured speeds."""
        self._times, self._speeds = [], []

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """Each vehicle's command from what it holds; its force, clipped to its envelope.

        Parameters
        ----------
        t : float
            Simulation time [s], >= the previous step's since :meth:`reset`
            (each vehicle's measured speed is recorded at t).
        measurement : Measurement
            The measured speeds [m/s] (``outputs``, else the state's speeds),
            the ``messages`` received over the network (None: an ideal
            network, the measured speeds and the reference now) and, for the
            line feedforward, the vehicle ``positions`` [m].
        reference : ReferencePreview
            The reference; its first sample's acceleration v̇_d [m/s²] is
            used, and its speed [m/s] only when there are no messages.

        Returns
        -------
        StepRecord
            The forces [N] per vehicle to hold over [t, t + dt), clipped to
            the envelope at the measured speeds, status ``"optimal"``, with
            ``info`` holding ``saturated``, ``missing_terms`` (pinning and
            consensus terms left out for want of data) and
            ``oldest_data_age`` [s]; or, on a fault (module docstring), the
            feedforward [N] within the envelope, status ``"error"``, fallback
            ``"feedforward"`` and ``info["reason"]``.

        Raises
        ------
        ModelError
            If the measurement holds neither n speeds nor a state, its
            positions are not n (with the line fed forward), or ``t`` is
            earlier than the previous step's.
        """
        start = time.perf_counter()
        speeds = self._speeds_of(measurement)
        n = self.law.n
        v_ref, a_ref = float(reference.speed[0]), float(reference.acceleration[0])
        reason = non_finite_reason("outputs", speeds)
        if reason:
            return self._fallback(v_ref, a_ref, np.full(n, v_ref), reason, start)
        self._record(float(t), speeds)
        messages = measurement.messages
        if messages is None:
            e0 = speeds - float(reference.speed[0])
            e = speeds[:, None] - speeds[None, :]
            oldest = 0.0
        else:
            e0, e, oldest = self._errors(float(t), speeds, messages)
        commands, reason = call_solver(self.law.commands, a_ref, e0, e)
        if commands is None or not np.all(np.isfinite(commands)):
            return self._fallback(v_ref, a_ref, speeds, reason or "the commands are not finite",
                                  start)
        inputs = self.law.forces(commands, speeds, measurement.positions)
        inputs, saturated = self._envelope.clip(inputs, speeds)
        missing = (int(np.count_nonzero((self.law.pinning > 0) & np.isnan(e0)))
                   + sum(1 for i, j in self._links if math.isnan(e[i, j])))
        return StepRecord(inputs=inputs, status="optimal", iterations=0,
                          solve_time=time.perf_counter() - start,
                          info={"saturated": saturated, "missing_terms": missing,
                                "oldest_data_age": oldest})

    def _fallback(self, v_ref: float, a_ref: float, speeds: Array, reason: str,
                  start: float) -> StepRecord:
        """The faulty step's record: m a_ref + R(v_ref) [N] within the envelope at ``speeds``."""
        return feedforward_fallback(self.law, self._envelope, v_ref, a_ref, speeds, reason, start)

    def _errors(self, t: float, speeds: Array,
                messages: Mapping[Any, Any]) -> tuple[Array, Array, float]:
        """e_i0, e_ij (NaN where absent) and the oldest used datum's age [s]."""
        n = self.law.n
        e0 = np.full(n, math.nan)
        e = np.full((n, n), math.nan)
        oldest = 0.0
        delayed = self.law.own_speed == "delayed"
        for key, message in messages.items():
            receiver, sender = key
            t_sent, value = message
            i = int(receiver)
            if not 0 <= i < n:
                continue
            own = self._own_speed(i, float(t_sent)) if delayed else float(speeds[i])
            if sender == REFERENCE:
                if self.law.pinning[i] <= 0:
                    continue
                e0[i] = own - float(value)
            else:
                j = int(sender)
                if not 0 <= j < n or self.law.adjacency[i, j] <= 0:
                    continue
                e[i, j] = own - float(value)
            oldest = max(oldest, t - float(t_sent))
        return e0, e, oldest

    def _record(self, t: float, speeds: Array) -> None:
        """Append this sample's measured speeds to the record (a repeated time replaces it)."""
        if self._times and t <= self._times[-1]:
            if t < self._times[-1]:
                raise ModelError(f"{self.name}: time must not go back (got {t!r} s after "
                                 f"{self._times[-1]!r} s); call reset() to start again.")
            self._speeds[-1] = speeds.copy()
            return
        self._times.append(t)
        self._speeds.append(speeds.copy())

    def _own_speed(self, i: int, t_sent: float) -> float:
        """Vehicle i's recorded measured speed at ``t_sent`` (the newest sample at or before)."""
        due = t_sent + ARRIVAL_TOLERANCE * max(1.0, abs(t_sent))
        k = max(bisect.bisect_right(self._times, due) - 1, 0)
        return float(self._speeds[k][i])

    def _speeds_of(self, measurement: Measurement) -> Array:
        """The measured speeds [m/s]: the outputs, else the state's speeds."""
        return measured_speeds(measurement, self.law.n, self.name)
