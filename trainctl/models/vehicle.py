# Vehicle and coupler parameters (SI units inside).
"""Vehicle, traction envelope and coupler parameters.

All quantities are SI: mass [kg], Davis resistance per unit mass a0 [m/s²],
a1 [1/s], a2 [1/m] with the speed in m/s, forces [N], powers [W], lengths
[m]. Paper units are converted by :mod:`trainctl.units` before they reach
these classes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.declare.constraints import NONNEGATIVE, Number, Rule
from trainctl.declare.keys import check_fields
from trainctl.declare.limits import (
    COUPLER_DAMPING,
    COUPLER_SPACING,
    COUPLER_STIFFNESS,
    DAVIS,
    LENGTH,
    MASS,
)
from trainctl.exceptions import ModelError
from trainctl.units import GRAVITY

__all__ = ["COUPLER_RULES", "ENVELOPE_RULES", "VEHICLE_RULES", "Coupler", "TractionEnvelope",
           "Vehicle", "envelope_limit"]

_FORCE_LIMIT = Number(ge=0, allow_inf=True)
_POWER_LIMIT = Number(gt=0, allow_inf=True)

ENVELOPE_RULES: dict[str, Rule] = {
    "max_traction": _FORCE_LIMIT,
    "max_power": _POWER_LIMIT,
    "max_braking": _FORCE_LIMIT,
    "max_braking_power": _POWER_LIMIT,
    "adhesion": _POWER_LIMIT,
}
"""The rule of each :class:`TractionEnvelope` field (also used by scenario files)."""

VEHICLE_RULES: dict[str, Rule] = {
    "mass": MASS,
    "a0": DAVIS["a0"],
    "a1": DAVIS["a1"],
    "a2": DAVIS["a2"],
    "length": LENGTH,
    "traction_share": NONNEGATIVE,
}
"""The rule of each numeric :class:`Vehicle` field (also used by scenario files)."""

COUPLER_RULES: dict[str, Rule] = {"stiffness": COUPLER_STIFFNESS, "damping": COUPLER_DAMPING,
                                  "spacing": COUPLER_SPACING,
                                  "max_force": Number(gt=0, allow_inf=True)}
"""The rule of each :class:`Coupler` field; a physical coupler's stiffness is also > 0."""

_MIN_SPEED = 0.1
"""Speed below which the power limit P/v is evaluated at this speed [m/s]."""


@dataclass(frozen=True, kw_only=True)
class TractionEnvelope:
    """Speed-dependent traction and braking limits of one vehicle.

    The available tractive force at speed v is
    min(max_traction, max_power / v, adhesion * m * g), and the available
    braking force min(max_braking, max_braking_power / v, adhesion * m * g).
    A limit of ``math.inf`` means "not limiting"; a force limit of 0 means the
    vehicle cannot produce that force (a trailer has ``max_traction = 0``).

    Parameters
    ----------
    max_traction : float
        Largest tractive force [N], >= 0.
    max_power : float
        Largest traction power at the wheel [W], > 0 (``inf`` = no limit).
    max_braking : float
        Largest braking force, as a positive number [N], >= 0.
    max_braking_power : float
        Largest braking power [W], > 0 (``inf`` = no limit).
    adhesion : float
        Adhesion coefficient mu [-], > 0 (``inf`` = no adhesion limit).

    Examples
    --------
    >>> env = TractionEnvelope(max_traction=80e3, max_power=1.2e6)
    >>> round(env.traction_limit(83.333, mass=48e3))
    14400
    """

    max_traction: float = math.inf
    max_power: float = math.inf
    max_braking: float = math.inf
    max_braking_power: float = math.inf
    adhesion: float = math.inf

    def __post_init__(self) -> None:
        check_fields("TractionEnvelope", self, ENVELOPE_RULES)

    @property
    def pins_force(self) -> bool:
        """True when the vehicle can produce no force at all: no traction and no braking
        (e.g. an unpowered wagon whose air brake a controller does not command)."""
        return self.max_traction == 0.0 and self.max_braking == 0.0

    def traction_limit(self, speed: ArrayLike, *, mass: float) -> NDArray[np.float64]:
        """Largest tractive force available at ``speed``.

        Parameters
        ----------
        speed : array_like
            Speed [m/s].
        mass : float
            Vehicle mass carried by the powered axles [kg], for adhesion.

        Returns
        -------
        ndarray
            Tractive force limit [N], >= 0, same shape as ``speed``.
        """
        return envelope_limit(speed, self.max_traction, self.max_power, self.adhesion, mass)

    def braking_limit(self, speed: ArrayLike, *, mass: float) -> NDArray[np.float64]:
        """Largest braking force (positive number) available at ``speed``.

        Parameters
        ----------
        speed : array_like
            Speed [m/s].
        mass : float
            Vehicle mass [kg], for adhesion.

        Returns
        -------
        ndarray
            Braking force limit [N], >= 0, same shape as ``speed``.
        """
        return envelope_limit(speed, self.max_braking, self.max_braking_power, self.adhesion, mass)


