# Compare the saved simulations of two sets of `trainctl analyse --save` runs.
"""Check that two sets of saved runs agree: bit-identical, or to 1e-12 relative.

Usage::

    python benchmarks/compare_runs.py BASE_DIR NEW_DIR [--rtol 1e-12]

``BASE_DIR`` and ``NEW_DIR`` each hold one directory per scenario, as written
by ``trainctl analyse NAME --save DIR/NAME``. For every scenario directory of
``BASE_DIR`` and every strategy under its ``simulations/``, every array of
``arrays.npz`` is compared with the same array of ``NEW_DIR``, and so are the
per-step Jacobi residuals, statuses and fallbacks of ``result.json``. Wall-clock
arrays (``solve_times``) are skipped. The run's manifest (``trainctl-run.json``: checks,
spectra, family data, frequency responses, repetitions) is compared too, every number
as an array of one and every other value for equality, the environment, command,
timings and source path aside. A directory holding ``sweep.json`` is a sweep store
(``trainctl sweep -o DIR``): its ``rows.parquet`` (numeric columns as arrays, the others
for equality; wall-clock columns aside) and every point's ``runs/*/arrays.npz`` are
compared.

Each array is reported as ``identical`` (equal values, NaNs in the same places)
or with its maximum relative difference: per signal (row of a 2-D array; a 1-D
array is one signal) max |new - base| / max |base|, then the largest over the
signals. A difference above ``--rtol`` (default 1e-12), a changed shape, or a
missing scenario, strategy or array is a mismatch; an array only the new run
has (a field added since the baseline) is listed as added.

Exit status: 0 when everything agrees, 1 on any mismatch, 2 on a usage error.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

WALL_CLOCK = frozenset({"solve_times"})
"""Arrays holding wall-clock times, which differ between any two runs."""


def relative_difference(base: np.ndarray, new: np.ndarray) -> float:
    """Largest per-signal max |new - base| / max |base| (0 where both are all zero)."""
    b = np.atleast_2d(np.asarray(base, dtype=float))
    c = np.atleast_2d(np.asarray(new, dtype=float))
    b = b.reshape(b.shape[0], -1)
    c = c.reshape(c.shape[0], -1)
    worst = 0.0
    for row_b, row_c in zip(b, c, strict=True):
        both_nan = np.isnan(row_b) & np.isnan(row_c)
        diff = np.where(both_nan, 0.0, np.abs(row_c - row_b))
        if np.any(np.isnan(diff)):
            return float("inf")
        scale = float(np.nanmax(np.abs(row_b), initial=0.0))
        peak = float(diff.max(initial=0.0))
        if peak == 0.0:
            continue
        worst = max(worst, peak / scale if scale > 0.0 else float("inf"))
    return worst


def compare_array(name: str, base: np.ndarray, new: np.ndarray, rtol: float) -> tuple[str, bool]:
    """One report line for an array and whether it passes."""
    if base.shape != new.shape:
        return f"{name}: shape {base.shape} -> {new.shape}  MISMATCH", False
    if np.array_equal(base, new, equal_nan=bool(base.dtype.kind == "f")):
        return f"{name}: identical", True
    rel = relative_difference(base, new)
    ok = rel <= rtol
    return f"{name}: max relative difference {rel:.3e}{'' if ok else '  MISMATCH'}", ok


def _residuals(result: dict) -> np.ndarray:
    """The ragged per-step residual lists as one flat array (lengths checked separately)."""
    steps = result.get("residuals") or []
    return np.array([r for step in steps for r in step], dtype=float)


def compare_strategy(base: Path, new: Path, rtol: float) -> tuple[list[str], bool]:
    """Report lines for one strategy directory and whether all of it passes."""
    if not (new / "arrays.npz").is_file():
        return [f"  missing {new / 'arrays.npz'}  MISMATCH"], False
    lines: list[str] = []
    ok = True
    with np.load(base / "arrays.npz") as b, np.load(new / "arrays.npz") as c:
        for name in sorted(set(b.files) | set(c.files)):
            if name in WALL_CLOCK:
                lines.append(f"  {name}: skipped (wall clock)")
                continue
            if name not in b.files:
                lines.append(f"  {name}: added (only in new)")
                continue
            if name not in c.files:
                lines.append(f"  {name}: only in base  MISMATCH")
                ok = False
                continue
            line, good = compare_array(name, b[name], c[name], rtol)
            lines.append(f"  {line}")
            ok &= good
    rb = json.loads((base / "result.json").read_text())
    rc = json.loads((new / "result.json").read_text())
    for key in ("statuses", "fallbacks"):
        same = rb.get(key) == rc.get(key)
        lines.append(f"  {key}: {'identical' if same else 'differ  MISMATCH'}")
        ok &= same
    lengths_b = [len(r) for r in rb.get("residuals") or []]
    lengths_c = [len(r) for r in rc.get("residuals") or []]
    if lengths_b != lengths_c:
        lines.append("  residuals: iteration counts differ  MISMATCH")
        ok = False
    else:
        line, good = compare_array("residuals", _residuals(rb), _residuals(rc), rtol)
        lines.append(f"  {line}")
        ok &= good
    return lines, ok


MANIFEST = "trainctl-run.json"
MANIFEST_SKIP = frozenset({"environment", "command", "timings", "source"})
"""Manifest keys that differ between any two runs (versions, paths, wall clock)."""
WALL_CLOCK_LEAVES = ("solve_time", "search_time")
"""Substrings of the manifest's leaf names that hold wall-clock times (e.g. solve_time_p95)."""


