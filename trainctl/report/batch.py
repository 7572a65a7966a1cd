# Report jobs end to end: where reports go, how long they take, one scenario or every built-in.
"""Write reports of one scenario, a saved run, or every built-in, with a progress bar.

The policies behind ``trainctl report`` live here, so that the command only
parses and dispatches: default output paths (:func:`default_report_path`),
progress totals (:func:`progress_total`) and the one-line summaries printed
at the end (:func:`summary_line`).
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from trainctl._files import read_regular
from trainctl.report.build import ReportJob, run_report_data, write_gallery, write_report_file
from trainctl.report.data import ReportData
from trainctl.report.output import OutputError as OutputError
from trainctl.report.output import OutputTarget, output_target

if TYPE_CHECKING:
    from trainctl.scenario import Scenario

__all__ = [
    "OutputError",
    "check_gallery_output",
    "check_report_output",
    "render_saved_run",
    "default_report_path",
    "progress_total",
    "report_all",
    "report_scenario",
    "summary_line",
]


def default_report_path(scenario: Scenario) -> Path:
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

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> default_report_path(load_scenario("crh2-dmpc")).as_posix()
    'reports/crh2-dmpc.html'
    """
    from trainctl.scenario import slugify

    source = str(getattr(scenario, "source", ""))
    if source.startswith("builtin:"):
        stem = slugify(source.removeprefix("builtin:"))
    else:
        stem = scenario.slug
    return Path("reports") / f"{stem}.html"


def check_report_output(path: str | Path | OutputTarget, *,
                        default_name: str | None = None) -> OutputTarget:
    """Classify a report's output before the run (a refusal costs no work).

    Parameters
    ----------
    path : str, pathlib.Path or OutputTarget
        The ``-o`` value: a file, ``dir/``, a device, a pipe or ``-``.
    default_name : str or None
        The file name used inside a directory (e.g. ``crh2-dmpc.html``);
        None refuses directories.

    Returns
    -------
    OutputTarget
        Where the page goes.

    Raises
    ------
    OutputError
        For a path that cannot take the page (see
        :func:`~trainctl.report.output.output_target`).

    Examples
    --------
    A directory takes the report's default name; without one it is refused
    before anything runs:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     target = check_report_output(tmp + "/", default_name="crh2-dmpc.html")
    ...     try:
    ...         check_report_output(tmp)
    ...     except OutputError as error:
    ...         refused = type(error).__name__
    >>> target.path.name, target.kind, refused
    ('crh2-dmpc.html', 'file', 'OutputError')
    """
    return output_target(path, default_name=default_name)


GENERATOR_MARK = b'<meta name="generator" content="trainctl">'
"""The mark every page trainctl writes carries in its head (``_layout.html.j2``)."""

_MARK_WINDOW = 4096
"""Bytes read from an existing page to find :data:`GENERATOR_MARK` (it is on line 7)."""


def _written_by_trainctl(path: Path) -> bool:
    """True for a regular file whose first KiB carry :data:`GENERATOR_MARK` (never blocks)."""
    try:
        head = read_regular(path, limit=_MARK_WINDOW)
    except OSError:
        return False
    return GENERATOR_MARK in head[:_MARK_WINDOW]


def _gallery_refusals(outdir: Path, names: Sequence[str]) -> list[str]:
    """``"name: why"`` for each page name whose existing entry the gallery may not replace."""
    refused = []
    for name in names:
        path = outdir / name
        if not os.path.lexists(path):
            continue
        try:
            target = output_target(path)
        except OutputError as exc:  # a broken link, another user's file, a directory, ...
            why = str(exc).removeprefix(f"{path}: ")
            refused.append(f"{name}: {why}")
            continue
        if target.kind != "file":
            refused.append(f"{name}: is not a regular file (the gallery writes only files)")
        elif not _written_by_trainctl(target.path):
            refused.append(f"{name}: is not a page trainctl wrote (no <meta name=\"generator\" "
                           "content=\"trainctl\"> in its head)")
    return refused


