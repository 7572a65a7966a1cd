# Running a sweep's points and turning each run into tidy rows: one per point and strategy.
"""Run the validated points of a sweep and tabulate them, one row per point and strategy.

Each point is the scenario of :meth:`~trainctl.sweep.SweepDefinition.validate`,
run by :func:`trainctl.run.analysis.run_scenario` like ``trainctl analyse`` runs a
file (its analysis and, unless ``simulate=False``, its simulations); a run
is reduced where it ran to its JSON summary without wall-clock values
(:meth:`~trainctl.run.analysis.AnalysisRun.to_dict`), so that the rows do not depend
on where or when a point ran. :func:`point_rows` turns a summary into tidy
rows:

- ``point``, ``point_key`` (:func:`~trainctl.sweep.point_key`) and the
  swept values, one column per key (file units, as written in the sweep);
- ``check.<name>.status`` and ``check.<name>.value`` for every design check;
- ``strategy`` and ``metric.<name>`` per simulated strategy
  (:data:`METRICS`); a point without simulations has one row with an empty
  strategy.

The points run in order, on an executor when one is given (a process pool,
:func:`trainctl.run.pool.worker_pool`), each independent of the others, so
the rows are the same either way.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

    from trainctl.scenario import Scenario
    from trainctl.sweep.definition import SweepPoint

__all__ = ["METRICS", "point_rows", "rows_frame", "run_point", "sweep_rows"]

METRICS = ("rms_error", "max_error", "max_coupler_force", "energy_kwh", "net_energy_kwh",
           "energy_per_tonne_km", "operating_cost", "tracking_ok", "iterations_mean", "diverged",
           "converged", "iteration_limit_steps", "deviation_ratio")
"""Per-strategy metric columns: the RMS speed error over every vehicle and sample after
``settle_time`` [m/s], the largest speed error [m/s], the largest |coupler force| [N], the
net traction energy [kWh] (:attr:`trainctl.sim.Metrics.energy`), the exact energy
account's net energy drawn [kWh] and net energy per tonne of train and km run
[J/(t·km)] (:class:`trainctl.sim.EnergyAccount`; both None without an account), the
operating cost's total at the ``[cost]`` prices [currency] (None without them), whether
tracking held, the mean solver iterations per sample,
whether the run diverged, whether an iterating strategy's iteration (N-DMPC, cooperative
DMPC) converged within its ``max_iterations`` at every step (bool), and the number of steps
that stopped at that limit unconverged [-] (both None for a strategy that does not iterate:
:class:`trainctl.sim.Metrics`), and the deviation ratio [-]: vehicle 1's RMS speed error over
the whole run divided by the same in the run on the ``[simulation] baseline_network`` with
the same seed (seed 003's case-(c) measure, :mod:`trainctl.controllers.hinf.claims`; None without a
baseline network, or when the baseline run does not deviate)."""


def run_point(scenario: Scenario, simulate: bool = True) -> dict[str, Any]:
    """One point's run, summarised: ``AnalysisRun.to_dict()`` without wall-clock values.

    Parameters
    ----------
    scenario : Scenario
        The point's validated scenario.
    simulate : bool
        Run its ``[simulation]`` strategies.

    Returns
    -------
    dict
        JSON-safe.

    Examples
    --------
    The design review of the CRH2 scenario alone (no simulation): its
    checks, and no ``simulations`` entry:

    >>> import trainctl
    >>> summary = run_point(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> [(c["name"], c["status"]) for c in summary["checks"]][:2]
    [('open_loop_stability', 'pass'), ('controllability', 'pass')]
    >>> "simulations" in summary
    False
    """
    from trainctl.run.analysis import run_scenario
    from trainctl.run.wall_clock import without_wall_clock

    result: dict[str, Any] = without_wall_clock(run_scenario(scenario, simulate=simulate)
                                                .to_dict())
    return result


def _deviation_ratio(summary: Mapping[str, Any], strategy: str) -> float | None:
    """Run 0's vehicle-1 whole-run RMS speed error over its baseline run's (same seed)."""
    runs = (summary.get("repetitions") or {}).get(strategy) or []
    first = next((r for r in runs if r.get("index") == 0), None)
    base = [b for b in (summary.get("baseline_network") or {}).get(strategy) or []
            if first is not None and b.get("seed") == first.get("seed")]
    if first is None or not base:
        return None
    num, den = first["deviation"]["rms_error"][0], base[0]["deviation"]["rms_error"][0]
    if num is None or den is None or not den > 0:
        return None
    return float(num) / float(den)


def _metric(name: str, m: Mapping[str, Any], summary: Mapping[str, Any],
            strategy: str) -> Any:
    value = m.get(name)
    if name == "deviation_ratio":
        return _deviation_ratio(summary, strategy)
    if name == "diverged":
        return m.get("divergence") is not None
    if name == "converged":
        return m.get("iterations_converged")
    if name == "operating_cost":  # the total at the [cost] prices (None without them)
        return (m.get("operating_cost") or {}).get("total")
    if name in ("net_energy_kwh", "energy_per_tonne_km"):
        account = m.get("energy_account") or {}
        if name == "net_energy_kwh":
            return (account.get("kwh") or {}).get("net_energy")
        return account.get("energy_per_tonne_km")
    if name == "rms_error":
        values = [float(x) for x in (value or []) if x is not None]
        return math.sqrt(sum(x * x for x in values) / len(values)) if values else None
    if name == "max_error":
        values = [float(x) for x in (value or []) if x is not None]
        return max(values) if values else None
    return value


def point_rows(point: SweepPoint, key: str, summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The tidy rows of one point (module docstring).

    Parameters
    ----------
    point : SweepPoint
        The point (index and swept values).
    key : str
        Its :func:`~trainctl.sweep.point_key`.
    summary : mapping
        Its run's summary (:func:`run_point`).

    Returns
    -------
    list of dict
        One row per simulated strategy (one row with ``strategy = ""``
        without simulations).

    Examples
    --------
    >>> from trainctl.sweep import SweepPoint
    >>> p = SweepPoint(3, {"controller.r_per_kn2": 10})
    >>> rows = point_rows(p, "ab12", {"checks": [{"name": "sampling", "status": "fail",
    ...                                          "value": 555.4}]})
    >>> rows == [{"point": 3, "point_key": "ab12", "controller.r_per_kn2": 10,
    ...           "check.sampling.status": "fail", "check.sampling.value": 555.4,
    ...           "strategy": ""}]
    True
    """
    base: dict[str, Any] = {"point": int(point.index), "point_key": key, **dict(point)}
    for check in summary.get("checks", []):
        base[f"check.{check['name']}.status"] = check.get("status")
        base[f"check.{check['name']}.value"] = check.get("value")
    sims = summary.get("simulations") or {}
    if not sims:
        return [{**base, "strategy": ""}]
    return [{**base, "strategy": strategy,
             **{f"metric.{name}": _metric(name, m, summary, strategy) for name in METRICS}}
            for strategy, m in sims.items()]


def sweep_rows(points: Sequence[SweepPoint], scenarios: Sequence[Scenario], *,
               simulate: bool = True, executor: Executor | None = None) -> list[dict[str, Any]]:
    """Run every point and return all their rows, in point order.

    Parameters
    ----------
    points : sequence of SweepPoint
        :meth:`~trainctl.sweep.SweepDefinition.points`.
    scenarios : sequence of Scenario
        The validated scenarios of those points
        (:meth:`~trainctl.sweep.SweepDefinition.validate`), in the same order.
    simulate : bool
        Run the ``[simulation]`` strategies of each point.
    executor : concurrent.futures.Executor or None
        Where to run the points side by side; None: here, one after the
        other. The rows are the same either way.

    Returns
    -------
    list of dict
        :func:`point_rows` of every point.

    Examples
    --------
    Two points of the input weight, design review only (one row each, no
    strategy). The N-DMPC iteration's spectral radius ρ falls below 1 for the
    heavier weight, so its check passes there:

    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> from trainctl.sweep import SweepDefinition, parse_set, point_key
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> base = parse_scenario(text, source=label)
    >>> sweep = SweepDefinition.of(base, [parse_set("controller.r_per_kn2=1,10")])
    >>> points, scenarios = sweep.points(base_seed=base.seed), sweep.validate(base)
    >>> rows = sweep_rows(points, scenarios, simulate=False)
    >>> [(r["controller.r_per_kn2"], round(r["check.ndmpc_convergence.value"], 4),
    ...   r["check.ndmpc_convergence.status"], r["strategy"]) for r in rows]
    [(1, 1.5849, 'fail', ''), (10, 0.3057, 'pass', '')]
    """
    from trainctl.sweep.definition import point_key

    if len(points) != len(scenarios):
        from trainctl.exceptions import ModelError

        raise ModelError(f"sweep_rows: {len(points)} points but {len(scenarios)} scenarios.")
    if executor is None:
        summaries = [run_point(s, simulate) for s in scenarios]
    else:
        futures = [executor.submit(run_point, s, simulate) for s in scenarios]
        summaries = [f.result() for f in futures]
    rows: list[dict[str, Any]] = []
    for point, scenario, summary in zip(points, scenarios, summaries, strict=True):
        rows += point_rows(point, point_key(scenario), summary)
    return rows


def _column(values: list[Any]) -> tuple[list[Any], str | None]:
    """A column's values and pandas dtype: numbers, booleans, text, else JSON text."""
    present = [v for v in values if v is not None]
    if all(isinstance(v, bool) for v in present) and present:
        return values, "boolean"
    if all(isinstance(v, int) and not isinstance(v, bool) for v in present) and present:
        return values, "Int64"
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in present):
        return [math.nan if v is None else float(v) for v in values], "float64"
    if all(isinstance(v, str) for v in present):
        return values, "string"
    return [None if v is None else json.dumps(v, sort_keys=True) for v in values], "string"


