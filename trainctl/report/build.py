# From scenario names to report files: run (in parallel when it pays), collect, render, write.
"""The ``trainctl report`` pipeline.

:func:`run_report_data` runs scenarios (analysis here, simulations on a
process pool when they are long, see :func:`trainctl.run.pool.want_pool`)
and yields one :class:`~trainctl.report.ReportData` per scenario, in order.
:func:`write_report_file` renders one and writes it atomically;
:func:`write_gallery` writes the ``index.html`` of several.
"""

from __future__ import annotations

import datetime
import os
import time
from collections.abc import Callable, Generator, Sequence
from concurrent.futures import Future
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from trainctl.exceptions import TrainctlError
from trainctl.report.context import build_index_context, build_report_context, headline
from trainctl.report.data import ReportData, collect_report_data
from trainctl.report.render import render_index, render_report, write_report

if TYPE_CHECKING:
    from trainctl.design import Design
    from trainctl.report.output import OutputTarget
    from trainctl.run._progress import Progress
    from trainctl.scenario import Scenario
    from trainctl.sim.results import SimulationResult

__all__ = [
    "ReportJob",
    "TimestampError",
    "normalise_timestamp",
    "portable_command",
    "run_report_data",
    "write_gallery",
    "write_report_file",
]


class TimestampError(TrainctlError, ValueError):
    """An injected report timestamp that cannot be read.

    Examples
    --------
    >>> try:
    ...     normalise_timestamp("yesterday")
    ... except TimestampError as error:
    ...     print(str(error).split(" is ")[0])
    timestamp 'yesterday'
    """


@dataclass(frozen=True)
class ReportJob:
    """One scenario to report on.

    Parameters
    ----------
    scenario : Scenario
        The parsed scenario.
    text : str
        Its TOML text.
    command : str
        The command line to print in the report (machine-specific paths removed).

    Examples
    --------
    The CRH2 scenario cut to 120 s with one strategy (a light job):

    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> scenario = (parse_scenario(text, source=label)
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0)
    ...             .replace("simulation.strategies", ["decentralised"]))
    >>> job = ReportJob(scenario, text, "trainctl report crh2-dmpc")
    >>> job.scenario.simulation.strategies, job.command
    (('decentralised',), 'trainctl report crh2-dmpc')
    """

    scenario: Scenario
    text: str
    command: str


def portable_command(argv: Sequence[str], *, prog: str = "trainctl") -> str:
    """A command line without machine-specific paths.

    The program is called by its name; an absolute path argument (or
    ``--option=/abs/path``) is reduced to its last component. Relative paths
    and everything else stay as given.

    Parameters
    ----------
    argv : sequence of str
        Arguments after the program name.
    prog : str
        Program name.

    Returns
    -------
    str
        The command, arguments quoted where needed.

    Examples
    --------
    >>> portable_command(["report", "/home/ana/thesis/my scenario.toml", "-o", "out/r.html"])
    "trainctl report 'my scenario.toml' -o out/r.html"
    """
    import shlex

    parts = [prog]
    for arg in argv:
        head, sep, tail = arg.partition("=")
        if sep and arg.startswith("--") and os.path.isabs(tail):
            arg = f"{head}={Path(tail).name}"
        elif os.path.isabs(arg):
            arg = Path(arg).name
        parts.append(arg)
    return shlex.join(parts)