def _leaves(value: object, path: str = "") -> dict[str, object]:
    """Every leaf of a JSON document by its path (``a.b[2]``)."""
    if isinstance(value, dict):
        out: dict[str, object] = {}
        for key, item in value.items():
            out.update(_leaves(item, f"{path}.{key}" if path else str(key)))
        return out
    if isinstance(value, list):
        out = {}
        for i, item in enumerate(value):
            out.update(_leaves(item, f"{path}[{i}]"))
        return out
    return {path: value}


def compare_manifest(base: Path, new: Path, rtol: float) -> tuple[list[str], bool]:
    """Report lines for the manifests of two saved runs (numbers to ``rtol``)."""
    if not (base / MANIFEST).is_file():
        return [], True
    if not (new / MANIFEST).is_file():
        return [f"  missing {new / MANIFEST}  MISMATCH"], False
    b = json.loads((base / MANIFEST).read_text())
    c = json.loads((new / MANIFEST).read_text())
    def kept(doc: dict) -> dict[str, object]:
        leaves = _leaves({k: v for k, v in doc.items() if k not in MANIFEST_SKIP})
        return {k: v for k, v in leaves.items()
                if not any(w in k.rsplit(".", 1)[-1] for w in WALL_CLOCK_LEAVES)}

    lb, lc = kept(b), kept(c)
    bad = [k for k in lb if k not in lc]
    added = [k for k in lc if k not in lb]
    worst, differ = 0.0, []
    for key in lb.keys() & lc.keys():
        x, y = lb[key], lc[key]
        numbers = (int, float)
        if isinstance(x, numbers) and isinstance(y, numbers) and not isinstance(x, bool):
            if x != y:
                rel = relative_difference(np.array([x]), np.array([y]))
                worst = max(worst, rel)
                if rel > rtol:
                    differ.append(f"{key}: {x!r} -> {y!r}")
        elif x != y:
            differ.append(f"{key}: {x!r} -> {y!r}")
    state = "identical" if not (differ or bad or worst) else f"max relative difference {worst:.3e}"
    lines = [f"  manifest ({len(lb)} values): {state}"]
    lines += [f"  manifest {k}: only in base  MISMATCH" for k in sorted(bad)[:20]]
    lines += [f"  manifest {d}  MISMATCH" for d in differ[:20]]
    if added:
        lines.append(f"  manifest: {len(added)} values added (only in new)")
    return lines, not (bad or differ)


WALL_COLUMNS = ("seconds", "time_s", "elapsed", "wall")
"""Substrings of sweep-table columns holding wall-clock times."""


