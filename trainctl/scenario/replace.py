# Scenario.replace: one key of the file changed, the whole file validated again.
"""Vary one design parameter of a loaded scenario: :meth:`Scenario.replace`.

A scenario read from a file keeps its TOML document (read-only). Replacing a
key edits a copy of that document at a file key path — the spelling of the
file and of the error messages, ``"controller.r_per_kn2"``,
``"train.vehicle[1].mass_t"`` (array indices from 0) — with a value in the
key's file unit, and parses the copy again: the new scenario is validated by
exactly the declarations a file is, and an error names the key path.

Setting a key of a group of alternatives (``r_per_kn2`` / ``r_per_n2``, the
three Davis keys, ``speeds_kmh`` / ``speeds``) removes the other keys of its
group from the same table; ``None`` removes the key.
"""

from __future__ import annotations

import copy
import re
from collections.abc import Mapping
from typing import Any

from trainctl.exceptions import ScenarioError
from trainctl.scenario.core import FrozenMapping

__all__ = ["freeze", "parse_key_path", "replaced_document", "thaw"]

_SEGMENT = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*)((?:\[\d+\])*)$")


def parse_key_path(path: str) -> tuple[str | int, ...]:
    """The parts of a file key path: names and 0-based array indices.

    Parameters
    ----------
    path : str
        Dotted key path, e.g. ``"train.vehicle[1].mass_t"``.

    Returns
    -------
    tuple of str or int
        E.g. ``("train", "vehicle", 1, "mass_t")``.

    Raises
    ------
    ScenarioError
        If the path is not dotted names with optional ``[index]`` suffixes.

    Examples
    --------
    >>> parse_key_path("train.vehicle[1].mass_t")
    ('train', 'vehicle', 1, 'mass_t')
    """
    if not isinstance(path, str) or not path:
        raise ScenarioError(f"Scenario.replace: the key path must be a non-empty str such as "
                            f"'controller.r_per_kn2' (got {path!r}).")
    parts: list[str | int] = []
    for segment in path.split("."):
        match = _SEGMENT.match(segment)
        if match is None:
            raise ScenarioError(
                f"Scenario.replace: {path!r} is not a key path: each part must be a key name "
                f"with optional [index] suffixes, e.g. 'train.vehicle[1].mass_t' (got part "
                f"{segment!r}).")
        parts.append(match.group(1))
        parts += [int(i) for i in re.findall(r"\[(\d+)\]", match.group(2))]
    return tuple(parts)


def replaced_document(document: Mapping[str, Any], path: str, value: Any) -> dict[str, Any]:
    """A copy of ``document`` with the key at ``path`` set to ``value`` (None: removed).

    Parameters
    ----------
    document : mapping
        A scenario's TOML document.
    path : str
        File key path (:func:`parse_key_path`).
    value : object
        New value in the key's file unit; None removes the key.

    Returns
    -------
    dict
        The edited copy (plain dicts and lists, as ``tomllib`` gives).

    Raises
    ------
    ScenarioError
        If the path runs through a value that is not a table or an array,
        or indexes past the end of an array.

    Examples
    --------
    >>> doc = {"controller": {"r_per_n2": 1e-5}}
    >>> replaced_document(doc, "controller.r_per_kn2", 10.0)
    {'controller': {'r_per_kn2': 10.0}}
    """
    parts = parse_key_path(path)
    doc: dict[str, Any] = thaw(document)  # a mapping thaws to a dict
    table: Any = doc
    for depth, part in enumerate(parts[:-1]):
        table = _step(table, part, parts[depth + 1], path, parts[: depth + 1])
    last = parts[-1]
    if isinstance(last, int):
        if not isinstance(table, list) or last >= len(table):
            raise _no_such(path, parts, table)
        table[last] = _toml_value(value)
        return doc
    if not isinstance(table, dict):
        raise _no_such(path, parts, table)
    for alternative in _alternatives(last):
        table.pop(alternative, None)
    if value is None:
        table.pop(last, None)
    else:
        table[last] = _toml_value(value)
    return doc


