# Feasibility where the train runs: quasi-static forces along the route against the envelopes.
"""Can every vehicle supply the force the scenario asks of it, where the train actually runs?

The quasi-static force split (:class:`~trainctl.models.ForceSplit`, the split
of the cruise equilibrium and of the controllers' feedforward) gives the
force each vehicle needs when the whole train runs at one speed v and
acceleration a: u_i from m_j (a0_j + a1_j v + a2_j v² + a + r_j), with r_j the
line resistance (grade and curves) under vehicle j. Positive forces are
judged against the vehicle's traction envelope, negative ones against its
braking envelope (force, power and adhesion, at v).

:func:`route_forces` evaluates the split along the scenario's route:

- with a ``[simulation]``, along its reference: the reference speed is
  integrated to the head position (the simulation starts with the head at
  0 m), each vehicle's position gives its track section, and the forces are
  evaluated on a grid over the run plus every reference breakpoint (with the
  acceleration before and after it) and every instant a vehicle crosses into
  another section;
- without one, at the model (cruise) speed with the whole train on each track
  section in turn (a section shorter than the train is judged as if it held
  the whole train, which is conservative).

:func:`feasibility_check` is the design review's ``feasibility`` check; with a
reference on a track with speed limits it also fails where the reference
exceeds a limit under the train (:func:`speed_limit_excess`): a route the
train may not run is not feasible either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import NDArray

from trainctl.analysis.check import Check, finite_or_none
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.feedforward import ForceSplit
from trainctl.models.track import Track, TrackSection

if TYPE_CHECKING:
    from trainctl.models.train import Train
    from trainctl.scenario import Scenario, SimulationSettings

__all__ = ["GRID_POINTS", "LimitExcess", "RouteForces", "feasibility_check", "reference_motion",
           "route_forces", "speed_limit_excess"]

KN = 1e3
Array = NDArray[np.float64]

GRID_POINTS = 2001
"""Evenly spaced evaluation instants over a simulated run (besides the events)."""

_MAX_CROSSINGS = 200_000
"""Above this many (vehicle, section) crossings only the head's and tail's are added."""

_SHOWN = 4

_LIMIT_TOL = 1e-9
"""Relative excess over a speed limit the check allows (the planner meets limits exactly)."""
"""Vehicles listed by name in a check message (the rest are counted)."""


@dataclass(frozen=True, kw_only=True, eq=False)
class RouteForces:
    """Quasi-static forces of a train along its route, one row per evaluation point.

    Parameters
    ----------
    mode : {"reference", "cruise"}
        Along a simulation's reference, or cruise at the model speed on each section.
    times : ndarray
        Time of each point [s] (the section's index in the ``"cruise"`` mode), shape (k,).
    speeds, accelerations : ndarray
        Common speed [m/s] and acceleration [m/s²] of the train, shape (k,).
    head_positions : ndarray
        Head position [m] (``"cruise"``: the section's start), shape (k,).
    sections : ndarray of int
        0-based index of the track section under each vehicle, shape (k, n).
    track : Track
        The track (a level one when the scenario has none).
    inputs : ndarray
        Force each vehicle must supply [N], traction positive, shape (k, n).
    coupler_forces : ndarray
        Static coupler forces [N], tension positive, shape (k, n-1).
    traction_limit, braking_limit : ndarray
        Each vehicle's traction and braking limits at the speed [N], >= 0, shape (k, n).

    Examples
    --------
    The heavy-haul train cruising on its two sections: level, then a 12 ‰
    down-grade where every car must brake with 519.8 kN but can give 380 kN.

    >>> import numpy as np
    >>> from trainctl.scenario import load_scenario
    >>> route = route_forces(load_scenario("heavy-haul-hinf"))
    >>> np.round(route.inputs[:, 0] / 1e3, 1).tolist()  # car 1 on each section [kN]
    [100.9, -519.8]
    >>> route.infeasible()[:, 0].tolist()
    [False, True]
    >>> np.round(route.excess()[1, 0] / 1e3, 1)  # 519.8 - 380 [kN]
    np.float64(139.8)
    >>> np.round(route.utilisation()[1, 0], 3)  # 519.8 / 380 [-]
    np.float64(1.368)
    """

    mode: str
    times: Array
    speeds: Array
    accelerations: Array
    head_positions: Array
    sections: NDArray[np.intp]
    track: Track
    inputs: Array
    coupler_forces: Array
    traction_limit: Array
    braking_limit: Array

    def excess(self) -> Array:
        """How far each vehicle's force is outside its envelope [N] (<= 0 inside), (k, n).

        Returns
        -------
        ndarray, shape (k, n)
            Per point and vehicle, the larger of the force above the
            traction limit and the braking force beyond the braking limit
            [N]: positive outside the envelope, <= 0 inside.
        """
        return np.maximum(self.inputs - self.traction_limit, -self.braking_limit - self.inputs)

    def infeasible(self) -> NDArray[np.bool_]:
        """True where a vehicle's force is outside its envelope (relative 1e-9 + 1e-6 N).

        Returns
        -------
        ndarray of bool, shape (k, n)
            Per point and vehicle: :meth:`excess` above a tolerance of 1e-9
            times the limit on the force's side (traction or braking; 0 when
            that limit is infinite) plus 1e-6 N.
        """
        limit = np.where(self.inputs >= 0, self.traction_limit, self.braking_limit)
        tol = 1e-9 * np.where(np.isfinite(limit), limit, 0.0) + 1e-6
        return self.excess() > tol

    def utilisation(self) -> Array:
        """Required over available force [-], per point and vehicle (inf: none available).

        Returns
        -------
        ndarray, shape (k, n)
            The force's magnitude over the traction limit (traction) or the
            braking limit (braking) [-]: > 1 outside the envelope, 0 where the force
            is at most 1e-6 N, inf where a force is needed and the limit is
            zero.
        """
        need = np.abs(self.inputs)
        available = np.where(self.inputs >= 0, self.traction_limit, self.braking_limit)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = need / available
        ratio[need <= 1e-6] = 0.0
        return np.where(np.isnan(ratio), 0.0, ratio)


def route_forces(scenario: Scenario, times: Array | None = None) -> RouteForces:
    """The quasi-static forces along the scenario's route (module docstring).

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    times : ndarray or None
        Instants [s] at which to evaluate the reference (needs a
        ``[simulation]``); None: the review's points (reference grid and
        events, or the cruise on every section without a simulation).

    Returns
    -------
    RouteForces
        Forces, limits and where each vehicle is.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> route = route_forces(load_scenario("heavy-haul-hinf"))
    >>> route.mode, route.sections[:, 0].tolist()
    ('cruise', [0, 1])
    >>> (route.inputs[1, 0] / 1e3).round(1), (route.braking_limit[1, 0] / 1e3).round(1)
    (np.float64(-519.8), np.float64(380.0))
    """
    train, track = scenario.train, scenario.track or Track()
    sim = scenario.simulation
    split = ForceSplit(train, allocation=scenario.model.allocation, where="feasibility")
    if sim is None and times is None:
        return _cruise(train, track, split, scenario.model.speed)
    if sim is None:
        from trainctl.exceptions import ScenarioError

        raise ScenarioError(f"{scenario.source}: route_forces at given times needs a "
                            "[simulation] reference (got none).")
    if times is None:
        t, accel = _review_points(sim, train, track)
    else:
        t = np.asarray(times, dtype=float)
        accel = reference_motion(sim, t)[1]
    speed, _, head = reference_motion(sim, t)
    positions = head[:, None] - _offsets(train)[None, :]
    line = track.resistance_per_mass(positions)
    return _evaluate(train, track, split, mode="reference", times=t, speeds=speed,
                     accelerations=accel, heads=head, line=line,
                     sections=_section_index(track, positions))


def reference_motion(sim: SimulationSettings, times: Array) -> tuple[Array, Array, Array]:
    """Speed, acceleration and head position of the reference at ``times``.

    The reference is piecewise linear in speed through its breakpoints and
    constant after the last one; the acceleration is the slope of the
    segment that starts at or before t; the head position is the integral of
    the speed from 0 m at t = 0.

    Parameters
    ----------
    sim : SimulationSettings
        The simulation with the reference.
    times : ndarray
        Instants [s], >= 0.

    Returns
    -------
    speed, acceleration, position : ndarray
        [m/s], [m/s²] and [m], shaped like ``times``.

    Examples
    --------
    >>> from trainctl.scenario import SimulationSettings
    >>> sim = SimulationSettings(duration=20.0, strategies=("centralised",),
    ...                          reference_times=(0.0, 10.0), reference_speeds=(10.0, 20.0))
    >>> [x.tolist() for x in reference_motion(sim, np.array([5.0, 15.0]))]
    [[15.0, 20.0], [1.0, 0.0], [62.5, 250.0]]
    """
    tb = np.asarray(sim.reference_times, dtype=float)
    vb = np.asarray(sim.reference_speeds, dtype=float)
    slopes = np.append(np.diff(vb) / np.diff(tb), 0.0)
    travelled = np.concatenate([[0.0], np.cumsum(np.diff(tb) * (vb[:-1] + vb[1:]) / 2)])
    t = np.asarray(times, dtype=float)
    j = np.clip(np.searchsorted(tb, t, side="right") - 1, 0, tb.size - 1)
    tau = t - tb[j]
    speed = vb[j] + slopes[j] * tau
    return speed, slopes[j], travelled[j] + vb[j] * tau + slopes[j] * tau * tau / 2


class LimitExcess(NamedTuple):
    """The reference's worst excess over a speed limit (:func:`speed_limit_excess`).

    Parameters
    ----------
    excess : float
        Reference speed minus the limit [m/s] (> 0: over it).
    time : float
        When [s].
    speed : float
        The reference speed then [m/s].
    limit : float
        The limit [m/s].
    start : float
        Where that limit starts [m].
    head : float
        The head's position then [m].

    Examples
    --------
    >>> LimitExcess(excess=2.0, time=5.0, speed=27.0, limit=25.0, start=800.0,
    ...             head=820.0).excess
    2.0
    """

    excess: float
    time: float
    speed: float
    limit: float
    start: float
    head: float


def speed_limit_excess(sim: SimulationSettings, train: Train,
                       track: Track) -> LimitExcess | None:
    """The largest excess of the reference over the speed limits under the train.

    The reference speed is common to the train; restriction j (limit ℓ from
    its start a to the next start b) holds while any vehicle is on it: from
    the head reaching a until the tail leaving b. The reference is piecewise
    linear in time, so its largest value over that interval is at the
    interval's ends or at a breakpoint inside: the check is exact (the ends
    located by bisection on the head position to 1e-12 s).

    Parameters
    ----------
    sim : SimulationSettings
        The reference (head at 0 m at t = 0).
    train, track : Train, Track
        The train's length; the track's speed limits.

    Returns
    -------
    LimitExcess or None
        The worst point (largest speed minus limit) over every restriction the
        run meets; None without speed limits or when the run meets none.

    Examples
    --------
    >>> from trainctl.models import crh2_half
    >>> from trainctl.models.track import SpeedLimit
    >>> from trainctl.scenario import SimulationSettings
    >>> sim = SimulationSettings(duration=100.0, strategies=("centralised",),
    ...                          reference_times=(0.0,), reference_speeds=(30.0,))
    >>> track = Track(speed_limits=(SpeedLimit(start=0.0, limit=40.0),
    ...                             SpeedLimit(start=1500.0, limit=25.0)))
    >>> worst = speed_limit_excess(sim, crh2_half(), track)
    >>> round(worst.excess, 6), worst.time  # 5 m/s over, from t = 50 s
    (5.0, 50.0)
    """
    limits = track.speed_limits
    if not limits:
        return None
    duration = float(sim.duration)
    length = float(np.sum(train.spacing))
    end_head = float(reference_motion(sim, np.array([duration]))[2][0])
    tb = np.asarray(sim.reference_times, dtype=float)
    worst: LimitExcess | None = None
    for j, limit in enumerate(limits):
        stop = limits[j + 1].start + length if j + 1 < len(limits) else math.inf
        if limit.start > end_head or stop <= 0.0:
            continue
        t0 = 0.0 if limit.start <= 0.0 else _time_at(sim, limit.start, duration)
        t1 = duration if stop >= end_head else _time_at(sim, stop, duration)
        inside = tb[(tb > t0) & (tb < t1)]
        t = np.concatenate([[t0, t1], inside])
        speed, _, head = reference_motion(sim, t)
        k = int(np.argmax(speed))
        excess = float(speed[k] - limit.limit)
        if worst is None or excess > worst.excess:
            worst = LimitExcess(excess=excess, time=float(t[k]), speed=float(speed[k]),
                                limit=limit.limit, start=limit.start, head=float(head[k]))
    return worst


def _time_at(sim: SimulationSettings, position: float, duration: float) -> float:
    """The first time in [0, duration] the reference's head reaches ``position`` [m]."""
    lo, hi = 0.0, duration
    for _ in range(200):
        if hi - lo <= 1e-12 * max(1.0, hi):
            break
        mid = 0.5 * (lo + hi)
        if float(reference_motion(sim, np.array([mid]))[2][0]) < position:
            lo = mid
        else:
            hi = mid
    return hi