def compare_store(base: Path, new: Path, rtol: float) -> tuple[list[str], bool]:
    """Report lines for two sweep stores: the tidy table and every point's arrays."""
    import pandas as pd

    lines, ok = [f"{base.name}: sweep store"], True
    if not (new / "rows.parquet").is_file():
        return lines + [f"  missing {new / 'rows.parquet'}  MISMATCH"], False
    tb, tc = pd.read_parquet(base / "rows.parquet"), pd.read_parquet(new / "rows.parquet")
    if list(tb.columns) != list(tc.columns) or len(tb) != len(tc):
        return lines + ["  rows.parquet: columns or rows differ  MISMATCH"], False
    for column in tb.columns:
        if any(w in column for w in WALL_COLUMNS):
            continue
        x, y = tb[column].to_numpy(), tc[column].to_numpy()
        if x.dtype.kind in "fiu" and y.dtype.kind in "fiu":
            line, good = compare_array(f"rows.{column}", x.astype(float), y.astype(float), rtol)
            if not line.endswith("identical"):
                lines.append(f"  {line}")
        else:
            good = [str(v) for v in x] == [str(v) for v in y]
            if not good:
                lines.append(f"  rows.{column}: differ  MISMATCH")
        ok &= good
    points = sorted((base / "points").glob("*/runs/*"))
    for run in points:
        rel = run.relative_to(base)
        for name, good_line in _npz_lines(run / "arrays.npz", new / rel / "arrays.npz", rtol):
            ok &= good_line
            if not name.endswith("identical"):
                lines.append(f"  {rel}: {name}")
    lines.append(f"  {len(tb)} rows, {len(points)} point runs compared")
    return lines, ok


def _npz_lines(base: Path, new: Path, rtol: float) -> list[tuple[str, bool]]:
    if not new.is_file():
        return [(f"missing {new}  MISMATCH", False)]
    out = []
    with np.load(base) as b, np.load(new) as c:
        for name in sorted(set(b.files) | set(c.files)):
            if name in WALL_CLOCK:
                continue
            if name not in b.files or name not in c.files:
                out.append((f"{name}: in one run only  MISMATCH", False))
                continue
            out.append(compare_array(name, b[name], c[name], rtol))
    return out


def compare_runs(base_dir: Path, new_dir: Path, rtol: float) -> tuple[list[str], bool]:
    """Report lines for every scenario and strategy of ``base_dir`` and the overall verdict."""
    lines: list[str] = []
    ok = True
    scenarios = sorted(p for p in base_dir.iterdir() if p.is_dir())
    for scenario in scenarios:
        if (scenario / "sweep.json").is_file():
            more, good = compare_store(scenario, new_dir / scenario.name, rtol)
            lines += more
            ok &= good
            continue
        sims = scenario / "simulations"
        strategies = sorted(p for p in sims.iterdir() if p.is_dir()) if sims.is_dir() else []
        count = f"{len(strategies)} strateg{'y' if len(strategies) == 1 else 'ies'}"
        lines.append(f"{scenario.name}: {count}")
        if not (new_dir / scenario.name).is_dir():
            lines.append(f"  missing {new_dir / scenario.name}  MISMATCH")
            ok = False
            continue
        for strategy in strategies:
            lines.append(f" {strategy.name}")
            new = new_dir / scenario.name / "simulations" / strategy.name
            more, good = compare_strategy(strategy, new, rtol)
            lines += more
            ok &= good
        more, good = compare_manifest(scenario, new_dir / scenario.name, rtol)
        lines += more
        ok &= good
    return lines, ok


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("base", type=Path, help="directory of the baseline scenario runs")
    parser.add_argument("new", type=Path, help="directory of the runs to check")
    parser.add_argument("--rtol", type=float, default=1e-12,
                        help="largest admissible relative difference")
    args = parser.parse_args(argv)
    for path in (args.base, args.new):
        if not path.is_dir():
            parser.error(f"{path} is not a directory")
    lines, ok = compare_runs(args.base, args.new, args.rtol)
    print("\n".join(lines))
    verdict = "OK: all arrays agree" if ok else f"FAIL: differences above {args.rtol:g} or missing"
    print(verdict)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