def rows_frame(rows: Sequence[Mapping[str, Any]], swept: Sequence[str] = ()) -> pd.DataFrame:
    """Tidy rows as a DataFrame with one dtype per column, the same for the same rows.

    Columns: ``point``, ``point_key``, the swept keys, ``strategy``, then the
    check and metric columns in the order they first appear. Each column's
    type follows its values: nullable integers (``Int64``), floats (missing
    values NaN), nullable booleans, text; anything else (arrays, tables,
    mixed types) is JSON text.

    Parameters
    ----------
    rows : sequence of mapping
        :func:`~trainctl.sweep.point_rows` of the points.
    swept : sequence of str
        The swept keys (put after ``point_key``).

    Returns
    -------
    pandas.DataFrame

    Examples
    --------
    >>> frame = rows_frame([{"point": 0, "point_key": "a", "x": 1.5, "strategy": "",
    ...                      "check.c.status": "pass", "check.c.value": None}], ["x"])
    >>> list(frame.columns), [str(t) for t in frame.dtypes]
    (['point', 'point_key', 'x', 'strategy', 'check.c.status', 'check.c.value'], ['Int64', \
'string', 'float64', 'string', 'string', 'float64'])
    """
    import pandas as pd

    columns = ["point", "point_key", *swept, "strategy"]
    for row in rows:
        for name in row:
            if name not in columns:
                columns.append(name)
    data: dict[str, Any] = {}
    for name in columns:
        values, dtype = _column([row.get(name) for row in rows])
        data[name] = pd.array(values, dtype=dtype) if dtype else values
    return pd.DataFrame(data, columns=columns)