def feasibility_check(scenario: Scenario, route: RouteForces | None = None) -> Check:
    """The ``feasibility`` check: every vehicle within its envelope along the route.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    route : RouteForces or None
        Its :func:`route_forces` when already computed.

    Returns
    -------
    Check
        Value: the largest required/available force ratio over the route and
        the vehicles; threshold 1. Fails naming the first infeasible point:
        time and head position, the section (start, grade, curve) and each
        out-of-envelope vehicle (1-based) with its required and available force.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> check = feasibility_check(load_scenario("heavy-haul-hinf"))
    >>> check.status, "section 2" in check.message, "519.8 kN braking" in check.message
    ('fail', True, True)
    """
    if route is None:
        route = route_forces(scenario)
    ratio = route.utilisation()
    worst = float(np.max(ratio)) if ratio.size else 0.0
    bad = route.infeasible()
    details: dict[str, object] = {"mode": route.mode, "points": int(route.speeds.size),
                                  "max_utilisation": finite_or_none(worst)}
    sim, track = scenario.simulation, scenario.track
    excess = None if sim is None or track is None else speed_limit_excess(
        sim, scenario.train, track)
    if excess is not None:
        details["speed_limit"] = excess._asdict()
    if excess is not None and excess.excess > _LIMIT_TOL * (1.0 + excess.limit):
        found = _failed(route, bad, worst, details) if bad.any() else None
        text = (f"the reference exceeds the speed limit of {3.6 * excess.limit:.4g} km/h "
                f"(from {excess.start:g} m) by {3.6 * excess.excess:.3g} km/h at "
                f"t = {excess.time:.6g} s (head at {excess.head:.6g} m, reference "
                f"{3.6 * excess.speed:.4g} km/h)")
        return Check(name="feasibility", status="fail", value=worst, threshold=1.0, unit="",
                     message=text if found is None else f"{text}; {found.message}",
                     hint="Plan the reference under the limits ([simulation.plan]) or lower "
                     "its speeds there.", details=details)
    if bad.any():
        return _failed(route, bad, worst, details)
    k, i = (int(x) for x in np.unravel_index(int(np.argmax(ratio)), ratio.shape))
    use = "" if worst <= 0 else (
        f"; highest use {100 * worst:.3g} % (vehicle {i + 1}, "
        f"{'traction' if route.inputs[k, i] >= 0 else 'braking'}, {_where(route, k)})")
    return Check(name="feasibility", status="pass", value=worst, threshold=1.0, unit="",
                 message=f"{_scope(route)} within every vehicle's traction and braking "
                 f"envelope{use}", details=details)


