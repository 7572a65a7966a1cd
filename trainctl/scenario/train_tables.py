# The file tables of the train and the track, each key declared once.
"""Declarations of the ``[train]`` and ``[track]`` scenario-file tables.

``[train]`` with its vehicle groups (:class:`VehicleTable`) and couplers
(:class:`CouplerTable`), and ``[track]`` with its sections
(:class:`SectionTable`), are pydantic models whose fields are the file keys,
each declared once with its rule (:mod:`trainctl.declare.constraints`), unit,
converter to SI, default and documentation (:class:`~trainctl.declare.keys.Key`);
model validators hold the rules that span several keys. The domain objects
(:class:`~trainctl.models.vehicle.Vehicle`, ...) are built from validated
tables by :mod:`trainctl.scenario.parse`; the top level and the other tables
are :mod:`trainctl.scenario.tables`' (which re-exports these).
"""

from __future__ import annotations

from typing import Annotated, Any, ClassVar

from pydantic import (
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    TypeAdapter,
    model_validator,
)
from pydantic_core import CoreSchema, core_schema

from trainctl.declare.constraints import (
    Array,
    Choice,
    Flag,
    Integer,
    Number,
    Rule,
    Text,
    Violation,
    fail,
    raise_at,
)
from trainctl.declare.keys import Key
from trainctl.declare.limits import COUPLER_GAP, MAX_VEHICLES, VEHICLES_WHY, in_unit
from trainctl.models.lines import LINES
from trainctl.models.track import LIMIT_RULES, SECTION_RULES, TRACK_RULES
from trainctl.models.vehicle import COUPLER_RULES, ENVELOPE_RULES, VEHICLE_RULES
from trainctl.scenario.filemodel import (
    FileTable,
    convert,
    exactly_one,
    field_at,
    one_of_schema,
)
from trainctl.units import (
    davis_book_literal,
    davis_from_unit_resistance_kmh,
    kmh_to_ms,
    kn_per_m_to_n_per_m,
    kn_s_per_m_to_n_s_per_m,
    kn_to_n,
    kw_to_w,
    tonnes_to_kg,
)

__all__ = [
    "CouplerTable",
    "SectionTable",
    "SpeedLimitTable",
    "TableRule",
    "TrackTable",
    "TrainTable",
    "VehicleTable",
]

_ENVELOPE = {name: rule.for_file() for name, rule in ENVELOPE_RULES.items()}

DAVIS_KEYS = ("davis_n_per_kn_kmh", "davis_si", "davis_book_literal")
_DAVIS = Array(Number(ge=0), length=3)  # SI bounds: trainctl.declare.limits.DAVIS
_DAVIS_HINT = (" davis_n_per_kn_kmh is N/kN with V in km/h; davis_si is [a0 m/s², a1 1/s, "
               "a2 1/m].")


class TableRule(Rule):
    """A TOML table (its keys checked elsewhere).

    Examples
    --------
    >>> from pydantic import TypeAdapter, ValidationError
    >>> adapter = TypeAdapter(Annotated[Any, TableRule()])
    >>> adapter.validate_python({"speed_kmh": 300})
    {'speed_kmh': 300}
    >>> try:
    ...     adapter.validate_python([300])
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["msg"])
    must be a table
    """

    is_table = True

    def want(self, *, python: bool = False) -> str:
        """``"a table"``.

        Parameters
        ----------
        python : bool
            Word it for a Python caller; the wording is the same.

        Returns
        -------
        str
            ``"a table"``.
        """
        return "a table"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """A dict.

        Parameters
        ----------
        handler : pydantic.GetCoreSchemaHandler
            The handler pydantic passes to ``__get_pydantic_core_schema__``;
            unused here.

        Returns
        -------
        pydantic_core.CoreSchema
            A strict dict schema (its keys are checked by the file model).
        """
        return core_schema.dict_schema(strict=True)

    def json_extra(self) -> dict[str, Any]:
        """An object.

        Returns
        -------
        dict of str to object
            ``{"type": "object"}``.
        """
        return {"type": "object"}


class PresetName(Text):
    """A preset name of :data:`trainctl.models.presets.PRESETS` (checked when parsed)."""

    def json_extra(self) -> dict[str, Any]:
        """The presets as an enumeration."""
        from trainctl.models.presets import PRESETS

        return {"enum": sorted(PRESETS)}


