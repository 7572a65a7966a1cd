"""The 204-vehicle heavy-haul chain under MPC, in a short version.

The scenario is ``benchmarks/scenarios/heavy-haul-204-ndmpc.toml``; its full
run (600 s, 6000 samples, both strategies) and its whole design review are a
benchmark (``benchmarks/hh204.py``); here 5 s of it: both strategies build,
track and solve every step to optimality, and only the four locomotives apply
a force.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from trainctl.controllers.mpc.controller import fixed_inputs
from trainctl.design import build_design
from trainctl.design.review import scenario_checks
from trainctl.run.analysis import make_controller, simulate_strategy
from trainctl.scenario import load_scenario

SCENARIO = str(Path(__file__).resolve().parents[1] / "benchmarks" / "scenarios"
               / "heavy-haul-204-ndmpc.toml")
LOCOS = [0, 101, 102, 203]


@pytest.fixture(scope="module")
def short():
    """The scenario cut to 5 s (tracking judged from the start), and its design."""
    scenario = (load_scenario(SCENARIO).replace("simulation.settle_time", 0.0)
                .replace("simulation.duration", 5.0))
    return scenario, build_design(scenario)


def test_the_train_is_the_full_chain(short) -> None:
    """204 vehicles, locomotives at 0, 101, 102, 203; every wagon's force pinned at 0."""
    scenario, design = short
    train = scenario.train
    assert train.n_vehicles == 204
    assert [i for i, v in enumerate(train.vehicles) if v.name == "SS4B"] == LOCOS
    fam = design.family("mpc")
    pinned = fixed_inputs(train, fam.mpc, fam.settings.mpc_constraints())
    assert pinned == tuple(i for i in range(204) if i not in LOCOS)


@pytest.mark.parametrize("strategy", ["decentralised", "ndmpc-local"])
def test_short_run_tracks(short, strategy: str) -> None:
    """5 s of each strategy: every step optimal, speeds on the reference, wagons unforced."""
    scenario, design = short
    controller = make_controller(scenario, strategy, design)
    if strategy == "decentralised":  # no QP for a pinned coach
        assert sorted(b.inputs[0] for b in controller.blocks) == LOCOS
    result = simulate_strategy(scenario, strategy, design)
    assert result.n_samples == 50
    counts = result.status_counts()
    assert counts["optimal"] == 50, counts
    assert result.divergence is None
    error = np.abs(result.velocities - result.reference_speed[None, :])
    assert error.max() < 0.05
    wagons = [i for i in range(204) if i not in LOCOS]
    assert np.all(result.inputs[wagons] == 0.0)
    assert np.all(np.isfinite(result.inputs[LOCOS]))


def test_scenario_checks_pass(short) -> None:
    """Feasibility and plausibility (the review's cheap part; the whole review takes minutes)."""
    scenario, _ = short
    found = {c.name: c.status for c in scenario_checks(scenario)}
    assert found == {"feasibility": "pass", "plausibility": "pass"}
    assert {k: scenario.expected[k] for k in found} == found
