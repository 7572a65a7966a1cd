# Hard limits of what trainctl can compute: each bound declared once, with its reason.
"""The largest (and smallest) values trainctl accepts, and why.

These are not plausibility checks (the design review warns about values that
look like unit slips, such as ``mass_t = 42800``): they are hard limits far
outside any real train, beyond which the models lose their meaning and their
arithmetic overflows, or a run would not fit in memory or finish in days.
Each bound is declared here once, in SI, as a :class:`~trainctl.declare.constraints.Rule`
with the reason; the model classes (:class:`~trainctl.models.vehicle.Vehicle`,
the settings classes) and the scenario-file keys use the same rules, a file
key in another unit (``mass_t``, ``speed_kmh``) with the bound converted to it
(:func:`in_unit`). A value outside a bound is a
:class:`~trainctl.exceptions.ScenarioError` (files) or
:class:`~trainctl.exceptions.ModelError` (Python) naming the key, the bound and
the reason, before anything runs.

Examples
--------
>>> from trainctl.exceptions import ModelError
>>> from trainctl.scenario import ModelSettings
>>> try:
...     ModelSettings(speed=25.0, sample_time=1e-9)
... except ModelError as exc:
...     print(exc)  # doctest: +ELLIPSIS
ModelSettings: 'sample_time' must be a finite number >= 0.0001 (got 1e-09). Sample times ...
>>> SAMPLE_TIME.want(), in_unit(MASS, lambda t: t * 1000.0).want()
('a number from 0.0001 to 3600', 'a number from 0.001 to 1e+06')
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

from trainctl.declare.constraints import Array, Integer, Number, Rule
from trainctl.units import KMH_PER_MS

__all__ = [
    "COUPLER_DAMPING", "COUPLER_GAP", "COUPLER_SPACING", "COUPLER_STIFFNESS", "CURVE_RADIUS",
    "DAVIS", "DURATION", "GRADE", "LENGTH",
    "HORIZON", "ITERATIONS", "MASS", "MAX_DURATION", "MAX_HORIZON", "MAX_SAMPLES", "MAX_SPEED",
    "MAX_SPEED_KMH", "MAX_VEHICLES", "SAMPLES_WHY", "SAMPLE_TIME", "SPEED", "SPEED_ERROR",
    "SPEED_NOISE", "SPEED_POINTS", "VEHICLES_WHY", "in_unit",
]

_BOUND_DIGITS = 12
"""Significant digits of a bound converted to a key's unit (drops rounding noise)."""

MAX_SPEED_KMH = 1000.0
"""Fastest speed trainctl models [km/h] (the rail speed record is 603 km/h, maglev)."""

MAX_SPEED = MAX_SPEED_KMH / KMH_PER_MS
""":data:`MAX_SPEED_KMH` in m/s."""

_SPEED_WHY = ("Speeds beyond 1000 km/h (the rail record is 603 km/h) are outside what trainctl "
              "models; far beyond, the resistance a2·v² and the energies overflow.")

SPEED = Number(gt=0, le=MAX_SPEED, why=_SPEED_WHY)
"""A cruise (linearisation) speed [m/s]."""

SPEED_POINTS = Number(ge=0, le=MAX_SPEED, why=_SPEED_WHY)
"""A reference speed [m/s]."""

SPEED_ERROR = Number(ge=-MAX_SPEED, le=MAX_SPEED, why=_SPEED_WHY)
"""An initial speed offset [m/s]."""

SPEED_NOISE = Number(ge=0, le=MAX_SPEED, why=_SPEED_WHY)
"""A speed-measurement noise level [m/s]."""

MASS = Number(ge=1.0, le=1e9, why=(
    "A vehicle (or a unit train modelled as one) weighs from 1 kg to 1e6 t here; the heaviest "
    "trains ever run weighed about 1e5 t, and beyond the bounds the forces per unit mass "
    "(k/m, F/m) overflow or vanish."))
"""A vehicle mass [kg]: 1 kg to 1e6 t."""

DAVIS = {
    "a0": Number(ge=0, le=100.0, why=(
        "Davis a0 <= 100 m/s² (real trains: about 0.01 m/s²); beyond it the resistance "
        "exceeds ten times the vehicle's weight.")),
    "a1": Number(ge=0, le=1.0, why=(
        "Davis a1 <= 1 1/s (real trains: about 1e-3 1/s); beyond it the resistance exceeds "
        "the vehicle's weight many times over at any speed.")),
    "a2": Number(ge=0, le=0.01, why=(
        "Davis a2 <= 0.01 1/m (real trains: about 2e-5 1/m); beyond it the resistance exceeds "
        "the vehicle's weight many times over at line speeds.")),
}
"""The Davis coefficients per unit mass [m/s², 1/s, 1/m]."""

COUPLER_STIFFNESS = Number(le=1e12, why=(
    "Above 1e9 kN/m a coupler is stiffer than a solid steel block of 1 m² section and 1 m "
    "length (about 2e8 kN/m; real couplers: 1e3 to 1e5 kN/m), and its mode is too fast to "
    "sample or integrate."))
"""A coupler stiffness [N/m] (its sign is checked by the coupler)."""

COUPLER_DAMPING = Number(ge=0, le=1e12, why=(
    "Above 1e9 kN·s/m (real draft gears: 10 to 1000 kN·s/m) the coupler modes decay faster "
    "than any sample time or integrator step can follow."))
"""A coupler damping [N·s/m]."""

_POSITIONS_WHY = ("beyond 1e9 m (a million km) the vehicle positions along the track, summed in "
                  "floating point, lose the micrometre resolution the simulation's track-section "
                  "lookup relies on, and values such as 1e300 overflow.")

