# Command-line interface: `trainctl list | export | analyse | report`.
"""The ``trainctl`` command.

Subcommands
-----------
``list``
    One line per built-in scenario: its name and description.
``schema [--markdown]``
    The JSON Schema of scenario files (or the README's schema tables).
``export NAME [-o PATH] [--force]``
    Write a built-in scenario's TOML text to ``PATH`` (default ``./NAME.toml``).
``analyse SCENARIO [--json] [--deterministic] [--strict] [--no-simulate] [--jobs N] [--save DIR]``
    Print the model summary, the design checks and — when the scenario has a
    ``[simulation]`` section — the closed-loop metrics of a scenario (a
    built-in name or a file path); ``--save`` also writes everything a report
    shows to ``DIR``.
``sweep SCENARIO [--set KEY=V1,V2,...]... [--seeds N] [--dry-run] [-o DIR] ...``
    Validate every point of a parameter sweep (the scenario's ``[sweep]``,
    or the ``--set`` axes and ``--seeds``; :mod:`trainctl.sweep`); with
    ``--dry-run`` list the points: index, the swept values and the start of
    each point's key (a sweep of more than 1000 points is summarised: its
    size, its axes and a validated spread of each axis's values; a run takes
    at most 10 000 points). Otherwise every point runs (``--no-simulate``; serially,
    on ``--jobs N`` processes or on the Dask cluster of ``--scheduler``) into
    the store ``DIR`` (:mod:`trainctl.sweep.store`: ``rows.parquet``, one row
    per point and strategy, and each run's arrays); an interrupted sweep run
    again finishes the missing points; the rows are printed (``--json``).
``report [SCENARIO | DIR] [-o PATH] [--all] [--deterministic] [--timestamp T] [--jobs N]``
    Run a scenario (or read a directory saved by ``analyse --save``) and
    write its self-contained HTML design report (default
    ``reports/<name>.html``, see :func:`trainctl.report.batch.default_report_path`);
    ``--all`` writes every built-in's report and an ``index.html`` gallery
    into ``-o DIR``; a file there of a name the gallery writes is replaced
    only if trainctl wrote it (:func:`trainctl.report.batch.check_gallery_output`).
    For a sweep store (``trainctl sweep -o DIR``) the sweep report
    (:mod:`trainctl.report.sweep`), by default ``DIR/report.html``.

Output paths (``-o``): a regular file is replaced atomically, keeping its
owner and permissions; ``-``, ``/dev/null`` or a pipe that another process
reads is written through, never replaced; a path ending in ``/`` is a
directory that receives the default file name; anything else is refused before
any work
(:mod:`trainctl.report.output`). ``analyse`` and ``report`` estimate the run
first (:mod:`trainctl.run.budget`): a long one prints its estimate on stderr, one
over ``--max-time`` (default one hour) is refused, and a run that outlives
it is stopped. Solver chatter never reaches stdout (:mod:`trainctl.run._signals`).

Exit status: 0 the command ran; 1 ``--strict`` found a failure (a failing check, a
missed tracking tolerance, too long a saturation, a coupler above its admissible force,
or an ``[expected]`` mismatch); 2 a
usage, scenario or file error (``trainctl: error: <message>`` on stderr, no
traceback, no file written); 128 + the signal when a signal stopped it (130 Ctrl-C,
143 SIGTERM, 129 SIGHUP; no partial output, no worker left). Any other exception is a
bug and propagates.

Examples
--------
>>> args = build_parser().parse_args(["report"])
>>> args.scenario, args.output, args.all
(None, None, False)
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from trainctl import __version__
from trainctl.cli.support import (
    EXIT_CHECK_FAILED,
    EXIT_ERROR,
    EXIT_OK,
    PROG,
    _by_signal,
    add_budget_option,
    check_cost,
    describe_error,
    positive_int,
    printable_stdout,
    without_wall_clock,
)
from trainctl.cli.sweep import _add_sweep
from trainctl.exceptions import TrainctlError
from trainctl.naming import printable
from trainctl.run._signals import BudgetExceeded, exit_status, quiet_c_stdout, signal_guard

__all__ = ["DEFAULT_SCENARIO", "build_parser", "main"]

DEFAULT_SCENARIO = "crh2-dmpc"
"""Scenario used by ``trainctl report`` when none is given."""


class _UserError(TrainctlError):
    """A command-line usage problem found after parsing (e.g. refusing to overwrite)."""


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser of the ``trainctl`` command.

    Returns
    -------
    argparse.ArgumentParser
        Parser whose namespaces carry the handler in ``func``.

    Examples
    --------
    Parsing only, nothing runs; ``--max-time`` defaults to one hour [s]:

    >>> args = build_parser().parse_args(["analyse", "crh2-dmpc", "--jobs", "2"])
    >>> args.command, args.scenario, args.jobs, args.strict, args.max_time
    ('analyse', 'crh2-dmpc', 2, False, 3600.0)
    >>> args.func.__name__
    '_cmd_analyse'
    """
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Analyse distributed train control: model summaries, distributed MPC "
            "and HTML reports for the built-in or your own scenarios."
        ),
        epilog=(
            "exit status: 0 ran; 1 --strict found a failure; 2 usage, scenario or file error"
        ),
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in (_add_list, _add_schema, _add_export, _add_analyse, _add_sweep, _add_report):
        add(sub)
    return parser


