# The closed loop's cost per sample with a solver-free law (LQR), new tree against main.
"""LQR closed-loop cost per sample: this tree against a baseline tree, side by side.

Usage::

    python benchmarks/loop_cost.py [--base /work/main] [--duration 200] [--rounds 5]
                                   [--strategy lqr.centralised]
                                   [--scenario crh2-dmpc-well-sampled]

Each round runs one subprocess per tree (``PYTHONPATH`` switched to that
tree, base first then new, interleaved round by round) that loads
``crh2-dmpc-well-sampled`` (T = 0.05 s, 4 coaches), shortens it to
``--duration`` seconds, builds the design and simulates the strategy once to
warm the caches, then times a second run. Printed per round: the loop's wall
time per sample [µs] (``meta["wall_time"]``, the samples only) and its share
spent in the controller's step (``solve_times``) and the process's CPU time per
sample of the whole timed run (``time.process_time``: less disturbed by other
processes than the wall clock, on a loaded machine); then the medians and the
ratio new / base of the medians, and of the best rounds (the least disturbed).
The machine's load average is printed too: the timings are only as quiet as the
machine.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, sys
from trainctl.design import build_design
from trainctl.run import simulate_strategy
from trainctl.scenario import load_scenario
duration, strategy, name = float(sys.argv[1]), sys.argv[2], sys.argv[3]
scenario = load_scenario(name).replace("simulation.duration", duration)
design = build_design(scenario)
import time
simulate_strategy(scenario, strategy, design, warn=False)  # warm the caches
cpu = time.process_time()
result = simulate_strategy(scenario, strategy, design, warn=False)
cpu = time.process_time() - cpu
samples = len(result.statuses)
print(json.dumps({"samples": samples, "loop": result.meta["wall_time"] / samples,
                  "cpu": cpu / samples,
                  "controller": float(result.solve_times.sum()) / samples}))
"""


def _run(tree: Path, duration: float, strategy: str, scenario: str) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run([sys.executable, "-c", CHILD, str(duration), strategy, scenario], env=env,
                         capture_output=True, text=True, cwd=tree)
    if out.returncode:
        raise SystemExit(f"{tree}: the run failed:\n{out.stderr}")
    data: dict[str, float] = json.loads(out.stdout.strip().splitlines()[-1])
    return data


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, default=Path("/work/main"))
    parser.add_argument("--duration", type=float, default=200.0)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--strategy", default="lqr.centralised")
    parser.add_argument("--scenario", default="crh2-dmpc-well-sampled",
                        help="e.g. crh2-potential with --strategy consensus --duration 70")
    args = parser.parse_args()
    trees = {"base": args.base.resolve(), "new": HERE}
    loops: dict[str, list[float]] = {"base": [], "new": []}
    cpus: dict[str, list[float]] = {"base": [], "new": []}
    print(f"load average {os.getloadavg()[0]:.2f}; {args.scenario} {args.strategy}, "
          f"{args.duration:g} s")
    for r in range(args.rounds):
        line = []
        for name, tree in trees.items():
            data = _run(tree, args.duration, args.strategy, args.scenario)
            loops[name].append(data["loop"])
            cpus[name].append(data["cpu"])
            line.append(f"{name} {1e6 * data['loop']:7.1f} µs/sample "
                        f"(controller {1e6 * data['controller']:5.1f}, "
                        f"CPU {1e6 * data['cpu']:6.1f})")
        print(f"round {r + 1}: " + "; ".join(line))
    base, new = (statistics.median(loops[k]) for k in ("base", "new"))
    print(f"median: base {1e6 * base:.1f} µs/sample, new {1e6 * new:.1f} µs/sample, "
          f"new/base {new / base:.3f}; load average {os.getloadavg()[0]:.2f}")
    best_base, best_new = min(loops["base"]), min(loops["new"])
    cpu_base, cpu_new = (statistics.median(cpus[k]) for k in ("base", "new"))
    print(f"median CPU time of the whole run: base {1e6 * cpu_base:.1f} µs/sample, "
          f"new {1e6 * cpu_new:.1f} µs/sample, new/base {cpu_new / cpu_base:.3f}")
    print(f"best: base {1e6 * best_base:.1f} µs/sample, new {1e6 * best_new:.1f} µs/sample, "
          f"new/base {best_new / best_base:.3f}")


if __name__ == "__main__":
    main()
