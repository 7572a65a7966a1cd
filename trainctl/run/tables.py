# What `trainctl analyse` prints of a run: the [expected] comparison, metrics, repetitions, claims.
"""The text tables of an :class:`~trainctl.run.AnalysisRun` and its ``frequency`` entry."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from trainctl.run.result import AnalysisRun
    from trainctl.sim.metrics import Metrics

__all__: list[str] = []  # helpers of AnalysisRun; frequency_dict is documented there


def _expected_text(run: AnalysisRun) -> str:
    skipped = run.unsimulated_checks
    declared = len(run.scenario.expected) - len(skipped)
    wrong = run.unexpected_checks()
    note = ("" if not skipped else f"\n  not compared without the simulation, which decides "
            f"them: {', '.join(skipped)}")
    if not wrong:
        return f"Expected outcomes ([expected]): all {declared} declared statuses match." + note
    lines = [f"Expected outcomes ([expected]): {len(wrong)} of {declared} declared "
             "statuses differ:"]
    lines += [f"  {name}: expected {want.upper()}, found {got.upper()}"
              for name, (want, got) in wrong.items()]
    return "\n".join(lines) + note


def frequency_dict(run: AnalysisRun) -> dict[str, object]:
    """The ``frequency`` entry of :meth:`AnalysisRun.to_dict`: numbers per strategy.

    Parameters
    ----------
    run : AnalysisRun
        The run.

    Returns
    -------
    dict
        Strategy → peak gains with their frequencies [rad/s], the bandwidth
        and the 1 ‰ grade-step peaks (:meth:`ClosedLoopResponse.to_dict`);
        empty without linear closed loops.
    """
    return {name: response.to_dict() for name, response in run.frequency.items()}


_NOTED = 8
"""Saturated vehicles (and overloaded couplers) listed one by one under the metrics table,
per strategy."""


def _metrics_table(run: AnalysisRun) -> str:
    sim = run.scenario.simulation
    assert sim is not None  # metrics exist only with a [simulation] section
    w = max([15] + [len(name) + 2 for name in run.metrics])
    plant = "nonlinear plant" + ("" if sim.plant_saturation else " without saturation")
    lines = [f"Closed-loop simulations ({sim.duration:g} s, {plant}; errors after "
             f"{sim.settle_time:g} s, tolerance {sim.tracking_tolerance:g} m/s; maxima "
             "between samples too):",
             f"  {'strategy':<{w}}{'RMS err':>9}{'max err':>9}{'max |f|':>9}{'energy':>9}"
             f"{'sat':>7}{'iters':>7}{'solve p50':>10}  statuses",
             f"  {'':<{w}}{'[m/s]':>9}{'[m/s]':>9}{'[kN]':>9}{'[kWh]':>9}{'[s]':>7}{'mean':>7}"
             f"{'[ms]':>10}"]
    notes = []
    for name, m in run.metrics.items():
        ok = "" if run.tracking_ok(name) else "  (tracking outside tolerance)"
        statuses = ", ".join(f"{k} {v}" for k, v in m.status_counts.items() if v)
        statuses += "".join(f"; {f} {c}" for f, c in m.fallback_counts.items())
        lines.append(f"  {name:<{w}}{_cell(float(np.sqrt(np.mean(m.rms_error**2))), 9, 3)}"
                     f"{_cell(float(np.max(m.max_error)), 9, 3)}"
                     f"{_cell(m.max_coupler_force / 1e3, 9, 2)}{_cell(m.energy, 9, 2)}"
                     f"{_cell(float(np.max(m.saturation_time)), 7, 0)}"
                     f"{m.iterations_mean:>7.1f}{m.solve_time_median * 1e3:>10.2f}  "
                     f"{statuses}{ok}")
        notes += _run_notes(name, m)
    return "\n".join(lines + notes)


def _repetitions_table(run: AnalysisRun) -> str:
    """Each strategy's whole-run measures over its repetitions (median [min, max]) and its
    baseline-network run."""
    from trainctl.run.repetitions import SETTLING_BAND, spread

    sim = run.scenario.simulation
    assert sim is not None
    w = max([15] + [len(name) + 2 for name in run.metrics])
    lines = [f"Repetitions ({sim.repetitions} runs per strategy, seeds {run.scenario.seed} to "
             f"{run.scenario.seed + sim.repetitions - 1}; whole run, vehicle 1; median "
             f"[min, max]; settling: within {SETTLING_BAND:g} m/s after t = "
             f"{sim.reference_times[-1]:g} s):",
             f"  {'strategy':<{w}}{'RMS err [m/s]':>26}{'max err [m/s]':>26}"
             f"{'settling [s]':>26}{'max |f| [kN]':>26}"]

    def cell(values: list[float], scale: float = 1.0) -> str:
        if not values:
            return f"{'-':>26}"
        x = spread(np.asarray(values) * scale)
        return f"{x['median']:>10.4g} [{x['min']:.3g}, {x['max']:.3g}]".rjust(26)

    for name in run.metrics:
        reps = list(run.repetitions.get(name, ()))
        lines.append(f"  {name:<{w}}"
                     + cell([float(r.deviation.rms_error[0]) for r in reps])
                     + cell([float(r.deviation.max_error[0]) for r in reps])
                     + cell([float(r.deviation.settling_time[0]) for r in reps])
                     + cell([r.deviation.max_coupler_force for r in reps], 1e-3))
        if name in run.baseline:
            base = [r.deviation for r in run.baseline[name]]
            label = f"  {sim.baseline_network} network"
            lines.append(f"  {label:<{w}}" + cell([float(d.rms_error[0]) for d in base])
                         + cell([float(d.max_error[0]) for d in base])
                         + cell([float(d.settling_time[0]) for d in base])
                         + cell([d.max_coupler_force for d in base], 1e-3))
    return "\n".join(lines)


def _claims_text(run: AnalysisRun) -> str:
    """The published claims, trainctl's numbers and the verdicts."""
    from trainctl.controllers.hooks import family_hook
    from trainctl.registry import get_family

    sources = [source for name in run.design.families
               if (source := family_hook(get_family(name), "claims_source"))]
    lines = [f"Paper claims ({'; '.join(sources)}) against this run:" if sources
             else "Paper claims against this run:"]
    for c in run.claims:
        lines.append(f"  {c.case} {c.claim}: paper {c.paper}; trainctl {c.trainctl} — "
                     f"{c.verdict.upper()}")
    return "\n".join(lines)


