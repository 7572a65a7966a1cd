# The HTML report of a sweep store: header, points, every check and metric against the parameters.
"""The sweep report: ``trainctl report SWEEP_DIR`` for a store of ``trainctl sweep``.

The page follows the design report's rules (:mod:`trainctl.report`): one
self-contained HTML file (inline CSS and SVG, no script, no remote
resource), the package's Jinja environment and stylesheet, an atomic write,
``--deterministic`` for byte-identical output. Its default path is
``<SWEEP_DIR>/report.html`` (:func:`default_sweep_report_path`): the page
lives beside the results it shows.

Sections:

1. *Sweep* — scenario, trainctl version, number of points, the swept
   parameters and their values, seeds, whether the points were simulated;
   the table of points (in a closed ``<details>`` beyond
   :data:`POINTS_OPEN` points).
2. *Design checks* and *Metrics* (two sections) — each check's status and value and
   each metric against the swept parameters (:mod:`trainctl.report.figures_sweep`):
   one parameter, lines (one per strategy; median and min–max band over
   seeds); two, heat maps (one per strategy); more than two, heat maps over
   the first two, one panel per combination of the others, at most
   :data:`~trainctl.report.figures_sweep.MAX_PANELS` panels per figure.
   With seeds a heat map shows the median over them (a status: the worst,
   with the count of passing seeds). A sweep of seeds only draws against
   the seed. Columns constant over the sweep, or empty, are listed in one
   table instead of drawn.
3. *Certificates against simulation* — each pair of :data:`CERTIFICATES`
   (a design check and the simulation outcome that tests its promise) whose
   columns the table has: the count table (predicted pass / warn / fail
   against simulated ok / not ok) and the certificate's verdict per cell
   (laid out as the heat maps above) with the simulated outcome
   marked (a row of cells for one parameter); then every check against
   ``metric.tracking_ok`` (tracking held in every simulated strategy).
4. *Reproducibility* — the store, the command, versions.
"""

from __future__ import annotations

import itertools
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from markupsafe import Markup

from trainctl._format import format_value
from trainctl.exceptions import ScenarioError
from trainctl.report.figures import ReportFigure, encode
from trainctl.report.figures_sweep import (
    MAX_PANELS,
    Grid,
    Line,
    Panel,
    category_figure,
    certificate_figure,
    is_log,
    line_figure,
    numeric_map_figure,
)

if TYPE_CHECKING:
    import pandas as pd

    from trainctl.report.output import OutputTarget

__all__ = [
    "CERTIFICATES",
    "POINTS_OPEN",
    "REPORT_NAME",
    "Certificate",
    "Outcome",
    "SweepReportData",
    "agreement_counts",
    "build_sweep_context",
    "default_sweep_report_path",
    "load_sweep_report_data",
    "render_sweep_report",
    "write_sweep_report",
]

REPORT_NAME = "report.html"
"""File name of the default sweep report, inside the store."""

POINTS_OPEN = 20
"""The table of points is shown open up to this many points, folded beyond."""

STATUSES = ("pass", "warn", "fail")
"""A check's statuses, best first (``other`` for anything else)."""


# --------------------------------------------------------------------------- certificates


@dataclass(frozen=True)
class Outcome:
    """A simulated outcome: a boolean metric column and the value that means "fine".

    Parameters
    ----------
    metric : str
        The metric's name (column ``metric.<metric>``).
    ok_when : bool
        The value that means the promise held (``converged``: True,
        ``diverged``: False).
    says : str
        What "fine" means, for the page (``"converged"``).
    says_not : str
        What "not fine" means (``"did not converge"``).

    Examples
    --------
    >>> outcome = Outcome("diverged", False, "did not diverge", "diverged")
    >>> outcome.column, outcome.ok_when
    ('metric.diverged', False)
    """

    metric: str
    ok_when: bool
    says: str
    says_not: str

    @property
    def column(self) -> str:
        """``metric.<metric>``."""
        return f"metric.{self.metric}"