def _failed(route: RouteForces, bad: NDArray[np.bool_], worst: float,
            details: dict[str, object]) -> Check:
    """The failing check: the first point with a vehicle out of its envelope."""
    k = int(np.flatnonzero(bad.any(axis=1))[0])
    vehicles = [int(i) for i in np.flatnonzero(bad[k])]
    section = int(route.sections[k, vehicles[0]])
    found = [_vehicle_need(route, k, i) for i in vehicles]
    details["first"] = {"time": float(route.times[k]) if route.mode == "reference" else None,
                        "head_position": float(route.head_positions[k]),
                        "speed": float(route.speeds[k]),
                        "acceleration": float(route.accelerations[k]),
                        **_section_dict(route.track, section),
                        "vehicles": [need._asdict() for need in found]}
    listed = "; ".join(f"vehicle {v.vehicle} needs {abs(v.required_kn):.1f} kN "
                       f"{v.direction}, {v.available_kn:.1f} kN available" for v in found[:_SHOWN])
    more = f"; and {len(found) - _SHOWN} more vehicle(s)" if len(found) > _SHOWN else ""
    return Check(name="feasibility", status="fail", value=worst, threshold=1.0, unit="",
                 message=f"infeasible {_where(route, k)}, section {section + 1} "
                 f"({_describe(route.track, section)}): {listed}{more}",
                 hint=_hint(route, k, found[0].direction), details=details)


