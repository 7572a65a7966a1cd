# File tables derived from declarations: generated pydantic models, SI conversion, walking.
"""The scenario-file table of a settings class, generated from its declaration.

A settings class (:func:`trainctl.declare.keys.settings`) declares SI fields with
a :class:`~trainctl.declare.keys.Key` each. :func:`file_model` turns it into the
pydantic model of its file table: one field per file key (a dotted key
``"a.b"`` becomes key ``b`` of the sub-table ``[x.a]``), with the file
flavour of the same rule, the default, the unit and the documentation.
:func:`load_settings` validates a table with it, converts the values to SI
with the declared converters and builds the settings object, whose own
validators then check the rules that span several fields.

A settings model without declarations (a plug-in family's plain pydantic
model) is its own file table.
"""

from __future__ import annotations

import math
import types
import typing
from collections.abc import Callable, Iterator, Mapping
from dataclasses import replace
from typing import Annotated, Any, Union

from pydantic import (
    BaseModel,
    ConfigDict,
    TypeAdapter,
    ValidationError,
    create_model,
    model_validator,
)
from pydantic_core import InitErrorDetails

from trainctl.declare.constraints import ERROR_TYPE, Violation, fail, raise_at
from trainctl.declare.keys import Alt, DeclaredField, Key, declared_fields
from trainctl.declare.limits import in_unit
from trainctl.scenario.filetable import FileTable as FileTable
from trainctl.scenario.filetable import Section as Section
from trainctl.scenario.filetable import Target as Target
from trainctl.scenario.filetable import is_declared as is_declared
from trainctl.scenario.filetable import issubclass_safe as issubclass_safe
from trainctl.scenario.filetable import parameters_section as parameters_section
from trainctl.scenario.filetable import rule_of as rule_of

__all__ = [
    "FileTable",
    "parameters_section",
    "Section",
    "one_of_schema",
    "Target",
    "exactly_one",
    "field_at",
    "file_loc",
    "file_model",
    "is_declared",
    "load_settings",
    "rule_of",
    "table_kind",
]


def _file_default(f: DeclaredField, key: Key) -> Any:
    default = None if f.required else f.default
    if isinstance(default, float) and math.isinf(default):
        return None  # "no limit": the key is omitted
    return list(default) if isinstance(default, tuple) else default


def _file_fields(cls: type) -> Iterator[tuple[str, Any, Any]]:
    """(dotted file key, annotation, default) of every file key of ``cls``."""
    for f in declared_fields(cls):
        key = f.key or Key(doc="")
        rule = rule_of(f)
        if key.file == "" or rule is None:
            continue
        file_rule = rule.for_file()
        alts = key.one_of or (Alt(key.file or f.name, key.unit, key.to_si),)
        for alt in alts:
            alt_rule = file_rule if key.vector else in_unit(file_rule, alt.to_si)
            meta = replace(key, file=alt.key, unit=alt.unit, to_si=alt.to_si, one_of=(),
                           si_text=alt.si_text or key.si_text)
            target = Target(f.name, alt.sets)
            default = None if key.one_of else _file_default(f, key)
            required = f.required and not key.one_of
            yield alt.key, Annotated[Any, alt_rule, meta, target], ... if required else default


_FILE_MODELS: dict[type, type[BaseModel]] = {}


def file_model(cls: type) -> type[BaseModel]:
    """The pydantic model of the file table of settings class ``cls``.

    Parameters
    ----------
    cls : type
        A declared settings class, or a plain pydantic model (returned as is).

    Returns
    -------
    type of pydantic.BaseModel
        Fields named by file key; sub-tables as nested models.

    Examples
    --------
    The SI field ``speed`` [m/s] of :class:`~trainctl.scenario.ModelSettings`
    is the file key ``speed_kmh``; a file table is returned as it is:

    >>> from trainctl.scenario.settings import ModelSettings
    >>> from trainctl.scenario.tables import CouplerTable
    >>> list(file_model(ModelSettings).model_fields)[:2]
    ['speed_kmh', 'linearisation']
    >>> file_model(CouplerTable) is CouplerTable
    True
    """
    if not is_declared(cls):
        return cls
    if cls not in _FILE_MODELS:
        _FILE_MODELS[cls] = _generate(cls)
    return _FILE_MODELS[cls]


