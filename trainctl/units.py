# Unit conversions from paper units to SI, applied once at the edge.
"""Named, tested converters from the units used in the sources to SI.

trainctl computes in SI units only (m, s, kg, N). Papers on Chinese railway
vehicles use tonnes, kN, km/h and the *unit resistance* w in N/kN, i.e.
newtons of resistance per kilonewton of vehicle weight. These functions are the
only place where such units are converted; scenario files call them when a key
name carries a unit (``mass_t``, ``speed_kmh``, ``stiffness_kn_per_m``).

The Davis (running-resistance) law per unit mass is

    a_R(v) = a0 + a1 v + a2 v**2    [m/s²], v in m/s,

with a0 [m/s²], a1 [1/s], a2 [1/m]. The Chinese form
w(V) = c0 + c1 V + c2 V**2 [N/kN] with V in km/h converts as
a0 = c0 g/1000, a1 = c1 g/1000 * 3.6, a2 = c2 g/1000 * 3.6**2.
"""

from __future__ import annotations

__all__ = [
    "GRAVITY",
    "JOULES_PER_KWH",
    "KMH_PER_MS",
    "davis_book_literal",
    "davis_from_unit_resistance_kmh",
    "davis_from_unit_resistance_ms",
    "j_to_kwh",
    "kg_per_s_to_t_per_h",
    "kmh_to_ms",
    "kn_per_m_to_n_per_m",
    "kn_s_per_m_to_n_s_per_m",
    "kn_to_n",
    "kw_to_w",
    "kwh_to_j",
    "ms_to_kmh",
    "n_to_kn",
    "permille_to_accel",
    "tonnes_to_kg",
    "unit_resistance_to_accel",
]

GRAVITY = 9.81
"""Standard gravity used for N/kN conversions [m/s²] (as in the sources)."""

KMH_PER_MS = 3.6
"""Kilometres per hour in one metre per second."""

JOULES_PER_KWH = 3.6e6
"""Joules in one kilowatt-hour."""


def kmh_to_ms(speed_kmh: float) -> float:
    """Convert a speed from km/h to m/s.

    Parameters
    ----------
    speed_kmh : float
        Speed [km/h].

    Returns
    -------
    float
        Speed [m/s].

    Examples
    --------
    >>> round(kmh_to_ms(300.0), 4)
    83.3333
    """
    return speed_kmh / KMH_PER_MS


def ms_to_kmh(speed: float) -> float:
    """Convert a speed from m/s to km/h.

    Parameters
    ----------
    speed : float
        Speed [m/s].

    Returns
    -------
    float
        Speed [km/h].

    Examples
    --------
    >>> ms_to_kmh(25.0)
    90.0
    """
    return speed * KMH_PER_MS


def tonnes_to_kg(mass_t: float) -> float:
    """Convert a mass from tonnes to kilograms.

    Parameters
    ----------
    mass_t : float
        Mass [t].

    Returns
    -------
    float
        Mass [kg].

    Examples
    --------
    >>> tonnes_to_kg(42.8)
    42800.0
    """
    return mass_t * 1000.0


def kn_to_n(force_kn: float) -> float:
    """Convert a force from kN to N.

    Parameters
    ----------
    force_kn : float
        Force [kN].

    Returns
    -------
    float
        Force [N].

    Examples
    --------
    >>> kn_to_n(5.5)
    5500.0
    """
    return force_kn * 1000.0


def n_to_kn(force: float) -> float:
    """Convert a force from N to kN.

    Parameters
    ----------
    force : float
        Force [N].

    Returns
    -------
    float
        Force [kN].

    Examples
    --------
    >>> n_to_kn(5500.0)
    5.5
    """
    return force / 1000.0


def kw_to_w(power_kw: float) -> float:
    """Convert a power from kW to W.

    Parameters
    ----------
    power_kw : float
        Power [kW].

    Returns
    -------
    float
        Power [W].

    Examples
    --------
    >>> kw_to_w(1200.0)
    1200000.0
    """
    return power_kw * 1000.0


def j_to_kwh(energy: float) -> float:
    """Convert an energy from J to kWh.

    Parameters
    ----------
    energy : float
        Energy [J].

    Returns
    -------
    float
        Energy [kWh].

    Examples
    --------
    >>> j_to_kwh(7.2e6)
    2.0
    """
    return energy / JOULES_PER_KWH


def kwh_to_j(energy_kwh: float) -> float:
    """Convert an energy from kWh to J.

    Parameters
    ----------
    energy_kwh : float
        Energy [kWh].

    Returns
    -------
    float
        Energy [J].

    Examples
    --------
    >>> kwh_to_j(0.5)
    1800000.0
    """
    return energy_kwh * JOULES_PER_KWH


def kg_per_s_to_t_per_h(flow: float) -> float:
    """Convert a mass flow from kg/s to tonnes per hour (3600 s/h over 1000 kg/t).

    Parameters
    ----------
    flow : float
        Mass flow [kg/s].

    Returns
    -------
    float
        Mass flow [t/h].

    Examples
    --------
    >>> kg_per_s_to_t_per_h(1000.0)
    3600.0
    """
    return flow * 3.6


