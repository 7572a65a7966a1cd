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

Part 2 — ``-j 1 / -j 2 / dask``: the same ``--points`` points (default 8) with
1 and 2 local worker processes (``-j 1`` is one after the other in this
process, ``-j 2`` the process pool of trainctl.run.pool.worker_pool, its
start-up and shut-down included) and on a Dask LocalCluster of two
single-threaded worker processes on loopback (started beforehand and warmed,
as a running cluster is; the client's connection is included), in
``--rounds`` interleaved rounds (the order rotates from one round to the
next). The speed-up is the median over rounds of ``-j 1``'s time over
each one's in the same round. Each point's run is timed where it runs
(process, start, end, CPU seconds), so that a shared machine's noise can be
told from the executor's own cost: the delay before the first point starts,
the share of the time two points really ran side by side, the CPU share each
point's process got (CPU / wall), and the CPU seconds of the workers beyond
their points' runs (the pool's start-up in them; local pool only).

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
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from concurrent.futures import Executor, Future
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


def _timed(fn: Any, *args: Any) -> tuple[Any, dict[str, float]]:
    """Run ``fn(*args)`` where it is submitted; its result and (pid, start, end, CPU)."""
    start, cpu = time.time(), time.process_time()
    out = fn(*args)
    return out, {"pid": os.getpid(), "start": start, "end": time.time(),
                 "cpu": time.process_time() - cpu}


class TimedExecutor(Executor):
    """An executor that runs each task through :func:`_timed` and keeps the timeline."""

    def __init__(self, inner: Executor) -> None:
        self.inner = inner
        self.timeline: list[dict[str, float]] = []

    def submit(self, fn: Any, /, *args: Any, **kwargs: Any) -> Future[Any]:
        assert not kwargs
        outer: Future[Any] = Future()

        def done(inner: Future[Any]) -> None:
            try:
                result, entry = inner.result()
            except BaseException as exc:  # noqa: BLE001 - handed to the caller
                outer.set_exception(exc)
                return
            self.timeline.append(entry)
            outer.set_result(result)

        self.inner.submit(_timed, fn, *args).add_done_callback(done)
        return outer


def timeline_stats(timeline: list[dict[str, float]], start: float) -> dict[str, Any]:
    """First start after ``start`` [s], the share of the span with 2+ points running, the
    CPU share of the points' processes (CPU / wall), the points' CPU seconds."""
    events = sorted([(e["start"], 1) for e in timeline] + [(e["end"], -1) for e in timeline])
    running, last, both = 0, events[0][0], 0.0
    for moment, step in events:
        if running >= 2:
            both += moment - last
        running, last = running + step, moment
    span = max(e["end"] for e in timeline) - min(e["start"] for e in timeline)
    return {
        "first_start_s": min(e["start"] for e in timeline) - start,
        "overlap": both / span if span > 0 else 0.0,
        "cpu_share": sum(e["cpu"] for e in timeline) / sum(e["end"] - e["start"]
                                                           for e in timeline),
        "points_cpu_s": sum(e["cpu"] for e in timeline),
        "pids": len({e["pid"] for e in timeline}),
        "busiest_worker_cpu_s": max(sum(e["cpu"] for e in timeline if e["pid"] == pid)
                                    for pid in {e["pid"] for e in timeline}),
        "points": [{"pid": e["pid"], "start": e["start"] - start, "end": e["end"] - start,
                    "cpu": e["cpu"]} for e in sorted(timeline, key=lambda e: e["start"])],
    }


