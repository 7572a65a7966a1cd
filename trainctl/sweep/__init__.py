# Parameter sweeps: the definition (axes, points, validation) and running the points.
"""Parameter studies and Monte-Carlo over any scenario key.

A sweep varies file keys of a scenario along axes — lists, grids, random
samples — and optionally the scenario seed; every point is validated by
the scenario schema before anything runs (:mod:`trainctl.sweep.definition`);
the points run serially, on a process pool or on a Dask cluster
(:mod:`trainctl.sweep.runner`) into a resumable store
(:mod:`trainctl.sweep.store`) whose table has one tidy row per point and
strategy (:mod:`trainctl.sweep.rows`).
A scenario file declares one in its ``[sweep]`` section
(:attr:`trainctl.scenario.Scenario.sweep`); the command line with
``trainctl sweep SCENARIO --set KEY=V1,V2,... [--seeds N]``.

Examples
--------
>>> from trainctl.scenario import load_scenario
>>> sweep = SweepDefinition([parse_set("controller.r_per_kn2=0.1,1,10")])
>>> [dict(p) for p in sweep.points()]
[{'controller.r_per_kn2': 0.1}, {'controller.r_per_kn2': 1}, {'controller.r_per_kn2': 10}]
"""

from trainctl.sweep.definition import (
    DISTRIBUTIONS,
    MAX_POINTS,
    SCALES,
    Axis,
    GridAxis,
    ListAxis,
    RandomAxis,
    SweepDefinition,
    SweepPoint,
    parse_set,
    point_key,
)
from trainctl.sweep.rows import METRICS, point_rows, rows_frame, run_point, sweep_rows
from trainctl.sweep.runner import dask_executor, run_point_results, run_sweep, sweep_scenario
from trainctl.sweep.store import SweepStore

__all__ = [
    "DISTRIBUTIONS",
    "MAX_POINTS",
    "SCALES",
    "Axis",
    "GridAxis",
    "ListAxis",
    "RandomAxis",
    "SweepDefinition",
    "SweepPoint",
    "parse_set",
    "METRICS",
    "point_key",
    "point_rows",
    "run_point",
    "sweep_rows",
    "SweepStore",
    "dask_executor",
    "rows_frame",
    "run_point_results",
    "run_sweep",
    "sweep_scenario",
]
