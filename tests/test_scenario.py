"""Tests for trainctl.scenario: TOML scenario files to SI dataclasses."""

from __future__ import annotations

import copy
import dataclasses
import math
import pickle
import re
import sys
import types
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from trainctl.controllers.mpc.settings import SOLVER_PATHS, ControllerSettings
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.models.train import Train
from trainctl.models.vehicle import Coupler, Vehicle
from trainctl.scenario import (
    CHECK_NAMES,
    RESERVED_SECTIONS,
    SIMULATION_STRATEGIES,
    BuiltinScenario,
    ModelSettings,
    Scenario,
    SimulationSettings,
    builtin_scenario_text,
    builtin_scenarios,
    load_scenario,
    parse_scenario,
    slugify,
)

BUILTIN_NAMES = [
    "crh2-dmpc",
    "crh2-dmpc-convergence-sweep",
    "crh2-dmpc-well-sampled",
    "crh2-potential",
    "crh2-potential-unpinned",
    "heavy-haul-flocking",
    "heavy-haul-flocking-collision",
    "heavy-haul-flocking-line",
    "heavy-haul-flocking-outage",
    "heavy-haul-hinf",
    "heavy-haul-hinf-delay",
    "heavy-haul-hinf-delay-sweep",
    "heavy-haul-hinf-delayed-own-speed",
    "heavy-haul-hinf-ideal",
    "heavy-haul-hinf-interruption",
    "heavy-haul-hinf-noise",
]
ANALYSES = Path(__file__).resolve().parent.parent / "analyses"

BASE = """\
schema_version = 1
name = "Test train"
description = "A three-coach test train"
seed = 0

[train]

[[train.vehicle]]
name = "T"
mass_t = 42.8
length = 25.0
davis_n_per_kn_kmh = [0.8806, 0.007444, 0.0001143]
traction_share = 0.0

[[train.vehicle]]
name = "M"
count = 2
mass_t = 48.0
davis_n_per_kn_kmh = [0.8806, 0.007444, 0.0001143]
max_traction_kn = 80.0
max_power_kw = 1200.0

[train.coupler]
stiffness_kn_per_m = 10488.0
damping_kn_s_per_m = 0.0

[model]
speed_kmh = 300.0
sample_time = 20.0
"""

SINGLE = """\
schema_version = 1
name = "One car"
description = "A single vehicle"
[train]
[[train.vehicle]]
mass_t = 40.0
davis_si = [0.01, 0.0, 1e-5]
[model]
speed_kmh = 90.0
sample_time = 1.0
"""


def edit(old: str, new: str, text: str = BASE) -> str:
    """Replace ``old`` (which must occur) by ``new`` in a scenario text."""
    assert old in text, old
    return text.replace(old, new, 1)


def check_fails(text: str, *fragments: str) -> ScenarioError:
    """Parse ``text`` expecting ScenarioError whose message holds every fragment."""
    with pytest.raises(ScenarioError, match=re.escape(fragments[0])) as info:
        parse_scenario(text, source="t.toml")
    message = str(info.value)
    assert message.startswith("t.toml: "), message
    for fragment in fragments[1:]:
        assert fragment in message, (fragment, message)
    return info.value


class TestBuiltins:
    """The shipped scenario files and their lookup."""

    def test_names_sorted(self) -> None:
        """builtin_scenarios lists the seed scenarios sorted by name."""
        found = builtin_scenarios()
        assert [b.name for b in found] == BUILTIN_NAMES
        assert all(isinstance(b, BuiltinScenario) and b.path.is_file() for b in found)

    @pytest.mark.parametrize("name", BUILTIN_NAMES)
    def test_every_builtin_loads(self, name: str) -> None:
        """Each built-in parses into a Scenario with a builtin: source."""
        scenario = load_scenario(name)
        assert isinstance(scenario, Scenario)
        assert isinstance(scenario.train, Train)
        assert scenario.source == f"builtin:{name}"
        assert re.fullmatch(r"[a-z0-9-]+", scenario.slug)

    @pytest.mark.parametrize("name", BUILTIN_NAMES)
    def test_description_is_one_line(self, name: str) -> None:
        """Each built-in's description is a single non-empty line."""
        (entry,) = [b for b in builtin_scenarios() if b.name == name]
        assert entry.description and "\n" not in entry.description
        assert entry.description == load_scenario(name).description

    @pytest.mark.parametrize("name", BUILTIN_NAMES)
    def test_first_lines_are_comments(self, name: str) -> None:
        """Each built-in file opens with comment lines citing its source."""
        text = builtin_scenario_text(name)
        assert text.splitlines()[0].startswith("# Seed 00")
        assert "Source:" in text

    def test_crh2_dmpc_values(self) -> None:
        """crh2-dmpc holds the book's masses, stiffness, speed and sample time in SI."""
        scenario = load_scenario("crh2-dmpc")
        train = scenario.train
        assert train.mass.tolist() == [42800.0, 48000.0, 46500.0, 42000.0]
        assert train.stiffness.tolist() == pytest.approx([1.0488e7] * 3)
        assert train.damping.tolist() == [0.0, 0.0, 0.0]
        assert train.traction_share.tolist() == [0.0, 1.0, 1.0, 0.0]
        assert scenario.model.speed == pytest.approx(83.333, abs=1e-3)
        assert scenario.model.sample_time == 20.0
        assert scenario.model.linearisation == "jacobian"
        assert scenario.model.dummy_state is True
        assert scenario.track is None
        assert train.vehicles[1].envelope.max_power == pytest.approx(1.2e6)
        assert train.vehicles[0].envelope.max_traction == 0.0

    def test_crh2_dmpc_simulation(self) -> None:
        """crh2-dmpc simulates 60 samples of 20 s for the three strategies of Figs 12.10-12.13."""
        scenario = load_scenario("crh2-dmpc")
        sim, ctl = scenario.simulation, scenario.controller
        assert sim is not None and ctl is not None
        assert sim.duration == 1200.0
        assert sim.n_steps(20.0) == 60
        assert sim.n_steps(scenario.model.sample_time) == 60
        assert sim.strategies == ("centralised", "decentralised", "ndmpc")
        assert sim.reference_times == (0.0, 60.0, 460.0, 1020.0, 1200.0)
        assert sim.reference_speeds == pytest.approx((20.0, 20.0, 60.0, 80.0, 80.0))
        assert (sim.settle_time, sim.tracking_tolerance) == (100.0, 1.0)
        assert (sim.initial_speed_error, sim.measurement_noise, sim.regen_efficiency) == (
            0.0,
            0.0,
            1.0,
        )
        assert (ctl.max_iterations, ctl.iteration_tolerance) == (50, 1e-4)
        assert ctl.coupler_force_limit == pytest.approx(5e5)
        assert (ctl.rate_limit, ctl.input_bounds, ctl.solver_path) == (math.inf, True, "fast")
        assert (ctl.iterations, ctl.input_weight) == (10, 10.0)

    def test_crh2_potential_formation(self) -> None:
        """crh2-potential: the 8-car CRH2C-type T-M-M-M-M-M-M-T train, baselines at 0.05 s,
        the potential law sampled at 0.002 s."""
        scenario = load_scenario("crh2-potential")
        assert [v.name for v in scenario.train.vehicles] == list("TMMMMMMT")
        assert scenario.train.mass.tolist() == [
            42800.0, 48000.0, 46500.0, 42000.0, 42000.0, 46500.0, 48000.0, 42800.0,
        ]  # fmt: skip
        assert scenario.train.davis[:, 0].tolist() == [0.01176, 0.00077616, 1.6e-5]
        assert scenario.model.sample_time == 0.05
        assert scenario.controllers["potential"].control_interval == 0.002

    def test_heavy_haul_flocking_virtual_links(self) -> None:
        """heavy-haul-flocking has 4 unit trains joined by virtual links 500 m apart."""
        train = load_scenario("heavy-haul-flocking").train
        assert train.n_vehicles == 4
        assert train.virtual.tolist() == [True, True, True]
        assert train.stiffness.tolist() == [0.0, 0.0, 0.0]
        assert train.spacing.tolist() == [1800.0, 1800.0, 1800.0]
        assert train.groups == ((0,), (1,), (2,), (3,))

    def test_heavy_haul_hinf_track_and_couplers(self) -> None:
        """heavy-haul-hinf has 5184 t subsystems, damped couplers and a 12 permille down-grade."""
        scenario = load_scenario("heavy-haul-hinf")
        assert scenario.train.mass.tolist() == [5184000.0] * 4
        assert scenario.train.damping.tolist() == [5e5] * 3
        assert scenario.train.spacing.tolist() == pytest.approx([632.8] * 3)
        assert scenario.track is not None and scenario.track.formula == "ning2016"
        assert [s.grade_permille for s in scenario.track.sections] == [0.0, -12.0]

    def test_hinf_davis_is_mass_weighted_mix(self) -> None:
        """The subsystem Davis coefficients are the 184 t / 5000 t weighted mix."""
        loco, wagon = [2.25, 0.0190, 0.000320], [0.92, 0.0048, 0.000125]
        mix = [(184 * a + 5000 * b) / 5184 for a, b in zip(loco, wagon, strict=True)]
        text = builtin_scenario_text("heavy-haul-hinf")
        match = re.search(r"^davis_n_per_kn_kmh = \[(.*?)\]", text, re.MULTILINE)
        assert match is not None
        printed = [float(x) for x in match.group(1).split(",")]
        assert printed == pytest.approx(mix, rel=1e-5)

    def test_text_matches_file(self) -> None:
        """builtin_scenario_text returns the file's text."""
        entry = builtin_scenarios()[0]
        assert builtin_scenario_text(entry.name) == entry.path.read_text(encoding="utf-8")

    def test_unknown_builtin_lists_and_suggests(self) -> None:
        """An unknown built-in name lists the available ones and suggests a close match."""
        with pytest.raises(ScenarioError, match=r"builtin:crh2-dmcp") as info:
            load_scenario("crh2-dmcp")
        assert "Did you mean 'crh2-dmpc'?" in str(info.value)
        assert "heavy-haul-hinf" in str(info.value)

    def test_unknown_builtin_text(self) -> None:
        """builtin_scenario_text rejects an unknown name with ScenarioError."""
        with pytest.raises(ScenarioError, match="no built-in scenario named 'nope'"):
            builtin_scenario_text("nope")

    def test_readme_example_parses(self) -> None:
        """The annotated example in analyses/README.md is a valid scenario."""
        readme = (ANALYSES / "README.md").read_text(encoding="utf-8")
        example = re.search(r"```toml\n(.*?)```", readme, re.DOTALL)
        assert example is not None
        scenario = parse_scenario(example.group(1))
        assert scenario.train.n_vehicles == 2
        assert scenario.track is not None and len(scenario.track.sections) == 2


