# One pure function from report data to the template context; templates never compute.
"""Build the context of the report and gallery templates.

:func:`build_report_context` is the only place where results become display
values: numbers are formatted, units attached, statuses mapped to badges and
figures encoded. It reads no clock unless asked to (``generated_at``) and no
files, so the same data give the same page.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from trainctl._format import (
    docstring_units,
    format_complex,
    format_number,
    format_value,
    humanise,
    is_real,
    one_based,
)
from trainctl.report.checks import checks_context
from trainctl.report.comparison import controllers_context
from trainctl.report.data import ReportData
from trainctl.report.figures import FIGURES_SECTION, ReportFigure, family_section, report_figures

__all__ = ["MATRIX_COACHES_SHOWN", "build_index_context", "build_report_context", "headline"]

MATRIX_COACHES_SHOWN = 8
"""Per-coach matrices are listed for at most this many coaches."""

SECTIONS = (
    ("scenario", "Scenario"),
    ("model", "Model"),
    ("checks", "Design checks"),
    ("controllers", "Controllers compared"),
    ("claims", "Paper claims"),
    ("figures", "Figures"),
    ("reproducibility", "Reproducibility"),
)
"""Section anchors and titles, in page order."""

def utc_now() -> str:
    """The current UTC time, ISO 8601 to the second (``2026-11-22T05:30:00Z``)."""
    now = datetime.datetime.now(datetime.UTC)
    return now.isoformat(timespec="seconds").replace("+00:00", "Z")


def build_report_context(
    data: ReportData,
    *,
    generated_at: str | None = None,
    deterministic: bool = False,
) -> dict[str, Any]:
    """Everything the report template shows, display-ready.

    Parameters
    ----------
    data : ReportData
        From :func:`~trainctl.report.collect_report_data` or
        :meth:`ReportData.load`.
    generated_at : str or None
        Timestamp for the header and footer. None: the current UTC time, or
        no timestamp at all when ``deterministic``.
    deterministic : bool
        Leave out everything that depends on the wall clock (solve times,
        stage timings, the current time), so that the same data render to
        the same bytes.

    Returns
    -------
    dict
        Template variables (see ``templates/report.html.j2``).

    Examples
    --------
    The CRH2 design review without simulations, without a timestamp:

    >>> import trainctl
    >>> from trainctl.report import collect_report_data
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> context = build_report_context(data, deterministic=True)
    >>> context["checks"]["counts"], context["generated_at"]
    ({'pass': 13, 'warn': 3, 'fail': 3}, '')
    >>> context["headline"]
    '19 checks: 13 pass, 3 warn, 3 fail · ρ(D0) = 0.306 · no closed-loop simulation'
    """
    if generated_at is None and not deterministic:
        generated_at = utc_now()
    scenario = data.scenario
    checks = checks_context(data)
    figures = report_figures(data)
    sections = _sections(data, figures)
    placed = {s["id"] for s in sections if s["family"]}
    shown = [f for f in figures if f.section not in placed]
    return {
        "title": f"{scenario.name} — trainctl design report",
        "sections": sections,
        "scenario": _scenario(data),
        "headline": headline(data),
        "model": _model(data),
        "checks": checks,
        "controllers": controllers_context(data, deterministic=deterministic),
        "claims": _claims(data),
        "claims_source": _claims_sources(data),
        "figures": shown,
        "figure_numbers": _figure_numbers(sections, shown),
        "footer": _footer(data, generated_at=generated_at, deterministic=deterministic),
        "generated_at": generated_at or "",
    }


def _sections(data: ReportData, figures: Sequence[ReportFigure]) -> list[dict[str, Any]]:
    """The page's sections: the fixed ones, with one per controller family after the checks.

    A family's section lists the figures placed in it (:attr:`ReportFigure.section`).
    """
    from trainctl.registry import get_family

    sections: list[dict[str, Any]] = []
    for key, title in SECTIONS:
        if key == "claims" and not data.results.get("claims"):
            continue
        sections.append({"id": key, "title": title, "family": ""})
        if key != "checks":
            continue
        for name, family_data in data.families.items():
            family = get_family(name)
            if family.report_partial:
                sid = family_section(name)
                sections.append({"id": sid, "title": family.title, "family": name,
                                 "template": f"families/{name}.html.j2", "data": family_data,
                                 "figures": [f for f in figures if f.section == sid]})
    return sections


def _claims(data: ReportData) -> list[dict[str, str]]:
    """The run's published claims (each family's ``claims`` hook), each with its badge status.

    ``status`` maps the verdict onto the page's badges
    (:data:`~trainctl.analysis.claims.VERDICT_BADGES`: reproduced → pass,
    not reproduced → fail, depends → warn).
    """
    from trainctl.analysis.claims import VERDICT_BADGES

    return [{**c, "status": VERDICT_BADGES.get(c.get("kind", ""), "other")}
            for c in data.results.get("claims", [])]


def _claims_sources(data: ReportData) -> str:
    """Where the run's families' claims come from (their ``claims_source``), joined."""
    from trainctl.controllers.hooks import family_hook
    from trainctl.registry import get_family

    return "; ".join(source for name in data.families
                     if (source := family_hook(get_family(name), "claims_source")))


def _figure_numbers(sections: Sequence[Mapping[str, Any]],
                    shown: Sequence[ReportFigure]) -> dict[str, int]:
    """Figure key → its number, counted from 1 in page order (family sections, then Figures)."""
    order: list[ReportFigure] = []
    for section in sections:
        if section["family"]:
            order.extend(section["figures"])
        elif section["id"] == FIGURES_SECTION:
            order.extend(shown)
    return {f.key: k for k, f in enumerate(order, start=1)}


# --------------------------------------------------------------------------- scenario


def _scenario(data: ReportData) -> dict[str, Any]:
    scenario = data.scenario
    from trainctl.controllers.hooks import family_hook
    from trainctl.registry import get_family

    blocks: list[tuple[str, Any, str, Mapping[str, str]]] = [
        ("Model", scenario.model, "model", {})]
    controllers = dict(scenario.controllers)
    for i, (name, obj) in enumerate(controllers.items()):
        blocks.append(("Controller" if len(controllers) == 1 else f"Controller ({name})", obj,
                       "controller" if i == 0 else f"controller.{name}",
                       family_hook(get_family(name), "settings_labels")))
    blocks.append(("Simulation", scenario.simulation, "simulation", {}))
    tags = dict(scenario.tags)
    settings = []
    for title, obj, table, labels in blocks:
        if obj is None:
            continue
        rows = _settings_rows(obj, tags, table, labels)
        settings.append({"title": title, "rows": rows, "tag": tags.get(table, ""),
                         "sources": any(row.get("source") for row in rows)})
    return {
        "name": scenario.name,
        "description": scenario.description,
        "source": scenario.source,
        "seed": str(scenario.seed),
        "slug": scenario.slug,
        "text": data.scenario_text,
        "train": _train(scenario.train),
        "track": _track(scenario.track),
        "settings": settings,
        "expected": [{"name": k, "status": v} for k, v in data.expected.items()],
    }


def _field_names(settings: Any) -> list[str]:
    """Field names of a settings object: a dataclass, a pydantic model or a plain object."""
    if dataclasses.is_dataclass(settings):
        return [f.name for f in dataclasses.fields(settings)]
    fields = getattr(type(settings), "model_fields", None)
    if isinstance(fields, Mapping):
        return list(fields)
    return [k for k in vars(settings) if not k.startswith("_")]


def _file_keys(cls: type) -> dict[str, tuple[str, ...]]:
    """Field name → the file keys that can set it (its key, or its alternatives)."""
    from trainctl.declare.keys import declared_fields

    keys: dict[str, tuple[str, ...]] = {}
    for f in declared_fields(cls):
        if f.key is None:
            keys[f.name] = (f.name,)
        elif f.key.one_of:
            keys[f.name] = tuple(alt.key for alt in f.key.one_of)
        elif f.key.file != "":
            keys[f.name] = (f.key.file or f.name,)
    return keys


def _settings_rows(settings: Any, tags: Mapping[str, str] | None = None,
                   table: str = "", labels: Mapping[str, str] | None = None
                   ) -> list[dict[str, str]]:
    """Name, value, unit and source tag of every field of a settings object.

    ``tags`` are the scenario's source tags by file key path
    (:attr:`~trainctl.scenario.Scenario.tags`), ``table`` the file table
    the settings come from ("model", "controller", "controller.lqr", ...)
    and ``labels`` the family's labels of its fields (``settings_labels``).
    """
    labels = labels or {}
    units = docstring_units(type(settings))
    file_keys = _file_keys(type(settings))
    tags = tags or {}
    rows = []
    for name in _field_names(settings):
        value = getattr(settings, name)
        numeric = is_real(value) or (
            isinstance(value, tuple) and bool(value) and all(is_real(v) for v in value))
        unit = units.get(name, "") if numeric else ""
        if name == "input_weight":
            unit = f"per {settings.input_weight_unit}²"
        unit = unit.replace("^2", "²")
        shown = format_value(value)
        if numeric and (unit == "N" or unit.startswith("N/")):  # forces in kN, as elsewhere
            scaled = tuple(v / 1e3 for v in value) if isinstance(value, tuple) else value / 1e3
            shown, unit = format_value(scaled), "k" + unit
        source = next((tags[f"{table}.{key}"] for key in file_keys.get(name, (name,))
                       if f"{table}.{key}" in tags), "")
        rows.append({"name": labels.get(name) or humanise(name), "key": name, "value": shown,
                     "unit": unit,
                     "source": source})
        if name == "speed" and is_real(value):
            rows.append({"name": "Speed", "key": "speed_kmh",
                         "value": format_number(float(value) * 3.6), "unit": "km/h",
                         "source": source})
    return rows


def _train(train: Any) -> dict[str, Any]:
    vehicles = []
    for i, v in enumerate(train.vehicles):
        env = v.envelope
        vehicles.append({
            "index": str(i + 1), "name": v.name, "mass_t": format_number(v.mass / 1e3),
            "a0": format_number(v.a0), "a1": format_number(v.a1), "a2": format_number(v.a2),
            "traction_share": format_number(v.traction_share),
            "max_traction_kn": format_number(env.max_traction / 1e3),
            "max_braking_kn": format_number(env.max_braking / 1e3),
            "max_power_kw": format_number(env.max_power / 1e3),
            "length": format_number(v.length),
        })
    couplers = [{
        "index": str(i + 1), "between": f"{i + 1}–{i + 2}",
        "kind": "virtual" if c.virtual else "physical",
        "stiffness_kn_per_m": format_number(c.stiffness / 1e3),
        "damping_kn_s_per_m": format_number(c.damping / 1e3),
        "spacing": format_number(c.spacing),
        "max_force_kn": format_number(c.max_force / 1e3) if np.isfinite(c.max_force)
        else "no limit",
    } for i, c in enumerate(train.couplers)]
    return {"name": train.name, "n_vehicles": str(train.n_vehicles),
            "total_mass_t": format_number(float(np.sum(train.mass)) / 1e3),
            "vehicles": vehicles, "couplers": couplers,
            "coupler_limited": bool(np.any(np.isfinite(train.max_coupler_force)))}


def _track(track: Any) -> list[dict[str, str]]:
    if track is None:
        return []
    rows = []
    for section in track.sections:
        radius = float(section.curve_radius)
        rows.append({"start": format_number(section.start),
                     "grade_permille": format_number(section.grade_permille),
                     "curve_radius": "straight" if math.isinf(radius) else format_number(radius)})
    return rows


# --------------------------------------------------------------------------- model


def _model(data: ReportData) -> dict[str, Any]:
    r = data.results
    eq = r["equilibrium"]
    dummy = bool(data.scenario.model.dummy_state)
    overview = [
        {"name": "States" + (" (with the book's dummy state)" if dummy else ""),
         "value": str(r["n_states"]), "unit": "-"},
        {"name": "Inputs (one traction/braking force per vehicle, in N)",
         "value": str(r["n_inputs"]), "unit": "-"},
        {"name": "Outputs (speeds)", "value": one_based(", ".join(r["outputs"])),
         "unit": "m/s"},
        {"name": "Linearisation speed", "value": format_value(r["speed"]), "unit": "m/s"},
        {"name": "Linearisation speed", "value": format_value(r["speed_kmh"]), "unit": "km/h"},
        {"name": "Linearisation", "value": str(r["linearisation"]), "unit": ""},
        {"name": "Sample time T", "value": format_value(r["sampling"]["sample_time"]),
         "unit": "s"},
        {"name": "Largest sample time resolving the couplers (π/ω_max)",
         "value": format_value(r["sampling"]["nyquist_sample_time"]), "unit": "s"},
        {"name": "ω_max·T", "value": format_value(r["sampling"]["omega_max_times_T"]),
         "unit": "rad"},
        *_open_loop_radius(data),
        {"name": "Cruise force within the traction and braking envelopes (model speed; "
                 "the route: check 'feasibility')",
         "value": format_value(eq.get("feasible")), "unit": ""},
    ]
    equilibrium = [
        {"index": str(i + 1), "input_kn": _scaled(u, 1e-3), "limit_kn": _scaled(lim, 1e-3)}
        for i, (u, lim) in enumerate(zip(eq["inputs"], eq["traction_limit"], strict=True))]
    couplers = [
        {"index": f"{i + 1}–{i + 2}", "force_kn": _scaled(f, 1e-3),
         "elongation_mm": _scaled(x, 1e3)}
        for i, (f, x) in enumerate(zip(eq["coupler_forces"], eq["elongations"], strict=True))]
    modes = [{
        "kind": m["kind"],
        "eigenvalue": format_complex(*m["eigenvalue"]),
        "natural_frequency": format_value(m["natural_frequency"]),
        "damping_ratio": format_value(m["damping_ratio"]),
        "period": format_value(m["period"]),
        "multiplicity": str(m["multiplicity"]),
    } for m in r["modes"]]
    coaches = [_coach(c) for c in data.subsystems[:MATRIX_COACHES_SHOWN]]
    return {"overview": overview, "equilibrium": equilibrium, "couplers": couplers,
            "modes": modes, "coaches": coaches,
            "coaches_hidden": max(0, len(data.subsystems) - MATRIX_COACHES_SHOWN)}


def _open_loop_radius(data: ReportData) -> list[dict[str, str]]:
    """The discrete open-loop spectral radius, of the design model and, if kept, with the dummy.

    The design model (what the controllers and the eigenvalue figure use)
    drops the book's dummy state; the dummy's eigenvalue 0 becomes e^(0·T) = 1
    when sampled, so with it the radius is at least 1.
    """
    open_loop = data.spectra.get("open loop")
    design = float(np.max(np.abs(open_loop))) if open_loop is not None and open_loop.size else None
    n = data.results["n_states"] - int(bool(data.scenario.model.dummy_state))
    rows = [{"name": f"Discrete open-loop spectral radius, design model ({n} states, "
                     "no dummy state)", "value": format_value(design), "unit": "-"}]
    if data.scenario.model.dummy_state:
        rows.append({"name": "Discrete open-loop spectral radius with the book's dummy state "
                             "(its eigenvalue is 1)",
                     "value": format_value(data.results["sampling"]["discrete_spectral_radius"]),
                     "unit": "-"})
    return rows


def _scaled(value: float | None, factor: float) -> str:
    """``value * factor`` formatted; None (a non-finite number in JSON) as a dash."""
    return "—" if value is None else format_number(value * factor)


def _coach(coach: Mapping[str, Any]) -> dict[str, Any]:
    """One coach's matrices, numbered from 1 (coach i + 1, signals v₁, δ₁, …)."""
    i = coach["index"]
    states = [one_based(x) for x in coach["states"]]
    roles = {"B": "input", "C": "output"}
    matrices = []
    for block in coach["blocks"]:
        kind, j = block["kind"], block["from"]
        if kind == "A":
            columns = states if j == i else [one_based(x) for x in block["columns"]]
            role = "local dynamics" if j == i else f"coupling from coach {j + 1}"
            subscript = f"{i + 1},{j + 1}"
        else:
            columns = [one_based(f"u[{i}]") + " [N]"] if kind == "B" else states
            role, subscript = roles[kind], str(i + 1)
        row_labels = [one_based(f"y[{i}]") + " [m/s]"] if kind == "C" else states
        matrices.append({
            "kind": kind, "subscript": subscript, "role": role, "columns": columns,
            "rows": [{"label": row_labels[k] if k < len(row_labels) else str(k + 1),
                      "cells": [format_number(x) for x in row]}
                     for k, row in enumerate(block["matrix"])],
        })
    return {"index": str(i + 1), "states": ", ".join(states), "matrices": matrices}


