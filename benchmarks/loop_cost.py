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
machine. Runs of 10 000 samples or more (``--duration 500`` and up) take the
compiled lane when numba is installed (``trainctl.sim._lane``); set
``TRAINCTL_COMPILED=0`` to time the Python loop, ``=1`` for any length.

``--floor`` measures instead, in this tree alone, the least a NumPy loop does per
sample for this law and plant: the recorded run replayed as (1) the plant's
one-sample map (``Plant.sample_map``: drag flows, the precomputed [Φ | Γ]
product, the dense points) alone, and (2) that plus the law's arithmetic (the
deviation from the recorded reference and feedforward, K x̃, the envelope at the
speeds and the clip) with every array preallocated, no check, no record and no
per-sample object. Measured on the 4-coach CRH2 train: about 10 µs for the plant
and 17 µs with the law, so the issue's 20 µs per sample leaves some 3 µs for
everything the loop must also do (saturation flags, the records, the divergence
and finiteness checks, the reference).
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


FLOOR = r"""
import json, sys, time
import numpy as np
from trainctl.design import build_design
from numpy._core.umath import clip
from trainctl.models.envelope import EnvelopeBounds
from trainctl.run import simulate_strategy, make_controller
from trainctl.scenario import load_scenario
from trainctl.sim.plant import Plant
duration, strategy, name = float(sys.argv[1]), sys.argv[2], sys.argv[3]
scenario = load_scenario(name).replace("simulation.duration", duration)
design = build_design(scenario)
result = simulate_strategy(scenario, strategy, design, warn=False)
controller = make_controller(scenario, strategy, design)
train = controller.train
n = train.n_vehicles
per = int(result.meta["dense_points_per_sample"])
plant = Plant(train=scenario.train, track=scenario.track)  # the run's plant
fast = plant.sample_map(result.meta["duration"] / len(result.statuses), per)
states, inputs = result.states, result.inputs
steps = inputs.shape[1]
vref = result.reference_speed[:-1]
ff = np.array([controller._split.single(max(v, 0.1), a)[0]
               for v, a in zip(vref, result.reference_acceleration[:-1])])
eff = np.array([controller._split.single(max(v, 0.1), a)[1]
                for v, a in zip(vref, result.reference_acceleration[:-1])])
K, bounds = controller.gain, EnvelopeBounds(train, enabled=True)
block = np.empty((2 * n, per))
dev, fb, u = np.empty(2 * n - 1), np.empty(n), np.empty(n)
speed, limits, low = np.empty(n), np.empty((2, n)), np.empty(n)

def plant_only():
    start = time.perf_counter()
    for k in range(steps):
        fast.advance(states[:, k], inputs[:, k], block)
    return (time.perf_counter() - start) / steps

def with_law():
    force, power, cap = bounds._at
    start = time.perf_counter()
    for k in range(steps):
        x = states[:, k]
        np.subtract(x[:n], vref[k], out=dev[:n])
        np.subtract(x[n : 2 * n - 1], eff[k], out=dev[n:])
        np.matmul(K, dev, out=fb)
        np.multiply(fb, 1e3, out=fb)
        np.subtract(ff[k], fb, out=u)
        np.abs(x[:n], out=speed)
        np.maximum(speed, 0.1, out=speed)
        np.divide(power, speed, out=limits)
        np.minimum(force, limits, out=limits)
        np.minimum(limits, cap, out=limits)
        np.negative(limits[0], out=low)
        clip(u, low, limits[1], out=u)
        fast.advance(x, inputs[:, k], block)
    return (time.perf_counter() - start) / steps

best = {"plant": min(plant_only() for _ in range(5)), "law": min(with_law() for _ in range(5))}
print(json.dumps({"samples": steps, **best}))
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
    parser.add_argument("--floor", action="store_true",
                        help="the NumPy floor per sample in this tree (module docstring)")
    args = parser.parse_args()
    if args.floor:
        out = subprocess.run([sys.executable, "-c", FLOOR, str(args.duration), args.strategy,
                              args.scenario], capture_output=True, text=True, cwd=HERE,
                             env=dict(os.environ, PYTHONPATH=str(HERE)))
        if out.returncode:
            raise SystemExit(f"the floor run failed:\n{out.stderr}")
        data = json.loads(out.stdout.strip().splitlines()[-1])
        print(f"load average {os.getloadavg()[0]:.2f}; {args.scenario} {args.strategy}, "
              f"{data['samples']} samples: plant map alone {1e6 * data['plant']:.1f} µs/sample, "
              f"with the law's arithmetic {1e6 * data['law']:.1f} µs/sample (best of 5)")
        return
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