def kn_per_m_to_n_per_m(stiffness_kn_per_m: float) -> float:
    """Convert a stiffness from kN/m to N/m.

    Parameters
    ----------
    stiffness_kn_per_m : float
        Stiffness [kN/m].

    Returns
    -------
    float
        Stiffness [N/m].

    Examples
    --------
    >>> kn_per_m_to_n_per_m(10488.0)
    10488000.0
    """
    return stiffness_kn_per_m * 1000.0


def kn_s_per_m_to_n_s_per_m(damping_kn_s_per_m: float) -> float:
    """Convert a viscous damping coefficient from kN·s/m to N·s/m.

    Parameters
    ----------
    damping_kn_s_per_m : float
        Damping coefficient [kN·s/m].

    Returns
    -------
    float
        Damping coefficient [N·s/m].

    Examples
    --------
    >>> kn_s_per_m_to_n_s_per_m(500.0)
    500000.0
    """
    return damping_kn_s_per_m * 1000.0


def unit_resistance_to_accel(w_n_per_kn: float) -> float:
    """Convert a unit resistance in N/kN to a specific force in m/s².

    A unit resistance of w N per kN of weight decelerates the vehicle by
    w * g / 1000.

    Parameters
    ----------
    w_n_per_kn : float
        Unit resistance [N/kN].

    Returns
    -------
    float
        Resistance per unit mass [m/s²].

    Examples
    --------
    >>> round(unit_resistance_to_accel(13.40), 4)
    0.1315
    """
    return w_n_per_kn * GRAVITY / 1000.0


def permille_to_accel(grade_permille: float) -> float:
    """Convert a grade in per mille to the Chinese-standard resistance in m/s².

    The TB/T convention takes the grade resistance as i N/kN for a grade of
    i per mille (small-angle approximation), so the specific force is
    i * g / 1000. Positive grades climb.

    Parameters
    ----------
    grade_permille : float
        Grade [‰], positive uphill.

    Returns
    -------
    float
        Grade resistance per unit mass [m/s²].

    Examples
    --------
    >>> permille_to_accel(12.0)
    0.11772
    """
    return unit_resistance_to_accel(grade_permille)


def davis_from_unit_resistance_kmh(
    c0: float, c1: float, c2: float
) -> tuple[float, float, float]:
    """Davis coefficients in SI from a unit resistance in N/kN with V in km/h.

    This is the usual Chinese form w = c0 + c1 V + c2 V**2 [N/kN], and the
    reading trainctl recommends for seed 000's printed coefficients.

    Parameters
    ----------
    c0 : float
        Constant term [N/kN].
    c1 : float
        Linear term [N/kN per km/h].
    c2 : float
        Quadratic term [N/kN per (km/h)²].

    Returns
    -------
    tuple of float
        ``(a0, a1, a2)`` with a0 [m/s²], a1 [1/s], a2 [1/m], for v in m/s.

    Examples
    --------
    >>> a0, a1, a2 = davis_from_unit_resistance_kmh(0.8806, 0.007444, 0.0001143)
    >>> v = kmh_to_ms(300.0)
    >>> round(a0 + a1 * v + a2 * v**2, 4)
    0.1315
    """
    scale = GRAVITY / 1000.0
    return (c0 * scale, c1 * scale * KMH_PER_MS, c2 * scale * KMH_PER_MS**2)


def davis_from_unit_resistance_ms(
    c0: float, c1: float, c2: float
) -> tuple[float, float, float]:
    """Davis coefficients in SI from a unit resistance in N/kN with v in m/s.

    Parameters
    ----------
    c0 : float
        Constant term [N/kN].
    c1 : float
        Linear term [N/kN per m/s].
    c2 : float
        Quadratic term [N/kN per (m/s)²].

    Returns
    -------
    tuple of float
        ``(a0, a1, a2)`` with a0 [m/s²], a1 [1/s], a2 [1/m].

    Examples
    --------
    >>> davis_from_unit_resistance_ms(1000.0, 0.0, 0.0)[0]
    9.81
    """
    scale = GRAVITY / 1000.0
    return (c0 * scale, c1 * scale, c2 * scale)


def davis_book_literal(c0: float, c1: float, c2: float) -> tuple[float, float, float]:
    """Davis coefficients taken literally as SI numbers (reproduction switch).

    Seed 000 prints its coefficients as "N/kN/kg" etc.; read naively as
    m/s², 1/s and 1/m they give 2.29 m/s² of resistance at 300 km/h, which is
    physically impossible (0.23 g). trainctl keeps this reading only so that
    the book's numbers can be reproduced; it is never a default.

    Parameters
    ----------
    c0 : float
        Constant term, used as a0 [m/s²].
    c1 : float
        Linear term, used as a1 [1/s].
    c2 : float
        Quadratic term, used as a2 [1/m].

    Returns
    -------
    tuple of float
        ``(c0, c1, c2)`` unchanged, as floats.

    Examples
    --------
    >>> a0, a1, a2 = davis_book_literal(0.8806, 0.007444, 0.0001143)
    >>> v = kmh_to_ms(300.0)
    >>> round(a0 + a1 * v + a2 * v**2, 3)
    2.295
    """
    return (float(c0), float(c1), float(c2))