@dataclass(frozen=True)
class Certificate:
    """A design check and the simulation outcome that tests its promise.

    Parameters
    ----------
    check : str
        The check's name (columns ``check.<check>.status``/``.value``).
    strategies : tuple of str
        The simulated strategies it speaks for, as ``[simulation]`` names
        them (with or without the family prefix); the first present is used.
    outcomes : tuple of Outcome
        Simulated outcomes in order of preference: the first whose column
        the table has is used (a store made before a metric existed falls
        back to the next).
    promise : str
        What the check promises, for the page.

    Examples
    --------
    The N-DMPC certificate: its check, and the metric columns tried in turn:

    >>> cert = CERTIFICATES[0]
    >>> cert.check, [o.column for o in cert.outcomes]
    ('ndmpc_convergence', ['metric.converged', 'metric.tracking_ok', 'metric.diverged'])
    """

    check: str
    strategies: tuple[str, ...]
    outcomes: tuple[Outcome, ...]
    promise: str


CONVERGED = Outcome("converged", True, "converged", "did not converge")
NOT_DIVERGED = Outcome("diverged", False, "did not diverge", "diverged")
TRACKING = Outcome("tracking_ok", True, "tracked", "did not track")

CERTIFICATES: tuple[Certificate, ...] = (
    Certificate("ndmpc_convergence", ("ndmpc", "mpc.ndmpc"),
                (CONVERGED, TRACKING, NOT_DIVERGED),
                "ρ(D0) < 1: the N-DMPC iteration converges at every step"),
    Certificate("hinf_delay_margin", ("distributed", "hinf.distributed"),
                (NOT_DIVERGED, TRACKING),
                "the H∞ law keeps stability up to the network's largest delay"),
    Certificate("synchronous_delay_margin", ("synchronous", "synchronous.synchronous"),
                (NOT_DIVERGED, TRACKING),
                "synchronous operation keeps stability up to the network's largest delay"),
)
"""Declared pairs of a design check and what the simulation shows; add a pair here."""


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
                 "energy_kwh": "kWh", "iterations_mean": "per sample",
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


# --------------------------------------------------------------------------- figures


@dataclass
class _Layout:
    """How a sweep's points map onto panels and cells (strategies × further parameters)."""

    params: list[Parameter]
    strategies: list[str]
    panels: list[tuple[str, tuple[Any, ...]]]
    total: int

    @property
    def grid(self) -> Grid:
        x = self.params[0]
        y = self.params[1] if len(self.params) > 1 else None
        return Grid(
            x_label=x.label, y_label=y.label if y else "",
            x_ticks=x.ticks, y_ticks=y.ticks if y else ("",),
            x_values=tuple(float(v) for v in x.values) if x.numeric else None,
            y_values=(tuple(float(v) for v in y.values) if y and y.numeric else None)
            if y else (0.0,))

    def cell(self, row: Mapping[str, Any]) -> tuple[int, int]:
        x = self.params[0].index(row[self.params[0].key])
        y = self.params[1].index(row[self.params[1].key]) if len(self.params) > 1 else 0
        return x, y

    def facet(self, row: Mapping[str, Any]) -> tuple[Any, ...]:
        return tuple(_plain(row[p.key]) for p in self.params[2:])

    def title(self, strategy: str, facet: tuple[Any, ...]) -> str:
        parts = [strategy] if strategy else []
        parts += [f"{p.key} = {format_value(v)}" for p, v in zip(self.params[2:], facet,
                                                                    strict=True)]
        return ", ".join(parts)


def _layout(params: list[Parameter], strategies: list[str]) -> _Layout:
    facets = list(itertools.product(*(p.values for p in params[2:])))
    everything = [(s, f) for s in strategies for f in facets]
    return _Layout(params, strategies, everything[:MAX_PANELS], len(everything))


