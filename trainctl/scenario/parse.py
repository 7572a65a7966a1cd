# parse_scenario: validate each table with its declaration, build the SI objects.
"""Parse scenario TOML text into a :class:`~trainctl.scenario.Scenario`.

The document is validated table by table, in file order: the top level,
``[train]``, ``[track]``, ``[model]``, ``[controller]`` (its family from the
registry, at parse time), ``[communication]``, ``[network]`` (its vehicle
indices checked against the train), ``[simulation]``, ``[expected]`` and
``[sweep]`` (:mod:`trainctl.sweep`; its points are validated when the sweep
runs, not here). Tables that
depend on earlier ones get them through the validation context: the number
of coaches, the sample time, the strategies and checks of the controller
families present. The first error becomes a ScenarioError with its key path
(:mod:`trainctl.scenario.errors`).
"""

from __future__ import annotations

import functools
import inspect
import math
import os
import tomllib
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Literal, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError, create_model

from trainctl.declare.constraints import Violation, suggest
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.models.network.schema import NetworkSettings
from trainctl.models.track import SpeedLimit, Track, TrackSection
from trainctl.models.train import Train
from trainctl.models.vehicle import Coupler, TractionEnvelope, Vehicle
from trainctl.scenario.communication import CommunicationSettings
from trainctl.scenario.core import (
    FrozenMapping,
    Scenario,
    check_names,
    check_statuses,
    expectation_violation,
    strategy_names,
)
from trainctl.scenario.cost import CostSettings
from trainctl.scenario.errors import DocumentTable, describe, got, scenario_error
from trainctl.scenario.filemodel import FileTable, convert, field_at, file_model, load_settings
from trainctl.scenario.settings import ModelSettings, SimulationSettings
from trainctl.scenario.tables import (
    SweepAxisTable,
    SweepTable,
    TopLevel,
    expected_table,
    family_table,
)
from trainctl.scenario.train_tables import (
    DAVIS_KEYS,
    CouplerTable,
    SectionTable,
    SpeedLimitTable,
    TrackTable,
    TrainTable,
    VehicleTable,
)
from trainctl.units import kmh_to_ms

__all__ = ["MAX_TEXT_BYTES", "check_size", "load_toml", "parse_document", "parse_scenario"]

_T = TypeVar("_T")


MAX_TEXT_BYTES = 4 * 1024 * 1024
"""Largest scenario text trainctl reads [bytes] (the built-ins are under 10 kB; a train of
:data:`~trainctl.declare.limits.MAX_VEHICLES` vehicles written one table each stays under 2 MB)."""


def load_toml(text: str, source: str) -> dict[str, Any]:
    """The TOML document, or ScenarioError naming the syntax error (or the size or depth).

    Parameters
    ----------
    text : str
        The scenario file's text.
    source : str
        Where the text comes from, for messages.

    Returns
    -------
    dict
        The parsed document.

    Examples
    --------
    >>> try:
    ...     load_toml("a = " + "[" * 5000 + "]" * 5000, "deep.toml")
    ... except ScenarioError as exc:
    ...     print(str(exc).split(" (")[0])
    deep.toml: not valid TOML: nested too deeply
    """
    check_size(len(text.encode("utf-8", "surrogatepass")), source)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}.") from None
    except RecursionError:
        raise ScenarioError(f"{source}: not valid TOML: nested too deeply (arrays or inline "
                            "tables inside each other, thousands of levels).") from None


def check_size(size: int, source: str) -> None:
    """Refuse scenario text over :data:`MAX_TEXT_BYTES` bytes (ScenarioError).

    Parameters
    ----------
    size : int
        The text's size [bytes].
    source : str
        Where the text comes from, for the message.

    Raises
    ------
    ScenarioError
        If ``size`` exceeds :data:`MAX_TEXT_BYTES`.

    Examples
    --------
    A few kilobytes pass silently; one byte over the 4 MiB = 4194304 bytes
    limit is refused:

    >>> check_size(4096, "demo.toml")
    >>> check_size(4 * 2**20 + 1, "demo.toml")
    Traceback (most recent call last):
        ...
    trainctl.exceptions.ScenarioError: demo.toml: is too large for a scenario file (more than \
4194304 bytes, 4 MiB). Scenario files describe a train in kilobytes; give the right file.
    """
    if size > MAX_TEXT_BYTES:
        raise ScenarioError(
            f"{source}: is too large for a scenario file (more than {MAX_TEXT_BYTES} bytes, "
            f"{MAX_TEXT_BYTES // 2**20} MiB). Scenario files describe a train in kilobytes; "
            "give the right file.")