class TestLoadScenario:
    """Resolution of bare names vs paths and file-level errors."""

    def test_path_is_read_from_file(self, tmp_path: Path) -> None:
        """A path named like a built-in is read from the file, not the built-in."""
        path = tmp_path / "crh2-dmpc.toml"
        path.write_text(edit('name = "Test train"', 'name = "From file"'), encoding="utf-8")
        scenario = load_scenario(str(path))
        assert scenario.name == "From file"
        assert scenario.source == str(path)

    def test_pathlike_is_read_from_file(self, tmp_path: Path) -> None:
        """An os.PathLike is always read as a file."""
        path = tmp_path / "crh2-dmpc"
        path.write_text(BASE, encoding="utf-8")
        assert load_scenario(path).name == "Test train"

    def test_toml_suffix_without_directory_is_a_path(
        self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
    ) -> None:
        """'crh2-dmpc.toml' (no separator) is a relative path because of its suffix."""
        (tmp_path / "crh2-dmpc.toml").write_text(BASE, encoding="utf-8")
        monkeypatch.chdir(tmp_path)
        scenario = load_scenario("crh2-dmpc.toml")
        assert scenario.name == "Test train"
        assert scenario.source == "crh2-dmpc.toml"

    def test_bare_name_is_builtin(self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        """A bare name selects the built-in even if a same-named file is in the cwd."""
        (tmp_path / "crh2-dmpc").write_text(BASE, encoding="utf-8")
        monkeypatch.chdir(tmp_path)
        assert load_scenario("crh2-dmpc").source == "builtin:crh2-dmpc"

    def test_file_not_found(self, tmp_path: Path) -> None:
        """A missing file gives ScenarioError naming the path."""
        path = tmp_path / "missing.toml"
        with pytest.raises(ScenarioError, match=re.escape(f"{path}: file not found")):
            load_scenario(path)

    def test_directory_is_not_readable(self, tmp_path: Path) -> None:
        """A directory path gives ScenarioError naming the problem, not an OSError."""
        with pytest.raises(ScenarioError, match="is a directory, not a scenario file"):
            load_scenario(tmp_path)

    def test_not_utf8(self, tmp_path: Path) -> None:
        """A latin-1 encoded file gives ScenarioError with the line, not UnicodeDecodeError."""
        path = tmp_path / "latin1.toml"
        path.write_bytes(edit('"Test train"', '"Zürich train"').encode("latin-1"))
        with pytest.raises(ScenarioError, match=r"not UTF-8 text .* at line 2"):
            load_scenario(path)

    def test_utf8_bom_is_accepted(self, tmp_path: Path) -> None:
        """A UTF-8 file with a byte-order mark loads."""
        path = tmp_path / "bom.toml"
        path.write_bytes(b"\xef\xbb\xbf" + BASE.encode("utf-8"))
        assert load_scenario(path).name == "Test train"

    def test_error_names_the_file(self, tmp_path: Path) -> None:
        """Errors in a file start with the path as given."""
        path = tmp_path / "bad.toml"
        path.write_text(edit("sample_time = 20.0", "sample_time = -1.0"), encoding="utf-8")
        with pytest.raises(ScenarioError) as info:
            load_scenario(path)
        assert str(info.value).startswith(f"{path}: [model].sample_time must be a number "
                                          ">= 0.0001 (got -1.0). Sample times below 0.1 ms")


class TestParseValid:
    """Well-formed documents and their conversion to SI."""

    def test_base_document(self) -> None:
        """The base document expands counts and converts units."""
        scenario = parse_scenario(BASE)
        train = scenario.train
        assert train.mass.tolist() == [42800.0, 48000.0, 48000.0]
        assert [v.name for v in train.vehicles] == ["T", "M", "M"]
        assert train.stiffness.tolist() == [1.0488e7, 1.0488e7]
        assert scenario.source == "<string>"
        assert scenario.seed == 0 and scenario.track is None

    def test_defaults(self) -> None:
        """Omitted optional keys take their documented defaults."""
        scenario = parse_scenario(SINGLE)
        vehicle = scenario.train.vehicles[0]
        assert vehicle.name == "vehicle" and vehicle.length == 25.0
        assert vehicle.traction_share == 1.0
        assert math.isinf(vehicle.envelope.max_traction)
        assert math.isinf(vehicle.envelope.adhesion)
        model = scenario.model
        assert (model.linearisation, model.dummy_state, model.allocation, model.discretisation) == (
            "jacobian", True, "shares", "zoh",
        )  # fmt: skip
        assert scenario.train.couplers == ()

    def test_ints_become_floats(self) -> None:
        """TOML integers where numbers are expected become floats."""
        scenario = parse_scenario(edit("sample_time = 20.0", "sample_time = 20"))
        assert isinstance(scenario.model.sample_time, float)

    @pytest.mark.parametrize(
        ("key", "expected"),
        [
            ("davis_si", [0.01, 0.0, 1e-5]),
            ("davis_book_literal", [0.01, 0.0, 1e-5]),
            ("davis_n_per_kn_kmh", [0.01 * 9.81e-3, 0.0, 1e-5 * 9.81e-3 * 3.6**2]),
        ],
    )
    def test_davis_readings(self, key: str, expected: list[float]) -> None:
        """Each Davis key converts with its own reading."""
        scenario = parse_scenario(edit("davis_si", key, SINGLE))
        assert scenario.train.davis[:, 0].tolist() == pytest.approx(expected)

    def test_coupler_array(self) -> None:
        """[[train.coupler]] gives one coupler per link, with gap added to the spacing."""
        text = edit(
            "[train.coupler]\nstiffness_kn_per_m = 10488.0\ndamping_kn_s_per_m = 0.0\n",
            "[[train.coupler]]\nstiffness_kn_per_m = 1.0\ngap = 2.0\n"
            "[[train.coupler]]\nstiffness_kn_per_m = 3.0\ndamping_kn_s_per_m = 4.0\n",
        )
        train = parse_scenario(text).train
        assert train.stiffness.tolist() == [1000.0, 3000.0]
        assert train.damping.tolist() == [0.0, 4000.0]
        assert train.spacing.tolist() == [27.0, 25.0]

    def test_virtual_link_without_stiffness(self) -> None:
        """A virtual coupler may omit stiffness and becomes a virtual link."""
        text = edit("stiffness_kn_per_m = 10488.0\ndamping_kn_s_per_m = 0.0\n", "virtual = true\n")
        train = parse_scenario(text).train
        assert train.virtual.tolist() == [True, True]
        assert train.stiffness.tolist() == [0.0, 0.0]

    def test_track(self) -> None:
        """[track] sections become a Track with SI positions."""
        text = SINGLE + (
            '[track]\nformula = "ning2016"\nwheelbase = 2.0\n'
            "[[track.section]]\nstart = 0\n"
            "[[track.section]]\nstart = 100.0\ngrade_permille = 6\ncurve_radius = 800\n"
        )
        track = parse_scenario(text).track
        assert track is not None
        assert (track.formula, track.wheelbase) == ("ning2016", 2.0)
        assert track.sections[1].curve_radius == 800.0
        assert math.isinf(track.sections[0].curve_radius)

    def test_name_any_text(self) -> None:
        """The display name may hold any text; the slug is safe."""
        scenario = parse_scenario(edit('"Test train"', '"<script>alert(1)</script>"'))
        assert scenario.name == "<script>alert(1)</script>"
        assert scenario.slug == "script-alert-1-script"


class TestUnknownAndReserved:
    """Unknown keys, unknown sections and reserved sections."""

    def test_unknown_key_suggests(self) -> None:
        """A misspelt key names its path and suggests the right one."""
        error = check_fails(
            edit("sample_time = 20.0", "sample_tim = 20.0"),
            "unknown key [model].sample_tim. Did you mean 'sample_time'?",
        )
        assert "reserved" not in str(error)

    def test_unknown_vehicle_key(self) -> None:
        """A misspelt key in the second vehicle group names the group index."""
        check_fails(edit("mass_t = 48.0", "mass_t = 48.0\nmas_t = 1.0"), "[train.vehicle][1].mas_t")

    def test_unknown_top_level_key(self) -> None:
        """An unknown top-level key is reported with a suggestion."""
        check_fails(edit("seed = 0", "seeds = 0"), "unknown key seeds. Did you mean 'seed'?")

    def test_unknown_section(self) -> None:
        """A misspelt section is reported as an unknown section."""
        check_fails(edit("[model]", "[modle]"), "unknown section [modle]. Did you mean 'model'?")

    def test_unknown_subsection(self) -> None:
        """An unknown sub-table inside [train] gives its dotted name."""
        check_fails(BASE + "[train.wagon]\nx = 1\n", "unknown section [train.wagon]")

    def test_unknown_without_match_lists_allowed(self) -> None:
        """Without a close match the allowed keys are listed."""
        check_fails(
            edit("[model]", "[model]\nzzz = 1"), "unknown key [model].zzz.", "Allowed here:"
        )

    @pytest.mark.parametrize("section", RESERVED_SECTIONS)
    def test_reserved_section(self, section: str) -> None:
        """Reserved sections are rejected as not supported yet, not as unknown."""
        error = check_fails(
            BASE + f"[{section}]\nx = 1\n",
            f"section [{section}] is reserved for a later trainctl release",
            "not supported yet",
        )
        assert "unknown" not in str(error)


class TestMissing:
    """Missing required keys and sections."""

    @pytest.mark.parametrize(
        ("old", "fragment"),
        [
            ("schema_version = 1\n", "missing required key schema_version"),
            ('name = "Test train"\n', "missing required key name"),
            ('description = "A three-coach test train"\n', "missing required key description"),
            ("sample_time = 20.0\n", "missing required key [model].sample_time"),
            ("speed_kmh = 300.0\n", "missing required key [model].speed_kmh"),
            ("mass_t = 48.0\n", "missing required key [train.vehicle][1].mass_t"),
            (
                "stiffness_kn_per_m = 10488.0\n",
                "missing required key [train.coupler].stiffness_kn_per_m",
            ),
        ],
    )
    def test_missing_key(self, old: str, fragment: str) -> None:
        """Each required key is reported by its key path."""
        check_fails(edit(old, ""), fragment)

    def test_missing_model_section(self) -> None:
        """A document without [model] names the section."""
        check_fails(BASE.split("[model]")[0], "missing required section [model]")

    def test_missing_train_section(self) -> None:
        """A document without [train] names the section."""
        check_fails(
            SINGLE.replace("[train]\n[[train.vehicle]]\nmass_t = 40.0\n", "").replace(
                "davis_si = [0.01, 0.0, 1e-5]\n", ""
            ),
            "missing required section [train]",
        )

    def test_no_vehicles_and_no_preset(self) -> None:
        """[train] needs a preset or vehicles."""
        text = edit("davis_si = [0.01, 0.0, 1e-5]\n", "", SINGLE)
        text = edit("[[train.vehicle]]\nmass_t = 40.0\n", "", text)
        check_fails(text, "missing required key [train].preset or [train.vehicle]")

    def test_missing_davis(self) -> None:
        """A vehicle group without Davis coefficients names the group."""
        check_fails(
            edit("davis_si = [0.01, 0.0, 1e-5]\n", "", SINGLE),
            "[train.vehicle][0] needs exactly one of",
        )

    def test_two_davis_keys(self) -> None:
        """Two Davis keys in one group are rejected."""
        check_fails(
            edit(
                "davis_si = [0.01, 0.0, 1e-5]\n",
                "davis_si = [0.01, 0.0, 1e-5]\ndavis_book_literal = [1, 1, 1]\n",
                SINGLE,
            ),
            "[train.vehicle][0] needs exactly one of",
            "(got davis_si and davis_book_literal)",
        )

    def test_missing_coupler(self) -> None:
        """A train of several vehicles without a coupler names [train.coupler]."""
        check_fails(
            BASE.replace(
                "[train.coupler]\nstiffness_kn_per_m = 10488.0\ndamping_kn_s_per_m = 0.0\n", ""
            ),
            "missing required key [train.coupler]",
            "3 vehicles",
        )


class TestWrongType:
    """Values of the wrong TOML type."""

    @pytest.mark.parametrize(
        ("old", "new", "fragment"),
        [
            (
                "mass_t = 42.8",
                "mass_t = true",
                "[train.vehicle][0].mass_t must be a number >= 0.001 (got true, a boolean)",
            ),
            (
                "sample_time = 20.0",
                'sample_time = "20"',
                "[model].sample_time must be a number >= 0.0001 (got '20', a string)",
            ),
            (
                "count = 2",
                "count = 2.0",
                "[train.vehicle][1].count must be an integer >= 1 (got 2.0)",
            ),
            ("seed = 0", "seed = true", "seed must be an integer >= 0 (got true, a boolean)"),
            ("schema_version = 1", "schema_version = 1.0", "schema_version must be an integer"),
            ('name = "Test train"', "name = 3", "name must be a string (got 3)"),
            (
                'name = "T"',
                "name = [1]",
                "[train.vehicle][0].name must be a string (got an array of 1 item)",
            ),
            (
                "speed_kmh = 300.0",
                "speed_kmh = 1979-05-27",
                "[model].speed_kmh must be a number > 0 (got 1979-05-27, a date/time)",
            ),
            (
                "[model]",
                "[model]\ndummy_state = 1",
                "[model].dummy_state must be true or false (got 1)",
            ),
            (
                "damping_kn_s_per_m = 0.0",
                'damping_kn_s_per_m = 0.0\nvirtual = "no"',
                "[train.coupler].virtual must be true or false",
            ),
        ],
    )
    def test_wrong_scalar_type(self, old: str, new: str, fragment: str) -> None:
        """Bools, strings, floats and dates where another type is required are rejected."""
        check_fails(edit(old, new), fragment)

    def test_string_number_hint(self) -> None:
        """A quoted number gets a hint to drop the quotes."""
        check_fails(
            edit("sample_time = 20.0", 'sample_time = "20"'),
            "[model].sample_time",
            "without quotes",
        )

    def test_list_where_table_expected(self) -> None:
        """An array where the [model] table is expected is rejected."""
        text = edit("seed = 0", "seed = 0\nmodel = [1, 2]", BASE.split("[model]")[0])
        check_fails(text, "[model] must be a table (got an array of 2 items)")

    def test_table_where_array_of_tables_expected(self) -> None:
        """[train.vehicle] written as a single table asks for double brackets."""
        text = edit("[[train.vehicle]]", "[train.vehicle]", SINGLE)
        check_fails(text, "[train.vehicle] must be a non-empty array of tables", "double brackets")

    def test_scalar_where_array_item_table_expected(self) -> None:
        """A plain array in place of [[train.vehicle]] names the bad item."""
        text = SINGLE.replace(
            "[[train.vehicle]]\nmass_t = 40.0\ndavis_si = [0.01, 0.0, 1e-5]\n", "vehicle = [1]\n"
        )
        check_fails(text, "[train.vehicle][0] must be a table (got 1)")

    def test_davis_element_type(self) -> None:
        """A non-number inside the Davis list names its index."""
        check_fails(
            edit("[0.01, 0.0, 1e-5]", '[0.01, "x", 1e-5]', SINGLE),
            "[train.vehicle][0].davis_si[1] must be a number >= 0",
        )


class TestNonFinite:
    """nan and inf, which TOML allows, are rejected."""

    @pytest.mark.parametrize("value", ["nan", "inf", "-inf", "+inf"])
    def test_mass(self, value: str) -> None:
        """Non-finite mass is rejected with the key path."""
        check_fails(
            edit("mass_t = 42.8", f"mass_t = {value}"),
            "[train.vehicle][0].mass_t must be a finite number >= 0.001",
        )

    def test_sample_time_nan(self) -> None:
        """nan sample time is rejected and shown as nan."""
        check_fails(
            edit("sample_time = 20.0", "sample_time = nan"),
            "[model].sample_time must be a finite number >= 0.0001 (got nan)",
        )

    def test_inf_limit_hint(self) -> None:
        """inf for an optional limit hints to omit the key."""
        check_fails(
            edit("max_power_kw = 1200.0", "max_power_kw = inf"),
            "[train.vehicle][1].max_power_kw",
            "Omit the key for no limit",
        )

    def test_davis_nan(self) -> None:
        """nan inside the Davis list is rejected with its index."""
        check_fails(
            edit("[0.01, 0.0, 1e-5]", "[0.01, nan, 1e-5]", SINGLE),
            "[train.vehicle][0].davis_si[1] must be a finite number",
        )

    def test_huge_integer(self) -> None:
        """An integer too large for a float is treated as non-finite."""
        check_fails(
            edit("sample_time = 20.0", "sample_time = " + "9" * 400),
            "[model].sample_time must be a finite number",
        )


class TestBounds:
    """Zero or negative values where positive ones are required."""

    @pytest.mark.parametrize(
        ("old", "new", "fragment"),
        [
            (
                "mass_t = 42.8",
                "mass_t = 0",
                "[train.vehicle][0].mass_t must be a number >= 0.001 (got 0)",
            ),
            (
                "mass_t = 48.0",
                "mass_t = -1.0",
                "[train.vehicle][1].mass_t must be a number >= 0.001 (got -1.0)",
            ),
            (
                "stiffness_kn_per_m = 10488.0",
                "stiffness_kn_per_m = 0.0",
                "[train.coupler].stiffness_kn_per_m must be a number > 0 (got 0.0)",
            ),
            (
                "stiffness_kn_per_m = 10488.0",
                "stiffness_kn_per_m = -5",
                "[train.coupler].stiffness_kn_per_m must be a number > 0",
            ),
            (
                "sample_time = 20.0",
                "sample_time = 0.0",
                "[model].sample_time must be a number >= 0.0001 (got 0.0)",
            ),
            (
                "speed_kmh = 300.0",
                "speed_kmh = -300.0",
                "[model].speed_kmh must be a number > 0 (got -300.0)",
            ),
            ("count = 2", "count = 0", "[train.vehicle][1].count must be an integer >= 1 (got 0)"),
            ("seed = 0", "seed = -1", "seed must be an integer >= 0 (got -1)"),
            (
                "traction_share = 0.0",
                "traction_share = -0.5",
                "[train.vehicle][0].traction_share must be a number >= 0",
            ),
            (
                "damping_kn_s_per_m = 0.0",
                "damping_kn_s_per_m = -1.0",
                "[train.coupler].damping_kn_s_per_m must be a number >= 0",
            ),
            ("length = 25.0", "length = 0.0", "[train.vehicle][0].length must be a number > 0"),
        ],
    )
    def test_out_of_range(self, old: str, new: str, fragment: str) -> None:
        """Each out-of-range value names its key path, the bound and the value."""
        check_fails(edit(old, new), fragment)

    def test_schema_version(self) -> None:
        """Only schema_version 1 is read."""
        check_fails(
            edit("schema_version = 1", "schema_version = 2"), "schema_version must be 1 (got 2)"
        )

    def test_blank_name(self) -> None:
        """A blank name is rejected."""
        check_fails(edit('"Test train"', '"   "'), "name must be a non-empty string")

    def test_multi_line_description(self) -> None:
        """The description must be one line."""
        check_fails(
            edit('"A three-coach test train"', '"""two\nlines"""'),
            "description must be a single line",
        )

    def test_curve_radius_zero(self) -> None:
        """A zero curve radius is rejected with the section index."""
        text = SINGLE + "[track]\n[[track.section]]\nstart = 0.0\ncurve_radius = 0.0\n"
        check_fails(text, "[track.section][0].curve_radius must be a number >= 10")

    def test_vehicle_count_limit(self) -> None:
        """An absurd count is rejected before expanding the train."""
        check_fails(
            edit("count = 2", "count = 100000000"),
            "[train.vehicle][1].count makes the train longer",
        )


class TestLengths:
    """Lists and arrays of tables with the wrong length."""

    def test_davis_two_numbers(self) -> None:
        """A Davis list of 2 numbers is rejected."""
        check_fails(
            edit("[0.01, 0.0, 1e-5]", "[0.01, 0.0]", SINGLE),
            "[train.vehicle][0].davis_si must be an array of 3 numbers >= 0",
            "(got an array of 2 items)",
        )

    def test_davis_not_a_list(self) -> None:
        """A scalar Davis value is rejected."""
        check_fails(
            edit("[0.01, 0.0, 1e-5]", "0.01", SINGLE),
            "[train.vehicle][0].davis_si must be an array of 3 numbers",
        )

    def test_coupler_count(self) -> None:
        """[[train.coupler]] with the wrong number of entries gives the expected count."""
        text = edit("[train.coupler]", "[[train.coupler]]")
        check_fails(text, "[[train.coupler]] must have exactly 2 entries", "(got 1)")

    def test_empty_track_sections(self) -> None:
        """A track needs at least one section."""
        check_fails(
            SINGLE + "[track]\nsection = []\n",
            "[track.section] must be a non-empty array of tables",
        )

    def test_missing_track_sections(self) -> None:
        """[track] without sections (or a line) names the missing key and the alternatives."""
        check_fails(SINGLE + "[track]\nformula = 'tbt'\n",
                    "[track.section] must be given, or 'line' or 'file' instead")


class TestSyntaxAndEnums:
    """Not-TOML input and bad enumeration values."""

    def test_not_toml(self) -> None:
        """A TOML syntax error is reported with its line."""
        line = len(BASE.splitlines()) + 1
        check_fails(BASE + "sample_time = = 3\n", "not valid TOML", f"at line {line}, column")

    def test_duplicate_key(self) -> None:
        """A duplicated key is a TOML error."""
        check_fails(edit("seed = 0", "seed = 0\nseed = 1"), "not valid TOML")

    @pytest.mark.parametrize(
        ("key", "bad", "fragment"),
        [
            ("linearisation", "book2", "Did you mean 'book'?"),
            ("allocation", "share", "Did you mean 'shares'?"),
            ("discretisation", "tustn", "Did you mean 'tustin'?"),
        ],
    )
    def test_bad_enum(self, key: str, bad: str, fragment: str) -> None:
        """A bad enum value lists the options and suggests a close one."""
        check_fails(
            edit("[model]", f'[model]\n{key} = "{bad}"'),
            f"[model].{key} must be one of",
            f"(got '{bad}', a string)",
            fragment,
        )

    def test_bad_track_formula(self) -> None:
        """An unknown track formula is rejected with the options."""
        text = SINGLE + "[track]\nformula = 'ning'\n[[track.section]]\nstart = 0.0\n"
        check_fails(text, "[track].formula must be one of 'tbt', 'ning2016'")


class TestModelErrors:
    """ModelError from the model constructors becomes ScenarioError with a key path."""

    def test_virtual_with_stiffness(self) -> None:
        """A virtual link with stiffness is rejected at [train.coupler]."""
        error = check_fails(
            edit("damping_kn_s_per_m = 0.0", "damping_kn_s_per_m = 0.0\nvirtual = true"),
            "[train.coupler]: Coupler: a virtual link transmits no force",
        )
        assert isinstance(error.__cause__, ModelError)

    def test_virtual_with_damping_in_array(self) -> None:
        """A virtual link with damping in [[train.coupler]] names its index."""
        text = edit(
            "[train.coupler]\nstiffness_kn_per_m = 10488.0\ndamping_kn_s_per_m = 0.0\n",
            "[[train.coupler]]\nstiffness_kn_per_m = 1.0\n"
            "[[train.coupler]]\nvirtual = true\ndamping_kn_s_per_m = 4.0\n",
        )
        check_fails(text, "[train.coupler][1]: Coupler:")

    def test_track_starts_must_increase(self) -> None:
        """Section starts out of order name the offending section."""
        text = SINGLE + "[track]\n[[track.section]]\nstart = 10.0\n[[track.section]]\nstart = 5.0\n"
        check_fails(
            text, "[track.section][1].start must be greater than the previous section's start 10.0"
        )


def _fake_presets(monkeypatch: pytest.MonkeyPatch) -> None:
    """Install a stand-in trainctl.models.presets with one preset."""

    def two_cars(*, mass_t: float = 40.0, stiffness_kn_per_m: float = 1000.0) -> Train:
        car = Vehicle(mass=mass_t * 1e3, a0=0.01, a1=0.0, a2=1e-5)
        return Train(vehicles=(car, car), couplers=(Coupler(stiffness=stiffness_kn_per_m * 1e3),))

    def needs_n(*, n: int) -> Train:
        car = Vehicle(mass=1e3, a0=0.0, a1=0.0, a2=0.0)
        return Train(vehicles=(car,) * n, couplers=(Coupler(stiffness=1.0),) * (n - 1))

    module = types.ModuleType("trainctl.models.presets")
    module.PRESETS = {"two_cars": two_cars, "needs_n": needs_n}  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "trainctl.models.presets", module)


