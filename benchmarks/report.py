"""Benchmark: wall time of `trainctl report` (default scenario) and `trainctl report --all`.

Run:  .venv/bin/python benchmarks/report.py [--repeat N] [--skip-all]

Each measurement is a fresh `python -m trainctl ...` process in a scratch
directory, so imports, analysis, simulations, figures, HTML and the write are
all included — what a user waits for. Targets (issue 5, 2-core machine):

  default   `trainctl report`          (crh2-dmpc: analysis, 3 simulations, figures)  <= 10 s
  all       `trainctl report --all`    (every built-in and the gallery)                 <= 60 s

Side by side, as baselines on the same machine and in the same session:

  import    `python -c "import trainctl.cli, trainctl.report, trainctl.run"` —
            the fixed start-up cost inside every run above
  all -j1   `trainctl report --all --jobs 1` — everything in one process; the
            ratio all / all -j1 is what the process pool buys on this machine

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

TARGETS = {"default": 10.0, "all": 60.0}
REPO = Path(__file__).resolve().parents[1]


def timed(args: list[str], cwd: Path) -> float:
    env = dict(os.environ)
    env.pop("SOURCE_DATE_EPOCH", None)
    start = time.perf_counter()
    result = subprocess.run([sys.executable, *args], cwd=cwd, env=env, capture_output=True,
                            text=True, check=False)
    seconds = time.perf_counter() - start
    if result.returncode != 0:
        sys.exit(f"{' '.join(args)} failed ({result.returncode}):\n{result.stderr}")
    return seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="runs of the default report")
    parser.add_argument("--skip-all", action="store_true", help="only the default report")
    args = parser.parse_args()
    rows: list[tuple[str, float, str]] = []
    with tempfile.TemporaryDirectory() as scratch:
        cwd = Path(scratch)
        imports = [timed(["-c", "import trainctl.cli, trainctl.report, trainctl.run"], cwd)
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
