# A sweep's results on disk: a manifest, one directory per finished point, the tidy table.
"""The store of a sweep: what it is, which points are done, and the table of all of them.

A store is a directory::

    sweep.json                  manifest (format, versions, the points and their keys)
    scenario.toml               the base scenario as read (its [sweep] included)
    .trainctl-sweep.lock        the writer's lock (fcntl.flock), holding its PID
    points/<key>/summary.json   a finished point's run, summarised (run_point)
    points/<key>/runs/<strategy>/result.json, arrays.npz
                                its simulations' time series (SimulationResult.save)
    points/<key>/checksums.json SHA-256 of each of the point's files, written last
    rows.parquet                one row per point and strategy (point_rows), all points
    rows.csv                    the same table, on request

Points are keyed by :func:`~trainctl.sweep.point_key` (the SHA-256 of the
validated scenario), so the points of a store are exactly the scenarios it
ran. A point directory is written under a temporary name and renamed when
complete, so a point is either done or absent, even after Ctrl-C or a
killed process; an interrupted sweep run again with the same command finds
its finished points and runs only the rest (:meth:`SweepStore.done`).

Nothing of a store is trusted when it is read back. The manifest is
validated (:class:`SweepManifest`) and its fingerprint recomputed from its
points, so a value edited in ``sweep.json`` is named. A point counts as done
only when every file its ``checksums.json`` lists has that checksum: on
resume a damaged point (a file edited, truncated or deleted) is recomputed
(:meth:`SweepStore.damaged` names it, and ``trainctl sweep`` says so on
stderr); ``trainctl report STORE`` refuses a store with a damaged point,
naming the file, and one whose table is not the table of its points.

One writer at a time: :meth:`SweepStore.open` takes an exclusive
:func:`fcntl.flock` on ``.trainctl-sweep.lock`` (released when the store is
closed or the process ends, however it ends) and writes its PID there; a
second writer is refused at once with "store in use by PID …" (it does not
wait), so no point is lost or written twice.

A store belongs to one sweep: :meth:`SweepStore.open` refuses a directory
whose manifest lists other points (a changed scenario or sweep), another
``simulate`` choice or another trainctl version, so results of different
scenarios are never mixed in one table; a store another trainctl version made
is refused by the same rule whether it is resumed or reported
(:meth:`SweepStore.load`).

The table is built from the stored summaries in point order
(:meth:`SweepStore.table`), never from results in memory, so it is the same
byte for byte whichever executor ran the points and in whatever order they
finished.

The manifest, its fingerprint and the file operations are
:mod:`trainctl.sweep.manifest`'s; the tidy table's columns
:func:`~trainctl.sweep.rows.rows_frame`'s.
"""


from __future__ import annotations

import json
import os
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from trainctl._files import read_regular_text
from trainctl.declare.jsonfile import read_json, validate_json
from trainctl.exceptions import ScenarioError
from trainctl.sweep.manifest import (
    _HINT,
    _PARTIAL,
    CHECKSUMS,
    CSV_TABLE,
    TABLE,
    _atomic,
    _json_value,
    _lock,
    _point_problem,
    _sha256,
    _unlock,
    _write_text,
)
from trainctl.sweep.manifest import ARRAYS as ARRAYS
from trainctl.sweep.manifest import FORMAT as FORMAT
from trainctl.sweep.manifest import LOCK as LOCK
from trainctl.sweep.manifest import MANIFEST as MANIFEST
from trainctl.sweep.manifest import SweepManifest as SweepManifest
from trainctl.sweep.manifest import is_sweep_store as is_sweep_store
from trainctl.sweep.manifest import sweep_fingerprint as sweep_fingerprint
from trainctl.sweep.rows import rows_frame as rows_frame

if TYPE_CHECKING:
    import pandas as pd

    from trainctl.sim.results import SimulationResult
    from trainctl.sweep.definition import SweepPoint

__all__ = ["ARRAYS", "FORMAT", "LOCK", "MANIFEST", "SweepManifest", "SweepStore", "is_sweep_store",
           "sweep_fingerprint"]


