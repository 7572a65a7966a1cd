# Command-line interface: `trainctl list | export | analyse | report`.
"""The ``trainctl`` command.

Subcommands
-----------
``list``
    One line per built-in scenario: its name and description.
``export NAME [-o PATH] [--force]``
    Write a built-in scenario's TOML text to ``PATH`` (default ``./NAME.toml``).
``analyse SCENARIO [--json] [--strict] [--no-simulate]``
    Print the model summary, the design checks and — when the scenario has a
    ``[simulation]`` section — the closed-loop metrics of a scenario (a
    built-in name or a file path).
``report [SCENARIO] [-o PATH]``
    Write the HTML model summary (default ``reports/<slug>.html``, see
    :func:`default_report_path`).

Exit status: 0 the command ran; 1 ``--strict`` found a failing check; 2 a
usage, scenario or file error (``trainctl: error: <message>`` on stderr, no
traceback, no file written). Any other exception is a bug and propagates.

Examples
--------
>>> args = build_parser().parse_args(["report"])
>>> args.scenario, args.output
('crh2-dmpc', None)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from . import __version__
from .exceptions import TrainctlError

__all__ = ["DEFAULT_SCENARIO", "build_parser", "default_report_path", "main"]

PROG = "trainctl"

DEFAULT_SCENARIO = "crh2-dmpc"
"""Scenario used by ``trainctl report`` when none is given."""

EXIT_OK = 0
EXIT_CHECK_FAILED = 1
EXIT_ERROR = 2


class _UserError(TrainctlError):
    """A command-line usage problem found after parsing (e.g. refusing to overwrite)."""


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser of the ``trainctl`` command.

    Returns
    -------
    argparse.ArgumentParser
        Parser whose namespaces carry the handler in ``func``.
    """
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Analyse distributed train control: model summaries, distributed MPC "
            "and HTML reports for the built-in or your own scenarios."
        ),
        epilog=(
            "exit status: 0 ran; 1 --strict found a failing check; 2 usage, scenario or file error"
        ),
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p_list = sub.add_parser("list", help="list the built-in scenarios")
    p_list.set_defaults(func=_cmd_list)

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
        help="output file ('-' for standard output; default: ./NAME.toml)",
    )
    p_export.add_argument("-f", "--force", action="store_true", help="overwrite PATH if it exists")
    p_export.set_defaults(func=_cmd_export)

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
        "--strict", action="store_true", help="exit with status 1 if any check fails"
    )
    p_analyse.add_argument(
        "--no-simulate", action="store_true",
        help="skip the [simulation] runs (model summary and design checks only)",
    )
    p_analyse.set_defaults(func=_cmd_analyse)

    p_report = sub.add_parser(
        "report",
        help="write the HTML model-summary report of a scenario",
        description="Render the HTML model summary of a scenario.",
    )
    p_report.add_argument(
        "scenario",
        metavar="SCENARIO",
        nargs="?",
        default=DEFAULT_SCENARIO,
        help=f"built-in scenario name or path to a TOML file (default: {DEFAULT_SCENARIO})",
    )
    p_report.add_argument(
        "-o",
        "--output",
        metavar="PATH",
        help=(
            "output HTML file (default: reports/NAME.html for a built-in, "
            "reports/<slug of the scenario name>.html for a file)"
        ),
    )
    p_report.set_defaults(func=_cmd_report)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``trainctl`` command.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; ``sys.argv[1:]`` when None.

    Returns
    -------
    int
        Exit status: 0 ran, 1 a ``--strict`` check failed, 2 user error.
        (argparse exits with 2 by itself on a usage error, 0 for ``--help``.)
    """
    parser = build_parser()
    args = parser.parse_args(list(argv) if argv is not None else None)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except (TrainctlError, OSError) as exc:
        _error(_describe(exc))
        return EXIT_ERROR


def _error(message: str) -> None:
    print(f"{PROG}: error: {message}", file=sys.stderr)


def _describe(exc: BaseException) -> str:
    if isinstance(exc, OSError) and not isinstance(exc, TrainctlError):
        if exc.filename is not None and exc.strerror:
            return f"{exc.strerror}: {os.fsdecode(exc.filename)}"
    message = str(exc)
    return message or type(exc).__name__


def _cmd_list(args: argparse.Namespace) -> int:
    from .scenario import builtin_scenarios

    scenarios = builtin_scenarios()
    width = max((len(s.name) for s in scenarios), default=0)
    for item in scenarios:
        description = " ".join(str(item.description).split())
        print(f"{item.name:<{width}}  {description}".rstrip())
    return EXIT_OK


def _cmd_export(args: argparse.Namespace) -> int:
    from .scenario import builtin_scenario_text

    text = builtin_scenario_text(args.name)
    if args.output == "-":
        sys.stdout.write(text)
        return EXIT_OK
    path = Path(args.output) if args.output else Path(f"{args.name}.toml")
    if path.exists() and not args.force:
        raise _UserError(f"{path} already exists; use --force to overwrite it")
    if path.is_dir():
        raise _UserError(f"{path} is a directory; give a file path with -o")
    from .report.render import write_text_atomic

    write_text_atomic(text, path)
    print(f"wrote {path}")
    return EXIT_OK


def _summary_of(source: str) -> tuple[Any, Any]:
    from .analysis.summary import model_summary
    from .scenario import load_scenario

    scenario = load_scenario(source)
    return scenario, model_summary(scenario)


def _cmd_analyse(args: argparse.Namespace) -> int:
    from .run import run_scenario
    from .scenario import load_scenario

    summary = run_scenario(load_scenario(args.scenario), simulate=not args.no_simulate)
    if args.json:
        print(json.dumps(summary.to_dict(), indent=2))
    else:
        print(summary.format_text().rstrip("\n"))
    if args.strict:
        failed = summary.failed_checks
        if failed:
            noun = "check" if len(failed) == 1 else "checks"
            print(f"{PROG}: {len(failed)} {noun} failed: " + "; ".join(failed), file=sys.stderr)
            return EXIT_CHECK_FAILED
    return EXIT_OK


def default_report_path(scenario: Any) -> Path:
    """Default output of ``trainctl report``: ``reports/<stem>.html``.

    The stem is the built-in name for a built-in scenario (``crh2-dmpc``) and
    the slug of the scenario's display name otherwise; both are ``[a-z0-9-]``.

    Parameters
    ----------
    scenario : trainctl.scenario.Scenario
        The loaded scenario.

    Returns
    -------
    pathlib.Path
        Relative path under ``reports/``.
    """
    from .scenario import slugify

    source = str(getattr(scenario, "source", ""))
    if source.startswith("builtin:"):
        stem = slugify(source.removeprefix("builtin:"))
    else:
        stem = scenario.slug
    return Path("reports") / f"{stem}.html"


def _cmd_report(args: argparse.Namespace) -> int:
    from .report import build_summary_context, render_summary_report, write_report

    scenario, summary = _summary_of(args.scenario)
    path = Path(args.output) if args.output else default_report_path(scenario)
    html = render_summary_report(build_summary_context(scenario, summary))
    written = write_report(html, path)
    print(f"wrote {written}")
    return EXIT_OK
