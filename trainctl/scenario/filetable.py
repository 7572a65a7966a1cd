# The pieces of a file table: its base class, its field metadata, the rules of declared fields.
"""The base of every scenario-file table and the metadata its generated fields carry.

:class:`FileTable` refuses unknown keys and documents its keys (its numpydoc
Parameters from the declarations, :func:`parameters_section`); :class:`Target`
and :class:`Section` mark, on a generated field, the SI field it sets and the
sub-table it holds; :func:`is_declared` and :func:`rule_of` read a settings
class's declarations. :mod:`trainctl.scenario.filemodel` builds the tables from
them (its names are re-exported there).
"""

from __future__ import annotations

import inspect
import re
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ConfigDict

from trainctl.declare.constraints import Rule
from trainctl.declare.keys import DeclaredField, declared_fields

__all__ = ["FileTable", "Section", "Target", "is_declared", "parameters_section", "rule_of"]


class FileTable(BaseModel):
    """Base of every file table: unknown keys are errors.

    A subclass's docstring gets a Parameters section written from its keys'
    :class:`~trainctl.declare.keys.Key` declarations (:func:`parameters_section`),
    so each key is described once, for the schema, the Markdown tables and
    the API reference alike. A table's JSON Schema description stays the
    first paragraph of its docstring.

    Examples
    --------
    :class:`~trainctl.scenario.train_tables.CouplerTable` is a file table: a
    misspelt key is refused, and its docstring lists its keys:

    >>> from pydantic import ValidationError
    >>> from trainctl.scenario.tables import CouplerTable
    >>> issubclass(CouplerTable, FileTable)
    True
    >>> CouplerTable.model_validate({"stiffness_kn_per_m": 1e4}).stiffness_kn_per_m  # [kN/m]
    10000.0
    >>> try:
    ...     CouplerTable.model_validate({"stiffnes_kn_per_m": 1e4})
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["type"], exc.errors()[0]["loc"])
    extra_forbidden ('stiffnes_kn_per_m',)
    >>> CouplerTable.__doc__.splitlines()[2:5]
    ['Parameters', '----------', 'stiffness_kn_per_m : float | None, optional']
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    @classmethod
    def __pydantic_init_subclass__(cls, **kwargs: Any) -> None:
        """Append the Parameters section of the new table to its own docstring.

        Parameters
        ----------
        **kwargs : dict
            Class keywords, passed on to pydantic.
        """
        super().__pydantic_init_subclass__(**kwargs)
        doc = cls.__dict__.get("__doc__")
        section = parameters_section(cls)
        if doc and section and "\nParameters\n" not in doc:
            # Before an Examples section, where numpydoc wants Parameters.
            head, sep, examples = inspect.cleandoc(doc).partition("\n\nExamples\n--------\n")
            tail = f"\nExamples\n--------\n{examples}\n" if sep else ""
            cls.__doc__ = f"{head}\n\n{section}{tail}"

    @classmethod
    def __get_pydantic_json_schema__(cls, core_schema: Any, handler: Any) -> Any:
        """The schema pydantic makes, its description cut to the docstring's summary.

        Parameters
        ----------
        core_schema : pydantic_core.CoreSchema
            The table's core schema.
        handler : pydantic.GetJsonSchemaHandler
            pydantic's schema generator.

        Returns
        -------
        dict
            The table's JSON Schema.
        """
        json_schema = handler(core_schema)
        target = handler.resolve_ref_schema(json_schema)
        description = target.get("description")
        if isinstance(description, str):
            target["description"] = description.split("\n\n")[0]
        return json_schema


def _type_text(annotation: Any) -> str:
    """A field's type as the API reference shows it, without module paths."""
    text = annotation.__name__ if isinstance(annotation, type) else str(annotation)
    return re.sub(r"\b(?:[A-Za-z_]\w*\.)+([A-Za-z_]\w*)", r"\1", text)