def _records(data: SweepReportData, per_strategy: bool) -> list[dict[str, Any]]:
    table = data.table
    if per_strategy:
        rows = table[table["strategy"].astype(str) != ""]
    else:
        rows = table.drop_duplicates("point")
    return [{k: _plain(v) for k, v in r.items()} for r in rows.to_dict("records")]


def _figure_for(q: Quantity, data: SweepReportData, params: list[Parameter],
                key: str) -> ReportFigure:
    strategies = data.strategies if q.per_strategy else [""]
    records = _records(data, q.per_strategy)
    seeds = " over seeds" if data.seeded else ""
    what = ("one line per strategy" if q.per_strategy and len(strategies) > 1 else "")
    if len(params) == 1 and q.kind == "number":
        p = params[0]
        lines = []
        for strategy in strategies:
            groups: dict[int, list[float]] = {}
            for r in records:
                if r.get("strategy", "") == strategy or not q.per_strategy:
                    v = r.get(q.column)
                    if v is not None and math.isfinite(float(v)):
                        groups.setdefault(p.index(r[p.key]), []).append(float(v))
            xs = sorted(groups)
            import numpy as np

            lines.append(Line(strategy,
                              tuple(float(p.values[i]) if p.numeric else float(i) for i in xs),
                              tuple(float(np.median(groups[i])) for i in xs),
                              tuple(min(groups[i]) for i in xs),
                              tuple(max(groups[i]) for i in xs)))
        figure = line_figure(lines, x_label=p.label, y_label=q.label,
                             x_ticks=None if p.numeric else p.ticks, band=data.seeded)
        caption = (f"{q.label} against {p.key}"
                   + (f" ({what})" if what else "")
                   + (f"; the line is the median{seeds}, the band the min–max{seeds}"
                      if data.seeded else "") + ".")
        return encode(key, q.title, caption, figure)
    layout = _layout(params, strategies)
    panels = {pf: Panel(layout.title(*pf)) for pf in layout.panels}
    buckets: dict[tuple[Any, ...], list[Any]] = {}
    for r in records:
        pf = (r.get("strategy", "") if q.per_strategy else "", layout.facet(r))
        if pf in panels:
            buckets.setdefault((pf, layout.cell(r)), []).append(r.get(q.column))
    if q.kind == "number":
        import numpy as np

        for (pf, cell), values in buckets.items():
            finite = [float(v) for v in values if v is not None and math.isfinite(float(v))]
            panels[pf].cells[cell] = float(np.median(finite)) if finite else math.nan
        figure = numeric_map_figure(layout.grid, list(panels.values()), label=q.label)
        how = f"median{seeds} per cell" if data.seeded else "one value per point"
    else:
        categories: list[str] = []
        for (pf, cell), values in buckets.items():
            labels = [c for c in (_category(q, v) for v in values) if c is not None]
            if not labels:
                continue
            worst = max(labels, key=_badness(q))
            panels[pf].cells[cell] = worst
            if len(values) > 1:
                good = sum(1 for c in labels if _category_colour_key(q, c) == "pass")
                panels[pf].notes[cell] = f"{worst} {good}/{len(values)}"
            categories.append(worst)
        order = [c for c in (("yes", "no") if q.good_when is not None else (*STATUSES, "other"))
                 if c in categories]
        colour_of: dict[str, str] = {c: _category_colour_key(q, c) for c in order}
        figure = category_figure(layout.grid, [_recolour(p, colour_of)
                                               for p in panels.values()],
                                 categories=[colour_of[c] for c in order], names=order,
                                 legend_title=q.label)
        how = (f"the worst{seeds} per cell, with the count of good seeds" if data.seeded
               else "one value per point")
    caption = (f"{q.label} over {' and '.join(p.key for p in params[:2])}"
               + (", one panel per strategy" if q.per_strategy and len(strategies) > 1 else "")
               + (f", one panel per value of {', '.join(p.key for p in params[2:])}"
                  if len(params) > 2 else "")
               + f" ({how}).")
    if layout.total > len(layout.panels):
        caption += (f" Showing the first {len(layout.panels)} of {layout.total} panels "
                    f"(at most {MAX_PANELS} per figure).")
    return encode(key, q.title, caption, figure)