def parse_scenario(text: str, *, source: str = "<string>",
                   directory: str | os.PathLike[str] | None = None) -> Scenario:
    """Parse scenario TOML text.

    Parameters
    ----------
    text : str
        The TOML document.
    source : str
        Label used in error messages and stored as ``Scenario.source``.
    directory : str or os.PathLike or None
        Where relative paths in the file (``[track].file``) are read from;
        None: the directory of ``source`` when it names a file, else the
        working directory.

    Returns
    -------
    Scenario
        The scenario, SI inside.

    Raises
    ------
    ScenarioError
        If the text is not TOML or does not follow the schema.

    Examples
    --------
    >>> text = '''
    ... schema_version = 1
    ... name = "Two coaches"
    ... description = "Smallest coupled train"
    ... [train]
    ... vehicle = [{mass_t = 40.0, count = 2, davis_si = [0.01, 0.0, 1e-5]}]
    ... coupler = {stiffness_kn_per_m = 10000.0}
    ... [model]
    ... speed_kmh = 90.0
    ... sample_time = 0.5
    ... '''
    >>> scenario = parse_scenario(text)
    >>> scenario.train.stiffness.tolist(), scenario.model.speed
    ([10000000.0], 25.0)
    >>> scenario.controller is None, dict(scenario.expected)
    (True, {})

    A controller design, a second controller family and the expected
    outcome of their checks:

    >>> text += '''
    ... [controller]
    ... form = "du"
    ... prediction_horizon = 4
    ... control_horizon = 2
    ... r_per_n2 = 1e-5
    ... [controller.lqr]
    ... r_per_kn2 = 1.0
    ... [expected]
    ... ndmpc_convergence = "pass"
    ... '''
    >>> scenario = parse_scenario(text)
    >>> scenario.controller.input_weight_per_kn2(), scenario.controller.neighbourhoods(2)
    (10.0, ((0, 1), (0, 1)))
    >>> list(scenario.controllers), scenario.controllers["lqr"].input_bounds
    (['mpc', 'lqr'], True)
    >>> scenario.expected["ndmpc_convergence"]
    'pass'
    """
    if not isinstance(text, str):
        raise TypeError(f"parse_scenario: 'text' must be a str (got {type(text).__name__}).")
    from trainctl.scenario.tags import source_tags

    return _Parser(source, load_toml(text, source), source_tags(text),
                   _directory(source, directory)).scenario()


def _directory(source: str, directory: str | os.PathLike[str] | None) -> str | None:
    """The directory of a file's relative paths (:func:`parse_scenario`)."""
    if directory is not None:
        return os.fspath(directory)
    path = Path(source)
    try:
        return str(path.resolve().parent) if path.is_file() else None
    except (OSError, ValueError):  # a label that is no path
        return None


def parse_document(document: dict[str, Any], *, source: str = "<string>",
                   tags: Mapping[str, str] | None = None,
                   directory: str | os.PathLike[str] | None = None) -> Scenario:
    """Parse a scenario from its TOML document (the dict ``tomllib`` gives).

    Parameters
    ----------
    document : dict
        The document: tables as dicts, arrays as lists.
    source : str
        Label used in error messages and stored as ``Scenario.source``.
    tags : mapping of str to str or None
        Source tags of the values by file key path (``Scenario.tags``; a
        document has no comments to read them from).
    directory : str or os.PathLike or None
        As for :func:`parse_scenario`.

    Returns
    -------
    Scenario
        The scenario, SI inside, with ``document`` kept.

    Raises
    ------
    ScenarioError
        If the document does not follow the schema.

    Examples
    --------
    >>> import tomllib
    >>> from trainctl.scenario import builtin_scenario_text
    >>> doc = tomllib.loads(builtin_scenario_text("crh2-dmpc"))
    >>> parse_document(doc, source="mine").model.sample_time
    20.0
    """
    if not isinstance(document, dict):
        raise TypeError(f"parse_document: 'document' must be a dict (got "
                        f"{type(document).__name__}).")
    return _Parser(source, document, tags, _directory(source, directory)).scenario()