def envelope_limit(
    speed: ArrayLike, force: float | NDArray[np.float64], power: float | NDArray[np.float64],
    adhesion: float | NDArray[np.float64], mass: float | NDArray[np.float64],
) -> NDArray[np.float64]:
    """Force limit min(force, power / v, adhesion · mass · g) of an envelope at ``speed``.

    The function behind :meth:`TractionEnvelope.traction_limit` and
    :meth:`TractionEnvelope.braking_limit` (v below 0.1 m/s counts as 0.1 m/s).
    Elementwise numpy, so it also broadcasts over vehicles given per-vehicle arrays.

    Parameters
    ----------
    speed : array_like
        Speed [m/s].
    force, power, adhesion, mass : float or ndarray
        Force limit [N], power limit [W], adhesion coefficient [-] and mass [kg].

    Returns
    -------
    ndarray
        The limit [N], broadcast over the arguments.

    Examples
    --------
    >>> float(envelope_limit(83.333, 80e3, 1.2e6, float("inf"), 48e3).round())
    14400.0
    """
    v = np.maximum(np.abs(np.asarray(speed, dtype=float)), _MIN_SPEED)
    limit = np.minimum(force, power / v)
    envelope: NDArray[np.float64] = np.minimum(limit, adhesion * mass * GRAVITY)
    return envelope


@dataclass(frozen=True, kw_only=True)
class Vehicle:
    """One rigid vehicle (a coach, a locomotive, a wagon or a whole unit train).

    Parameters
    ----------
    mass : float
        Mass [kg], > 0.
    a0 : float
        Constant Davis resistance per unit mass [m/s²], >= 0.
    a1 : float
        Linear Davis coefficient per unit mass [1/s], >= 0 (v in m/s).
    a2 : float
        Quadratic Davis coefficient per unit mass [1/m], >= 0 (v in m/s).
    name : str
        Label, e.g. ``"T"`` for a trailer or ``"M"`` for a motor coach.
    length : float
        Length over couplers [m], > 0.
    traction_share : float
        Relative share of the train's cruise traction carried by this vehicle
        [-], >= 0. Trailers have 0; the equilibrium spreads the resistance of
        each physically coupled group over its vehicles in these proportions.
    envelope : TractionEnvelope
        Traction and braking limits.

    Examples
    --------
    >>> from trainctl.units import davis_from_unit_resistance_kmh
    >>> a0, a1, a2 = davis_from_unit_resistance_kmh(0.8806, 0.007444, 0.0001143)
    >>> car = Vehicle(mass=42.8e3, a0=a0, a1=a1, a2=a2)
    >>> round(float(car.resistance(300 / 3.6)))
    5627
    """

    mass: float
    a0: float
    a1: float
    a2: float
    name: str = "vehicle"
    length: float = 25.0
    traction_share: float = 1.0
    envelope: TractionEnvelope = field(default_factory=TractionEnvelope)

    def __post_init__(self) -> None:
        check_fields(f"Vehicle {self.name!r}", self, VEHICLE_RULES)

    def resistance_per_mass(self, speed: ArrayLike) -> NDArray[np.float64]:
        """Davis running resistance per unit mass a0 + a1 v + a2 v² [m/s²].

        Parameters
        ----------
        speed : array_like
            Speed [m/s], assumed >= 0 (forward running).

        Returns
        -------
        ndarray
            Resistance per unit mass [m/s²].
        """
        v = np.asarray(speed, dtype=float)
        resistance: NDArray[np.float64] = self.a0 + self.a1 * v + self.a2 * v * v
        return resistance

    def resistance(self, speed: ArrayLike) -> NDArray[np.float64]:
        """Davis running resistance force [N] at ``speed`` [m/s].

        Parameters
        ----------
        speed : array_like
            Speed [m/s], assumed >= 0 (forward running).

        Returns
        -------
        ndarray
            Resistance force m (a0 + a1 v + a2 v²) [N], the shape of
            ``speed``.
        """
        return self.mass * self.resistance_per_mass(speed)


