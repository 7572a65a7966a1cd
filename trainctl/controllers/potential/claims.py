# Seed 001's claims (Zhao & Wang 2017) judged on the potential family's simulated run.
"""Seed 001's claims on the potential law's run (:class:`~trainctl.analysis.claims.Claim`).

The paper's example is lost (spec §2.4); what it states: the speeds reach the
reference and the spacings their desired values (the largest speed error
after ``settle_time`` within ``tracking_tolerance``, the largest elongation
deviation at the end within 1 % of the run's largest), and the inputs reach
the equilibrium's (within 1 % of the largest cruise force). The family's
``claims`` hook calls :func:`potential_claims` when it is the scenario's
primary family.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from trainctl.analysis.claims import Claim, tracking_claim, verdict

__all__ = ["potential_claims"]


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
    out = [tracking_claim(run, strategies, "(Example 1)")]
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
        "equilibrium elongations at the final reference speed.", **verdict(ok_spacing)))
    out.append(Claim(
        key="inputs", case="(Example 1)", claim="the inputs reach the equilibrium's ū_i",
        paper="stated, no number",
        trainctl="largest |u - ū| at the end: "
        + ", ".join(f"{s} {u / 1e3:.3g} kN" for s, _, u in rows),
        note="Reproduced when it is within 1 % of the largest cruise force.",
        **verdict(ok_inputs)))
    return out
