"""Benchmark: what `trainctl sweep` costs beyond its points' own runs, and what workers buy.

Run:  .venv/bin/python benchmarks/sweep.py [--quick] [--json PATH]

The points are the book's CRH2 scenario (crh2-dmpc: analysis and its three
simulated strategies) at several weights R, with the simulated time cut to
``--duration`` seconds so that one point runs in about two seconds.

Part 1 — the runner's overhead, side by side and interleaved (the order of
the two alternates from one repeat to the next):

  direct    run_scenario(s).to_dict() for each validated point scenario
  sweep     run_sweep(store, ...) serially into a new store: the same runs,
            their summaries without wall-clock values, each point written
            (summary.json and the sampled arrays, atomically), the table
            built from the store and read back

The overhead is sweep / direct - 1 (median of the paired ratios, and the
ratio of the best times); the target is under 5 %. The store's own work is
also timed alone, on the results of one run, so it can be read without the
noise of the runs: write_point per point, write_table + read_table.

Part 2 — the same ``--points`` points (default 8) with 1 and 2 local worker
processes (``-j 1`` is one after the other in this process, ``-j 2`` the
process pool of trainctl.run.pool.worker_pool, its start-up included) and on
a Dask LocalCluster of two single-threaded worker processes on loopback
(started beforehand and warmed, as a running cluster is; the client's
connection is included). The speed-up is relative to ``-j 1``.

Part 3 — the table of a large sweep: a store of ``--table-points`` points
(default 10 000) is made from one real point's summary.json (hard-linked
under 10 000 keys, R = 0, 1, 2, ...), and a fresh process builds and writes
its rows.parquet (write_table: every summary read, its rows made, the frame
built and written). Reported: the time, the peak resident memory above the
process's before the call (modules imported and one point's table written, so
only what grows with the points counts), and the Parquet bytes per row, as
written (the copies' rows repeat, which Parquet compresses well) and with every
float column replaced by random numbers (rows that differ, as a real sweep's).

On a machine with two cores, shared with other work, part 2's ratios are
bounded by 2 and lowered by whatever else runs.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

from trainctl.run.analysis import run_scenario
from trainctl.run.pool import worker_pool
from trainctl.scenario import builtin_scenario_text, load_scenario
from trainctl.sweep import SweepDefinition, SweepPoint, parse_set, point_key
from trainctl.sweep.runner import dask_executor, run_point_results, run_sweep
from trainctl.sweep.store import SweepStore

SCENARIO = "crh2-dmpc"
R_VALUES = (5, 6, 8, 10, 12, 15, 20, 30, 40, 50, 60, 80)


def sweep_points(count: int, duration: float) -> tuple[SweepDefinition, list[Any], list[Any]]:
    """``count`` points of crh2-dmpc over R, ``duration`` s simulated: sweep, points, scenarios."""
    values = ",".join(str(r) for r in R_VALUES[:count])
    sweep = SweepDefinition((parse_set(f"controller.r_per_kn2={values}"),
                             parse_set(f"simulation.duration={duration!r}")))
    points = sweep.points()
    return sweep, points, sweep.validate(load_scenario(SCENARIO))


def new_store(root: Path, sweep: SweepDefinition, points: list[Any],
              scenarios: list[Any]) -> tuple[SweepStore, dict[str, Any]]:
    """A new store for the sweep in ``root`` and its key → scenario mapping."""
    keys = [point_key(s) for s in scenarios]
    store = SweepStore.open(root, label=SCENARIO, scenario_text=builtin_scenario_text(SCENARIO),
                            points=points, keys=keys, swept=sweep.keys, simulate=True)
    return store, dict(zip(keys, scenarios, strict=True))


def time_direct(scenarios: list[Any]) -> tuple[float, float]:
    """Wall and CPU seconds of this process to run every scenario and summarise it."""
    wall, cpu = time.perf_counter(), time.process_time()
    for scenario in scenarios:
        run_scenario(scenario).to_dict()
    return time.perf_counter() - wall, time.process_time() - cpu


def time_sweep(root: Path, sweep: SweepDefinition, points: list[Any], scenarios: list[Any],
               executor: Executor | None = None) -> tuple[float, float]:
    """Wall and CPU seconds of this process for run_sweep into a new store in ``root``.

    Opening the store, and reading the table back, are included.
    """
    wall, cpu = time.perf_counter(), time.process_time()
    store, by_key = new_store(root, sweep, points, scenarios)
    frame = run_sweep(store, by_key, executor=executor)
    seconds = time.perf_counter() - wall, time.process_time() - cpu
    assert len(frame) == 3 * len(set(by_key)), "three strategies per point"
    return seconds


def store_costs(scratch: Path, sweep: SweepDefinition, points: list[Any],
                scenarios: list[Any], repeats: int) -> dict[str, float]:
    """The store's work alone [s]: write_point per point, write_table + read_table."""
    results = [run_point_results(s) for s in scenarios]
    per_point, table = [], []
    for r in range(repeats):
        store, by_key = new_store(scratch / f"store-{r}", sweep, points, scenarios)
        start = time.perf_counter()
        for key, (summary, sims) in zip(by_key, results, strict=True):
            store.write_point(key, summary, sims)
        per_point.append((time.perf_counter() - start) / len(by_key))
        start = time.perf_counter()
        store.write_table()
        store.read_table()
        table.append(time.perf_counter() - start)
    return {"write_point_s": min(per_point), "table_s": min(table)}


