# The saved-results directory: what may be written over, and an atomic, signal-safe move.
"""The directory ``trainctl analyse --save DIR`` writes (:meth:`~trainctl.report.ReportData.save`).

A save never deletes what it did not write (:func:`check_save_target`): DIR
is new, empty, or an earlier save holding nothing else; a re-save stages its
files in a hidden ``DIR/.trainctl-save-<hex>.tmp`` and renames them over the
earlier save's, the manifest last. :func:`is_saved_run` tells such a
directory from a scenario path.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import secrets
import shutil
import signal
import stat
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from trainctl._files import node_kind, read_regular_text
from trainctl.exceptions import ScenarioError
from trainctl.report.runfile import FORMAT as FORMAT
from trainctl.report.runfile import MANIFEST as MANIFEST

if TYPE_CHECKING:
    pass

__all__ = ["check_save_target", "is_saved_run"]


def check_save_target(path: str | os.PathLike[str]) -> None:
    """Refuse a directory that :meth:`ReportData.save` must not write into (checked before a run).

    Accepted: a path that does not exist yet, an empty directory, or a
    directory holding a previous save and nothing else: the files a save
    writes (:data:`MANIFEST`, ``scenario.toml``, ``simulations/<strategy>/``
    with ``result.json`` and ``arrays.npz``, the strategies its manifest
    lists), whose manifest is trainctl's (a JSON object of format
    :data:`FORMAT`'s family). Anything else in it (a user's file, a
    symbolic link, an unlisted strategy, a fake manifest) is named and
    refused. A symbolic link to a directory is followed and its target
    judged by the same rule.

    Parameters
    ----------
    path : str or os.PathLike
        The intended saved-results directory.

    Raises
    ------
    ScenarioError
        If ``path`` is a file or a broken symbolic link, or a directory
        holding entries a save did not write (the message names them).

    Examples
    --------
    A new or empty directory is accepted; one holding other files is not:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     check_save_target(tmp)  # empty: nothing raised
    ...     _ = (Path(tmp) / "notes.txt").write_text("mine")
    ...     try:
    ...         check_save_target(tmp)
    ...     except ScenarioError as error:
    ...         print(type(error).__name__, "notes.txt" in str(error))
    ScenarioError True
    """
    _save_directory(Path(path))


def is_saved_run(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a directory holding :data:`MANIFEST`.

    Parameters
    ----------
    path : str or os.PathLike
        A path given to ``trainctl report``.

    Returns
    -------
    bool
        Whether it is a saved run.

    Examples
    --------
    >>> import tempfile
    >>> import trainctl
    >>> from trainctl.report import collect_report_data
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     saved = data.save(Path(tmp) / "run")
    ...     print(is_saved_run(tmp), is_saved_run(saved))
    False True
    """
    return (Path(path) / MANIFEST).is_file()


# --------------------------------------------------------------------------- the save directory

_STAGING_PREFIX = ".trainctl-save-"
"""Prefix of the hidden entries a save stages in (``.trainctl-save-<hex>.tmp`` / ``.old``)."""

_STAGING = re.compile(r"\.trainctl-save-[0-9a-f]{12}\.(?:tmp|old)")

_TOP_FILES = (MANIFEST, "scenario.toml")
"""The regular files a save writes at the top of its directory."""

_SIMULATIONS = "simulations"
"""The directory of the simulation results (``simulations/<strategy>/``)."""

_RESULT_FILES = frozenset({"arrays.npz", "result.json"})
"""What :meth:`SimulationResult.save` writes into a strategy's directory."""

_MAX_MANIFEST_BYTES = 256 * 2**20
"""A manifest larger than this is not one trainctl wrote (so not replaced)."""

_SHOWN = 5
"""Foreign entries named in a refusal (the rest are counted)."""


def _save_directory(given: Path) -> Path:
    """The directory a save writes (a link followed), refused when it is not a save's."""
    if os.path.islink(given) and not os.path.exists(given):
        raise ScenarioError(f"{given}: is a broken symbolic link; give a new directory for the "
                            "saved results, or make the link point to one.")
    target = Path(os.path.realpath(given)) if os.path.lexists(given) else Path(
        os.path.abspath(given))
    if os.path.exists(target) and not os.path.isdir(target):
        raise ScenarioError(f"{given}: exists and is not a directory; give a directory for "
                            "the saved results.")
    _refuse_foreign(given, target)
    return target


def _refuse_foreign(given: Path, target: Path) -> None:
    if not os.path.isdir(target):
        return
    foreign = _foreign_entries(target)
    if foreign:
        shown = ", ".join(foreign[:_SHOWN])
        if len(foreign) > _SHOWN:
            shown += f" and {len(foreign) - _SHOWN} more"
        linked = os.path.abspath(given) != os.fspath(target)
        where = f" (resolved: {target})" if linked else ""
        raise ScenarioError(
            f"{given}{where}: holds what a trainctl save does not write: {shown}; refusing to "
            "overwrite the directory (nothing was changed). A save goes into a new or empty "
            f"directory, or replaces an earlier save ({MANIFEST}, scenario.toml, "
            "simulations/) holding nothing else: give another directory, or move those "
            "entries away.")


