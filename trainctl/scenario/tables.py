# The file tables of the train, the track and the top level, each key declared once.
"""Declarations of the scenario-file tables that are not settings classes.

The top level, ``[train]`` with its vehicle groups and couplers, and
``[track]`` with its sections are pydantic models whose fields are the file
keys, each declared once with its rule (:mod:`trainctl.declare.constraints`), unit,
converter to SI, default and documentation (:class:`~trainctl.declare.keys.Key`);
model validators hold the rules that span several keys. The domain objects
(:class:`~trainctl.models.vehicle.Vehicle`, ...) are built from validated
tables by :mod:`trainctl.scenario.parse`. The train and track tables are
:mod:`trainctl.scenario.train_tables`' (re-exported here); this module holds the
top level, ``[sweep]`` and the tables built per scenario (the controller
families, ``[expected]``).
"""

from __future__ import annotations

import functools
import typing
from collections.abc import Mapping
from typing import Annotated, Any

from pydantic import (
    ConfigDict,
    Field,
    GetCoreSchemaHandler,
    create_model,
    model_validator,
)
from pydantic_core import CoreSchema, core_schema

from trainctl.declare.constraints import (
    Choice,
    Integer,
    Number,
    Rule,
    Text,
    Violation,
    raise_at,
)
from trainctl.declare.keys import Key
from trainctl.declare.limits import MAX_VEHICLES
from trainctl.scenario.core import SCHEMA_VERSION
from trainctl.scenario.filemodel import (
    FileTable,
    Section,
)
from trainctl.scenario.train_tables import CouplerTable as CouplerTable
from trainctl.scenario.train_tables import SectionTable as SectionTable
from trainctl.scenario.train_tables import SpeedLimitTable as SpeedLimitTable
from trainctl.scenario.train_tables import TableRule as TableRule
from trainctl.scenario.train_tables import TrackTable as TrackTable
from trainctl.scenario.train_tables import TrainTable as TrainTable
from trainctl.scenario.train_tables import VehicleTable as VehicleTable

__all__ = [
    "MAX_VEHICLES",
    "CouplerTable",
    "SectionTable",
    "SpeedLimitTable",
    "SweepAxisTable",
    "SweepTable",
    "TableRule",
    "TopLevel",
    "TrackTable",
    "TrainTable",
    "VehicleTable",
    "expected_table",
    "family_table",
]

class ValueList(Rule):
    """A non-empty array of TOML values of any type (a sweep's list axis)."""

    def want(self, *, python: bool = False) -> str:
        """``"a non-empty array of values"``."""
        return "a non-empty array of values"

    def schema(self, handler: GetCoreSchemaHandler) -> CoreSchema:
        """A list of anything, at least one item."""
        return core_schema.list_schema(core_schema.any_schema(), min_length=1, strict=True)


_SWEEP_SCALES = ("linear", "log")
_SWEEP_DISTRIBUTIONS = ("uniform", "normal", "log-uniform")
_SWEEP_KINDS = {"values": ("values",), "grid": ("start", "stop", "num", "scale"),
                "random": ("distribution", "low", "high", "mean", "std")}


