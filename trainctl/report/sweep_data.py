# The sweep report's data: the store read back, its parameters and its quantities, labelled.
"""What the sweep report (:mod:`trainctl.report.sweep`) reads from a store, and how it names it.

:func:`load_sweep_report_data` reads a ``trainctl sweep`` store into a
:class:`SweepReportData`; the swept parameters (:class:`Parameter`) and the
drawn checks and metrics (:class:`Quantity`) are found in its table and
labelled from the scenario schema (:func:`key_label`, :func:`key_title`).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from trainctl._format import format_value
from trainctl.exceptions import ScenarioError
from trainctl.report.figures_sweep import (
    is_log,
)

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["REPORT_NAME", "SweepReportData", "default_sweep_report_path",
           "load_sweep_report_data"]

REPORT_NAME = "report.html"
"""File name of the default sweep report, inside the store."""

STATUSES = ("pass", "warn", "fail")
"""A check's statuses, best first (``other`` for anything else)."""


# --------------------------------------------------------------------------- data


@dataclass(frozen=True)
class SweepReportData:
    """What the sweep report shows, read from a store.

    Parameters
    ----------
    name : str
        The store directory's name.
    manifest : dict
        ``sweep.json``.
    table : pandas.DataFrame
        ``rows.parquet``.
    scenario_name : str
        The scenario's display name (from a point's summary; else the label).
    check_units : dict
        ``check name -> unit`` (from the first point's summary; may be empty).
    check_thresholds : dict
        ``check name -> threshold`` where constant (from the first point).

    Examples
    --------
    A design-review sweep of two input weights (no simulation): one
    parameter drawn, no strategy, no seeds:

    >>> import tempfile
    >>> from trainctl.sweep import sweep_scenario
    >>> tmp = tempfile.TemporaryDirectory()
    >>> _ = sweep_scenario("crh2-dmpc", tmp.name, axes=["controller.r_per_kn2=1,10"],
    ...                    simulate=False)
    >>> data = load_sweep_report_data(tmp.name)
    >>> data.parameters, data.strategies, data.seeded, data.table.shape[0]
    (['controller.r_per_kn2'], [], False, 2)
    >>> tmp.cleanup()
    """

    name: str
    manifest: Mapping[str, Any]
    table: pd.DataFrame
    scenario_name: str
    check_units: Mapping[str, str]
    check_thresholds: Mapping[str, Any]

    @property
    def swept(self) -> list[str]:
        """The swept keys, in order (``seed`` included when swept)."""
        return [str(k) for k in self.manifest["swept"]]

    @property
    def parameters(self) -> list[str]:
        """The swept keys drawn against: those taking several values, ``seed`` aside.

        ``seed`` is drawn against only when nothing else varies (a sweep of
        seeds alone); a key with one value is listed in the header, not drawn.
        """
        varying = [k for k in self.swept if self.table[k].nunique(dropna=False) > 1]
        keys = [k for k in varying if k != "seed"]
        return keys or [k for k in varying if k == "seed"] or self.swept[:1]

    @property
    def seeded(self) -> bool:
        """True when ``seed`` is swept beside other keys (values are aggregated over seeds)."""
        return "seed" in self.swept and self.parameters != ["seed"]

    @property
    def strategies(self) -> list[str]:
        """The simulated strategies in table order (empty without simulations)."""
        return [s for s in dict.fromkeys(self.table["strategy"].astype(str)) if s]


def default_sweep_report_path(store: str | os.PathLike[str]) -> Path:
    """Default output of ``trainctl report SWEEP_DIR``: ``SWEEP_DIR/report.html``.

    Parameters
    ----------
    store : str or os.PathLike
        The sweep store's directory.

    Returns
    -------
    pathlib.Path
        The report's path inside it.

    Examples
    --------
    >>> default_sweep_report_path("reports/sweeps/crh2-dmpc").as_posix()
    'reports/sweeps/crh2-dmpc/report.html'
    """
    return Path(store) / REPORT_NAME