def parameters_section(cls: type[BaseModel]) -> str:
    """The numpydoc Parameters section of a file table, from its keys' declarations.

    A field without a :class:`~trainctl.declare.keys.Key` is left out (and so
    shows as undocumented to a docstring check).

    Parameters
    ----------
    cls : type
        A file table (a pydantic model whose fields carry ``Key`` metadata).

    Returns
    -------
    str
        The section, "" when no field is declared.

    Examples
    --------
    >>> from trainctl.scenario.tables import SectionTable
    >>> print(parameters_section(SectionTable).splitlines()[2:4])
    ['start : float', "    Where the section starts; it runs to the next section's start [m]."]
    """
    entries = []
    for f in declared_fields(cls):
        if f.key is None:
            continue
        optional = "" if f.required else ", optional"
        entries.append(f"{f.name} : {_type_text(f.info.annotation)}{optional}\n"
                       f"    {f.key.describe()}")
    return "Parameters\n----------\n" + "\n".join(entries) + "\n" if entries else ""


@dataclass(frozen=True)
class Target:
    """Metadata of a generated file field: the SI field it sets, and how.

    Parameters
    ----------
    field : str
        The SI field of the settings class.
    sets : mapping
        How the file value becomes the SI value (converter and alternatives).

    Examples
    --------
    The file key ``[simulation.reference].speeds_kmh`` sets the SI field
    ``reference_speeds`` [m/s]:

    >>> from trainctl.scenario.filemodel import field_at, file_model
    >>> from trainctl.scenario.settings import SimulationSettings
    >>> f = field_at(file_model(SimulationSettings), ("reference", "speeds_kmh"))
    >>> next(m for m in f.info.metadata if isinstance(m, Target))
    Target(field='reference_speeds', sets={})
    """

    field: str
    sets: Mapping[str, Any]


@dataclass(frozen=True)
class Section:
    """Metadata of a field that is a sub-table (``model``) or an array of them.

    Parameters
    ----------
    model : type or None
        The sub-table's model (None: checked by the section's own settings).
    array : bool
        An array of tables rather than one.

    Examples
    --------
    ``[simulation.reference]`` is a sub-table of the generated
    ``[simulation]`` model, so its field carries a ``Section``:

    >>> from trainctl.scenario.filemodel import field_at, file_model
    >>> from trainctl.scenario.settings import SimulationSettings
    >>> f = field_at(file_model(SimulationSettings), ("reference",))
    >>> section = next(m for m in f.info.metadata if isinstance(m, Section))
    >>> section.model.__name__, section.array
    ('SimulationSettings_reference', False)
    """

    model: type[BaseModel] | None
    array: bool = False


def is_declared(cls: type) -> bool:
    """True for a settings class whose fields carry :class:`Key` declarations.

    Parameters
    ----------
    cls : type
        Any class.

    Returns
    -------
    bool
        Whether it is a declared settings class (not itself a file table).

    Examples
    --------
    >>> from trainctl.scenario.settings import ModelSettings
    >>> from trainctl.scenario.tables import CouplerTable
    >>> is_declared(ModelSettings), is_declared(CouplerTable), is_declared(int)
    (True, False, False)
    """
    return any(f.key is not None for f in declared_fields(cls)) and not issubclass_safe(
        cls, BaseModel
    )


def issubclass_safe(cls: Any, base: type) -> bool:
    """``issubclass`` that is False for non-classes."""
    return isinstance(cls, type) and issubclass(cls, base)


def rule_of(f: DeclaredField) -> Rule | None:
    """The rule of a field, also inside ``Annotated[...] | None``.

    Parameters
    ----------
    f : DeclaredField
        The field.

    Returns
    -------
    Rule or None
        Its rule, or None without one.

    Examples
    --------
    The per-vehicle speed errors are optional (``... | None``), so their
    rule sits inside the annotation rather than on the field:

    >>> from trainctl.declare.keys import declared_fields
    >>> from trainctl.scenario.settings import SimulationSettings
    >>> f = next(f for f in declared_fields(SimulationSettings)
    ...          if f.name == "initial_speed_errors")
    >>> f.rule is None, type(rule_of(f)).__name__
    (True, 'Array')
    """
    return f.rule or _rule_in(f.info.annotation)


def _rule_in(annotation: Any) -> Rule | None:
    for arg in typing.get_args(annotation):
        if isinstance(arg, Rule):
            return arg
        found = _rule_in(arg)
        if found is not None:
            return found
    return None
