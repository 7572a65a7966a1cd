"""Benchmark: start-up of the light commands (imports on demand, issue 27) against a baseline.

Run:  .venv/bin/python benchmarks/imports.py --baseline DIR [--repeat N]

Each measurement is a fresh interpreter with ``PYTHONPATH`` set to this
checkout or to ``DIR`` (another checkout, e.g. the main branch's),
interleaved run by run:

  --help          ``python -m trainctl --help``
  list            ``python -m trainctl list``
  load_scenario   ``python -c "from trainctl.scenario import load_scenario; load_scenario(...)"``
  report          ``python -m trainctl report`` (crh2-dmpc; with ``--report``)

For each: the medians of wall and CPU time (user + system of the child; on a
shared machine the CPU-time ratio is the steadier one), the ratios this /
baseline, and how many modules the command imported (``-X importtime``, a
separate run). Which modules must stay out is tested, not timed:
``tests/test_import_graph.py``. Compile both checkouts' bytecode first
(``python -m compileall -q trainctl`` in each) when PYTHONDONTWRITEBYTECODE is set.
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

REPO = Path(__file__).resolve().parents[1]

CASES = {
    "--help": ["-m", "trainctl", "--help"],
    "list": ["-m", "trainctl", "list"],
    "load_scenario": ["-c", "from trainctl.scenario import load_scenario; "
                            "load_scenario('crh2-dmpc')"],
    "report": ["-m", "trainctl", "report", "-o", "report.html"],
}


def timed_cpu(args: list[str], cwd: Path, path: Path) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of ``python ARGS`` with ``PYTHONPATH=path``."""
    env = dict(os.environ, PYTHONPATH=str(path))
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


def module_count(args: list[str], cwd: Path, path: Path) -> int:
    """How many modules ``python -X importtime ARGS`` imports."""
    env = dict(os.environ, PYTHONPATH=str(path))
    result = subprocess.run([sys.executable, "-X", "importtime", *args], cwd=cwd, env=env,
                            capture_output=True, text=True, check=True)
    return sum(1 for line in result.stderr.splitlines()
               if line.startswith("import time:") and "imported package" not in line)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True,
                        help="another checkout to compare with, interleaved (PYTHONPATH)")
    parser.add_argument("--repeat", type=int, default=5, help="runs of each command")
    parser.add_argument("--report", action="store_true", help="also the default report")
    args = parser.parse_args()
    baseline = args.baseline.resolve()
    cases = [name for name in CASES if name != "report" or args.report]
    print(f"machine: {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}; python "
          f"{sys.version.split()[0]}; this = {REPO}, baseline = {baseline}; "
          f"medians of {args.repeat} interleaved runs")
    print(f"{'command':<15}{'wall this':>10}{'base':>8}{'ratio':>7}"
          f"{'cpu this':>10}{'base':>8}{'ratio':>7}{'modules':>9}{'base':>6}")
    for name in cases:
        this: list[tuple[float, float]] = []
        base: list[tuple[float, float]] = []
        with tempfile.TemporaryDirectory() as scratch:
            cwd = Path(scratch)
            for run in range(args.repeat):
                order = ((baseline, base), (REPO, this))
                for path, into in order if run % 2 == 0 else order[::-1]:
                    into.append(timed_cpu(CASES[name], cwd, path))
            counts = [module_count(CASES[name], cwd, path) for path in (REPO, baseline)]
        tw, tc = (statistics.median(x[k] for x in this) for k in (0, 1))
        bw, bc = (statistics.median(x[k] for x in base) for k in (0, 1))
        print(f"{name:<15}{tw:>10.2f}{bw:>8.2f}{tw / bw:>7.2f}{tc:>10.2f}{bc:>8.2f}"
              f"{tc / bc:>7.2f}{counts[0]:>9}{counts[1]:>6}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
