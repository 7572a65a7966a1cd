# Real railway lines: TTOBench track files read as a trainctl Track with its stops.
"""Railway lines from TTOBench track files: grades, curves, speed limits and stops.

TTOBench (Kouzoupis et al., the train-trajectory-optimisation benchmark,
BSD 2-Clause; ``data/lines/SOURCE``) describes a line by a JSON document:
``metadata`` (``id`` and ``library version`` required), the ``stops`` (the
first at 0, the last the line's length), and lists of breakpoints, each the
start of a stretch that runs to the next: ``speed limits`` [position,
limit], ``gradients`` [position, slope] (optional: level) and ``curvatures``
[position, radius at start, radius at end] (optional: straight), every list
starting at 0 and ending before the line's end, each with its units.
:func:`read_line` reads such a file (any problem is a
:class:`~trainctl.exceptions.ScenarioError` naming the file and the key);
:func:`line_from_document` does the same for a parsed document.

Conversions (once, here): positions in m (or km), speeds in km/h (or m/s)
to m/s, slopes in ‰ as :class:`TrackSection` grades. The track's sections
start at every gradient and curvature breakpoint. A TTOBench curve whose
radius changes along it (a clothoid: its curvature κ = 1/R runs linearly from
start to end) becomes a section of constant radius with the same mean |κ|,
so the curve resistance (proportional to |κ| in both of trainctl's
formulas) does the same work over it: |κ_1 + κ_2| / 2 when both ends turn
the same way, (κ_1² + κ_2²) / (2 |κ_1 − κ_2|) when they turn opposite ways
(κ passes through zero inside). The sign of a radius (the turn's side) does
not enter the resistance.

:data:`LINES` names the lines shipped with trainctl (:func:`builtin_line`).

Examples
--------
>>> line = builtin_line("CH_Fribourg_Bern")
>>> round(line.length / 1000, 2), len(line.stops), line.track.speed_limit([0.0]).round(2).tolist()
(31.24, 2, [26.39])
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    StrictFloat,
    StrictInt,
    model_validator,
)

from trainctl._files import read_regular
from trainctl.declare.constraints import suggest
from trainctl.declare.jsonfile import read_json, validate_json
from trainctl.declare.violations import Violation, raise_at
from trainctl.exceptions import ScenarioError
from trainctl.models.track import SpeedLimit, Track, TrackSection
from trainctl.units import KMH_PER_MS

__all__ = ["LINES", "Line", "builtin_line", "line_from_document", "read_line"]

LINES = ("CH_Fribourg_Bern", "SE_Vasteras_Kolback")
"""The TTOBench lines shipped with trainctl (``trainctl/models/data/lines``)."""

_HINT = (" The format is TTOBench's (its README ships with trainctl: "
         "trainctl/models/data/lines/README.md).")

_LENGTH = {"m": 1.0, "km": 1000.0}
_SPEED = {"km/h": 1.0 / KMH_PER_MS, "m/s": 1.0}
_SLOPE = {"permil": 1.0, "permille": 1.0, "‰": 1.0}

Number = StrictFloat | StrictInt


def _radius_value(value: Any) -> Any:
    """A radius as TTOBench writes it: a number, or "infinity" (either sign) for straight."""
    if isinstance(value, str):
        if value.strip().lower() in ("infinity", "+infinity", "-infinity", "inf", "-inf"):
            return math.inf if not value.strip().startswith("-") else -math.inf
        raise ValueError('must be a number, or "infinity" for straight track')
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError('must be a number, or "infinity" for straight track')
    return float(value)


Radius = Annotated[float, BeforeValidator(_radius_value)]


class _Table(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True, frozen=True)


class _Metadata(BaseModel):
    model_config = ConfigDict(extra="allow", frozen=True)
    id: Annotated[str, Field(pattern=r"^[A-Za-z0-9_]+$")]
    library_version: Annotated[str, Field(alias="library version")]
    description: str = ""
    created_by: Annotated[str, Field(alias="created by")] = ""
    license: str = ""


class _Scalar(_Table):
    unit: Literal["m", "km"]
    value: Number


class _Stops(_Table):
    unit: Literal["m", "km"]
    values: Annotated[list[Number], Field(min_length=2)]


class _LimitUnits(_Table):
    position: Literal["m", "km"]
    velocity: Literal["km/h", "m/s"]


class _SlopeUnits(_Table):
    position: Literal["m", "km"]
    slope: Literal["permil", "permille", "‰"]


class _CurveUnits(_Table):
    position: Literal["m", "km"]
    radius_at_start: Annotated[Literal["m", "km"], Field(alias="radius at start")]
    radius_at_end: Annotated[Literal["m", "km"], Field(alias="radius at end")]


class _Limits(_Table):
    units: _LimitUnits
    values: Annotated[list[tuple[Number, Number]], Field(min_length=1)]


class _Slopes(_Table):
    units: _SlopeUnits
    values: Annotated[list[tuple[Number, Number]], Field(min_length=1)]


class _Curves(_Table):
    units: _CurveUnits
    values: Annotated[list[tuple[Number, Radius, Radius]], Field(min_length=1)]


class _Document(_Table):
    """A TTOBench track document, with the rules of its README."""

    metadata: _Metadata
    altitude: _Scalar | None = None
    stops: _Stops
    speed_limits: Annotated[_Limits, Field(alias="speed limits")]
    gradients: _Slopes | None = None
    curvatures: _Curves | None = None

    @model_validator(mode="after")
    def _positions(self) -> _Document:
        stops = self.stops.values
        _increasing(("stops", "values"), stops, first=True)
        length = stops[-1] * _LENGTH[self.stops.unit]
        lists: list[tuple[str, Any]] = [("speed limits", self.speed_limits)]
        if self.gradients is not None:
            lists.append(("gradients", self.gradients))
        if self.curvatures is not None:
            lists.append(("curvatures", self.curvatures))
        for key, table in lists:
            scale = _LENGTH[table.units.position]
            positions = [row[0] for row in table.values]
            _increasing((key, "values"), positions, first=True, index=0)
            last = positions[-1] * scale
            if not last < length:
                raise_at((key, "values", len(positions) - 1, 0), Violation(
                    f"must be before the line's end, the last stop at {length:g} m", got=last,
                    hint=" Each entry starts a stretch that runs to the next one or the end."),
                    positions[-1])
        for i, (_, limit) in enumerate(self.speed_limits.values):
            if not (math.isfinite(limit) and limit > 0):
                raise_at(("speed limits", "values", i, 1), Violation(
                    "must be a speed > 0", got=limit,
                    hint=" A stretch where trains may not run is not a speed limit."), limit)
        if self.curvatures is not None:
            scale = _LENGTH[self.curvatures.units.radius_at_start]
            for i, row in enumerate(self.curvatures.values):
                for j in (1, 2):
                    radius = row[j]
                    if not (math.isinf(radius) or abs(radius) * scale >= 10.0):
                        raise_at(("curvatures", "values", i, j), Violation(
                            "must be a radius of at least 10 m, or \"infinity\" for straight "
                            "track", got=radius), radius)
        return self


def _increasing(loc: tuple[str, ...], values: list[Any], *, first: bool,
                index: int | None = None) -> None:
    """Refuse values that do not start at 0 (``first``) or do not increase strictly."""
    def where(i: int) -> tuple[str | int, ...]:
        return (*loc, i) if index is None else (*loc, i, index)

    if first and values[0] != 0:
        raise_at(where(0), Violation("must be 0, the line's start", got=values[0]), values[0])
    for i in range(1, len(values)):
        if not values[i] > values[i - 1]:
            raise_at(where(i), Violation(
                f"must be greater than the previous position {values[i - 1]!r}",
                got=values[i], hint=" List the entries in track order."), values[i])


@dataclass(frozen=True, kw_only=True)
class Line:
    """A railway line: its track (grades, curves, speed limits) and stops.

    Parameters
    ----------
    name : str
        The line's identifier (TTOBench's ``metadata.id``).
    track : Track
        Grades, curves and speed limits, positions [m] from the line's start.
    stops : tuple of float
        Stop positions [m], the first 0 and the last the line's end.
    altitude : float
        Altitude at the line's start [m] (0 when the file gives none).
    source : str
        Where it was read from (a path, or ``"trainctl:NAME"`` for a shipped line).
    credit : str
        The file's ``created by`` and ``license``, to be cited with the line.
    digest : str
        SHA-256 of the file's bytes (:func:`read_line`; "" for a parsed document).

    Examples
    --------
    >>> line = builtin_line("SE_Vasteras_Kolback")
    >>> line.name, round(line.length), line.source
    ('SE_Vasteras_Kolback', 19305, 'trainctl:SE_Vasteras_Kolback')
    """

    name: str
    track: Track
    stops: tuple[float, ...]
    altitude: float = 0.0
    source: str = ""
    credit: str = ""
    digest: str = ""

    @property
    def length(self) -> float:
        """The line's length [m]: its last stop."""
        return self.stops[-1]