def _recolour(panel: Panel, colour_of: Mapping[str, str]) -> Panel:
    """A yes/no panel with its labels replaced by their colour classes, words kept as notes."""
    out = Panel(panel.title)
    for cell, label in panel.cells.items():
        out.cells[cell] = colour_of[label]
        out.notes[cell] = panel.notes.get(cell, label)
    return out


def _badness(q: Quantity) -> Any:
    rank = {"pass": 0, "warn": 1, "fail": 2, "other": 3}

    def key(label: str) -> int:
        return rank.get(_category_colour_key(q, label), 3)
    return key


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "x"


# --------------------------------------------------------------------------- certificates


def _outcome_ok(outcome: Outcome, value: Any) -> bool | None:
    value = _plain(value)
    if value is None:
        return None
    return bool(value) == outcome.ok_when


def _predicted(status: Any) -> str:
    status = _plain(status)
    return str(status) if status in STATUSES else "other"


def agreement_counts(pairs: Sequence[tuple[str, bool | None]]) -> dict[str, int]:
    """Counts of predicted status against simulated outcome, and the agreement.

    Parameters
    ----------
    pairs : sequence of (str, bool or None)
        Per point: the check's status and whether the simulation was fine
        (None: no outcome).

    Returns
    -------
    dict
        ``"<status> & ok"``, ``"<status> & not ok"`` for pass, warn, fail
        and other, ``"no outcome"``, ``"agree"`` (pass & ok plus fail & not
        ok) and ``"decided"`` (pass or fail with an outcome).

    Examples
    --------
    >>> c = agreement_counts([("pass", True), ("fail", True), ("fail", False), ("warn", None)])
    >>> c["pass & ok"], c["fail & ok"], c["fail & not ok"], c["agree"], c["decided"]
    (1, 1, 1, 2, 3)
    """
    counts = {f"{s} & {o}": 0 for s in (*STATUSES, "other") for o in ("ok", "not ok")}
    counts["no outcome"] = 0
    for status, ok in pairs:
        if ok is None:
            counts["no outcome"] += 1
        else:
            counts[f"{status if status in STATUSES else 'other'} & {'ok' if ok else 'not ok'}"] \
                += 1
    counts["agree"] = counts["pass & ok"] + counts["fail & not ok"]
    counts["decided"] = counts["agree"] + counts["pass & not ok"] + counts["fail & ok"]
    return counts


def _certificate_rows(data: SweepReportData, cert: Certificate
                      ) -> tuple[str, Outcome, list[dict[str, Any]]] | None:
    """The strategy, outcome and the joined rows of a certificate, or None when absent."""
    table = data.table
    status = f"check.{cert.check}.status"
    if status not in table.columns:
        return None
    strategy = next((s for s in cert.strategies if s in data.strategies), None)
    outcome = next((o for o in cert.outcomes if o.column in table.columns), None)
    if strategy is None or outcome is None:
        return None
    rows = table[table["strategy"].astype(str) == strategy]
    records = [{k: _plain(v) for k, v in r.items()} for r in rows.to_dict("records")]
    return strategy, outcome, records