def normalise_timestamp(value: str) -> str:
    """An ISO 8601 time (or a Unix epoch in seconds) as ``YYYY-MM-DDTHH:MM:SSZ`` UTC.

    Parameters
    ----------
    value : str
        ``2026-11-22T10:00:00Z``, ``2026-11-22 10:00+01:00``, ``2026-11-22``
        (midnight UTC) or ``1795000000``; a time without a zone is UTC.

    Returns
    -------
    str
        The normalised UTC time.

    Raises
    ------
    TimestampError
        When ``value`` is neither.

    Examples
    --------
    >>> normalise_timestamp("2026-11-22 10:00+01:00"), normalise_timestamp("0")
    ('2026-11-22T09:00:00Z', '1970-01-01T00:00:00Z')
    """
    text = value.strip()
    try:
        if text.isdigit():
            moment = datetime.datetime.fromtimestamp(int(text), datetime.UTC)
        else:
            moment = datetime.datetime.fromisoformat(text.replace("Z", "+00:00"))
    except (ValueError, OverflowError, OSError):
        raise TimestampError(
            f"timestamp {value!r} is neither an ISO 8601 time nor a Unix time in seconds; "
            "give e.g. 2026-11-22T10:00:00Z or 1795000000.") from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=datetime.UTC)
    moment = moment.astimezone(datetime.UTC)
    return moment.isoformat(timespec="seconds").replace("+00:00", "Z")


# --------------------------------------------------------------------------- running


def run_report_data(
    jobs: Sequence[ReportJob],
    *,
    workers: int = 0,
    progress: Progress | None = None,
) -> Generator[ReportData, None, None]:
    """Run each job's analysis and simulations; yield its report data, in order.

    Parameters
    ----------
    jobs : sequence of ReportJob
        The scenarios.
    workers : int
        Process-pool size for the simulations (0: run them here). All
        simulations of all jobs are submitted up front, longest first, so
        that later scenarios simulate while earlier ones are analysed.
    progress : Progress or None
        Advanced once per analysis and per simulation.

    Yields
    ------
    ReportData
        With stage timings.

    Examples
    --------
    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> scenario = (parse_scenario(text, source=label)
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0)
    ...             .replace("simulation.strategies", ["decentralised"]))
    >>> job = ReportJob(scenario, text, "trainctl report crh2-dmpc")
    >>> [data] = list(run_report_data([job]))
    >>> list(data.simulations), sorted(data.timings)
    (['decentralised'], ['analysis and simulations', 'report data'])
    >>> data.simulations["decentralised"].time[-1]  # s
    np.float64(120.0)
    """
    from trainctl.design import build_design
    from trainctl.run.pool import worker_pool

    designs = [build_design(job.scenario) for job in jobs]
    with worker_pool(workers) as pool:
        pending: dict[int, dict[str, Future[SimulationResult]]] = {}
        extra: dict[int, dict[tuple[str, int], Future[Any]]] = {}
        if pool is not None:
            tasks = [(k, strategy) for k, job in enumerate(jobs) if job.scenario.simulation
                     for strategy in job.scenario.simulation.strategies]
            from trainctl.run.budget import strategy_seconds

            tasks.sort(key=lambda t: -strategy_seconds(jobs[t[0]].scenario, t[1]))
            from trainctl.run.simulate import _simulate_recorded

            for k, strategy in tasks:
                future = pool.submit(_simulate_recorded, jobs[k].scenario, strategy, designs[k])
                if progress is not None:
                    future.add_done_callback(_advance(progress, f"simulated {strategy}"))
                pending.setdefault(k, {})[strategy] = future
            from trainctl.run.repetitions import submit_repetitions

            for k, job in enumerate(jobs):
                extra[k] = submit_repetitions(job.scenario, pool, designs[k])
        for k, job in enumerate(jobs):
            yield _run_one(job, designs[k], pending.get(k), progress, extra.get(k))


def _advance(progress: Progress, label: str) -> Callable[[Future[Any]], None]:
    def callback(_: Future[Any]) -> None:
        progress.advance(label)
    return callback


def _run_one(job: ReportJob, design: Design,
             pending: dict[str, Future[SimulationResult]] | None,
             progress: Progress | None,
             repetitions: dict[tuple[str, int], Future[Any]] | None = None) -> ReportData:
    from trainctl.run.analysis import run_scenario

    name = job.scenario.name
    if progress is not None:
        progress.set_label(f"analysing {name}")
    start = time.perf_counter()

    def simulated(strategy: str) -> None:
        if progress is not None:
            progress.advance(f"simulated {strategy} ({name})")

    run = run_scenario(job.scenario, pending=pending, design=design,
                       on_simulated=simulated if pending is None else None,
                       pending_repetitions=repetitions)
    middle = time.perf_counter()
    if progress is not None:
        progress.set_label(f"collecting {name}")
    data = collect_report_data(run, scenario_text=job.text, command=job.command)
    end = time.perf_counter()
    timings = {"analysis and simulations": middle - start, "report data": end - middle}
    if progress is not None:
        progress.advance(f"analysed {name}")
    return _with_timings(data, timings)


