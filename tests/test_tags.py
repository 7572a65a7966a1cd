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


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_report_settings_show_the_sources() -> None:
    """The report's settings tables carry each value's tag; untagged scenarios get no column."""
    from trainctl.report.build import collect_report_data
    from trainctl.report.context import build_report_context
    from trainctl.run.analysis import run_scenario
    from trainctl.scenario import read_scenario_text

    def settings(scenario, text):
        data = collect_report_data(run_scenario(scenario, simulate=False), scenario_text=text,
                                   command="test")
        ctx = build_report_context(data, deterministic=True)
        return {g["title"]: g for g in ctx["scenario"]["settings"]}

    text, _ = read_scenario_text("crh2-potential")
    scenario = load_scenario("crh2-potential")
    groups = settings(scenario, text)
    rows = {r["key"]: r for r in groups["Controller (potential)"]["rows"]}
    assert rows["kappa"]["source"] == scenario.tags["controller.kappa_per_s2"]
    assert rows["potential"]["source"] == scenario.tags["controller.pair_potential"]
    assert groups["Controller (potential)"]["sources"]
    mpc = groups["Controller (mpc)"]
    assert mpc["tag"] == scenario.tags["controller.mpc"]
    assert {r["key"]: r for r in mpc["rows"]}["input_weight"]["source"] == \
        scenario.tags["controller.mpc.r_per_kn2"]
    bare = "\n".join(line.split("#")[0] for line in text.splitlines())
    plain = settings(parse_scenario(bare), bare)
    assert not any(g["sources"] or g["tag"] for g in plain.values())