def _cell(x: float, width: int, decimals: int) -> str:
    """``x`` right-aligned in ``width`` with ``decimals``, or in 3 significant digits
    when that would not fit."""
    text = f"{x:>{width}.{decimals}f}"
    return text if len(text) <= width else f" {x:>{width - 1}.3g}"


def _run_notes(name: str, m: Metrics) -> list[str]:
    """Lines under the table for a strategy whose run diverged or saturated, and the
    verdict of the couplers' admissible forces when the train has some."""
    notes = []
    if m.divergence is not None:
        notes.append(f"  {name}: DIVERGED: {m.divergence.get('message', '')}")
    saturated = np.flatnonzero(m.saturation_time > 0)
    for i in saturated[:_NOTED]:
        braking = m.braking_saturation_time[i]
        side = ("braking" if braking == m.saturation_time[i] else
                "traction" if braking == 0 else "traction and braking")
        notes.append(f"  {name}: vehicle {i + 1} saturated ({side}) for "
                     f"{m.saturation_time[i]:g} s, first at t = {m.first_saturation_time[i]:g} s, "
                     f"head at {m.first_saturation_position[i]:.0f} m")
    if saturated.size > _NOTED:
        notes.append(f"  {name}: ... and {saturated.size - _NOTED} more vehicles saturated")
    return notes + _coupler_notes(name, m)


def _coupler_notes(name: str, m: Metrics) -> list[str]:
    """Couplers above their admissible force, or the closest one's margin when none is."""
    worst = m.worst_coupler
    if worst is None:
        return []
    over = m.couplers_over_limit
    if not over.size:
        return [f"  {name}: coupler forces within their limits, the closest coupler {worst + 1} "
                f"at {100 * m.coupler_ratio[worst]:.0f} % of {m.coupler_limit[worst] / 1e3:g} kN "
                f"(t = {m.coupler_peak_time[worst]:.4g} s)"]
    order = over[np.argsort(-m.coupler_ratio[over], kind="stable")]
    notes = [f"  {name}: coupler {i + 1} exceeded {m.coupler_limit[i] / 1e3:g} kN by "
             f"{100 * (m.coupler_ratio[i] - 1):.0f} % at t = {m.coupler_peak_time[i]:.4g} s "
             f"(peak {m.coupler_peak_force[i] / 1e3:.4g} kN), above it for "
             f"{m.coupler_over_time[i]:.4g} s" for i in order[:_NOTED]]
    if over.size > _NOTED:
        notes.append(f"  {name}: ... and {over.size - _NOTED} more couplers above their limits")
    return notes


