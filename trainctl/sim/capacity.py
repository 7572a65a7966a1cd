# Line capacity: braking distances, headways and throughput of trains on one track.
"""How many trains, and how many tonnes, a line passes per hour (SI units throughout).

Trains of length L at speed v, L + gap apart head to head, pass a point every
(L + gap) / v seconds. The gap is a given one (:func:`uniform_capacity`), the
absolute braking distance of moving block, where the follower stops behind
where its leader's tail is (:func:`absolute_braking_capacity`), or the
relative braking distance of virtual coupling, where it stops behind its
leader braking at its strongest (:func:`relative_braking_capacity`).
:func:`passing_times` and :func:`headways_at` read headways off a simulated
formation. The braking kinematics (:func:`braking_distance`,
:func:`relative_braking_distance`) live in :mod:`trainctl.models.braking`,
below the controllers that supervise with them, and are importable from here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_finite, check_nonnegative, check_positive
from trainctl.exceptions import ModelError
from trainctl.models.braking import _relative, braking_distance, relative_braking_distance
from trainctl.units import kg_per_s_to_t_per_h

__all__ = ["LineCapacity", "absolute_braking_capacity", "braking_distance", "headways_at",
           "passing_times", "relative_braking_capacity", "relative_braking_distance",
           "uniform_capacity"]

Array = NDArray[np.float64]

SECONDS_PER_HOUR = 3600.0


@dataclass(frozen=True, kw_only=True)
class LineCapacity:
    """Trains at one speed and one spacing: headway and throughput.

    Parameters
    ----------
    speed : float
        Speed of every train [m/s].
    distance_headway : float
        Head to head: train length plus gap [m].
    headway : float
        Between successive heads at a point, ``distance_headway`` / ``speed`` [s].
    trains_per_hour : float
        3600 / ``headway`` [1/h].
    mass_per_train : float
        Mass of one train [kg].
    throughput : float
        Mass passing a point, ``mass_per_train`` / ``headway`` [kg/s].

    Examples
    --------
    >>> capacity = uniform_capacity(1000.0, 200.0, 20.0, 5.0e6)
    >>> capacity.headway, capacity.trains_per_hour, capacity.tonnes_per_hour
    (60.0, 60.0, 300000.0)
    """

    speed: float
    distance_headway: float
    headway: float
    trains_per_hour: float
    mass_per_train: float
    throughput: float

    @property
    def tonnes_per_hour(self) -> float:
        """The throughput in tonnes per hour [t/h]."""
        return kg_per_s_to_t_per_h(self.throughput)


def _train(where: str, train_length: float, speed: float,
           mass_per_train: float) -> tuple[float, float, float]:
    return (check_positive(where, "train_length", train_length),
            check_positive(where, "speed", speed),
            check_positive(where, "mass_per_train", mass_per_train))


def _capacity(speed: float, distance_headway: float, mass: float) -> LineCapacity:
    headway = distance_headway / speed
    return LineCapacity(speed=speed, distance_headway=distance_headway, headway=headway,
                        trains_per_hour=SECONDS_PER_HOUR / headway, mass_per_train=mass,
                        throughput=mass / headway)


def uniform_capacity(train_length: float, gap: float, speed: float,
                     mass_per_train: float) -> LineCapacity:
    """Trains a given gap apart: distance headway = ``train_length`` + ``gap``.

    Parameters
    ----------
    train_length : float
        Length of one train [m], > 0.
    gap : float
        From a train's tail to the next one's head [m], >= 0.
    speed : float
        Speed of every train [m/s], > 0.
    mass_per_train : float
        Mass of one train [kg], > 0.

    Returns
    -------
    LineCapacity
        Headway and throughput.

    Examples
    --------
    >>> uniform_capacity(1300.0, 490.0, 20.0, 1.0e7).headway  # 1790 m / 20 m/s
    89.5
    """
    where = "uniform_capacity"
    length, v, mass = _train(where, train_length, speed, mass_per_train)
    space = check_nonnegative(where, "gap", gap)
    return _capacity(v, length + space, mass)


def absolute_braking_capacity(train_length: float, speed: float, deceleration: float,
                              mass_per_train: float, *, reaction_time: float = 0.0,
                              margin: float = 0.0) -> LineCapacity:
    """Trains an absolute braking distance apart (moving block): gap = :func:`braking_distance`.

    Parameters
    ----------
    train_length : float
        Length of one train [m], > 0.
    speed : float
        Speed of every train [m/s], > 0.
    deceleration : float
        The follower's braking deceleration [m/s²], > 0.
    mass_per_train : float
        Mass of one train [kg], > 0.
    reaction_time : float
        Time at full speed before the brakes act [s], >= 0.
    margin : float
        Distance kept behind the stopping point [m], >= 0.

    Returns
    -------
    LineCapacity
        Headway and throughput.

    Examples
    --------
    >>> absolute_braking_capacity(1300.0, 20.0, 0.5, 1.0e7, reaction_time=2.0,
    ...                           margin=50.0).headway  # (1300 + 490) / 20
    89.5
    """
    where = "absolute_braking_capacity"
    length, v, mass = _train(where, train_length, speed, mass_per_train)
    gap = braking_distance(v, check_positive(where, "deceleration", deceleration),
                           reaction_time=check_nonnegative(where, "reaction_time",
                                                           reaction_time),
                           margin=check_nonnegative(where, "margin", margin))
    return _capacity(v, length + gap, mass)


def relative_braking_capacity(train_length: float, speed: float, *,
                              follower_deceleration: float, leader_deceleration: float,
                              delay: float, mass_per_train: float,
                              margin: float = 0.0) -> LineCapacity:
    """Trains at equal speeds a :func:`relative_braking_distance` apart (virtual coupling).

    Parameters
    ----------
    train_length : float
        Length of one train [m], > 0.
    speed : float
        Speed of every train [m/s], > 0.
    follower_deceleration, leader_deceleration : float
        The follower's braking deceleration and the leader's strongest [m/s²], > 0.
    delay : float
        Time before the follower brakes [s], >= 0.
    mass_per_train : float
        Mass of one train [kg], > 0.
    margin : float
        Least gap kept [m], >= 0.

    Returns
    -------
    LineCapacity
        Headway and throughput.

    Examples
    --------
    Equal brakes: the follower gains 20 m/s × 2 s during the delay, plus 50 m.

    >>> relative_braking_capacity(1300.0, 20.0, follower_deceleration=0.5,
    ...                           leader_deceleration=0.5, delay=2.0, mass_per_train=1.0e7,
    ...                           margin=50.0).headway  # (1300 + 90) / 20
    69.5
    """
    where = "relative_braking_capacity"
    length, v, mass = _train(where, train_length, speed, mass_per_train)
    gap = _relative(where, v, v, follower_deceleration, leader_deceleration, delay, margin)
    return _capacity(v, length + gap, mass)


def _passing(where: str, times: ArrayLike, head_positions: ArrayLike, point: float) -> Array:
    x = check_finite(where, "point", point)
    try:
        t, p = np.asarray(times, dtype=float), np.asarray(head_positions, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: 'times' and 'head_positions' must be numbers "
                         f"(got {times!r}, {head_positions!r}).") from None
    if t.ndim != 1 or t.size < 1:
        raise ModelError(f"{where}: 'times' must be a non-empty 1-D sequence "
                         f"(got shape {t.shape}).")
    bad = np.flatnonzero(~np.isfinite(t))
    if not bad.size:
        bad = np.flatnonzero(np.diff(t) <= 0.0) + 1
    if bad.size:
        raise ModelError(f"{where}: 'times' must be finite and strictly increasing "
                         f"(got {float(t[bad[0]])!r} at [{bad[0]}]).")
    if p.ndim != 2 or p.shape[1] != t.size:
        raise ModelError(f"{where}: 'head_positions' must have shape (units, {t.size}), one "
                         f"row per unit over 'times' (got {p.shape}).")
    if not np.all(np.isfinite(p)):
        index = [int(i) for i in np.argwhere(~np.isfinite(p))[0]]
        raise ModelError(f"{where}: 'head_positions' must be finite "
                         f"(got {float(p[tuple(index)])!r} at {index}).")
    reached = p >= x
    k = np.argmax(reached, axis=1)  # first sample at or past the point
    rows = np.arange(p.shape[0])
    before = np.maximum(k - 1, 0)
    p0, p1 = p[rows, before], p[rows, k]
    share = np.where(k > 0, (x - p0) / np.where(p1 > p0, p1 - p0, 1.0), 0.0)
    out: Array = t[before] + share * (t[k] - t[before])
    out[~reached.any(axis=1)] = np.nan
    return out


def passing_times(times: ArrayLike, head_positions: ArrayLike, point: float) -> Array:
    """When each unit's head first reaches ``point`` [s], linear between the two samples.

    Parameters
    ----------
    times, head_positions : array_like
        Sample instants [s], (m,) increasing; each unit's head then [m], (units, m).
    point : float
        Position on the line [m].

    Returns
    -------
    ndarray
        Passing times [s], shape (units,); NaN where a unit never reaches it.

    Examples
    --------
    >>> passing_times([0.0, 1.0, 2.0], [[0.0, 10.0, 20.0], [-10.0, 0.0, 10.0]], 5.0).tolist()
    [0.5, 1.5]
    """
    return _passing("passing_times", times, head_positions, point)


def headways_at(times: ArrayLike, head_positions: ArrayLike, point: float) -> Array:
    """Time headways between successive heads at ``point`` [s].

    Parameters
    ----------
    times, head_positions : array_like
        Sample instants [s], (m,) increasing; each unit's head then [m], (units, m).
    point : float
        Position on the line [m].

    Returns
    -------
    ndarray
        Differences of the sorted finite :func:`passing_times` [s].

    Examples
    --------
    >>> headways_at([0.0, 1.0, 2.0], [[0.0, 10.0, 20.0], [-10.0, 0.0, 10.0]], 5.0).tolist()
    [1.0]
    """
    passed = _passing("headways_at", times, head_positions, point)
    return np.diff(np.sort(passed[np.isfinite(passed)]))