class _Parser:
    """One document being parsed: its label, its TOML data and the error context."""

    def __init__(self, file: str, doc: dict[str, Any],
                 tags: Mapping[str, str] | None = None, directory: str | None = None) -> None:
        self.file, self.doc, self.directory = file, doc, directory
        self.track_digest: str | None = None
        self.line_stops: tuple[float, ...] | None = None
        self.tags = FrozenMapping(tags or {})

    def validate(self, model: type[BaseModel], prefix: tuple[Any, ...], data: Any = None,
                 **extra: Any) -> Any:
        """Validate the table at ``prefix`` (or ``data`` found there) with a file model."""
        if data is None:
            data = self.doc
            for part in prefix:
                data = data[part]
        try:
            return model.model_validate(data, context=extra.pop("context", None))
        except ValidationError as exc:
            raise scenario_error(self.file, exc, doc=self.doc, prefix=prefix, model=model,
                                 **extra) from None

    def settings(self, cls: type, table: Mapping[str, Any], prefix: tuple[Any, ...],
                 context: dict[str, Any], extra_keys: tuple[str, ...] = ()) -> Any:
        """Validate a table with a settings class (its file model, then its rules)."""
        try:
            return load_settings(cls, table, context)
        except ValidationError as exc:
            raise scenario_error(self.file, exc, doc=self.doc, prefix=prefix,
                                 model=file_model(cls), settings=cls,
                                 extra_keys=extra_keys) from None

    def fail(self, violation: Violation, prefix: tuple[Any, ...], loc: tuple[Any, ...] = (),
             model: type[BaseModel] | None = None) -> ScenarioError:
        """The ScenarioError of a violation found by the parser itself."""
        table = DocumentTable(self.doc, prefix, model, None)
        return ScenarioError(f"{self.file}: {describe(violation, table, loc)}")

    def build(self, loc: tuple[Any, ...], make: Callable[[], _T],
              catch: tuple[type[Exception], ...] = (ModelError,)) -> _T:
        """Call ``make``; a model-level error becomes a ScenarioError at ``loc``."""
        try:
            return make()
        except ScenarioError:
            raise
        except catch as exc:
            where = DocumentTable(self.doc, loc, None, None).path(())
            raise ScenarioError(f"{self.file}: {where}: {exc}" if where
                                else f"{self.file}: {exc}") from exc

    def scenario(self) -> Scenario:
        """Validate every table in order and build the scenario."""
        top = self.validate(TopLevel, ())
        train = self.train()
        track = None if top.track is None else self.track()
        model = self.settings(ModelSettings, top.model, ("model",), {})
        controllers = self.controllers(top.controller, train.n_vehicles)
        communication = None if top.communication is None else self.settings(
            CommunicationSettings, top.communication, ("communication",), {})
        cost = None if top.cost is None else self.settings(CostSettings, top.cost, ("cost",), {})
        network = None if top.network is None else self.settings(
            NetworkSettings, top.network, ("network",), {"n_vehicles": train.n_vehicles})
        simulation = self.simulation(top.simulation, model.sample_time, tuple(controllers),
                                     train, track)
        expected = self.expected(top.expected, tuple(controllers))
        sweep = None if top.sweep is None else self.sweep()
        return self.build((), lambda: Scenario(
            name=top.name, description=top.description, seed=top.seed, train=train,
            track=track, model=model, controllers=FrozenMapping(controllers),
            communication=communication, cost=cost, network=network, simulation=simulation,
            expected=expected, sweep=sweep,
            source=self.file, document=self.doc, tags=self.tags, directory=self.directory,
            track_digest=self.track_digest,
        ))

    def train(self) -> Train:
        """``[train]``: a preset, or vehicle groups and couplers."""
        table: TrainTable = self.validate(TrainTable, ("train",))
        if table.preset is not None:
            return self.preset(table)
        vehicles: list[Vehicle] = []
        for i, group in enumerate(table.vehicle or ()):
            vehicle = self.build(("train", "vehicle", i), functools.partial(_vehicle, group))
            vehicles += [vehicle] * group.count
        couplers = []
        for i in range(len(vehicles) - 1):
            link = table.coupler
            loc: tuple[Any, ...] = ("train", "coupler")
            if isinstance(link, list):
                link, loc = link[i], (*loc, i)
            front, rear = vehicles[i].length, vehicles[i + 1].length
            couplers.append(self.build(loc, functools.partial(_coupler, link, front, rear)))
        return self.build(("train",), lambda: Train(
            vehicles=tuple(vehicles), couplers=tuple(couplers), name=_formation(vehicles)))

    def preset(self, table: TrainTable) -> Train:
        """A preset train, called with the checked ``[train.preset_options]``."""
        name = table.preset or ""
        try:
            from trainctl.models.presets import PRESETS
        except ImportError as exc:
            raise ScenarioError(f"{self.file}: [train].preset: presets are not available "
                                f"({exc}).") from None
        if name not in PRESETS:
            raise ScenarioError(
                f"{self.file}: [train].preset must name a preset (got {name!r})."
                f"{suggest(name, PRESETS)} Available: {', '.join(sorted(PRESETS))}.")
        factory = PRESETS[name]
        options = table.preset_options or {}
        self.validate(_options_table(factory), ("train", "preset_options"), options)
        loc = ("train", "preset_options") if options else ("train",)
        train = self.build(loc, lambda: factory(**options), (ValueError, TypeError))
        if not isinstance(train, Train):
            raise ScenarioError(f"{self.file}: [train].preset: preset {name!r} did not return a "
                                "Train.")
        return train

    def track(self) -> Track:
        """``[track]``: its sections, or a line's (a shipped one or a TTOBench file), and
        its speed limits."""
        table: TrackTable = self.validate(TrackTable, ("track",))
        line = self.line(table)
        if line is not None:
            sections, limits = line.track.sections, line.track.speed_limits
        else:
            sections = tuple(
                self.build(("track", "section", i), functools.partial(_section, s))
                for i, s in enumerate(table.section or ())
            )
            limits = ()
        if table.speed_limit:
            limits = tuple(
                self.build(("track", "speed_limit", i), functools.partial(_limit, s))
                for i, s in enumerate(table.speed_limit)
            )
        return self.build(("track",), lambda: Track(
            sections=sections, formula=table.formula, wheelbase=table.wheelbase,
            speed_limits=limits))

    def line(self, table: TrackTable) -> Any:
        """The :class:`~trainctl.models.lines.Line` of ``[track].line`` or ``[track].file``
        (None for neither): a TTOBench file's error names the file and its key."""
        from trainctl.models.lines import builtin_line, read_line

        if table.line is not None:
            line = builtin_line(table.line)
            self.line_stops = line.stops
            return line
        if table.file is None:
            return None
        path = Path(table.file).expanduser()
        if not path.is_absolute():
            path = Path(self.directory or os.getcwd()) / path
        try:
            line = read_line(path)
            self.track_digest = line.digest
            self.line_stops = line.stops
            return line
        except ScenarioError as exc:
            where = "" if self.directory is None else " (relative to the scenario file's directory)"
            raise ScenarioError(f"{self.file}: [track].file = {table.file!r}{where}: {exc}") \
                from None

    def controllers(self, raw: dict[str, Any] | None, n: int) -> dict[str, Any]:
        """``[controller]``: the primary family, then ``[controller.<family>]`` sub-tables."""
        if raw is None:
            return {}
        from trainctl.registry import DEFAULT_FAMILY, family_names, get_family

        names = family_names()
        family = self.validate(family_table(names, DEFAULT_FAMILY), ("controller",)).family
        subs = [k for k in raw if k in names]
        for k in subs:
            if not isinstance(raw[k], dict) or k == family:
                text = (f"must be a table (got {got(raw[k])})" if k != family else
                        f"repeats the primary family {family!r}: its keys belong in "
                        "[controller] itself")
                raise ScenarioError(f"{self.file}: [controller.{k}] {text}.")
        primary = {k: v for k, v in raw.items() if k != "family" and k not in subs}
        context = {"n_coaches": n}
        found = {family: self.settings(get_family(family).settings, primary, ("controller",),
                                       context, ("family", *names))}
        for k in subs:
            found[k] = self.settings(get_family(k).settings, raw[k], ("controller", k), context)
        return found

    def simulation(self, raw: dict[str, Any] | None, sample_time: float,
                   families: tuple[str, ...], train: Train | None = None,
                   track: Track | None = None) -> SimulationSettings | None:
        """``[simulation]``, checked against the sample time and the families present;
        a ``[simulation.plan]`` planned along the track into the reference."""
        if raw is None:
            return None
        if not families:
            raise self.fail(Violation(
                text="needs a [controller] section", got_text="none",
                hint=" The simulation runs the design given in [controller]. Add [controller] "
                "or remove [simulation]."), ("simulation",))
        if "plan" in raw:
            raw = self.plan(raw, train, track)
        context = {"sample_time": sample_time, "strategies": strategy_names(families)}
        simulation: SimulationSettings = self.settings(SimulationSettings, raw, ("simulation",),
                                                       context)
        return simulation

    def plan(self, raw: dict[str, Any], train: Train | None,
             track: Track | None) -> dict[str, Any]:
        """``[simulation]`` with its ``plan`` made into the reference's breakpoints
        (:mod:`trainctl.scenario.plan`)."""
        from trainctl.models.planner import limited_breakpoints
        from trainctl.scenario.plan import PlanSettings

        where = ("simulation", "plan")
        if "reference" in raw:
            raise self.fail(Violation(
                text="cannot be given with [simulation.reference]", got_text="both",
                hint=" Plan the reference along the track or type its breakpoints: remove "
                "one of the two tables."), where)
        if not isinstance(raw["plan"], dict):
            raise self.fail(Violation(text="must be a table", got=raw["plan"]), where)
        plan: PlanSettings = self.settings(PlanSettings, raw["plan"], where, {})
        if track is None or train is None:
            raise self.fail(Violation(
                text="needs a [track] to plan along", got_text="no [track]",
                hint=" Add [track] (line = \"...\", file = \"...\" or sections with "
                "[[track.speed_limit]]), or give [simulation.reference] instead."), where)
        end = plan.end
        if end is None:
            if self.line_stops is None:
                raise self.fail(Violation(
                    text="needs end (the head position where the plan ends, m)",
                    got_text="none",
                    hint=" Only a [track].line or [track].file has a last stop to end at."),
                    where)
            end = self.line_stops[-1]
        times, speeds = self.build(where, lambda: limited_breakpoints(
            track, train, cruise=plan.cruise, acceleration=plan.acceleration, end=end,
            deceleration=plan.deceleration, start_speed=plan.start_speed, margin=plan.margin))
        reference = {"times": list(times), "speeds": list(speeds)}
        return {**{k: v for k, v in raw.items() if k != "plan"}, "reference": reference}

    def expected(self, raw: dict[str, Any] | None, families: tuple[str, ...]) -> FrozenMapping[str]:
        """``[expected]``: known checks, statuses, and each check's family present."""
        if raw is None:
            return FrozenMapping()
        model = expected_table(dict.fromkeys(check_names(), ""), check_statuses())
        self.validate(model, ("expected",))
        for check in raw:
            problem = expectation_violation(check, families)
            if problem is not None:
                raise self.fail(problem, ("expected",), (check,), model)
        return FrozenMapping(raw)

    def sweep(self) -> Any:
        """``[sweep]``: its keys checked, the axes built (points are validated when run)."""
        from trainctl.scenario.sweep_axes import GridAxis, ListAxis, RandomAxis
        from trainctl.scenario.sweep_definition import SweepDefinition

        table: SweepTable = self.validate(SweepTable, ("sweep",))
        raw = self.doc["sweep"]
        axes: list[Any] = []
        for i, axis in enumerate(table.axis or ()):
            given: dict[str, Any] = raw["axis"][i]  # the file's numbers: ints stay ints
            where = f"{self.file}: [sweep.axis][{i}]"
            try:
                axes.append(_sweep_axis(axis, given, ListAxis, GridAxis, RandomAxis))
            except ScenarioError as exc:
                raise ScenarioError(f"{where}: {str(exc).split(': ', 1)[1]}") from None
        try:
            return SweepDefinition(tuple(axes), seed=table.seed, samples=table.samples,
                                   seeds=table.seeds)
        except ScenarioError as exc:
            raise ScenarioError(f"{self.file}: [sweep]: {str(exc).split(': ', 1)[1]}") from None