def _add_list(sub: Any) -> None:
    """The ``list`` subcommand."""

    p_list = sub.add_parser("list", help="list the built-in scenarios")
    p_list.set_defaults(func=_cmd_list)


def _add_schema(sub: Any) -> None:
    """The ``schema`` subcommand."""
    p_schema = sub.add_parser(
        "schema",
        help="print the JSON Schema of scenario files",
        description="Print the JSON Schema (draft 2020-12) of scenario files, generated from "
        "the key declarations; editors that validate TOML against a JSON Schema use it.",
    )
    p_schema.add_argument(
        "--markdown", action="store_true",
        help="print the schema tables of analyses/README.md instead",
    )
    p_schema.set_defaults(func=_cmd_schema)


def _add_export(sub: Any) -> None:
    """The ``export`` subcommand."""
    p_export = sub.add_parser(
        "export",
        help="write a built-in scenario's TOML file, to start your own",
        description="Write the TOML text of a built-in scenario to a file.",
    )
    p_export.add_argument("name", metavar="NAME", help="built-in scenario name (see 'list')")
    p_export.add_argument(
        "-o",
        "--output",
        metavar="PATH",
        help="output file, DIR/ or a device ('-' for standard output; default: ./NAME.toml)",
    )
    p_export.add_argument("-f", "--force", action="store_true",
                          help="replace PATH if it is an existing file")
    p_export.set_defaults(func=_cmd_export)


def _add_analyse(sub: Any) -> None:
    """The ``analyse`` subcommand."""
    p_analyse = sub.add_parser(
        "analyse",
        aliases=["analyze"],
        help="model summary, design checks and simulations of a scenario",
        description="Print the model summary, the design checks (pass/warn/fail with hints) "
        "and, for scenarios with [simulation], the closed-loop metrics.",
    )
    p_analyse.add_argument(
        "scenario", metavar="SCENARIO", help="built-in scenario name or path to a TOML file"
    )
    p_analyse.add_argument(
        "--json", action="store_true", help="print the summary as JSON on standard output"
    )
    p_analyse.add_argument(
        "--deterministic", action="store_true",
        help="leave out wall-clock values (solve times): same input, same bytes",
    )
    p_analyse.add_argument(
        "--strict", action="store_true",
        help="exit with status 1 if a check fails, a simulated strategy misses its tracking "
        "tolerance, a vehicle saturates longer than [simulation] allows, a coupler's force "
        "exceeds its max_force_kn, or a check's status differs from [expected]"
    )
    p_analyse.add_argument(
        "--no-simulate", action="store_true",
        help="skip the [simulation] runs (model summary and design checks only)",
    )
    p_analyse.add_argument(
        "-j", "--jobs", metavar="N", type=positive_int,
        help="worker processes for the simulations (default: all CPUs when the simulations "
        "are long, else 1); at most the usable CPUs and the simulations to run",
    )
    p_analyse.add_argument(
        "--save", metavar="DIR",
        help="also write the results to DIR (new, empty, or an earlier --save); "
        "'trainctl report DIR' renders them without re-running",
    )
    add_budget_option(p_analyse)
    p_analyse.set_defaults(func=_cmd_analyse)


