# What a controller offers to run many runs of its law at once (trainctl.sim.batch).
"""The interface of a controller's batched law (:func:`trainctl.sim.batch.simulate_batch`).

A controller class that can run R runs of its law on (R, n) arrays, each run
bit for bit as its serial :meth:`step` would, has a method
``batched(controllers) -> BatchLaw | None`` (None: not for these settings).
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import ReferencePreview

__all__ = ["BatchLaw", "BatchUnsupported", "Messages"]

Array = NDArray[np.float64]


class BatchUnsupported(Exception):
    """The batch cannot give these runs' serial results bit for bit: run them serially.

    Examples
    --------
    >>> str(BatchUnsupported("a run diverged"))
    'a run diverged'
    """


class Messages:
    """What every run's links hold at one sample (the batched ``Measurement.messages``).

    Parameters
    ----------
    links : tuple
        The (receiver, sender) links, the same for every run.
    values : ndarray
        Shape (R, L): the value each link holds, noise included (NaN: none yet).
    t_sent : ndarray
        Shape (R, L): when it was sent [s] (NaN: none).

    Examples
    --------
    Two runs, one link (vehicle 1 hears vehicle 0); the second run holds nothing yet:

    >>> m = Messages(((1, 0),), np.array([[15.0], [np.nan]]), np.array([[0.2], [np.nan]]))
    >>> m.values[:, 0].tolist()
    [15.0, nan]
    """

    def __init__(self, links: tuple[tuple[int, Any], ...], values: Array, t_sent: Array):
        self.links, self.values, self.t_sent = links, values, t_sent


class BatchLaw(Protocol):
    """A controller's law over R runs: one call per sample on (R, ...) arrays.

    Examples
    --------
    The hinf family's (:class:`trainctl.controllers.hinf.batch.HinfBatch`):

    >>> from trainctl.controllers.hinf.batch import HinfBatch
    >>> callable(HinfBatch.step), callable(HinfBatch.start)
    (True, True)
    """

    def start(self, times: Array) -> None:
        """Reset for runs whose samples are at ``times``.

        Parameters
        ----------
        times : ndarray
            The sample times [s], shape (K,).
        """
        ...

    def step(self, k: int, t: float, states: Array, measured: Array, positions: Array,
             messages: Messages | None, reference: ReferencePreview) -> Array:
        """The R runs' forces for sample k, as their serial steps give them.

        Raises :class:`BatchUnsupported` where a serial step would take a
        fault path.

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
        ...


def clip_rows(envelopes: tuple[Array, ...] | None, inputs: Array, speeds: Array) -> Array:
    """:meth:`~trainctl.models.envelope.EnvelopeBounds.clip`'s forces on every row (R, n).

    ``envelopes``: the bounds' ``envelopes`` (None: not enabled).
    """
    from trainctl.models.vehicle import envelope_limit

    if envelopes is None:
        return inputs
    force, power, adhesion, mass = envelopes
    limits = envelope_limit(speeds[None], force, power, adhesion, mass)
    clipped: Array = np.clip(inputs, -limits[0], limits[1])
    return clipped


def own_resistance_rows(mass: Array, davis: Array, speeds: Array) -> Array:
    """:func:`~trainctl.controllers.continuous.resistance.own_resistance` on every row."""
    a0, a1, a2 = davis
    out: Array = mass * (a0 + a1 * speeds + a2 * speeds * speeds)
    return out