def _remove_stale_temporaries(outdir: Path, names: Sequence[str]) -> None:
    """Remove the temporary files a killed gallery left (``.NAME.<hex>.tmp``, empty or ours)."""
    try:
        entries = list(os.scandir(outdir))
    except OSError:
        return
    pattern = re.compile("|".join(rf"\.{re.escape(n)}\.[0-9a-f]{{12}}\.tmp" for n in names))
    for entry in entries:
        if not pattern.fullmatch(entry.name) or not entry.is_file(follow_symlinks=False):
            continue
        path = Path(entry.path)
        try:
            empty = entry.stat(follow_symlinks=False).st_size == 0
            if empty or _written_by_trainctl(path):
                path.unlink()
        except OSError:
            pass


def check_gallery_output(outdir: str | os.PathLike[str], names: Sequence[str]) -> Path:
    """Check, before anything runs, that the gallery may write its pages into ``outdir``.

    ``outdir`` may be missing or empty, or hold an earlier gallery: an
    existing entry of a name the gallery writes is replaced only if it is a
    regular file that carries :data:`GENERATOR_MARK` in its first 4 KiB
    (a page trainctl wrote). A symbolic link follows the output rules of
    :func:`~trainctl.report.output.output_target` (its regular file is
    replaced, the link kept; a broken link or another user's file is
    refused). Files of other names are left alone. Temporary files a killed
    gallery left beside its pages are removed.

    Parameters
    ----------
    outdir : str or os.PathLike
        The ``-o`` directory of ``report --all``.
    names : sequence of str
        The file names the gallery writes (its pages and ``index.html``).

    Returns
    -------
    pathlib.Path
        ``outdir``.

    Raises
    ------
    OutputError
        If ``outdir`` is not a directory, or holds an entry of one of
        ``names`` that trainctl did not write (all such entries are named;
        nothing is written or removed).

    Examples
    --------
    A user's own ``index.html`` is refused; a page trainctl wrote is not:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     _ = (Path(tmp) / "index.html").write_text("<p>my notes</p>")
    ...     try:
    ...         check_gallery_output(tmp, ["index.html"])
    ...     except OutputError as error:
    ...         print(str(error).splitlines()[1].split(" (")[0])
    ...     mark = '<meta name="generator" content="trainctl">'
    ...     _ = (Path(tmp) / "index.html").write_text(mark)
    ...     check_gallery_output(tmp, ["index.html"]) == Path(tmp)
      index.html: is not a page trainctl wrote
    True
    """
    directory = Path(outdir)
    if os.path.lexists(directory) and not directory.exists():
        raise OutputError(f"{directory}: is a broken symbolic link; with --all, -o names the "
                          "output directory")
    if directory.exists() and not directory.is_dir():
        raise OutputError(f"{directory}: is not a directory; with --all, -o names the output "
                          "directory")
    if not directory.exists():
        return directory
    refused = _gallery_refusals(directory, names)
    if refused:
        lines = "\n".join(f"  {line}" for line in refused)
        raise OutputError(f"{directory}: holds files the gallery would replace but trainctl did "
                          f"not write:\n{lines}\nNothing was written. Give another directory "
                          f"with -o, or move those files out of {directory}.")
    _remove_stale_temporaries(directory, names)
    return directory


