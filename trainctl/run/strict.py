# What `--strict` fails on: the policy, in the library; the CLI only prints and returns.
"""The reasons ``trainctl analyse --strict`` exits with status 1.

A run is strict-clean when none of these holds:

- ``check``: a design check failed;
- ``tracking``: a simulated strategy's largest speed error after
  ``[simulation] settle_time`` exceeds ``tracking_tolerance``;
- ``saturation``: a vehicle's force was saturated by its envelope for longer
  than ``[simulation] max_saturation_time`` allows (read from the metrics'
  per-vehicle saturation time and the simulation settings when both exist);
- ``coupler``: a coupler's force exceeded its admissible force
  (``[train.coupler] max_force_kn``, :attr:`trainctl.models.vehicle.Coupler.max_force`)
  somewhere on a simulated strategy's dense output (read from the metrics'
  per-coupler peaks and limits when they exist);
- ``expected``: a check's status differs from the scenario's ``[expected]``.

:func:`strict_failures` lists them; :meth:`trainctl.run.analysis.AnalysisRun.strict_failures`
is the same list for a run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from trainctl.run.analysis import AnalysisRun

__all__ = ["STRICT_KINDS", "StrictFailure", "format_strict", "strict_failures"]

STRICT_KINDS = ("check", "tracking", "saturation", "coupler", "expected")
"""The kinds of reason ``--strict`` fails on, in the order they are listed."""


@dataclass(frozen=True, kw_only=True)
class StrictFailure:
    """One reason ``--strict`` exits 1.

    Parameters
    ----------
    kind : {"check", "tracking", "saturation", "coupler", "expected"}
        What failed (module docstring).
    name : str
        The check or strategy concerned.
    detail : str
        One line with the numbers.

    Examples
    --------
    >>> StrictFailure(kind="check", name="sampling", detail="aliased").to_dict()
    {'kind': 'check', 'name': 'sampling', 'detail': 'aliased'}
    """

    kind: str
    name: str
    detail: str

    def to_dict(self) -> dict[str, str]:
        """JSON-safe dict.

        Returns
        -------
        dict of str to str
            ``kind``, ``name`` and ``detail``.
        """
        return {"kind": self.kind, "name": self.name, "detail": self.detail}


def strict_failures(run: AnalysisRun) -> tuple[StrictFailure, ...]:
    """Every reason a run fails ``--strict``, grouped by kind.

    The kinds are check, tracking, saturation, coupler and expected.

    Parameters
    ----------
    run : AnalysisRun
        A scenario's run (:func:`trainctl.run.analysis.run_scenario`).

    Returns
    -------
    tuple of StrictFailure
        Empty when the run is strict-clean.

    Examples
    --------
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import load_scenario
    >>> run = run_scenario(load_scenario("crh2-dmpc"), simulate=False)
    >>> [(f.kind, f.name) for f in strict_failures(run)]
    [('check', 'sampling'), ('check', 'input_collapse'), ('check', 'string_stability')]
    """
    found = [StrictFailure(kind="check", name=c.name, detail=c.message)
             for c in run.review.checks if c.status == "fail"]
    sim = run.scenario.simulation
    if sim is not None:
        for strategy, metrics in run.metrics.items():
            error = float(np.max(metrics.max_error))
            if not error <= sim.tracking_tolerance:
                found.append(StrictFailure(
                    kind="tracking", name=strategy,
                    detail=f"max speed error {error:.4g} m/s after {sim.settle_time:g} s exceeds "
                    f"the tracking_tolerance {sim.tracking_tolerance:g} m/s"))
        found += _saturation(run.metrics, getattr(sim, "max_saturation_time", None))
        found += _couplers(run.metrics)
    for name, (want, got) in run.unexpected_checks().items():
        found.append(StrictFailure(
            kind="expected", name=name,
            detail=f"[expected] declares {want!r}, the review found {got!r}"))
    return tuple(found)


def format_strict(failures: tuple[StrictFailure, ...]) -> str:
    """The ``Strict:`` block of ``trainctl analyse``'s text.

    Parameters
    ----------
    failures : tuple of StrictFailure
        :func:`strict_failures` of a run.

    Returns
    -------
    str
        One line when clean, else one line per reason.

    Examples
    --------
    >>> print(format_strict((StrictFailure(kind="check", name="sampling", detail="aliased"),)))
    Strict: 1 reason --strict exits 1 for:
      check     sampling: aliased
    """
    if not failures:
        return "Strict: no failed check, missed tracking, over-long saturation, coupler over " \
               "its limit or [expected] mismatch (--strict exits 0)"
    noun = "reason" if len(failures) == 1 else "reasons"
    lines = [f"Strict: {len(failures)} {noun} --strict exits 1 for:"]
    lines += [f"  {f.kind:<10}{f.name}: {f.detail}" for f in failures]
    return "\n".join(lines)


def _saturation(metrics: Mapping[str, Any], limit: Any) -> list[StrictFailure]:
    """Vehicles saturated longer than ``limit`` [s], when the metrics record it."""
    if not isinstance(limit, int | float) or not math.isfinite(limit):
        return []
    found = []
    for strategy, m in metrics.items():
        seconds = _per_vehicle(getattr(m, "saturation_time", None))
        if seconds is None:
            seconds = _per_vehicle(getattr(m, "saturation", None))
        if seconds is None:
            continue
        over = np.flatnonzero(seconds > limit)
        if over.size:
            worst = int(over[np.argmax(seconds[over])])
            found.append(StrictFailure(
                kind="saturation", name=strategy,
                detail=f"{over.size} vehicle(s) saturated longer than max_saturation_time "
                f"{limit:g} s, the longest vehicle {worst + 1} for {seconds[worst]:.4g} s"))
    return found


def _couplers(metrics: Mapping[str, Any]) -> list[StrictFailure]:
    """Strategies whose coupler forces exceeded an admissible force, when the metrics record
    the per-coupler peaks and limits."""
    found = []
    for strategy, m in metrics.items():
        peak = _per_vehicle(getattr(m, "coupler_peak_force", None))
        limit = _per_vehicle(getattr(m, "coupler_limit", None))
        if peak is None or limit is None or peak.shape != limit.shape:
            continue
        over = np.flatnonzero(peak > limit)
        if not over.size:
            continue
        ratio = peak[over] / limit[over]
        worst = int(over[np.argmax(ratio)])
        excess = 100 * (float(np.max(ratio)) - 1)
        when = _per_vehicle(getattr(m, "coupler_peak_time", None))
        seconds = _per_vehicle(getattr(m, "coupler_over_time", None))
        at = f" at t = {when[worst]:.4g} s" if when is not None and when.shape == peak.shape else ""
        for_ = (f", above it for {seconds[worst]:.4g} s"
                if seconds is not None and seconds.shape == peak.shape else "")
        found.append(StrictFailure(
            kind="coupler", name=strategy,
            detail=f"{over.size} coupler(s) above their admissible force (max_force_kn), the "
            f"worst coupler {worst + 1} at {peak[worst] / 1e3:.4g} kN, {excess:.0f} % "
            f"over its {limit[worst] / 1e3:g} kN{at}{for_}"))
    return found


def _per_vehicle(value: Any) -> np.ndarray | None:
    """Numbers per vehicle (or coupler) as a float array, or None when ``value`` is not such a
    record."""
    if value is None:
        return None
    try:
        seconds = np.asarray(value, dtype=float).ravel()
    except (TypeError, ValueError):
        return None
    return seconds if seconds.size else None