class SweepAxisTable(FileTable):
    """One axis of a sweep (``[[sweep.axis]]``): a list, a grid or random samples.

    Examples
    --------
    A logarithmic grid of three input weights, then an axis that mixes a
    list with a grid:

    >>> from pydantic import ValidationError
    >>> axis = SweepAxisTable.model_validate(
    ...     {"key": "controller.r_per_kn2", "start": 0.1, "stop": 10.0, "num": 3,
    ...      "scale": "log"})
    >>> axis.num, axis.scale, axis.values
    (3, 'log', None)
    >>> try:
    ...     SweepAxisTable.model_validate({"key": "seed", "values": [1, 2], "start": 0.0})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["msg"].split(":")[0])
    must be exactly one kind of axis
    """

    key: Annotated[str, Text(nonblank=True), Key(
        "File key path to vary, e.g. 'controller.r_per_kn2' or 'train.vehicle[1].mass_t'")]
    values: Annotated[list[Any] | None, ValueList(), Key(
        "List axis: the values in order, in the key's file unit")] = None
    start: Annotated[float | None, Number(), Key(
        "Grid axis: first value (file unit; > 0 for a log grid)")] = None
    stop: Annotated[float | None, Number(), Key(
        "Grid axis: last value, included (file unit; > 0 for a log grid)")] = None
    num: Annotated[int | None, Integer(ge=1), Key("Grid axis: number of values")] = None
    scale: Annotated[str | None, Choice(_SWEEP_SCALES), Key(
        "Grid axis: even spacing of the values or of their logarithms",
        omitted='"linear"')] = None
    distribution: Annotated[str | None, Choice(_SWEEP_DISTRIBUTIONS), Key(
        "Random axis: the distribution, drawn [sweep].samples times")] = None
    low: Annotated[float | None, Number(), Key(
        "Random axis, uniform and log-uniform: lower bound (log-uniform: > 0)")] = None
    high: Annotated[float | None, Number(), Key(
        "Random axis, uniform and log-uniform: upper bound, > low")] = None
    mean: Annotated[float | None, Number(), Key("Random axis, normal: mean")] = None
    std: Annotated[float | None, Number(gt=0), Key(
        "Random axis, normal: standard deviation")] = None

    @model_validator(mode="after")
    def _one_kind(self) -> SweepAxisTable:
        given = self.model_fields_set
        kinds = [kind for kind, keys in _SWEEP_KINDS.items() if given.intersection(keys)]
        if len(kinds) != 1:
            raise_at((), Violation(
                text="must be exactly one kind of axis: values (a list), start/stop/num (a "
                "grid) or distribution (random samples)",
                got_text=" and ".join(kinds) if kinds else "none of them", where=True,
                hint=" Give values = [...], or start/stop/num, or distribution = \"uniform\" "
                "with low/high."))
        kind = kinds[0]
        if kind == "grid":
            for name in ("start", "stop", "num"):
                if name not in given:
                    raise_at((), Violation(
                        text=f"missing required key {{{name}}}: a grid axis needs start, stop "
                        "and num", where=False))
        if kind == "random" and "distribution" not in given:
            raise_at((), Violation(
                text="missing required key {distribution}: low, high, mean and std belong "
                "to a random axis", where=False))
        return self


class SweepTable(FileTable):
    """A parameter sweep over the scenario (``[sweep]``).

    Examples
    --------
    Only repeating the scenario with four seeds (0 to 3), no axes:

    >>> sweep = SweepTable.model_validate({"seeds": 4})
    >>> sweep.seed, sweep.samples, sweep.seeds, sweep.axis
    (0, 1, 4, None)
    """

    seed: Annotated[int, Integer(ge=0), Key(
        "Seed of the random axes' draws (one stream per axis key)")] = 0
    samples: Annotated[int, Integer(ge=1), Key(
        "Joint draws of the random axes, each combined with every grid point")] = 1
    seeds: Annotated[int, Integer(ge=1), Key(
        "Repeat every point with the scenario seeds seed, seed + 1, ..., seed + seeds - 1 "
        "(the top-level seed)")] = 1
    axis: Annotated[list[SweepAxisTable] | None, Field(min_length=1), Key(
        "The axes: the grids and lists form a product, the first varying slowest",
        omitted="none (seeds > 1 only)")] = None


_SECTION = TableRule()