class TableOrTables(Rule):
    """One table for every entry, or an array of tables (``model`` each)."""

    def __init__(self, model: type[FileTable]) -> None:
        self.model = model

    def want(self, *, python: bool = False) -> str:
        """``"a table or an array of tables"``."""
        return "a table or an array of tables"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """Anything; :meth:`check` dispatches on dict or list."""
        return core_schema.any_schema()

    def check(self, value: Any, info: Any) -> Any:
        """Validate the table, or each table of the array."""
        if isinstance(value, dict):
            return self.model.model_validate(value)
        if isinstance(value, list):
            return TypeAdapter(list[self.model]).validate_python(value)  # type: ignore[name-defined]
        raise fail(Violation(text=f"must be {self.want()}", got=value))

    def json_extra(self) -> dict[str, Any]:
        """The table's schema, or an array of it."""
        table = self.model.model_json_schema()
        return {"anyOf": [table, {"type": "array", "items": table}]}


class VehicleTable(FileTable):
    """A group of identical vehicles (``[[train.vehicle]]``).

    Examples
    --------
    Two CRH2 trailers of 42.8 t with their unit resistance in N/kN; exactly
    one of the three Davis keys must be given:

    >>> from pydantic import ValidationError
    >>> group = VehicleTable.model_validate(
    ...     {"name": "T", "count": 2, "mass_t": 42.8,
    ...      "davis_n_per_kn_kmh": [0.8806, 0.007444, 0.0001143]})
    >>> group.name, group.count, group.mass_t, group.length  # length [m]
    ('T', 2, 42.8, 25.0)
    >>> try:
    ...     VehicleTable.model_validate({"mass_t": 42.8})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["msg"])
    needs exactly one of davis_n_per_kn_kmh, davis_si, davis_book_literal
    """

    model_config = ConfigDict(**FileTable.model_config, json_schema_extra=one_of_schema(DAVIS_KEYS))
    one_of_keys: ClassVar[tuple[tuple[str, ...], ...]] = (DAVIS_KEYS,)

    name: Annotated[str, Text(), Key("Label, e.g. 'T' (trailer) or 'M' (motor coach)")] = (
        "vehicle"
    )
    count: Annotated[int, Integer(ge=1), Key("This many identical vehicles in a row")] = 1
    mass_t: Annotated[float, in_unit(VEHICLE_RULES["mass"], tonnes_to_kg), Key(
        "Mass", unit="t", to_si=tonnes_to_kg, si_unit="kg")]
    length: Annotated[float, VEHICLE_RULES["length"], Key("Length over couplers", unit="m")] = 25.0
    davis_n_per_kn_kmh: Annotated[tuple[float, ...] | None, _DAVIS, Key(
        "Unit running resistance c0 + c1 V + c2 V² (one of three Davis keys)",
        unit="N/kN, V in km/h", to_si=lambda c: davis_from_unit_resistance_kmh(*c),
        vector=True, si_text="c·g/1000, × 3.6, × 3.6² → a0, a1, a2")] = None
    davis_si: Annotated[tuple[float, ...] | None, _DAVIS, Key(
        "Davis coefficients per unit mass (one of three Davis keys)", unit="m/s², 1/s, 1/m",
        si_text="used as a0, a1, a2")] = None
    davis_book_literal: Annotated[tuple[float, ...] | None, _DAVIS, Key(
        "Coefficients as printed in the book (one of three Davis keys; reproduction only)",
        unit="as printed", to_si=lambda c: davis_book_literal(*c), vector=True,
        si_text="used literally as a0, a1, a2")] = None
    traction_share: Annotated[float, VEHICLE_RULES["traction_share"], Key(
        "Share of the cruise traction within its coupled group")] = 1.0
    max_traction_kn: Annotated[float | None, _ENVELOPE["max_traction"], Key(
        "Largest tractive force", unit="kN", to_si=kn_to_n, si_unit="N",
        omitted="no limit")] = None
    max_power_kw: Annotated[float | None, _ENVELOPE["max_power"], Key(
        "Largest traction power at the wheel", unit="kW", to_si=kw_to_w, si_unit="W",
        omitted="no limit")] = None
    max_braking_kn: Annotated[float | None, _ENVELOPE["max_braking"], Key(
        "Largest braking force", unit="kN", to_si=kn_to_n, si_unit="N",
        omitted="no limit")] = None
    max_braking_power_kw: Annotated[float | None, _ENVELOPE["max_braking_power"], Key(
        "Largest braking power", unit="kW", to_si=kw_to_w, si_unit="W",
        omitted="no limit")] = None
    adhesion: Annotated[float | None, _ENVELOPE["adhesion"], Key(
        "Adhesion coefficient mu", omitted="no limit")] = None

    @model_validator(mode="after")
    def _one_davis_key(self) -> VehicleTable:
        key = exactly_one(self, DAVIS_KEYS, _DAVIS_HINT)
        _davis_within_limits(self, key)
        return self