def _sweep_axis(axis: SweepAxisTable, given: dict[str, Any], *kinds: Any) -> Any:
    """The axis object of a validated ``[[sweep.axis]]`` table."""
    list_axis, grid_axis, random_axis = kinds
    if axis.values is not None:
        return list_axis(axis.key, given["values"])
    if axis.distribution is None:
        return grid_axis(axis.key, given["start"], given["stop"], axis.num,
                         scale=axis.scale or "linear")
    return random_axis(axis.key, axis.distribution, low=axis.low, high=axis.high,
                       mean=axis.mean, std=axis.std)


def _si(table: FileTable, name: str, absent: float = math.inf) -> Any:
    """The SI value of key ``name`` of a validated table (``absent`` if omitted)."""
    value = getattr(table, name)
    if value is None:
        return absent
    f = field_at(type(table), (name,))
    return convert(value, f.key if f is not None else None)


def _vehicle(group: VehicleTable) -> Vehicle:
    davis = next(k for k in DAVIS_KEYS if getattr(group, k) is not None)
    a0, a1, a2 = _si(group, davis)
    envelope = TractionEnvelope(
        max_traction=_si(group, "max_traction_kn"),
        max_power=_si(group, "max_power_kw"),
        max_braking=_si(group, "max_braking_kn"),
        max_braking_power=_si(group, "max_braking_power_kw"),
        adhesion=_si(group, "adhesion"),
    )
    return Vehicle(mass=_si(group, "mass_t"), a0=a0, a1=a1, a2=a2, name=group.name,
                   length=group.length, traction_share=group.traction_share, envelope=envelope)