def _equivalent_radius(start: float, end: float) -> float:
    """The constant radius [m] with the mean |curvature| of a clothoid from ``start`` to
    ``end`` [m] (module docstring); inf for straight track."""
    if start == end:
        return abs(start)
    k1, k2 = 1.0 / start, 1.0 / end
    if k1 * k2 >= 0.0:
        mean = abs(k1 + k2) / 2.0
    else:
        mean = (k1 * k1 + k2 * k2) / (2.0 * abs(k1 - k2))
    return math.inf if mean == 0.0 else 1.0 / mean


def line_from_document(document: Any, *, source: str | Path) -> Line:
    """The :class:`Line` of a parsed TTOBench document.

    Parameters
    ----------
    document : object
        The parsed JSON document.
    source : str or pathlib.Path
        Where it came from (named in error messages and kept in :attr:`Line.source`).

    Returns
    -------
    Line
        The line; its track's formula is TB/T's (``"tbt"``).

    Raises
    ------
    ScenarioError
        When the document breaks TTOBench's rules: naming ``source`` and the key.

    Examples
    --------
    >>> doc = {"metadata": {"id": "demo", "library version": "TTOBench v1.1"},
    ...        "stops": {"unit": "m", "values": [0.0, 2000.0]},
    ...        "speed limits": {"units": {"position": "m", "velocity": "km/h"},
    ...                         "values": [[0.0, 90], [1500.0, 60]]},
    ...        "gradients": {"units": {"position": "m", "slope": "permil"},
    ...                      "values": [[0.0, 0.0], [500.0, 5.0]]}}
    >>> line = line_from_document(doc, source="demo.json")
    >>> [(s.start, s.grade_permille) for s in line.track.sections]
    [(0.0, 0.0), (500.0, 5.0)]
    >>> line.track.speed_limit([1000.0, 1500.0]).round(3).tolist()  # m/s
    [25.0, 16.667]
    >>> bad = {**doc, "speed limits": {"units": {"position": "m", "velocity": "mph"},
    ...                                 "values": [[0.0, 90]]}}
    >>> try:
    ...     line_from_document(bad, source="bad.json")
    ... except ScenarioError as exc:
    ...     print(exc)  # doctest: +ELLIPSIS
    bad.json: speed limits.units.velocity must be 'km/h' or 'm/s' (got 'mph', a string)...
    """
    path = Path(source)
    doc = validate_json(document, _Document, path, hint=_HINT)
    metres = _LENGTH[doc.stops.unit]
    stops = tuple(float(s) * metres for s in doc.stops.values)
    units = doc.speed_limits.units
    limits = tuple(SpeedLimit(start=float(p) * _LENGTH[units.position],
                              limit=float(v) * _SPEED[units.velocity])
                   for p, v in doc.speed_limits.values)
    grades: list[tuple[float, float]] = [(0.0, 0.0)]
    if doc.gradients is not None:
        scale = _LENGTH[doc.gradients.units.position]
        grades = [(float(p) * scale, float(g) * _SLOPE[doc.gradients.units.slope])
                  for p, g in doc.gradients.values]
    curves: list[tuple[float, float]] = [(0.0, math.inf)]
    if doc.curvatures is not None:
        cu = doc.curvatures.units
        scale, r1, r2 = _LENGTH[cu.position], _LENGTH[cu.radius_at_start], _LENGTH[cu.radius_at_end]
        curves = [(float(p) * scale, _equivalent_radius(a * r1, b * r2))
                  for p, a, b in doc.curvatures.values]
    sections = []
    for start in sorted({p for p, _ in grades} | {p for p, _ in curves}):
        grade = next(g for p, g in reversed(grades) if p <= start)
        radius = next(r for p, r in reversed(curves) if p <= start)
        sections.append(TrackSection(start=start, grade_permille=grade, curve_radius=radius))
    altitude = 0.0 if doc.altitude is None else float(doc.altitude.value) * _LENGTH[
        doc.altitude.unit]
    meta = doc.metadata
    credit = "; ".join(part for part in (meta.created_by, meta.license) if part)
    return Line(name=meta.id, track=Track(sections=tuple(sections), speed_limits=limits),
                stops=stops, altitude=altitude, source=str(source), credit=credit)