# -- evaluation ---------------------------------------------------------------------------------
def _evaluate(train: Train, track: Track, split: ForceSplit, *, mode: str, times: Array,
              speeds: Array, accelerations: Array, heads: Array, line: Array,
              sections: NDArray[np.intp]) -> RouteForces:
    q = split(np.maximum(speeds, 0.1), accelerations, line)
    pair = EnvelopeBounds(train, enabled=True).pair(speeds) * KN   # [lb; ub], move by move
    n = train.n_vehicles
    return RouteForces(mode=mode, times=times, speeds=speeds, accelerations=accelerations,
                       head_positions=heads, sections=sections, track=track, inputs=q.inputs,
                       coupler_forces=q.coupler_forces,
                       traction_limit=pair[1].reshape(-1, n),
                       braking_limit=-pair[0].reshape(-1, n))


def _cruise(train: Train, track: Track, split: ForceSplit, speed: float) -> RouteForces:
    """The whole train at the cruise speed on each section in turn."""
    starts = np.array([s.start for s in track.sections])
    k, n = starts.size, train.n_vehicles
    line = np.repeat(track.resistance_per_mass(starts)[:, None], n, axis=1)
    return _evaluate(train, track, split, mode="cruise", times=np.arange(k, dtype=float),
                     speeds=np.full(k, speed), accelerations=np.zeros(k), heads=starts,
                     line=line, sections=np.repeat(np.arange(k)[:, None], n, axis=1))


