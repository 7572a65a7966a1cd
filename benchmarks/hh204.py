"""Benchmark: the 204-vehicle heavy-haul chain under MPC (heavy-haul-204-ndmpc).

Run:  .venv/bin/python benchmarks/hh204.py [--duration S] [--review]

The scenario benchmarks/scenarios/heavy-haul-204-ndmpc.toml (run it with
``trainctl analyse benchmarks/scenarios/heavy-haul-204-ndmpc.toml``): with
--review, its whole design review first (timed, statuses against its
[expected]); then its closed loops (1+2+1 train, one agent per vehicle, T = 0.1 s,
P = 10, M = 3, 600 s by default: 6000 samples), one strategy after the other
in this process: ``decentralised`` (the baseline: one QP per locomotive, no
exchange) and ``ndmpc-local`` (neighbourhood-local N-DMPC: every coach
exchanges its predicted trajectory; only the locomotives solve a QP, the
wagons' forces are pinned at 0 by their envelope). Printed per strategy: the
controller's build time, the closed loop's total, the time per step (total /
samples) and the controller's own share (the recorded solve times), mean
iterations, statuses — and each as a ratio to the baseline measured in the
same run (the machine's load cancels, to first order).

Target (issue 14): the N-DMPC closed loop, 10 min simulated, under 2 minutes
on a quiet machine.

Measured 2026-11-30 on the shared 2-core machine under load (other jobs
running, OPENBLAS_NUM_THREADS=1), 600 s simulated, every step optimal, largest
speed error 0.029 m/s for both:

  decentralised  build 2.6 s  closed loop  20.8 s   3.5 ms/step (controller  2.2)
  ndmpc-local    build 2.7 s  closed loop 116.0 s  19.3 ms/step (controller 17.8),
                 1.42 iterations per step on average, at most 4
  ratios ndmpc-local / decentralised: closed loop 5.6, controller per step 8.2

With several BLAS threads on a loaded machine every eigenproblem and matrix
product slowed by up to 100× (eig of a 407 × 407 matrix: 12 s against 0.14 s
on one thread); hence the default above.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # threads thrash on a loaded machine

import numpy as np  # noqa: E402

import trainctl.run.analysis as run  # noqa: E402
from trainctl.design import build_design  # noqa: E402
from trainctl.design.review import review_design  # noqa: E402
from trainctl.scenario import load_scenario  # noqa: E402

SCENARIO = str(Path(__file__).resolve().parent / "scenarios" / "heavy-haul-204-ndmpc.toml")
STRATEGIES = ("decentralised", "ndmpc-local")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=600.0, help="simulated time [s]")
    parser.add_argument("--review", action="store_true",
                        help="also time the whole design review and compare it with [expected]")
    args = parser.parse_args()
    scenario = load_scenario(SCENARIO)
    if args.duration != scenario.simulation.duration:
        settle = min(scenario.simulation.settle_time, 0.5 * args.duration)
        scenario = (scenario.replace("simulation.settle_time", settle)
                    .replace("simulation.duration", args.duration))
    start = time.perf_counter()
    design = build_design(scenario)
    print(f"heavy-haul-204-ndmpc: {scenario.train.n_vehicles} vehicles, {args.duration:g} s "
          f"simulated; design built in {time.perf_counter() - start:.2f} s")
    if args.review:
        start = time.perf_counter()
        review = review_design(scenario, design)
        found = {c.name: c.status for c in review.checks}
        wrong = {k: (v, found.get(k)) for k, v in scenario.expected.items() if found.get(k) != v}
        print(f"  design review {time.perf_counter() - start:.1f} s, {len(found)} checks; "
              f"[expected]: {'all match' if not wrong else wrong}")
    rows = {}
    for strategy in STRATEGIES:
        start = time.perf_counter()
        controller = run.make_controller(scenario, strategy, design)
        build = time.perf_counter() - start
        made = run.make_controller
        run.make_controller = lambda *a, _c=controller, **k: _c  # reuse the built one
        try:
            start = time.perf_counter()
            result = run.simulate_strategy(scenario, strategy, design)
            total = time.perf_counter() - start
        finally:
            run.make_controller = made
        n = result.n_samples
        solve = float(np.sum(result.solve_times))
        error = np.abs(result.velocities - result.reference_speed[None, :]).max()
        rows[strategy] = (build, total, total / n, solve / n, float(np.mean(result.iterations)))
        print(f"  {strategy:14} build {build:6.2f} s  closed loop {total:7.2f} s  "
              f"{1e3 * total / n:6.2f} ms/step (controller {1e3 * solve / n:6.2f})  "
              f"iterations mean {np.mean(result.iterations):.2f} max {np.max(result.iterations)}  "
              f"max |v - v_ref| {error:.3g} m/s  {result.status_counts()}")
    base = rows[STRATEGIES[0]]
    print(f"ratios to {STRATEGIES[0]} (build, closed loop, per step, controller per step):")
    for strategy in STRATEGIES[1:]:
        r = rows[strategy]
        print(f"  {strategy:14} " + "  ".join(f"{a / b:6.2f}" for a, b in zip(r[:4], base[:4],
                                                                               strict=True)))


if __name__ == "__main__":
    main()
