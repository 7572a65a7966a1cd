# The sweep report's figures: each quantity against the parameters, each certificate tested.
"""Figures and certificate tables of the sweep report (:mod:`trainctl.report.sweep`).

Each check and metric is drawn against the swept parameters (lines, heat
maps, panels; :mod:`trainctl.report.figures_sweep`); each certificate a
family declares (:func:`declared_certificates`, the families'
``certificates()`` hook) is set against the simulated outcome that tests it
(:func:`agreement_counts`).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from trainctl._format import format_value
from trainctl.report.figures import ReportFigure, encode
from trainctl.report.figures_sweep import (
    MAX_PANELS,
    Grid,
    Line,
    Panel,
    category_figure,
    certificate_figure,
    line_figure,
    numeric_map_figure,
)

if TYPE_CHECKING:

    pass

from trainctl.analysis.certificates import Certificate, Outcome
from trainctl.report.sweep_data import (
    STATUSES,
    Parameter,
    Quantity,
    SweepReportData,
    _category,
    _category_colour_key,
    _plain,
)

__all__ = ["agreement_counts", "declared_certificates"]


def declared_certificates() -> tuple[Certificate, ...]:
    """Every known family's certificates, in :func:`~trainctl.registry.family_names` order.

    Returns
    -------
    tuple of Certificate
        The certificates (:class:`~trainctl.analysis.certificates.Certificate`)
        of every family's ``certificates()`` hook; a family without it declares none.

    Examples
    --------
    >>> checks = [c.check for c in declared_certificates()]
    >>> len(checks) == len(set(checks)) and "ndmpc_convergence" in checks
    True
    """
    from trainctl.controllers.hooks import family_hook
    from trainctl.registry import family_names, get_family

    return tuple(c for name in family_names()
                 for c in family_hook(get_family(name), "certificates")())


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
    for cert in declared_certificates():
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
    declared = {c.check for c in declared_certificates()}
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


