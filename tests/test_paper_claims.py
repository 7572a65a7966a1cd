"""Seeds 000 and 001's claims tables (``trainctl.controllers.mpc.claims``, ``...potential.claims``).

The rules are checked on stand-in runs whose metrics sit on either side of
each threshold; one short run of each seed's scenario checks that the claims
reach the run (and that each claim's number is the metric it names).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from trainctl.controllers.mpc.claims import mpc_claims
from trainctl.controllers.potential.claims import potential_claims
from trainctl.models import crh2_half, equilibrium


def _mpc_run(errors: dict[str, float], rms: dict[str, float], saturation: float = 0.0,
             peak: float = 10e3, limit: float = 500e3) -> SimpleNamespace:
    metrics = {s: SimpleNamespace(max_error=np.array([e, e / 2]), rms_error=np.array([rms[s]]),
                                  saturation_time=np.array([0.0, saturation]),
                                  max_coupler_force=peak) for s, e in errors.items()}
    return SimpleNamespace(
        simulations=dict.fromkeys(errors), metrics=metrics,
        scenario=SimpleNamespace(simulation=SimpleNamespace(settle_time=100.0,
                                                            tracking_tolerance=1.0)),
        design=SimpleNamespace(families={"mpc": SimpleNamespace(
            settings=SimpleNamespace(coupler_force_limit=limit))}))


def _kinds(claims) -> dict[str, str]:
    return {c.key: c.kind for c in claims}


def test_seed_000_rules_on_either_side_of_their_thresholds() -> None:
    good = _mpc_run({"centralised": 0.5, "ndmpc": 0.9}, {"centralised": 0.10, "ndmpc": 0.109})
    assert _kinds(mpc_claims(good)) == dict.fromkeys(
        ["tracking", "traction_range", "coupler_forces", "neighbourhood_vs_global"],
        "reproduced")
    bad = _mpc_run({"centralised": 0.5, "ndmpc": 1.1}, {"centralised": 0.10, "ndmpc": 0.12},
                   saturation=3.0, peak=501e3)
    assert set(_kinds(mpc_claims(bad)).values()) == {"not reproduced"}
    near_zero = _mpc_run({"centralised": 0.1, "ndmpc": 0.1}, {"centralised": 1e-4, "ndmpc": 4e-3})
    assert _kinds(mpc_claims(near_zero))["neighbourhood_vs_global"] == "reproduced"  # 4 mm/s
    unbounded = _mpc_run({"ndmpc": 0.1}, {"ndmpc": 0.1}, limit=np.inf)
    kinds = _kinds(mpc_claims(unbounded))
    assert kinds["coupler_forces"] == "not reproduced" and "neighbourhood_vs_global" not in kinds


def test_seed_000_claims_of_a_short_run() -> None:
    from trainctl.run import run_scenario
    from trainctl.scenario import load_scenario

    scenario = load_scenario("crh2-dmpc").replace("simulation.duration", 400.0)
    run = run_scenario(scenario.replace("simulation.strategies", ["centralised", "ndmpc"]))
    claims = {c.key: c for c in run.claims}
    assert {"tracking", "traction_range", "coupler_forces", "neighbourhood_vs_global"} <= set(
        claims)
    worst = float(np.max(run.metrics["ndmpc"].max_error))
    assert f"ndmpc {worst:.3g} m/s" in claims["tracking"].trainctl


def _potential_run(end_offset: float, input_offset: float) -> SimpleNamespace:
    train = crh2_half()
    n, eq = 4, equilibrium(train, 80.0)
    steps = 50
    states = np.tile(np.concatenate([eq.state(), [0.0]])[:, None], (1, steps + 1))
    states[n:2 * n - 1, 0] += 0.5  # the run starts off the equilibrium spacings
    states[n:2 * n - 1, -1] += end_offset
    inputs = np.tile(eq.inputs[:, None], (1, steps))
    inputs[:, -1] += input_offset
    result = SimpleNamespace(states=states, inputs=inputs, reference_speed=np.full(steps + 1, 80.0))
    return SimpleNamespace(
        simulations={"consensus": result},
        metrics={"consensus": SimpleNamespace(max_error=np.array([0.01]))},
        scenario=SimpleNamespace(train=train, simulation=SimpleNamespace(
            settle_time=10.0, tracking_tolerance=1.0)))


def test_seed_001_rules_on_either_side_of_their_thresholds() -> None:
    eq = equilibrium(crh2_half(), 80.0)
    scale = float(np.max(np.abs(eq.inputs)))
    assert set(_kinds(potential_claims(_potential_run(0.004, 0.009 * scale))).values()) == {
        "reproduced"}  # 0.4 % of the 0.5 m start; 0.9 % of the cruise force
    kinds = _kinds(potential_claims(_potential_run(0.006, 0.011 * scale)))
    assert kinds == {"tracking": "reproduced", "spacing": "not reproduced",
                     "inputs": "not reproduced"}


@pytest.mark.parametrize("primary, other", [("mpc", "potential")])
def test_claims_only_for_the_primary_family(primary: str, other: str) -> None:
    from trainctl.registry import get_family

    run = SimpleNamespace(design=SimpleNamespace(families={other: None, primary: None}))
    assert get_family(primary).claims(run) == []