def read_line(path: str | Path) -> Line:
    """Read a TTOBench track file as a :class:`Line`.

    Parameters
    ----------
    path : str or pathlib.Path
        The JSON file.

    Returns
    -------
    Line
        The line (:func:`line_from_document`).

    Raises
    ------
    ScenarioError
        A missing or unreadable file, text that is not JSON, or a document
        that breaks TTOBench's rules: naming the file and the key.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     bad = Path(tmp) / "line.json"
    ...     _ = bad.write_text('{"stops": {"unit": "m", "values": [0, 10]}}')
    ...     try:
    ...         read_line(bad)
    ...     except ScenarioError as exc:
    ...         print(str(exc).split(": ", 1)[1].split(".")[0])
    missing required key 'metadata'
    """
    file = Path(path)
    line = line_from_document(read_json(file, hint=_HINT), source=file)
    try:
        digest = hashlib.sha256(read_regular(file)).hexdigest()
    except OSError as exc:  # gone between the two reads
        raise ScenarioError(f"{file}: cannot read the file again ({exc}).") from None
    return dataclasses.replace(line, digest=digest)


def builtin_line(name: str) -> Line:
    """A line shipped with trainctl (:data:`LINES`), from its TTOBench file.

    Parameters
    ----------
    name : str
        One of :data:`LINES`.

    Returns
    -------
    Line
        The line; its :attr:`~Line.source` is ``"trainctl:NAME"``.

    Raises
    ------
    ScenarioError
        For a name not in :data:`LINES`.

    Examples
    --------
    >>> builtin_line("CH_Fribourg_Bern").credit
    'Dimitris Kouzoupis; BSD 2-Clause License'
    """
    if name not in LINES:
        raise ScenarioError(f"builtin_line: no shipped line {name!r}.{suggest(name, LINES)} "
                            f"Shipped: {', '.join(LINES)}.")
    file = resources.files("trainctl.models") / "data" / "lines" / f"{name}.json"
    with resources.as_file(file) as path:
        line = read_line(path)
    return dataclasses.replace(line, source=f"trainctl:{name}")

