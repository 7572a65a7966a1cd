"""Benchmark: batched against serial Monte-Carlo, heavy-haul-hinf-delay's 80 runs.

Run:  .venv/bin/python benchmarks/batch_mc.py [--duration 300] [--seeds 20] [--rounds 3]

The scenario's repetitions: for each of its two strategies (the distributed
H-infinity law and synchronous operation), ``--seeds`` network seeds over the
0-2 s random delays and the same seeds over the delay-free baseline network,
2 x 2 x 20 = 80 runs. ``serial`` simulates them one by one
(:func:`trainctl.run.simulate.simulate_strategy`, as the repetitions did);
``batched`` simulates each strategy's 40 runs as one batch
(:func:`trainctl.run.simulate.simulate_batch_strategy`). The two run
interleaved (serial, batched, serial, ...) ``--rounds`` times; the ratio of
the medians is reported, in wall-clock and in CPU seconds of this process
(the machine may be shared). The runs are shortened to ``--duration``
seconds (1800 s: the whole run; the cost of both is linear in the duration,
the batch's fixed part aside), and the script checks that every batched run's
speeds equal the serial run's bit for bit.

Measured (2-core machine shared with other jobs, load 6-15;
``--duration 300 --rounds 2``): serial 89.8 / 88.4 s CPU, batched 4.4 / 4.2 s
CPU, median ratio 20.7x in CPU time and 27.6x in wall-clock time (596 s
against 21.5 s); every batched run's speeds equal the serial ones.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

import trainctl
from trainctl.design import build_design
from trainctl.run.repetitions import BASELINE, repetition_scenario
from trainctl.run.simulate import simulate_batch_strategy, simulate_strategy


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=300.0)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    scenario = (trainctl.load_scenario("heavy-haul-hinf-delay")
                .replace("simulation.settle_time", args.duration / 2)
                .replace("simulation.duration", args.duration))
    design = build_design(scenario)
    assert scenario.simulation is not None
    strategies = scenario.simulation.strategies
    indices = [*range(args.seeds), *(BASELINE - r for r in range(args.seeds))]
    runs = [repetition_scenario(scenario, i) for i in indices]
    for strategy in strategies:  # warm the caches (propagators, ziggurat tables)
        simulate_strategy(runs[0], strategy, design, warn=False)
        simulate_batch_strategy(runs[:2], strategy, design)

    def serial() -> list[np.ndarray]:
        return [simulate_strategy(run, s, design, warn=False).velocities
                for s in strategies for run in runs]

    def batched() -> list[np.ndarray]:
        out = []
        for s in strategies:
            results = simulate_batch_strategy(runs, s, design)
            assert results is not None, s
            out += [r.velocities for r in results]
        return out

    times: dict[str, list[tuple[float, float]]] = {"serial": [], "batched": []}
    speeds: dict[str, list[np.ndarray]] = {}
    for k in range(args.rounds):
        for name, run in (("serial", serial), ("batched", batched)):
            wall, cpu = time.perf_counter(), time.process_time()
            speeds[name] = run()
            times[name].append((time.perf_counter() - wall, time.process_time() - cpu))
            print(f"round {k + 1} {name:8s} wall {times[name][-1][0]:8.2f} s  "
                  f"cpu {times[name][-1][1]:8.2f} s  (load {os.getloadavg()[0]:.1f})")
    same = all(np.array_equal(a, b) for a, b in zip(speeds["serial"], speeds["batched"],
                                                    strict=True))
    print(f"{len(speeds['serial'])} runs of {args.duration:g} s; batched speeds equal the "
          f"serial ones bit for bit: {same}")
    for i, label in enumerate(("wall", "cpu")):
        a = statistics.median(t[i] for t in times["serial"])
        b = statistics.median(t[i] for t in times["batched"])
        print(f"median {label}: serial {a:.2f} s, batched {b:.2f} s, ratio {a / b:.1f}x")


if __name__ == "__main__":
    main()