def freeze(value: Any) -> Any:
    """A read-only deep copy of a TOML value: tables as FrozenMapping, arrays as tuples.

    Parameters
    ----------
    value : object
        A TOML value (dicts, lists, scalars).

    Returns
    -------
    object
        The frozen copy.

    Examples
    --------
    >>> freeze({"vehicle": [{"mass_t": 40.0}]})["vehicle"]
    ({'mass_t': 40.0},)
    """
    if isinstance(value, Mapping):
        return FrozenMapping((k, freeze(v)) for k, v in value.items())
    if isinstance(value, list | tuple):
        return tuple(freeze(v) for v in value)
    return value


def thaw(value: Any) -> Any:
    """A mutable deep copy of a (frozen) TOML value: dicts and lists, as ``tomllib`` gives.

    Parameters
    ----------
    value : object
        A (frozen) TOML value.

    Returns
    -------
    object
        Dicts, lists and scalars.

    Examples
    --------
    >>> thaw(freeze({"speeds": [20.0, 80.0]}))
    {'speeds': [20.0, 80.0]}
    """
    if isinstance(value, Mapping):
        return {k: thaw(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [thaw(v) for v in value]
    return copy.copy(value)


def _step(table: Any, part: str | int, following: str | int, path: str,
          done: tuple[str | int, ...]) -> Any:
    """The table or array at ``part`` below ``table`` (a missing table is created)."""
    if isinstance(part, int):
        if isinstance(table, list) and part < len(table):
            return table[part]
        raise _no_such(path, done, table)
    if not isinstance(table, dict):
        raise _no_such(path, done, table)
    if part not in table:
        table[part] = [] if isinstance(following, int) else {}
    return table[part]


def _no_such(path: str, done: tuple[str | int, ...], found: Any) -> ScenarioError:
    where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in done).lstrip(".")
    what = (f"an array of {len(found)}" if isinstance(found, list) else
            "a table" if isinstance(found, dict) else f"the value {found!r}")
    return ScenarioError(f"Scenario.replace: cannot set {path!r}: the scenario has {what} at "
                         f"{where or 'the top level'}.")


def _toml_value(value: Any) -> Any:
    """``value`` as tomllib would give it (numpy scalars as Python numbers, arrays as lists)."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, tuple | list):
        return [_toml_value(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _toml_value(v) for k, v in value.items()}
    return value


def _alternatives(key: str) -> tuple[str, ...]:
    """The other keys of the alternative group ``key`` belongs to (none: ())."""
    for group in _one_of_groups():
        if key in group:
            return tuple(k for k in group if k != key)
    return ()


def _one_of_groups() -> tuple[tuple[str, ...], ...]:
    """Every group of alternative keys declared in the file tables (leaf names)."""
    from trainctl.declare.keys import declared_fields
    from trainctl.models.network.schema import NetworkSettings
    from trainctl.registry import family_names, get_family
    from trainctl.scenario.communication import CommunicationSettings
    from trainctl.scenario.filemodel import file_model, sub_model
    from trainctl.scenario.settings import ModelSettings, SimulationSettings
    from trainctl.scenario.tables import TrackTable, TrainTable

    roots: list[type | None] = [TrainTable, TrackTable, file_model(ModelSettings),
                                file_model(SimulationSettings),
                                file_model(CommunicationSettings),
                                file_model(NetworkSettings)]
    roots += [file_model(get_family(name).settings) for name in family_names()]
    groups: list[tuple[str, ...]] = []
    seen: set[type] = set()
    while roots:
        model = roots.pop()
        if model is None or model in seen:
            continue
        seen.add(model)
        groups += [tuple(g) for g in getattr(model, "one_of_keys", ())]
        roots += [sub_model(f) for f in declared_fields(model)]
    return tuple(groups)
