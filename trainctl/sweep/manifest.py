# A sweep store's manifest, its fingerprint, and the file operations the store makes.
"""The manifest of a sweep store (``sweep.json``) and the store's file operations.

:class:`SweepManifest` validates a manifest read back; :func:`sweep_fingerprint`
recomputes what makes a sweep's results (its points' keys, ``simulate``, the
version), so that a value edited in ``sweep.json`` is named;
:func:`is_sweep_store` tells a store from any other directory. The private
helpers write files atomically (a temporary name renamed into place), check a
point's files against its ``checksums.json`` and take and release the
writer's lock. The store itself is :class:`trainctl.sweep.store.SweepStore`.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictStr, model_validator

from trainctl.declare.constraints import Choice, Integer, Violation, raise_at
from trainctl.exceptions import ScenarioError

if TYPE_CHECKING:
    from trainctl.sweep.definition import SweepPoint

__all__ = ["ARRAYS", "CHECKSUMS", "CSV_TABLE", "FORMAT", "LOCK", "MANIFEST", "TABLE",
           "SweepManifest", "is_sweep_store", "sweep_fingerprint"]

FORMAT = "trainctl-sweep/2"
"""Format of ``sweep.json`` (2: each point's files carry their checksums)."""

LOCK = ".trainctl-sweep.lock"
"""The lock file of a store's writer (its PID inside)."""

CHECKSUMS = "checksums.json"
"""A point's record of its files' SHA-256, written last into the point's directory."""

_HINT = " The store was edited or damaged; run the sweep again into a new directory."

_HELD: dict[Path, int] = {}
"""Stores this process holds the lock of: resolved directory -> the lock file's descriptor."""


def _forget_locks() -> None:
    """In a forked child (a pool worker, :mod:`trainctl.run.pool`): close the inherited lock
    descriptors, which share the parent's ``flock``, so that the lock ends with the parent's
    :func:`_unlock` and never lives on in a worker. The child writes no store."""
    for fd in _HELD.values():
        with contextlib.suppress(OSError):
            os.close(fd)
    _HELD.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_locks)

MANIFEST = "sweep.json"
"""The manifest's file name; a directory holding it is a sweep store."""

TABLE = "rows.parquet"
"""The table's file name (Parquet)."""

CSV_TABLE = "rows.csv"
"""The table as CSV (written on request)."""

ARRAYS = ("none", "sampled", "dense")
"""What a store keeps of each run's time series: nothing, the arrays at the controller's
samples, or those and the between-sample (dense) ones."""

_Digest = Annotated[str, Field(pattern=r"^[0-9a-f]{64}$")]


