"""A student's script: load the assignment scenario, review it, simulate one strategy.

Run it from the course repository's root, next to ``scenario.toml``::

    python student.py             # the scenario's whole simulation (60 s)
    python student.py --short     # 10 s, for a quick check (CI uses this)

Every number it prints carries its unit; everything inside trainctl is SI.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import trainctl
from trainctl.analysis import review_design
from trainctl.run import simulate_strategy
from trainctl.sim import compute_metrics

HERE = Path(__file__).resolve().parent


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", default=str(HERE / "scenario.toml"),
                        help="the scenario file (default: scenario.toml beside this script)")
    parser.add_argument("--strategy", default="ndmpc", help="strategy to simulate")
    parser.add_argument("--short", action="store_true", help="simulate 10 s only")
    args = parser.parse_args(argv)

    scenario = trainctl.load_scenario(Path(args.scenario))
    print(f"scenario: {scenario.name}")
    print(f"train: {scenario.train.n_vehicles} vehicles, {scenario.train.mass.sum() / 1e3:.1f} t; "
          f"T = {scenario.model.sample_time:g} s")

    # 1. The design review: every check with its status and message.
    review = review_design(scenario)
    for check in review.checks:
        print(f"  {check.name:<30s} {check.status:<4s} {check.message}")
    conv = review.check("ndmpc_convergence")
    print(f"rho(D0) = {conv.value:.4f} (converges below 1)")

    # 2. One strategy on the nonlinear train (shortened with --short).
    if args.short:
        scenario = scenario.replace("simulation.settle_time", 5.0).replace(
            "simulation.duration", 10.0)
    result = simulate_strategy(scenario, args.strategy)
    settle = scenario.simulation.settle_time
    metrics = compute_metrics(result, settle_time=settle)
    print(f"simulated {args.strategy} for {result.time[-1]:g} s")
    print(f"max speed error after {settle:g} s = {np.max(metrics.max_error):.3g} m/s")
    print(f"max |coupler force| = {np.abs(result.coupler_forces).max() / 1e3:.2f} kN")
    print(f"solver statuses: {sorted(set(result.statuses))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