PRESET_DOC = """\
schema_version = 1
name = "Preset train"
description = "From a preset"
[train]
preset = "{preset}"
{options}
[model]
speed_kmh = 100.0
sample_time = 1.0
"""


def preset_doc(preset: str, options: str = "") -> str:
    """A scenario text using ``preset`` with optional [train.preset_options] lines."""
    block = f"[train.preset_options]\n{options}" if options else ""
    return PRESET_DOC.format(preset=preset, options=block)


class TestPresetMachinery:
    """The preset path, exercised with a stand-in presets module."""

    def test_preset_with_options(self, monkeypatch: pytest.MonkeyPatch) -> None:
        """Options are passed as keyword arguments to the preset function."""
        _fake_presets(monkeypatch)
        train = parse_scenario(preset_doc("two_cars", "mass_t = 50.0\n")).train
        assert train.mass.tolist() == [50000.0, 50000.0]

    def test_unknown_preset(self, monkeypatch: pytest.MonkeyPatch) -> None:
        """An unknown preset lists the available ones and suggests a close match."""
        _fake_presets(monkeypatch)
        check_fails(
            preset_doc("two_car"),
            "[train].preset must name a preset (got 'two_car')",
            "Did you mean 'two_cars'?",
            "needs_n",
        )

    def test_unknown_option(self, monkeypatch: pytest.MonkeyPatch) -> None:
        """An option the preset function does not take is rejected with a suggestion."""
        _fake_presets(monkeypatch)
        check_fails(
            preset_doc("two_cars", "mass = 50.0\n"),
            "unknown key [train.preset_options].mass. Did you mean 'mass_t'?",
        )

    def test_missing_required_option(self, monkeypatch: pytest.MonkeyPatch) -> None:
        """A keyword-only argument without default must be given."""
        _fake_presets(monkeypatch)
        check_fails(preset_doc("needs_n"), "missing required key [train.preset_options].n")

    def test_model_error_from_preset(self, monkeypatch: pytest.MonkeyPatch) -> None:
        """A ModelError inside the preset becomes ScenarioError at [train.preset_options]."""
        _fake_presets(monkeypatch)
        check_fails(preset_doc("two_cars", "mass_t = -1.0\n"), "[train.preset_options]: Vehicle")

    def test_preset_and_vehicles_conflict(self) -> None:
        """A preset cannot be combined with explicit vehicles."""
        check_fails(
            edit("[train]\n", '[train]\npreset = "crh2_half"\n'),
            "[train].preset cannot be combined with [train.vehicle]",
        )

    def test_options_without_preset(self) -> None:
        """[train.preset_options] without a preset is rejected."""
        check_fails(
            edit("[train]\n", "[train]\npreset_options = {}\n"),
            "[train.preset_options] needs [train].preset",
        )


