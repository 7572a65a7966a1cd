# A published claim set against a run's numbers: the vocabulary every family's claims share.
"""A published claim, trainctl's number for it and the verdict (:class:`Claim`).

A family that reproduces a paper declares what a run of it can decide
through its ``claims(run)`` hook (:class:`~trainctl.registry.ControllerFamily`,
default none: :class:`~trainctl.controllers.hooks.FamilyHooks`); the run
collects them (:attr:`trainctl.run.AnalysisRun.claims`), prints them and the
report shows them in its "Paper claims" section, whatever the family. The
H∞ family's (seed 003, Ning et al. 2016) are in
:mod:`trainctl.controllers.hinf.claims`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["VERDICT_BADGES", "Claim", "tracking_claim", "verdict"]

VERDICT_BADGES = {"reproduced": "pass", "not reproduced": "fail", "depends": "warn"}
"""A claim's ``kind`` → the report's badge status (anything else: ``"other"``)."""


@dataclass(frozen=True, kw_only=True)
class Claim:
    """One published claim, trainctl's number and the verdict.

    Parameters
    ----------
    key : str
        The claim's identifier within its family (e.g. the H∞ family's
        ``"delay_deviation"`` or ``"gamma"``).
    case : str
        The paper's case (e.g. ``"(a)"`` … ``"(d)"``), or ``"design"``.
    claim : str
        What the paper says.
    paper : str
        The paper's number or statement.
    trainctl : str
        trainctl's number(s).
    kind : {"reproduced", "not reproduced", "depends"}
        The verdict's kind.
    verdict : str
        The verdict as shown (``"depends on the scaling"`` for that kind).
    note : str
        How it was measured and what it depends on.

    Examples
    --------
    >>> claim = Claim(key="gamma", case="design", claim="γ = 1 is achieved", paper="γ = 1",
    ...               trainctl="certified γ = 0.8", kind="depends",
    ...               verdict="depends on the scaling", note="No scaling in the paper.")
    >>> claim.to_dict()["verdict"]
    'depends on the scaling'
    """

    key: str
    case: str
    claim: str
    paper: str
    trainctl: str
    kind: str
    verdict: str
    note: str

    def to_dict(self) -> dict[str, str]:
        """JSON-safe.

        Returns
        -------
        dict of str to str
            Every field by name: ``key``, ``case``, ``claim``, ``paper``,
            ``trainctl``, ``kind``, ``verdict`` and ``note``.
        """
        return {"key": self.key, "case": self.case, "claim": self.claim, "paper": self.paper,
                "trainctl": self.trainctl, "kind": self.kind, "verdict": self.verdict,
                "note": self.note}


def verdict(ok: bool) -> dict[str, str]:
    """``kind`` and ``verdict`` of a claim that holds or does not.

    Parameters
    ----------
    ok : bool
        Whether trainctl's number bears the claim out.

    Returns
    -------
    dict of str to str
        ``{"kind": ..., "verdict": ...}``, both "reproduced" or "not reproduced".

    Examples
    --------
    >>> verdict(False)
    {'kind': 'not reproduced', 'verdict': 'not reproduced'}
    """
    kind = "reproduced" if ok else "not reproduced"
    return {"kind": kind, "verdict": kind}


def tracking_claim(run: Any, strategies: Sequence[str], case: str) -> Claim:
    """"Every vehicle tracks the reference speed accurately", judged on a run's metrics.

    Parameters
    ----------
    run : AnalysisRun
        The run (its ``[simulation]`` and metrics).
    strategies : sequence of str
        The simulated strategies the claim is about.
    case : str
        The source's case or figure.

    Returns
    -------
    Claim
        Reproduced when every strategy's largest speed error after
        ``settle_time`` is within ``tracking_tolerance``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> run = SimpleNamespace(
    ...     scenario=SimpleNamespace(simulation=SimpleNamespace(settle_time=10.0,
    ...                                                         tracking_tolerance=1.0)),
    ...     metrics={"a": SimpleNamespace(max_error=np.array([0.2, 1.5]))})
    >>> tracking_claim(run, ["a"], "(Fig 1)").kind
    'not reproduced'
    """
    sim = run.scenario.simulation
    worst = {s: float(np.max(run.metrics[s].max_error)) for s in strategies}
    text = ", ".join(f"{s} {w:.3g} m/s" for s, w in worst.items())
    return Claim(key="tracking", case=case, claim="every vehicle tracks the reference speed "
                 "accurately", paper="stated, no number",
                 trainctl=f"largest speed error after {sim.settle_time:g} s: {text}",
                 note=f"Reproduced when every strategy's largest speed error after settle_time "
                 f"is within tracking_tolerance = {sim.tracking_tolerance:g} m/s.",
                 **verdict(all(w <= sim.tracking_tolerance for w in worst.values())))