def part_overhead(scratch: Path, count: int, duration: float, repeats: int) -> dict[str, Any]:
    """Part 1: run_sweep serially against direct runs of the same points, interleaved."""
    sweep, points, scenarios = sweep_points(count, duration)
    run_scenario(scenarios[0])  # warm imports and caches before anything is timed
    direct, swept = [], []
    for r in range(repeats):
        order = ("direct", "sweep") if r % 2 == 0 else ("sweep", "direct")
        for what in order:
            if what == "direct":
                direct.append(time_direct(scenarios))
            else:
                swept.append(time_sweep(scratch / f"overhead-{r}", sweep, points, scenarios))
    ratios = [s[0] / d[0] for s, d in zip(swept, direct, strict=True)]
    costs = store_costs(scratch, sweep, points, scenarios, repeats)
    point_s = min(d[0] for d in direct) / count
    return {
        "points": count, "duration_s": duration, "repeats": repeats,
        "direct_wall_s": [d[0] for d in direct], "sweep_wall_s": [s[0] for s in swept],
        "direct_cpu_s": [d[1] for d in direct], "sweep_cpu_s": [s[1] for s in swept],
        "point_s": point_s,
        "overhead_median": statistics.median(ratios) - 1.0,
        "overhead_best": min(s[0] for s in swept) / min(d[0] for d in direct) - 1.0,
        "overhead_cpu_best": min(s[1] for s in swept) / min(d[1] for d in direct) - 1.0,
        "store_write_point_s": costs["write_point_s"],
        "store_table_s": costs["table_s"],
        "store_overhead": (costs["write_point_s"] * count + costs["table_s"])
        / (point_s * count),
    }