def _real_presets() -> dict:
    """The real PRESETS mapping, or skip the test when it is not available yet."""
    presets = pytest.importorskip("trainctl.models.presets")
    if not hasattr(presets, "PRESETS"):
        pytest.skip("trainctl.models.presets has no PRESETS yet")
    return presets.PRESETS


class TestRealPresets:
    """The preset path with the project's presets module (skipped until it exists)."""

    @pytest.mark.parametrize(
        "name", ["crh2_half", "crh2_8car", "heavy_haul_1p2p1", "virtual_formation"]
    )
    def test_preset_loads(self, name: str) -> None:
        """Each documented preset builds a Train with default options."""
        presets = _real_presets()
        if name not in presets:
            pytest.skip(f"preset {name!r} not defined yet")
        assert isinstance(parse_scenario(preset_doc(name)).train, Train)

    def test_unknown_preset(self) -> None:
        """An unknown preset name lists the real presets."""
        _real_presets()
        check_fails(preset_doc("crh2_halff"), "[train].preset must name a preset", "Available:")


class TestSlugify:
    """slugify: safe identifiers from any text."""

    @pytest.mark.parametrize(
        ("text", "slug"),
        [
            ("CRH2 half train", "crh2-half-train"),
            ("<script>alert(1)</script>", "script-alert-1-script"),
            ("../../etc/passwd", "etc-passwd"),
            ("Zürich — Genève", "zurich-geneve"),
            ("  --Hello__World--  ", "hello-world"),
            ("", "scenario"),
            ("!!!", "scenario"),
            ("北京", "scenario"),
        ],
    )
    def test_cases(self, text: str, slug: str) -> None:
        """Known inputs give the expected slug."""
        assert slugify(text) == slug

    def test_long_text_cut_at_word(self) -> None:
        """Long text is cut to at most 60 characters at a word boundary."""
        slug = slugify("word " * 30)
        assert len(slug) <= 60 and not slug.endswith("-")
        assert set(slug.split("-")) == {"word"}

    @given(st.text())
    def test_property(self, text: str) -> None:
        """Every slug is non-empty, at most 60 chars of [a-z0-9-], no edge dashes."""
        slug = slugify(text)
        assert re.fullmatch(r"[a-z0-9]+(-[a-z0-9]+)*", slug)
        assert len(slug) <= 60


class TestDataclasses:
    """ModelSettings, Scenario and BuiltinScenario as data."""

    def test_frozen(self) -> None:
        """Scenario and ModelSettings are immutable."""
        scenario = load_scenario("crh2-dmpc")
        with pytest.raises(dataclasses.FrozenInstanceError):
            scenario.name = "x"  # type: ignore[misc]
        with pytest.raises(dataclasses.FrozenInstanceError):
            scenario.model.speed = 1.0  # type: ignore[misc]

    def test_model_settings_validates(self) -> None:
        """ModelSettings built directly rejects bad values with ModelError."""
        with pytest.raises(ModelError, match="'sample_time' must be a finite number >= 0.0001"):
            ModelSettings(speed=1.0, sample_time=0.0)
        with pytest.raises(ModelError, match="'linearisation' must be one of"):
            ModelSettings(speed=1.0, sample_time=1.0, linearisation="book2")

    def test_scenario_error_is_value_error(self) -> None:
        """ScenarioError stays catchable as ValueError."""
        with pytest.raises(ValueError):
            parse_scenario("not = [toml")


CONTROLLER = """
[controller]
form = "u"
prediction_horizon = 4
control_horizon = 2
r_per_kn2 = 10.0
"""

FULL_CONTROLLER = """
[controller]
form = "du"
prediction_horizon = 6
control_horizon = 3
outputs = ["force", "v"]
q_velocity = 2.5
q_force_per_kn2 = 0.5
r_per_n2 = 2e-5
neighbourhood = [[1, 0], [1, 2, 0], [2]]
iterations = 4
cooperative_weights = [0.5, 0.25, 0.25]
"""


def with_controller(*lines: str, base: str = CONTROLLER) -> str:
    """BASE plus a [controller] section with ``lines`` appended to it."""
    return BASE + base + "".join(f"{line}\n" for line in lines)


def controller_without(key: str, *lines: str) -> str:
    """BASE plus the minimal [controller] section without the line starting with ``key``."""
    kept = [line for line in CONTROLLER.splitlines() if not line.startswith(f"{key} =")]
    return BASE + "\n".join(kept) + "\n" + "".join(f"{line}\n" for line in lines)


def make_controller(**changes: object) -> ControllerSettings:
    """A valid ControllerSettings with ``changes`` applied."""
    settings: dict[str, object] = {
        "form": "u",
        "prediction_horizon": 4,
        "control_horizon": 2,
        "input_weight": 10.0,
    }
    settings.update(changes)
    return ControllerSettings(**settings)  # type: ignore[arg-type]


class TestControllerValid:
    """A well-formed [controller] section and its defaults."""

    def test_absent_is_none(self) -> None:
        """Without [controller] the scenario has no controller."""
        assert parse_scenario(BASE).controller is None

    def test_readme_example_parses(self) -> None:
        """The [controller]/[expected] example in analyses/README.md fits the annotated example."""
        readme = (ANALYSES / "README.md").read_text(encoding="utf-8")
        blocks = re.findall(r"```toml\n(.*?)```", readme, re.DOTALL)
        (extra,) = [block for block in blocks if block.startswith("[controller]")]
        scenario = parse_scenario(blocks[0] + extra)
        assert scenario.controller is not None
        assert scenario.controller.outputs == ("v", "force")
        assert scenario.controller.neighbourhoods(2) == ((0, 1), (0, 1))
        assert dict(scenario.expected) == {
            "open_loop_stability": "pass",
            "ndmpc_convergence": "pass",
        }

    def test_not_reserved_any_more(self) -> None:
        """[controller] is a real section, not a reserved one."""
        assert "controller" not in RESERVED_SECTIONS
        error = check_fails(BASE + "[controller]\n", "missing required key [controller].form")
        assert "reserved" not in str(error)

    def test_full_section(self) -> None:
        """Every key is read with its value, units kept as documented."""
        ctl = parse_scenario(BASE + FULL_CONTROLLER).controller
        assert ctl == ControllerSettings(
            form="du",
            prediction_horizon=6,
            control_horizon=3,
            outputs=("force", "v"),
            q_velocity=2.5,
            q_force=0.5,
            input_weight=2e-5,
            input_weight_unit="N",
            neighbourhood=((1, 0), (1, 2, 0), (2,)),
            iterations=4,
            cooperative_weights=(0.5, 0.25, 0.25),
        )
        assert ctl is not None
        assert ctl.input_weight_per_kn2() == pytest.approx(20.0)
        assert ctl.neighbourhoods(3) == ((0, 1), (0, 1, 2), (2,))
        assert ctl.cooperative_weight_vector(3) == (0.5, 0.25, 0.25)

    def test_defaults(self) -> None:
        """Omitted optional keys take their documented defaults."""
        ctl = parse_scenario(with_controller()).controller
        assert ctl is not None
        assert (ctl.form, ctl.prediction_horizon, ctl.control_horizon) == ("u", 4, 2)
        assert ctl.outputs == ("v",)
        assert (ctl.q_velocity, ctl.q_force) == (1.0, 0.0)
        assert (ctl.input_weight, ctl.input_weight_unit) == (10.0, "kN")
        assert ctl.input_weight_per_kn2() == 10.0
        assert ctl.neighbourhood == "adjacent"
        assert ctl.iterations == 10
        assert ctl.cooperative_weights == "uniform"
        assert ctl.cooperative_weight_vector(4) == (0.25, 0.25, 0.25, 0.25)

    def test_r_per_n2_converts(self) -> None:
        """r_per_n2 keeps the user's unit and converts to per kN^2 as r * 1e6."""
        ctl = parse_scenario(controller_without("r_per_kn2", "r_per_n2 = 3e-6")).controller
        assert ctl is not None
        assert (ctl.input_weight, ctl.input_weight_unit) == (3e-6, "N")
        assert ctl.input_weight_per_kn2() == pytest.approx(3.0, rel=1e-12)

    def test_ints_become_floats(self) -> None:
        """TOML integers for weights become floats."""
        ctl = parse_scenario(with_controller("q_velocity = 2", "q_force_per_kn2 = 0")).controller
        assert ctl is not None
        assert isinstance(ctl.q_velocity, float) and isinstance(ctl.q_force, float)

    def test_m_equals_p(self) -> None:
        """M = P is allowed."""
        ctl = parse_scenario(controller_without("control_horizon", "control_horizon = 4"))
        assert ctl.controller is not None and ctl.controller.control_horizon == 4

    @pytest.mark.parametrize(
        ("kind", "expected"),
        [
            ("adjacent", ((0, 1), (0, 1, 2), (1, 2, 3), (2, 3))),
            ("all", ((0, 1, 2, 3),) * 4),
            ("self", ((0,), (1,), (2,), (3,))),
        ],
    )
    def test_named_neighbourhoods(self, kind: str, expected: tuple) -> None:
        """The named kinds resolve to {i-1, i, i+1}, every coach, or {i} alone."""
        ctl = parse_scenario(with_controller(f'neighbourhood = "{kind}"')).controller
        assert ctl is not None and ctl.neighbourhood == kind
        assert ctl.neighbourhoods(4) == expected

    def test_single_coach_neighbourhoods(self) -> None:
        """A one-coach train has the neighbourhood (0,) whatever the kind."""
        for kind in ("adjacent", "all", "self"):
            assert make_controller(neighbourhood=kind).neighbourhoods(1) == ((0,),)

    def test_weights_within_tolerance(self) -> None:
        """Cooperative weights summing to 1 within 1e-9 are accepted."""
        ctl = parse_scenario(
            with_controller("cooperative_weights = [0.3333333333, 0.3333333333, 0.3333333334]")
        )
        assert ctl.controller is not None
        assert len(ctl.controller.cooperative_weight_vector(3)) == 3


