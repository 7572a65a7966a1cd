# Track geometry: grade and curvature as functions of position.
"""Track grade and curvature, and the line resistance they cause.

Two formulas for the additional resistance per unit mass are offered:

``"tbt"`` (default)
    The standard Chinese (TB/T) unit resistances: grade i‰ gives i N/kN and a
    curve of radius R [m] gives 600/R N/kN; converted with g/1000.
``"ning2016"``
    Seed 003's printed term per unit mass, 9.98·sin θ + 0.04·D, with
    θ = arctan(i/1000) and D = 0.5·wheelbase/R (Ning et al. 2016, eq. 3 as
    printed; 9.98 is the paper's constant, not g).

Positions are measured along the track in the direction of travel [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.declare.constraints import FINITE, POSITIVE, Choice, Rule
from trainctl.declare.keys import check_fields
from trainctl.declare.limits import CURVE_RADIUS, GRADE, SPEED
from trainctl.exceptions import ModelError
from trainctl.units import GRAVITY

__all__ = ["LIMIT_RULES", "RESISTANCE_FORMULAS", "SECTION_RULES", "TRACK_RULES", "SpeedLimit",
           "Track", "TrackSection"]

RESISTANCE_FORMULAS = ("tbt", "ning2016")
"""Names of the supported line-resistance formulas."""

SECTION_RULES: dict[str, Rule] = {
    "start": FINITE,
    "grade_permille": GRADE,
    "curve_radius": CURVE_RADIUS,
}
"""The rule of each :class:`TrackSection` field (also used by scenario files)."""

LIMIT_RULES: dict[str, Rule] = {"start": FINITE, "limit": SPEED}
"""The rule of each :class:`SpeedLimit` field."""

TRACK_RULES: dict[str, Rule] = {"formula": Choice(RESISTANCE_FORMULAS), "wheelbase": POSITIVE}
"""The rule of each :class:`Track` setting (also used by scenario files)."""


@dataclass(frozen=True, kw_only=True)
class TrackSection:
    """A stretch of track with constant grade and curvature.

    Parameters
    ----------
    start : float
        Position where the section starts [m]; it runs to the next section's start.
    grade_permille : float
        Grade [‰], positive uphill.
    curve_radius : float
        Curve radius [m], > 0; ``math.inf`` for straight track.

    Examples
    --------
    >>> TrackSection(start=0.0, grade_permille=-12.0).curve_radius
    inf
    """

    start: float
    grade_permille: float = 0.0
    curve_radius: float = math.inf

    def __post_init__(self) -> None:
        check_fields("TrackSection", self, SECTION_RULES)


@dataclass(frozen=True, kw_only=True)
class SpeedLimit:
    """A speed restriction from ``start`` to the next restriction's start.

    Parameters
    ----------
    start : float
        Position where the restriction starts [m].
    limit : float
        Largest speed allowed there [m/s], > 0.

    Examples
    --------
    >>> from trainctl.units import kmh_to_ms
    >>> round(SpeedLimit(start=413.6, limit=kmh_to_ms(110.0)).limit, 4)  # 110 km/h
    30.5556
    """

    start: float
    limit: float

    def __post_init__(self) -> None:
        check_fields("SpeedLimit", self, LIMIT_RULES)


@dataclass(frozen=True, kw_only=True)
class Track:
    """Piecewise-constant grade and curvature along the line.

    Parameters
    ----------
    sections : tuple of TrackSection
        Sections sorted by strictly increasing ``start``. Before the first
        section's start the first section applies.
    formula : {"tbt", "ning2016"}
        Line-resistance formula (module docstring).
    wheelbase : float
        Wheelset spacing used by ``"ning2016"`` for D = 0.5·wheelbase/R [m].
    speed_limits : tuple of SpeedLimit
        Speed restrictions sorted by strictly increasing ``start``; each holds
        up to the next one's start, the last one to the end of the line. No
        limit before the first one's start; none at all when empty.

    Examples
    --------
    >>> track = Track(sections=(TrackSection(start=0.0),
    ...                         TrackSection(start=1000.0, grade_permille=6.0)))
    >>> track.resistance_per_mass([500.0, 1500.0]).round(5).tolist()
    [0.0, 0.05886]
    """

    sections: tuple[TrackSection, ...] = field(default=(TrackSection(start=0.0),))
    formula: str = "tbt"
    wheelbase: float = 1.83
    speed_limits: tuple[SpeedLimit, ...] = ()

    def __post_init__(self) -> None:
        limits = [s.start for s in self.speed_limits]
        if any(b <= a for a, b in zip(limits, limits[1:], strict=False)):
            raise ModelError(
                f"Track: speed-limit starts must increase strictly (got {limits})."
            )
        if not self.sections:
            raise ModelError("Track: 'sections' must hold at least one TrackSection (got none).")
        starts = [s.start for s in self.sections]
        if any(b <= a for a, b in zip(starts, starts[1:], strict=False)):
            raise ModelError(
                f"Track: section starts must increase strictly (got {starts})."
            )
        check_fields("Track", self, TRACK_RULES)

    @property
    def is_flat(self) -> bool:
        """True when every section is level and straight."""
        return all(s.grade_permille == 0 and math.isinf(s.curve_radius) for s in self.sections)

    @cached_property
    def _section_arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        starts = np.array([s.start for s in self.sections])
        per_section = np.array([self._section_resistance(s) for s in self.sections])
        return starts, per_section

    def _section_resistance(self, section: TrackSection) -> float:
        grade = section.grade_permille
        radius = section.curve_radius
        if self.formula == "tbt":
            curve = 0.0 if math.isinf(radius) else 600.0 / radius
            return (grade + curve) * GRAVITY / 1000.0
        theta = math.atan(grade / 1000.0)
        curvature = 0.0 if math.isinf(radius) else 0.5 * self.wheelbase / radius
        return 9.98 * math.sin(theta) + 0.04 * curvature

    def _section_grade(self, section: TrackSection) -> float:
        """The grade part of :meth:`_section_resistance` [m/s²]."""
        if self.formula == "tbt":
            return section.grade_permille * GRAVITY / 1000.0
        return 9.98 * math.sin(math.atan(section.grade_permille / 1000.0))

    @cached_property
    def _integral_arrays(self) -> dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """Per part: each section's resistance per mass [m/s²] and its integral from the
        first section's start to the section's own start [J/kg]."""
        starts, total = self._section_arrays
        grade = np.array([self._section_grade(s) for s in self.sections])
        parts = {"all": total, "grade": grade, "curve": total - grade}
        lengths = np.diff(starts)
        return {name: (r, np.concatenate([[0.0], np.cumsum(r[:-1] * lengths)]))
                for name, r in parts.items()}

    def resistance_integral(self, position: ArrayLike, *, part: str = "all") -> NDArray[np.float64]:
        """Line resistance per unit mass integrated along the track [J/kg].

        R(p) = ∫ r(q) dq from the first section's start to p, in closed form:
        r is constant on each section, so R is piecewise linear, R(p) =
        R(start_j) + r_j (p - start_j) on section j (the first section extends
        backwards, the last forwards). The work a vehicle of mass m does
        against the line moving from p to p' is m (R(p') - R(p)), whatever its
        speed on the way.

        Parameters
        ----------
        position : array_like
            Positions along the track [m].
        part : {"all", "grade", "curve"}
            The whole line resistance, its grade part or its curve part (the
            whole minus the grade part). With ``"tbt"`` the grade part of a
            vehicle's work is its potential energy m g Δh with Δh = i/1000 Δp.

        Returns
        -------
        ndarray
            R(position) [J/kg = m²/s²], the shape of ``position``.

        Examples
        --------
        Level for 1 km, then 6 ‰ up: 500 m into the climb a tonne has gained
        1000 kg · 0.05886 m/s² · 500 m = 29.43 kJ.

        >>> track = Track(sections=(TrackSection(start=0.0),
        ...                         TrackSection(start=1000.0, grade_permille=6.0)))
        >>> (1000.0 * track.resistance_integral([500.0, 1500.0])).round(2).tolist()
        [0.0, 29430.0]
        """
        if part not in self._integral_arrays:
            raise ModelError(
                f"Track.resistance_integral: 'part' must be one of 'all', 'grade', 'curve' "
                f"(got {part!r})."
            )
        starts = self._section_arrays[0]
        per_section, at_start = self._integral_arrays[part]
        p = np.asarray(position, dtype=float)
        index = np.clip(np.searchsorted(starts, p, side="right") - 1, 0, len(starts) - 1)
        integral: NDArray[np.float64] = at_start[index] + per_section[index] * (p - starts[index])
        return integral

    def resistance_per_mass(self, position: ArrayLike) -> NDArray[np.float64]:
        """Grade plus curve resistance per unit mass at ``position`` [m/s²].

        Parameters
        ----------
        position : array_like
            Positions along the track [m].

        Returns
        -------
        ndarray
            Line resistance per unit mass [m/s²]; negative on down-grades.
        """
        starts, per_section = self._section_arrays
        index = np.searchsorted(starts, np.asarray(position, dtype=float), side="right") - 1
        return per_section[np.clip(index, 0, len(starts) - 1)]

    def speed_limit(self, position: ArrayLike) -> NDArray[np.float64]:
        """The speed limit at ``position`` [m/s]; inf where none applies.

        Parameters
        ----------
        position : array_like
            Positions along the track [m].

        Returns
        -------
        ndarray
            The limit of the restriction that holds there [m/s], the shape of
            ``position``; a restriction holds from its start up to (not
            including) the next one's start.

        Examples
        --------
        >>> track = Track(speed_limits=(SpeedLimit(start=0.0, limit=25.0),
        ...                             SpeedLimit(start=800.0, limit=15.0)))
        >>> track.speed_limit([-1.0, 0.0, 799.9, 800.0, 1e6]).tolist()
        [inf, 25.0, 25.0, 15.0, 15.0]
        """
        starts, limits = self._limit_arrays
        p = np.asarray(position, dtype=float)
        found: NDArray[np.float64] = limits[np.searchsorted(starts, p, side="right")]
        return found

    @cached_property
    def _limit_arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The restrictions' starts [m], and inf followed by their limits [m/s]."""
        starts = np.array([s.start for s in self.speed_limits], dtype=float)
        return starts, np.array([np.inf] + [s.limit for s in self.speed_limits])