def part_speedup(scratch: Path, count: int, duration: float) -> dict[str, Any]:
    """Part 2: ``count`` points with -j 1, -j 2 and a two-worker Dask LocalCluster."""
    import distributed

    sweep, points, scenarios = sweep_points(count, duration)
    run_scenario(scenarios[0])
    seconds: dict[str, float] = {}
    seconds["-j 1"] = time_sweep(scratch / "j1", sweep, points, scenarios)[0]
    start = time.perf_counter()
    with worker_pool(2) as pool:
        time_sweep(scratch / "j2", sweep, points, scenarios, pool)
    seconds["-j 2"] = time.perf_counter() - start  # the pool's start and stop included
    start = time.perf_counter()
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=":0",
                                  silence_logs=40) as cluster:
        cluster_start = time.perf_counter() - start
        with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
            # a running cluster's workers have trainctl imported already
            client.run(lambda: __import__("trainctl.run.analysis") and None)
        start = time.perf_counter()
        with dask_executor(cluster.scheduler_address) as executor:
            time_sweep(scratch / "dask", sweep, points, scenarios, executor)
        seconds["dask 2 workers"] = time.perf_counter() - start
    tables = {name: (scratch / d / "rows.parquet").read_bytes()
              for name, d in (("-j 1", "j1"), ("-j 2", "j2"), ("dask", "dask"))}
    return {
        "points": count, "duration_s": duration, "seconds": seconds,
        "speedup": {name: seconds["-j 1"] / s for name, s in seconds.items()},
        "cluster_start_s": cluster_start,
        "tables_identical": len(set(tables.values())) == 1,
    }


TABLE_CHILD = """
import io, json, resource, sys, time
import numpy, pandas, pyarrow.parquet
from trainctl.sweep.definition import SweepPoint
from trainctl.sweep.rows import point_rows
from trainctl.sweep.store import SweepStore, rows_frame

def rss():
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) * 1024 for line in fh if line.startswith("VmRSS:"))

store = SweepStore.load(sys.argv[1])
first = store.manifest["points"][0]
warm = rows_frame(point_rows(SweepPoint(0, first["values"]), first["key"],
                             store.summary(first["key"])), store.manifest["swept"])
warm.to_parquet(io.BytesIO(), index=False, engine="pyarrow")
before = rss()
start = time.perf_counter()
path = store.write_table()
seconds = time.perf_counter() - start
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
frame = pandas.read_parquet(path)
# the same table with every float replaced by a random one (NaN kept): rows that differ
rng = numpy.random.default_rng(0)
for name in frame.columns:
    if frame[name].dtype == "float64":
        frame[name] = frame[name].where(frame[name].isna(), rng.random(len(frame)))
buffer = io.BytesIO()
frame.to_parquet(buffer, index=False, engine="pyarrow")
print(json.dumps({"seconds": seconds, "baseline_rss": before, "peak_rss": peak,
                  "rows": len(frame), "columns": len(frame.columns),
                  "bytes": path.stat().st_size, "random_bytes": len(buffer.getvalue())}))
"""


def part_table(scratch: Path, source: SweepStore, count: int) -> dict[str, Any]:
    """Part 3: write the table of ``count`` copies of one stored point, in a fresh process."""
    key = source.keys[0]
    summary = source.points_dir / key / "summary.json"
    axis = source.manifest["swept"][0]
    points = [SweepPoint(i, {axis: float(i)}) for i in range(count)]
    keys = [hashlib.sha256(str(i).encode()).hexdigest() for i in range(count)]
    root = scratch / "table"
    store = SweepStore.open(root, label=SCENARIO, scenario_text="", points=points, keys=keys,
                            swept=[axis], simulate=True)
    for k in keys:
        (store.points_dir / k).mkdir()
        os.link(summary, store.points_dir / k / "summary.json")
    child = subprocess.run([sys.executable, "-c", TABLE_CHILD, str(root)], check=True,
                           capture_output=True, text=True)
    out = json.loads(child.stdout)
    return {
        "points": count, "rows": out["rows"], "seconds": out["seconds"],
        "summary_bytes": summary.stat().st_size,
        "columns": out["columns"],
        "parquet_bytes": out["bytes"], "parquet_bytes_per_row": out["bytes"] / out["rows"],
        "random_parquet_bytes_per_row": out["random_bytes"] / out["rows"],
        "peak_memory_bytes": out["peak_rss"] - out["baseline_rss"],
        "peak_memory_bytes_per_row": (out["peak_rss"] - out["baseline_rss"]) / out["rows"],
    }