@dataclass(frozen=True, kw_only=True)
class Coupler:
    """A link between two consecutive vehicles.

    A physical coupler is a linear spring-damper: the force on the front
    vehicle is -f and on the rear vehicle +f with f = k*delta + d*d(delta)/dt
    (tension positive), where delta is the elongation: the centre distance
    minus ``spacing``. A virtual link (virtual coupling, seed 002) transmits no
    force; its delta is the deviation of the gap from the desired one.

    Parameters
    ----------
    stiffness : float
        Spring stiffness k [N/m]; > 0 for a physical coupler, 0 for a virtual link.
    damping : float
        Viscous damping d [N·s/m], >= 0; 0 for a virtual link.
    spacing : float
        Nominal (force-free, or desired) centre-to-centre distance [m], > 0.
    virtual : bool
        True for a virtual (communication-only) link.
    max_force : float
        Admissible coupler force |f| [N], > 0 (``inf`` = no limit, the only
        value a virtual link takes). Simulations compare the coupler's force
        with it (:func:`trainctl.sim.compute_metrics`, ``--strict``); the
        controllers do not see it.

    Examples
    --------
    >>> Coupler(stiffness=10488e3, spacing=25.0).stiffness
    10488000.0
    >>> Coupler(stiffness=80e6, max_force=2250e3).max_force
    2250000.0
    """

    stiffness: float
    damping: float = 0.0
    spacing: float = 25.0
    virtual: bool = False
    max_force: float = math.inf

    def __post_init__(self) -> None:
        where = "Coupler"
        check_fields(where, self, COUPLER_RULES)
        stiffness, damping = float(self.stiffness), float(self.damping)
        object.__setattr__(self, "stiffness", stiffness)
        object.__setattr__(self, "damping", damping)
        object.__setattr__(self, "max_force", float(self.max_force))
        if self.virtual:
            if stiffness != 0.0 or damping != 0.0:
                raise ModelError(
                    f"{where}: a virtual link transmits no force, so 'stiffness' and "
                    f"'damping' must be 0 (got {stiffness!r}, {damping!r})."
                )
            if self.max_force != math.inf:
                raise ModelError(
                    f"{where}: a virtual link transmits no force, so 'max_force' must be "
                    f"inf (no limit) (got {self.max_force!r}). Leave it out, or make the "
                    "link physical (virtual=False) with a stiffness."
                )
        elif stiffness <= 0.0:
            raise ModelError(
                f"{where}: 'stiffness' must be > 0 for a physical coupler (got "
                f"{stiffness!r}). Use virtual=True for a link without coupling."
            )
