"""Benchmark: dense against banded propagators of Plant, side by side.

Run:  .venv/bin/python benchmarks/plant_banded.py [--repeats 5] [--hour] [--json PATH]

Two parts, each timing ``Plant(propagation="dense")`` and
``Plant(propagation="banded")`` interleaved in the same process (batches
alternate), so that a shared, loaded machine slows both alike and the
*ratios* are meaningful even when absolute times are not:

  per substep   chains of 4 (CRH2 half train), 16, 64 and 204 vehicles (the
                1+2+1 heavy-haul formation with 6, 30 and 100 wagons per
                group), level track, T = 1 s (20 substeps of 0.05 s), warm
                caches: best of ``--repeats`` batches, µs per substep.
  1 h run       (--hour) the 204-vehicle chain for 3600 s at T = 1 s (72 000
                substeps), cold caches, a speed law tracking 15 → 25 → 18 m/s
                (so the drag linearisation speed visits ~7 grid speeds), on
                level track and on a track with a grade change every 2 km
                (~7000 vehicle crossings): total seconds, and the largest
                speed difference between the two paths.

OpenBLAS threads: on a machine shared with other jobs, multi-threaded BLAS
makes small dense operations erratic (a 12 x 12 expm took 16 ms instead of
0.05 ms under load); set OPENBLAS_NUM_THREADS=1 for stable numbers.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from trainctl.models import (
    Plant,
    Track,
    TrackSection,
    Train,
    crh2_half,
    equilibrium,
    heavy_haul_1p2p1,
)

MODES = ("dense", "banded")


def trains(sizes: tuple[int, ...] = (4, 16, 64, 204)) -> list[Train]:
    """Chains of the given numbers of vehicles: 4 is the CRH2 half train, the others
    (even, >= 8) the 1+2+1 heavy-haul formation with (n - 4) / 2 wagons per group."""
    return [crh2_half() if n == 4
            else heavy_haul_1p2p1(detail="full", wagons_per_group=(n - 4) // 2) for n in sizes]


def start(train: Train, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """Cruise at ``speed`` [m/s] with a small disturbance, and an accelerating input [N]."""
    n = train.n_vehicles
    eq = equilibrium(train, speed, allocation="own")
    x0 = eq.state(position=100.0)
    x0[:n] += 0.01 * np.sin(np.arange(n))
    return x0, eq.inputs + 0.02 * train.mass


def per_substep(repeats: int, sizes: tuple[int, ...] = (4, 16, 64, 204)) -> dict[str, float]:
    """µs per substep, dense and banded, for every chain (warm caches, interleaved)."""
    out: dict[str, float] = {}
    print(f"{'vehicles':>8} {'dense µs':>10} {'banded µs':>10} {'dense/banded':>13}")
    for train in trains(sizes):
        n = train.n_vehicles
        x0, u = start(train, 20.0)
        plants = {mode: Plant(train=train, propagation=mode) for mode in MODES}
        samples = max(2, 400 // n)
        for plant in plants.values():  # warm: every propagator the batches use
            x = x0
            for _ in range(samples):
                x = plant.advance(x, u, 1.0)
        best = dict.fromkeys(MODES, float("inf"))
        for _ in range(repeats):
            for mode, plant in plants.items():
                x = x0
                t0 = time.perf_counter()
                for _ in range(samples):
                    x = plant.advance(x, u, 1.0)
                best[mode] = min(best[mode], (time.perf_counter() - t0) / (20 * samples))
        for mode in MODES:
            out[f"{mode} n={n}"] = best[mode] * 1e6
        print(f"{n:>8} {best['dense'] * 1e6:>10.1f} {best['banded'] * 1e6:>10.1f} "
              f"{best['dense'] / best['banded']:>13.2f}", flush=True)
    return out


def reference_speed(t: float) -> float:
    """The speed law's target [m/s] at t [s]: 15, up to 25, down to 18."""
    return float(np.interp(t, [0.0, 600.0, 1500.0, 2700.0, 3600.0], [15.0, 15.0, 25.0, 18.0, 18.0]))


def hour(duration: float = 3600.0, grades: bool = True, vehicles: int = 204,
         verbose: bool = True) -> dict[str, float]:
    """The 1 h run of a chain of ``vehicles`` (default the 204-vehicle one, see :func:`trains`),
    both paths interleaved sample by sample, on a track with a grade change every 2 km
    (``grades``) or on level track."""
    train = trains((vehicles,))[0]
    n = train.n_vehicles
    track = Track(sections=tuple(
        TrackSection(start=2000.0 * i, grade_permille=3.0 * ((-1) ** i)) for i in range(60)
    )) if grades else None
    x0, _ = start(train, 15.0)
    plants = {mode: Plant(train=train, track=track, propagation=mode) for mode in MODES}
    states = dict.fromkeys(MODES, x0)
    spent = dict.fromkeys(MODES, 0.0)
    a0, a1, a2 = train.davis
    worst = 0.0
    for k in range(int(round(duration))):
        target = reference_speed(float(k))
        for mode in MODES:
            x = states[mode]
            v = x[:n]
            u = train.mass * (a0 + a1 * v + a2 * v * v + 0.05 * (target - v))
            t0 = time.perf_counter()
            states[mode] = plants[mode].advance(x, u, 1.0)
            spent[mode] += time.perf_counter() - t0
        worst = max(worst, float(np.abs(states["dense"][:n] - states["banded"][:n]).max()))
    end = states["banded"]
    tag = "grades" if grades else "level"
    out = {f"hour {tag} dense s": spent["dense"], f"hour {tag} banded s": spent["banded"],
           f"hour {tag} max dv": worst, f"hour {tag} km": float(end[-1]) / 1e3}
    if not verbose:
        return out
    where = "grade change every 2 km" if grades else "level track"
    print(f"1 h of the {n}-vehicle chain ({int(duration)} s at T = 1 s, "
          f"{int(duration) * 20} substeps, cold caches, {end[-1] / 1e3:.1f} km, {where}):")
    print(f"  dense {spent['dense']:.2f} s   banded {spent['banded']:.2f} s   "
          f"dense/banded {spent['dense'] / spent['banded']:.2f}")
    print(f"  per substep: dense {spent['dense'] / (20 * duration) * 1e6:.0f} µs, "
          f"banded {spent['banded'] / (20 * duration) * 1e6:.0f} µs; "
          f"max |v_dense - v_banded| over the run {worst:.1e} m/s")
    return out


def main() -> None:
    """Time both parts and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--hour", action="store_true", help="also the 1 h run (slow: dense)")
    parser.add_argument("--seconds", type=float, default=3600.0,
                        help="duration of the --hour run [s] (default 3600)")
    parser.add_argument("--sizes", default="4,16,64,204",
                        help="vehicles per chain, comma-separated (default 4,16,64,204)")
    parser.add_argument("--json", help="also write the numbers to this file")
    args = parser.parse_args()
    results = per_substep(args.repeats, tuple(int(s) for s in args.sizes.split(",")))
    if args.hour:
        results.update(hour(args.seconds, grades=False))
        results.update(hour(args.seconds, grades=True))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(results, fh, indent=1)


if __name__ == "__main__":
    main()