# --------------------------------------------------------------------------- checks


def headline(data: ReportData) -> str:
    """One line of key results (the gallery shows it under the link).

    Parameters
    ----------
    data : ReportData
        The report's data.

    Returns
    -------
    str
        The check counts, ρ(D0) where known and the best tracking strategy.

    Examples
    --------
    ``12 checks: 7 pass, 3 warn, 2 fail · ρ(D0) = 0.306 · best tracking: ndmpc,
    max error 0.197 m/s``
    """
    checks = data.results.get("checks", [])
    counts = {s: sum(1 for c in checks if c["status"] == s) for s in ("pass", "warn", "fail")}
    parts = [f"{len(checks)} checks: " + ", ".join(f"{v} {k}" for k, v in counts.items())]
    quoted = _headline_checks(data)
    for check in checks:
        if check["name"] in quoted and check["value"] is not None:
            parts.append(f"{quoted[check['name']]} = {format_number(check['value'], 3)}")
    sims = data.results.get("simulations", {})
    if sims:
        best = min(sims, key=lambda name: max(x for x in sims[name]["max_error"]
                                              if x is not None))
        worst_err = max(x for x in sims[best]["max_error"] if x is not None)
        parts.append(f"best tracking: {best}, max error {format_number(worst_err, 3)} m/s")
    else:
        parts.append("no closed-loop simulation")
    return " · ".join(parts)