def _coupler(link: CouplerTable, front: float, rear: float) -> Coupler:
    return Coupler(
        stiffness=_si(link, "stiffness_kn_per_m", 0.0),
        damping=_si(link, "damping_kn_s_per_m"),
        spacing=(front + rear) / 2.0 + link.gap,
        virtual=link.virtual,
        max_force=_si(link, "max_force_kn"),
    )


def _limit(limit: SpeedLimitTable) -> SpeedLimit:
    return SpeedLimit(start=limit.start, limit=kmh_to_ms(limit.limit_kmh))


def _section(section: SectionTable) -> TrackSection:
    return TrackSection(start=section.start, grade_permille=section.grade_permille,
                        curve_radius=_si(section, "curve_radius"))


def _formation(vehicles: list[Vehicle]) -> str:
    """The formation: 'T-M-M-T', 'unit train ×4', run-length coded when long."""
    names = [v.name for v in vehicles]
    if len(set(names)) > 1 and len(names) <= 12:
        return "-".join(names)
    runs: list[tuple[str, int]] = []
    for v in vehicles:
        if runs and runs[-1][0] == v.name:
            runs[-1] = (v.name, runs[-1][1] + 1)
        else:
            runs.append((v.name, 1))
    return "-".join(name if count == 1 else f"{name} ×{count}" for name, count in runs)


_KEYWORD = (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)


def _options_table(factory: Callable[..., Train]) -> type[BaseModel]:
    """The keyword arguments of a preset function as a file table."""
    params = inspect.signature(factory).parameters
    extra: Literal["allow", "forbid"] = (
        "allow" if any(p.kind is p.VAR_KEYWORD for p in params.values()) else "forbid"
    )
    fields: dict[str, Any] = {
        name: (Any, ... if p.kind is p.KEYWORD_ONLY and p.default is p.empty else None)
        for name, p in params.items() if p.kind in _KEYWORD
    }
    return create_model("PresetOptions", __config__=ConfigDict(extra=extra), **fields)
