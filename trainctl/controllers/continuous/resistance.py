# Each vehicle's own resistance and the line under it: the feedforward of the speed-consensus laws.
"""The resistance feedforward shared by the synchronous and hinf laws.

Every vehicle estimates its own Davis resistance at its own measured speed
(:func:`own_resistance`) and, with the line feedforward, the grade and curve
resistance under itself (:func:`line_resistance`); the slope of the first
about the cruise (:func:`resistance_damping_per_vehicle`) enters their
linear closed loops. :func:`feedforward_fallback` is their controllers'
step on a fault: the feedforward of the reference within the envelope.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.controllers.base import StepRecord
from trainctl.controllers.faults import fault_record
from trainctl.exceptions import ModelError
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.track import Track

__all__ = ["ForceLaw", "feedforward_fallback", "line_resistance", "own_resistance",
           "resistance_damping_per_vehicle"]

Array = NDArray[np.float64]


class ForceLaw(Protocol):
    """A law whose ``forces(commands, speeds)`` [N] add each vehicle's own resistance.

    Examples
    --------
    >>> from trainctl.controllers.synchronous.law import SynchronousLaw
    >>> SynchronousLaw.forces.__name__
    'forces'
    """

    @property
    def n(self) -> int:
        """Number of vehicles."""
        ...

    def forces(self, commands: ArrayLike, speeds: ArrayLike) -> Array:
        """u_i = m_i a_i + R_i(v_i) [N] for the specific-force commands a_i [m/s²].

        Parameters
        ----------
        commands : array_like
            The commands a_i [m/s²], shape (n,).
        speeds : array_like
            The speeds v_i [m/s] of the resistances, shape (n,).

        Returns
        -------
        ndarray
            The forces [N], shape (n,).
        """
        ...


def own_resistance(mass: Array, davis: Array, speeds: ArrayLike) -> Array:
    """R_i(v_i) = m_i (a0_i + a1_i v_i + a2_i v_i²) [N]: each vehicle's Davis resistance.

    Parameters
    ----------
    mass : ndarray
        Masses m_i [kg], shape (n,).
    davis : ndarray
        Davis coefficients per unit mass [m/s², 1/s, 1/m], shape (3, n).
    speeds : array_like
        Speeds v_i [m/s], shape (n,).

    Returns
    -------
    ndarray
        The resistances R_i [N], shape (n,).

    Examples
    --------
    >>> own_resistance(np.array([2.0]), np.array([[1.0], [0.1], [0.01]]), [10.0]).tolist()
    [6.0]
    """
    v = np.asarray(speeds, dtype=float)
    a0, a1, a2 = davis
    return np.asarray(mass * (a0 + a1 * v + a2 * v * v), dtype=float)


def line_resistance(line: Track | None, positions: ArrayLike | None, n: int) -> Array:
    """r(p_i) [m/s²], shape (n,): the grade and curve resistance per unit mass at each position.

    The plant's own line model
    (:meth:`trainctl.models.track.Track.resistance_per_mass`), evaluated at
    the measured vehicle positions: the line feedforward of the synchronous
    and hinf laws. Zeros when there is no line to feed forward (``line``
    None: flat track, or ``line_feedforward = false``) or no positions
    (a measurement without them).

    Parameters
    ----------
    line : Track or None
        The line.
    positions : array_like or None
        Each vehicle's position along the line [m], shape (n,).
    n : int
        Number of vehicles.

    Returns
    -------
    ndarray
        Negative on down-grades.

    Examples
    --------
    >>> from trainctl.models.track import Track, TrackSection
    >>> line = Track(sections=(TrackSection(start=0.0),
    ...                        TrackSection(start=100.0, grade_permille=-12.0)))
    >>> line_resistance(line, [150.0, 50.0], 2).round(4).tolist()
    [-0.1177, 0.0]
    >>> line_resistance(None, [150.0, 50.0], 2).tolist()
    [0.0, 0.0]
    """
    if line is None or positions is None:
        return np.zeros(n)
    p = np.asarray(positions, dtype=float)
    if p.shape != (n,):
        raise ModelError(f"line_resistance: expected {n} positions (got shape {p.shape}).")
    return np.asarray(line.resistance_per_mass(p), dtype=float)


def resistance_damping_per_vehicle(davis: Array, speed: float) -> Array:
    """c_i = a1_i + 2 a2_i v [1/s]: the slope of the Davis resistance per unit mass.

    Parameters
    ----------
    davis : ndarray
        Davis coefficients per unit mass [m/s², 1/s, 1/m], shape (3, n).
    speed : float
        The linearisation speed v [m/s].

    Returns
    -------
    ndarray
        The slopes c_i [1/s], shape (n,).

    Examples
    --------
    >>> resistance_damping_per_vehicle(np.array([[1.0], [0.01], [0.001]]), 10.0).tolist()
    [0.03]
    """
    return np.asarray(davis[1] + 2.0 * davis[2] * float(speed), dtype=float)


def feedforward_fallback(law: ForceLaw, envelope: EnvelopeBounds, v_ref: float, a_ref: float,
                         speeds: Array, reason: str, start: float) -> StepRecord:
    """A faulty step's record: m a_ref + R(v_ref) [N] within the envelope at ``speeds``.

    Parameters
    ----------
    law : ForceLaw
        The law (its ``forces``).
    envelope : EnvelopeBounds
        The controller's envelope.
    v_ref, a_ref : float
        The reference speed [m/s] (negative taken as 0) and acceleration [m/s²].
    speeds : ndarray
        The speeds [m/s] of the envelope, shape (n,).
    reason : str
        What went wrong.
    start : float
        The step's start (``time.perf_counter()``) [s].

    Returns
    -------
    StepRecord
        Status ``"error"``, fallback ``"feedforward"``, ``info["reason"]``.

    Examples
    --------
    >>> from trainctl.controllers.synchronous.law import law_of
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> law = law_of(scenario, SynchronousSettings())
    >>> envelope = EnvelopeBounds(scenario.train, enabled=True)
    >>> rec = feedforward_fallback(law, envelope, 19.5, 0.0, np.full(4, 19.5), "a fault", 0.0)
    >>> rec.status, rec.fallback, rec.info["reason"]
    ('error', 'feedforward', 'a fault')
    """
    n = law.n
    feedforward = law.forces(np.full(n, a_ref), np.full(n, max(v_ref, 0.0)))
    inputs, _ = envelope.clip(np.asarray(feedforward, dtype=float), speeds)
    return fault_record(inputs, reason=reason, fallback="feedforward", start=start)