# --------------------------------------------------------------------------- footer


def _footer(data: ReportData, *, generated_at: str | None, deterministic: bool) -> dict[str, Any]:
    env = data.environment
    versions = [{"name": k, "version": v or "not installed"}
                for k, v in env.get("versions", {}).items()]
    versions.append({"name": "python", "version": str(env.get("python", ""))})
    timings = [] if deterministic else [
        {"stage": humanise(k), "seconds": format_number(v, 3)} for k, v in data.timings.items()]
    return {"versions": versions, "seed": str(data.scenario.seed), "command": data.command,
            "generated_at": generated_at or "", "timings": timings,
            "deterministic": deterministic}


# --------------------------------------------------------------------------- gallery


def build_index_context(
    entries: Sequence[Mapping[str, str]],
    *,
    generated_at: str | None = None,
    deterministic: bool = False,
    versions: Sequence[Mapping[str, str]] = (),
) -> dict[str, Any]:
    """Context of the gallery page.

    Parameters
    ----------
    entries : sequence of mapping
        One per report: ``name``, ``href`` (relative link), ``description``,
        ``headline`` (:func:`headline`) and ``source``.
    generated_at : str or None
        As for :func:`build_report_context`.
    deterministic : bool
        As for :func:`build_report_context`.
    versions : sequence of mapping
        ``name`` / ``version`` rows for the footer.

    Returns
    -------
    dict
        Template variables of ``templates/index.html.j2``.

    Examples
    --------
    >>> entry = {"name": "CRH2", "href": "crh2-dmpc.html", "description": "half train",
    ...          "headline": "19 checks", "source": "builtin:crh2-dmpc"}
    >>> context = build_index_context([entry], generated_at="2026-11-22T10:00:00Z")
    >>> context["entries"][0]["href"], context["generated_at"]
    ('crh2-dmpc.html', '2026-11-22T10:00:00Z')
    >>> build_index_context([], deterministic=True)["generated_at"]  # no time at all
    ''
    """
    if generated_at is None and not deterministic:
        generated_at = utc_now()
    return {"title": "trainctl — built-in analyses", "entries": [dict(e) for e in entries],
            "generated_at": generated_at or "", "versions": [dict(v) for v in versions]}


def _headline_checks(data: ReportData) -> dict[str, str]:
    """Check name → symbol, for the checks whose value the headline quotes (the families'
    ``headline_checks``)."""
    from trainctl.controllers.hooks import family_hook
    from trainctl.registry import get_family

    return {check: symbol for name in data.families
            for check, symbol in family_hook(get_family(name), "headline_checks").items()}
