"""Benchmark: the per-sample cost of Plant.advance (the simulated plant).

Run:  .venv/bin/python benchmarks/plant_advance.py [--repeats 7] [--json PATH]

Cases (warm caches; each timed as the best of ``--repeats`` batches, per sample):

  crh2 flat      CRH2 half train, level track, T = 0.05 s and T = 20 s
  crh2 track     the same on a track with a grade change every 200 m
  hh204 flat     the 204-vehicle 1+2+1 heavy-haul chain, T = 0.05 s and 20 s
  hh204 track    the same with a section boundary every 2 km

The hh204 cases run on the plant's default propagators (banded from 128
vehicles on, since the banded plant); ``benchmarks/plant_banded.py`` times the
dense and banded paths side by side.

Each batch starts from the same state (cruise plus a small disturbance, with
an accelerating input so the drag linearisation speed moves), and advances it
sample after sample. The script imports ``trainctl.sim.Plant``, which exists
before and after the plant moved to ``trainctl.models``, so the same script
measures both.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from trainctl.models import Track, TrackSection, crh2_half, equilibrium, heavy_haul_1p2p1
from trainctl.sim import Plant


def _track(spacing: float, count: int) -> Track:
    return Track(sections=tuple(
        TrackSection(start=spacing * i, grade_permille=3.0 * ((-1) ** i)) for i in range(count)
    ))


def cases() -> list[tuple[str, Plant, np.ndarray, np.ndarray, float, int]]:
    """(name, plant, initial state, inputs, T, samples per batch) for every case."""
    out = []
    crh2 = crh2_half()
    hh = heavy_haul_1p2p1(detail="full")
    for label, train, speed, tracks in (
        ("crh2", crh2, 80.0, (None, _track(200.0, 2000))),
        ("hh204", hh, 20.0, (None, _track(2000.0, 200))),
    ):
        eq = equilibrium(train, speed, allocation="own")
        n = train.n_vehicles
        x0 = eq.state(position=100.0)
        x0[:n] += 0.01 * np.sin(np.arange(n))
        u = eq.inputs + 0.05 * train.mass  # accelerate at ~0.05 m/s²
        for track in tracks:
            plant = Plant(train=train, track=track)
            name = f"{label} {'flat' if track is None else 'track'}"
            for dt in (0.05, 20.0):
                if dt < 1:
                    samples = 200 if label == "crh2" else 100
                else:
                    samples = 5 if label == "crh2" else 1
                out.append((name, plant, x0, u, dt, samples))
    return out


def time_case(plant: Plant, x0: np.ndarray, u: np.ndarray, dt: float, samples: int,
              repeats: int) -> float:
    """Best per-sample time [s] over ``repeats`` batches of ``samples`` samples."""
    x = x0
    for _ in range(samples):  # warm every propagator the batch will use
        x = plant.advance(x, u, dt)
    best = float("inf")
    for _ in range(repeats):
        x = x0
        start = time.perf_counter()
        for _ in range(samples):
            x = plant.advance(x, u, dt)
        best = min(best, (time.perf_counter() - start) / samples)
    return best


def main() -> None:
    """Time every case and print a table (µs per sample)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--json", help="also write the numbers to this file")
    args = parser.parse_args()
    results = {}
    print(f"{'case':<14} {'T [s]':>6} {'µs per sample':>15}")
    for name, plant, x0, u, dt, samples in cases():
        seconds = time_case(plant, x0, u, dt, samples, args.repeats)
        results[f"{name} T={dt:g}"] = seconds * 1e6
        print(f"{name:<14} {dt:>6g} {seconds * 1e6:>15.1f}", flush=True)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(results, fh, indent=1)


if __name__ == "__main__":
    main()
