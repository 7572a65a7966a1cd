# A reference speed profile planned along a line: cruise, speed limits, braking curves.
"""A reference that respects a line's speed limits, planned along the track.

:func:`limited_breakpoints` plans the reference speed of the head vehicle from a
start position to an end position: it runs at the cruise speed where the
line allows it, brakes at a constant deceleration b so that it reaches each
lower limit by the limit's start, and accelerates at a constant a only once
the whole train (its head and its tail, ``train.length`` behind) has left a
restriction. The ceiling for the head at position s is therefore
min(cruise, the lowest limit over [s - length, s]); the profile is the
fastest one under it with |dv/dt| <= a and b (the classic forward-backward
pass over the ceiling's steps). Every phase has a constant acceleration, so
the result is exactly piecewise linear in time: breakpoints of times and
speeds (:func:`trainctl.sim.planner.limited_profile` makes them a
:class:`~trainctl.sim.reference.SpeedProfile`; a scenario's
``[simulation.plan]`` its reference).

The deceleration must be one the train's brakes give at every speed of the
plan on the steepest down-grade of the stretch:
:func:`braking_deceleration` (the envelopes' braking force over the mass, at
common speeds) minus g·i/1000 of that grade (TB/T's grade resistance), so a
braking curve of the plan is one the train can follow. The default is 90 % of
that (``margin``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_finite, check_positive
from trainctl.exceptions import ModelError
from trainctl.models.track import Track
from trainctl.models.train import Train
from trainctl.units import GRAVITY

__all__ = ["braking_deceleration", "limited_breakpoints"]


def braking_deceleration(train: Train, speeds: ArrayLike) -> NDArray[np.float64]:
    """The train's deceleration by its brakes alone at common speeds [m/s²].

    Parameters
    ----------
    train : Train
        The train (each vehicle's braking envelope and mass).
    speeds : array_like
        Common speeds of every vehicle [m/s].

    Returns
    -------
    ndarray
        Σ braking force limit / Σ mass [m/s²] at each speed (no resistance,
        no grade), the shape of ``speeds``.

    Examples
    --------
    >>> from trainctl.models import crh2_half
    >>> braking_deceleration(crh2_half(), [10.0, 80.0]).round(3).tolist()
    [0.892, 0.613]
    """
    v = np.asarray(speeds, dtype=float)
    force = sum(veh.envelope.braking_limit(v, mass=veh.mass) for veh in train.vehicles)
    decel: NDArray[np.float64] = np.asarray(force, dtype=float) / float(np.sum(train.mass))
    return decel


def _ceiling(track: Track, cruise: float, length: float, start: float,
             end: float) -> tuple[list[float], list[float]]:
    """Steps of the head's ceiling on [start, end]: (positions x_0..x_m [m], ceilings
    c_0..c_{m-1} [m/s]), c_i holding on [x_i, x_{i+1}), equal neighbours merged."""
    limits = track.speed_limits
    cuts = {start, end}
    for limit in limits:
        for p in (limit.start, limit.start + length):
            if start < p < end:
                cuts.add(p)
    xs = sorted(cuts)
    starts = np.array([limit.start for limit in limits])
    ceilings = []
    for a, b in zip(xs, xs[1:], strict=False):
        mid = 0.5 * (a + b)
        window = [mid - length, mid]
        inside = [p for p in starts if window[0] < p <= window[1]]
        speeds = track.speed_limit(np.array([window[0], *inside, window[1]]))
        ceilings.append(min(cruise, float(speeds.min())))
    positions, merged = [xs[0]], list[float]()
    for x, c in zip(xs[1:], ceilings, strict=True):
        if merged and merged[-1] == c:
            positions[-1] = x
        else:
            merged.append(c)
            positions.append(x)
    return positions, merged


def limited_breakpoints(track: Track, train: Train, *, cruise: float, acceleration: float,
                        end: float, deceleration: float | None = None,
                        start_speed: float | None = None, start: float = 0.0,
                        margin: float = 0.9) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The fastest reference under the line's speed limits (module docstring).

    Parameters
    ----------
    track : Track
        The line: its speed limits (:attr:`Track.speed_limits`) and grades.
    train : Train
        The train: its spacings (the tail clears a restriction before the
        train accelerates) and its braking envelopes.
    cruise : float
        Speed wanted wherever the limits allow it [m/s], > 0.
    acceleration : float
        Acceleration of the plan [m/s²], > 0.
    end : float
        Head position where the plan ends [m], > ``start``; the reference
        holds its last speed after it.
    deceleration : float or None
        Deceleration of the braking curves [m/s²], > 0 and at most the
        train's brakes on the steepest down-grade (module docstring); None:
        ``margin`` times that.
    start_speed : float or None
        Speed at ``start`` [m/s], >= 0 and within the ceiling there; None:
        the cruise speed or the ceiling, the lower.
    start : float
        Head position at t = 0 [m].
    margin : float
        Share of the brakes' deceleration the default uses, in (0, 1].

    Returns
    -------
    (tuple of float, tuple of float)
        Breakpoint times [s] (t = 0 at ``start``) and speeds [m/s]; linear
        between them.

    Raises
    ------
    ModelError
        For a bad argument, a start above the ceiling or too fast to brake
        for the next limit, or a deceleration the brakes cannot give.

    Examples
    --------
    A 40 km/h restriction from 3 km to 3.5 km on a 10 km line, for a 200 m train
    cruising at 25 m/s, braking at 0.5 m/s² and accelerating at 0.3 m/s²:

    >>> from trainctl.models import crh2_half
    >>> from trainctl.models.track import SpeedLimit, Track
    >>> track = Track(speed_limits=(SpeedLimit(start=0.0, limit=40.0),
    ...                             SpeedLimit(start=3000.0, limit=40.0 / 3.6),
    ...                             SpeedLimit(start=3500.0, limit=40.0)))
    >>> times, speeds = limited_breakpoints(track, crh2_half(), cruise=25.0, acceleration=0.3,
    ...                                     deceleration=0.5, end=10_000.0)
    >>> [round(v, 2) for v in speeds]  # cruise, brake, hold the limit, accelerate, cruise
    [25.0, 25.0, 11.11, 11.11, 25.0, 25.0]
    """
    where = "limited_breakpoints"
    cruise = check_positive(where, "cruise", cruise)
    a = check_positive(where, "acceleration", acceleration)
    start, end = check_finite(where, "start", start), check_finite(where, "end", end)
    if not end > start:
        raise ModelError(f"{where}: 'end' must be beyond 'start' = {start!r} m (got {end!r}).")
    if not 0.0 < margin <= 1.0:
        raise ModelError(f"{where}: 'margin' must be in (0, 1] (got {margin!r}).")
    length = float(np.sum(train.spacing))
    xs, cs = _ceiling(track, cruise, length, start, end)
    b = _deceleration(track, train, cruise, xs, deceleration, margin)
    first = cs[0]
    v0 = min(cruise, first) if start_speed is None else check_finite(where, "start_speed",
                                                                      start_speed)
    if not 0.0 <= v0 <= first * (1 + 1e-12):
        raise ModelError(f"{where}: 'start_speed' must be from 0 to the ceiling "
                         f"{first:.6g} m/s at the start (got {v0!r}). The train starts under "
                         "the lowest limit over its length, and at most at the cruise speed.")
    m = len(cs)
    u = [v0] + [min(cs[i - 1], cs[i]) for i in range(1, m)] + [cs[-1]]
    for i in range(m - 1, -1, -1):  # backward: brake into every lower step in time
        u[i] = min(u[i], math.sqrt(u[i + 1] ** 2 + 2 * b * (xs[i + 1] - xs[i])))
    if u[0] < v0 * (1 - 1e-12):
        raise ModelError(f"{where}: from {v0:.6g} m/s at {start:g} m the train cannot brake at "
                         f"{b:.6g} m/s² to the next limit in time (it could start at "
                         f"{u[0]:.6g} m/s). Start slower or farther from the restriction.")
    u[0] = v0
    for i in range(m):  # forward: accelerate at most at a
        u[i + 1] = min(u[i + 1], math.sqrt(u[i] ** 2 + 2 * a * (xs[i + 1] - xs[i])))
    times, speeds = [0.0], [v0]

    def phase(v_end: float, duration: float) -> None:
        if duration > 0.0:
            times.append(times[-1] + duration)
            speeds.append(v_end)

    for i in range(m):
        v1, v2, c, length = u[i], u[i + 1], cs[i], xs[i + 1] - xs[i]
        s_up = (c * c - v1 * v1) / (2 * a)      # to reach the ceiling
        s_down = (c * c - v2 * v2) / (2 * b)    # to brake from it to the next boundary
        if s_up + s_down <= length:
            phase(c, (c - v1) / a)
            phase(c, (length - s_up - s_down) / c)
            phase(v2, (c - v2) / b)
        else:  # no cruise: accelerate to the peak, brake from it
            peak = math.sqrt(max((2 * a * b * length + b * v1 * v1 + a * v2 * v2) / (a + b),
                                 0.0))
            phase(peak, (peak - v1) / a)
            phase(v2, (peak - v2) / b)
    return tuple(times), tuple(speeds)