def _certificates(data: SweepReportData, params: list[Parameter]) -> list[dict[str, Any]]:
    out = []
    for cert in CERTIFICATES:
        found = _certificate_rows(data, cert)
        if found is None:
            continue
        strategy, outcome, records = found
        status, value = f"check.{cert.check}.status", f"check.{cert.check}.value"
        pairs = [(_predicted(r.get(status)), _outcome_ok(outcome, r.get(outcome.column)))
                 for r in records]
        counts = agreement_counts(pairs)
        fallback = outcome is not cert.outcomes[0]
        entry: dict[str, Any] = {
            "check": cert.check, "promise": cert.promise, "strategy": strategy,
            "outcome": outcome.column, "says": outcome.says, "says_not": outcome.says_not,
            "ok_when": "true" if outcome.ok_when else "false",
            "fallback": (f"{cert.outcomes[0].column} is not in this store's table; "
                         f"{outcome.column} stands in for it.") if fallback else "",
            "counts": _count_rows(counts), "agree": counts["agree"],
            "decided": counts["decided"], "no_outcome": counts["no outcome"],
            "rows": len(records), "figure": None,
            "value_unit": data.check_units.get(cert.check, ""),
        }
        if records:
            entry["figure"] = _certificate_figure(data, cert, strategy, outcome, records,
                                                  params, status, value)
        out.append(entry)
    return out


def _count_rows(counts: Mapping[str, int]) -> list[dict[str, Any]]:
    rows = []
    for status in (*STATUSES, "other"):
        ok, bad = counts[f"{status} & ok"], counts[f"{status} & not ok"]
        if status == "other" and not ok + bad:
            continue
        rows.append({"status": status, "ok": ok, "not_ok": bad,
                     "verdict": {"pass": "agree / missed", "fail": "conservative / agree"}
                     .get(status, "")})
    return rows


def _certificate_figure(data: SweepReportData, cert: Certificate, strategy: str,
                        outcome: Outcome, records: list[dict[str, Any]],
                        params: list[Parameter], status: str, value: str) -> ReportFigure:
    layout = _layout(params, [""])
    panels = {pf: Panel(layout.title(*pf)) for pf in layout.panels}
    buckets: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in records:
        pf = ("", layout.facet(r))
        if pf in panels:
            buckets.setdefault((pf, layout.cell(r)), []).append(r)
    seen: list[str] = []
    for (pf, cell), rows in buckets.items():
        statuses = [_predicted(r.get(status)) for r in rows]
        worst = max(statuses, key=lambda s: {"pass": 0, "warn": 1, "fail": 2}.get(s, 3))
        panels[pf].cells[cell] = worst
        seen.append(worst)
        oks = [_outcome_ok(outcome, r.get(outcome.column)) for r in rows]
        known = [o for o in oks if o is not None]
        if known and all(known):
            panels[pf].marks[cell] = True
        elif known and not any(known):
            panels[pf].marks[cell] = False
        elif known:
            panels[pf].marks[cell] = None
            panels[pf].notes[cell] = f"{sum(known)}/{len(known)}"
    categories = [s for s in (*STATUSES, "other") if s in seen]
    figure = certificate_figure(layout.grid, list(panels.values()), categories=categories,
                                outcome=outcome.says, outcome_not=outcome.says_not)
    caption = (f"Fill: the {cert.check} check's verdict (the design certificate); mark: "
               f"what the simulation of {strategy} showed ({outcome.column}: ○ "
               f"{outcome.says}, ✕ {outcome.says_not}"
               f"{'; k/n: k of n seeds ' + outcome.says if data.seeded else ''}).")
    if layout.total > len(layout.panels):
        caption += f" Showing the first {len(layout.panels)} of {layout.total} panels."
    return encode(f"certificate-{_slug(cert.check)}", f"{cert.check} against simulation",
                  caption, figure)


