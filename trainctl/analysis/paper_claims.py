# The claims the seeds' sources make about a simulated run, judged on its metrics.
"""Claims of seeds 000 and 001 judged on a run's metrics (:class:`~trainctl.analysis.claims.Claim`).

Neither source gives numbers (spec §1.7, §2.4): they state what their
simulations show. Each statement a run can check is a :class:`Claim` with
trainctl's numbers:

- seed 000 (Li & Zheng, ch. 12, N-DMPC of the CRH2 half train), for the MPC
  family's strategies: every coach tracks the reference accurately (Fig 12.7:
  largest speed error after ``settle_time`` within ``tracking_tolerance``);
  the traction forces stay within their range (Fig 12.8: no time at the
  envelope); the inter-coach forces stay within the constraint (Fig 12.9:
  largest |f| at most ``coupler_force_limit_kn``); and the neighbourhood
  optimisation performs as the global one does (Figs 12.10–12.13: N-DMPC's RMS
  speed error within 10 % of centralised MPC's, or a few mm/s of it);
- seed 001 (Zhao & Wang 2017, the potential-function law): the speeds reach
  the reference and the spacings their desired values (the largest speed
  error after ``settle_time`` within ``tracking_tolerance``, the largest
  elongation deviation at the end within 1 % of its largest value), and the
  inputs reach the equilibrium's (within 1 % of the largest cruise force).

The families call :func:`mpc_claims` and :func:`potential_claims` from their
``claims`` hooks when they are the scenario's primary family.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from trainctl.analysis.claims import Claim

__all__ = ["mpc_claims", "potential_claims"]

_CLOSE = 0.10
"""N-DMPC's RMS speed error within this share of centralised MPC's counts as "as the global"."""

_FLOOR = 5e-3
"""... or within this many m/s of it [m/s] (both near zero)."""


def _verdict(ok: bool) -> dict[str, str]:
    kind = "reproduced" if ok else "not reproduced"
    return {"kind": kind, "verdict": kind}


def _tracking(run: Any, strategies: Sequence[str], case: str) -> Claim:
    sim = run.scenario.simulation
    worst = {s: float(np.max(run.metrics[s].max_error)) for s in strategies}
    text = ", ".join(f"{s} {w:.3g} m/s" for s, w in worst.items())
    return Claim(key="tracking", case=case, claim="every vehicle tracks the reference speed "
                 "accurately", paper="stated, no number",
                 trainctl=f"largest speed error after {sim.settle_time:g} s: {text}",
                 note=f"Reproduced when every strategy's largest speed error after settle_time "
                 f"is within tracking_tolerance = {sim.tracking_tolerance:g} m/s.",
                 **_verdict(all(w <= sim.tracking_tolerance for w in worst.values())))


def mpc_claims(run: Any) -> list[Claim]:
    """Seed 000's claims on the MPC strategies simulated (module docstring).

    Parameters
    ----------
    run : AnalysisRun
        A run whose primary family is ``mpc``.

    Returns
    -------
    list of Claim
        Tracking, traction range, inter-coach forces and, with both
        ``ndmpc`` and ``centralised`` simulated, the comparison; empty
        without a simulated MPC strategy.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> mpc_claims(SimpleNamespace(simulations={}, metrics={}))
    []
    """
    strategies = [s for s in run.simulations if "." not in s and s in run.metrics]
    if not strategies:
        return []
    out = [_tracking(run, strategies, "(Fig 12.7)")]
    saturated = {s: float(np.max(run.metrics[s].saturation_time)) for s in strategies}
    out.append(Claim(
        key="traction_range", case="(Fig 12.8)",
        claim="all traction forces within the appropriate range", paper="stated, no number",
        trainctl="time at the envelope: " + ", ".join(f"{s} {t:g} s"
                                                       for s, t in saturated.items()),
        note="Reproduced when no coach's force reaches its traction or braking envelope.",
        **_verdict(all(t == 0.0 for t in saturated.values()))))
    settings = run.design.families["mpc"].settings
    limit = float(getattr(settings, "coupler_force_limit", math.inf))
    peaks = {s: float(run.metrics[s].max_coupler_force) for s in strategies}
    bound = f"{limit / 1e3:g} kN" if math.isfinite(limit) else "no bound"
    out.append(Claim(
        key="coupler_forces", case="(Fig 12.9)",
        claim="inter-coach forces within the constraint range", paper="stated, no number",
        trainctl=f"largest |f| against {bound}: "
        + ", ".join(f"{s} {p / 1e3:.3g} kN" for s, p in peaks.items()),
        note="Reproduced when every strategy's largest coupler force over the dense grid is "
        "within coupler_force_limit_kn (judged only with one).",
        **_verdict(math.isfinite(limit) and all(p <= limit for p in peaks.values()))))
    if "ndmpc" in strategies and "centralised" in strategies:
        n, c = (float(np.max(run.metrics[s].rms_error)) for s in ("ndmpc", "centralised"))
        ok = n <= c * (1 + _CLOSE) or n - c <= _FLOOR
        others = "".join(f", {s} {float(np.max(run.metrics[s].rms_error)):.3g} m/s"
                         for s in strategies if s not in ("ndmpc", "centralised"))
        out.append(Claim(
            key="neighbourhood_vs_global", case="(Figs 12.10–12.13)",
            claim="neighbourhood optimisation (N-DMPC) performs as the global optimisation",
            paper="stated, no number",
            trainctl=f"largest RMS speed error: ndmpc {n:.3g} m/s, centralised {c:.3g} m/s"
            f"{others}",
            note=f"Reproduced when N-DMPC's is within {100 * _CLOSE:g} % (or "
            f"{1e3 * _FLOOR:g} mm/s) of centralised MPC's.", **_verdict(ok)))
    return out


def potential_claims(run: Any) -> list[Claim]:
    """Seed 001's claims on the potential law's simulated run (module docstring).

    Parameters
    ----------
    run : AnalysisRun
        A run whose primary family is ``potential``.

    Returns
    -------
    list of Claim
        Speed and spacing consensus, and inputs at the equilibrium; empty
        without a simulated strategy of the family.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> potential_claims(SimpleNamespace(simulations={}, metrics={}))
    []
    """
    from trainctl.models import equilibrium

    strategies = [s for s in run.simulations if "." not in s and s in run.metrics]
    if not strategies:
        return []
    out = [_tracking(run, strategies, "(Example 1)")]
    train, n = run.scenario.train, run.scenario.train.n_vehicles
    rows = []
    ok_spacing, ok_inputs = True, True
    for s in strategies:
        result = run.simulations[s]
        z = result.states[n:2 * n - 1]
        target = equilibrium(train, float(result.reference_speed[-1]))
        end = np.abs(z[:, -1] - target.state()[n:2 * n - 1])
        spread = float(np.max(np.abs(z - target.state()[n:2 * n - 1, None]))) or 1.0
        u_end = np.abs(result.inputs[:, -1] - target.inputs)
        scale = float(np.max(np.abs(target.inputs))) or 1.0
        ok_spacing &= bool(np.max(end) <= 0.01 * spread)
        ok_inputs &= bool(np.max(u_end) <= 0.01 * scale)
        rows.append((s, float(np.max(end)), float(np.max(u_end))))
    out.append(Claim(
        key="spacing", case="(Example 1)", claim="the spacings reach their desired values",
        paper="stated, no number",
        trainctl="largest elongation deviation at the end: "
        + ", ".join(f"{s} {e:.3g} m" for s, e, _ in rows),
        note="Reproduced when it is within 1 % of the run's largest deviation from the "
        "equilibrium elongations at the final reference speed.", **_verdict(ok_spacing)))
    out.append(Claim(
        key="inputs", case="(Example 1)", claim="the inputs reach the equilibrium's ū_i",
        paper="stated, no number",
        trainctl="largest |u - ū| at the end: "
        + ", ".join(f"{s} {u / 1e3:.3g} kN" for s, _, u in rows),
        note="Reproduced when it is within 1 % of the largest cruise force.",
        **_verdict(ok_inputs)))
    return out