def _add_report(sub: Any) -> None:
    """The ``report`` subcommand."""
    p_report = sub.add_parser(
        "report",
        help="write the HTML design report of a scenario (or of all built-ins)",
        description="Run a scenario's analysis and simulations and write one self-contained "
        "HTML design report: scenario, model, design checks, controllers compared, figures.",
    )
    p_report.add_argument(
        "scenario",
        metavar="SCENARIO",
        nargs="?",
        help=f"built-in scenario name, path to a TOML file, a directory written by "
        f"'analyse --save', or a sweep store written by 'sweep' (its report goes to "
        f"DIR/report.html) (default: {DEFAULT_SCENARIO})",
    )
    p_report.add_argument(
        "-o",
        "--output",
        metavar="PATH",
        help=(
            "output HTML file, DIR/, a device or '-' for standard output (default: "
            "reports/NAME.html for a built-in, reports/<slug of the scenario name>.html "
            "otherwise); with --all, the output directory (default: reports), which may "
            "be missing or empty or hold an earlier gallery: a file there of a name the "
            "gallery writes (index.html, NAME.html) is replaced only if trainctl wrote it "
            "(its page carries <meta name=\"generator\" content=\"trainctl\">), otherwise "
            "the command refuses before any run (exit 2); other files are left alone"
        ),
    )
    p_report.add_argument(
        "--all", action="store_true",
        help="report on every built-in scenario and write an index.html gallery",
    )
    p_report.add_argument(
        "--deterministic", action="store_true",
        help="leave out wall-clock values (solve and stage times, and the current time unless "
        "--timestamp or SOURCE_DATE_EPOCH gives one): same input, same bytes",
    )
    p_report.add_argument(
        "--timestamp", metavar="TIME",
        help="time printed in the report, ISO 8601 or Unix seconds (default: now, or "
        "SOURCE_DATE_EPOCH when set)",
    )
    p_report.add_argument(
        "-j", "--jobs", metavar="N", type=positive_int,
        help="worker processes for the simulations (default: all CPUs when the simulations "
        "are long, else 1); at most the usable CPUs and the simulations to run",
    )
    add_budget_option(p_report)
    p_report.set_defaults(func=_cmd_report)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``trainctl`` command.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; ``sys.argv[1:]`` when None.

    Returns
    -------
    int
        Exit status: 0 ran, 1 ``--strict`` found a failure, 2 user error
        (argparse exits with 2 by itself on a usage error, 0 for ``--help``).

    Examples
    --------
    ``list`` prints one line per built-in scenario and returns 0; an unknown
    scenario is a user error: a one-line message on stderr and status 2:

    >>> import contextlib, io
    >>> out, err = io.StringIO(), io.StringIO()
    >>> with contextlib.redirect_stdout(out):
    ...     status = main(["list"])
    >>> status, out.getvalue().split()[0]
    (0, 'crh2-dmpc')
    >>> with contextlib.redirect_stderr(err):
    ...     status = main(["export", "no-such-scenario"])
    >>> status
    2
    >>> err.getvalue().split(": no built-in")[0]
    'trainctl: error: builtin:no-such-scenario'
    """
    parser = build_parser()
    args = parser.parse_args(list(argv) if argv is not None else None)
    func: Callable[[argparse.Namespace], int] = printable_stdout(args.func)
    try:
        # SIGTERM unwinds like Ctrl-C (temporary files removed); a watchdog ends a process
        # stuck in C code; C libraries' prints stay off stdout.
        with quiet_c_stdout(), signal_guard(max_time=getattr(args, "max_time", math.inf)):
            status = func(args)
    except (TrainctlError, OSError) as exc:
        _error(describe_error(exc))
        return EXIT_ERROR
    except BudgetExceeded as exc:
        from trainctl.run.budget import format_duration

        _error(f"stopped after {format_duration(exc.seconds)}: the run outlived its time budget "
               "(--max-time); no partial output was written. Give a larger --max-time, or "
               "make the train, the horizon or the run shorter.")
        return EXIT_ERROR
    except KeyboardInterrupt as exc:
        print(f"\n{PROG}: interrupted{_by_signal(exc)}; no partial output was written",
              file=sys.stderr)
        status = exit_status(exc)
    # An interrupted command (a sweep reports its own interrupt and returns 128 + signal)
    # run as the program itself, not called from Python, ends without delay.
    if status > 128 and argv is None:
        _exit_now(status)
    return status


def _exit_now(status: int) -> None:
    """End the process at once with ``status``, after the exit handlers but without the
    interpreter's teardown.

    Everything the command wrote is complete or removed by now (the unwinding ran every
    cleanup); what remains of an interrupted run is freeing its objects, which took 5 to
    15 s after a large design (seen: "Garbage-collecting" for 13 s on a loaded machine),
    longer than a signalled command may take to end.
    """
    import atexit

    with contextlib.suppress(Exception):
        atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(status)


def _error(message: str) -> None:
    print(f"{PROG}: error: {printable(message)}", file=sys.stderr)


def _cmd_list(args: argparse.Namespace) -> int:
    from trainctl.scenario import builtin_scenarios

    scenarios = builtin_scenarios()
    width = max((len(s.name) for s in scenarios), default=0)
    for item in scenarios:
        description = " ".join(str(item.description).split())
        print(f"{item.name:<{width}}  {description}".rstrip())
    return EXIT_OK


def _cmd_schema(args: argparse.Namespace) -> int:
    if args.markdown:
        from trainctl.scenario.docs import markdown_text

        print(markdown_text(), end="")
    else:
        from trainctl.scenario import json_schema

        print(json.dumps(json_schema(), indent=2, ensure_ascii=False))
    return EXIT_OK


def _cmd_export(args: argparse.Namespace) -> int:
    from trainctl.report.output import output_target, write_output
    from trainctl.scenario import builtin_scenario_text

    text = builtin_scenario_text(args.name)
    target = output_target(args.output or f"{args.name}.toml", default_name=f"{args.name}.toml")
    if target.kind == "file" and target.exists and not args.force:
        raise _UserError(f"{target} already exists; use --force to overwrite it")
    write_output(text, target)
    if not target.is_stdout:
        print(f"wrote {target}", file=sys.stderr if target.kind == "fd" else sys.stdout)
    return EXIT_OK


def _cmd_analyse(args: argparse.Namespace) -> int:
    from trainctl.run.analysis import run_scenario
    from trainctl.scenario import parse_scenario, read_scenario_text

    text, label = read_scenario_text(args.scenario)
    scenario = parse_scenario(text, source=label)
    if args.save:
        from trainctl.report.data import check_save_target

        check_save_target(args.save)
    check_cost([scenario], args.max_time, simulate=not args.no_simulate)
    from trainctl.run.pool import want_pool, worker_pool

    workers = 0 if args.no_simulate else want_pool([scenario], args.jobs)
    with worker_pool(workers) as pool:
        summary = run_scenario(scenario, simulate=not args.no_simulate, executor=pool)
    if args.save:
        from trainctl.report import collect_report_data, portable_command

        command = portable_command(_rebuild_argv(args))
        data = collect_report_data(summary, scenario_text=text, command=command)
        data.save(args.save)
    if args.json:
        found = summary.to_dict()
        print(json.dumps(without_wall_clock(found) if args.deterministic else found, indent=2))
    else:
        print(summary.format_text().rstrip("\n"))
    if args.save:
        print(f"saved results to {args.save}", file=sys.stderr)
    if args.strict:
        failures = summary.strict_failures()
        if failures:
            noun = "reason" if len(failures) == 1 else "reasons"
            print(f"{PROG}: --strict: {len(failures)} {noun}: "
                  + "; ".join(f"{f.kind} {f.name}" for f in failures), file=sys.stderr)
            return EXIT_CHECK_FAILED
    return EXIT_OK


def _rebuild_argv(args: argparse.Namespace) -> list[str]:
    """Arguments that reproduce ``args``, in a canonical order (printed in reports)."""
    argv = [args.command]
    if getattr(args, "scenario", None):
        argv.append(args.scenario)
    for flag in ("all", "deterministic", "json", "strict", "no_simulate"):
        if getattr(args, flag, False):
            argv.append("--" + flag.replace("_", "-"))
    for option in ("save", "timestamp", "output"):
        value = getattr(args, option, None)
        if value:
            argv += ["--" + option, str(value)]
    return argv


def _cmd_report(args: argparse.Namespace) -> int:
    from trainctl.report import ReportData, is_saved_run, normalise_timestamp, portable_command
    from trainctl.report.batch import (
        check_gallery_output,
        check_report_output,
        default_report_path,
        render_saved_run,
        report_all,
        report_scenario,
        summary_line,
    )
    from trainctl.run.pool import want_pool

    if args.all and args.scenario:
        raise _UserError("give either a SCENARIO or --all, not both")
    stamp = args.timestamp or os.environ.get("SOURCE_DATE_EPOCH") or None
    generated_at = normalise_timestamp(stamp) if stamp else None
    start = time.perf_counter()
    if args.all:
        from trainctl.scenario import builtin_scenarios

        jobs = [_report_job(item.name, args) for item in builtin_scenarios()]
        outdir = Path(args.output) if args.output else Path("reports")
        check_gallery_output(outdir, [default_report_path(j.scenario).name for j in jobs]
                             + ["index.html"])
        check_cost([j.scenario for j in jobs], args.max_time)
        index, written = report_all(jobs, outdir, generated_at=generated_at,
                                    deterministic=args.deterministic,
                                    workers=want_pool([j.scenario for j in jobs], args.jobs))
        failing = sum(1 for data, _ in written if data.results.get("failed_checks"))
        print(f"wrote {index} and {len(written)} reports ({failing} with failing checks; "
              f"{time.perf_counter() - start:.1f} s)")
        return EXIT_OK
    source = args.scenario or DEFAULT_SCENARIO
    if _is_sweep_store(source):
        from trainctl.report.sweep import default_sweep_report_path, write_sweep_report
        from trainctl.report.sweep import summary_line as sweep_line

        default = default_sweep_report_path(source)
        path = check_report_output(args.output or default, default_name=default.name)
        command = portable_command(["report", source] + (["--deterministic"]
                                                         if args.deterministic else []))
        _, sweep = write_sweep_report(source, path, generated_at=generated_at,
                                      deterministic=args.deterministic, command=command)
        print(f"wrote {path} ({sweep_line(sweep)}; {time.perf_counter() - start:.1f} s)",
              file=sys.stderr if path.kind == "fd" else sys.stdout)
        return EXIT_OK
    if Path(source).is_dir():
        if not is_saved_run(source):
            raise _UserError(f"{source}: is a directory but not one written by 'trainctl analyse "
                             "--save'; give a scenario file, a built-in name or a saved run")
        data = ReportData.load(source)
        default = default_report_path(data.scenario)
        path = check_report_output(args.output or default, default_name=default.name)
        render_saved_run(data, source, path, generated_at=generated_at,
                         deterministic=args.deterministic)
    else:
        job = _report_job(source, args)
        default = default_report_path(job.scenario)
        path = check_report_output(args.output or default, default_name=default.name)
        check_cost([job.scenario], args.max_time)
        data = report_scenario(job, path, workers=want_pool([job.scenario], args.jobs),
                               generated_at=generated_at, deterministic=args.deterministic)
    print(f"wrote {path} ({summary_line(data)}; {time.perf_counter() - start:.1f} s)",
          file=sys.stderr if path.kind == "fd" else sys.stdout)
    return EXIT_OK


def _is_sweep_store(source: str) -> bool:
    """Whether ``trainctl report SOURCE`` reports a sweep (a store is a directory).

    A scenario name or file does not import the sweep package.
    """
    if not Path(source).is_dir():
        return False
    from trainctl.sweep.store import is_sweep_store

    return is_sweep_store(source)


def _report_job(source: str, args: argparse.Namespace) -> Any:
    from trainctl.report import ReportJob, portable_command
    from trainctl.scenario import parse_scenario, read_scenario_text

    text, label = read_scenario_text(source)
    scenario = parse_scenario(text, source=label)
    argv = ["report", source]
    if args.deterministic:
        argv.append("--deterministic")
    return ReportJob(scenario=scenario, text=text, command=portable_command(argv))