def _davis_within_limits(table: VehicleTable, key: str) -> None:
    """The Davis key's coefficients, converted to SI, within the hard limits (at ``key``).

    The limits hold in SI (:data:`trainctl.declare.limits.DAVIS`); a key in another unit
    is checked after its conversion, so that the message names the file key.
    """
    given = getattr(table, key)
    declared = field_at(VehicleTable, (key,))
    si = convert(given, declared.key if declared is not None else None)
    for name, value in zip(("a0", "a1", "a2"), si, strict=True):
        rule = VEHICLE_RULES[name]
        if not isinstance(rule, Number) or rule.le is None:
            continue
        bound = rule.le
        if not value <= bound:   # also catches an overflow to inf
            unit = {"a0": "m/s²", "a1": "1/s", "a2": "1/m"}[name]
            raise_at((key,), Violation(
                text=f"must give a Davis {name} <= {bound:g} {unit} in SI",
                got_text=f"{list(given)!r}, {name} = {value:.4g} {unit}",
                hint=f" {rule.why}"), list(given))


class CouplerTable(FileTable):
    """A coupler or virtual link (``[train.coupler]`` or ``[[train.coupler]]``).

    Examples
    --------
    A virtual link needs no stiffness and may not have a force limit:

    >>> from pydantic import ValidationError
    >>> CouplerTable.model_validate({"virtual": True}).stiffness_kn_per_m is None
    True
    >>> try:
    ...     CouplerTable.model_validate({"virtual": True, "max_force_kn": 100.0})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["loc"], exc.errors()[0]["msg"])
    ('max_force_kn',) must be omitted on a virtual link: it transmits no force
    """

    model_config = ConfigDict(**FileTable.model_config, json_schema_extra={
        "if": {"properties": {"virtual": {"const": True}}, "required": ["virtual"]},
        "then": {"properties": {"stiffness_kn_per_m": {"const": 0}},
                 "not": {"required": ["max_force_kn"]}},
        "else": {"required": ["stiffness_kn_per_m"],
                 "properties": {"stiffness_kn_per_m": {"exclusiveMinimum": 0}}},
    })

    stiffness_kn_per_m: Annotated[float | None,
                                  in_unit(COUPLER_RULES["stiffness"], kn_per_m_to_n_per_m), Key(
        "Spring stiffness k: > 0, required unless virtual (then 0 or omitted)", unit="kN/m",
        to_si=kn_per_m_to_n_per_m, si_unit="N/m")] = None
    damping_kn_s_per_m: Annotated[float, in_unit(COUPLER_RULES["damping"],
                                                 kn_s_per_m_to_n_s_per_m), Key(
        "Viscous damping d (0 when virtual)", unit="kN·s/m", to_si=kn_s_per_m_to_n_s_per_m,
        si_unit="N·s/m")] = 0.0
    virtual: Annotated[bool, Flag(), Key(
        "A virtual (communication-only) link: no force, the gap is kept by control")] = False
    gap: Annotated[float, COUPLER_GAP, Key(
        "Extra centre spacing beyond the two half-lengths", unit="m")] = 0.0
    max_force_kn: Annotated[float | None, in_unit(COUPLER_RULES["max_force"].for_file(), kn_to_n),
                            Key("Admissible coupler force |f|, judged on the simulated runs "
                                "(--strict); not allowed when virtual", unit="kN", to_si=kn_to_n,
                                si_unit="N", omitted="no limit")] = None

    @model_validator(mode="after")
    def _stiffness(self) -> CouplerTable:
        stiffness = self.stiffness_kn_per_m
        if stiffness is None and not self.virtual:
            raise_at((), Violation(
                text="missing required key {stiffness_kn_per_m} (a number > 0): a physical "
                "coupler needs a stiffness", where=False))
        bound = Number(ge=0) if self.virtual else Number(gt=0)
        if stiffness is not None and (stiffness < 0 or (stiffness == 0 and not self.virtual)):
            raise_at(("stiffness_kn_per_m",), Violation(
                text=f"must be {bound.want()}", got=stiffness,
                hint="" if self.virtual else " Set virtual = true for a link without coupling."))
        if self.virtual and self.max_force_kn is not None:
            raise_at(("max_force_kn",), Violation(
                text="must be omitted on a virtual link: it transmits no force",
                got=self.max_force_kn,
                hint=" Remove max_force_kn, or set virtual = false and give the coupler's "
                "stiffness_kn_per_m."))
        return self


