# The `trainctl sweep` subcommand: its options, the dry run, the run into a store, the rows.
"""The ``sweep`` subcommand of :mod:`trainctl.cli.main`.

:func:`_add_sweep` declares its options; its handler validates every point
(the scenario's ``[sweep]`` or the ``--set`` axes and ``--seeds``), lists them
with ``--dry-run`` (summarises a large sweep) or runs them, serially, on a
process pool or on a Dask cluster, into a resumable store (:mod:`trainctl.sweep`),
and prints the rows.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

from trainctl.cli.support import EXIT_OK, PROG, _by_signal, positive_int
from trainctl.run._signals import exit_status

__all__: list[str] = []


def _add_sweep(sub: Any) -> None:
    """The ``sweep`` subcommand."""
    p_sweep = sub.add_parser(
        "sweep",
        help="run a parameter sweep over scenario keys into a resumable store",
        description="Define a parameter sweep over file keys of a scenario (its [sweep] "
        "section, or --set and --seeds), validate every point by the scenario schema before "
        "anything runs, then run every point's analysis and simulations (serially, on --jobs "
        "worker processes, or on a Dask cluster with --scheduler) into a store in --output: "
        "one tidy table (rows.parquet, one row per point and strategy: the swept values, "
        "every check's status and value, every metric) and each run's time series. An "
        "interrupted sweep run again with the same command finishes the missing points. "
        "'trainctl report DIR' renders the store. --dry-run only lists the points.",
    )
    p_sweep.add_argument(
        "scenario", metavar="SCENARIO", help="built-in scenario name or path to a TOML file"
    )
    p_sweep.add_argument(
        "--set", metavar="KEY=V1,V2,...", action="append", default=[], dest="sets",
        help="a list axis: a file key path and its values (TOML values split on commas "
        "outside brackets, e.g. controller.r_per_kn2=0.1,1,10); repeat for a product, the "
        "first varying slowest; replaces the axes of the scenario's [sweep]",
    )
    p_sweep.add_argument(
        "--seeds", metavar="N", type=positive_int,
        help="repeat every point with the scenario seeds seed, ..., seed + N - 1 (overrides "
        "[sweep] seeds)",
    )
    p_sweep.add_argument(
        "--dry-run", action="store_true",
        help="validate every point and list them (more than 1000 points: summarise the "
        "sweep and validate a spread of each axis's values); run nothing, write nothing",
    )
    p_sweep.add_argument(
        "--no-simulate", action="store_true",
        help="run each point's analysis only, not its [simulation] strategies",
    )
    p_sweep.add_argument(
        "--json", action="store_true",
        help="print the rows (one per point and strategy) as JSON on standard output",
    )
    p_sweep.add_argument(
        "-j", "--jobs", metavar="N", type=positive_int, default=1,
        help="worker processes for the points (default 1: one after the other); at most "
        "the usable CPUs and the points to run",
    )
    p_sweep.add_argument(
        "--scheduler", metavar="ADDRESS",
        help="run the points on a Dask cluster, e.g. tcp://HOST:8786 (default: the "
        "TRAINCTL_DASK_SCHEDULER environment variable; without either, locally); needs "
        "trainctl-toolbox[dask]",
    )
    p_sweep.add_argument(
        "-o", "--output", metavar="DIR",
        help="the store's directory (default reports/sweeps/NAME for a built-in, "
        "reports/sweeps/<slug of the scenario name> otherwise); a store of the same sweep is "
        "resumed, one of another sweep refused",
    )
    p_sweep.add_argument(
        "--csv", action="store_true", help="also write the table as rows.csv",
    )
    p_sweep.add_argument(
        "--arrays", choices=("sampled", "dense", "none"), default="sampled",
        help="what to keep of each run's time series beside the table: the arrays at the "
        "controller's samples (default), those and the between-sample ones (about 100 times "
        "larger), or nothing",
    )
    p_sweep.set_defaults(func=_cmd_sweep)



def _cmd_sweep(args: argparse.Namespace) -> int:
    from trainctl.scenario import parse_scenario, read_scenario_text
    from trainctl.sweep import SweepDefinition, parse_set
    from trainctl.sweep.definition import DRY_RUN_LISTED

    if not args.dry_run:  # a malformed scheduler address is refused before any work
        from trainctl.sweep.runner import SCHEDULER_ENV, check_scheduler_address, scheduler_address

        address = scheduler_address(args.scheduler)
        if address:
            check_scheduler_address(address, "--scheduler" if args.scheduler else SCHEDULER_ENV)
    axes = [parse_set(text) for text in args.sets]
    text, label = read_scenario_text(args.scenario)
    scenario = parse_scenario(text, source=label)
    sweep = SweepDefinition.of(scenario, axes, seeds=args.seeds)
    if not args.dry_run:
        scenarios = sweep.validate(scenario)  # refuses a sweep too large to run at once
        points = sweep.points(base_seed=scenario.seed)
        return _run_sweep(args, label, text, scenario, sweep, points, scenarios)
    if sweep.n_points > DRY_RUN_LISTED:
        return _summarise_sweep(label, scenario, sweep)
    points = sweep.points(base_seed=scenario.seed)
    pairs = list(zip(points, sweep.validate(scenario), strict=True))
    print(f"{label}: {len(points)} valid sweep points")
    _print_points(sweep, pairs)
    return EXIT_OK


def _print_points(sweep: Any, pairs: Any) -> None:
    """The table of a dry run: index, the swept values and the start of each point's key."""
    from trainctl.sweep import point_key
    from trainctl.sweep.definition import toml_text

    header = ["point", *sweep.keys, "key"]
    rows = [[str(p.index), *(toml_text(v) for v in p.values()), point_key(s)[:12]]
            for p, s in pairs]
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    for row in [header, *rows]:
        print("  ".join(c.rjust(w) if i == 0 else c.ljust(w)
                        for i, (c, w) in enumerate(zip(row, widths, strict=True))).rstrip())


