"""Source tags of scenario values, read from the file's comments (trainctl.scenario.tags)."""

from __future__ import annotations

import pytest

from trainctl.scenario import load_scenario, parse_scenario
from trainctl.scenario.tags import source_tags


def test_units_are_not_tags_and_the_last_source_group_wins() -> None:
    text = "\n".join([
        "[model]",
        "speed_kmh = 300.0  # speed [km/h] [recalled: timetable] [reconstructed: cruise]",
        "sample_time = 0.05  # T [s]",
        "prediction = 40  # P [steps] = 2 s [trainctl]",
        "[controller]",
        'note = "a # inside [paper] a string"  # [Li & Zheng p. 297]',
    ])
    tags = source_tags(text)
    assert tags == {"model.speed_kmh": "reconstructed: cruise",
                    "model.prediction": "trainctl",
                    "controller.note": "Li & Zheng p. 297"}


def test_array_tables_are_numbered_from_zero_and_dotted_keys_joined() -> None:
    text = "\n".join([
        "[[train.vehicle]]  # head [paper]",
        "mass_t = 1.0  # [seed 000]",
        "[[train.vehicle]]",
        "mass_t = 2.0  # [seed 001]",
        "[[track.section]]",
        "grade_permille = 3.0  # [spec §4]",
        "[train]",
        "coupler . stiffness_kn_per_m = 1.0  # [recalled]",
    ])
    assert source_tags(text) == {
        "train.vehicle[0]": "paper", "train.vehicle[0].mass_t": "seed 000",
        "train.vehicle[1].mass_t": "seed 001", "track.section[0].grade_permille": "spec §4",
        "train.coupler.stiffness_kn_per_m": "recalled"}


@pytest.mark.parametrize("name", ["crh2-potential", "heavy-haul-flocking"])
def test_seed_001_002_controller_keys_all_carry_a_source(name: str) -> None:
    """The reconstructed parts of seeds 001/002 stay visible: every [controller] key is tagged."""
    scenario = load_scenario(name)
    keys = [k for k, v in scenario.document["controller"].items() if not hasattr(v, "items")]
    assert keys
    missing = [k for k in keys if f"controller.{k}" not in scenario.tags]
    assert missing == []
    assert any("reconstructed" in scenario.tags[f"controller.{k}"] for k in keys)


def test_replace_drops_the_changed_key_only() -> None:
    scenario = load_scenario("crh2-potential")
    changed = scenario.replace("controller.kappa_per_s2", 1.0)
    assert "controller.kappa_per_s2" in scenario.tags
    assert "controller.kappa_per_s2" not in changed.tags
    assert changed.tags["controller.position_gain"] == scenario.tags["controller.position_gain"]
    gone = scenario.replace("simulation.strategies", ["consensus"]).replace("controller.mpc", None)
    assert not any(k.startswith("controller.mpc") for k in gone.tags)
    assert "controller.lqr.r_per_kn2" in gone.tags


def test_tags_do_not_change_equality() -> None:
    text = 'schema_version = 1\nname = "x"\ndescription = "y"\n[train]\npreset = "crh2_half"\n' \
           "[model]\nspeed_kmh = 200.0\nsample_time = 0.1\n"
    tagged = text.replace("sample_time = 0.1", "sample_time = 0.1  # [paper]")
    assert parse_scenario(tagged).tags == {"model.sample_time": "paper"}
    assert parse_scenario(tagged) == parse_scenario(text)