def _review_points(sim: SimulationSettings, train: Train, track: Track) -> tuple[Array, Array]:
    """Instants and accelerations the review evaluates (module docstring)."""
    duration = float(sim.duration)
    grid = np.linspace(0.0, duration, GRID_POINTS)
    tb = np.asarray(sim.reference_times, dtype=float)
    inside = tb[(tb > 0) & (tb <= duration)]
    times = np.unique(np.concatenate([grid, inside, _crossings(sim, train, track, grid)]))
    accel = reference_motion(sim, times)[1]
    # At each breakpoint also the acceleration of the segment that ends there.
    slopes = np.diff(np.asarray(sim.reference_speeds, dtype=float)) / np.diff(tb)
    before = slopes[np.searchsorted(tb, inside, side="left") - 1] if inside.size else inside
    order = np.argsort(np.concatenate([times, inside]), kind="stable")
    return np.concatenate([times, inside])[order], np.concatenate([accel, before])[order]


def _crossings(sim: SimulationSettings, train: Train, track: Track, grid: Array) -> Array:
    """Instants just after a vehicle passes the start of a section (head and tail if many)."""
    starts = np.array([s.start for s in track.sections[1:]])
    if starts.size == 0:
        return np.zeros(0)
    offsets = _offsets(train)
    if starts.size * offsets.size > _MAX_CROSSINGS:
        offsets = offsets[[0, -1]]
    fine = np.linspace(0.0, float(grid[-1]), 20 * GRID_POINTS)
    head = reference_motion(sim, fine)[2]
    targets = (starts[:, None] + offsets[None, :]).ravel()
    index = np.searchsorted(head, targets, side="left")
    return fine[index[index < fine.size]]