def main() -> None:
    """Run both parts, print a table, write the numbers as JSON on request."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="fewer and shorter points, fewer repeats (smoke run)")
    parser.add_argument("--points", type=int, default=8, help="points of part 2 (default 8)")
    parser.add_argument("--duration", type=float, default=400.0,
                        help="simulated time per point [s] (default 400: about 2 s a point)")
    parser.add_argument("--repeats", type=int, default=3, help="repeats of part 1 (default 3)")
    parser.add_argument("--table-points", type=int, default=10_000,
                        help="points of part 3's store (default 10 000)")
    parser.add_argument("--json", help="also write the numbers to this file")
    args = parser.parse_args()
    count, duration, repeats, table = (args.points, args.duration, args.repeats,
                                       args.table_points)
    if args.quick:
        count, duration, repeats, table = 4, 200.0, 2, 1000
    results: dict[str, Any] = {"load_average": os.getloadavg()}
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        one = part_overhead(scratch, max(2, count // 2), duration, repeats)
        results["overhead"] = one
        print(f"load average: {' '.join(f'{x:.2f}' for x in results['load_average'])} "
              f"({os.cpu_count()} CPUs)")
        print(f"Part 1: {one['points']} points of {SCENARIO} ({duration:g} s simulated, "
              f"{one['point_s']:.2f} s a point), {repeats} interleaved repeats")
        print(f"  {'':<34} {'best wall':>9}  {'ratio':>5}  {'best CPU':>9}  {'ratio':>5}")
        print(f"  {'direct (run_scenario + to_dict)':<34} {min(one['direct_wall_s']):7.2f} s  "
              f"1.000  {min(one['direct_cpu_s']):7.2f} s  1.000")
        print(f"  {'run_sweep into a store':<34} {min(one['sweep_wall_s']):7.2f} s  "
              f"{1 + one['overhead_best']:.3f}  {min(one['sweep_cpu_s']):7.2f} s  "
              f"{1 + one['overhead_cpu_best']:.3f}")
        print(f"  overhead: {100 * one['overhead_best']:+.1f} % wall, "
              f"{100 * one['overhead_cpu_best']:+.1f} % CPU (best times), "
              f"{100 * one['overhead_median']:+.1f} % wall (median of paired ratios); "
              "target < 5 %")
        print(f"  store alone: write_point {1e3 * one['store_write_point_s']:.1f} ms a point, "
              f"table {1e3 * one['store_table_s']:.1f} ms: "
              f"{100 * one['store_overhead']:.1f} % of the points' runs", flush=True)
        two = part_speedup(scratch, count, duration)
        results["speedup"] = two
        print(f"Part 2: {count} points ({duration:g} s simulated)")
        print(f"  {'executor':<16} {'wall [s]':>9} {'speed-up':>9}")
        for name, seconds in two["seconds"].items():
            print(f"  {name:<16} {seconds:9.2f} {two['speedup'][name]:9.2f}")
        print(f"  (LocalCluster start, not included: {two['cluster_start_s']:.1f} s; "
              f"tables identical: {two['tables_identical']})", flush=True)
        three = part_table(scratch, SweepStore.load(scratch / "overhead-0"), table)
        results["table"] = three
        print(f"Part 3: the table of {table} points ({three['rows']} rows), one process")
        print(f"  write_table {three['seconds']:.1f} s; peak memory "
              f"+{three['peak_memory_bytes'] / 2**20:.0f} MiB "
              f"({three['peak_memory_bytes_per_row'] / 1024:.1f} KiB a row); rows.parquet "
              f"{three['parquet_bytes'] / 2**20:.1f} MiB ({three['parquet_bytes_per_row']:.0f} "
              f"bytes a row; {three['random_parquet_bytes_per_row']:.0f} with random floats, "
              f"{three['columns']} columns); summary.json {three['summary_bytes'] / 1024:.0f} "
              "KiB a point")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(results, fh, indent=1)


if __name__ == "__main__":
    main()