def render_saved_run(data: ReportData, source: str, target: Path | OutputTarget, *,
                     generated_at: str | None = None, deterministic: bool = False) -> Path:
    """Write the report of a loaded saved run; data the page cannot use is a ScenarioError.

    :meth:`ReportData.load` validates what the report reads; a controller
    family's own report data is checked only by rendering it. A saved run
    whose data still does not render was edited or damaged (a fresh run of
    the same code renders), so the failure names the directory instead of
    showing a traceback.

    Parameters
    ----------
    data : ReportData
        From :meth:`ReportData.load`.
    source : str
        The saved run's directory, for the message.
    target : pathlib.Path or OutputTarget
        Where the page goes.
    generated_at, deterministic
        As for :func:`~trainctl.report.write_report_file`.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ScenarioError
        If the page cannot be built from the saved data.

    Examples
    --------
    Data whose results lost a key, as from an edited saved run, is named
    as such rather than shown as a traceback:

    >>> import dataclasses
    >>> import tempfile
    >>> import trainctl
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> from trainctl.report import collect_report_data
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> damaged = dataclasses.replace(data, results={})
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     try:
    ...         render_saved_run(damaged, "saved-run", Path(tmp) / "r.html")
    ...     except trainctl.ScenarioError as error:
    ...         print(str(error).split(". ")[0])
    saved-run: the saved run's data does not fit the report (key 'equilibrium' is missing)
    """
    from trainctl.exceptions import ScenarioError
    from trainctl.report.runfile import RUN_HINT

    try:
        return write_report_file(data, target, generated_at=generated_at,
                                 deterministic=deterministic)
    except (KeyError, IndexError, TypeError, AttributeError, ValueError, ArithmeticError) as exc:
        if isinstance(exc, ScenarioError):
            raise
        what = f"key {exc.args[0]!r} is missing" if isinstance(exc, KeyError) else str(exc)
        raise ScenarioError(f"{source}: the saved run's data does not fit the report ({what})."
                            f"{RUN_HINT}") from None


def progress_total(jobs: Sequence[ReportJob]) -> int:
    """Steps of the progress bar: one per simulation, per analysis and per page, plus the index.

    Parameters
    ----------
    jobs : sequence of ReportJob
        The scenarios to report on.

    Returns
    -------
    int
        ``simulations + 2·jobs`` (plus 1 for the gallery when there are several).

    Examples
    --------
    One strategy: 1 simulation + 2 = 3 steps; the same job twice:
    2 + 4 + 1 (the gallery) = 7:

    >>> from trainctl.report import ReportJob
    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> scenario = (parse_scenario(text, source=label)
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0)
    ...             .replace("simulation.strategies", ["decentralised"]))
    >>> job = ReportJob(scenario, text, "trainctl report crh2-dmpc")
    >>> progress_total([job]), progress_total([job, job])
    (3, 7)
    """
    sims = sum(len(j.scenario.simulation.strategies) if j.scenario.simulation else 0
               for j in jobs)
    return sims + 2 * len(jobs) + (1 if len(jobs) > 1 else 0)


def summary_line(data: ReportData) -> str:
    """The check counts and simulations of a report, for the last line the command prints.

    Parameters
    ----------
    data : ReportData
        A report's data.

    Returns
    -------
    str
        ``"12 checks: 7 pass, 3 warn, 2 fail; 3 controllers simulated"``.

    Examples
    --------
    >>> import trainctl
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> from trainctl.report import collect_report_data
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> summary_line(data)
    '19 checks: 13 pass, 3 warn, 3 fail'
    """
    checks = data.results.get("checks", [])
    counts = {s: sum(1 for c in checks if c["status"] == s) for s in ("pass", "warn", "fail")}
    text = f"{len(checks)} checks: " + ", ".join(f"{v} {k}" for k, v in counts.items())
    if data.simulations:
        text += f"; {len(data.simulations)} controllers simulated"
    return text


def report_scenario(job: ReportJob, path: Path | OutputTarget, *, workers: int = 0,
                    generated_at: str | None = None, deterministic: bool = False) -> ReportData:
    """Run one scenario and write its report, with a progress bar on a terminal.

    Parameters
    ----------
    job : ReportJob
        The scenario.
    path : pathlib.Path or OutputTarget
        Output file, device, pipe or standard output.
    workers : int
        Process-pool size for the simulations (0: run them here).
    generated_at, deterministic
        As for :func:`~trainctl.report.write_report_file`.

    Returns
    -------
    ReportData
        The data that was rendered.

    Examples
    --------
    The CRH2 scenario cut to 120 s with one strategy, run and reported:

    >>> import tempfile
    >>> from trainctl.report import ReportJob
    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> scenario = (parse_scenario(text, source=label)
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0)
    ...             .replace("simulation.strategies", ["decentralised"]))
    >>> job = ReportJob(scenario, text, "trainctl report crh2-dmpc")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     data = report_scenario(job, Path(tmp) / "crh2.html", deterministic=True)
    ...     written = sorted(p.name for p in Path(tmp).iterdir())
    >>> written, summary_line(data)
    (['crh2.html'], '19 checks: 13 pass, 3 warn, 3 fail; 1 controllers simulated')
    """
    from trainctl.run._progress import Progress

    target = check_report_output(path, default_name=default_report_path(job.scenario).name)
    with Progress(progress_total([job])) as bar:
        [data] = list(run_report_data([job], workers=workers, progress=bar))
        bar.set_label("rendering figures and page")
        write_report_file(data, target, generated_at=generated_at, deterministic=deterministic)
        bar.advance("written")
    return data


