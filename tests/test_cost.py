"""A run's operating cost at the ``[cost]`` prices (:func:`trainctl.sim.energy.operating_cost`).

Checked against the hand formula on the run's own energy account and duration:
cost = energy_price · net kWh / drive_efficiency + train_hour_price · trains · hours,
with a virtually coupled formation counting each unit train.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.test_cli import assert_refused
from trainctl.cli.main import main
from trainctl.exceptions import ModelError
from trainctl.run.simulate import simulate_strategy
from trainctl.scenario import builtin_scenario_text, load_scenario, parse_scenario
from trainctl.sim import compute_metrics, energy_account
from trainctl.sim.energy import operating_cost, trains_in

PRICES = "\n[cost]\nenergy_price = 0.15\ntrain_hour_price = 420.0\ndrive_efficiency = 0.85\n" \
         'currency = "CHF"\n'


@pytest.mark.parametrize("name, strategy, duration, trains", [
    ("crh2-dmpc", "ndmpc", 400.0, 1),
    ("heavy-haul-flocking", "flocking", 300.0, 4),
])
def test_cost_is_the_hand_formula_on_the_run(name: str, strategy: str, duration: float,
                                             trains: int) -> None:
    base = load_scenario(name)
    text = builtin_scenario_text(name) + PRICES
    scenario = parse_scenario(text).replace("simulation.settle_time", duration / 2) \
        .replace("simulation.duration", duration)
    assert scenario.cost is not None and base.cost is None
    result = simulate_strategy(scenario, strategy, warn=False)
    metrics = compute_metrics(result, settle_time=duration / 2, train=scenario.train,
                              track=scenario.track, cost=scenario.cost,
                              regen_efficiency=scenario.simulation.regen_efficiency)
    account = energy_account(result, scenario.train, scenario.track,
                             regen_efficiency=scenario.simulation.regen_efficiency)
    kwh = float(np.sum(account.net_energy)) / 3.6e6
    hours = trains * duration / 3600.0
    cost = metrics.operating_cost
    assert cost is not None and trains_in(scenario.train) == trains
    assert cost.supply_energy == pytest.approx(kwh / 0.85, rel=1e-12)
    assert cost.train_hours == pytest.approx(hours, rel=1e-12)
    assert cost.total == pytest.approx(0.15 * kwh / 0.85 + 420.0 * hours, rel=1e-12)
    assert cost.currency == "CHF"
    assert metrics.to_dict()["operating_cost"]["total"] == cost.total
    assert compute_metrics(result, settle_time=duration / 2).operating_cost is None


def test_analyse_json_carries_the_cost(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "priced.toml"
    path.write_text(builtin_scenario_text("crh2-dmpc") + PRICES)
    assert main(["analyse", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    found = [m["operating_cost"] for m in doc["simulations"].values()]
    assert len(found) == 3 and all(c["currency"] == "CHF" and c["total"] > 0 for c in found)


@pytest.mark.parametrize("line, message", [
    ("drive_efficiency = 0.0", "[cost].drive_efficiency must be"),
    ("energy_price = -1.0", "[cost].energy_price must be"),
    ("price = 1.0", "unknown key"),
])
def test_bad_prices_are_refused(line: str, message: str, tmp_path: Path,
                                capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(builtin_scenario_text("crh2-dmpc") + f"\n[cost]\n{line}\n")
    assert_refused(path, message, capsys)


def test_operating_cost_refuses_bad_arguments() -> None:
    class Account:
        def total(self, name: str) -> float:
            return 3.6e6

    with pytest.raises(ModelError, match="'trains' must be a whole number >= 1"):
        operating_cost(Account(), duration=10.0, trains=0, energy_price=1.0,
                       train_hour_price=1.0)
    with pytest.raises(ModelError, match="'duration' must be >= 0"):
        operating_cost(Account(), duration=-1.0, trains=1, energy_price=1.0,
                       train_hour_price=1.0)
    with pytest.raises(ModelError, match="'drive_efficiency' must be in"):
        operating_cost(Account(), duration=1.0, trains=1, energy_price=1.0,
                       train_hour_price=1.0, drive_efficiency=1.5)