class TestControllerErrors:
    """Malformed [controller] sections, each with its key path."""

    @pytest.mark.parametrize(
        ("key", "fragment"),
        [
            ("form", "missing required key [controller].form (one of 'u', 'du')"),
            (
                "prediction_horizon",
                "missing required key [controller].prediction_horizon (an integer from 1 to 2000)",
            ),
            ("control_horizon", "missing required key [controller].control_horizon"),
        ],
    )
    def test_missing_required(self, key: str, fragment: str) -> None:
        """form and both horizons are required."""
        check_fails(controller_without(key), fragment)

    def test_bad_form(self) -> None:
        """An unknown form lists the options."""
        check_fails(
            controller_without("form", 'form = "delta"'),
            "[controller].form must be one of 'u', 'du' (got 'delta', a string)",
        )

    def test_m_greater_than_p(self) -> None:
        """M > P is rejected, naming P's value."""
        check_fails(
            controller_without("control_horizon", "control_horizon = 5"),
            "[controller].control_horizon must be an integer from 1 to "
            "[controller].prediction_horizon = 4 (got 5)",
            "free moves",
        )

    @pytest.mark.parametrize(
        ("key", "value", "fragment"),
        [
            (
                "prediction_horizon",
                "0",
                "[controller].prediction_horizon must be an integer >= 1 (got 0)",
            ),
            (
                "control_horizon",
                "0",
                "[controller].control_horizon must be an integer >= 1 (got 0)",
            ),
            (
                "prediction_horizon",
                "true",
                "[controller].prediction_horizon must be an integer >= 1 (got true, a boolean)",
            ),
            (
                "control_horizon",
                "2.0",
                "[controller].control_horizon must be an integer >= 1 (got 2.0)",
            ),
            ("prediction_horizon", '"4"', "[controller].prediction_horizon must be an integer"),
        ],
    )
    def test_bad_horizon(self, key: str, value: str, fragment: str) -> None:
        """Horizons must be integers >= 1, not bools, floats or strings."""
        check_fails(controller_without(key, f"{key} = {value}"), fragment)

    @pytest.mark.parametrize("line", ["iterations = 0", "iterations = 1.5", "iterations = false"])
    def test_bad_iterations(self, line: str) -> None:
        """iterations must be an integer >= 1."""
        check_fails(with_controller(line), "[controller].iterations must be an integer >= 1")

    def test_both_input_weights(self) -> None:
        """r_per_kn2 and r_per_n2 together are rejected."""
        check_fails(
            with_controller("r_per_n2 = 1e-5"),
            "[controller] needs exactly one of r_per_kn2, r_per_n2 (got r_per_kn2 and r_per_n2)",
            "r_per_kn2 = r_per_n2 × 1e6",
        )

    def test_no_input_weight(self) -> None:
        """One of r_per_kn2 / r_per_n2 is required."""
        check_fails(
            controller_without("r_per_kn2"),
            "[controller] needs exactly one of r_per_kn2, r_per_n2 (got none)",
        )

    @pytest.mark.parametrize(
        ("line", "fragment"),
        [
            ("r_per_kn2 = 0.0", "[controller].r_per_kn2 must be a number > 0 (got 0.0)"),
            ("r_per_kn2 = -1", "[controller].r_per_kn2 must be a number > 0 (got -1)"),
            ("r_per_n2 = 0", "[controller].r_per_n2 must be a number > 0 (got 0)"),
            ("r_per_kn2 = inf", "[controller].r_per_kn2 must be a finite number > 0"),
            ("r_per_kn2 = nan", "[controller].r_per_kn2 must be a finite number > 0"),
        ],
    )
    def test_input_weight_not_positive(self, line: str, fragment: str) -> None:
        """The input weight must be a finite number > 0."""
        check_fails(controller_without("r_per_kn2", line), fragment)

    @pytest.mark.parametrize(
        ("line", "fragment"),
        [
            ("q_velocity = -1.0", "[controller].q_velocity must be a number >= 0 (got -1.0)"),
            ("q_force_per_kn2 = -0.5", "[controller].q_force_per_kn2 must be a number >= 0"),
            (
                'q_velocity = "1"',
                "[controller].q_velocity must be a number >= 0 (got '1', a string)",
            ),
        ],
    )
    def test_bad_output_weight(self, line: str, fragment: str) -> None:
        """Output weights must be numbers >= 0."""
        check_fails(with_controller(line), fragment)

    def test_unknown_output(self) -> None:
        """An unknown output names its index and suggests a close one."""
        check_fails(
            with_controller('outputs = ["v", "forces"]'),
            "[controller].outputs[1] must be one of 'v', 'force' (got 'forces', a string)",
            "Did you mean 'force'?",
        )

    def test_output_not_a_string(self) -> None:
        """An output that is not a string is rejected."""
        check_fails(
            with_controller("outputs = [1]"),
            "[controller].outputs[0] must be one of 'v', 'force' (got 1)",
        )

    def test_duplicate_output(self) -> None:
        """An output listed twice is rejected."""
        check_fails(
            with_controller('outputs = ["v", "force", "v"]'),
            "[controller].outputs[2] must not repeat an earlier output (got 'v' again)",
        )

    @pytest.mark.parametrize(
        ("line", "got"),
        [("outputs = []", "an array of 0 items"), ('outputs = "v"', "'v', a string")],
    )
    def test_outputs_not_a_non_empty_array(self, line: str, got: str) -> None:
        """outputs must be a non-empty array."""
        check_fails(
            with_controller(line), "[controller].outputs must be a non-empty array", f"(got {got})"
        )

    def test_force_output_without_couplers(self) -> None:
        """'force' is rejected for a one-vehicle train, which has no couplers."""
        check_fails(
            SINGLE + CONTROLLER + 'outputs = ["force"]\n',
            "[controller].outputs[0] must be 'v' for a train of one vehicle",
        )

    def test_force_weight_without_force_output(self) -> None:
        """q_force_per_kn2 > 0 needs 'force' in outputs, with a hint."""
        check_fails(
            with_controller("q_force_per_kn2 = 2.0"),
            "[controller].q_force_per_kn2 must be 0 when [controller].outputs has no 'force' "
            "(got 2.0 with outputs ['v'])",
            'Add "force" to outputs',
        )

    def test_neighbourhood_wrong_length(self) -> None:
        """An explicit neighbourhood needs one entry per coach."""
        check_fails(
            with_controller("neighbourhood = [[0, 1], [0, 1]]"),
            "[controller].neighbourhood must be one of 'adjacent', 'all', 'self' or an array of "
            "3 arrays of coach indices, one per coach (got an array of 2 items)",
            "the train has 3 coaches",
        )

    def test_neighbourhood_missing_own_index(self) -> None:
        """Entry i must contain i."""
        check_fails(
            with_controller("neighbourhood = [[0], [1], [0, 1]]"),
            "[controller].neighbourhood[2] must contain its own coach index 2 (got [0, 1])",
        )

    @pytest.mark.parametrize("bad", ["3", "-1", "1.0", "true", '"1"'])
    def test_neighbourhood_index_out_of_range(self, bad: str) -> None:
        """Indices must be integers from 0 to n-1; the message names entry and position."""
        check_fails(
            with_controller(f"neighbourhood = [[0], [1, {bad}], [2]]"),
            "[controller].neighbourhood[1][1] must be a coach index from 0 to 2",
            "Indices count from 0",
        )

    def test_neighbourhood_duplicates(self) -> None:
        """An index listed twice in one entry is rejected."""
        check_fails(
            with_controller("neighbourhood = [[0], [1, 2, 1], [2]]"),
            "[controller].neighbourhood[1] must list distinct coach indices (got [1, 2, 1])",
        )

    def test_neighbourhood_entry_not_array(self) -> None:
        """Each entry must be an array."""
        check_fails(
            with_controller("neighbourhood = [[0], 1, [2]]"),
            "[controller].neighbourhood[1] must be an array of coach indices (got 1)",
        )

    def test_neighbourhood_unknown_kind(self) -> None:
        """An unknown named kind suggests a close one."""
        check_fails(
            with_controller('neighbourhood = "adjacnt"'),
            "[controller].neighbourhood must be one of 'adjacent', 'all', 'self'",
            "Did you mean 'adjacent'?",
        )

    def test_weights_not_summing_to_one(self) -> None:
        """Cooperative weights must sum to 1 within 1e-9."""
        check_fails(
            with_controller("cooperative_weights = [0.5, 0.25, 0.2]"),
            "[controller].cooperative_weights must sum to 1 within 1e-9 (got sum 0.95)",
        )

    def test_weights_slightly_off(self) -> None:
        """A sum off by more than 1e-9 is rejected."""
        check_fails(
            with_controller("cooperative_weights = [0.5, 0.25, 0.25000001]"),
            "[controller].cooperative_weights must sum to 1",
        )

    def test_weights_wrong_length(self) -> None:
        """Cooperative weights need one entry per coach."""
        check_fails(
            with_controller("cooperative_weights = [0.5, 0.5]"),
            "[controller].cooperative_weights must be 'uniform' or an array of 3 numbers > 0 "
            "summing to 1, one per coach (got an array of 2 items)",
        )

    @pytest.mark.parametrize("bad", ["0.0", "-0.5", "nan", "true"])
    def test_weight_not_positive(self, bad: str) -> None:
        """Each cooperative weight must be a finite number > 0, named by index."""
        check_fails(
            with_controller(f"cooperative_weights = [0.5, 0.5, {bad}]"),
            "[controller].cooperative_weights[2] must be a",
        )

    def test_weights_unknown_name(self) -> None:
        """A misspelt 'uniform' gets a suggestion."""
        check_fails(
            with_controller('cooperative_weights = "unifrom"'),
            "[controller].cooperative_weights must be 'uniform'",
            "Did you mean 'uniform'?",
        )

    def test_unknown_key_suggests(self) -> None:
        """A misspelt key in [controller] suggests the right one."""
        error = check_fails(
            with_controller("prediction_horizn = 4"),
            "unknown key [controller].prediction_horizn. Did you mean 'prediction_horizon'?",
        )
        assert "reserved" not in str(error)

    def test_unknown_key_r(self) -> None:
        """A unit-less weight key suggests a unit-carrying one."""
        check_fails(
            with_controller("r_per_kn = 1.0"),
            "unknown key [controller].r_per_kn. Did you mean 'r_per_kn2'?",
        )

    def test_not_a_table(self) -> None:
        """controller given as a value, not a table, is rejected."""
        check_fails("controller = 1\n" + BASE, "[controller] must be a table (got 1)")


class TestExpected:
    """The [expected] section: check name to declared status."""

    def test_absent_is_empty(self) -> None:
        """Without [expected] the mapping is empty."""
        assert dict(parse_scenario(BASE).expected) == {}

    def test_valid(self) -> None:
        """Statuses are kept per check in file order."""
        text = with_controller(
            "[expected]",
            'sampling = "fail"',
            'ndmpc_convergence = "pass"',
            'nash_gap = "warn"',
        )
        expected = parse_scenario(text).expected
        assert list(expected.items()) == [
            ("sampling", "fail"),
            ("ndmpc_convergence", "pass"),
            ("nash_gap", "warn"),
        ]

    def test_every_check_name(self) -> None:
        """Every name in CHECK_NAMES is accepted."""
        lines = [f'{name} = "pass"' for name in CHECK_NAMES]
        expected = parse_scenario(with_controller("[expected]", *lines)).expected
        assert tuple(expected) == CHECK_NAMES

    def test_model_checks_without_controller(self) -> None:
        """Model-level checks may be declared without a [controller]."""
        text = BASE + '[expected]\nopen_loop_stability = "pass"\ninput_collapse = "warn"\n'
        assert dict(parse_scenario(text).expected) == {
            "open_loop_stability": "pass",
            "input_collapse": "warn",
        }

    def test_controller_check_needs_controller(self) -> None:
        """A controller check declared without [controller] is rejected."""
        check_fails(
            BASE + '[expected]\nclosed_loop_nash = "pass"\n',
            "[expected].closed_loop_nash needs a [controller] section (got none)",
        )

    def test_read_only(self) -> None:
        """The mapping cannot be changed."""
        expected = parse_scenario(BASE + '[expected]\nsampling = "pass"\n').expected
        with pytest.raises(TypeError):
            expected["sampling"] = "fail"  # type: ignore[index]

    def test_hashable_and_picklable(self) -> None:
        """The mapping hashes, compares to a dict and survives pickle and deepcopy."""
        scenario = parse_scenario(BASE + '[expected]\nsampling = "pass"\n')
        expected = scenario.expected
        assert isinstance(hash(expected), int)
        assert expected == {"sampling": "pass"}
        assert pickle.loads(pickle.dumps(scenario)).expected == expected
        assert copy.deepcopy(expected) == expected

    def test_unknown_check_suggests(self) -> None:
        """An unknown check name suggests a close one."""
        check_fails(
            BASE + '[expected]\nsamplng = "pass"\n',
            "unknown key [expected].samplng. Did you mean 'sampling'?",
        )

    def test_unknown_check_lists_names(self) -> None:
        """Without a close match the check names are listed."""
        check_fails(BASE + '[expected]\nzzz = "pass"\n', "unknown key [expected].zzz.", "nash_gap")

    @pytest.mark.parametrize(
        ("value", "got"), [('"passed"', "'passed', a string"), ("true", "true, a boolean")]
    )
    def test_bad_status(self, value: str, got: str) -> None:
        """A status other than pass, warn or fail is rejected."""
        check_fails(
            BASE + f"[expected]\nsampling = {value}\n",
            "[expected].sampling must be one of 'pass', 'warn', 'fail'",
            f"(got {got})",
        )

    def test_status_suggestion(self) -> None:
        """A misspelt status suggests a close one."""
        check_fails(BASE + '[expected]\nsampling = "warning"\n', "Did you mean 'warn'?")