def load_sweep_report_data(path: str | os.PathLike[str]) -> SweepReportData:
    """Read a finished sweep store for its report.

    Parameters
    ----------
    path : str or path-like
        The store's directory.

    Returns
    -------
    SweepReportData

    Raises
    ------
    ScenarioError
        Not a store, a damaged manifest (or one another trainctl version
        wrote), an unfinished sweep (no table), a point whose files do not
        have their recorded checksums (naming the file), or a table that
        does not fit the manifest or is not the table of the stored points.

    Examples
    --------
    The store of a two-point sweep; the N-DMPC check's threshold is
    ρ(D0) = 1:

    >>> import tempfile
    >>> from trainctl.sweep import sweep_scenario
    >>> tmp = tempfile.TemporaryDirectory()
    >>> _ = sweep_scenario("crh2-dmpc", tmp.name, axes=["controller.r_per_kn2=1,10"],
    ...                    simulate=False)
    >>> data = load_sweep_report_data(tmp.name)
    >>> data.swept, data.check_thresholds["ndmpc_convergence"]
    (['controller.r_per_kn2'], 1.0)
    >>> data.table["check.ndmpc_convergence.status"].tolist()
    ['fail', 'pass']
    >>> try:
    ...     load_sweep_report_data(tmp.name + "/points")
    ... except ScenarioError as error:
    ...     print("not a sweep store" in str(error))
    True
    >>> tmp.cleanup()
    """
    from trainctl.sweep.store import SweepStore

    root = Path(path)
    store = SweepStore.load(root)
    table = store.read_table()
    manifest = store.manifest
    swept = [str(k) for k in manifest["swept"]]
    hint = " The store was edited or damaged; run the sweep again into a new directory."
    missing = [c for c in ("point", "point_key", "strategy", *swept) if c not in table.columns]
    if missing:
        raise ScenarioError(f"{root}: rows.parquet lacks the column(s) "
                            f"{', '.join(missing)}.{hint}")
    listed = {int(p["index"]) for p in manifest["points"]}
    found = {int(p) for p in table["point"].dropna()}
    if not listed or found != listed:
        raise ScenarioError(f"{root}: rows.parquet holds {len(found)} points, the manifest "
                            f"lists {len(listed)}.{hint}")
    store.verify()  # every point stored whole: its files have their checksums
    if not table.equals(store.table()):
        raise ScenarioError(f"{root / 'rows.parquet'}: is not the table of the store's points "
                            f"(it was edited, or a point's summary was).{hint}")
    units: dict[str, str] = {}
    thresholds: dict[str, Any] = {}
    scenario_name = str(manifest.get("scenario", root.name))
    try:
        summary = store.summary(manifest["points"][0]["key"])
    except ScenarioError:
        summary = {}
    if isinstance(summary.get("scenario"), str):
        scenario_name = summary["scenario"]
    for check in summary.get("checks") or []:
        if isinstance(check, dict) and isinstance(check.get("name"), str):
            units[check["name"]] = str(check.get("unit") or "")
            thresholds[check["name"]] = check.get("threshold")
    return SweepReportData(name=root.resolve().name, manifest=manifest, table=table,
                           scenario_name=scenario_name, check_units=units,
                           check_thresholds=thresholds)


# --------------------------------------------------------------------------- parameters


@dataclass(frozen=True)
class Parameter:
    """A swept parameter: its distinct values in order and how to label them."""

    key: str
    label: str
    values: tuple[Any, ...]
    numeric: bool

    @property
    def ticks(self) -> tuple[str, ...]:
        return tuple(format_value(v) for v in self.values)

    @property
    def log(self) -> bool:
        return self.numeric and is_log([float(v) for v in self.values])

    def index(self, value: Any) -> int:
        return self.values.index(_plain(value))


def _plain(value: Any) -> Any:
    """A table value as a hashable Python value (numpy and pandas scalars unwrapped)."""
    if value is None:
        return None
    try:
        import pandas as pd

        if pd.isna(value):
            return None
    except (TypeError, ValueError):
        pass
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and value.is_integer():
        return value
    return value


