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
3. *Certificates against simulation* — each certificate a family declares
   (:func:`~trainctl.report.sweep_checks.declared_certificates`: a design
   check and the simulation outcome that tests its promise) whose
   columns the table has: the count table (predicted pass / warn / fail
   against simulated ok / not ok) and the certificate's verdict per cell
   (laid out as the heat maps above) with the simulated outcome
   marked (a row of cells for one parameter); then every check against
   ``metric.tracking_ok`` (tracking held in every simulated strategy).
4. *Reproducibility* — the store, the command, versions.

The store's data and labels are read in :mod:`trainctl.report.sweep_data`,
the figures and certificates drawn in :mod:`trainctl.report.sweep_checks`;
this module builds the page's context and writes it.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from markupsafe import Markup

from trainctl._format import format_value
from trainctl.analysis.certificates import Certificate, Outcome
from trainctl.exceptions import ScenarioError
from trainctl.report.figures import ReportFigure
from trainctl.report.figures_sweep import (
    MAX_PANELS,
)
from trainctl.report.sweep_checks import (
    _certificates,
    _figure_for,
    _slug,
    _tracking_rows,
    agreement_counts,
    declared_certificates,
)
from trainctl.report.sweep_data import (
    REPORT_NAME,
    Parameter,
    Quantity,
    SweepReportData,
    _parameters,
    _plain,
    _quantities,
    default_sweep_report_path,
    key_label,
    key_title,
    load_sweep_report_data,
)

if TYPE_CHECKING:

    from trainctl.report.output import OutputTarget

__all__ = [
    "POINTS_OPEN",
    "REPORT_NAME",
    "Certificate",
    "Outcome",
    "SweepReportData",
    "agreement_counts",
    "build_sweep_context",
    "declared_certificates",
    "default_sweep_report_path",
    "load_sweep_report_data",
    "render_sweep_report",
    "write_sweep_report",
]

POINTS_OPEN = 20
"""The table of points is shown open up to this many points, folded beyond."""




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


def __getattr__(name: str) -> Any:
    """``CERTIFICATES``: every family's certificates (:func:`declared_certificates`), kept
    under its former name."""
    if name == "CERTIFICATES":
        return declared_certificates()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