def _deceleration(track: Track, train: Train, cruise: float, xs: list[float],
                  deceleration: float | None, margin: float) -> float:
    """The braking curves' deceleration [m/s²]: given (checked) or ``margin`` of the
    brakes' on the steepest down-grade of [xs[0], xs[-1]]."""
    sections = track.sections
    grades = [s.grade_permille for i, s in enumerate(sections)
              if (i + 1 == len(sections)
                  or sections[i + 1].start > xs[0] - float(np.sum(train.spacing)))
              and s.start < xs[-1]]
    down = max(0.0, -min(grades, default=0.0)) * GRAVITY / 1000.0
    brakes = float(braking_deceleration(train, np.linspace(0.0, cruise, 65)).min())
    available = brakes - down
    if available <= 0.0:
        raise ModelError(
            f"limited_breakpoints: the train's brakes ({brakes:.4g} m/s² at their weakest up to "
            f"{cruise:.6g} m/s) cannot hold it on the {down * 1000 / GRAVITY:.4g} ‰ down-grade "
            "of the stretch: no braking curve is safe.")
    if deceleration is None:
        return margin * available
    b = check_positive("limited_breakpoints", "deceleration", deceleration)
    if b > available * (1 + 1e-12):
        raise ModelError(
            f"limited_breakpoints: 'deceleration' must be at most {available:.6g} m/s², what the "
            f"brakes give at their weakest up to {cruise:.6g} m/s on the stretch's steepest "
            f"down-grade (got {b!r}). Brake more gently, or leave it out for "
            f"{margin:g} of that.")
    return b
