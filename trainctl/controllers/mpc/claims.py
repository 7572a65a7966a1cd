# Seed 000's claims (Li & Zheng, ch. 12) judged on the MPC family's simulated run.
"""Seed 000's claims on the MPC strategies of a run (:class:`~trainctl.analysis.claims.Claim`).

The book gives no numbers (spec §1.7); it states what its simulation shows.
Each statement a run can check: every coach tracks the reference accurately
(Fig 12.7: the largest speed error after ``settle_time`` within
``tracking_tolerance``); the traction forces stay within their range (Fig 12.8:
no time at the envelope); the inter-coach forces stay within the constraint
(Fig 12.9: the largest |f| at most ``coupler_force_limit_kn``); and the
neighbourhood optimisation performs as the global one does (Figs 12.10–12.13:
N-DMPC's RMS speed error within 10 % of centralised MPC's, or a few mm/s of
it). The family's ``claims`` hook calls :func:`mpc_claims` when it is the
scenario's primary family.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from trainctl.analysis.claims import Claim, tracking_claim, verdict

__all__ = ["mpc_claims"]

_CLOSE = 0.10
"""N-DMPC's RMS speed error within this share of centralised MPC's counts as "as the global"."""

_FLOOR = 5e-3
"""... or within this many m/s of it [m/s] (both near zero)."""


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
    out = [tracking_claim(run, strategies, "(Fig 12.7)")]
    saturated = {s: float(np.max(run.metrics[s].saturation_time)) for s in strategies}
    out.append(Claim(
        key="traction_range", case="(Fig 12.8)",
        claim="all traction forces within the appropriate range", paper="stated, no number",
        trainctl="time at the envelope: " + ", ".join(f"{s} {t:g} s"
                                                       for s, t in saturated.items()),
        note="Reproduced when no coach's force reaches its traction or braking envelope.",
        **verdict(all(t == 0.0 for t in saturated.values()))))
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
        **verdict(math.isfinite(limit) and all(p <= limit for p in peaks.values()))))
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
            f"{1e3 * _FLOOR:g} mm/s) of centralised MPC's.", **verdict(ok)))
    return out