def _tracking_rows(data: SweepReportData,
                   checks: Sequence[Quantity]) -> list[dict[str, Any]]:
    """Every drawn check's status against tracking held in every simulated strategy."""
    if "metric.tracking_ok" not in data.table.columns or not data.strategies:
        return []
    table = data.table
    sims = table[table["strategy"].astype(str) != ""]
    tracked: dict[int, bool | None] = {}
    for point, group in sims.groupby("point", sort=True):
        values = [_plain(v) for v in group["metric.tracking_ok"]]
        tracked[int(point)] = None if any(v is None for v in values) else all(values)
    declared = {c.check for c in CERTIFICATES}
    out = []
    for column in table.columns:
        name = str(column)
        if not (name.startswith("check.") and name.endswith(".status")):
            continue
        check = name[6:-7]
        points = table.drop_duplicates("point")
        pairs = [(_predicted(s), tracked.get(int(p))) for p, s in zip(points["point"],
                                                                     points[name], strict=True)]
        counts = agreement_counts(pairs)
        out.append({"check": check, "declared": check in declared,
                    **{k.replace(" & ", "_").replace(" ", "_"): v for k, v in counts.items()}})
    return out


# --------------------------------------------------------------------------- context


def build_sweep_context(data: SweepReportData, *, generated_at: str | None = None,
                        deterministic: bool = False, command: str = "") -> dict[str, Any]:
    """Everything the sweep page shows, display-ready.

    Parameters
    ----------
    data : SweepReportData
        From :func:`load_sweep_report_data`.
    generated_at : str or None
        Timestamp; None: now, or none when ``deterministic``.
    deterministic : bool
        Leave out the wall clock (same store, same bytes).
    command : str
        The command line to print.

    Returns
    -------
    dict
        Template variables of ``templates/sweep.html.j2``.

    Examples
    --------
    Without simulations there are no metric figures and no certificates;
    each varying check gets a status and a value figure:

    >>> import tempfile
    >>> from trainctl.sweep import sweep_scenario
    >>> tmp = tempfile.TemporaryDirectory()
    >>> _ = sweep_scenario("crh2-dmpc", tmp.name, axes=["controller.r_per_kn2=1,10"],
    ...                    simulate=False)
    >>> context = build_sweep_context(load_sweep_report_data(tmp.name), deterministic=True)
    >>> context["show_metrics"], context["certificates"], context["sweep"]["points"]
    (False, [], 2)
    >>> [f.key for f in context["check_figures"]][:2]
    ['check-ndmpc-convergence-status', 'check-ndmpc-convergence-value']
    >>> tmp.cleanup()
    """
    from trainctl.report.context import utc_now
    from trainctl.sim.results import environment

    if generated_at is None and not deterministic:
        generated_at = utc_now()
    params = _parameters(data)
    checks, metrics, skipped = _quantities(data)
    check_figures = _figures(data, checks, params, "check")
    metric_figures = _figures(data, metrics, params, "metric")
    certificates = _certificates(data, params)
    numbers: dict[str, int] = {}
    for f in [*check_figures, *metric_figures,
              *[c["figure"] for c in certificates if c["figure"] is not None]]:
        numbers[f.key] = len(numbers) + 1
    manifest = data.manifest
    env = environment()
    versions = [{"name": k, "version": v or "not installed"}
                for k, v in dict(env["versions"]).items()]  # type: ignore[call-overload]
    versions.append({"name": "python", "version": str(env["python"])})
    sections = [("sweep", "Sweep"), ("points", "Points"), ("checks", "Design checks"),
                ("metrics", "Metrics"), ("certificates", "Certificates against simulation"),
                ("reproducibility", "Reproducibility")]
    if not data.strategies:
        sections = [s for s in sections if s[0] != "metrics"]
    n_points = len(manifest["points"])
    return {
        "title": f"{data.scenario_name} — trainctl sweep report",
        "sections": [{"id": i, "title": t} for i, t in sections],
        "sweep": {
            "name": data.name,
            "scenario": data.scenario_name,
            "label": str(manifest.get("scenario", "")),
            "trainctl": str(manifest.get("trainctl", "")),
            "points": n_points,
            "simulate": bool(manifest.get("simulate")),
            "strategies": ", ".join(data.strategies) or "—",
            "seeds": _seeds(data),
            "parameters": [_parameter_row(p) for p in _parameters_all(data)],
            "drawn": ", ".join(p.key for p in params),
            "layout": _layout_note(params),
        },
        "points": _points(data),
        "points_open": n_points <= POINTS_OPEN,
        "show_metrics": bool(data.strategies),
        "check_figures": check_figures,
        "metric_figures": metric_figures,
        "skipped": skipped,
        "certificates": certificates,
        "tracking": _tracking_rows(data, checks),
        "figure_numbers": numbers,
        "footer": {"command": command, "generated_at": generated_at or "",
                   "deterministic": deterministic, "versions": versions,
                   "store_version": str(manifest.get("trainctl", "")),
                   "format": str(manifest.get("format", ""))},
        "generated_at": generated_at or "",
    }


