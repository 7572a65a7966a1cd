# The "Controllers compared" section: closed-loop metrics, solver effort, linear loops.
"""Context of the report's comparison of the simulated strategies.

Three narrow tables instead of one wide one, so that the section fits a
1280 px window without scrolling: tracking, forces and energy; the solver's
effort; and the frequency-domain numbers of the linear closed loops
(:func:`trainctl.analysis.analyse_closed_loops`). Every header carries its
unit; forces are in kN.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from trainctl._format import format_number, format_value
from trainctl.report.data import ReportData

__all__ = ["controllers_context"]

_METRICS = (
    ("strategy", "Strategy", ""), ("rms_error", "RMS speed error", "m/s"),
    ("max_error", "Max speed error", "m/s"), ("max_coupler_force", "Max |coupler force|", "kN"),
    ("energy", "Net traction energy", "kWh"), ("max_jerk", "Max jerk (head)", "m/s³"),
    ("tracking", "Tracking", ""),
)
_COUPLER_LIMIT = ("coupler_limit", "Coupler admissible force (max_force_kn)", "")
"""Column of the metrics table when some coupler has an admissible force."""
_COST = ("operating_cost", "Operating cost (energy + train-hours)", "")
"""Column of the metrics table when the scenario declares prices (``[cost]``)."""
_SOLVER = (
    ("strategy", "Strategy", ""), ("iterations", "Iterations mean / max", "-"),
    ("solve_time", "Step time median / p95", "ms"), ("statuses", "Step statuses", ""),
)
_LOOPS = (
    ("strategy", "Strategy", ""),
    ("speed", "Grade → speed error: peak σ at ω", "(m/s)/(m/s²) at rad/s"),
    ("force", "Grade → coupler force: peak σ at ω", "kN/(m/s²) at rad/s"),
    ("sensitivity", "‖S‖∞ at ω", "- at rad/s"),
    ("complementary", "‖T‖∞ at ω", "- at rad/s"),
    ("bandwidth", "Bandwidth", "rad/s"),
    ("step", "1 ‰ grade step: peak speed / force", "m/s / kN"),
)


def controllers_context(data: ReportData, *, deterministic: bool) -> dict[str, Any]:
    """The comparison tables of the simulated strategies and their linear loops.

    Parameters
    ----------
    data : ReportData
        The report's data (``results["simulations"]`` and ``["frequency"]``).
    deterministic : bool
        Leave out the wall-clock step times.

    Returns
    -------
    dict
        ``tables``: list of ``{"key", "caption", "columns", "rows"}`` (columns
        ``{"key", "title", "unit"}``; rows ``{"ok", "cells"}``), and ``note``.

    Examples
    --------
    Without simulations only the table of the linear closed loops is left,
    one row per loop:

    >>> import trainctl
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> from trainctl.report import collect_report_data
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> context = controllers_context(data, deterministic=True)
    >>> [t["key"] for t in context["tables"]], context["simulated"]
    (['loops'], False)
    >>> context["tables"][0]["rows"][0]["cells"][0]
    'centralised'
    """
    sims = data.results.get("simulations", {})
    tables = []
    if sims:
        limited = any(m.get("coupler_verdict") for m in sims.values())
        metrics: tuple[tuple[str, str, str], ...] = (
            _METRICS[:-1] + (_COUPLER_LIMIT,) + _METRICS[-1:] if limited else _METRICS)
        if any(m.get("operating_cost") for m in sims.values()):
            metrics = metrics[:5] + (_COST,) + metrics[5:]
        tables.append(_table("metrics", "Tracking, forces and energy", metrics,
                             {name: _metric_cells(m) for name, m in sims.items()}, sims))
        solver = [c for c in _SOLVER if not (deterministic and c[0] == "solve_time")]
        tables.append(_table("solver", "Solver effort and step outcomes", tuple(solver),
                             {name: _solver_cells(m) for name, m in sims.items()}, sims))
    repetitions = data.results.get("repetitions", {})
    if repetitions:
        tables.append(_repetition_table(data, repetitions))
    loops = data.results.get("frequency", {})
    if loops:
        tables.append(_table(
            "loops", "Linear closed loops (unconstrained, at the linearisation speed): peaks "
            "over frequency, S and T at the plant input (figures below); “≤ ω”: still "
            "rising at the lowest frequency shown", _LOOPS,
            {name: _loop_cells(entry) for name, entry in loops.items()}, {}))
    return {"tables": tables, "note": _note(data), "simulated": bool(sims)}


def _table(key: str, caption: str, columns: tuple[tuple[str, str, str], ...],
           cells: Mapping[str, Mapping[str, str]], sims: Mapping[str, Any]) -> dict[str, Any]:
    rows = [{"ok": bool(sims[name].get("tracking_ok")) if name in sims else True,
             "cells": [name] + [row[k] for k, _, _ in columns[1:]]}
            for name, row in cells.items()]
    return {"key": key, "caption": caption,
            "columns": [{"key": k, "title": t, "unit": u} for k, t, u in columns], "rows": rows}


_SPREAD = (
    ("strategy", "Strategy (runs)", ""), ("rms", "RMS speed error, vehicle 1", "m/s"),
    ("max", "Max speed error, vehicle 1", "m/s"),
    ("settling", "Settling, vehicle 1", "s"), ("force", "Max |coupler force|", "kN"),
)


def _spread_cell(values: list[float | None], scale: float = 1.0) -> str:
    """``median [min – max]`` of some numbers (None: never settled, ∞)."""
    from trainctl.run.repetitions import spread

    x = [math.inf if v is None else float(v) * scale for v in values]
    if not x:
        return "—"
    m = spread(x)
    if m["count"] == 1:
        return format_number(m["median"], 4)
    return (f"{format_number(m['median'], 4)} [{format_number(m['min'], 3)} – "
            f"{format_number(m['max'], 3)}]")


def _repetition_table(data: ReportData, repetitions: Mapping[str, Any]) -> dict[str, Any]:
    """The spread of every strategy's whole-run measures over its repetitions and its
    baseline-network run (:mod:`trainctl.run.repetitions`)."""
    from trainctl.run.repetitions import SETTLING_BAND

    sim = data.scenario.simulation
    baseline = data.results.get("baseline_network", {})
    cells: dict[str, dict[str, str]] = {}

    def row(reps: list[Mapping[str, Any]]) -> dict[str, str]:
        d = [r["deviation"] for r in reps]
        return {"rms": _spread_cell([x["rms_error"][0] for x in d]),
                "max": _spread_cell([x["max_error"][0] for x in d]),
                "settling": _spread_cell([x["settling_time"][0] for x in d]),
                "force": _spread_cell([x["max_coupler_force"] for x in d], 1e-3)}

    for name, reps in repetitions.items():
        cells[f"{name} ({len(reps)})"] = row(reps)
        if name in baseline:
            kind = sim.baseline_network if sim is not None else "baseline"
            cells[f"{name}, {kind} network"] = row(list(baseline[name]))
    since = sim.reference_times[-1] if sim is not None else 0.0
    seeds = ""
    if sim is not None:
        seeds = f"seeds {data.scenario.seed} to {data.scenario.seed + sim.repetitions - 1}; "
    caption = (f"Spread over the repetitions ({seeds}median [min – max]), over the whole run, "
               "each against its baseline run with the same seed: speed errors and settling "
               f"of vehicle 1 (the head), settling the time after t = {since:g} s until its "
               f"speed error stays within {SETTLING_BAND:g} m/s (∞: not by the end, or the "
               "run diverged); coupler forces of the whole train")
    rows = [{"ok": True, "cells": [name] + [c[k] for k, _, _ in _SPREAD[1:]]}
            for name, c in cells.items()]
    return {"key": "repetitions", "caption": caption,
            "columns": [{"key": k, "title": t, "unit": u} for k, t, u in _SPREAD], "rows": rows}


def _metric_cells(m: Mapping[str, Any]) -> dict[str, str]:
    rms = [x for x in m["rms_error"] if x is not None]
    maxe = [x for x in m["max_error"] if x is not None]
    return {
        "rms_error": format_number(math.sqrt(sum(x * x for x in rms) / len(rms)), 4)
        if rms else "—",
        "max_error": format_number(max(maxe), 4) if maxe else "—",
        "max_coupler_force": format_number((m["max_coupler_force"] or 0.0) / 1e3, 4),
        "energy": format_value(_round(m["energy_kwh"])),
        "max_jerk": format_value(_round(m["max_jerk"])),
        "tracking": "within tolerance" if m.get("tracking_ok") else "outside tolerance",
        "coupler_limit": _coupler_cell(m.get("coupler_verdict")),
        "operating_cost": _cost_cell(m.get("operating_cost")),
    }


def _cost_cell(cost: Mapping[str, Any] | None) -> str:
    """The operating cost of one strategy (:class:`~trainctl.sim.energy.OperatingCost`).

    Examples
    --------
    >>> _cost_cell({"total": 1234.5, "energy": 434.5, "time": 800.0, "currency": "EUR"})
    '1234 EUR (energy 434.5, time 800)'
    """
    if not cost:
        return "—"
    return (f"{format_number(cost['total'], 4)} {cost['currency']} (energy "
            f"{format_number(cost['energy'], 4)}, time {format_number(cost['time'], 4)})")


def _coupler_cell(verdict: Mapping[str, Any] | None) -> str:
    """The coupler-limit verdict of one strategy (:meth:`Metrics.coupler_verdict`).

    Examples
    --------
    >>> _coupler_cell({"exceeded": True, "couplers_over": [2], "coupler": 2, "ratio": 1.12,
    ...                "limit": 2.25e6, "time": 31.5, "over_time": 2.0, "peak_force": 2.52e6})
    'exceeded: coupler 2 by 12 % of 2250 kN at t = 31.5 s, for 2 s'
    """
    if not verdict:
        return "no limit"
    limit = format_number(verdict["limit"] / 1e3, 4)
    if not verdict.get("exceeded"):
        return (f"held: closest coupler {verdict['coupler']} at "
                f"{format_number(100 * verdict['ratio'], 3)} % of {limit} kN")
    more = len(verdict.get("couplers_over", ())) - 1
    others = f" (and {more} more)" if more > 0 else ""
    return (f"exceeded: coupler {verdict['coupler']}{others} by "
            f"{format_number(100 * (verdict['ratio'] - 1), 3)} % of {limit} kN at t = "
            f"{format_number(verdict['time'], 4)} s, for "
            f"{format_number(verdict['over_time'], 4)} s")


def _solver_cells(m: Mapping[str, Any]) -> dict[str, str]:
    return {
        "iterations": f"{format_number(m['iterations_mean'], 3)} / {m['iterations_max']}",
        "solve_time": f"{format_number(_ms(m['solve_time_median']), 3)} / "
                      f"{format_number(_ms(m['solve_time_p95']), 3)}",
        "statuses": ", ".join(f"{k} {v}" for k, v in m["status_counts"].items() if v),
    }


def _loop_cells(entry: Mapping[str, Any]) -> dict[str, str]:
    step = entry.get("grade_step", {})
    bandwidth = entry.get("bandwidth")
    low = (entry.get("omega_range") or [0.0])[0]
    note = str(entry.get("bandwidth_note") or "")
    return {
        "speed": _peak(entry.get("speed_error_peak"), low),
        "force": _peak(entry.get("coupler_force_peak"), low),
        "sensitivity": _peak(entry.get("sensitivity_peak"), low),
        "complementary": _peak(entry.get("complementary_sensitivity_peak"), low),
        "bandwidth": format_number(bandwidth, 4) if bandwidth is not None
        else "none: pole at z = 1" if "z = 1" in note
        else "> π/T" if "does not drop" in note else "—",
        "step": f"{_num(step.get('peak_speed'))} / {_num(step.get('peak_force'))}",
    }


def _peak(peak: Mapping[str, Any] | None, low: float) -> str:
    """``gain at ω``; ``at DC`` for ω = 0, ``at ≤ ω`` at the grid's lowest frequency (rising)."""
    if not peak or peak.get("gain") is None:
        return "—"
    frequency = peak.get("frequency")
    if frequency == 0:
        where = "DC"
    elif frequency is not None and frequency <= low * (1 + 1e-9):
        where = f"≤ {_num(frequency, 3)}"
    else:
        where = _num(frequency, 3)
    return f"{_num(peak['gain'])} at {where}"


def _num(x: float | None, digits: int = 4) -> str:
    return "—" if x is None else format_number(x, digits)


def _note(data: ReportData) -> str:
    sim = data.scenario.simulation
    if sim is None:
        return ""
    return (f"{format_number(sim.duration)} s on the nonlinear plant, sample time "
            f"{format_number(data.scenario.model.sample_time)} s; errors after "
            f"{format_number(sim.settle_time)} s, tolerance "
            f"{format_number(sim.tracking_tolerance)} m/s; measurement noise σ = "
            f"{format_number(sim.measurement_noise)} m/s.")


def _round(x: float | None) -> float | None:
    return None if x is None else float(f"{x:.4g}")


def _ms(x: float | None) -> float:
    return math.nan if x is None else x * 1e3