class _Point(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    index: Annotated[int, Integer(ge=0)]
    values: dict[str, Any]
    key: _Digest


class SweepManifest(BaseModel):
    """``sweep.json``, declared: what reading or resuming a store relies on.

    Parameters
    ----------
    format : str
        :data:`FORMAT`.
    trainctl : str
        The version that made the store.
    environment : dict
        Versions of Python and the dependencies.
    scenario : str
        The base scenario's name or path.
    simulate : bool
        Whether the points' simulations run.
    arrays : {"none", "sampled", "dense"}
        What is kept of each simulation (:data:`ARRAYS`).
    swept : list of str
        The swept keys, in order: every point's values have exactly these.
    fingerprint : str
        :func:`sweep_fingerprint` of the points: recomputed on reading, so an
        edited value or key is named.
    points : list
        Per point: ``index`` (0, 1, ... in order), ``values``, ``key``.

    Examples
    --------
    >>> doc = {"format": FORMAT, "trainctl": "0.1.0", "environment": {}, "scenario": "x",
    ...        "simulate": False, "arrays": "none", "swept": ["a"], "fingerprint": "0" * 64,
    ...        "points": [{"index": 0, "values": {"a": 1}, "key": "f" * 64}]}
    >>> SweepManifest.model_validate(doc).points[0].values
    {'a': 1}
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    format: StrictStr
    trainctl: StrictStr
    environment: dict[str, Any]
    scenario: StrictStr
    simulate: StrictBool
    arrays: Annotated[str, Choice(ARRAYS)]
    swept: list[StrictStr]
    fingerprint: _Digest
    points: list[_Point] = Field(min_length=1)

    @model_validator(mode="after")
    def _relations(self) -> SweepManifest:
        for i, point in enumerate(self.points):
            if point.index != i:
                raise_at(("points", i, "index"), Violation(f"must be {i} (points in order)",
                                                           got=point.index), point.index)
            if list(point.values) != list(self.swept):
                raise_at(("points", i, "values"), Violation(
                    f"must have the swept keys {self.swept}, in order", got=point.values),
                    point.values)
        return self

_PARTIAL = ".partial-"
"""Infix of a point directory being written (``points/.<key>.partial-<pid>``)."""


def is_sweep_store(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a directory holding a sweep manifest.

    Parameters
    ----------
    path : str or os.PathLike
        A path given to ``trainctl report``.

    Returns
    -------
    bool
        Whether it is a sweep store.

    Examples
    --------
    >>> import tempfile
    >>> from trainctl.sweep import sweep_scenario
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     before = is_sweep_store(tmp)  # an empty directory
    ...     _ = sweep_scenario("crh2-dmpc", tmp, axes=["controller.r_per_kn2=1,10"],
    ...                        simulate=False)
    ...     after = is_sweep_store(tmp)
    >>> before, after
    (False, True)
    """
    return (Path(path) / MANIFEST).is_file()


def _json_value(value: Any) -> Any:
    """A swept value as JSON (TOML values: numbers, strings, booleans, arrays, tables)."""
    return json.loads(json.dumps(value))


def sweep_fingerprint(points: Sequence[SweepPoint], keys: Sequence[str], simulate: bool,
                      version: str) -> str:
    """SHA-256 of what makes a sweep's results: its points' keys, ``simulate``, the version.

    Parameters
    ----------
    points : sequence of SweepPoint
        The points in order.
    keys : sequence of str
        Their :func:`~trainctl.sweep.point_key` s, in the same order.
    simulate : bool
        Whether the points' simulations run.
    version : str
        trainctl's version.

    Returns
    -------
    str
        64 hexadecimal digits.

    Examples
    --------
    The same points give the same fingerprint; running their simulations
    too makes another sweep:

    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> from trainctl.sweep import SweepDefinition, parse_set, point_key
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> base = parse_scenario(text, source=label)
    >>> sweep = SweepDefinition.of(base, [parse_set("controller.r_per_kn2=1,10")])
    >>> points, scenarios = sweep.points(base_seed=base.seed), sweep.validate(base)
    >>> keys = [point_key(s) for s in scenarios]
    >>> a = sweep_fingerprint(points, keys, False, "0.1.0")
    >>> len(a), a == sweep_fingerprint(points, keys, False, "0.1.0")
    (64, True)
    >>> a == sweep_fingerprint(points, keys, True, "0.1.0")
    False
    """
    document = {"points": [[dict(p), k] for p, k in zip(points, keys, strict=True)],
                "simulate": bool(simulate), "trainctl": version}
    text = json.dumps(_json_value(document), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _write_text(path: Path, text: str) -> None:
    _atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def _atomic(target: Path, write: Any) -> None:
    """Write ``target`` through a temporary file renamed into place (nothing half-written)."""
    tmp = target.with_name(f".{target.name}{_PARTIAL}{os.getpid()}")
    try:
        write(tmp)
        os.replace(tmp, target)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _point_problem(folder: Path) -> str | None:
    """What is wrong with a stored point's files (a message naming the file), or None."""
    record = folder / CHECKSUMS
    try:
        sums = json.loads(record.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return f"{record}: missing"
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        return f"{record}: not readable ({exc})"
    if (not isinstance(sums, dict) or "summary.json" not in sums
            or not all(isinstance(k, str) and isinstance(v, str) for k, v in sums.items())):
        return f"{record}: not a record of the point's files with summary.json"
    for name, digest in sums.items():
        target = folder / name
        if ".." in Path(name).parts or Path(name).is_absolute():
            return f"{record}: lists {name!r}, outside the point"
        if not target.is_file():
            return f"{target}: missing"
        if _sha256(target) != digest:
            return f"{target}: its SHA-256 is not the one in {CHECKSUMS} (edited or truncated)"
    return None


def _lock(root: Path) -> None:
    """Take the store's writer lock (exclusive, non-blocking), or refuse naming its owner."""
    key = root.resolve()
    if key in _HELD:
        return
    try:
        fd = os.open(root / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise ScenarioError(f"{root / LOCK}: cannot create the store's lock file "
                            f"({exc.strerror or exc}).") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        owner = os.pread(fd, 64, 0).decode("ascii", "replace").strip() or "unknown"
        os.close(fd)
        raise ScenarioError(f"{root}: store in use by PID {owner} (another 'trainctl sweep' "
                            "is writing it); wait for it to finish, or give another "
                            "--output.") from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode("ascii"), 0)
    _HELD[key] = fd


def _unlock(root: Path) -> None:
    fd = _HELD.pop(root.resolve(), None)
    if fd is not None:
        os.close(fd)  # releases the flock
