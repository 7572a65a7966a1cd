# Braking kinematics at constant decelerations: stopping, relative braking, dead reckoning.
"""How far trains run when they brake at constant decelerations (SI units throughout).

:func:`braking_distance` is the distance to a stop (the absolute braking
distance of moving block); :func:`relative_braking_distance` the least gap a
follower needs behind a leader that brakes at its strongest (virtual
coupling), by the exact closest approach of the two motions; :func:`braked`
the distance and speed of a train braking for a given time, which dead
reckons a leader's worst case from its last known state. The line-capacity
arithmetic (:mod:`trainctl.sim.capacity`) and the flocking family's braking
supervisor (:mod:`trainctl.controllers.flocking.supervisor`) share them.
"""

from __future__ import annotations

from typing import overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_nonnegative, check_positive
from trainctl.exceptions import ModelError

__all__ = ["braked", "braking_distance", "relative_braking_distance"]

Array = NDArray[np.float64]


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


def braked(speed: float, deceleration: float, elapsed: float) -> tuple[float, float]:
    """Distance run [m] and speed [m/s] after braking from ``speed`` for ``elapsed`` seconds.

    The train brakes at a constant ``deceleration`` until it stands, then
    stays.

    Parameters
    ----------
    speed : float
        Speed when the braking begins [m/s], >= 0.
    deceleration : float
        Braking deceleration [m/s²], > 0.
    elapsed : float
        Time since the braking began [s], >= 0.

    Returns
    -------
    (float, float)
        The distance run since the braking began [m] and the speed then [m/s].

    Raises
    ------
    ModelError
        If an argument is not finite or out of its range.

    Examples
    --------
    From 20 m/s at 0.5 m/s²: 10 s later 200 - 25 = 175 m on at 15 m/s; the
    stop takes 40 s, so after 60 s the train stands 400 m on:

    >>> braked(20.0, 0.5, 10.0), braked(20.0, 0.5, 60.0)
    ((175.0, 15.0), (400.0, 0.0))
    """
    where = "braked"
    v = check_nonnegative(where, "speed", speed)
    b = check_positive(where, "deceleration", deceleration)
    stop = v / b
    e = min(check_nonnegative(where, "elapsed", elapsed), stop)
    return v * e - 0.5 * b * e * e, (v - b * e) if e < stop else 0.0


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
    """:func:`relative_braking_distance`, its errors naming ``where``."""
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
