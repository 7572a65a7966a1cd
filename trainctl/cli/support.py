# Pieces of the trainctl command shared by analyse and report: budgets, outputs, clean JSON.
"""Helpers of :mod:`trainctl.cli.main`: the run budget, output targets and deterministic JSON.

:func:`add_budget_option` adds ``--max-time``; :func:`check_cost` estimates the
run (:mod:`trainctl.run.budget`), refuses one over the budget or the machine's
memory and prints the estimate of a long one on stderr before anything
runs. :func:`~trainctl.run.wall_clock.without_wall_clock` (re-exported) drops the fields
that differ between two runs of the same scenario (solve and stage times).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from trainctl.exceptions import TrainctlError
from trainctl.naming import printable
from trainctl.run.budget import DEFAULT_MAX_TIME, format_duration, parse_duration
from trainctl.run.wall_clock import WALL_CLOCK_KEYS as WALL_CLOCK_KEYS
from trainctl.run.wall_clock import without_wall_clock as without_wall_clock

if TYPE_CHECKING:
    from trainctl.scenario import Scenario

__all__ = ["WALL_CLOCK_KEYS", "add_budget_option", "check_cost", "describe_error", "positive_int",
           "printable_stdout", "without_wall_clock"]

PROG = "trainctl"
"""The command's name (in its messages)."""

EXIT_OK = 0
EXIT_CHECK_FAILED = 1
EXIT_ERROR = 2
EXIT_INTERRUPTED = 130
"""Ctrl-C (SIGINT); SIGTERM exits 143, SIGHUP 129 (128 + the signal,
:func:`~trainctl.run._signals.exit_status`)."""

_R = TypeVar("_R")


class _PrintableStream:
    """A text stream whose written text has its control characters escaped."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        self._stream.write(printable(text))
        return len(text)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def printable_stdout(func: Callable[..., _R]) -> Callable[..., _R]:
    """``func`` with ``sys.stdout`` escaping control characters while it runs.

    Names, file names and values a command prints come from the user; a NUL,
    a terminal escape sequence or a bidirectional override among them is
    written as ``\\uXXXX`` (:func:`trainctl.naming.printable`), never sent to
    the terminal as a command.

    Parameters
    ----------
    func : callable
        A command function.

    Returns
    -------
    callable
        ``func`` with the same arguments and result.

    Examples
    --------
    >>> import contextlib, io
    >>> out = io.StringIO()
    >>> with contextlib.redirect_stdout(out):
    ...     printable_stdout(print)("red \\x1b[31m")
    >>> out.getvalue()
    'red \\\\u001b[31m\\n'
    """
    def run(*args: Any, **kwargs: Any) -> _R:
        original = sys.stdout
        sys.stdout = _PrintableStream(original)
        try:
            return func(*args, **kwargs)
        finally:
            sys.stdout = original

    return run


def _duration(text: str) -> float:
    try:
        return parse_duration(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be a positive duration such as 600, 90s, 30min, 2h, 1d or 'inf' (got {text!r})"
        ) from None


def add_budget_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--max-time DURATION`` (default :data:`~trainctl.run.budget.DEFAULT_MAX_TIME`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        A subcommand's parser.

    Examples
    --------
    >>> parser = argparse.ArgumentParser()
    >>> add_budget_option(parser)
    >>> parser.parse_args(["--max-time", "30min"]).max_time
    1800.0
    """
    parser.add_argument(
        "--max-time", metavar="DURATION", type=_duration, default=DEFAULT_MAX_TIME,
        help="time budget: refuse a run estimated to take longer, and stop one that does "
        f"(seconds, or 90s, 30min, 2h, 1d; 'inf' for none; default "
        f"{format_duration(DEFAULT_MAX_TIME)})",
    )


def check_cost(scenarios: Sequence[Scenario], max_time: float, *, simulate: bool = True) -> None:
    """Estimate running ``scenarios``; refuse it over budget, announce it when long.

    Parameters
    ----------
    scenarios : sequence of Scenario
        What the command will run, one after the other.
    max_time : float
        The time budget [s].
    simulate : bool
        Whether the ``[simulation]`` strategies run.

    Raises
    ------
    trainctl.run.budget.BudgetError
        When the estimate exceeds the budget or the machine's memory.

    Examples
    --------
    The CRH2 design review is far inside an hour (and prints nothing):

    >>> from trainctl.scenario import load_scenario
    >>> check_cost([load_scenario("crh2-dmpc")], 3600.0, simulate=False)
    """
    from trainctl.run.budget import PRINT_ESTIMATE_FROM, check_budget, estimate_run, total_estimate

    estimate = total_estimate(estimate_run(s, simulate=simulate) for s in scenarios)
    check_budget(estimate, max_time)
    if estimate.seconds >= PRINT_ESTIMATE_FROM:
        budget = "no time budget" if math.isinf(max_time) else (
            f"time budget {format_duration(max_time)}, --max-time")
        print(f"trainctl: estimate: {estimate.describe()} ({budget})", file=sys.stderr,
              flush=True)


def positive_int(text: str) -> int:
    """An argparse type: a whole number >= 1.

    Parameters
    ----------
    text : str
        The option's value as given.

    Returns
    -------
    int
        The number.

    Examples
    --------
    >>> positive_int("4")
    4
    """
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1 (got {text!r})") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1 (got {text!r})")
    return value


def describe_error(exc: BaseException) -> str:
    """The message of an error the command reports (an OSError with its file).

    Parameters
    ----------
    exc : BaseException
        The error.

    Returns
    -------
    str
        Its message; an ``OSError``'s names the file.

    Examples
    --------
    >>> describe_error(FileNotFoundError(2, "No such file or directory", "a.toml"))
    'No such file or directory: a.toml'
    """
    if isinstance(exc, OSError) and not isinstance(exc, TrainctlError):
        if exc.filename is not None and exc.strerror:
            return f"{exc.strerror}: {os.fsdecode(exc.filename)}"
    message = str(exc)
    return message or type(exc).__name__


def _by_signal(exc: BaseException) -> str:
    """`` (SIGTERM)`` for a stop signal other than Ctrl-C, else nothing."""
    import signal

    signum = getattr(exc, "signum", None)
    return "" if signum is None else f" ({signal.Signals(signum).name})"