class TestControllerSettings:
    """ControllerSettings and Scenario built directly, without a file."""

    def test_defaults_and_frozen(self) -> None:
        """The defaults match the file defaults and the object is immutable."""
        ctl = make_controller()
        assert (ctl.outputs, ctl.q_velocity, ctl.q_force) == (("v",), 1.0, 0.0)
        assert (ctl.input_weight_unit, ctl.neighbourhood) == ("kN", "adjacent")
        assert (ctl.iterations, ctl.cooperative_weights) == (10, "uniform")
        with pytest.raises(dataclasses.FrozenInstanceError):
            ctl.iterations = 3  # type: ignore[misc]

    def test_sequences_become_tuples(self) -> None:
        """Lists given for outputs, neighbourhood and weights are stored as tuples."""
        ctl = make_controller(
            outputs=["v", "force"],
            q_force=1,
            neighbourhood=[[0, 1], [1]],
            cooperative_weights=[0.5, 0.5],
        )
        assert ctl.outputs == ("v", "force")
        assert ctl.neighbourhood == ((0, 1), (1,))
        assert ctl.cooperative_weights == (0.5, 0.5)
        assert isinstance(ctl.q_force, float)
        hash(ctl)

    @pytest.mark.parametrize(
        ("changes", "fragment"),
        [
            ({"form": "x"}, "'form' must be one of"),
            ({"prediction_horizon": 0}, "'prediction_horizon' must be an integer >= 1"),
            ({"control_horizon": True}, "'control_horizon' must be an integer >= 1"),
            (
                {"control_horizon": 5},
                "'control_horizon' must be an integer from 1 to 'prediction_horizon' = 4",
            ),
            ({"iterations": 1.0}, "'iterations' must be an integer >= 1"),
            ({"outputs": ()}, "'outputs' must be a non-empty array of distinct names"),
            ({"outputs": ("v", "v")}, "'outputs'[1] must not repeat an earlier output"),
            ({"outputs": ("x",)}, "'outputs'[0] must be one of ('v', 'force')"),
            ({"q_velocity": -1.0}, "'q_velocity' must be a finite number >= 0"),
            ({"q_force": 1.0}, "'q_force' must be 0 when 'outputs' has no 'force'"),
            ({"input_weight": 0.0}, "'input_weight' must be a finite number > 0"),
            ({"input_weight": math.inf}, "'input_weight' must be a finite number > 0"),
            ({"input_weight": "1"}, "'input_weight' must be a finite number > 0"),
            ({"input_weight_unit": "kn"}, "'input_weight_unit' must be one of ('kN', 'N')"),
            ({"neighbourhood": "near"}, "'neighbourhood' must be one of"),
            ({"neighbourhood": 3}, "'neighbourhood' must be one of"),
            ({"neighbourhood": ((1,), (1,))}, "'neighbourhood'[0] must contain its own coach"),
            ({"neighbourhood": ((0, 0),)}, "'neighbourhood'[0] must list distinct coach"),
            ({"neighbourhood": ((0, -1),)}, "'neighbourhood'[0][1] must be a coach index >= 0"),
            ({"neighbourhood": ()}, "'neighbourhood' must be one of"),
            ({"cooperative_weights": "even"}, "'cooperative_weights' must be 'uniform'"),
            ({"cooperative_weights": (0.5, 0.4)}, "'cooperative_weights' must sum to 1"),
            ({"cooperative_weights": (1.5, -0.5)}, "'cooperative_weights'[1] must be a finite"),
            ({"cooperative_weights": ()}, "'cooperative_weights' must be 'uniform' or an array"),
            ({"cooperative_weights": 1.0}, "'cooperative_weights' must be 'uniform' or an array"),
        ],
    )
    def test_validates(self, changes: dict, fragment: str) -> None:
        """Invalid values raise ModelError naming the field."""
        with pytest.raises(ModelError, match=re.escape(f"ControllerSettings: {fragment}")):
            make_controller(**changes)

    def test_explicit_neighbourhoods_checked_against_n(self) -> None:
        """neighbourhoods(n) rejects an explicit list of the wrong length or range."""
        ctl = make_controller(neighbourhood=((0, 2), (1,), (2,)))
        assert ctl.neighbourhoods(3) == ((0, 2), (1,), (2,))
        with pytest.raises(ModelError, match="an array of 4 arrays of coach indices") as info:
            ctl.neighbourhoods(4)
        assert "the train has 4 coaches" in str(info.value)
        with pytest.raises(ModelError, match="'neighbourhood' must be one of .* an array of 2"):
            ctl.neighbourhoods(2)

    def test_explicit_neighbourhood_index_beyond_n(self) -> None:
        """An index >= n is rejected by neighbourhoods(n)."""
        ctl = make_controller(neighbourhood=((0, 5), (1,)))
        message = "'neighbourhood'[0][1] must be a coach index from 0 to 1 (got 5)"
        with pytest.raises(ModelError, match=re.escape(message)):
            ctl.neighbourhoods(2)

    @pytest.mark.parametrize("n", [0, -1, 1.0, True])
    def test_bad_n(self, n: object) -> None:
        """n must be an integer >= 1."""
        with pytest.raises(ModelError, match="'n' must be an integer >= 1"):
            make_controller().neighbourhoods(n)  # type: ignore[arg-type]
        with pytest.raises(ModelError, match="'n' must be an integer >= 1"):
            make_controller().cooperative_weight_vector(n)  # type: ignore[arg-type]

    def test_weight_vector_wrong_length(self) -> None:
        """cooperative_weight_vector(n) rejects weights of another length."""
        with pytest.raises(ModelError, match="'cooperative_weights' must be 'uniform' or an array"):
            make_controller(cooperative_weights=(0.5, 0.5)).cooperative_weight_vector(3)

    def test_scenario_checks_controller_against_train(self) -> None:
        """Scenario built directly rejects a controller that does not fit the train."""
        scenario = parse_scenario(BASE)
        with pytest.raises(ModelError, match="'neighbourhood' must be one of .* an array of 3"):
            dataclasses.replace(scenario, controller=make_controller(neighbourhood=((0,), (1,))))

    def test_scenario_checks_expected(self) -> None:
        """Scenario built directly validates and freezes expected."""
        scenario = parse_scenario(BASE)
        frozen = dataclasses.replace(scenario, expected={"sampling": "warn"})
        assert frozen.expected == {"sampling": "warn"}
        with pytest.raises(TypeError):
            frozen.expected["sampling"] = "pass"  # type: ignore[index]
        with pytest.raises(ModelError, match="unknown check 'samplin'. Did you mean 'sampling'?"):
            dataclasses.replace(scenario, expected={"samplin": "warn"})
        with pytest.raises(ModelError, match=r"'expected'\['sampling'\] must be one of"):
            dataclasses.replace(scenario, expected={"sampling": "ok"})
        with pytest.raises(ModelError, match="needs a controller"):
            dataclasses.replace(scenario, expected={"nash_gap": "pass"})


def controller_with(*lines: str) -> ControllerSettings:
    """The [controller] of BASE plus the minimal controller with ``lines`` appended."""
    ctl = parse_scenario(with_controller(*lines)).controller
    assert ctl is not None
    return ctl


class TestControllerConstraints:
    """The iteration and constraint keys of [controller] used in simulation."""

    def test_defaults(self) -> None:
        """Omitted keys take their documented defaults; limits default to no limit."""
        ctl = controller_with()
        assert (ctl.max_iterations, ctl.iteration_tolerance, ctl.relaxation) == (50, 1e-4, 1.0)
        assert ctl.input_bounds is True
        assert (ctl.rate_limit, ctl.coupler_force_limit) == (math.inf, math.inf)
        assert (ctl.soft_penalty_linear, ctl.soft_penalty_quadratic) == (1000.0, 100.0)
        assert ctl.solver_path == "fast"
        assert ctl == make_controller()

    def test_all_keys(self) -> None:
        """Every key is read; kN limits become N, the tolerance stays in kN."""
        ctl = controller_with(
            "max_iterations = 7",
            "iteration_tolerance_kn = 0.01",
            "relaxation = 0.5",
            "input_bounds = false",
            "rate_limit_kn = 20.0",
            "coupler_force_limit_kn = 500.0",
            "soft_penalty_linear = 0.0",
            "soft_penalty_quadratic = 2.5",
            'solver_path = "cvxpy"',
        )
        assert (ctl.max_iterations, ctl.iteration_tolerance, ctl.relaxation) == (7, 0.01, 0.5)
        assert ctl.input_bounds is False
        assert ctl.rate_limit == pytest.approx(2e4)
        assert ctl.coupler_force_limit == pytest.approx(5e5)
        assert (ctl.soft_penalty_linear, ctl.soft_penalty_quadratic) == (0.0, 2.5)
        assert ctl.solver_path == "cvxpy"

    def test_ints_become_floats(self) -> None:
        """Numbers written as TOML integers are stored as floats."""
        ctl = controller_with("relaxation = 1", "rate_limit_kn = 3", "soft_penalty_quadratic = 4")
        for value in (ctl.relaxation, ctl.rate_limit, ctl.soft_penalty_quadratic):
            assert isinstance(value, float)
        assert ctl.rate_limit == 3000.0

    def test_every_solver_path(self) -> None:
        """Each name in SOLVER_PATHS is accepted."""
        for path in SOLVER_PATHS:
            assert controller_with(f'solver_path = "{path}"').solver_path == path

    def test_qp_solver(self) -> None:
        """qp_solver defaults to "auto"; each of "auto", "osqp", "daqp" is accepted."""
        assert controller_with().qp_solver == "auto"
        for solver in ("auto", "osqp", "daqp"):
            assert controller_with(f'qp_solver = "{solver}"').qp_solver == solver

    def test_bad_qp_solver(self) -> None:
        check_fails(
            with_controller('qp_solver = "dapq"'),
            "[controller].qp_solver must be one of 'auto', 'osqp', 'daqp' (got 'dapq', a "
            "string).",
        )

    def test_mpc_constraints(self) -> None:
        """mpc_constraints() copies the settings into MPCConstraints, limits in N."""
        from trainctl.controllers.mpc import MPCConstraints

        ctl = controller_with(
            "input_bounds = false",
            "rate_limit_kn = 20.0",
            "coupler_force_limit_kn = 500.0",
            "soft_penalty_linear = 5.0",
            "soft_penalty_quadratic = 6.0",
        )
        assert ctl.mpc_constraints() == MPCConstraints(
            input_bounds=False,
            rate_limit=2e4,
            coupler_force_limit=5e5,
            soft_linear=5.0,
            soft_quadratic=6.0,
        )

    def test_default_constraints_match_mpc_defaults(self) -> None:
        """The file defaults give the MPC's own default constraints."""
        from trainctl.controllers.mpc import MPCConstraints

        assert make_controller().mpc_constraints() == MPCConstraints()

    def test_strategy_names_match_mpc(self) -> None:
        """SIMULATION_STRATEGIES is the MPC module's STRATEGIES."""
        from trainctl.controllers.mpc import STRATEGIES

        assert SIMULATION_STRATEGIES == STRATEGIES

    def test_import_stays_light(self) -> None:
        """Importing trainctl.scenario does not import the MPC controller or cvxpy."""
        import subprocess

        code = (
            "import sys, trainctl.scenario; "
            "print('trainctl.controllers.mpc.controller' in sys.modules, 'cvxpy' in sys.modules)"
        )
        result = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        )
        assert result.stdout.split() == ["False", "False"]

    @pytest.mark.parametrize(
        ("line", "fragment"),
        [
            ("max_iterations = 0", "[controller].max_iterations must be an integer >= 1 (got 0)"),
            ("max_iterations = 2.0", "[controller].max_iterations must be an integer >= 1"),
            ("max_iterations = true", "[controller].max_iterations must be an integer >= 1"),
            (
                "iteration_tolerance_kn = 0.0",
                "[controller].iteration_tolerance_kn must be a number > 0 (got 0.0)",
            ),
            ("iteration_tolerance_kn = nan", "[controller].iteration_tolerance_kn must be a"),
            ("relaxation = 0.0", "[controller].relaxation must be a number in (0, 1] (got 0.0)"),
            ("relaxation = -0.5", "[controller].relaxation must be a number in (0, 1]"),
            ("relaxation = 1.5", "[controller].relaxation must be a number in (0, 1] (got 1.5)"),
            ("input_bounds = 1", "[controller].input_bounds must be true or false (got 1)"),
            ('input_bounds = "yes"', "[controller].input_bounds must be true or false"),
            ("rate_limit_kn = 0.0", "[controller].rate_limit_kn must be a number > 0 (got 0.0)"),
            ('rate_limit_kn = "20"', "[controller].rate_limit_kn must be a number > 0"),
            ("coupler_force_limit_kn = -5.0", "[controller].coupler_force_limit_kn must be a"),
            ("soft_penalty_linear = -1.0", "[controller].soft_penalty_linear must be a number >="),
            (
                "soft_penalty_quadratic = 0",
                "[controller].soft_penalty_quadratic must be a number >",
            ),
        ],
    )
    def test_bad_value(self, line: str, fragment: str) -> None:
        """Out-of-range or wrongly typed values name the key and what must hold."""
        check_fails(with_controller(line), fragment)

    @pytest.mark.parametrize("key", ["rate_limit_kn", "coupler_force_limit_kn"])
    def test_inf_limit_hint(self, key: str) -> None:
        """An infinite limit is rejected with the hint to omit the key."""
        check_fails(
            with_controller(f"{key} = inf"),
            f"[controller].{key} must be a finite number > 0",
            "Omit the key for no limit.",
        )

    def test_bad_solver_path(self) -> None:
        """An unknown solver path lists the choices and suggests a close one."""
        check_fails(
            with_controller('solver_path = "cvx"'),
            "[controller].solver_path must be one of 'fast', 'cvxpy' (got 'cvx', a string).",
            "Did you mean 'cvxpy'?",
        )

    def test_unit_less_key_suggests(self) -> None:
        """A limit key without its unit suggests the unit-carrying one."""
        check_fails(
            with_controller("rate_limit = 20.0"),
            "unknown key [controller].rate_limit. Did you mean 'rate_limit_kn'?",
        )