def _summarise_sweep(label: str, scenario: Any, sweep: Any) -> int:
    """The dry run of a sweep too large to list: its size, its axes and a validated sample.

    Validating every point takes a few milliseconds each (hours for a million): the
    first and last points and a spread of every axis's values are validated instead,
    in time independent of the sweep's size.
    """
    from trainctl.sweep.definition import DRY_RUN_LISTED, MAX_RUN_POINTS, RandomAxis, toml_text

    pairs = sweep.validate_sample(scenario)
    sizes = " × ".join(str(n) for n in sweep.sizes())
    print(f"{label}: {sweep.n_points} sweep points ({sizes}), more than {DRY_RUN_LISTED}: "
          f"not listed; {len(pairs)} of them validated (the first, the last and a spread of "
          "each axis's values)")
    for axis in sweep.axes:
        if isinstance(axis, RandomAxis):
            print(f"  {axis.key}: {sweep.samples} draws, {axis.distribution}")
        else:
            values = axis.grid_values()
            ends = (toml_text(values[0]) if len(values) == 1
                    else f"{toml_text(values[0])} ... {toml_text(values[-1])}")
            print(f"  {axis.key}: {len(values)} values, {ends}")
    if sweep.seeds > 1:
        print(f"  seed: {sweep.seeds} seeds, {scenario.seed} ... {scenario.seed + sweep.seeds - 1}")
    _print_points(sweep, pairs)
    if sweep.n_points > MAX_RUN_POINTS:
        print(f"{label}: a run of this sweep is refused: more than {MAX_RUN_POINTS} points "
              "(each is validated before any runs); split it into several sweeps",
              file=sys.stderr)
    else:
        print(f"{label}: a run validates every point before any runs", file=sys.stderr)
    return EXIT_OK


def default_sweep_dir(scenario: Any) -> Path:
    """``reports/sweeps/<stem>``, the stem of :func:`~trainctl.report.batch.default_report_path`."""
    from trainctl.report.batch import default_report_path

    return Path("reports") / "sweeps" / default_report_path(scenario).stem