def _generate(cls: type) -> type[BaseModel]:
    tables: dict[str, dict[str, Any]] = {}
    top: dict[str, Any] = {}
    for dotted, annotation, default in _file_fields(cls):
        head, _, rest = dotted.partition(".")
        if rest:
            tables.setdefault(head, {})[rest] = (annotation, default)
        else:
            top[dotted] = (annotation, default)
    docs: Mapping[str, str] = getattr(cls, "tables", {})
    for name, fields in tables.items():
        sub = _make(f"{cls.__name__}_{name}", fields, cls.__doc__ or "")
        required = any(d is ... for _, d in fields.values())
        meta = (Key(doc=docs.get(name, "")), Section(sub))
        top[name] = (Annotated[sub, *meta], ... if required else None)
    return _make(cls.__name__, top, cls.__doc__ or "")


def _make(name: str, fields: dict[str, Any], doc: str) -> type[BaseModel]:
    groups = _alternatives(fields)
    validators: dict[str, Any] = {
        f"_one_of_{i}": model_validator(mode="after")(_one_of_check(keys, hint))
        for i, (keys, hint) in enumerate(groups)
    }
    config = ConfigDict(**FileTable.model_config)
    if groups:
        config["json_schema_extra"] = one_of_schema(*(keys for keys, _ in groups))
    model = create_model(name, __config__=config, __validators__=validators, **fields)
    model.__doc__ = doc.split("\n\n")[0] if doc else None
    model.one_of_keys = tuple(keys for keys, _ in groups)
    built: type[BaseModel] = model
    return built


def one_of_schema(*groups: tuple[str, ...]) -> dict[str, Any]:
    """JSON Schema keywords: exactly one key of each group.

    Parameters
    ----------
    *groups : tuple of str
        Groups of alternative keys.

    Returns
    -------
    dict
        The keywords to merge into a table's schema.

    Examples
    --------
    >>> one_of_schema(("speeds_kmh", "speeds"))
    {'oneOf': [{'required': ['speeds_kmh']}, {'required': ['speeds']}]}
    >>> list(one_of_schema(("a", "b"), ("c", "d")))  # several groups must all hold
    ['allOf']
    """
    options = [{"oneOf": [{"required": [k]} for k in keys]} for keys in groups]
    return options[0] if len(options) == 1 else {"allOf": options}


def _alternatives(fields: dict[str, Any]) -> list[tuple[tuple[str, ...], str]]:
    """Groups of alternative keys (same SI target) with the group's hint."""
    by_target: dict[str, list[str]] = {}
    hints: dict[str, str] = {}
    for key_name, (annotation, _) in fields.items():
        meta = getattr(annotation, "__metadata__", ())
        target = next((m for m in meta if isinstance(m, Target)), None)
        key = next((m for m in meta if isinstance(m, Key)), None)
        if target is None or key is None:
            continue
        by_target.setdefault(target.field, []).append(key_name)
        hints[target.field] = key.hint
    return [(tuple(keys), hints[t]) for t, keys in by_target.items() if len(keys) > 1]


def _one_of_check(keys: tuple[str, ...], hint: str) -> Any:
    def check(self: BaseModel) -> BaseModel:
        exactly_one(self, keys, hint)
        return self

    return check


