# The JSON Schema of scenario files, generated from the key declarations.
"""A JSON Schema (draft 2020-12) of the scenario-file format.

It is generated from the same declarations as the parser (titles,
descriptions, units, defaults, enumerations, bounds), for editors that
validate TOML against a JSON Schema and complete keys. The controller
families come from the registry when the schema is made; ``[controller]``
holds the keys of the family its ``family`` key names (``"mpc"`` when
omitted) and one sub-table per further family. Rules that need the whole
scenario (the number of coaches, the sample time, the strategies of the
families present) are checked by the parser only.

Examples
--------
>>> schema = json_schema()
>>> schema["$schema"]
'https://json-schema.org/draft/2020-12/schema'
>>> schema["properties"]["model"]["$ref"]
'#/$defs/ModelSettings'
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, create_model
from pydantic.fields import FieldInfo
from pydantic.json_schema import models_json_schema

from trainctl.declare.keys import Key, declared_fields
from trainctl.models.network.schema import NetworkSettings
from trainctl.scenario.communication import CommunicationSettings
from trainctl.scenario.core import SCHEMA_VERSION, check_names, check_statuses
from trainctl.scenario.cost import CostSettings
from trainctl.scenario.filemodel import FileTable, file_model
from trainctl.scenario.plan import PlanSettings
from trainctl.scenario.settings import ModelSettings, SimulationSettings
from trainctl.scenario.tables import SweepTable, TopLevel, TrackTable, TrainTable, expected_table

__all__ = ["DRAFT", "json_schema"]

DRAFT = "https://json-schema.org/draft/2020-12/schema"
"""The JSON Schema dialect of :func:`json_schema`."""

_SECTIONS: dict[str, Any] = {
    "train": TrainTable,
    "track": TrackTable,
    "model": lambda: file_model(ModelSettings),
    "communication": lambda: file_model(CommunicationSettings),
    "cost": lambda: file_model(CostSettings),
    "network": lambda: file_model(NetworkSettings),
    "simulation": lambda: _simulation(),
    "expected": lambda: expected_table(dict.fromkeys(check_names(), ""), check_statuses()),
    "sweep": SweepTable,
}


def _simulation() -> type[BaseModel]:
    """``[simulation]``: its settings' keys, with ``[simulation.plan]``
    (:mod:`trainctl.scenario.plan`) in place of ``[simulation.reference]``, one of the two."""
    base = file_model(SimulationSettings)
    fields: dict[str, Any] = {}
    for name, f in base.model_fields.items():
        if name == "reference":
            f = FieldInfo.merge_field_infos(f, default=None)
            fields[name] = (f.annotation | None, f)  # type: ignore[operator]
        else:
            fields[name] = (f.annotation, f)
    plan = file_model(PlanSettings)
    fields["plan"] = (Annotated[plan | None, Key(doc=(
        "The reference planned along [track] under its speed limits, in place of "
        "[simulation.reference]"))], None)
    extra: dict[str, Any] = dict(base.model_config.get("json_schema_extra") or {})  # type: ignore[arg-type]
    either = {"oneOf": [{"required": ["reference"]}, {"required": ["plan"]}]}
    extra["allOf"] = [*extra.get("allOf", []), either]
    config = ConfigDict(**FileTable.model_config, json_schema_extra=extra)
    return create_model(base.__name__, __config__=config, __doc__=base.__doc__, **fields)


def _document() -> type[BaseModel]:
    """The whole document as one model: top-level keys and section tables."""
    fields: dict[str, Any] = {}
    for f in declared_fields(TopLevel):
        default = ... if f.required else None
        metadata = list(f.info.metadata)
        if f.name in _SECTIONS:
            section = _SECTIONS[f.name]
            model = section if isinstance(section, type) else section()
            key = next(m for m in metadata if isinstance(m, Key))
            fields[f.name] = (Annotated[model if f.required else model | None, key], default)
        else:
            fields[f.name] = (Annotated[Any, *metadata], default if f.required else f.default)
    config = ConfigDict(**FileTable.model_config, title="trainctl scenario",
                        json_schema_extra={"dependentRequired": {"simulation": ["controller"]}})
    return create_model("Scenario", __config__=config, **fields)


def _controller(names: tuple[str, ...], default: str, refs: dict[str, str],
                defs: dict[str, Any]) -> dict[str, Any]:
    """``[controller]``: the primary family's keys (by ``family``) and family sub-tables."""
    branches = []
    for name in names:
        closed = refs[name].rsplit("/", 1)[-1]
        open_name = f"{closed}Keys"
        defs[open_name] = {k: v for k, v in defs[closed].items() if k != "additionalProperties"}
        condition: dict[str, Any] = {"properties": {"family": {"const": name}}}
        if name != default:
            condition["required"] = ["family"]
        then = {"allOf": [{"$ref": f"#/$defs/{open_name}"}, {"properties": {name: False}}]}
        branches.append({"if": condition, "then": then})
    family = {
        "enum": list(names), "default": default, "title": "Controller family",
        "description": "The primary controller family: the rest of [controller] holds its "
        "settings; further families go in [controller.<family>] sub-tables.",
    }
    return {
        "type": "object",
        "title": "Controller design(s)",
        "description": "The primary family's keys, and one sub-table per further family.",
        "properties": {"family": family, **{n: {"$ref": refs[n]} for n in names}},
        "allOf": branches,
        "unevaluatedProperties": False,
    }


def _clean(node: Any) -> Any:
    """Drop ``null`` alternatives and ``null`` defaults: TOML has no null."""
    if isinstance(node, list):
        return [_clean(item) for item in node]
    if not isinstance(node, dict):
        return node
    out = {k: _clean(v) for k, v in node.items() if not (k == "default" and v is None)}
    options = out.get("anyOf")
    if isinstance(options, list) and {"type": "null"} in options:
        kept = [o for o in options if o != {"type": "null"}]
        del out["anyOf"]
        if len(kept) == 1:
            out = {**kept[0], **out}
        else:
            out["anyOf"] = kept
    return out


def json_schema() -> dict[str, Any]:
    """The JSON Schema of scenario files (draft 2020-12).

    Returns
    -------
    dict
        A JSON-serialisable schema: ``trainctl schema`` prints it.

    Examples
    --------
    >>> speed = json_schema()["$defs"]["ModelSettings"]["properties"]["speed_kmh"]
    >>> speed["unit"], speed["exclusiveMinimum"], speed["maximum"], speed["type"]
    ('km/h', 0, 1000.0, 'number')
    """
    from trainctl.registry import DEFAULT_FAMILY, family_names, get_family

    names = family_names()
    families = {n: file_model(get_family(n).settings) for n in names}
    document = _document()
    models = [document, *families.values()]
    refs, defs = models_json_schema([(m, "validation") for m in models],
                                    ref_template="#/$defs/{model}")
    all_defs = dict(defs.get("$defs", {}))
    root = all_defs.pop(document.__name__)
    family_refs = {n: refs[(m, "validation")]["$ref"] for n, m in families.items()}
    root["properties"]["controller"] = _controller(names, DEFAULT_FAMILY, family_refs, all_defs)
    root["properties"]["schema_version"]["const"] = SCHEMA_VERSION
    schema = {"$schema": DRAFT, **root, "$defs": all_defs}
    cleaned: dict[str, Any] = _clean(schema)
    return cleaned