def _offsets(train: Train) -> Array:
    """Distance of each vehicle behind the head at nominal spacing [m]."""
    return np.concatenate([[0.0], np.cumsum(train.spacing)])


def _section_index(track: Track, positions: Array) -> NDArray[np.intp]:
    starts = np.array([s.start for s in track.sections])
    index = np.searchsorted(starts, positions, side="right") - 1
    return np.asarray(np.clip(index, 0, starts.size - 1), dtype=np.intp)


# -- wording ------------------------------------------------------------------------------------
class _Need(NamedTuple):
    """One vehicle's required and available force at a point [kN]; vehicle 1-based."""

    vehicle: int
    direction: str
    required_kn: float
    available_kn: float


def _vehicle_need(route: RouteForces, k: int, i: int) -> _Need:
    u = float(route.inputs[k, i])
    traction = u >= 0
    available = float(route.traction_limit[k, i] if traction else route.braking_limit[k, i])
    return _Need(vehicle=i + 1, direction="traction" if traction else "braking",
                 required_kn=u / KN, available_kn=available / KN)


def _section_dict(track: Track, index: int) -> dict[str, object]:
    section: TrackSection = track.sections[index]
    return {"section": index + 1, "section_start": section.start,
            "grade_permille": section.grade_permille,
            "curve_radius": None if math.isinf(section.curve_radius) else section.curve_radius}


def _describe(track: Track, index: int) -> str:
    section = track.sections[index]
    curve = ("straight" if math.isinf(section.curve_radius)
             else f"curve radius {section.curve_radius:g} m")
    return f"from {section.start:g} m, grade {section.grade_permille:g} ‰, {curve}"


def _where(route: RouteForces, k: int) -> str:
    speed = f"{route.speeds[k] * 3.6:.4g} km/h"
    if route.mode == "cruise":
        return f"cruising at {speed}"
    accel = route.accelerations[k]
    motion = f", {accel:+.3g} m/s²" if accel else ""
    return (f"at t = {route.times[k]:.6g} s (head at {route.head_positions[k]:.6g} m, "
            f"{speed}{motion})")


def _scope(route: RouteForces) -> str:
    n_sections = len(route.track.sections)
    if route.mode == "cruise":
        return (f"cruise at {route.speeds[0] * 3.6:.4g} km/h on each of the {n_sections} "
                "track section(s)")
    used = np.unique(route.sections)
    return (f"the reference over {route.times[-1]:.6g} s ({route.head_positions[-1] / 1e3:.4g} km,"
            f" {used.size} of {n_sections} track section(s))")


def _hint(route: RouteForces, k: int, direction: str) -> str:
    need = float(np.sum(route.inputs[k]))
    if direction == "braking":
        total = float(np.sum(route.braking_limit[k]))
        fix = ("lower the speed on this section, or raise max_braking_kn / "
               "max_braking_power_kw (or let more vehicles brake)")
    else:
        total = float(np.sum(route.traction_limit[k]))
        fix = ("lower the speed or the acceleration of the reference, or raise max_traction_kn "
               "/ max_power_kw (or add motor vehicles)")
    spread = ": spread the force over more vehicles (traction_share)" if abs(need) <= total else ""
    return (f"{fix}; the train as a whole needs {abs(need) / KN:.1f} kN {direction} against "
            f"{total / KN:.1f} kN available{spread}")