def exactly_one(table: BaseModel, keys: tuple[str, ...], hint: str) -> str:
    """The one key of ``keys`` given in ``table`` (a violation otherwise).

    Parameters
    ----------
    table : pydantic.BaseModel
        The validated file table.
    keys : tuple of str
        The alternative keys.
    hint : str
        A sentence added to the message.

    Returns
    -------
    str
        The key given.

    Raises
    ------
    pydantic.ValidationError
        At the table when none or several of ``keys`` are given.

    Examples
    --------
    A reference profile gives its speeds in km/h or in m/s, not both:

    >>> from pydantic import ValidationError
    >>> from trainctl.scenario.settings import SimulationSettings
    >>> reference = field_at(file_model(SimulationSettings), ("reference",))
    >>> model = sub_model(reference)
    >>> table = model.model_validate({"times": [0, 10], "speeds_kmh": [72, 90]})
    >>> exactly_one(table, ("speeds_kmh", "speeds"), "")
    'speeds_kmh'
    >>> try:
    ...     model.model_validate({"times": [0, 10], "speeds_kmh": [72, 90], "speeds": [20, 25]})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["msg"])
    needs exactly one of speeds_kmh, speeds
    """
    given = [k for k in keys if k in table.model_fields_set]
    if len(given) != 1:
        what = "none" if not given else " and ".join(given)
        raise_at((), Violation(text=f"needs exactly one of {', '.join(keys)}", got_text=what,
                               hint=hint), None)
    return given[0]


def si_values(table: BaseModel) -> dict[str, Any]:
    """The SI field values a validated generated file table gives."""
    out: dict[str, Any] = {}
    for f in declared_fields(type(table)):
        value = getattr(table, f.name)
        target = next((m for m in f.info.metadata if isinstance(m, Target)), None)
        if isinstance(value, BaseModel):
            out.update(si_values(value))
        elif target is not None and f.name in table.model_fields_set:
            out[target.field] = convert(value, f.key)
            out.update(target.sets)
    return out


def convert(value: Any, key: Key | None) -> Any:
    """A file value in SI: the declared converter, item by item for arrays."""
    if key is None or key.to_si is None or value is None:
        return value
    if isinstance(value, tuple | list) and not key.vector:
        return tuple(key.to_si(x) for x in value)
    return key.to_si(value)


def load_settings(cls: type, table: Mapping[str, Any], context: dict[str, Any]) -> Any:
    """Validate a file table with the file model of ``cls``; return the settings.

    Parameters
    ----------
    cls : type
        A settings class (declared, or a plain pydantic model).
    table : mapping
        The TOML table.
    context : dict
        Validation context (e.g. ``n_coaches``, ``sample_time``).

    Returns
    -------
    object
        The validated settings object, SI inside.

    Raises
    ------
    pydantic.ValidationError
        With locations in file keys (file model) or in SI field names (the
        settings class's own validators; see :func:`file_loc`).

    Examples
    --------
    The file gives 72 km/h; the settings hold 72 / 3.6 = 20 m/s:

    >>> from trainctl.scenario.settings import ModelSettings
    >>> model = load_settings(ModelSettings, {"speed_kmh": 72.0, "sample_time": 0.5}, {})
    >>> model.speed, model.sample_time  # [m/s], [s]
    (20.0, 0.5)
    """
    model = file_model(cls)
    if model is cls:
        return TypeAdapter(cls).validate_python(dict(table), context=context)
    values = model.model_validate(dict(table), context=context)
    try:
        return TypeAdapter(cls).validate_python(si_values(values), context=context)
    except ValidationError as exc:
        raise relocate(exc, lambda loc: file_loc(cls, loc, table)) from None


def relocate(
    exc: ValidationError, move: Callable[[tuple[Any, ...]], tuple[Any, ...]]
) -> ValidationError:
    """``exc`` with every error location mapped by ``move``."""
    details = []
    for error in exc.errors():
        ctx = error.get("ctx")
        kind: Any = error["type"]
        if kind == ERROR_TYPE and ctx is not None:
            kind = fail(ctx["violation"])
        details.append(InitErrorDetails(type=kind, loc=move(tuple(error["loc"])),
                                        input=error.get("input"), ctx=ctx or {}))
    return ValidationError.from_exception_data(exc.title, details)