def _figures(data: SweepReportData, quantities: Sequence[Quantity], params: list[Parameter],
             prefix: str) -> list[ReportFigure]:
    out = []
    for q in quantities:
        if q.per_strategy and not data.strategies:
            continue
        out.append(_figure_for(q, data, params, f"{prefix}-{_slug(q.column[len(prefix) + 1:])}"))
    return out


def _parameters_all(data: SweepReportData) -> list[Parameter]:
    drawn = {p.key: p for p in _parameters(data)}
    out = []
    for key in data.swept:
        if key in drawn:
            out.append(drawn[key])
        else:
            values = list(dict.fromkeys(_plain(v) for v in data.table[key]))
            numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool)
                          for v in values)
            out.append(Parameter(key, key_label(key), tuple(sorted(values) if numeric
                                                           else values), numeric))
    return out


def _parameter_row(p: Parameter) -> dict[str, str]:
    values = p.ticks
    shown = ", ".join(values) if len(values) <= 8 else \
        ", ".join(values[:3]) + ", …, " + ", ".join(values[-2:])
    span = (f"{format_value(p.values[0])} … {format_value(p.values[-1])}"
            if p.numeric and len(values) > 1 else "")
    return {"key": p.key, "label": p.label, "title": key_title(p.key), "count": str(len(values)),
            "shown": shown,
            "range": span, "scale": "log" if p.log and len(values) > 2 else "linear"
            if p.numeric else "categories"}


def _seeds(data: SweepReportData) -> str:
    if "seed" not in data.swept:
        return "the scenario's seed (not swept)"
    seeds = list(dict.fromkeys(_plain(v) for v in data.table["seed"]))
    text = ", ".join(format_value(s) for s in seeds[:6]) + (", …" if len(seeds) > 6 else "")
    return f"{len(seeds)} seeds ({text})"


def _layout_note(params: Sequence[Parameter]) -> str:
    if len(params) == 1:
        return (f"Numbers are drawn against {params[0].key}, one line per strategy; statuses "
                "as a row of cells.")
    note = (f"Heat maps over {params[0].key} (x) and {params[1].key} (y), one panel per "
            "strategy")
    if len(params) > 2:
        note += (f" and per value of {', '.join(p.key for p in params[2:])} (at most "
                 f"{MAX_PANELS} panels per figure)")
    return note + "."


def _points(data: SweepReportData) -> dict[str, Any]:
    table = data.table
    status_columns = [c for c in table.columns if str(c).endswith(".status")]
    rows = []
    for entry in data.manifest["points"]:
        index = int(entry["index"])
        point_rows = table[table["point"] == index]
        first = point_rows.iloc[0]
        failed = [str(c)[6:-7] for c in status_columns if _plain(first[c]) == "fail"]
        outcome = ""
        if "metric.tracking_ok" in table.columns and data.strategies:
            bad = [str(s) for s, ok in zip(point_rows["strategy"],
                                           point_rows["metric.tracking_ok"], strict=True)
                   if _plain(ok) is False]
            outcome = ("all tracked" if not bad else "not tracked: " + ", ".join(bad))
        rows.append({"index": str(index),
                     "values": [format_value(_plain(first[k])) for k in data.swept],
                     "key": str(entry["key"])[:12], "failed": ", ".join(failed) or "—",
                     "outcome": outcome})
    return {"columns": [key_label(k) for k in data.swept], "rows": rows,
            "simulated": bool(data.strategies)}