class TopLevel(FileTable):
    """The top level of a scenario file.

    Examples
    --------
    Sections are validated by their own tables later; here only the keys
    and the schema version are checked:

    >>> from pydantic import ValidationError
    >>> doc = {"schema_version": SCHEMA_VERSION, "name": "demo", "description": "A demo",
    ...        "train": {"preset": "crh2_half"}, "model": {"speed_kmh": 300}}
    >>> top = TopLevel.model_validate(doc)
    >>> top.name, top.seed, top.simulation
    ('demo', 0, None)
    >>> try:
    ...     TopLevel.model_validate({**doc, "schema_version": SCHEMA_VERSION + 1})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["loc"], exc.errors()[0]["msg"] == f"must be {SCHEMA_VERSION}")
    ('schema_version',) True
    """

    schema_version: Annotated[int, Integer(ge=1), Key(f"Must be {SCHEMA_VERSION}")]
    name: Annotated[str, Text(nonblank=True), Key(
        "Display name, any text (file names use its slug)")]
    description: Annotated[str, Text(single_line=True), Key(
        "One line, shown by trainctl list")]
    seed: Annotated[int, Integer(ge=0), Key("Random seed")] = 0
    train: Annotated[dict[str, Any], _SECTION, Section(TrainTable), Key(
        "The train: a preset, or vehicle groups and couplers")]
    track: Annotated[dict[str, Any] | None, _SECTION, Section(TrackTable), Key(
        "Grade and curvature", omitted="flat, straight track")] = None
    model: Annotated[dict[str, Any], _SECTION, Section(None), Key(
        "Linearisation and sampling")]
    controller: Annotated[dict[str, Any] | None, _SECTION, Section(None), Key(
        "Controller design(s): the primary family's keys, other families as sub-tables",
        omitted="no controller")] = None
    communication: Annotated[dict[str, Any] | None, _SECTION, Section(None), Key(
        "Communication graph of consensus controllers: who hears whom, who hears the "
        "reference", omitted="bidirectional chain, every vehicle hears the reference")] = None
    cost: Annotated[dict[str, Any] | None, _SECTION, Section(None), Key(
        "Prices of energy and train-hours, for each run's operating cost",
        omitted="no cost")] = None
    network: Annotated[dict[str, Any] | None, _SECTION, Section(None), Key(
        "Radio links of networked controllers: delays, losses, noise, outage windows",
        omitted="no network model")] = None
    simulation: Annotated[dict[str, Any] | None, _SECTION, Section(None), Key(
        "Closed-loop simulation run; needs [controller]", omitted="no simulation")] = None
    expected: Annotated[dict[str, Any] | None, _SECTION, Section(None), Key(
        "Declared status of the design checks", omitted="none declared")] = None
    sweep: Annotated[dict[str, Any] | None, _SECTION, Section(SweepTable), Key(
        "Parameter sweep: lists, grids and random samples over file keys, and seeds",
        omitted="no sweep")] = None

    @model_validator(mode="after")
    def _version(self) -> TopLevel:
        if self.schema_version != SCHEMA_VERSION:
            raise_at(("schema_version",), Violation(
                text=f"must be {SCHEMA_VERSION}", got=self.schema_version,
                hint=f" This trainctl release reads schema version {SCHEMA_VERSION} only."))
        return self


# Both tables are built per parse from the registry; building a pydantic model costs
# ~3 ms, half the validation time of a sweep point (measured: 300 points, 1.6 s), so the
# models are made once per set of names.
@functools.lru_cache(maxsize=32)
def family_table(names: tuple[str, ...], default: str) -> type[FileTable]:
    """The ``family`` key of ``[controller]``, for the registry's families ``names``."""
    family = Annotated[str, Choice(names), Key(
        "The primary controller family: the rest of [controller] holds its settings")]
    model = create_model(
        "ControllerFamily", __config__=ConfigDict(extra="ignore"), family=(family, default)
    )
    return typing.cast(type[FileTable], model)


def expected_table(checks: Mapping[str, str], statuses: tuple[str, ...]) -> type[FileTable]:
    """The ``[expected]`` table: one optional status key per check (name -> doc).

    Parameters
    ----------
    checks : mapping
        Check name to its documentation line.
    statuses : tuple of str
        The statuses a key may take.

    Returns
    -------
    type
        The table's model (made once per set of checks).

    Examples
    --------
    >>> from pydantic import ValidationError
    >>> Expected = expected_table({"sampling": "Sampling rate", "feasibility": "Feasible"},
    ...                           ("pass", "warn", "fail"))
    >>> Expected.model_validate({"sampling": "pass"})
    Expected(sampling='pass', feasibility=None)
    >>> try:
    ...     Expected.model_validate({"sampling": "ok"})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["msg"])
    must be one of 'pass', 'warn', 'fail'
    >>> Expected is expected_table({"sampling": "Sampling rate", "feasibility": "Feasible"},
    ...                            ("pass", "warn", "fail"))
    True
    """
    return _expected_table(tuple(checks.items()), tuple(statuses))


@functools.lru_cache(maxsize=32)
def _expected_table(checks: tuple[tuple[str, str], ...],
                    statuses: tuple[str, ...]) -> type[FileTable]:
    fields: dict[str, Any] = {
        name: (Annotated[str | None, Choice(statuses), Key(doc)], None)
        for name, doc in checks
    }
    return create_model("Expected", __base__=FileTable, **fields)