def _foreign_entries(directory: Path) -> list[str]:
    """Entries of ``directory`` that a save did not write, each named (empty: a save's own)."""
    names = sorted(n for n in os.listdir(directory) if not _is_staging(directory / n))
    if not names:
        return []
    strategies, why = _manifest_strategies(directory / MANIFEST)
    if strategies is None:
        return [f"{n} ({why})" if n == MANIFEST else _describe(directory / n, n) for n in names]
    foreign = []
    for name in names:
        path = directory / name
        if name in _TOP_FILES:
            if not _is_regular(path):
                foreign.append(_describe(path, name))
        elif name == _SIMULATIONS and _is_directory(path):
            foreign += _foreign_simulations(path, strategies)
        else:
            foreign.append(_describe(path, name))
    return foreign


def _foreign_simulations(path: Path, strategies: set[str]) -> list[str]:
    foreign = []
    for strategy in sorted(os.listdir(path)):
        sub = path / strategy
        shown = f"{_SIMULATIONS}/{strategy}"
        if strategy not in strategies or not _is_directory(sub):
            foreign.append(_describe(sub, shown) if strategy in strategies
                           else f"{shown} (a strategy its {MANIFEST} does not list)")
            continue
        foreign += [_describe(sub / n, f"{shown}/{n}") for n in sorted(os.listdir(sub))
                    if n not in _RESULT_FILES or not _is_regular(sub / n)]
    return foreign


def _manifest_strategies(path: Path) -> tuple[set[str] | None, str]:
    """The strategies a manifest trainctl wrote lists, or None and why it is not trainctl's."""
    if not _is_regular(path):
        with contextlib.suppress(OSError):
            return None, f"{node_kind(os.lstat(path).st_mode)}, not a file trainctl wrote"
        return None, f"no {MANIFEST}"
    try:
        if os.lstat(path).st_size > _MAX_MANIFEST_BYTES:
            return None, "too large for a manifest trainctl writes"
        document = json.loads(read_regular_text(path))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError):
        return None, "not JSON, so not a manifest trainctl wrote"
    family = FORMAT.rsplit("/", 1)[0] + "/"
    if not (isinstance(document, dict) and isinstance(document.get("format"), str)
            and document["format"].startswith(family)):
        return None, f"not a manifest trainctl wrote (no format {family}N)"
    listed = document.get("strategies")
    strategies = {s for s in listed if isinstance(s, str)} if isinstance(listed, list) else set()
    return strategies, ""


def _describe(path: Path, shown: str) -> str:
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        return shown
    if stat.S_ISDIR(mode):
        return f"{shown}/"
    return shown if stat.S_ISREG(mode) else f"{shown} ({node_kind(mode)})"


def _is_regular(path: Path) -> bool:
    with contextlib.suppress(OSError):
        return stat.S_ISREG(os.lstat(path).st_mode)
    return False


def _is_directory(path: Path) -> bool:
    with contextlib.suppress(OSError):
        return stat.S_ISDIR(os.lstat(path).st_mode)
    return False


def _is_staging(path: Path) -> bool:
    """A staging entry of a save (left by a killed process when found by another)."""
    return _STAGING.fullmatch(path.name) is not None and _is_directory(path)


def _clean_up(staging: Path, created: list[Path]) -> None:
    """Remove the staging entry, and the directories a failed first save created."""
    shutil.rmtree(staging, ignore_errors=True)
    for made in reversed(created):
        with contextlib.suppress(OSError):
            made.rmdir()  # only if still empty: an interrupted first save leaves nothing


def _where(exc: OSError) -> str:
    return f": {os.fsdecode(exc.filename)}" if exc.filename else ""


def _make_directories(target: Path) -> list[Path]:
    """Create ``target`` and its missing parents; the ones created, outermost first."""
    missing = []
    for parent in (target, *target.parents):
        if os.path.lexists(parent):
            break
        missing.append(parent)
    target.mkdir(parents=True, exist_ok=True)
    return missing[::-1]


def _move_into_place(staging: Path, target: Path) -> None:
    """Swap a previous save's entries for the staged ones (renames, manifest out first, in last).

    A rename that fails undoes the ones made, so the previous save stays; the
    previous save's entries and any staging left by a killed save are removed
    afterwards.
    """
    trash = target / f"{_STAGING_PREFIX}{secrets.token_hex(6)}.old"
    leftovers = [target / n for n in os.listdir(target)
                 if _is_staging(target / n) and target / n != staging]
    trash.mkdir()
    done: list[tuple[Path, Path]] = []
    try:
        for name in (MANIFEST, "scenario.toml", _SIMULATIONS):
            if os.path.lexists(target / name):
                os.rename(target / name, trash / name)
                done.append((target / name, trash / name))
        for name in (_SIMULATIONS, "scenario.toml", MANIFEST):
            if os.path.lexists(staging / name):
                os.rename(staging / name, target / name)
                done.append((staging / name, target / name))
    except BaseException:
        for source, moved in reversed(done):
            with contextlib.suppress(OSError):
                os.rename(moved, source)
        raise
    finally:
        shutil.rmtree(trash, ignore_errors=True)
    staging.rmdir()
    for leftover in leftovers:
        shutil.rmtree(leftover, ignore_errors=True)


@contextlib.contextmanager
def _signals_deferred() -> Iterator[None]:
    """Hold SIGINT, SIGTERM and SIGHUP for the block; one that came is re-raised after it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []

    def hold(signum: int, frame: Any) -> None:
        caught.append(signum)

    previous: dict[int, Any] = {}
    try:
        for name in ("SIGINT", "SIGTERM", "SIGHUP"):
            signum = getattr(signal, name, None)
            if signum is not None and signal.getsignal(signum) is not None:
                previous[signum] = signal.signal(signum, hold)
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if caught:
            signal.raise_signal(caught[0])


