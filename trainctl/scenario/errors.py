# Scenario-file error messages: pydantic errors worded once, with trainctl key paths.
"""Turn a pydantic validation error of a file table into a ScenarioError.

The message has one shape: ``FILE: KEY PATH must ... (got ...). hint``. The
key path is built from the error location and the document
(``[train.vehicle][2].mass_t``: tables in brackets, array indices from 0);
what must hold comes from the rule that failed
(:class:`~trainctl.declare.constraints.Violation`) or, for pydantic's structural
errors (a missing or unknown key, a value where a table belongs), from the
table's declaration. This module is the one place where pydantic error types
become trainctl's wording.
"""

from __future__ import annotations

import datetime
from collections.abc import Mapping, Sequence
from typing import Any

from pydantic import BaseModel, ValidationError

from trainctl.declare.constraints import NOTHING, Violation
from trainctl.declare.keys import first_error, render_refs, violation_of
from trainctl.exceptions import ScenarioError
from trainctl.scenario.core import RESERVED_SECTIONS
from trainctl.scenario.filemodel import (
    field_at,
    field_names,
    file_loc,
    rule_of,
    sub_model,
    table_kind,
)

__all__ = ["DocumentTable", "describe", "got", "scenario_error"]

_TABLE_TYPES = ("model_type", "model_attributes_type", "dict_type", "dataclass_type")
_ARRAY_TYPES = ("list_type", "too_short", "tuple_type")


