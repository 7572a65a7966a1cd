# Ready-made trains for the four seed systems.
"""Preset trains for seeds 000–003, SI units inside.

Each preset states where its numbers come from. Tags: *[book]* printed in
the source, *[reconstructed]* chosen here (the source is silent or lost),
*[recalled]* standard literature values not re-checked against a copy.

- :func:`crh2_half` — seed 000, Li & Zheng (2015) ch. 12: CRH2 half train,
  T-M-M-T, masses 42.8/48/46.5/42 t [book p.299], k = 10488 kN/m [book],
  Davis 0.8806/0.007444/0.0001143 [book] read as N/kN with V in km/h
  (default) or literally (``davis_reading="book_literal"``).
- :func:`crh2_8car` — seed 001, Zhao & Wang (2017): 8 cars, masses of seed 000
  mirrored, the CRH2C's 6M2T arrangement with 1200 kW per motor car (7.2 MW)
  [recalled], Davis per unit mass c0 = 0.01176 N/kg, c1 = 7.7616e-4 N·s/(m·kg),
  c2 = 1.6e-5 N·s²/(m²·kg) [recalled, widely reused HST values].
- :func:`heavy_haul_1p2p1` — seed 003, Ning et al. (2016): 1+2+1 combined
  train, 4 SS4B locomotives + 200 C80 wagons; four locomotive subsystems or
  the full 204-vehicle chain.
- :func:`virtual_formation` — seed 002 (2023 patent): n unit trains without
  physical coupling (virtual links with a desired gap).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from trainctl.exceptions import ModelError
from trainctl.models.train import Train
from trainctl.models.vehicle import Coupler, TractionEnvelope, Vehicle
from trainctl.units import (
    davis_book_literal,
    davis_from_unit_resistance_kmh,
    kn_per_m_to_n_per_m,
    kn_to_n,
    kw_to_w,
    tonnes_to_kg,
)

__all__ = ["PRESETS", "crh2_8car", "crh2_half", "heavy_haul_1p2p1", "virtual_formation"]

CRH2_DAVIS = (0.8806, 0.007444, 0.0001143)
"""Seed 000's printed Davis coefficients (book p.299), best read as N/kN, V in km/h."""

CRH2_STIFFNESS_KN_PER_M = 10488.0
"""Seed 000's coupler stiffness [kN/m] (book p.299)."""

CRH2_HALF_MASS_T = (42.8, 48.0, 46.5, 42.0)
"""Seed 000's coach masses [t] (book p.299)."""

LOCO_DAVIS_KMH = (2.25, 0.0190, 0.000320)
"""SS-series electric locomotive unit resistance [N/kN, V in km/h] [recalled]."""

WAGON_DAVIS_KMH = (0.92, 0.0048, 0.000125)
"""Loaded roller-bearing wagon unit resistance [N/kN, V in km/h] [recalled]."""

_DAVIS_READINGS: dict[str, Callable[[float, float, float], tuple[float, float, float]]] = {
    "n_per_kn_kmh": davis_from_unit_resistance_kmh,
    "book_literal": davis_book_literal,
}


def _crh2_coach(
    mass_t: float, motor: bool, davis: tuple[float, float, float], name: str
) -> Vehicle:
    # [reconstructed] 80 kN and 1.2 MW per motor coach (CRH2C: 7.2 MW over 6 motor
    # cars); 40 kN service braking per coach; trailers brake only.
    envelope = TractionEnvelope(
        max_traction=kn_to_n(80.0) if motor else 0.0,
        max_power=kw_to_w(1200.0) if motor else math.inf,
        max_braking=kn_to_n(40.0),
        max_braking_power=kw_to_w(1200.0) if motor else math.inf,
    )
    a0, a1, a2 = davis
    return Vehicle(
        name=name, mass=tonnes_to_kg(mass_t), a0=a0, a1=a1, a2=a2, length=25.0,
        traction_share=1.0 if motor else 0.0, envelope=envelope,
    )