def _with_timings(data: ReportData, timings: dict[str, float]) -> ReportData:
    import dataclasses

    return dataclasses.replace(data, timings={**data.timings, **timings})


# --------------------------------------------------------------------------- writing


def write_report_file(
    data: ReportData,
    path: str | os.PathLike[str] | OutputTarget,
    *,
    generated_at: str | None = None,
    deterministic: bool = False,
) -> Path:
    """Render ``data`` and write the page atomically to ``path``.

    Parameters
    ----------
    data : ReportData
        The report's data.
    path : str, os.PathLike or OutputTarget
        Output file (parents created), written to a temporary file and
        renamed into place: an interrupted render leaves the previous file.
        A device, a pipe or standard output is written through
        (:func:`~trainctl.report.output.write_output`).
    generated_at : str or None
        Timestamp (see :func:`trainctl.report.build_report_context`).
    deterministic : bool
        Leave out wall-clock values.

    Returns
    -------
    pathlib.Path
        The written file.

    Examples
    --------
    The page of the CRH2 design review (no simulation), without wall-clock
    values; the page names its scenario:

    >>> import tempfile
    >>> import trainctl
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     page = write_report_file(data, Path(tmp) / "crh2.html", deterministic=True)
    ...     html = page.read_text(encoding="utf-8")
    >>> page.name, html.startswith("<!DOCTYPE html>"), "CRH2 half train" in html
    ('crh2.html', True, True)
    """
    start = time.perf_counter()
    context = build_report_context(data, generated_at=generated_at, deterministic=deterministic)
    if not deterministic:
        # The render's own time is known only now; put it in the footer table.
        seconds = time.perf_counter() - start
        context["footer"]["timings"].append({"stage": "Figures and page",
                                             "seconds": f"{seconds:.3g}"})
    return write_report(render_report(context), path)


def write_gallery(
    entries: Sequence[tuple[ReportData, Path]],
    path: str | os.PathLike[str],
    *,
    generated_at: str | None = None,
    deterministic: bool = False,
) -> Path:
    """Write the ``index.html`` that links several reports.

    Parameters
    ----------
    entries : sequence of (ReportData, Path)
        Each report's data and its file.
    path : str or os.PathLike
        The gallery file; links are relative to its directory.
    generated_at, deterministic
        As for :func:`write_report_file`.

    Returns
    -------
    pathlib.Path
        The written file.

    Examples
    --------
    A gallery linking one report in a subdirectory (the report itself need
    not exist for the link):

    >>> import tempfile
    >>> import trainctl
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     index = write_gallery([(data, Path(tmp) / "reports" / "crh2-dmpc.html")],
    ...                           Path(tmp) / "index.html", deterministic=True)
    ...     html = index.read_text(encoding="utf-8")
    >>> index.name, 'href="reports/crh2-dmpc.html"' in html
    ('index.html', True)
    """
    target = Path(path)
    rows = []
    for data, report in entries:
        # abspath, not resolve: a page that is a symbolic link is linked by its own name
        href = os.path.relpath(os.path.abspath(report), os.path.abspath(target.parent))
        rows.append({"name": data.scenario.name, "href": Path(href).as_posix(),
                     "description": data.scenario.description, "headline": headline(data),
                     "source": data.scenario.source})
    versions: list[dict[str, str]] = []
    if entries:
        env = entries[0][0].environment
        versions = [{"name": k, "version": v or "not installed"}
                    for k, v in env.get("versions", {}).items()]
    context = build_index_context(rows, generated_at=generated_at, deterministic=deterministic,
                                  versions=versions)
    return write_report(render_index(context), target)
