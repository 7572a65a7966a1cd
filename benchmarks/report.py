"""Benchmark: wall time of `trainctl report` (default scenario) and `trainctl report --all`.

Run:  .venv/bin/python benchmarks/report.py [--repeat N] [--skip-all] [--baseline DIR]

Each measurement is a fresh `python -m trainctl ...` process in a scratch
directory, so imports, analysis, simulations, figures, HTML and the write are
all included — what a user waits for. Targets on a quiet 2-core machine (issue 14; issue 5
had asked for 10 s and 60 s):

  default   `trainctl report`          (crh2-dmpc: analysis, 3 simulations, figures)  <= 2.5 s
  all       `trainctl report --all`    (every built-in and the gallery)                 <= 20 s

Side by side, as baselines on the same machine and in the same session:

  import    `python -c "import trainctl.cli.main, trainctl.report, trainctl.run.analysis"` —
            the fixed start-up cost inside every run above
  all -j1   `trainctl report --all --jobs 1` — everything in one process; the
            ratio all / all -j1 is what the process pool buys on this machine

With ``--baseline DIR`` (another checkout, e.g. the main branch's) every
measurement is also taken with ``PYTHONPATH=DIR``, interleaved run by run with
this checkout's, and the table adds the baseline's times and the ratios
this / baseline, of wall time and of CPU time (user + system of the child): on
a machine shared with other work the CPU-time ratio is the steadier one.
Compile both checkouts' bytecode first (``python -m compileall -q trainctl``
in each) when PYTHONDONTWRITEBYTECODE is set: a checkout without
``__pycache__`` pays some 0.3 s of compiling in every run.

The script prints a table and exits 1 when a target is missed.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGETS = {"default": 2.5, "all": 20.0}
REPO = Path(__file__).resolve().parents[1]


IMPORTS = "import trainctl.cli.main, trainctl.report, trainctl.run.analysis"

def timed_cpu(args: list[str], cwd: Path, path: Path = REPO) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of ``python ARGS`` with ``PYTHONPATH=path``."""
    env = dict(os.environ)
    env.pop("SOURCE_DATE_EPOCH", None)
    env["PYTHONPATH"] = str(path)
    before = os.times()
    start = time.perf_counter()
    result = subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True,
                            text=True, check=False)
    seconds = time.perf_counter() - start
    after = os.times()
    if result.returncode != 0:
        sys.exit(f"{' '.join(args)} failed ({result.returncode}):\n{result.stderr}")
    cpu = (after.children_user - before.children_user) + (after.children_system
                                                           - before.children_system)
    return seconds, cpu


def timed(args: list[str], cwd: Path) -> float:
    return timed_cpu(args, cwd)[0]


def side_by_side(baseline: Path, repeat: int, skip_all: bool) -> int:
    """This checkout against ``baseline``, interleaved; medians and ratios."""
    cases = [("import", ["-c", IMPORTS], repeat),
             ("default report", ["-m", "trainctl", "report"], repeat)]
    if not skip_all:
        cases.append(("all reports", ["-m", "trainctl", "report", "--all"], 1))
    print(f"machine: {os.cpu_count()} CPUs; python {sys.version.split()[0]}; this = {REPO}, "
          f"baseline = {baseline}; medians of interleaved runs")
    print(f"{'measurement':<18}{'wall this':>10}{'base':>8}{'ratio':>7}"
          f"{'cpu this':>10}{'base':>8}{'ratio':>7}")
    for name, args, runs in cases:
        this: list[tuple[float, float]] = []
        base: list[tuple[float, float]] = []
        for _ in range(runs):
            for path, into in ((baseline, base), (REPO, this)):
                with tempfile.TemporaryDirectory() as scratch:
                    into.append(timed_cpu(args, Path(scratch), path))
        tw, tc = (statistics.median(x[k] for x in this) for k in (0, 1))
        bw, bc = (statistics.median(x[k] for x in base) for k in (0, 1))
        print(f"{name:<18}{tw:>10.2f}{bw:>8.2f}{tw / bw:>7.2f}{tc:>10.2f}{bc:>8.2f}"
              f"{tc / bc:>7.2f}")
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs of the default report")
    parser.add_argument("--skip-all", action="store_true", help="only the default report")
    parser.add_argument("--baseline", type=Path, default=None,
                        help="another checkout to compare with, interleaved (PYTHONPATH)")
    args = parser.parse_args()
    if args.baseline is not None:
        return side_by_side(args.baseline.resolve(), args.repeat, args.skip_all)
    rows: list[tuple[str, float, str]] = []
    with tempfile.TemporaryDirectory() as scratch:
        cwd = Path(scratch)
        imports = [timed(["-c", IMPORTS], cwd)
                   for _ in range(args.repeat)]
        rows.append(("import (baseline)", statistics.median(imports), ""))
        default = [timed(["-m", "trainctl", "report"], cwd) for _ in range(args.repeat)]
        rows.append(("default report", statistics.median(default),
                     f"target <= {TARGETS['default']:g} s"))
        if not args.skip_all:
            rows.append(("all reports", timed(["-m", "trainctl", "report", "--all"], cwd),
                         f"target <= {TARGETS['all']:g} s"))
            rows.append(("all reports, --jobs 1 (baseline)",
                         timed(["-m", "trainctl", "report", "--all", "--jobs", "1"], cwd), ""))
    print(f"machine: {os.cpu_count()} CPUs; python {sys.version.split()[0]}; "
          f"median of {args.repeat} for the first two rows")
    print(f"{'measurement':<36}{'wall [s]':>10}  note")
    for name, seconds, note in rows:
        print(f"{name:<36}{seconds:>10.2f}  {note}")
    values = dict((name, s) for name, s, _ in rows)
    if "all reports" in values:
        ratio = values["all reports"] / values["all reports, --jobs 1 (baseline)"]
        print(f"pool ratio all / all --jobs 1: {ratio:.2f}")
    missed = [name for name, key in (("default report", "default"), ("all reports", "all"))
              if name in values and values[name] > TARGETS[key]]
    if missed:
        print("missed targets: " + ", ".join(missed))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