def file_loc(cls: type, loc: tuple[Any, ...], table: Mapping[str, Any]) -> tuple[Any, ...]:
    """Map the location of an SI field of ``cls`` to its file key location.

    Parameters
    ----------
    cls : type
        The settings class.
    loc : tuple
        The SI field's location (field names and indices).
    table : mapping
        The file table, which tells which alternative key was written.

    Returns
    -------
    tuple
        The location of the file key.

    Examples
    --------
    The second reference speed is reported under whichever key the file
    used (the first alternative when it used neither):

    >>> from trainctl.scenario.settings import ModelSettings, SimulationSettings
    >>> file_loc(SimulationSettings, ("reference_speeds", 1), {"reference": {"speeds": [0, 20]}})
    ('reference', 'speeds', 1)
    >>> file_loc(SimulationSettings, ("reference_speeds", 1), {})
    ('reference', 'speeds_kmh', 1)
    >>> file_loc(ModelSettings, ("speed",), {})
    ('speed_kmh',)
    """
    if not loc or not is_declared(cls):
        return loc
    f = next((f for f in declared_fields(cls) if f.name == loc[0]), None)
    if f is None or f.key is None or f.key.file == "":
        return loc
    keys = [a.key for a in f.key.one_of] or [f.key.file or f.name]
    present = [k for k in keys if _lookup(table, k.split(".")) is not None]
    return (*(present or keys)[0].split("."), *loc[1:])


def _lookup(table: Any, parts: list[str]) -> Any:
    for part in parts:
        if not isinstance(table, Mapping):
            return None
        table = table.get(part)
    return table


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    if issubclass_safe(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _models_in(arg)]


def table_kind(f: DeclaredField) -> str:
    """``"table"``, ``"tables"`` (array of tables), ``"either"`` or ``"value"``.

    Parameters
    ----------
    f : DeclaredField
        A field of a file table.

    Returns
    -------
    str
        What the field holds in the file.

    Examples
    --------
    In ``[train]``, vehicles are an array of tables; the couplers may be one
    table for every link or an array of them:

    >>> from trainctl.declare.keys import declared_fields
    >>> from trainctl.scenario.tables import TrainTable
    >>> {f.name: table_kind(f) for f in declared_fields(TrainTable)}
    {'preset': 'value', 'preset_options': 'table', 'vehicle': 'tables', 'coupler': 'either'}
    """
    section = next((m for m in f.info.metadata if isinstance(m, Section)), None)
    if section is not None:
        return "tables" if section.array else "table"
    rule = rule_of(f)
    if rule is not None and getattr(rule, "model", None) is not None:
        return "either"
    if getattr(rule, "is_table", False):
        return "table"
    annotation = f.info.annotation
    origin = typing.get_origin(annotation)
    if origin in (Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        annotation = args[0] if len(args) == 1 else annotation
        origin = typing.get_origin(annotation)
    if origin is list and _models_in(annotation):
        return "tables"
    return "table" if _models_in(annotation) else "value"


def sub_model(f: DeclaredField) -> type[BaseModel] | None:
    """The model of a sub-table field (or of the items of an array of tables)."""
    section = next((m for m in f.info.metadata if isinstance(m, Section)), None)
    if section is not None:
        return section.model
    rule = rule_of(f)
    if rule is not None and getattr(rule, "model", None) is not None:
        return typing.cast(type[BaseModel], rule.model)  # type: ignore[attr-defined]
    models = _models_in(f.info.annotation)
    return models[0] if models else None


def field_at(model: type[BaseModel] | None, loc: tuple[Any, ...]) -> DeclaredField | None:
    """The declared field at ``loc`` (file keys and indices) below ``model``.

    Parameters
    ----------
    model : type or None
        The file table's model.
    loc : tuple
        File keys and array indices.

    Returns
    -------
    DeclaredField or None
        The field, or None where ``loc`` leads to no declared field.

    Examples
    --------
    Array indices are skipped on the way down:

    >>> from trainctl.scenario.tables import TopLevel
    >>> f = field_at(TopLevel, ("train", "coupler", 0, "stiffness_kn_per_m"))
    >>> f.name, f.key.unit
    ('stiffness_kn_per_m', 'kN/m')
    >>> field_at(TopLevel, ("train", "couplers")) is None  # no such key
    True
    """
    found = None
    for part in loc:
        if isinstance(part, int):
            continue
        if model is None:
            return None
        found = next((f for f in declared_fields(model) if f.name == part), None)
        if found is None:
            return None
        model = sub_model(found)
    return found


def field_names(model: type[BaseModel] | None) -> tuple[str, ...]:
    """The keys of a file table."""
    return tuple(f.name for f in declared_fields(model)) if model is not None else ()