class TestControllerSettingsConstraints:
    """The new ControllerSettings fields built directly, without a file."""

    def test_limits_in_newtons(self) -> None:
        """Limits are given in N; inf means no limit; ints become floats."""
        ctl = make_controller(rate_limit=20_000, coupler_force_limit=math.inf, relaxation=1)
        assert ctl.rate_limit == 20_000.0 and isinstance(ctl.rate_limit, float)
        assert ctl.coupler_force_limit == math.inf
        assert isinstance(ctl.relaxation, float)
        assert ctl.mpc_constraints().rate_limit == 20_000.0

    @pytest.mark.parametrize(
        ("changes", "fragment"),
        [
            ({"max_iterations": 0}, "'max_iterations' must be an integer >= 1"),
            ({"max_iterations": 2.0}, "'max_iterations' must be an integer >= 1"),
            ({"iteration_tolerance": 0.0}, "'iteration_tolerance' must be a finite number > 0"),
            ({"iteration_tolerance": math.inf}, "'iteration_tolerance' must be a finite number"),
            ({"relaxation": 0.0}, "'relaxation' must be a finite number in (0, 1]"),
            ({"relaxation": 1.01}, "'relaxation' must be a finite number in (0, 1]"),
            ({"input_bounds": 1}, "'input_bounds' must be True or False"),
            ({"rate_limit": 0.0}, "'rate_limit' must be a number > 0, or inf for no limit"),
            ({"rate_limit": math.nan}, "'rate_limit' must be a number > 0, or inf for no limit"),
            ({"coupler_force_limit": -1.0}, "'coupler_force_limit' must be a number > 0"),
            ({"coupler_force_limit": "5e5"}, "'coupler_force_limit' must be a number > 0"),
            ({"soft_penalty_linear": -1.0}, "'soft_penalty_linear' must be a finite number >= 0"),
            ({"soft_penalty_quadratic": 0.0}, "'soft_penalty_quadratic' must be a finite number"),
            ({"solver_path": "osqp"}, "'solver_path' must be one of ('fast', 'cvxpy')"),
        ],
    )
    def test_validates(self, changes: dict, fragment: str) -> None:
        """Invalid values raise ModelError naming the field."""
        with pytest.raises(ModelError, match=re.escape(f"ControllerSettings: {fragment}")):
            make_controller(**changes)


SIMULATION = """
[simulation]
duration = 1200.0
strategies = ["centralised", "decentralised", "ndmpc"]

[simulation.reference]
times = [0.0, 60.0, 460.0, 1020.0, 1200.0]
speeds_kmh = [72.0, 72.0, 216.0, 288.0, 288.0]
"""


def with_simulation(*lines: str, reference: str | None = None, controller: bool = True) -> str:
    """BASE, the minimal [controller] and [simulation] with ``lines`` added.

    ``lines`` go into [simulation]; ``reference`` replaces the body of
    [simulation.reference] when given.
    """
    head, body = SIMULATION.split("[simulation.reference]\n")
    head += "".join(f"{line}\n" for line in lines)
    if reference is not None:
        body = reference if reference.endswith("\n") else reference + "\n"
    return BASE + (CONTROLLER if controller else "") + head + "[simulation.reference]\n" + body


def simulation_of(text: str) -> SimulationSettings:
    """Parse ``text`` and return its simulation settings."""
    sim = parse_scenario(text).simulation
    assert sim is not None
    return sim


def make_simulation(**changes: object) -> SimulationSettings:
    """A valid SimulationSettings with ``changes`` applied."""
    settings: dict[str, object] = {
        "duration": 100.0,
        "strategies": ("ndmpc",),
        "reference_times": (0.0, 50.0),
        "reference_speeds": (20.0, 30.0),
    }
    settings.update(changes)
    return SimulationSettings(**settings)  # type: ignore[arg-type]


class TestSimulationValid:
    """A well-formed [simulation] section, its defaults and conversions."""

    def test_absent_is_none(self) -> None:
        """Without [simulation] the scenario has no simulation."""
        assert parse_scenario(with_controller()).simulation is None

    def test_not_reserved_any_more(self) -> None:
        """[simulation] is a real section, not a reserved one."""
        assert "simulation" not in RESERVED_SECTIONS
        assert RESERVED_SECTIONS == ("report",)
        error = check_fails(
            with_controller("[simulation]"), "missing required key [simulation].duration"
        )
        assert "reserved" not in str(error)

    def test_defaults(self) -> None:
        """Omitted optional keys take their documented defaults; km/h become m/s."""
        sim = simulation_of(with_simulation())
        assert sim == SimulationSettings(
            duration=1200.0,
            strategies=("centralised", "decentralised", "ndmpc"),
            reference_times=(0.0, 60.0, 460.0, 1020.0, 1200.0),
            reference_speeds=sim.reference_speeds,
        )
        assert sim.reference_speeds == pytest.approx((20.0, 20.0, 60.0, 80.0, 80.0))
        assert (sim.initial_speed_error, sim.measurement_noise, sim.settle_time) == (0.0, 0.0, 0.0)
        assert (sim.tracking_tolerance, sim.regen_efficiency) == (1.0, 1.0)
        assert sim.n_steps(20.0) == 60

    def test_full_section(self) -> None:
        """Every key is read with its value, SI inside."""
        sim = simulation_of(
            with_simulation(
                "initial_speed_error = -2.5",
                "measurement_noise = 0.1",
                "settle_time = 100",
                "tracking_tolerance = 0.5",
                "regen_efficiency = 0.8",
            )
        )
        assert sim.initial_speed_error == -2.5
        assert sim.measurement_noise == 0.1
        assert sim.settle_time == 100.0 and isinstance(sim.settle_time, float)
        assert (sim.tracking_tolerance, sim.regen_efficiency) == (0.5, 0.8)

    def test_speeds_in_metres_per_second(self) -> None:
        """speeds (m/s) is used as given, integers becoming floats."""
        sim = simulation_of(with_simulation(reference="times = [0, 600]\nspeeds = [20, 80.5]"))
        assert sim.reference_times == (0.0, 600.0)
        assert sim.reference_speeds == (20.0, 80.5)
        assert all(isinstance(v, float) for v in sim.reference_times + sim.reference_speeds)

    def test_constant_reference(self) -> None:
        """A single breakpoint at t = 0 is a constant reference."""
        sim = simulation_of(with_simulation(reference="times = [0.0]\nspeeds_kmh = [300.0]"))
        assert sim.reference_times == (0.0,)
        assert sim.reference_speeds == pytest.approx((83.3333333,))

    def test_zero_speed_allowed(self) -> None:
        """A reference speed of 0 (standstill) is accepted."""
        sim = simulation_of(with_simulation(reference="times = [0, 10]\nspeeds = [0, 0]"))
        assert sim.reference_speeds == (0.0, 0.0)

    def test_every_strategy(self) -> None:
        """All strategies may be listed, in any order, and the order is kept."""
        names = ", ".join(f'"{s}"' for s in reversed(SIMULATION_STRATEGIES))
        text = with_simulation().replace(
            'strategies = ["centralised", "decentralised", "ndmpc"]', f"strategies = [{names}]"
        )
        assert simulation_of(text).strategies == tuple(reversed(SIMULATION_STRATEGIES))

    def test_duration_multiple_within_tolerance(self) -> None:
        """A duration that is a multiple up to rounding (0.3 / 0.1) is accepted."""
        text = with_simulation().replace("sample_time = 20.0", "sample_time = 0.1")
        text = text.replace("duration = 1200.0", "duration = 0.3")
        sim = simulation_of(text)
        assert sim.n_steps(0.1) == 3

    def test_one_sample(self) -> None:
        """duration equal to the sample time is one step."""
        text = with_simulation().replace("duration = 1200.0", "duration = 20.0")
        assert simulation_of(text).n_steps(20.0) == 1

    def test_readme_example_parses(self) -> None:
        """The [simulation] example in analyses/README.md fits the annotated example."""
        readme = (ANALYSES / "README.md").read_text(encoding="utf-8")
        blocks = re.findall(r"```toml\n(.*?)```", readme, re.DOTALL)
        (controller,) = [block for block in blocks if block.startswith("[controller]")]
        (simulation,) = [block for block in blocks if block.startswith("[simulation]")]
        scenario = parse_scenario(blocks[0] + controller + simulation)
        sim, ctl = scenario.simulation, scenario.controller
        assert sim is not None and ctl is not None
        assert sim.n_steps(scenario.model.sample_time) == 240
        assert sim.strategies == ("centralised", "ndmpc")
        assert sim.reference_speeds == pytest.approx((200 / 3.6, 60.0, 60.0))
        assert (ctl.rate_limit, ctl.coupler_force_limit) == (2e4, 2e5)

    def test_pickle_and_frozen(self) -> None:
        """A scenario with a simulation survives pickle; the settings are immutable."""
        scenario = parse_scenario(with_simulation())
        assert pickle.loads(pickle.dumps(scenario)) == scenario
        assert scenario.simulation is not None
        with pytest.raises(dataclasses.FrozenInstanceError):
            scenario.simulation.duration = 1.0  # type: ignore[misc]
        hash(scenario.simulation)


