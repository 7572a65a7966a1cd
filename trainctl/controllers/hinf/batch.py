# The hinf controller's law over many runs at once (trainctl.sim.batch).
"""R runs of :class:`~trainctl.controllers.hinf.controller.HinfController` on (R, n)
arrays, each bit for bit its serial :meth:`~HinfController.step` (the same
elementwise operations, the consensus sum along the same contiguous axis)."""

from __future__ import annotations

import math
import pickle
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import ReferencePreview
from trainctl.controllers.batch import (
    BatchUnsupported,
    Messages,
    clip_rows,
    own_resistance_rows,
)
from trainctl.models.network import ARRIVAL_TOLERANCE, REFERENCE

if TYPE_CHECKING:
    from trainctl.controllers.hinf.controller import HinfController

__all__ = ["HinfBatch"]

Array = NDArray[np.float64]
IntArray = NDArray[np.intp]
_Used = tuple[tuple[IntArray, IntArray], tuple[IntArray, IntArray, IntArray]]


class HinfBatch:
    """The law of R hinf controllers with the same settings (one per run).

    Parameters
    ----------
    controllers : sequence of HinfController
        One per run, with equal laws, control intervals and envelope settings
        (else :class:`~trainctl.controllers.batch.BatchUnsupported`).

    Examples
    --------
    Two runs at 19.5 m/s over an ideal network (no messages) get the
    feedforward of the cruise, as :meth:`HinfController.step` gives it:

    >>> from trainctl.controllers.base import Measurement, ReferencePreview
    >>> from trainctl.controllers.hinf.controller import HinfController
    >>> from trainctl.controllers.hinf.law import law_of
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> ctl = HinfController(scenario.train, law_of(scenario, HinfSettings()), dt=0.1)
    >>> batch = HinfBatch([ctl, ctl])
    >>> batch.start(np.zeros(1))
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 19.5),
    ...                        acceleration=np.zeros(1))
    >>> v = np.full((2, 4), 19.5)
    >>> u = batch.step(0, 0.0, np.zeros((2, 8)), v, np.zeros((2, 4)), None, ref)
    >>> ctl.reset()
    >>> serial = ctl.step(0.0, Measurement(outputs=v[0], positions=np.zeros(4)), ref).inputs
    >>> bool(np.array_equal(u[0], serial) and np.array_equal(u[1], serial))
    True
    """

    def __init__(self, controllers: Sequence[HinfController]) -> None:
        first = controllers[0]
        key = pickle.dumps((first.law, first.dt, first.input_bounds))
        if any(pickle.dumps((c.law, c.dt, c.input_bounds)) != key for c in controllers[1:]):
            raise BatchUnsupported("the runs' hinf laws differ")
        self.law, self.R = first.law, len(controllers)
        self.envelopes = first._envelope.envelopes if first.input_bounds else None
        if first.input_bounds and self.envelopes is None:
            raise BatchUnsupported("the train has envelopes of another kind")
        self.times = np.zeros(0)
        self.history = np.zeros((0, 0, 0))
        self._links: dict[tuple[tuple[int, Any], ...], _Used] = {}

    def start(self, times: Array) -> None:
        """Forget the record of own speeds (:meth:`HinfController.reset`).

        Parameters
        ----------
        times : ndarray
            The sample times [s], shape (K,).
        """
        self.times = np.asarray(times, dtype=float)
        if self.law.own_speed == "delayed":
            self.history = np.empty((self.R, self.times.size, self.law.n))

    def step(self, k: int, t: float, states: Array, measured: Array, positions: Array,
             messages: Messages | None, reference: ReferencePreview) -> Array:
        """The forces of :meth:`HinfController.step` for every run, shape (R, n).

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
        law, n = self.law, self.law.n
        speeds = measured
        v_ref, a_ref = float(reference.speed[0]), float(reference.acceleration[0])
        if not np.isfinite(speeds).all():
            raise BatchUnsupported("a measured speed is not finite")
        if self.history.size:
            self.history[:, k] = speeds
        R = speeds.shape[0]
        if messages is None:
            e0 = speeds - float(reference.speed[0])
            e = speeds[:, :, None] - speeds[:, None, :]
        else:
            ref, pairs = self._used(messages.links)
            e0 = np.full((R, n), math.nan)
            e = np.full((R, n, n), math.nan)
            for pinned, (m, receivers) in ((True, ref), (False, pairs[:2])):
                if not m.size:
                    continue
                value = messages.values[:, m]
                if law.own_speed == "delayed":
                    own = self._own_speed(k, receivers, messages.t_sent[:, m])
                else:
                    own = speeds[:, receivers]
                diff = np.where(np.isnan(value), math.nan, own - value)
                if pinned:
                    e0[:, receivers] = diff
                else:
                    e[:, receivers, pairs[2]] = diff
        pin_weights, weights = law._weights
        pin = np.where((pin_weights > 0) & ~np.isnan(e0), pin_weights * e0, 0.0)
        consensus = np.sum(np.where((weights > 0) & ~np.isnan(e), weights * e, 0.0), axis=2)
        commands = float(a_ref) - law.kappa_p * pin - law.kappa_c * consensus
        if not np.isfinite(commands).all():
            raise BatchUnsupported("a command is not finite")
        line = (np.zeros(n) if law.line is None
                else np.asarray(law.line.resistance_per_mass(positions), dtype=float))
        inputs = law.mass * (commands + line) + own_resistance_rows(law.mass, law.davis, speeds)
        del v_ref
        return clip_rows(self.envelopes, inputs, speeds)

    def _used(self, links: tuple[tuple[int, Any], ...]) -> _Used:
        """The links the law reads (:meth:`HinfController._errors` skips the others):
        (columns, receivers) of the reference's, (columns, receivers, senders) of the
        vehicles'."""
        cached: _Used | None = self._links.get(links)
        if cached is not None:
            return cached
        law, n = self.law, self.law.n
        ref: tuple[list[int], list[int]] = ([], [])
        pairs: tuple[list[int], list[int], list[int]] = ([], [], [])
        for m, (receiver, sender) in enumerate(links):
            i = int(receiver)
            if not 0 <= i < n:
                continue
            if sender == REFERENCE:
                if law.pinning[i] > 0:
                    ref[0].append(m)
                    ref[1].append(i)
                continue
            j = int(sender)
            if 0 <= j < n and law.adjacency[i, j] > 0:
                pairs[0].append(m)
                pairs[1].append(i)
                pairs[2].append(j)

        def index(values: list[int]) -> IntArray:
            return np.array(values, dtype=np.intp)

        out: _Used = ((index(ref[0]), index(ref[1])),
                      (index(pairs[0]), index(pairs[1]), index(pairs[2])))
        self._links[links] = out
        return out

    def _own_speed(self, k: int, receivers: IntArray, t_sent: Array) -> Array:
        """Each receiver's recorded measured speed at each run's ``t_sent`` (R, links)."""
        sent = np.where(np.isnan(t_sent), 0.0, t_sent)
        due = sent + ARRIVAL_TOLERANCE * np.maximum(1.0, np.abs(sent))
        index = np.maximum(np.searchsorted(self.times[: k + 1], due, side="right") - 1, 0)
        rows = np.arange(sent.shape[0])[:, None]
        own: Array = self.history[rows, index, receivers[None, :]]
        return own
