# The [simulation.plan] table: a reference planned along the line instead of typed by hand.
"""Settings of ``[simulation.plan]``: the reference speed planned along ``[track]``.

In place of ``[simulation.reference]``'s breakpoints, a scenario may ask for
the fastest reference under the line's speed limits
(:func:`trainctl.sim.planner.limited_profile`): the cruise speed where the
limits allow it, braking curves that reach each lower limit by its start,
acceleration once the whole train has left a restriction. The plan is made
when the file is read (again on every :meth:`Scenario.replace
<trainctl.scenario.Scenario.replace>`, so a changed train or track is
planned anew) and becomes the reference's breakpoints; the head starts at
position 0.
"""

from __future__ import annotations

from typing import Annotated

from trainctl.declare.constraints import Number
from trainctl.declare.keys import Key, settings
from trainctl.units import kmh_to_ms

__all__ = ["PlanSettings"]


@settings
class PlanSettings:
    """A reference planned along the track (module docstring).

    Parameters
    ----------
    cruise : float
        Speed wanted wherever the limits allow it [m/s], > 0 (file key
        ``cruise_kmh``, km/h).
    acceleration : float
        Acceleration of the plan [m/s²], > 0.
    deceleration : float or None
        Deceleration of its braking curves [m/s²], > 0, at most the train's
        brakes on the steepest down-grade; None: ``margin`` times that.
    end : float or None
        Head position where the plan ends [m], > 0 (the reference holds its
        last speed after it); None: the line's last stop (``[track].line``
        or ``file``).
    start_speed : float or None
        Speed at t = 0 [m/s], >= 0, within the limits there (file key
        ``start_speed_kmh``, km/h; 0: from a standstill); None: the cruise
        speed or the limit there, the lower.
    margin : float
        Share of the brakes' deceleration the default deceleration uses, in (0, 1].

    Examples
    --------
    >>> plan = PlanSettings(cruise=20.0, acceleration=0.3, end=5000.0)
    >>> plan.deceleration, plan.margin
    (None, 0.9)
    """

    cruise: Annotated[float, Number(gt=0, le=150), Key(
        "Speed wanted wherever the speed limits allow it", file="cruise_kmh", unit="km/h",
        to_si=kmh_to_ms, si_unit="m/s")]
    acceleration: Annotated[float, Number(gt=0, le=10), Key(
        "Acceleration of the plan", unit="m/s²")]
    deceleration: Annotated[Annotated[float, Number(gt=0, le=10)] | None, Key(
        "Deceleration of the braking curves (at most the brakes' on the steepest down-grade)",
        unit="m/s²", omitted="margin × the brakes' deceleration")] = None
    end: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Head position where the plan ends (its last speed is held after it)", unit="m",
        omitted="the line's last stop")] = None
    start_speed: Annotated[Annotated[float, Number(ge=0, le=150)] | None, Key(
        "Speed at t = 0 (0: from a standstill)", file="start_speed_kmh", unit="km/h",
        to_si=kmh_to_ms, si_unit="m/s",
        omitted="the cruise speed or the limit there, the lower")] = None
    margin: Annotated[float, Number(gt=0, le=1), Key(
        "Share of the brakes' deceleration the omitted deceleration uses")] = 0.9