def crh2_half(*, davis_reading: str = "n_per_kn_kmh") -> Train:
    """Seed 000's CRH2 half train: 4 coaches T-M-M-T.

    Parameters
    ----------
    davis_reading : {"n_per_kn_kmh", "book_literal"}
        How to read the printed Davis coefficients: as N/kN with V in km/h
        (physically plausible, default) or literally as SI numbers (the
        book's reproduction switch; 2.29 m/s² of resistance at 300 km/h).

    Returns
    -------
    Train
        4 coaches, 3 couplers of 10488 kN/m, no coupler damping.

    Examples
    --------
    >>> train = crh2_half()
    >>> train.mass.tolist(), train.traction_share.tolist()
    ([42800.0, 48000.0, 46500.0, 42000.0], [0.0, 1.0, 1.0, 0.0])
    """
    if davis_reading not in _DAVIS_READINGS:
        raise ModelError(
            f"crh2_half: 'davis_reading' must be one of {tuple(_DAVIS_READINGS)} "
            f"(got {davis_reading!r})."
        )
    davis = _DAVIS_READINGS[davis_reading](*CRH2_DAVIS)
    names = ("T1", "M2", "M3", "T4")
    coaches = tuple(
        _crh2_coach(m, name.startswith("M"), davis, name)
        for m, name in zip(CRH2_HALF_MASS_T, names, strict=True)
    )
    coupler = Coupler(stiffness=kn_per_m_to_n_per_m(CRH2_STIFFNESS_KN_PER_M), spacing=25.0)
    return Train(vehicles=coaches, couplers=(coupler,) * 3, name="CRH2 half train (T-M-M-T)")


def crh2_8car() -> Train:
    """Seed 001's 8-car high-speed train (reconstruction).

    Masses mirror seed 000's half train; motor arrangement T-M-M-M-M-M-M-T,
    the 300 km/h CRH2C's 6M2T with 7.2 MW, 1200 kW per motor car [recalled]
    (the CRH2A's 4M4T with 4.8 MW cannot hold 300 km/h against this
    resistance); Davis per unit mass a0 = 0.01176 m/s², a1 = 7.7616e-4 1/s,
    a2 = 1.6e-5 1/m [recalled]; couplers 10488 kN/m without damping.

    Returns
    -------
    Train
        8 cars, 7 couplers.

    Examples
    --------
    >>> crh2_8car().n_vehicles
    8
    """
    masses = CRH2_HALF_MASS_T + CRH2_HALF_MASS_T[::-1]
    kinds = "TMMMMMMT"
    davis = (0.01176, 0.00077616, 1.6e-5)
    cars = tuple(
        _crh2_coach(m, kind == "M", davis, f"{kind}{i + 1}")
        for i, (m, kind) in enumerate(zip(masses, kinds, strict=True))
    )
    coupler = Coupler(stiffness=kn_per_m_to_n_per_m(CRH2_STIFFNESS_KN_PER_M), spacing=25.0)
    return Train(vehicles=cars, couplers=(coupler,) * 7, name="CRH 8-car train")


def _mix_davis(parts: list[tuple[float, tuple[float, float, float]]]) -> tuple[float, float, float]:
    total = sum(m for m, _ in parts)
    return tuple(sum(m * c[i] for m, c in parts) / total for i in range(3))  # type: ignore[return-value]


def _ss4b_envelope() -> TractionEnvelope:
    # SS4B [recalled]: 6400 kW, ~628 kN starting tractive effort, ~380 kN rheostatic brake.
    return TractionEnvelope(
        max_traction=kn_to_n(628.0), max_power=kw_to_w(6400.0), max_braking=kn_to_n(380.0)
    )