@dataclass(frozen=True)
class SweepStore:
    """An open sweep store (module docstring); make one with :meth:`open` or :meth:`load`.

    Parameters
    ----------
    path : pathlib.Path
        The store's directory.
    manifest : dict
        The content of ``sweep.json``.

    Examples
    --------
    A new store of a two-point sweep lists both points as missing until
    they have run:

    >>> import tempfile
    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> from trainctl.sweep import SweepDefinition, parse_set, point_key
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> base = parse_scenario(text, source=label)
    >>> sweep = SweepDefinition.of(base, [parse_set("controller.r_per_kn2=1,10")])
    >>> points, scenarios = sweep.points(base_seed=base.seed), sweep.validate(base)
    >>> keys = [point_key(s) for s in scenarios]
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     store = SweepStore.open(tmp, label=label, scenario_text=text, points=points,
    ...                             keys=keys, swept=sweep.keys, simulate=False,
    ...                             arrays="none")
    ...     missing = store.missing() == keys
    >>> missing, store.manifest["swept"], store.manifest["simulate"]
    (True, ['controller.r_per_kn2'], False)
    """

    path: Path
    manifest: Mapping[str, Any]

    # ------------------------------------------------------------------ opening
    @classmethod
    def open(cls, path: str | os.PathLike[str], *, label: str, scenario_text: str,
             points: Sequence[SweepPoint], keys: Sequence[str], swept: Sequence[str],
             simulate: bool, arrays: str = "sampled") -> SweepStore:
        """Create a store, or reopen the one this same sweep left (to resume it).

        Parameters
        ----------
        path : str or path-like
            The directory: missing or empty (a new store), or a store of
            this same sweep.
        label : str
            The scenario's name or path, for the manifest and messages.
        scenario_text : str
            The base scenario's TOML text (kept as ``scenario.toml``).
        points : sequence of SweepPoint
            The sweep's points, in order.
        keys : sequence of str
            Their point keys.
        swept : sequence of str
            The swept file keys (the table's value columns), in order.
        simulate : bool
            Whether the points' simulations run.
        arrays : {"sampled", "dense", "none"}
            What to keep of each simulation's time series (:data:`ARRAYS`).

        Returns
        -------
        SweepStore

        Raises
        ------
        ScenarioError
            The directory is a file, holds something that is not a sweep
            store, or a store of another sweep (other points, ``simulate``
            or trainctl version): nothing is written. Or another process
            holds the store's lock: "store in use by PID ...".
        """
        from trainctl import __version__

        if arrays not in ARRAYS:
            raise ScenarioError(f"sweep arrays: must be one of {', '.join(ARRAYS)}; "
                                f"got {arrays!r}.")
        root = Path(path)
        fingerprint = sweep_fingerprint(points, keys, simulate, __version__)
        if root.exists() and not root.is_dir():
            raise ScenarioError(f"{root}: the sweep's output must be a directory; a file of "
                                "that name exists. Give another --output.")
        if not is_sweep_store(root) and root.is_dir() and any(
                p.name != LOCK for p in root.iterdir()):
            raise ScenarioError(f"{root}: not empty and not a sweep store ({MANIFEST} is "
                                "missing); refusing to write into it. Give an empty or new "
                                "--output directory.")
        root.mkdir(parents=True, exist_ok=True)
        _lock(root)
        try:
            return cls._open_locked(root, label=label, scenario_text=scenario_text,
                                    points=points, keys=keys, swept=swept, simulate=simulate,
                                    arrays=arrays, fingerprint=fingerprint)
        except BaseException:
            _unlock(root)
            raise

    @classmethod
    def _open_locked(cls, root: Path, *, label: str, scenario_text: str,
                     points: Sequence[SweepPoint], keys: Sequence[str], swept: Sequence[str],
                     simulate: bool, arrays: str, fingerprint: str) -> SweepStore:
        from trainctl import __version__

        if is_sweep_store(root):
            store = cls.load(root)
            old = store.manifest
            if (old.get("fingerprint") != fingerprint or old.get("trainctl") != __version__
                    or old.get("simulate") is not bool(simulate)
                    or [p.get("key") for p in old["points"]] != list(keys)):
                raise ScenarioError(
                    f"{root}: holds the results of another sweep "
                    f"({store.describe_difference(points, keys, simulate, __version__)}); "
                    "refusing to mix them. Give another --output directory, or delete "
                    f"{root} to start this sweep afresh.")
            store._clean_partials()
            return store
        if any(p.name != LOCK for p in root.iterdir()):
            raise ScenarioError(f"{root}: not empty and not a sweep store ({MANIFEST} is "
                                "missing); refusing to write into it. Give an empty or new "
                                "--output directory.")
        from trainctl.sim.results import environment

        manifest = {
            "format": FORMAT,
            "trainctl": __version__,
            "environment": environment(),
            "scenario": label,
            "simulate": bool(simulate),
            "arrays": str(arrays),
            "swept": list(swept),
            "fingerprint": fingerprint,
            "points": [{"index": int(p.index), "values": _json_value(dict(p)), "key": k}
                       for p, k in zip(points, keys, strict=True)],
        }
        (root / "points").mkdir(parents=True, exist_ok=True)
        _write_text(root / "scenario.toml", scenario_text)
        _write_text(root / MANIFEST, json.dumps(manifest, indent=1) + "\n")
        return cls(root, manifest)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> SweepStore:
        """Open an existing store to read it.

        Parameters
        ----------
        path : str or path-like
            The store's directory.

        Returns
        -------
        SweepStore

        Raises
        ------
        ScenarioError
            Not a sweep store, or its manifest is damaged.
        """
        from trainctl import __version__
        from trainctl.sweep.definition import SweepPoint

        root = Path(path)
        if not is_sweep_store(root):
            raise ScenarioError(f"{root}: not a sweep store ({MANIFEST} is missing). Run "
                                "'trainctl sweep SCENARIO --output DIR' to make one.")
        where = root / MANIFEST
        manifest = read_json(where, hint=_HINT)
        found = manifest.get("format") if isinstance(manifest, dict) else None
        if found != FORMAT:
            raise ScenarioError(f"{where}: not a {FORMAT!r} manifest with its points (index, "
                                f"values, key) and swept keys (got format {found!r}).{_HINT}")
        if manifest.get("trainctl") != __version__:
            raise ScenarioError(
                f"{where}: holds the results of another sweep (made by trainctl "
                f"{manifest.get('trainctl')}, this is {__version__}); a store is resumed and "
                "reported only by the version that made it. Run the sweep again into a new "
                "directory with this version.")
        doc = validate_json(manifest, SweepManifest, where, hint=_HINT)
        expected = sweep_fingerprint([SweepPoint(p.index, p.values) for p in doc.points],
                                     [p.key for p in doc.points], doc.simulate, doc.trainctl)
        if doc.fingerprint != expected:
            raise ScenarioError(f"{where}: fingerprint must be the SHA-256 of its points, keys, "
                                "simulate and version (a point's values or key, or simulate, "
                                f"was edited).{_HINT}")
        return cls(root, manifest)

    def describe_difference(self, points: Sequence[SweepPoint], keys: Sequence[str],
                            simulate: bool, version: str) -> str:
        """What differs between this store and a sweep (for the refusal message).

        Parameters
        ----------
        points : sequence of SweepPoint
            The sweep's points, in order (not compared themselves: only their
            keys are).
        keys : sequence of str
            Their point keys, in the same order.
        simulate : bool
            Whether the sweep's simulations run.
        version : str
            The trainctl version running the sweep.

        Returns
        -------
        str
            The first difference found, in words: the trainctl version, the
            ``simulate`` choice, the number of points, how many points are
            other scenarios, or else "other swept values".
        """
        old = self.manifest
        if old.get("trainctl") != version:
            return f"made by trainctl {old.get('trainctl')}, this is {version}"
        if bool(old.get("simulate")) != bool(simulate):
            return ("made with --no-simulate" if not old.get("simulate")
                    else "made with the simulations; this run has --no-simulate")
        stored = [p["key"] for p in old["points"]]
        if len(stored) != len(keys):
            return f"{len(stored)} points, this sweep has {len(keys)}"
        changed = sum(a != b for a, b in zip(stored, keys, strict=True))
        if changed:
            return (f"{changed} of its {len(stored)} points are other scenarios: the scenario "
                    "or the sweep changed")
        return "other swept values"

    def close(self) -> None:
        """Release the writer's lock taken by :meth:`open` (the process's end releases it too).

        Examples
        --------
        >>> import tempfile
        >>> from trainctl.sweep import SweepPoint
        >>> with tempfile.TemporaryDirectory() as tmp:
        ...     store = SweepStore.open(tmp, label="x", scenario_text="", keys=["0" * 64],
        ...                             points=[SweepPoint(0, {"a": 1})], swept=["a"],
        ...                             simulate=False, arrays="none")
        ...     store.close()
        ...     print((Path(tmp) / LOCK).read_text().strip() == str(os.getpid()))
        True
        """
        _unlock(self.path)

    # ------------------------------------------------------------------ points
    @property
    def points_dir(self) -> Path:
        """``points/``."""
        return self.path / "points"

    @property
    def keys(self) -> list[str]:
        """The point keys in point order (a key repeats when two points are one scenario)."""
        return [p["key"] for p in self.manifest["points"]]

    def done(self) -> set[str]:
        """Keys of the points whose results are stored.

        Returns
        -------
        set of str
            The point keys of the manifest that have a complete point directory
            (with its ``summary.json``); empty without ``points/``.
        """
        return set(self.keys) - set(self.damaged()) - set(self._absent())

    def _absent(self) -> list[str]:
        return [k for k in dict.fromkeys(self.keys) if not (self.points_dir / k).is_dir()]

    def damaged(self) -> dict[str, str]:
        """Points whose directory exists but whose files are not the ones stored.

        Returns
        -------
        dict of str to str
            Point key -> what is wrong, naming the file: its
            :data:`~trainctl.sweep.manifest.CHECKSUMS` missing or unreadable, a file it
            lists missing or with another SHA-256 (edited or truncated).
        """
        out: dict[str, str] = {}
        for key in dict.fromkeys(self.keys):
            folder = self.points_dir / key
            if folder.is_dir():
                problem = _point_problem(folder)
                if problem is not None:
                    out[key] = problem
        return out

    def verify(self) -> None:
        """Refuse a store with a point that is not stored whole (for reading it).

        Raises
        ------
        ScenarioError
            Naming the first damaged point's file (:meth:`damaged`).
        """
        damaged = self.damaged()
        if damaged:
            key, problem = next(iter(damaged.items()))
            raise ScenarioError(f"{problem}: point {self.keys.index(key)} ({key[:12]}) of the "
                                f"store is damaged ({len(damaged)} damaged points); run the "
                                "sweep's command again to recompute them.")

    def missing(self) -> list[str]:
        """Keys still to run, each once, in point order.

        Returns
        -------
        list of str
            The manifest's point keys not in :meth:`done`, without repeats.
        """
        done = self.done()
        out: list[str] = []
        for key in self.keys:
            if key not in done and key not in out:
                out.append(key)
        return out

    def write_point(self, key: str, summary: Mapping[str, Any],
                    simulations: Mapping[str, SimulationResult] | None = None) -> Path:
        """Store one finished point, whole or not at all.

        Parameters
        ----------
        key : str
            Its point key.
        summary : mapping
            Its run's summary (:func:`~trainctl.sweep.run_point`), JSON-safe.
        simulations : mapping of str to SimulationResult or None
            Its simulations, kept as ``runs/<strategy>/`` when the store
            keeps arrays.

        Returns
        -------
        pathlib.Path
            The point's directory.
        """
        final = self.points_dir / key
        if final.is_dir() and _point_problem(final) is None:
            return final
        partial = self.points_dir / f".{key}{_PARTIAL}{os.getpid()}"
        shutil.rmtree(partial, ignore_errors=True)
        partial.mkdir(parents=True)
        try:
            arrays = self.manifest.get("arrays", "sampled")
            if arrays in ARRAYS[1:]:
                for strategy, result in (simulations or {}).items():
                    result.save(partial / "runs" / strategy, dense=arrays == "dense",
                                compressed=True)
            text = json.dumps(summary, indent=1, sort_keys=True, allow_nan=False)
            (partial / "summary.json").write_text(text + "\n", encoding="utf-8")
            sums = {f.relative_to(partial).as_posix(): _sha256(f)
                    for f in sorted(partial.rglob("*")) if f.is_file()}
            (partial / CHECKSUMS).write_text(json.dumps(sums, indent=1) + "\n",
                                             encoding="utf-8")
            if final.exists():  # a damaged point (this store's own), recomputed
                old = self.points_dir / f".{key}{_PARTIAL}{os.getpid()}-old"
                shutil.rmtree(old, ignore_errors=True)
                os.replace(final, old)
                shutil.rmtree(old, ignore_errors=True)
            os.replace(partial, final)
        except BaseException:
            shutil.rmtree(partial, ignore_errors=True)
            raise
        return final

    def summary(self, key: str) -> dict[str, Any]:
        """A stored point's summary.

        Parameters
        ----------
        key : str
            The point's key (:func:`~trainctl.sweep.point_key`).

        Returns
        -------
        dict of str to object
            The point's ``summary.json``: its run's summary
            (:func:`~trainctl.sweep.run_point`).

        Raises
        ------
        ScenarioError
            The point is not stored, or its file is damaged.
        """
        path = self.points_dir / key / "summary.json"
        try:
            data = json.loads(read_regular_text(path))
        except FileNotFoundError:
            raise ScenarioError(f"{self.path}: point {key[:12]} has not run yet; run the "
                                "sweep's command again to finish it.") from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ScenarioError(f"{path}: not readable as JSON ({exc}); delete the point's "
                                "directory and run the sweep again to redo it.") from None
        if not isinstance(data, dict):
            raise ScenarioError(f"{path}: not a point summary (a JSON object); delete the "
                                "point's directory and run the sweep again to redo it.")
        return data

    def _clean_partials(self) -> None:
        """Remove the half-written point directories of an interrupted run."""
        if self.points_dir.is_dir():
            for p in self.points_dir.iterdir():
                if _PARTIAL in p.name:
                    shutil.rmtree(p, ignore_errors=True)

    # ------------------------------------------------------------------ table
    def rows(self) -> list[dict[str, Any]]:
        """Every point's rows (:func:`~trainctl.sweep.point_rows`), in point order.

        Returns
        -------
        list of dict of str to object
            One row per point and simulated strategy (one row with
            ``strategy = ""`` for a point without simulations).

        Raises
        ------
        ScenarioError
            A point has not run yet.
        """
        from trainctl.sweep.definition import SweepPoint
        from trainctl.sweep.rows import point_rows

        rows: list[dict[str, Any]] = []
        for entry in self.manifest["points"]:
            point = SweepPoint(entry["index"], entry["values"])
            rows += point_rows(point, entry["key"], self.summary(entry["key"]))
        return rows

    def table(self) -> pd.DataFrame:
        """The tidy table of every point (:func:`~trainctl.sweep.rows.rows_frame` of :meth:`rows`).

        Returns
        -------
        pandas.DataFrame
            One row per point and strategy; columns ``point``, ``point_key``,
            the swept keys, ``strategy``, then the check and metric columns,
            one dtype per column.

        Raises
        ------
        ScenarioError
            A point has not run yet.
        """
        return rows_frame(self.rows(), self.manifest["swept"])

    def write_table(self, csv: bool = False) -> Path:
        """Write ``rows.parquet`` (and ``rows.csv``) from the stored points.

        Parameters
        ----------
        csv : bool
            Also write the table as CSV.

        Returns
        -------
        pathlib.Path
            The Parquet file.
        """
        frame = self.table()
        target = self.path / TABLE
        _atomic(target, lambda tmp: frame.to_parquet(tmp, index=False, engine="pyarrow"))
        if csv:
            _atomic(self.path / CSV_TABLE,
                    lambda tmp: frame.to_csv(tmp, index=False, lineterminator="\n"))
        return target

    def read_table(self) -> pd.DataFrame:
        """``rows.parquet`` as written by :meth:`write_table`.

        Returns
        -------
        pandas.DataFrame
            The table of :meth:`table` as stored when the sweep finished.

        Raises
        ------
        ScenarioError
            The table is missing (the sweep has not finished) or unreadable.
        """
        import pandas as pd

        target = self.path / TABLE
        if not target.is_file():
            raise ScenarioError(f"{self.path}: the sweep has not finished ({TABLE} is missing; "
                                f"{len(self.done())} of {len(set(self.keys))} points done). "
                                "Run the sweep's command again to finish it.")
        try:
            return pd.read_parquet(target, engine="pyarrow")
        except Exception as exc:  # pyarrow raises several types for a damaged file
            raise ScenarioError(f"{target}: not a readable Parquet table ({exc}); run the "
                                "sweep's command again to rewrite it.") from None
