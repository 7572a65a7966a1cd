"""Tests of Scenario.replace: one file key changed, validated as a file is."""

from __future__ import annotations

import dataclasses
import math

import pytest

from trainctl.exceptions import ScenarioError
from trainctl.scenario import builtin_scenario_text, load_scenario, parse_scenario
from trainctl.scenario.replace import parse_key_path


class TestReplace:
    def test_changes_one_value_in_file_units_and_leaves_the_original(self):
        """r_per_kn2 = 1.0 gives R = 1 per kN²; the loaded scenario keeps R = 10."""
        book = load_scenario("crh2-dmpc")
        lighter = book.replace("controller.r_per_kn2", 1.0)
        assert lighter.controller.input_weight_per_kn2() == 1.0
        assert book.controller.input_weight_per_kn2() == 10.0
        assert lighter.source == "builtin:crh2-dmpc (controller.r_per_kn2 = 1.0)"

    def test_equals_parsing_the_edited_text(self):
        """The same change made in the TOML text gives the same train and settings."""
        text = builtin_scenario_text("crh2-dmpc").replace(
            "mass_t = 48.0  ", "mass_t = 50.0  ").replace("sample_time = 20.0 ",
                                                          "sample_time = 10.0 ")
        by_text = parse_scenario(text)
        by_replace = (load_scenario("crh2-dmpc").replace("train.vehicle[1].mass_t", 50.0)
                      .replace("model.sample_time", 10.0))
        assert by_replace.train.mass.tolist() == by_text.train.mass.tolist() == [
            42800.0, 50000.0, 46500.0, 42000.0]
        assert by_replace.model == by_text.model and by_replace.controller == by_text.controller
        assert by_replace.simulation == by_text.simulation

    def test_units_are_converted_like_a_file(self):
        """speed_kmh = 180 is 50 m/s inside; stiffness in kN/m becomes N/m."""
        scenario = (load_scenario("crh2-dmpc").replace("model.speed_kmh", 180.0)
                    .replace("train.coupler.stiffness_kn_per_m", 5000.0))
        assert scenario.model.speed == pytest.approx(50.0)
        assert scenario.train.stiffness.tolist() == [5e6, 5e6, 5e6]

    def test_alternative_key_replaces_its_sibling(self):
        """Setting r_per_n2 on a file with r_per_kn2 drops r_per_kn2 (exactly one is allowed)."""
        scenario = load_scenario("crh2-dmpc").replace("controller.r_per_n2", 1e-5)
        assert scenario.controller.input_weight_unit == "N"
        assert scenario.controller.input_weight_per_kn2() == pytest.approx(10.0)
        assert "r_per_kn2" not in scenario.document["controller"]

    def test_none_removes_a_key_or_a_table(self):
        """None drops the coupler-force bound (no limit) or the whole [simulation]."""
        scenario = load_scenario("crh2-dmpc").replace("controller.coupler_force_limit_kn", None)
        assert math.isinf(scenario.controller.coupler_force_limit)
        assert load_scenario("crh2-dmpc").replace("simulation", None).simulation is None

    def test_invalid_value_names_the_key_path(self):
        """A value that breaks a rule is refused with the file's own message."""
        with pytest.raises(ScenarioError, match=r"\[train\.vehicle\]\[2\]\.mass_t must be "):
            load_scenario("crh2-dmpc").replace("train.vehicle[2].mass_t", -1.0)
        with pytest.raises(ScenarioError, match=r"\[controller\]\.control_horizon"):
            load_scenario("crh2-dmpc").replace("controller.control_horizon", 9)

    def test_unknown_key_is_refused_with_a_suggestion(self):
        """A misspelt key gets the parser's near-miss suggestion."""
        with pytest.raises(ScenarioError, match=r"r_per_kn3.*Did you mean 'r_per_kn2'\?"):
            load_scenario("crh2-dmpc").replace("controller.r_per_kn3", 1.0)

    @pytest.mark.parametrize(("path", "match"), [
        ("train.vehicle[7].mass_t", r"an array of 4 at train\.vehicle"),
        ("model.speed_kmh.value", r"the value 300\.0 at model\.speed_kmh"),
        ("controller..r_per_kn2", r"is not a key path"),
        ("", r"non-empty str"),
    ])
    def test_bad_paths_are_refused(self, path, match):
        """Paths through values, past array ends or malformed: ScenarioError naming the path."""
        with pytest.raises(ScenarioError, match=match):
            load_scenario("crh2-dmpc").replace(path, 1.0)

    def test_scenario_stays_frozen_and_document_read_only(self):
        """The scenario is frozen; its document cannot be changed in place."""
        scenario = load_scenario("crh2-dmpc")
        with pytest.raises(dataclasses.FrozenInstanceError):
            scenario.model = None
        with pytest.raises(TypeError):
            scenario.document["model"]["speed_kmh"] = 1.0
        assert isinstance(scenario.document["train"]["vehicle"], tuple)

    def test_python_built_scenario_has_no_document(self):
        """A scenario made in Python cannot replace file keys; the message says why."""
        book = load_scenario("crh2-dmpc")
        built = dataclasses.replace(book, document=None)
        with pytest.raises(ScenarioError, match="built in Python"):
            built.replace("controller.r_per_kn2", 1.0)

    def test_key_paths(self):
        """Names and 0-based [index] suffixes, as error messages print them."""
        assert parse_key_path("controller.lqr.r_per_kn2") == ("controller", "lqr", "r_per_kn2")
        assert parse_key_path("track.section[1].grade_permille") == (
            "track", "section", 1, "grade_permille")
