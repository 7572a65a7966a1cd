# The schema tables of analyses/README.md, generated from the key declarations.
"""Markdown tables of the scenario-file keys, from the declarations.

Each table lists a file table's keys with their type (and constraint), unit
(and conversion to SI), default and meaning, all taken from the same
declarations the parser uses. ``analyses/README.md`` holds them between
marker comments ``<!-- schema:NAME -->`` and ``<!-- /schema:NAME -->``; a
test fails when they drift. Regenerate them with::

    python -m trainctl.scenario.docs --write    # or: trainctl schema --markdown

Examples
--------
>>> print(markdown_tables()["model"].splitlines()[2])
| `speed_kmh` | number in (0, 1000] | km/h → m/s (÷ 3.6) | required | Cruise (linearisation) speed |
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from trainctl.declare.constraints import Choice
from trainctl.declare.keys import DeclaredField, Key, declared_fields
from trainctl.models.network.schema import Interruption, NetworkSettings
from trainctl.scenario.communication import CommunicationSettings
from trainctl.scenario.cost import CostSettings
from trainctl.scenario.filemodel import file_model, rule_of, sub_model, table_kind
from trainctl.scenario.plan import PlanSettings
from trainctl.scenario.settings import ModelSettings, SimulationSettings
from trainctl.scenario.tables import (
    CouplerTable,
    SectionTable,
    SpeedLimitTable,
    SweepAxisTable,
    SweepTable,
    TopLevel,
    TrackTable,
    TrainTable,
    VehicleTable,
)

__all__ = ["README", "main", "markdown_tables", "markdown_text", "table", "update_readme"]

README = Path(__file__).resolve().parents[2] / "analyses" / "README.md"
"""The README these tables live in (a source checkout)."""

_HEADER = "| Key | Type | Unit | Default | Meaning |\n|---|---|---|---|---|"
_MARKER = re.compile(r"(<!-- schema:(?P<name>[\w-]+) -->\n).*?(<!-- /schema:(?P=name) -->)",
                     re.DOTALL)


def _toml(value: Any) -> str:
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, list | tuple):
        return "`[" + ", ".join(_toml(v).strip("`") for v in value) + "]`"
    return f"`{value!r}`"


def _unit(key: Key | None) -> str:
    if key is None:
        return "-"
    unit = key.unit or "-"
    if key.si_text:
        return f"{unit} ({key.si_text})"
    if key.to_si is None or key.vector:
        return unit
    factor = float(key.to_si(1.0))
    scale = f"× {factor:g}" if factor >= 1 else f"÷ {1 / factor:g}"
    return f"{unit} → {key.si_unit} ({scale})"


def _name(f: DeclaredField, dotted: str) -> str:
    kind = table_kind(f)
    if kind == "table":
        return f"`[{dotted}.{f.name}]`" if dotted else f"`[{f.name}]`"
    if kind == "tables":
        return f"`[[{dotted}.{f.name}]]`"
    if kind == "either":
        return f"`[{dotted}.{f.name}]` / `[[{dotted}.{f.name}]]`"
    return f"`{f.name}`"


def _type(f: DeclaredField) -> str:
    kind = table_kind(f)
    if kind != "value":
        return {"table": "table", "tables": "array of tables",
                "either": "table or array of tables"}[kind]
    rule = rule_of(f)
    return rule.doc_type() if rule is not None else "any"


def _default(f: DeclaredField, groups: Sequence[tuple[str, ...]]) -> str:
    group = next((g for g in groups if f.name in g), None)
    if group is not None:
        return f"one of {({2: 'two', 3: 'three'}).get(len(group), len(group))}"
    if f.required:
        return "required"
    if f.key is not None and f.key.omitted:
        return f.key.omitted
    default = f.default
    if default is None or (isinstance(default, float) and math.isinf(default)):
        return "-"
    return _toml(default)


def _row(cells: Sequence[str]) -> str:
    return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"


def table(model: type[BaseModel], dotted: str = "", *, extra: Sequence[str] = ()) -> str:
    """The Markdown table of a file table's keys.

    Parameters
    ----------
    model : type of pydantic.BaseModel
        The file table (declared keys).
    dotted : str
        Its TOML table name, for sub-table rows (``"train"``).
    extra : sequence of str
        Rows to put first (already formatted).

    Returns
    -------
    str
        Header and one row per key, in declaration order.

    Examples
    --------
    The ``[[train.couplers]]`` keys; the stiffness is given in kN/m and
    stored in N/m, hence the factor 1000:

    >>> lines = table(CouplerTable).splitlines()
    >>> lines[0]
    '| Key | Type | Unit | Default | Meaning |'
    >>> [line.split(" | ")[0] for line in lines[2:]]
    ['| `stiffness_kn_per_m`', '| `damping_kn_s_per_m`', '| `virtual`', '| `gap`', \
'| `max_force_kn`']
    >>> lines[2].split(" | ")[2]
    'kN/m → N/m (× 1000)'
    """
    groups = getattr(model, "one_of_keys", ())
    rows = list(extra)
    for f in declared_fields(model):
        key = f.key
        rows.append(_row([_name(f, dotted), _type(f), _unit(key), _default(f, groups),
                          key.doc if key is not None else ""]))
    return "\n".join([_HEADER, *rows])


def _family_row(default: str, names: Sequence[str]) -> str:
    return _row(["`family`", Choice(tuple(names)).doc_type(), "-", f'`"{default}"`',
                 "The primary controller family; further families go in "
                 "`[controller.<family>]` sub-tables"])


def markdown_tables() -> dict[str, str]:
    """Every schema table of the README, by marker name.

    Returns
    -------
    dict of str to str
        ``"top"``, ``"train"``, ``"vehicle"``, ``"coupler"``, ``"track"``,
        ``"section"``, ``"speed-limit"``, ``"model"``, ``"controller-<family>"`` for each
        built-in family, ``"communication"``, ``"cost"``, ``"network"``, ``"interruption"``,
        ``"simulation"``, ``"reference"``, ``"sweep"`` and ``"sweep-axis"``.

    Examples
    --------
    >>> tables = markdown_tables()
    >>> len(tables), "controller-mpc" in tables
    (23, True)
    >>> tables["vehicle"].splitlines()[0]
    '| Key | Type | Unit | Default | Meaning |'
    """
    from trainctl.registry import DEFAULT_FAMILY, FAMILY_MODULES, get_family

    simulation = file_model(SimulationSettings)
    reference = next(f for f in declared_fields(simulation) if f.name == "reference")
    tables = {
        "top": table(TopLevel),
        "train": table(TrainTable, "train"),
        "vehicle": table(VehicleTable),
        "coupler": table(CouplerTable),
        "track": table(TrackTable, "track"),
        "section": table(SectionTable),
        "speed-limit": table(SpeedLimitTable),
        "model": table(file_model(ModelSettings)),
        "communication": table(file_model(CommunicationSettings)),
        "cost": table(file_model(CostSettings)),
        "network": table(file_model(NetworkSettings), "network"),
        "interruption": table(file_model(Interruption)),
        "simulation": table(simulation, "simulation"),
        "reference": table(sub_model(reference) or simulation),
        "plan": table(file_model(PlanSettings)),
        "sweep": table(SweepTable, "sweep"),
        "sweep-axis": table(SweepAxisTable),
    }
    names = tuple(FAMILY_MODULES)
    for name in names:
        settings = file_model(get_family(name).settings)
        tables[f"controller-{name}"] = table(settings, extra=[_family_row(DEFAULT_FAMILY, names)])
    return tables


def markdown_text() -> str:
    """Every schema table between its README markers, one after the other.

    Returns
    -------
    str
        The Markdown text of all tables.

    Examples
    --------
    Each of the 23 tables sits between its two markers, the top-level keys
    first:

    >>> text = markdown_text()
    >>> text.splitlines()[0], text.count("<!-- schema:"), text.count("<!-- /schema:")
    ('<!-- schema:top -->', 23, 23)
    """
    return "".join(f"<!-- schema:{name} -->\n{markdown}\n<!-- /schema:{name} -->\n\n"
                   for name, markdown in markdown_tables().items())


def update_readme(text: str) -> str:
    """``text`` with every marked table replaced by the generated one.

    Parameters
    ----------
    text : str
        The README's text.

    Returns
    -------
    str
        The text with the tables brought up to date.

    Raises
    ------
    KeyError
        If a marker names no generated table.

    Examples
    --------
    Only the text between the markers changes:

    >>> readme = "Couplers:\\n<!-- schema:coupler -->\\nstale\\n<!-- /schema:coupler -->\\nEnd.\\n"
    >>> new = update_readme(readme)
    >>> "stale" in new, new.startswith("Couplers:\\n<!-- schema:coupler -->\\n| Key |")
    (False, True)
    >>> new.endswith("<!-- /schema:coupler -->\\nEnd.\\n")
    True
    >>> update_readme(new) == new  # up to date: nothing to do
    True
    """
    tables = markdown_tables()
    return _MARKER.sub(lambda m: f"{m.group(1)}{tables[m.group('name')]}\n{m.group(3)}", text)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m trainctl.scenario.docs [--write] [README]``.

    Parameters
    ----------
    argv : sequence of str or None
        The arguments (None: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status.

    Examples
    --------
    ``--write`` brings a README's tables up to date in place:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     readme = Path(tmp) / "README.md"
    ...     _ = readme.write_text("<!-- schema:sweep -->\\n<!-- /schema:sweep -->\\n")
    ...     status = main(["--write", str(readme)])
    ...     lines = readme.read_text().splitlines()
    >>> status, lines[1] == table(SweepTable, "sweep").splitlines()[0]
    (0, True)
    """
    parser = argparse.ArgumentParser(prog="python -m trainctl.scenario.docs",
                                     description="Print or rewrite the schema tables.")
    parser.add_argument("readme", nargs="?", default=str(README), help="the README to update")
    parser.add_argument("--write", action="store_true", help="rewrite the README in place")
    args = parser.parse_args(argv)
    if not args.write:
        print(markdown_text(), end="")
        return 0
    path = Path(args.readme)
    path.write_text(update_readme(path.read_text(encoding="utf-8")), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
