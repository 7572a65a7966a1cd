# Line capacity: braking distances, headways and throughput of trains on one track.
"""How many trains, and how many tonnes, a line passes per hour (SI units throughout).

Trains of length L at speed v, L + gap apart head to head, pass a point every
(L + gap) / v seconds. The gap is a given one (:func:`uniform_capacity`), the
absolute braking distance of moving block, where the follower stops behind
where its leader's tail is (:func:`absolute_braking_capacity`), or the
relative braking distance of virtual coupling, where it stops behind its
leader braking at its strongest (:func:`relative_braking_capacity`).
:func:`passing_times` and :func:`headways_at` read headways off a simulated
formation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_finite, check_nonnegative, check_positive
from trainctl.exceptions import ModelError
from trainctl.units import kg_per_s_to_t_per_h

__all__ = ["LineCapacity", "absolute_braking_capacity", "braking_distance", "headways_at",
           "passing_times", "relative_braking_capacity", "relative_braking_distance",
           "uniform_capacity"]

Array = NDArray[np.float64]

SECONDS_PER_HOUR = 3600.0


def _checked(where: str, name: str, value: ArrayLike, *, positive: bool) -> Array:
    """``value`` as a float array, or ModelError unless every entry is finite and > 0
    (``positive``) or >= 0."""
    if np.ndim(value) == 0:
        check = check_positive if positive else check_nonnegative
        return np.asarray(check(where, name, value))  # type: ignore[arg-type]
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: {name!r} must be numbers (got {value!r}).") from None
    bad = ~np.isfinite(arr) | ((arr <= 0.0) if positive else (arr < 0.0))
    if np.any(bad):
        index = [int(i) for i in np.argwhere(bad)[0]]
        rule = "> 0" if positive else ">= 0"
        raise ModelError(f"{where}: {name!r} must be finite and {rule} "
                         f"(got {float(arr[tuple(index)])!r} at {index}).")
    return arr


@overload
def braking_distance(speed: float, deceleration: float, *, reaction_time: float = 0.0,
                     margin: float = 0.0) -> float: ...
@overload
def braking_distance(speed: ArrayLike, deceleration: ArrayLike, *,
                     reaction_time: ArrayLike = 0.0, margin: ArrayLike = 0.0) -> Array: ...
def braking_distance(speed: ArrayLike, deceleration: ArrayLike, *,
                     reaction_time: ArrayLike = 0.0, margin: ArrayLike = 0.0) -> float | Array:
    """Distance to a stop, v·t_r + v²/(2b) + margin [m], broadcast over arrays.

    Parameters
    ----------
    speed, deceleration : float or array_like
        Speed when braking is asked for [m/s], >= 0; deceleration to the stop [m/s²], > 0.
    reaction_time, margin : float or array_like
        Time at full speed before the brakes act [s] and distance added [m], >= 0.

    Returns
    -------
    float or ndarray
        The distance [m]: a float for scalars.

    Examples
    --------
    >>> braking_distance(20.0, 0.5, reaction_time=2.0, margin=50.0)  # 40 + 400 + 50
    490.0
    >>> braking_distance([10.0, 20.0], 0.5).tolist()
    [100.0, 400.0]
    """
    where = "braking_distance"
    v = _checked(where, "speed", speed, positive=False)
    b = _checked(where, "deceleration", deceleration, positive=True)
    tr = _checked(where, "reaction_time", reaction_time, positive=False)
    extra = _checked(where, "margin", margin, positive=False)
    try:
        distance: Array = v * tr + v * v / (2.0 * b) + extra
    except ValueError:
        raise ModelError(f"{where}: 'speed', 'deceleration', 'reaction_time' and 'margin' must "
                         f"broadcast together (got shapes {v.shape}, {b.shape}, {tr.shape}, "
                         f"{extra.shape}).") from None
    return float(distance) if distance.ndim == 0 else distance


def _travelled(speed: float, deceleration: float, delay: float, t: float) -> float:
    """Distance [m] run by time ``t`` [s] at ``speed`` for ``delay``, then braking to a stop."""
    u = min(max(t - delay, 0.0), speed / deceleration)
    return speed * min(t, delay) + speed * u - 0.5 * deceleration * u * u


def _speed(speed: float, deceleration: float, delay: float, t: float) -> float:
    """Speed [m/s] at ``t`` [s] of the same motion."""
    return max(speed - deceleration * max(t - delay, 0.0), 0.0)


def relative_braking_distance(follower_speed: float, leader_speed: float, *,
                              follower_deceleration: float, leader_deceleration: float,
                              delay: float = 0.0, margin: float = 0.0) -> float:
    """The least gap from the follower's head to the leader's tail when both brake [m].

    At t = 0 the leader brakes to a stop; the follower runs on for ``delay``,
    then brakes to a stop. The result is ``margin`` + the maximum over t >= 0
    of what the follower gains, D(t) = x_f(t) - x_l(t) (piecewise quadratic:
    exact, at a stop, the delay's end or equal speeds). The standstill value
    v_f·τ + v_f²/(2b_f) - v_l²/(2b_l) is too small when a faster follower has
    stronger brakes: the closest approach then comes earlier.

    Parameters
    ----------
    follower_speed, leader_speed : float
        Speeds at t = 0 [m/s], >= 0.
    follower_deceleration, leader_deceleration : float
        Braking decelerations held to a stop [m/s²], > 0 (the leader's: the
        strongest it can brake).
    delay : float
        Time before the follower brakes [s], >= 0.
    margin : float
        Least gap kept [m], >= 0.

    Returns
    -------
    float
        The initial gap [m], >= ``margin``.

    Examples
    --------
    At 20 m/s braking at 1 m/s² behind 15 m/s at 0.5 m/s², the speeds are equal
    at t = 10 s, the follower 25 m closer (at the standstill 25 m farther):

    >>> relative_braking_distance(20.0, 15.0, follower_deceleration=1.0,
    ...                           leader_deceleration=0.5)
    25.0
    """
    return _relative("relative_braking_distance", follower_speed, leader_speed,
                     follower_deceleration, leader_deceleration, delay, margin)


def _relative(where: str, follower_speed: float, leader_speed: float,
              follower_deceleration: float, leader_deceleration: float, delay: float,
              margin: float) -> float:
    vf = check_nonnegative(where, "follower_speed", follower_speed)
    vl = check_nonnegative(where, "leader_speed", leader_speed)
    bf = check_positive(where, "follower_deceleration", follower_deceleration)
    bl = check_positive(where, "leader_deceleration", leader_deceleration)
    tau = check_nonnegative(where, "delay", delay)
    extra = check_nonnegative(where, "margin", margin)

    def gained(t: float) -> float:
        return _travelled(vf, bf, tau, t) - _travelled(vl, bl, 0.0, t)

    def closing(t: float) -> float:
        return _speed(vf, bf, tau, t) - _speed(vl, bl, 0.0, t)

    # Both speeds are linear between these instants, and both trains stand after the last.
    breaks = sorted({0.0, tau, tau + vf / bf, vl / bl})
    candidates = list(breaks)
    for a, b in zip(breaks, breaks[1:], strict=False):
        sa, sb = closing(a), closing(b)
        if sa > 0.0 > sb:  # D' falls through zero: a local maximum of D
            candidates.append(a + (b - a) * sa / (sa - sb))
    return extra + max(0.0, *(gained(t) for t in candidates))


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