def heavy_haul_1p2p1(*, detail: str = "subsystems", wagons_per_group: int = 100) -> Train:
    """Seed 003's 1+2+1 combined heavy-haul train (Ning et al. 2016).

    Formation: locomotive, 100 wagons, 2 locomotives, 100 wagons, locomotive
    (4 SS4B of 184 t [recalled], C80 wagons of 100 t gross [recalled]).

    Parameters
    ----------
    detail : {"subsystems", "full"}
        ``"subsystems"``: the paper's four locomotive subsystems, each one
        locomotive plus half of the adjacent wagon group (5184 t), joined by
        couplers of 2.5e7 N/m and 5e5 N·s/m [reconstructed]. ``"full"``: every
        vehicle, 204 in all, joined by the same couplers.
    wagons_per_group : int
        Wagons in each of the two wagon groups (100 in the paper), even, >= 2.

    Returns
    -------
    Train
        4 or 2*wagons_per_group + 4 vehicles.

    Examples
    --------
    >>> heavy_haul_1p2p1().mass.round().tolist()
    [5184000.0, 5184000.0, 5184000.0, 5184000.0]
    >>> heavy_haul_1p2p1(detail="full").n_vehicles
    204
    """
    if detail not in ("subsystems", "full"):
        raise ModelError(
            f"heavy_haul_1p2p1: 'detail' must be 'subsystems' or 'full' (got {detail!r})."
        )
    if (
        isinstance(wagons_per_group, bool)
        or not isinstance(wagons_per_group, int)
        or wagons_per_group < 2
        or wagons_per_group % 2
    ):
        raise ModelError(
            "heavy_haul_1p2p1: 'wagons_per_group' must be an even int >= 2 "
            f"(got {wagons_per_group!r})."
        )
    coupler = Coupler(stiffness=2.5e7, damping=5.0e5, spacing=12.0)
    loco_kmh = davis_from_unit_resistance_kmh(*LOCO_DAVIS_KMH)
    wagon_kmh = davis_from_unit_resistance_kmh(*WAGON_DAVIS_KMH)
    loco = Vehicle(name="SS4B", mass=184e3, a0=loco_kmh[0], a1=loco_kmh[1], a2=loco_kmh[2],
                   length=32.8, traction_share=1.0, envelope=_ss4b_envelope())
    wagon = Vehicle(name="C80", mass=100e3, a0=wagon_kmh[0], a1=wagon_kmh[1], a2=wagon_kmh[2],
                    length=12.0, traction_share=0.0,
                    envelope=TractionEnvelope(max_traction=0.0, max_braking=0.0))
    half = wagons_per_group // 2
    if detail == "full":
        order = (
            [loco] + [wagon] * wagons_per_group + [loco, loco] + [wagon] * wagons_per_group + [loco]
        )
        return Train(vehicles=tuple(order), couplers=(coupler,) * (len(order) - 1),
                     name="1+2+1 heavy-haul train (all vehicles)")
    mass = loco.mass + half * wagon.mass
    a = _mix_davis([
        (loco.mass, (loco.a0, loco.a1, loco.a2)),
        (half * wagon.mass, (wagon.a0, wagon.a1, wagon.a2)),
    ])
    group = Vehicle(name="SS4B+wagons", mass=mass, a0=a[0], a1=a[1], a2=a[2],
                    length=loco.length + half * wagon.length, traction_share=1.0,
                    envelope=_ss4b_envelope())
    link = Coupler(stiffness=2.5e7, damping=5.0e5, spacing=group.length)
    return Train(vehicles=(group,) * 4, couplers=(link,) * 3,
                 name="1+2+1 heavy-haul train (4 locomotive subsystems)")


def virtual_formation(*, n_trains: int = 4, gap: float = 500.0) -> Train:
    """Seed 002's virtually coupled heavy-haul unit trains.

    Each unit train is one point mass of 10 200 t, 1300 m long, with loaded
    wagon resistance 0.92 + 0.0048 V + 0.000125 V² N/kN [recalled] and one
    HXD1-class locomotive's envelope (700 kN, 9600 kW, 460 kN braking)
    [recalled]. Trains are joined by virtual links only.

    Parameters
    ----------
    n_trains : int
        Number of unit trains, >= 1.
    gap : float
        Desired gap between consecutive trains (tail to head) [m], > 0.

    Returns
    -------
    Train
        ``n_trains`` vehicles joined by virtual links of spacing 1300 m + gap.

    Examples
    --------
    >>> formation = virtual_formation(n_trains=3)
    >>> formation.virtual.tolist(), formation.spacing.tolist()
    ([True, True], [1800.0, 1800.0])
    """
    if isinstance(n_trains, bool) or not isinstance(n_trains, int) or n_trains < 1:
        raise ModelError(f"virtual_formation: 'n_trains' must be an int >= 1 (got {n_trains!r}).")
    if not (isinstance(gap, int | float) and math.isfinite(gap) and gap > 0):
        raise ModelError(f"virtual_formation: 'gap' must be a number > 0 [m] (got {gap!r}).")
    a0, a1, a2 = davis_from_unit_resistance_kmh(*WAGON_DAVIS_KMH)
    envelope = TractionEnvelope(
        max_traction=kn_to_n(700.0), max_power=kw_to_w(9600.0), max_braking=kn_to_n(460.0)
    )
    unit = Vehicle(name="unit train", mass=tonnes_to_kg(10200.0), a0=a0, a1=a1, a2=a2,
                   length=1300.0, traction_share=1.0, envelope=envelope)
    link = Coupler(stiffness=0.0, spacing=unit.length + float(gap), virtual=True)
    return Train(vehicles=(unit,) * n_trains, couplers=(link,) * (n_trains - 1),
                 name=f"{n_trains} virtually coupled unit trains")


PRESETS: dict[str, Callable[..., Train]] = {
    "crh2_half": crh2_half,
    "crh2_8car": crh2_8car,
    "heavy_haul_1p2p1": heavy_haul_1p2p1,
    "virtual_formation": virtual_formation,
}
"""Preset name → factory; scenario files select one with ``[train] preset``."""