# --------------------------------------------------------------------------- render / write


def render_sweep_report(context: Mapping[str, Any]) -> str:
    """Render the sweep page (``templates/sweep.html.j2``) with the inlined stylesheet.

    Parameters
    ----------
    context : Mapping
        From :func:`build_sweep_context`.

    Returns
    -------
    str
        A complete, self-contained HTML5 document.

    Examples
    --------
    >>> import tempfile
    >>> from trainctl.sweep import sweep_scenario
    >>> tmp = tempfile.TemporaryDirectory()
    >>> _ = sweep_scenario("crh2-dmpc", tmp.name, axes=["controller.r_per_kn2=1,10"],
    ...                    simulate=False)
    >>> context = build_sweep_context(load_sweep_report_data(tmp.name), deterministic=True)
    >>> html = render_sweep_report(context)
    >>> html.startswith("<!DOCTYPE html>"), "<script" in html
    (True, False)
    >>> tmp.cleanup()
    """
    from trainctl.report.render import _stylesheet, make_environment

    template = make_environment().get_template("sweep.html.j2")
    return template.render(**context, css=Markup(_stylesheet()))


def write_sweep_report(source: str | os.PathLike[str],
                       target: str | os.PathLike[str] | OutputTarget, *,
                       generated_at: str | None = None, deterministic: bool = False,
                       command: str = "") -> tuple[Path, SweepReportData]:
    """Read a sweep store and write its report (atomically; nothing on error).

    Parameters
    ----------
    source : str or path-like
        The store's directory.
    target : str, path-like or OutputTarget
        Where the page goes (:func:`~trainctl.report.output.write_output`).
    generated_at, deterministic, command
        As for :func:`build_sweep_context`.

    Returns
    -------
    (pathlib.Path, SweepReportData)
        The path written and the data shown.

    Raises
    ------
    ScenarioError
        The store is not finished, damaged, or its table does not fit the page.

    Examples
    --------
    A store whose table is missing (an interrupted sweep) is refused and
    nothing is written:

    >>> import os
    >>> import tempfile
    >>> from trainctl.sweep import sweep_scenario
    >>> tmp = tempfile.TemporaryDirectory()
    >>> _ = sweep_scenario("crh2-dmpc", tmp.name, axes=["controller.r_per_kn2=1,10"],
    ...                    simulate=False)
    >>> os.remove(os.path.join(tmp.name, "rows.parquet"))
    >>> try:
    ...     write_sweep_report(tmp.name, os.path.join(tmp.name, "report.html"))
    ... except ScenarioError as error:
    ...     print("the sweep has not finished" in str(error))
    True
    >>> os.path.exists(os.path.join(tmp.name, "report.html"))
    False
    >>> tmp.cleanup()
    """
    from trainctl.report.render import write_report

    data = load_sweep_report_data(source)
    try:
        html = render_sweep_report(build_sweep_context(data, generated_at=generated_at,
                                                       deterministic=deterministic,
                                                       command=command))
    except (KeyError, IndexError, TypeError, ValueError) as exc:
        what = f"key {exc.args[0]!r} is missing" if isinstance(exc, KeyError) else str(exc)
        raise ScenarioError(f"{source}: the sweep's table does not fit the report ({what}). "
                            "The store was edited or damaged; run the sweep again into a new "
                            "directory.") from None
    return write_report(html, target), data


def summary_line(data: SweepReportData) -> str:
    """``"8 points, 2 parameters, 3 strategies simulated"`` for the command's last line."""
    n = len(data.manifest["points"])
    k = len(data.parameters)
    text = f"{n} points, {k} parameter{'' if k == 1 else 's'}"
    if data.strategies:
        text += f", {len(data.strategies)} strategies simulated"
    return text

