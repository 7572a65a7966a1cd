# The synchronous controller's law and relay over many runs at once (trainctl.sim.batch).
"""R runs of :class:`~trainctl.controllers.synchronous.controller.SynchronousController`
on (R, n) arrays, each bit for bit its serial step: the lead's command by the
same operations, and each run's relay planned in advance
(:func:`trainctl.models.network.schedule.plan`: the relay's draws from its
seed, and which command each remote holds at each sample)."""

from __future__ import annotations

import math
import pickle
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import ReferencePreview
from trainctl.controllers.batch import (
    BatchUnsupported,
    Messages,
    clip_rows,
    own_resistance_rows,
)
from trainctl.models.network.schedule import plan

if TYPE_CHECKING:
    from trainctl.controllers.synchronous.controller import SynchronousController

__all__ = ["SynchronousBatch"]

Array = NDArray[np.float64]


class SynchronousBatch:
    """The law and relays of R synchronous controllers with the same law (one per run).

    Parameters
    ----------
    controllers : sequence of SynchronousController
        One per run (its relay as prepared for the run), with equal laws,
        control intervals and envelope settings (else
        :class:`~trainctl.controllers.batch.BatchUnsupported`).

    Examples
    --------
    Over an instantaneous relay every remote holds the lead's command at once,
    as :meth:`SynchronousController.step` has it:

    >>> from trainctl.controllers.base import Measurement, ReferencePreview
    >>> from trainctl.controllers.synchronous.controller import SynchronousController
    >>> from trainctl.controllers.synchronous.law import law_of
    >>> from trainctl.controllers.synchronous.relay import CommandRelay
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> law = law_of(scenario, SynchronousSettings())
    >>> ctl = SynchronousController(scenario.train, law, CommandRelay(None, 4, 0, seed=0),
    ...                             dt=0.1)
    >>> batch = SynchronousBatch([ctl])
    >>> batch.start(np.zeros(1))
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 19.5),
    ...                        acceleration=np.zeros(1))
    >>> v = np.array([[19.6, 19.5, 19.5, 19.4]])
    >>> u = batch.step(0, 0.0, np.zeros((1, 8)), v, np.zeros((1, 4)), None, ref)
    >>> ctl.reset()
    >>> serial = ctl.step(0.0, Measurement(outputs=v[0], positions=np.zeros(4)), ref).inputs
    >>> bool(np.array_equal(u[0], serial))
    True
    """

    def __init__(self, controllers: Sequence[SynchronousController]) -> None:
        first = controllers[0]
        key = pickle.dumps((first.law, first.dt, first.input_bounds))
        if any(pickle.dumps((c.law, c.dt, c.input_bounds)) != key for c in controllers[1:]):
            raise BatchUnsupported("the runs' synchronous laws differ")
        self.law, self.R = first.law, len(controllers)
        self.networks = [c.relay.network for c in controllers]
        self.envelopes = first._envelope.envelopes if first.input_bounds else None
        if first.input_bounds and self.envelopes is None:
            raise BatchUnsupported("the train has envelopes of another kind")

    def start(self, times: Array) -> None:
        """Plan every run's relay over the samples (:meth:`CommandRelay.reset`).

        Parameters
        ----------
        times : ndarray
            The sample times [s], shape (K,).
        """
        lead = self.law.lead
        plans = [plan(net, times, (lead,)) for net in self.networks]
        links = plans[0].links
        if any(p.links != links for p in plans):
            raise BatchUnsupported("the runs' relays have different links")
        self.receivers = np.array([i for i, _ in links], dtype=np.int64)
        self.source = np.stack([p.source for p in plans])
        self.noise = np.stack([p.noise for p in plans])
        self.sent = np.empty((self.R, times.size))

    def step(self, k: int, t: float, states: Array, measured: Array, positions: Array,
             messages: Messages | None, reference: ReferencePreview) -> Array:
        """The forces of :meth:`SynchronousController.step` for every run, shape (R, n).

        Parameters
        ----------
        k : int
            The sample index.
        t : float
            Its time [s].
        states : ndarray
            The true states ``[v, delta, s]``, shape (R, 2n).
        measured : ndarray
            The measured speeds [m/s] (noise included), shape (R, n).
        positions : ndarray
            Each vehicle's position [m], shape (R, n).
        messages : Messages or None
            What the runs' links hold (None: no network).
        reference : ReferencePreview
            The reference preview at t.

        Returns
        -------
        ndarray
            The forces [N] to hold over [t, t + dt), shape (R, n).
        """
        law, n, R = self.law, self.law.n, self.R
        speeds = measured
        v_ref, a_ref = float(reference.speed[0]), float(reference.acceleration[0])
        if not np.isfinite(speeds).all():
            raise BatchUnsupported("a measured speed is not finite")
        line = (np.zeros((R, n)) if law.line is None
                else np.asarray(law.line.resistance_per_mass(positions), dtype=float))
        lead = law.lead
        command = a_ref - law.speed_gain * (speeds[:, lead] - v_ref) + line[:, lead]
        if not np.isfinite(command).all():
            raise BatchUnsupported("a command is not finite")
        self.sent[:, k] = command
        commands = np.full((R, n), math.nan)
        commands[:, lead] = command
        if self.receivers.size:
            src = self.source[:, k]
            has = src >= 0
            idx = np.where(has, src, 0)
            rows = np.arange(R)[:, None]
            cols = np.arange(src.shape[1])[None, :]
            held = self.sent[rows, idx] + self.noise[rows, idx, cols]
            for m, i in enumerate(self.receivers.tolist()):
                commands[:, i] = np.where(has[:, m], held[:, m], commands[:, i])
        waiting = np.isnan(commands)
        inputs = (law.mass * np.where(waiting, 0.0, commands)
                  + own_resistance_rows(law.mass, law.davis, speeds))
        return clip_rows(self.envelopes, inputs, speeds)