class SectionTable(FileTable):
    """A stretch of constant grade and curvature (``[[track.section]]``).

    Examples
    --------
    A 5 ‰ climb from 1 km on; without a radius the section is straight:

    >>> section = SectionTable.model_validate({"start": 1000.0, "grade_permille": 5.0})
    >>> section.start, section.grade_permille, section.curve_radius
    (1000.0, 5.0, None)
    """

    start: Annotated[float, SECTION_RULES["start"], Key(
        "Where the section starts; it runs to the next section's start", unit="m")]
    grade_permille: Annotated[float, SECTION_RULES["grade_permille"], Key(
        "Grade, positive uphill", unit="‰")] = 0.0
    curve_radius: Annotated[float | None, SECTION_RULES["curve_radius"].for_file(), Key(
        "Curve radius", unit="m", omitted="straight track")] = None


class SpeedLimitTable(FileTable):
    """A speed restriction (``[[track.speed_limit]]``).

    Examples
    --------
    Trains may run at most 60 km/h from 2.5 km on (up to the next restriction):

    >>> limit = SpeedLimitTable.model_validate({"start": 2500.0, "limit_kmh": 60.0})
    >>> limit.start, limit.limit_kmh
    (2500.0, 60.0)
    """

    start: Annotated[float, LIMIT_RULES["start"], Key(
        "Where the restriction starts; it holds up to the next one's start", unit="m")]
    limit_kmh: Annotated[float, in_unit(LIMIT_RULES["limit"], kmh_to_ms), Key(
        "Largest speed allowed", unit="km/h")]


class TrackTable(FileTable):
    """Grade, curvature and speed limits along the line (``[track]``).

    The sections are given as ``[[track.section]]`` tables, or taken from a
    line: one shipped with trainctl (``line``, :data:`trainctl.models.lines.LINES`)
    or a TTOBench track file (``file``, read relative to the scenario file),
    with the line's speed limits. ``[[track.speed_limit]]`` tables give the
    limits (replacing a line's own).

    Examples
    --------
    >>> from pydantic import ValidationError
    >>> track = TrackTable.model_validate(
    ...     {"section": [{"start": 0.0}, {"start": 500.0, "curve_radius": 2000.0}]})
    >>> len(track.section), track.formula, track.wheelbase  # wheelbase [m]
    (2, 'tbt', 1.83)
    >>> try:
    ...     TrackTable.model_validate({"section": [{"start": 0.0}, {"start": 0.0}]})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["loc"], exc.errors()[0]["msg"])
    ('section', 1, 'start') must be greater than the previous section's start 0.0
    """

    formula: Annotated[str, TRACK_RULES["formula"], Key(
        "Line-resistance formula: TB/T unit resistances, or Ning et al. (2016) as printed"
    )] = "tbt"
    wheelbase: Annotated[float, TRACK_RULES["wheelbase"], Key(
        "Wheelset spacing, used by 'ning2016' for D = 0.5·wheelbase/R", unit="m")] = 1.83
    section: Annotated[list[SectionTable] | None, Field(min_length=1), Key(
        "Sections in track order, starts strictly increasing", omitted="a line's")] = None
    line: Annotated[str | None, Choice(LINES), Key(
        "A railway line shipped with trainctl (trainctl.models.lines)",
        omitted="sections or a file")] = None
    file: Annotated[str | None, Text(nonblank=True), Key(
        "A TTOBench track file (JSON), relative to the scenario file",
        omitted="sections or a line")] = None
    speed_limit: Annotated[list[SpeedLimitTable], Key(
        "Speed restrictions in track order, starts strictly increasing",
        omitted="the line's, or none")] = []

    @model_validator(mode="after")
    def _starts_increase(self) -> TrackTable:
        given = [k for k in ("section", "line", "file") if getattr(self, k) is not None]
        if len(given) != 1:
            raise_at(("section",) if not given else (given[1],), Violation(
                text="must be given, or 'line' or 'file' instead" if not given else
                f"cannot be given with {given[0]!r}",
                hint=" A track is [[track.section]] tables, a shipped line (line = ...) or "
                "a TTOBench file (file = ...): one of the three."))
        for i in range(1, len(self.speed_limit)):
            previous, start = self.speed_limit[i - 1].start, self.speed_limit[i].start
            if start <= previous:
                raise_at(("speed_limit", i, "start"), Violation(
                    text=f"must be greater than the previous restriction's start {previous!r}",
                    got=start, hint=" List speed limits in track order."))
        sections = self.section or []
        for i in range(1, len(sections)):
            previous, start = sections[i - 1].start, sections[i].start
            if start <= previous:
                raise_at(("section", i, "start"), Violation(
                    text=f"must be greater than the previous section's start {previous!r}",
                    got=start, hint=" List sections in track order."))
        return self