LENGTH = Number(gt=0, le=1e9, why=(
    "A vehicle (or a unit train modelled as one) is at most 1e9 m long here (the longest "
    "train ever run was 7.35 km; the plausibility check warns above 10 km): "
    + _POSITIONS_WHY))
"""A vehicle length over couplers [m]: up to 1e9 m."""

COUPLER_GAP = Number(ge=0, le=1e9, why=(
    "A coupler's (or a virtual link's) extra gap is at most 1e9 m here (virtual coupling "
    "keeps trains within a braking distance, about 10 km at 350 km/h at the most; the "
    "plausibility check warns above 10 km): " + _POSITIONS_WHY))
"""A coupler's extra centre spacing beyond the two half-lengths [m]: up to 1e9 m."""

COUPLER_SPACING = Number(gt=0, le=2e9, why=(
    "Two half-lengths of vehicles at most 1e9 m long plus a gap of at most 1e9 m: "
    + _POSITIONS_WHY))
"""A coupler's centre-to-centre spacing [m]: up to 2e9 m."""

GRADE = Number(ge=-1000.0, le=1000.0, why=(
    "A grade beyond ±1000 ‰ (45°) is not a railway: adhesion lines stay below 130 ‰ and rack "
    "railways below 480 ‰."))
"""A track grade [‰]."""

CURVE_RADIUS = Number(ge=10.0, allow_inf=True, inf="straight track", why=(
    "No rail vehicle takes a curve tighter than 10 m (tramways: 15 m and more); the curve "
    "resistance, about 600/R, grows without bound as R shrinks."))
"""A curve radius [m], inf for straight track."""

SAMPLE_TIME = Number(ge=1e-4, le=3600.0, why=(
    "Sample times below 0.1 ms resolve modes far beyond any coupler's (a few Hz) and make "
    "runs of millions of steps; above an hour there is no control loop, and the "
    "discretisation exp(A·T) overflows."))
"""A sample time [s]: 0.1 ms to 1 h."""

MAX_DURATION = 7 * 86400.0
"""Longest simulated run [s]: a week."""

DURATION = Number(gt=0, le=MAX_DURATION, why=(
    "A closed-loop run is limited to a week of simulated time (604800 s); a timetable study "
    "is a series of runs."))
"""A simulated duration [s]."""

MAX_SAMPLES = 10_000_000
"""Most controller samples in one simulated run (duration / sample time)."""

SAMPLES_WHY = (
    "The results keep every sample (about 100 bytes per vehicle and sample) and a controller "
    "step takes a millisecond or more, so 10 million samples are gigabytes and hours per "
    "strategy. Lengthen sample_time or shorten duration.")
"""Why :data:`MAX_SAMPLES`."""

MAX_HORIZON = 2000
"""Longest MPC prediction horizon [steps]."""

HORIZON = Integer(ge=1, le=MAX_HORIZON, why=(
    "The condensed MPC holds dense matrices of (vehicles × horizon)² entries and its analysis "
    "takes time growing with their cube; 2000 steps is far beyond any train's settling time "
    "at a sensible sample time."))
"""An MPC prediction horizon [steps]."""

ITERATIONS = Integer(ge=1, le=10_000, why=(
    "A distributed MPC iteration that converges does so in tens of iterations; a limit "
    "beyond 10000 per sample only turns a non-converging design into a run of days."))
"""An iteration count or limit per sample of distributed MPC."""

MAX_VEHICLES = 2000
"""Longest train a scenario may describe (vehicles after ``count``)."""

VEHICLES_WHY = (
    "The model has two states per vehicle and its analyses factor dense matrices of "
    "(2·vehicles)² entries, in time growing with the cube or faster; the longest trains run "
    "about 700 wagons.")
"""Why :data:`MAX_VEHICLES`."""


def in_unit(rule: Rule, to_si: Callable[[float], float] | None) -> Rule:
    """The rule for values in a key's unit, given the key's converter to SI.

    Rules declare their bounds in SI; a file key in another unit (``mass_t``,
    ``speed_kmh``) checks the same bounds divided by the converter's scale.
    Rules without bounds (and arrays of them) come back unchanged.

    Parameters
    ----------
    rule : Rule
        A rule (a :class:`~trainctl.declare.constraints.Number`, or an
        :class:`~trainctl.declare.constraints.Array` of them, carries bounds).
    to_si : callable or None
        The key's converter; it must be a positive scale factor.

    Returns
    -------
    Rule
        The rule with its bounds in the key's unit.

    Raises
    ------
    ValueError
        If the converter is not a positive scale factor (a declaration error).

    Examples
    --------
    >>> in_unit(Number(gt=0, le=1e9), lambda t: t * 1000.0).want()
    'a number in (0, 1e+06]'
    """
    if isinstance(rule, Array):
        return replace(rule, item=in_unit(rule.item, to_si))
    if not isinstance(rule, Number) or to_si is None:
        return rule
    if all(b is None or b == 0 for b in (rule.gt, rule.ge, rule.le)):
        return rule
    scale = float(to_si(1.0))
    if to_si(0.0) != 0.0 or not math.isclose(to_si(2.0), 2.0 * scale) or scale <= 0:
        raise ValueError(f"{to_si!r} is not a positive scale factor; the bounds of {rule!r} "
                         "cannot be converted to its unit")

    def unit(bound: float | None) -> float | None:
        return bound if bound is None or bound == 0 else float(f"{bound / scale:.{_BOUND_DIGITS}g}")

    return replace(rule, gt=unit(rule.gt), ge=unit(rule.ge), le=unit(rule.le))