class TestSimulationErrors:
    """Malformed [simulation] sections, each with its key path."""

    def test_needs_controller(self) -> None:
        """[simulation] without [controller] is rejected with a hint."""
        check_fails(
            with_simulation(controller=False),
            "[simulation] needs a [controller] section (got none)",
            "Add [controller] or remove [simulation].",
        )

    @pytest.mark.parametrize(
        ("key", "fragment"),
        [
            ("duration", "missing required key [simulation].duration (a number in (0, 604800])"),
            ("strategies", "missing required key [simulation].strategies"),
        ],
    )
    def test_missing_required(self, key: str, fragment: str) -> None:
        """duration and strategies are required."""
        text = "\n".join(
            line for line in with_simulation().splitlines() if not line.startswith(f"{key} =")
        )
        check_fails(text, fragment)

    def test_missing_reference(self) -> None:
        """[simulation.reference] is required."""
        text = with_simulation().split("[simulation.reference]")[0]
        check_fails(text, "missing required section [simulation.reference].")

    def test_reference_not_a_table(self) -> None:
        """reference given as a value is rejected."""
        text = with_simulation().split("[simulation.reference]")[0]
        check_fails(
            edit("duration = 1200.0", "duration = 1200.0\nreference = 1", text),
            "[simulation.reference] must be a table (got 1)",
        )

    @pytest.mark.parametrize(
        ("duration", "fragments"),
        [
            ("1210.0", ("(got 1210.0 s, 60.5 samples)", "Use e.g. 1200.0 or 1220.0.")),
            ("1200.5", ("(got 1200.5 s, 60.025 samples)", "Use e.g. 1200.0 or 1220.0.")),
            ("10.0", ("(got 10.0 s, 0.5 samples)", "Use e.g. 20.0.")),
        ],
    )
    def test_duration_not_a_multiple(self, duration: str, fragments: tuple[str, ...]) -> None:
        """A duration that is not a whole multiple of the sample time names both numbers."""
        check_fails(
            with_simulation().replace("duration = 1200.0", f"duration = {duration}"),
            "[simulation].duration must be a whole multiple of [model].sample_time = 20.0 s",
            *fragments,
        )

    @pytest.mark.parametrize(
        ("value", "fragment"),
        [
            ("0.0", "[simulation].duration must be a number > 0 (got 0.0)"),
            ("-1.0", "[simulation].duration must be a number > 0"),
            ("nan", "[simulation].duration must be a finite number > 0"),
            ('"1200"', "[simulation].duration must be a number > 0 (got '1200', a string)"),
        ],
    )
    def test_bad_duration(self, value: str, fragment: str) -> None:
        """duration must be a finite number > 0."""
        check_fails(with_simulation().replace("duration = 1200.0", f"duration = {value}"), fragment)

    def _strategies(self, value: str) -> str:
        return with_simulation().replace(
            'strategies = ["centralised", "decentralised", "ndmpc"]', f"strategies = {value}"
        )

    def test_unknown_strategy_suggests(self) -> None:
        """An unknown strategy names its index and suggests a close match."""
        check_fails(
            self._strategies('["centralised", "ndmpcc"]'),
            "[simulation].strategies[1] must be one of 'centralised', 'decentralised', "
            "'ndmpc', 'cooperative', 'ndmpc-local' (got 'ndmpcc', a string).",
            "Did you mean 'ndmpc'?",
        )

    def test_british_spelling_hint(self) -> None:
        """'centralized' suggests 'centralised'."""
        check_fails(self._strategies('["centralized"]'), "Did you mean 'centralised'?")

    def test_duplicate_strategy(self) -> None:
        """A strategy listed twice is rejected at its second position."""
        check_fails(
            self._strategies('["ndmpc", "centralised", "ndmpc"]'),
            "[simulation].strategies[2] must not repeat an earlier strategy (got 'ndmpc' again)",
        )

    @pytest.mark.parametrize(
        ("value", "got"),
        [("[]", "an array of 0 items"), ('"ndmpc"', "'ndmpc', a string"), ("1", "1")],
    )
    def test_strategies_not_a_non_empty_array(self, value: str, got: str) -> None:
        """strategies must be a non-empty array."""
        check_fails(
            self._strategies(value),
            "[simulation].strategies must be a non-empty array of distinct names",
            f"(got {got})",
        )

    def test_strategy_not_a_string(self) -> None:
        """A non-string strategy is rejected by index."""
        check_fails(self._strategies('["ndmpc", 3]'), "[simulation].strategies[1] must be one of")

    def test_both_speed_keys(self) -> None:
        """speeds_kmh and speeds together are rejected."""
        check_fails(
            with_simulation(reference="times = [0.0]\nspeeds_kmh = [72.0]\nspeeds = [20.0]"),
            "[simulation.reference] needs exactly one of speeds_kmh, speeds (got speeds_kmh and "
            "speeds)",
        )

    def test_no_speed_key(self) -> None:
        """A reference without speeds is rejected."""
        check_fails(
            with_simulation(reference="times = [0.0]"),
            "[simulation.reference] needs exactly one of speeds_kmh, speeds (got none)",
            "speeds_kmh is in km/h, speeds in m/s.",
        )

    def test_missing_times(self) -> None:
        """times is required."""
        check_fails(
            with_simulation(reference="speeds = [20.0]"),
            "missing required key [simulation.reference].times",
        )

    def test_length_mismatch(self) -> None:
        """times and speeds must pair up."""
        check_fails(
            with_simulation(
                reference="times = [0.0, 60.0, 460.0, 1020.0, 1200.0]\n"
                "speeds_kmh = [72.0, 72.0, 216.0, 288.0]"
            ),
            "[simulation.reference].speeds_kmh must have as many entries as "
            "[simulation.reference].times (got 4 for 5 times). Give one speed per time.",
        )

    def test_length_mismatch_speeds(self) -> None:
        """The length message names the speed key actually used."""
        check_fails(
            with_simulation(reference="times = [0.0]\nspeeds = [20.0, 30.0]"),
            "[simulation.reference].speeds must have as many entries as "
            "[simulation.reference].times (got 2 for 1 time)",
        )

    @pytest.mark.parametrize("times", ["[0.0, 60.0, 460.0, 460.0]", "[0.0, 60.0, 460.0, 400.0]"])
    def test_times_not_increasing(self, times: str) -> None:
        """Breakpoint times must strictly increase, named by index."""
        check_fails(
            with_simulation(reference=f"times = {times}\nspeeds = [20.0, 20.0, 60.0, 80.0]"),
            "[simulation.reference].times[3] must be greater than the previous time 460.0",
            "List the times in increasing order.",
        )

    def test_first_time_not_zero(self) -> None:
        """The reference must start at t = 0."""
        check_fails(
            with_simulation(reference="times = [5.0, 60.0]\nspeeds = [20.0, 20.0]"),
            "[simulation.reference].times[0] must be 0 (got 5.0). The reference starts at t = 0.",
        )

    def test_negative_time(self) -> None:
        """A negative time is rejected by index."""
        check_fails(
            with_simulation(reference="times = [-1.0, 60.0]\nspeeds = [20.0, 20.0]"),
            "[simulation.reference].times[0] must be a number >= 0 (got -1.0)",
        )

    @pytest.mark.parametrize(
        ("speeds", "fragment"),
        [
            ("[72.0, 72.0, -1.0]", "[simulation.reference].speeds_kmh[2] must be a number >= 0"),
            ('[72.0, 72.0, "fast"]', "[simulation.reference].speeds_kmh[2] must be a number"),
            ("[72.0, 72.0, inf]", "[simulation.reference].speeds_kmh[2] must be a finite"),
        ],
    )
    def test_bad_speed(self, speeds: str, fragment: str) -> None:
        """Each speed must be a finite number >= 0, named by index."""
        check_fails(
            with_simulation(reference=f"times = [0.0, 60.0, 120.0]\nspeeds_kmh = {speeds}"),
            fragment,
        )

    @pytest.mark.parametrize(("value", "got"), [("[]", "an array of 0 items"), ("0.0", "0.0")])
    def test_times_not_a_non_empty_array(self, value: str, got: str) -> None:
        """times must be a non-empty array of numbers."""
        check_fails(
            with_simulation(reference=f"times = {value}\nspeeds = [20.0]"),
            "[simulation.reference].times must be a non-empty array of numbers >= 0",
            f"(got {got})",
        )

    def test_unknown_reference_key_suggests(self) -> None:
        """A misspelt speed key suggests the right one."""
        check_fails(
            with_simulation(reference="times = [0.0]\nspeed_kmh = [72.0]"),
            "unknown key [simulation.reference].speed_kmh. Did you mean 'speeds_kmh'?",
        )

    def test_unknown_key_suggests(self) -> None:
        """A misspelt key in [simulation] suggests the right one."""
        check_fails(
            with_simulation("settle_tim = 1.0"),
            "unknown key [simulation].settle_tim. Did you mean 'settle_time'?",
        )

    @pytest.mark.parametrize(
        ("line", "fragment"),
        [
            ("measurement_noise = -0.1", "[simulation].measurement_noise must be a number >= 0"),
            ("settle_time = -1.0", "[simulation].settle_time must be a number >= 0"),
            ("tracking_tolerance = 0.0", "[simulation].tracking_tolerance must be a number > 0"),
            (
                "regen_efficiency = -0.1",
                "[simulation].regen_efficiency must be a number from 0 to 1 (got -0.1)",
            ),
            (
                "regen_efficiency = 1.5",
                "[simulation].regen_efficiency must be a number from 0 to 1 (got 1.5)",
            ),
            ("initial_speed_error = nan", "[simulation].initial_speed_error must be a finite"),
            ('initial_speed_error = "1"', "[simulation].initial_speed_error must be a number"),
        ],
    )
    def test_bad_value(self, line: str, fragment: str) -> None:
        """Optional keys are range-checked with their key path."""
        check_fails(with_simulation(line), fragment)

    @pytest.mark.parametrize("settle", ["1200.0", "1500.0"])
    def test_settle_time_not_before_end(self, settle: str) -> None:
        """settle_time must leave some time in which tracking is judged."""
        check_fails(
            with_simulation(f"settle_time = {settle}"),
            "[simulation].settle_time must be less than [simulation].duration = 1200.0 s",
        )

    def test_initial_speed_below_zero(self) -> None:
        """The initial speed error must not make a vehicle start backwards."""
        check_fails(
            with_simulation("initial_speed_error = -25.0"),
            "[simulation].initial_speed_error must be >= -20.0 m/s",
            "(got -25.0)",
        )
        assert simulation_of(with_simulation("initial_speed_error = -20.0")).initial_speed_error


class TestSimulationSettings:
    """SimulationSettings and Scenario.simulation built directly, without a file."""

    def test_defaults_and_conversion(self) -> None:
        """Defaults match the file defaults; lists become tuples, ints floats."""
        sim = make_simulation(
            strategies=["ndmpc", "cooperative"], reference_times=[0, 50], reference_speeds=[20, 30]
        )
        assert sim.strategies == ("ndmpc", "cooperative")
        assert sim.reference_times == (0.0, 50.0)
        assert sim.reference_speeds == (20.0, 30.0)
        assert all(isinstance(v, float) for v in sim.reference_times + sim.reference_speeds)
        assert (sim.initial_speed_error, sim.measurement_noise, sim.settle_time) == (0.0, 0.0, 0.0)
        assert (sim.tracking_tolerance, sim.regen_efficiency) == (1.0, 1.0)
        with pytest.raises(dataclasses.FrozenInstanceError):
            sim.duration = 1.0  # type: ignore[misc]

    @pytest.mark.parametrize(
        ("changes", "fragment"),
        [
            ({"duration": 0.0}, "'duration' must be a finite number > 0"),
            ({"duration": math.inf}, "'duration' must be a finite number > 0"),
            ({"initial_speed_error": math.nan}, "'initial_speed_error' must be a finite number"),
            ({"measurement_noise": -1.0}, "'measurement_noise' must be a finite number >= 0"),
            ({"settle_time": -1.0}, "'settle_time' must be a finite number >= 0"),
            ({"settle_time": 100.0}, "'settle_time' must be less than 'duration' = 100.0"),
            ({"tracking_tolerance": 0.0}, "'tracking_tolerance' must be a finite number > 0"),
            ({"regen_efficiency": 1.1}, "'regen_efficiency' must be a finite number from 0 to 1"),
            ({"regen_efficiency": True}, "'regen_efficiency' must be a finite number from 0 to"),
            ({"strategies": ()}, "'strategies' must be a non-empty array of distinct names"),
            ({"strategies": ("ndmpc", "ndmpc")}, "'strategies'[1] must not repeat an earlier"),
            ({"strategies": ("mpc",)}, "'strategies'[0] must be one of ('centralised', "),
            ({"reference_times": ()}, "'reference_times' must be a non-empty array of numbers"),
            ({"reference_times": (1.0, 50.0)}, "'reference_times'[0] must be 0 (got 1.0)"),
            ({"reference_times": 0.0}, "'reference_times' must be a non-empty array of numbers"),
            ({"reference_times": "0"}, "'reference_times' must be a non-empty array of numbers"),
            ({"reference_times": (0.0, 0.0)}, "'reference_times'[1] must be greater than the"),
            (
                {"reference_speeds": (20.0,)},
                "'reference_speeds' must have as many entries as 'reference_times' (got 1 for 2",
            ),
            ({"reference_speeds": (20.0, -1.0)}, "'reference_speeds'[1] must be a finite number"),
            ({"initial_speed_error": -21.0}, "'initial_speed_error' must be >= -20.0"),
        ],
    )
    def test_validates(self, changes: dict, fragment: str) -> None:
        """Invalid values raise ModelError naming the field."""
        with pytest.raises(ModelError, match=re.escape(f"SimulationSettings: {fragment}")):
            make_simulation(**changes)

    def test_single_strategy_string(self) -> None:
        """A single strategy name given as a string becomes a one-item tuple."""
        assert make_simulation(strategies="centralised").strategies == ("centralised",)

    @pytest.mark.parametrize(("dt", "steps"), [(100.0, 1), (20.0, 5), (0.1, 1000), (0.01, 10000)])
    def test_n_steps(self, dt: float, steps: int) -> None:
        """n_steps is duration / sample_time for whole multiples."""
        assert make_simulation().n_steps(dt) == steps

    @pytest.mark.parametrize("dt", [30.0, 200.0, 100.0 + 1e-6])
    def test_n_steps_not_a_multiple(self, dt: float) -> None:
        """A sample time that does not divide the duration is rejected."""
        with pytest.raises(ModelError, match="'duration' must be a whole multiple of the sample"):
            make_simulation().n_steps(dt)

    @pytest.mark.parametrize("dt", [0.0, -1.0, math.nan, math.inf, "20"])
    def test_n_steps_bad_sample_time(self, dt: object) -> None:
        """The sample time must be a finite number > 0."""
        with pytest.raises(ModelError, match="'sample_time' must be a finite number >= 0.0001"):
            make_simulation().n_steps(dt)  # type: ignore[arg-type]

    def test_scenario_needs_controller(self) -> None:
        """Scenario built directly rejects a simulation without a controller."""
        scenario = parse_scenario(BASE)
        with pytest.raises(ModelError, match="'simulation' needs a controller"):
            dataclasses.replace(scenario, simulation=make_simulation())

    def test_scenario_checks_duration(self) -> None:
        """Scenario built directly checks the duration against the sample time."""
        scenario = parse_scenario(with_controller())
        ok = dataclasses.replace(scenario, simulation=make_simulation(duration=200.0))
        assert ok.simulation is not None and ok.simulation.n_steps(20.0) == 10
        with pytest.raises(ModelError, match="must be a whole multiple of the sample time 20.0"):
            dataclasses.replace(scenario, simulation=make_simulation(duration=110.0))


class TestCouplerForceSteps:
    """[controller].coupler_force_steps."""

    def test_steps_reach_the_mpc_constraints(self) -> None:
        """The well-sampled built-in bounds the forces at its twelve listed steps."""
        ctl = load_scenario("crh2-dmpc-well-sampled").controller
        assert ctl.coupler_force_steps == (1, 2, 3, 4, 5, 10, 15, 20, 25, 30, 35, 40)
        assert ctl.mpc_constraints().force_steps == ctl.coupler_force_steps

    @pytest.mark.parametrize(
        "value", ["[]", "[0, 1]", "[3, 2]", "[1, 41]", "[1.0]", "[true]", '"all"']
    )
    def test_bad_steps_are_rejected(self, value: str) -> None:
        """Empty, out-of-range, non-increasing or non-integer steps name the key."""
        text = builtin_scenario_text("crh2-dmpc-well-sampled").replace(
            "coupler_force_steps = [1, 2, 3, 4, 5, 10, 15, 20, 25, 30, 35, 40]",
            f"coupler_force_steps = {value}",
        )
        with pytest.raises(ScenarioError, match=r"\[controller\]\.coupler_force_steps"):
            parse_scenario(text)