def report_all(jobs: Sequence[ReportJob], outdir: Path, *, workers: int = 0,
               generated_at: str | None = None,
               deterministic: bool = False) -> tuple[Path, list[tuple[ReportData, Path]]]:
    """Write every job's report into ``outdir`` and an ``index.html`` gallery.

    Parameters
    ----------
    jobs : sequence of ReportJob
        The scenarios (a report each, named as :func:`default_report_path`).
    outdir : pathlib.Path
        Output directory (created).
    workers : int
        Process-pool size for the simulations.
    generated_at, deterministic
        As for :func:`~trainctl.report.write_report_file`.

    Returns
    -------
    index : pathlib.Path
        The gallery.
    written : list of (ReportData, pathlib.Path)
        Each report's data and file.

    Raises
    ------
    OutputError
        Before any scenario runs, if ``outdir`` is not a directory or holds
        a file of a name the gallery writes that trainctl did not write
        (:func:`check_gallery_output`); if such a file appears while the
        scenarios run, when its page is due (the pages written so far stay).

    Examples
    --------
    An existing file as the output directory is refused before any
    scenario runs:

    >>> import tempfile
    >>> from trainctl.report import ReportJob
    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> scenario = (parse_scenario(text, source=label)
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0)
    ...             .replace("simulation.strategies", ["decentralised"]))
    >>> job = ReportJob(scenario, text, "trainctl report crh2-dmpc")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     taken = Path(tmp) / "reports"
    ...     _ = taken.write_text("not a directory")
    ...     try:
    ...         report_all([job], taken)
    ...     except OutputError as error:
    ...         print(str(error).split(": ")[1])
    is not a directory; with --all, -o names the output directory
    """
    from trainctl.run._progress import Progress

    names = [default_report_path(job.scenario).name for job in jobs] + ["index.html"]
    check_gallery_output(outdir, names)
    written: list[tuple[ReportData, Path]] = []
    # closing(): an interrupt while a report renders (outside the generator) closes the
    # generator, and with it its worker pool, at once and explicitly, not whenever the
    # last reference to it goes (a traceback or debugger holding one would keep the pool,
    # whose exit handler waits for every queued simulation).
    with Progress(progress_total(jobs)) as bar, contextlib.closing(
            run_report_data(jobs, workers=workers, progress=bar)) as results:
        for job, data in zip(jobs, results, strict=True):
            path = outdir / default_report_path(job.scenario).name
            _still_ours(outdir, path.name, written)
            bar.set_label(f"rendering {path.name}")
            write_report_file(data, path, generated_at=generated_at,
                              deterministic=deterministic)
            written.append((data, path))  # the page's name in outdir, even through a link
            bar.advance(f"wrote {path.name}")
        _still_ours(outdir, "index.html", written)
        index = write_gallery(written, outdir / "index.html", generated_at=generated_at,
                              deterministic=deterministic)
        bar.advance("wrote index.html")
    return index, written


def _still_ours(outdir: Path, name: str, written: Sequence[tuple[ReportData, Path]]) -> None:
    """Check one page again just before it is written: a file may appear during the runs."""
    refused = _gallery_refusals(outdir, [name])
    if refused:
        done = (f"the {len(written)} pages written before it stay" if written
                else "nothing was written")
        raise OutputError(f"{outdir}: {refused[0]}; it appeared while the scenarios ran and is "
                          f"left alone ({done}). Give another directory with -o, or move it.")
