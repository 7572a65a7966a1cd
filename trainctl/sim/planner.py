# The planned reference as a SpeedProfile (the planning itself: trainctl.models.planner).
"""A reference speed profile that respects a line's speed limits.

:func:`limited_profile` is :func:`trainctl.models.planner.limited_breakpoints`
(the plan, its rules and its checks) as a :class:`~trainctl.sim.reference.SpeedProfile`.
"""

from __future__ import annotations

from trainctl.models.planner import braking_deceleration, limited_breakpoints
from trainctl.models.track import Track
from trainctl.models.train import Train
from trainctl.sim.reference import SpeedProfile

__all__ = ["braking_deceleration", "limited_profile"]


def limited_profile(track: Track, train: Train, *, cruise: float, acceleration: float,
                    end: float, deceleration: float | None = None,
                    start_speed: float | None = None, start: float = 0.0,
                    margin: float = 0.9) -> SpeedProfile:
    """The fastest reference under the line's speed limits, as a SpeedProfile.

    The plan, its rules and its errors are
    :func:`~trainctl.models.planner.limited_breakpoints`'s.

    Parameters
    ----------
    track, train : Track, Train
        The line (speed limits, grades) and the train (length, brakes).
    cruise, acceleration : float
        Speed wanted [m/s] and the plan's acceleration [m/s²], > 0.
    end : float
        Head position where the plan stops [m], > ``start``.
    deceleration : float or None
        Braking curves' deceleration [m/s²]; None: ``margin`` × the brakes'.
    start_speed : float or None
        Speed at ``start`` [m/s]; None: the cruise speed or the ceiling there.
    start : float
        Head position at t = 0 [m].
    margin : float
        Share of the brakes' deceleration the default uses, in (0, 1].

    Returns
    -------
    SpeedProfile
        Piecewise linear in time [s] through the plan's speeds [m/s].

    Examples
    --------
    A 40 km/h restriction from 3 km to 3.5 km on a 10 km line, for a 200 m train
    cruising at 25 m/s, braking at 0.5 m/s² and accelerating at 0.3 m/s²:

    >>> from trainctl.models import crh2_half
    >>> from trainctl.models.track import SpeedLimit, Track
    >>> track = Track(speed_limits=(SpeedLimit(start=0.0, limit=40.0),
    ...                             SpeedLimit(start=3000.0, limit=40.0 / 3.6),
    ...                             SpeedLimit(start=3500.0, limit=40.0)))
    >>> profile = limited_profile(track, crh2_half(), cruise=25.0, acceleration=0.3,
    ...                           deceleration=0.5, end=10_000.0)
    >>> [round(v, 2) for v in profile.speeds]
    [25.0, 25.0, 11.11, 11.11, 25.0, 25.0]
    """
    times, speeds = limited_breakpoints(track, train, cruise=cruise, acceleration=acceleration,
                                        end=end, deceleration=deceleration,
                                        start_speed=start_speed, start=start, margin=margin)
    return SpeedProfile(times=times, speeds=speeds)