def part_speedup(scratch: Path, count: int, duration: float, rounds: int) -> dict[str, Any]:
    """Part 2: ``count`` points with -j 1, -j 2 and a two-worker Dask LocalCluster."""
    import resource

    import distributed

    sweep, points, scenarios = sweep_points(count, duration)
    run_scenario(scenarios[0])
    names = ("-j 1", "-j 2", "dask")
    seconds: dict[str, list[float]] = {name: [] for name in names}
    stats: dict[str, list[dict[str, Any]]] = {name: [] for name in names}
    parent_cpu: dict[str, list[float]] = {name: [] for name in names}
    tables: dict[str, bytes] = {}
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=":0",
                                  silence_logs=40) as cluster:
        with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
            # a running cluster's workers have trainctl imported already
            client.run(lambda: __import__("trainctl.run.analysis") and None)
        for r in range(rounds):
            for name in names[r % 3:] + names[:r % 3]:
                target = scratch / f"{name.replace(' ', '')}-{r}"
                start, cpu = time.perf_counter(), time.process_time()
                wall0 = time.time()
                children = resource.getrusage(resource.RUSAGE_CHILDREN)
                if name == "-j 1":
                    time_sweep(target, sweep, points, scenarios)
                elif name == "-j 2":
                    with worker_pool(2) as pool:
                        assert pool is not None
                        timed = TimedExecutor(pool)
                        time_sweep(target, sweep, points, scenarios, timed)
                else:
                    with dask_executor(cluster.scheduler_address) as executor:
                        timed = TimedExecutor(executor)
                        time_sweep(target, sweep, points, scenarios, timed)
                seconds[name].append(time.perf_counter() - start)
                parent_cpu[name].append(time.process_time() - cpu)
                if name != "-j 1":
                    entry = timeline_stats(timed.timeline, wall0)
                    if name == "-j 2":
                        after = resource.getrusage(resource.RUSAGE_CHILDREN)
                        used = (after.ru_utime + after.ru_stime
                                - children.ru_utime - children.ru_stime)
                        # only workers this process waited for count: forked ones, not those of
                        # a forkserver (whose start-up is in the forkserver, not counted)
                        entry["workers_cpu_beyond_points_s"] = (
                            used - entry["points_cpu_s"] if used >= entry["points_cpu_s"]
                            else math.nan)
                    stats[name].append(entry)
                tables.setdefault(name, (target / "rows.parquet").read_bytes())
    medians = {name: statistics.median(seconds[name]) for name in names}
    return {
        "points": count, "duration_s": duration, "rounds": rounds, "seconds": seconds,
        "median_s": medians, "parent_cpu_s": parent_cpu,
        "speedup": {name: statistics.median(a / b for a, b in zip(
            seconds["-j 1"], seconds[name], strict=True)) for name in names},
        "timelines": stats,
        "tables_identical": len(set(tables.values())) == 1,
        "load_average_after": os.getloadavg(),
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


def one_store(scratch: Path) -> SweepStore:
    """A store of one point (part 3's source when part 1 did not run)."""
    sweep, points, scenarios = sweep_points(1, 200.0)
    time_sweep(scratch / "one", sweep, points, scenarios)
    return SweepStore.load(scratch / "one")


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


def print_speedup(two: dict[str, Any]) -> None:
    """Part 2's table and the timelines' summary."""
    print(f"Part 2: -j 1 / -j 2 / dask, {two['points']} points ({two['duration_s']:g} s "
          f"simulated), {two['rounds']} interleaved rounds")
    print(f"  {'executor':<8} {'median [s]':>10} {'speed-up':>9} {'1st start':>9} "
          f"{'overlap':>8} {'CPU/wall':>8} {'points CPU':>10} {'start CPU':>9}")
    for name, median in two["median_s"].items():
        line = f"  {name:<8} {median:10.2f} {two['speedup'][name]:9.2f}"
        runs = two["timelines"][name]
        if runs:
            med = {k: statistics.median(r[k] for r in runs)
                   for k in ("first_start_s", "overlap", "cpu_share", "points_cpu_s")}
            line += (f" {med['first_start_s']:8.2f}s {100 * med['overlap']:7.0f}% "
                     f"{med['cpu_share']:8.2f} {med['points_cpu_s']:9.2f}s")
            if "workers_cpu_beyond_points_s" in runs[0]:
                beyond = statistics.median(r["workers_cpu_beyond_points_s"] for r in runs)
                line += f" {beyond:8.2f}s"
        print(line)
    print("  (1st start: from the executor's making to its first point's start; overlap: "
          "share of the points' span with two running; CPU/wall: CPU share the points' "
          "processes got; start CPU: the workers' CPU beyond their points, nan where they "
          "are not this process's children)")
    print(f"  (tables identical: {two['tables_identical']}; load average after: "
          f"{' '.join(f'{x:.2f}' for x in two['load_average_after'])})", flush=True)


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
    parser.add_argument("--rounds", type=int, default=3,
                        help="interleaved rounds of part 2 (default 3)")
    parser.add_argument("--parts", default="123", help="the parts to run (default 123)")
    parser.add_argument("--json", help="also write the numbers to this file")
    args = parser.parse_args()
    count, duration, repeats, table = (args.points, args.duration, args.repeats,
                                       args.table_points)
    if args.quick:
        count, duration, repeats, table = 4, 200.0, 2, 1000
    results: dict[str, Any] = {"load_average": os.getloadavg()}
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        print(f"load average: {' '.join(f'{x:.2f}' for x in results['load_average'])} "
              f"({os.cpu_count()} CPUs)")
        if "1" in args.parts:
            one = part_overhead(scratch, max(2, count // 2), duration, repeats)
            results["overhead"] = one
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
        if "2" in args.parts:
            two = part_speedup(scratch, count, duration, args.rounds)
            results["speedup"] = two
            print_speedup(two)
        if "3" in args.parts:
            three = part_table(scratch, SweepStore.load(scratch / "overhead-0")
                               if "1" in args.parts else one_store(scratch), table)
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