def _run_sweep(args: argparse.Namespace, label: str, text: str, scenario: Any, sweep: Any,
               points: Any, scenarios: Any) -> int:
    """Run the points of ``trainctl sweep`` into its store and print the rows."""
    from trainctl.sweep import point_key
    from trainctl.sweep.runner import SCHEDULER_ENV, dask_executor, scheduler_address
    from trainctl.sweep.store import SweepStore

    keys = [point_key(s) for s in scenarios]
    simulate = not args.no_simulate
    output = Path(args.output) if args.output else default_sweep_dir(scenario)
    address = scheduler_address(args.scheduler)
    option = "--scheduler" if args.scheduler else SCHEDULER_ENV
    store: SweepStore | None = None
    try:
        with contextlib.ExitStack() as stack:
            # the cluster is reached before the store is made: an unreachable
            # scheduler leaves nothing behind
            cluster = (stack.enter_context(dask_executor(address, option=option))
                       if address else None)
            store = SweepStore.open(output, label=label, scenario_text=text, points=points,
                                    keys=keys, swept=sweep.keys, simulate=simulate,
                                    arrays=args.arrays)
            stack.callback(store.close)
            for key, problem in store.damaged().items():
                print(f"{label}: {problem}: point {keys.index(key)} ({key[:12]}) is damaged; "
                      "recomputing it", file=sys.stderr)
            todo = store.missing()
            by_key = dict(zip(keys, scenarios, strict=True))
            if todo and len(todo) < len(set(keys)):
                print(f"{label}: resuming {output}: {len(set(keys)) - len(todo)} points "
                      f"stored, {len(todo)} to run", file=sys.stderr)
            frame = _sweep_points(args, store, todo, by_key, cluster, simulate)
    except KeyboardInterrupt as exc:
        if store is None:
            raise
        done = len(set(keys)) - len(store.missing())
        print(f"\n{PROG}: interrupted{_by_signal(exc)}: {done} of {len(set(keys))} points are "
              f"stored in {output}; run the same command again to finish the others",
              file=sys.stderr)
        return exit_status(exc)
    return _print_sweep(args, label, output, sweep, points, frame)


def _sweep_points(args: argparse.Namespace, store: Any, todo: list[str], by_key: Any,
                  cluster: Executor | None, simulate: bool) -> Any:
    """Run the missing points on ``cluster`` (Dask) or locally, with a progress bar; the table."""
    from trainctl.run._progress import Progress
    from trainctl.run.pool import pool_size, worker_pool
    from trainctl.sweep.runner import run_sweep

    with contextlib.ExitStack() as stack:
        executor: Executor | None
        if cluster is not None:
            executor = cluster
        else:
            workers = pool_size(args.jobs, len(todo))
            executor = stack.enter_context(worker_pool(workers))
        bar = stack.enter_context(Progress(len(todo)))
        return run_sweep(store, by_key, simulate=simulate, executor=executor,
                         on_point=lambda key: bar.advance(f"point {key[:8]}"), csv=args.csv)


def _print_sweep(args: argparse.Namespace, label: str, output: Path, sweep: Any, points: Any,
                 frame: Any) -> int:
    """Print a finished sweep's rows: a table, or JSON with ``--json``."""
    from trainctl.sweep.definition import toml_text

    rows = json.loads(frame.to_json(orient="records"))
    if args.json:
        print(json.dumps(rows, indent=2))
        return EXIT_OK
    header = ["point", *sweep.keys, "strategy", "failed checks", "max err [m/s]", "tracking"]
    table = []
    for row in rows:
        failed = [k.split(".")[1] for k, v in row.items()
                  if k.startswith("check.") and k.endswith(".status") and v == "fail"]
        err = row.get("metric.max_error")
        tracking = row.get("metric.tracking_ok")
        table.append([str(row["point"]), *(toml_text(row[k]) for k in sweep.keys),
                      row["strategy"] or "-", ", ".join(failed) or "-",
                      "-" if err is None else f"{err:.4g}",
                      "-" if tracking is None else ("ok" if tracking else "outside")])
    widths = [max(len(r[i]) for r in [header, *table]) for i in range(len(header))]
    print(f"{label}: {len(points)} sweep points, {len(rows)} rows in {output}/rows.parquet")
    for line in [header, *table]:
        print("  ".join(c.rjust(w) if i == 0 else c.ljust(w)
                        for i, (c, w) in enumerate(zip(line, widths, strict=True))).rstrip())
    return EXIT_OK