def key_label(key: str) -> str:
    """A swept key as an axis label: the key and its unit from the scenario schema.

    Examples
    --------
    >>> key_label("model.sample_time")
    'model.sample_time [s]'
    >>> key_label("train.vehicle[0].mass_t")
    'train.vehicle[0].mass_t [t]'
    >>> key_label("seed")
    'seed'
    """
    unit = _schema_entry(key)[1]
    return f"{key} [{unit}]" if unit else key


def key_title(key: str) -> str:
    """A swept key's title in the scenario schema ("" when unknown).

    Examples
    --------
    >>> key_title("model.sample_time")
    'Sample time of the discrete model'
    >>> key_title("controller.r_per_kn2") != ""   # a key of the primary family (MPC)
    True
    """
    return _schema_entry(key)[0]


@lru_cache(maxsize=64)
def _schema_entry(key: str) -> tuple[str, str]:
    """(title, unit) of a dotted file key in the scenario's JSON Schema ("" when unknown)."""
    from trainctl.scenario import json_schema

    schema = json_schema()
    defs = schema.get("$defs", {})
    node: Any = schema
    for part in key.split("."):
        name, indexed = re.subn(r"\[\d+\]$", "", part)
        node = _resolve(node, defs)
        props = node.get("properties", {}) if isinstance(node, dict) else {}
        if name not in props:
            # [controller] holds the primary family's keys at its top level; the schema
            # declares them in the family's sub-table (controller.mpc, ...): the first
            # family that has the key names it.
            families = [_resolve(v, defs) for v in props.values()
                        if isinstance(v, dict) and "$ref" in v]
            found = [f["properties"][name] for f in families
                     if isinstance(f, dict) and name in f.get("properties", {})]
            if not found:
                return "", _unit_from_name(key)
            props = {name: found[0]}
        node = props[name]
        if indexed:  # train.vehicle[1]: an item of the array (or the one table)
            node = _resolve(node, defs)
            if isinstance(node, dict) and "items" in node:
                node = node["items"]
    node = _resolve(node, defs)
    if not isinstance(node, dict) or "properties" in node:
        return "", ""
    title = str(node.get("title", ""))
    unit = str(node.get("unit", "")) or _unit_in(str(node.get("description", "")))
    return (title if key.rsplit(".", 1)[-1] != "seed" else ""), unit


def _resolve(node: Any, defs: Mapping[str, Any]) -> Any:
    for _ in range(8):
        if not isinstance(node, dict):
            return node
        if "$ref" in node:
            node = {**defs.get(node["$ref"].rsplit("/", 1)[-1], {}),
                    **{k: v for k, v in node.items() if k != "$ref"}}
            continue
        for combo in ("anyOf", "oneOf", "allOf"):
            if combo in node and "properties" not in node and "type" not in node:
                options = [_resolve(o, defs) for o in node[combo]]
                objects = [o for o in options if isinstance(o, dict)
                           and ("properties" in o or "unit" in o or "title" in o)]
                if objects:
                    node = {**objects[0], **{k: v for k, v in node.items() if k != combo}}
                    break
        else:
            return node
    return node


def _unit_in(text: str) -> str:
    found = re.search(r"\[([^\]]+)\]", text)
    return found.group(1) if found else ""


def _unit_from_name(key: str) -> str:
    """A unit read from a key's name when the schema does not know it (``_kn2``, ``_s``)."""
    leaf = key.rsplit(".", 1)[-1]
    for suffix, unit in (("_per_kn2", "per kN²"), ("_kn", "kN"), ("_kmh", "km/h"),
                         ("_ms", "ms"), ("_s", "s"), ("_m", "m"), ("_kg", "kg")):
        if leaf.endswith(suffix):
            return unit
    return ""