class TrainTable(FileTable):
    """The train (``[train]``): a preset, or vehicle groups and couplers.

    Examples
    --------
    A single coupler table applies to every link; an array must have one
    entry per link, n - 1 = 2 for three vehicles:

    >>> from pydantic import ValidationError
    >>> TrainTable.model_validate({"preset": "crh2_half"}).preset
    'crh2_half'
    >>> cars = [{"mass_t": 40.0, "davis_si": [0.01, 0.0, 0.0], "count": 3}]
    >>> train = TrainTable.model_validate(
    ...     {"vehicle": cars, "coupler": {"stiffness_kn_per_m": 1e4}})
    >>> type(train.coupler).__name__
    'CouplerTable'
    >>> try:
    ...     TrainTable.model_validate({"vehicle": cars, "coupler": [{"stiffness_kn_per_m": 1e4}]})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["msg"])
    [{coupler}] must have exactly 2 entries, one per link between 3 vehicles
    """

    model_config = ConfigDict(**FileTable.model_config, json_schema_extra={"oneOf": [
        {"required": ["preset"], "not": {"anyOf": [{"required": ["vehicle"]},
                                                   {"required": ["coupler"]}]}},
        {"required": ["vehicle"], "not": {"anyOf": [{"required": ["preset"]},
                                                    {"required": ["preset_options"]}]}},
    ]})

    preset: Annotated[str | None, PresetName(), Key(
        "A preset of trainctl.models.presets (instead of vehicles and couplers)")] = None
    preset_options: Annotated[dict[str, Any] | None, TableRule(), Key(
        "Keyword arguments of the preset function (names are checked)")] = None
    vehicle: Annotated[list[VehicleTable] | None, Field(min_length=1), Key(
        "Vehicle groups, head first (needed without a preset)")] = None
    coupler: Annotated[Any, TableOrTables(CouplerTable), Key(
        "One coupler for every link, or exactly n-1 couplers front to rear (n vehicles)")] = None

    @model_validator(mode="after")
    def _preset_or_vehicles(self) -> TrainTable:
        given = self.model_fields_set
        if self.preset is not None:
            for key in ("vehicle", "coupler"):
                if key in given:
                    raise_at(("preset",), Violation(
                        text=f"cannot be combined with {{{key}}}: give either a preset or "
                        "explicit vehicles"))
            return self
        if "preset_options" in given:
            raise_at(("preset_options",), Violation(text="needs {preset}", got_text="no preset"))
        if not self.vehicle:
            raise_at((), Violation(
                text="missing required key {preset} or {vehicle}: the train needs a preset "
                "name or at least one [{vehicle}] group", where=False))
        self._check_counts(self.vehicle)
        return self

    def _check_counts(self, groups: list[VehicleTable]) -> None:
        total = 0
        for i, group in enumerate(groups):
            if total + group.count > MAX_VEHICLES:
                raise_at(("vehicle", i, "count"), Violation(
                    text=f"makes the train longer than {MAX_VEHICLES} vehicles",
                    got_text=f"{group.count} after {total}", hint=f" {VEHICLES_WHY}"))
            total += group.count
        links = total - 1
        if self.coupler is None and links:
            raise_at((), Violation(
                text=f"missing required key {{coupler}}: a train of {total} vehicles needs a "
                f"{{coupler}} table or {links} [{{coupler}}] entries", where=False))
        if isinstance(self.coupler, list) and len(self.coupler) != links:
            raise_at((), Violation(
                text=f"[{{coupler}}] must have exactly {links} entries, one per link between "
                f"{total} vehicles", got=len(self.coupler), where=False,
                hint=" Use a single [train.coupler] table to apply one coupler to every link."))