def _short(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def got(value: Any) -> str:
    """Describe a TOML value for a ``(got ...)`` clause.

    Parameters
    ----------
    value : object
        The value found in the file.

    Returns
    -------
    str
        The value with its TOML type where that helps.

    Examples
    --------
    >>> got(True), got("20"), got([1, 2]), got(-1.0)
    ('true, a boolean', "'20', a string", 'an array of 2 items', '-1.0')
    """
    if isinstance(value, bool):
        return f"{str(value).lower()}, a boolean"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return f"{_short(value)!r}, a string"
    if isinstance(value, list | tuple):
        return f"an array of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, datetime.date | datetime.time):
        return f"{value.isoformat()}, a date/time"
    return type(value).__name__


def _lookup(doc: Any, loc: Sequence[Any]) -> Any:
    node = doc
    for part in loc:
        if isinstance(part, int) and isinstance(node, list) and 0 <= part < len(node):
            node = node[part]
        elif isinstance(part, str) and isinstance(node, Mapping):
            node = node.get(part, NOTHING)
        else:
            return NOTHING
    return node


class DocumentTable:
    """A validated table of a scenario document: where it is and what declares it.

    Error messages name keys as the file writes them (``[model].speed_kmh``,
    ``[train.vehicle][1].mass_t``); this is what knows the way there.

    Parameters
    ----------
    doc : mapping
        The whole parsed document (TOML tables as dicts).
    prefix : tuple
        Location of this table in ``doc`` (keys and array indices); ``()``
        for the top level.
    model : type of pydantic.BaseModel or None
        The file model declaring the table's keys
        (:func:`~trainctl.scenario.filemodel.file_model`), None if unknown.
    settings : type or None
        The settings class the table becomes, whose field names a rule's
        ``{field}`` reference may use; None if there is none.

    Examples
    --------
    The ``[model]`` table of a document, and the file path of a key in it:

    >>> from trainctl.scenario.filemodel import file_model
    >>> from trainctl.scenario.settings import ModelSettings
    >>> doc = {"model": {"speed_kmh": 300.0, "sample_time": 20.0}}
    >>> table = DocumentTable(doc, ("model",), file_model(ModelSettings), ModelSettings)
    >>> table.path(("speed_kmh",))
    '[model].speed_kmh'
    >>> table.ref((), "speed")  # the field 'speed' is written as speed_kmh
    '[model].speed_kmh'
    """

    def __init__(
        self,
        doc: Mapping[str, Any],
        prefix: tuple[Any, ...],
        model: type[BaseModel] | None,
        settings: type | None,
    ) -> None:
        self.doc, self.prefix, self.model, self.settings = doc, prefix, model, settings

    def is_table(self, loc: tuple[Any, ...], value: Any) -> bool:
        """True if the part at ``loc`` (relative) is a sub-table or array of them.

        Parameters
        ----------
        loc : tuple
            Location of the part below this table (keys and array indices).
        value : object
            The value the document holds there;
            :data:`~trainctl.declare.constraints.NOTHING` when absent (the file model
            alone decides then).

        Returns
        -------
        bool
            True when ``value`` is a dict or a non-empty list of dicts, or when
            the file model declares a table or an array of tables at ``loc``.
        """
        if isinstance(value, dict) or (
            isinstance(value, list) and value and all(isinstance(v, dict) for v in value)
        ):
            return True
        f = field_at(self.model, loc)
        return f is not None and table_kind(f) != "value"

    def path(self, loc: tuple[Any, ...], *, last_as_key: bool = False) -> str:
        """The display key path of ``loc`` (relative to this table).

        Parameters
        ----------
        loc : tuple
            Keys and array indices below this table; ``()`` for the table
            itself.
        last_as_key : bool
            Write the last part as a key even when it names a table
            (``[train].vehicle`` rather than ``[train.vehicle]``), e.g. for a
            missing table.

        Returns
        -------
        str
            The path as the file writes it: the TOML table name in brackets,
            then array indices and dotted keys, e.g. ``"[model].speed_kmh"`` or
            ``"[train.vehicle][1].mass_t"``.
        """
        full = self.prefix + loc
        text = ""
        dotted: str | None = ""  # the TOML table name; None inside an array element
        for i, part in enumerate(full):
            if isinstance(part, int):
                text, dotted = f"{text}[{part}]", None
                continue
            rel = full[len(self.prefix): i + 1]
            table = i < len(self.prefix) or self.is_table(rel, _lookup(self.doc, full[: i + 1]))
            if table and not (last_as_key and i == len(full) - 1) and dotted is not None:
                dotted = f"{dotted}.{part}" if dotted else part
                text = f"[{dotted}]"
            else:
                text, dotted = (f"{text}.{part}" if text else part), None
        return text

    def table_loc(self, loc: tuple[Any, ...]) -> tuple[Any, ...]:
        """``loc`` if it names a table, else the table that holds the key or item.

        Parameters
        ----------
        loc : tuple
            Keys and array indices below this table.

        Returns
        -------
        tuple
            The longest leading part of ``loc`` that the file model declares as
            a table or an array element of tables; ``()`` for this table.
        """
        while loc:
            *head, last = loc
            f = field_at(self.model, tuple(head) if isinstance(last, int) else loc)
            if f is not None and table_kind(f) != "value":
                return loc
            loc = tuple(head)
        return loc

    def ref(self, table: tuple[Any, ...], name: str) -> str | None:
        """The key path of field ``name`` of the table at ``table`` or of one around it.

        Parameters
        ----------
        table : tuple
            Location of the table the reference is made from, below this table.
        name : str
            A field name: a file key of that table or of one that holds it
            (innermost first), or a field of :attr:`settings` that a file key
            stands for (``speed`` written as ``speed_kmh``).

        Returns
        -------
        str or None
            The display key path (:meth:`path`); None when no table declares
            ``name``.
        """
        for depth in range(len(table), -1, -1):
            here = table[:depth]
            model = self.model if not here else _model_at(self.model, here)
            if model is not None and name in field_names(model):
                return self.path((*here, name))
        if self.settings is not None:
            raw = _lookup(self.doc, self.prefix)
            mapped = file_loc(self.settings, (name,), raw if isinstance(raw, Mapping) else {})
            if mapped != (name,):
                return self.path(mapped)
        return None


def _model_at(model: type[BaseModel] | None, loc: tuple[Any, ...]) -> type[BaseModel] | None:
    f = field_at(model, loc)
    return sub_model(f) if f is not None else None


def describe(violation: Violation, table: DocumentTable, loc: tuple[Any, ...]) -> str:
    """The message of a rule violation at ``loc`` of ``table`` (without the file).

    Parameters
    ----------
    violation : Violation
        What is wrong with the value.
    table : DocumentTable
        The file table holding the value.
    loc : tuple
        The value's location in the table (keys and indices).

    Returns
    -------
    str
        The message, naming the key.

    Examples
    --------
    A ``{field}`` reference in the rule's text becomes the file key of that
    field, here in the ``[model]`` table:

    >>> from trainctl.declare.constraints import Violation
    >>> from trainctl.scenario.filemodel import file_model
    >>> from trainctl.scenario.settings import ModelSettings
    >>> doc = {"model": {"speed_kmh": 300.0, "sample_time": 20.0}}
    >>> table = DocumentTable(doc, ("model",), file_model(ModelSettings), ModelSettings)
    >>> violation = Violation(text="must be below {sample_time}", got=30.0, hint=" Shorten it.")
    >>> describe(violation, table, ("speed_kmh",))
    '[model].speed_kmh must be below [model].sample_time (got 30.0). Shorten it.'
    """
    parent = table.table_loc(loc)
    text = render_refs(violation.text, lambda name: table.ref(parent, name))
    shown = "" if violation.got is NOTHING and not violation.got_text else (
        f" (got {violation.got_text or got(violation.got)})"
    )
    hint = violation.hint + violation.file_hint
    f = field_at(table.model, loc) if loc and not isinstance(loc[-1], int) else None
    if f is not None and f.key is not None:
        if violation.finite and f.key.omitted:
            hint += f" Omit the key for {f.key.omitted}."
        elif violation.value and f.key.hint and f.key.hint not in hint:
            hint += f.key.hint
    where = f"{table.path(loc)} " if violation.where else ""
    return f"{where}{text}{shown}.{hint}"


def _unknown(table: DocumentTable, loc: tuple[Any, ...], extra: Sequence[str]) -> str:
    name = loc[-1]
    if not table.prefix and len(loc) == 1 and name in RESERVED_SECTIONS:
        return (f"section [{name}] is reserved for a later trainctl release and is not "
                "supported yet. Remove it to load this scenario.")
    from trainctl.declare.constraints import suggest

    allowed = field_names(_model_at(table.model, loc[:-1]) if loc[:-1] else table.model)
    allowed = (*allowed, *(extra if len(loc) == 1 else ()))
    known = (*allowed, *(RESERVED_SECTIONS if not table.prefix else ()))
    section = isinstance(_lookup(table.doc, table.prefix + loc), dict)
    hint = suggest(name, known) or (
        f" Allowed here: {', '.join(allowed)}." if allowed else " No keys are allowed here."
    )
    return f"unknown {'section' if section else 'key'} {table.path(loc)}.{hint}"


def _missing(table: DocumentTable, loc: tuple[Any, ...]) -> str:
    f = field_at(table.model, loc)
    kind = table_kind(f) if f is not None else "value"
    if kind in ("table", "either"):
        return f"missing required section {table.path(loc)}."
    if kind == "tables":
        return (f"missing required key {table.path(loc, last_as_key=True)} (an array of "
                f"tables [{table.path(loc)}]).")
    rule = rule_of(f) if f is not None else None
    want = f" ({rule.want()})" if rule is not None else ""
    return f"missing required key {table.path(loc)}{want}."


def scenario_error(
    file: str,
    exc: ValidationError,
    *,
    doc: Mapping[str, Any],
    prefix: tuple[Any, ...] = (),
    model: type[BaseModel] | None = None,
    settings: type | None = None,
    extra_keys: Sequence[str] = (),
) -> ScenarioError:
    """The ScenarioError for a validation error of the table at ``prefix``.

    Parameters
    ----------
    file : str
        The file label, the message's first word.
    exc : pydantic.ValidationError
        The error, located in file keys below the table.
    doc : mapping
        The whole TOML document (to tell tables from values).
    prefix : tuple
        Location of the validated table in the document.
    model : type, optional
        The table's file model (declared keys, rules, sub-tables).
    settings : type, optional
        The settings class, to name its SI fields by their file keys.
    extra_keys : sequence of str
        Further keys allowed in the table (e.g. controller sub-tables).

    Returns
    -------
    ScenarioError
        ``FILE: KEY PATH must ... (got ...). hint``.

    Examples
    --------
    Validating a ``[model]`` table with a negative speed, then with a
    misspelt key:

    >>> from trainctl.scenario.filemodel import file_model
    >>> from trainctl.scenario.settings import ModelSettings
    >>> model = file_model(ModelSettings)
    >>> for raw in ({"speed_kmh": -1, "sample_time": 0.5},
    ...             {"speed_kmh": 300, "sample_time": 0.5, "sped": 1}):
    ...     try:
    ...         model.model_validate(raw)
    ...     except ValidationError as exc:
    ...         print(scenario_error("demo.toml", exc, doc={"model": raw}, prefix=("model",),
    ...                              model=model, settings=ModelSettings))
    demo.toml: [model].speed_kmh must be a number > 0 (got -1).
    demo.toml: unknown key [model].sped. Did you mean 'speed_kmh'?
    """
    error = first_error(exc)
    loc = tuple(error["loc"])
    table = DocumentTable(doc, prefix, model, settings)
    kind = error["type"]
    value = error.get("input", NOTHING)
    if kind == "extra_forbidden":
        message = _unknown(table, loc, extra_keys)
    elif kind == "missing":
        message = _missing(table, loc)
    elif kind in _TABLE_TYPES:
        message = f"{table.path(loc)} must be a table (got {got(value)})."
    elif kind in _ARRAY_TYPES and table.is_table(loc, NOTHING):
        where = table.path(loc)
        message = (f"{where} must be a non-empty array of tables, written [{where}] with "
                   f"double brackets (got {got(value)}).")
    else:
        message = describe(violation_of(error), table, loc)
    return ScenarioError(f"{file}: {message}")
