# Plausibility of the physical values: usual ranges, and the unit slip that explains a miss.
"""Are the scenario's physical values in the ranges real trains have?

A value far outside its usual range is most often a unit slip: kilograms
typed where the key takes tonnes, N/m where it takes kN/m. The
``plausibility`` check warns for every value outside its range and, where a
unit conversion brings it into the range, names that unit ("did you mean
kg?"). The ranges are deliberately wide, so that unusual but real trains
(a whole heavy-haul unit train as one vehicle) pass:

=====================  =====================  =======================================
quantity               usual range            why [source tag]
=====================  =====================  =======================================
mass per length        0.3 - 15 t/m           light rail cars ~1 t/m, 40 t-axle ore
                                              wagons ~12 t/m [reconstructed]
coupler stiffness      100 - 1e6 kN/m         draft gears 1e4 - 1e5 kN/m; CRH2 10488
                                              kN/m [seed 000] [reconstructed]
coupler damping        0 - 1e4 kN·s/m         0 is the book's assumption [seed 000]
                                              [reconstructed]
coupler admissible     50 - 2e4 kN            light-rail couplers a few hundred kN,
force                                         heavy haul 2250 kN [seed 003]
                                              [reconstructed]
Davis resistance       0.001 - 0.5 m/s²       at the model speed; 300 km/h EMUs
                                              0.1 - 0.2 m/s² [seed 000, 001]
speeds                 <= 600 km/h            wheel-rail record 574.8 km/h (2007)
                                              [recalled]
traction/braking       <= 1 g per unit mass   adhesion rarely exceeds 0.4
force                                         [recalled]
traction/braking       <= 100 kW/t            300 km/h EMUs 20 - 25 kW/t
power                                         [recalled]
traction force of      <= 5000 kN             the strongest locomotives start with
one vehicle                                   about 1.2 MN; four of them (a whole
                                              distributed-power train as one vehicle)
                                              about 5 MN [recalled]
adhesion coefficient   0.01 - 0.5             steel wheel on steel rail: 0.05 on wet
                                              leaves, 0.3 - 0.4 dry, about 0.5 with
                                              sand; more is not physical [recalled]
vehicle length         2 - 1e4 m              draisines about 2 m; a whole unit train
                                              as one vehicle at most the longest
                                              train run, 7.35 km [recalled]
train length           <= 1e4 m               the longest train ever run was 7.35 km
                                              (BHP iron ore, 2001) [recalled]
coupler gap            <= 1e4 m               a virtual link keeps trains within a
                                              braking distance, about 10 km at most
                                              [recalled]
=====================  =====================  =======================================

A value outside its range is a warning (the ``plausibility`` check), not an
error: the run is still computed, as for a real but unusual train. Values that
break the computation itself are refused by the hard limits of
:mod:`trainctl.declare.limits`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from trainctl.analysis.check import Check
from trainctl.units import GRAVITY

if TYPE_CHECKING:
    from trainctl.models.vehicle import Vehicle
    from trainctl.scenario import Scenario

__all__ = ["RANGES", "Range", "plausibility_check"]


@dataclass(frozen=True)
class Range:
    """The usual range of one quantity, in the unit it is quoted in.

    Parameters
    ----------
    low, high : float
        Bounds (inclusive).
    unit : str
        Unit of the bounds (as the message quotes them).

    Examples
    --------
    A CRH2 coupler stiffness of 10 488 kN/m is usual; the same number read as
    N/m (10.488 kN/m) is not:

    >>> r = RANGES["stiffness"]
    >>> r.text()
    '100–1e+06 kN/m'
    >>> r.holds(10488.0), r.holds(10.488)
    (True, False)
    """

    low: float
    high: float
    unit: str

    def holds(self, value: float) -> bool:
        """True when ``value`` lies within the range.

        Parameters
        ----------
        value : float
            The quantity, in the range's :attr:`unit`.

        Returns
        -------
        bool
            ``low <= value <= high`` (False for NaN).
        """
        return self.low <= value <= self.high

    def text(self) -> str:
        """``"0.3–15 t/m"``.

        Returns
        -------
        str
            The bounds (``%g``) joined by an en dash, then the unit.
        """
        return f"{self.low:g}–{self.high:g} {self.unit}"


RANGES: dict[str, Range] = {
    "mass_per_length": Range(0.3, 15.0, "t/m"),
    "stiffness": Range(100.0, 1e6, "kN/m"),
    "damping": Range(0.0, 1e4, "kN·s/m"),
    "max_force": Range(50.0, 2e4, "kN"),
    "resistance": Range(1e-3, 0.5, "m/s²"),
    "speed": Range(0.0, 600.0, "km/h"),
    "force_per_mass": Range(0.0, GRAVITY, "m/s²"),
    "power_per_mass": Range(0.0, 100.0, "kW/t"),
    # One vehicle's traction force: about 1.2 MN starting effort for the strongest
    # (multi-section) locomotives; 5 MN is four of them, a whole distributed-power train as
    # one vehicle. Braking is judged per unit mass only (a unit train brakes on every wagon).
    "traction": Range(0.0, 5e3, "kN"),
    # Adhesion of steel on steel: about 0.05 on wet leaves, 0.3 - 0.4 dry, 0.5 with sand;
    # a coefficient above 0.5 is not physical for a railway wheel, below 0.01 nothing moves.
    "adhesion": Range(0.01, 0.5, ""),
    # A vehicle from a 2 m draisine to a whole unit train modelled as one vehicle; the
    # longest train ever run (BHP iron ore, 2001) was 7.35 km.
    "vehicle_length": Range(2.0, 1e4, "m"),
    "train_length": Range(0.0, 1e4, "m"),
    # A coupler's extra gap: about 0 for a real coupler; a virtual link keeps trains within a
    # braking distance, at most about 10 km (350 km/h, service braking).
    "gap": Range(0.0, 1e4, "m"),
}
"""Usual ranges of the physical values (module docstring)."""


def plausibility_check(scenario: Scenario) -> Check:
    """The ``plausibility`` check: every physical value in its usual range.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.

    Returns
    -------
    Check
        ``warn`` listing each implausible value with the likely unit slip,
        ``pass`` otherwise; value = the number of findings, threshold 0.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> plausibility_check(load_scenario("crh2-dmpc")).status
    'pass'
    """
    findings = (_vehicle_findings(scenario) + _train_findings(scenario)
                + _coupler_findings(scenario) + _speed_findings(scenario))
    grouped: dict[str, list[int]] = {}
    for text, vehicle in findings:
        grouped.setdefault(text, []).append(vehicle)
    items = [f"{_who(vehicles)}{text}" for text, vehicles in grouped.items()]
    details = {"findings": items, "ranges": {k: [r.low, r.high, r.unit] for k, r in RANGES.items()}}
    if not items:
        return Check(name="plausibility", status="pass", value=0.0, threshold=0.0, unit="",
                     message="masses, couplers, resistance, envelopes and speeds are within "
                     "their usual ranges", details=details)
    return Check(name="plausibility", status="warn", value=float(len(items)), threshold=0.0,
                 unit="", message="; ".join(items),
                 hint="check the units of these keys (the key name carries the unit: mass_t "
                 "is tonnes, _kn kN, _kw kW, _kmh km/h)", details=details)


# -- findings: (text, 1-based vehicle or coupler number, 0 for the scenario) --------------------
def _vehicle_findings(scenario: Scenario) -> list[tuple[str, int]]:
    found: list[tuple[str, int]] = []
    # Resistance judged at the model speed, at most the speed range's top (a speed slip is
    # reported by itself, not again as a resistance slip).
    speed = min(scenario.model.speed, RANGES["speed"].high / 3.6)
    for i, vehicle in enumerate(scenario.train.vehicles, start=1):
        for text in (_length(vehicle) or _mass(vehicle), _resistance(vehicle, speed),
                     *_envelope(vehicle)):
            if text:
                found.append((text, i))
    return found


def _length(vehicle: Vehicle) -> str:
    """A length outside its range (then its mass per length is not judged)."""
    usual = RANGES["vehicle_length"]
    if usual.holds(vehicle.length):
        return ""
    slip = (" — did you mean mm?" if usual.holds(vehicle.length / 1e3)
            else " — did you mean km?" if usual.holds(vehicle.length * 1e3) else "")
    return f"length = {vehicle.length:g} m for one vehicle (usual {usual.text()}){slip}"


def _train_findings(scenario: Scenario) -> list[tuple[str, int]]:
    usual = RANGES["train_length"]
    lengths = [vehicle.length for vehicle in scenario.train.vehicles]
    total = sum(lengths)
    if usual.holds(total) or not all(map(RANGES["vehicle_length"].holds, lengths)):
        return []
    return [(f"the train is {total:g} m long, longer than any train ever run (7.35 km; usual "
             f"{usual.text()})", 0)]


def _mass(vehicle: Vehicle) -> str:
    tonnes = vehicle.mass / 1e3
    per_m = tonnes / vehicle.length
    usual = RANGES["mass_per_length"]
    if usual.holds(per_m):
        return ""
    slip = " — did you mean kg?" if usual.holds(per_m / 1e3) else ""
    fix = f" ({tonnes:g} kg = {tonnes / 1e3:g} t)" if slip else ""
    return (f"mass_t = {tonnes:g}: {tonnes:g} t for one {vehicle.length:g} m vehicle "
            f"({per_m:.3g} t/m, usual {usual.text()}){slip}{fix}")


def _resistance(vehicle: Vehicle, speed: float) -> str:
    usual = RANGES["resistance"]
    a = float(vehicle.resistance_per_mass(speed))
    if usual.holds(a):
        return ""
    coeffs = np.array([vehicle.a0, vehicle.a1, vehicle.a2])
    to_si = GRAVITY / 1000 * np.array([1.0, 3.6, 3.6**2])   # N/kN with V in km/h -> SI
    slip = ""
    if usual.holds(_at(coeffs * to_si, speed)):
        slip = " — are these N/kN with V in km/h? Give them as davis_n_per_kn_kmh"
    elif usual.holds(_at(coeffs / to_si, speed)):
        slip = " — are these already SI (m/s², 1/s, 1/m)? Give them as davis_si"
    return (f"Davis resistance {a:.3g} m/s² at {speed * 3.6:.4g} km/h ({a / GRAVITY:.3g} g; "
            f"usual {usual.text()}){slip}")


def _at(coeffs: np.ndarray, speed: float) -> float:
    return float(coeffs[0] + coeffs[1] * speed + coeffs[2] * speed * speed)


def _envelope(vehicle: Vehicle) -> list[str]:
    env, mass = vehicle.envelope, vehicle.mass
    out = []
    traction = RANGES["traction"]
    strong = math.isfinite(env.max_traction) and not traction.holds(env.max_traction / 1e3)
    if strong:
        slip = " — did you mean N?" if traction.holds(env.max_traction / 1e6) else ""
        out.append(f"max_traction_kn = {env.max_traction / 1e3:g} for one vehicle (the "
                   f"strongest locomotives about 1200 kN; usual {traction.text()}){slip}")
    for key, value in (("max_traction_kn", env.max_traction), ("max_braking_kn", env.max_braking)):
        per_mass = value / mass
        if key == "max_traction_kn" and strong:
            continue   # one finding per key
        if math.isfinite(value) and not RANGES["force_per_mass"].holds(per_mass):
            slip = " — did you mean N?" if per_mass / 1e3 <= GRAVITY else ""
            out.append(f"{key} = {value / 1e3:g}: {per_mass / GRAVITY:.3g} g for "
                       f"{mass / 1e3:g} t (adhesion allows about 0.4 g){slip}")
    adhesion = RANGES["adhesion"]
    if math.isfinite(env.adhesion) and not adhesion.holds(env.adhesion):
        out.append(f"adhesion = {env.adhesion:g} (steel on steel: about 0.05 wet to 0.5 sanded; "
                   f"usual {adhesion.text().strip()})")
    for key, value in (("max_power_kw", env.max_power),
                       ("max_braking_power_kw", env.max_braking_power)):
        per_t = value / mass   # W/kg = kW/t
        usual = RANGES["power_per_mass"]
        if math.isfinite(value) and not usual.holds(per_t):
            slip = " — did you mean W?" if usual.holds(per_t / 1e3) else ""
            out.append(f"{key} = {value / 1e3:g}: {per_t:.4g} kW/t (usual {usual.text()}){slip}")
    return out


def _coupler_findings(scenario: Scenario) -> list[tuple[str, int]]:
    found: list[tuple[str, int]] = []
    vehicles = scenario.train.vehicles
    for i, coupler in enumerate(scenario.train.couplers, start=1):
        # The gap beyond the half-lengths (spacings set in Python may be shorter: no finding).
        gap = coupler.spacing - (vehicles[i - 1].length + vehicles[i].length) / 2.0
        if gap > RANGES["gap"].high:
            found.append((f"gap = {gap:g} m (usual {RANGES['gap'].text()}: trains within a "
                          "braking distance)", -i))
        if coupler.virtual:
            continue
        values = [
            ("stiffness_kn_per_m", coupler.stiffness / 1e3, RANGES["stiffness"], "N/m"),
            ("damping_kn_s_per_m", coupler.damping / 1e3, RANGES["damping"], "N·s/m"),
        ]
        if math.isfinite(coupler.max_force):
            values.append(("max_force_kn", coupler.max_force / 1e3, RANGES["max_force"], "N"))
        for key, value, usual, si in values:
            if usual.holds(value):
                continue
            slip = f" — did you mean {si}?" if usual.holds(value / 1e3) else ""
            fix = f" ({value:g} {si} = {value / 1e3:g} {usual.unit})" if slip else ""
            found.append((f"{key} = {value:g} (usual {usual.text()}){slip}{fix}", -i))
    return found


def _speed_findings(scenario: Scenario) -> list[tuple[str, int]]:
    usual = RANGES["speed"]
    found = []
    kmh = scenario.model.speed * 3.6
    if not usual.holds(kmh):
        found.append((f"[model] speed_kmh = {kmh:g} is faster than any wheel–rail train "
                      f"(record 574.8 km/h; usual {usual.text()})", 0))
    sim = scenario.simulation
    if sim is not None:
        top = max(sim.reference_speeds) * 3.6
        if not usual.holds(top):
            slip = (" — km/h given as [simulation.reference] speeds (m/s)? Use speeds_kmh"
                    if usual.holds(top / 3.6) else "")
            found.append((f"[simulation.reference] reaches {top:g} km/h (usual "
                          f"{usual.text()}){slip}", 0))
    return found


def _who(numbers: list[int]) -> str:
    """``"vehicle 1: "``, ``"vehicles 1–4: "``, ``"coupler 2: "`` or ``""``."""
    if numbers[0] == 0:
        return ""
    noun = "vehicle" if numbers[0] > 0 else "coupler"
    values = sorted(abs(x) for x in numbers)
    if len(values) == 1:
        return f"{noun} {values[0]}: "
    if values == list(range(values[0], values[-1] + 1)):
        return f"{noun}s {values[0]}–{values[-1]}: "
    return f"{noun}s {', '.join(str(v) for v in values)}: "