def _parameters(data: SweepReportData) -> list[Parameter]:
    out = []
    for key in data.parameters:
        column = [_plain(v) for v in data.table[key]]
        values = list(dict.fromkeys(column))
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
        if numeric:
            values.sort()
        out.append(Parameter(key, key_label(key), tuple(values), numeric))
    return out


# --------------------------------------------------------------------------- quantities


@dataclass(frozen=True)
class Quantity:
    """One column drawn against the parameters.

    ``kind`` is ``"number"`` or ``"category"``; ``per_strategy`` is True for
    metrics (one line or panel per strategy), False for checks (one per point).
    """

    column: str
    title: str
    label: str
    kind: str
    per_strategy: bool
    good_when: bool | None = None


_METRIC_UNITS = {"rms_error": "m/s", "max_error": "m/s", "max_coupler_force": "N",
                 "energy_kwh": "kWh", "net_energy_kwh": "kWh",
                 "energy_per_tonne_km": "J/(t·km)", "operating_cost": "[cost] currency",
                 "iterations_mean": "per sample",
                 "iteration_limit_steps": "steps"}
_GOOD_WHEN = {"tracking_ok": True, "converged": True, "diverged": False}


def _quantities(data: SweepReportData) -> tuple[list[Quantity], list[Quantity],
                                                list[dict[str, str]]]:
    """Checks and metrics to draw, and the columns left out (constant or empty)."""
    table = data.table
    sim_rows = table[table["strategy"].astype(str) != ""]
    checks: list[Quantity] = []
    metrics: list[Quantity] = []
    skipped: list[dict[str, str]] = []
    for column in table.columns:
        name = str(column)
        if name.startswith("check."):
            check, _, part = name[6:].rpartition(".")
            rows = table
            unit = data.check_units.get(check, "")
            if part == "status":
                q = Quantity(name, f"{check}: status", f"{check} status", "category", False)
            else:
                q = Quantity(name, f"{check}: value", f"{check}" + (f" [{unit}]" if unit else ""),
                             "number", False)
            target = checks
        elif name.startswith("metric."):
            metric = name[7:]
            rows = sim_rows
            boolean = str(table[name].dtype) in ("boolean", "bool")
            unit = _METRIC_UNITS.get(metric, "")
            q = Quantity(name, metric, metric + (f" [{unit}]" if unit else ""),
                         "category" if boolean else "number", True,
                         _GOOD_WHEN.get(metric, True) if boolean else None)
            target = metrics
        else:
            continue
        values = [_plain(v) for v in rows[name]] if len(rows) else []
        present = [v for v in values if v is not None and not (isinstance(v, float)
                                                                 and math.isnan(v))]
        if not present:
            skipped.append({"column": name, "value": "empty (no value at any point)"})
        elif len(set(map(_hashable, values))) == 1 or _nearly_constant(present):
            skipped.append({"column": name, "value": f"constant: {format_value(present[0])}"})
        elif q.kind == "number" and not all(isinstance(v, (int, float)) for v in present):
            skipped.append({"column": name, "value": "not numeric (not drawn)"})
        else:
            target.append(q)
    return checks, metrics, skipped


def _nearly_constant(values: Sequence[Any]) -> bool:
    """Numbers equal to rounding (a value recomputed at every point, 1e-9 apart)."""
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return False
    finite = [float(v) for v in values if math.isfinite(float(v))]
    if len(finite) != len(values):
        return False
    scale = max(abs(v) for v in finite)
    return max(finite) - min(finite) <= 1e-9 * scale


def _hashable(value: Any) -> Any:
    return repr(value)


def _category(q: Quantity, value: Any) -> str | None:
    value = _plain(value)
    if value is None:
        return None
    if q.good_when is not None:
        return "yes" if bool(value) else "no"
    return str(value) if str(value) in STATUSES else "other"


def _category_colour_key(q: Quantity, label: str) -> str:
    """The colour class of a category: yes/no by whether it is the good outcome."""
    if q.good_when is None:
        return label
    good = (label == "yes") == q.good_when
    return "pass" if good else "fail"
