"""Tests for the scenario schema declared once: JSON Schema, README tables, families."""

from __future__ import annotations

import copy
import json
import pickle
import re
import tomllib
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Annotated

import jsonschema
import pytest
from pydantic import BaseModel, ConfigDict

from tests.test_scenario import BASE, CONTROLLER, SINGLE, edit, with_controller, with_simulation
from trainctl.cli.main import main
from trainctl.controllers.lqr.settings import LQRSettings
from trainctl.controllers.mpc.settings import ControllerSettings
from trainctl.declare.constraints import Number
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.registry import (
    FAMILY_MODULES,
    get_family,
    register_family,
    unregister_family,
)
from trainctl.scenario import (
    CHECK_NAMES,
    SIMULATION_STRATEGIES,
    Scenario,
    check_names,
    json_schema,
    load_scenario,
    parse_scenario,
)
from trainctl.scenario.docs import markdown_tables, update_readme
from trainctl.scenario.filemodel import file_model

ANALYSES = Path(__file__).resolve().parent.parent / "analyses"
README = ANALYSES / "README.md"
BUILTINS = sorted(ANALYSES.glob("*.toml"))


@pytest.fixture(scope="module")
def validator() -> jsonschema.Draft202012Validator:
    """A validator of the generated JSON Schema."""
    schema = json_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    return jsonschema.Draft202012Validator(schema)


def schema_errors(validator: jsonschema.Draft202012Validator, text: str) -> list[str]:
    """The JSON Schema errors of a TOML text."""
    return [error.message for error in validator.iter_errors(tomllib.loads(text))]


LQR_SUB = "[controller.lqr]\nr_per_kn2 = 1.0\n"

# One malformed file per rule class the JSON Schema can express; the parser rejects each too.
MALFORMED = {
    "wrong type": edit("mass_t = 42.8", 'mass_t = "42.8"'),
    "wrong boolean": edit("[model]", "[model]\ndummy_state = 1"),
    "integer expected": edit("count = 2", "count = 2.5"),
    "out of range": edit("sample_time = 20.0", "sample_time = 0.0"),
    "interval": with_controller("relaxation = 1.5"),
    "bad enum value": edit("[model]", '[model]\nlinearisation = "bok"'),
    "bad enum item": with_controller('outputs = ["v", "forces"]'),
    "repeated item": with_controller('outputs = ["v", "v"]'),
    "empty array": with_controller("outputs = []"),
    "unknown key": edit("seed = 0", "seeds = 0"),
    "unknown nested key": edit("mass_t = 48.0", "mass_t = 48.0\nmas_t = 1.0"),
    "unknown section": edit("[model]", "[modle]"),
    "unknown controller sub-table": with_controller("[controller.lqq]", "x = 1"),
    "reserved section": BASE + "[report]\nx = 1\n",
    "unknown [sweep] key": BASE + "[sweep]\nx = 1\n",
    "missing required key": edit("sample_time = 20.0\n", ""),
    "missing required section": BASE.split("[model]")[0],
    "wrong array length": edit("[0.01, 0.0, 1e-5]", "[0.01, 0.0]", SINGLE),
    "exactly one of (none)": BASE + CONTROLLER.replace("r_per_kn2 = 10.0\n", ""),
    "exactly one of (two)": with_controller("r_per_n2 = 1e-5"),
    "preset and vehicles": edit("[train]\n", '[train]\npreset = "crh2_half"\n'),
    "physical coupler stiffness": edit("stiffness_kn_per_m = 10488.0", "stiffness_kn_per_m = 0"),
    "schema version": edit("schema_version = 1", "schema_version = 2"),
    "simulation without controller": with_simulation(controller=False),
    "unknown family": with_controller('family = "lqrr"'),
    "key of another family": BASE + '[controller]\nfamily = "lqr"\nr_per_kn2 = 1.0\nform = "u"\n',
    "table expected": edit("seed = 0", "seed = 0\nmodel = 3", BASE.split("[model]")[0]),
}


class TestJsonSchema:
    """The JSON Schema that `trainctl schema` prints."""

    @pytest.mark.parametrize("path", BUILTINS, ids=lambda p: p.stem)
    def test_validates_every_builtin(
        self, validator: jsonschema.Draft202012Validator, path: Path
    ) -> None:
        """Every built-in scenario, read with tomllib, is valid."""
        with path.open("rb") as file:
            assert list(validator.iter_errors(tomllib.load(file))) == []

    def test_validates_readme_examples_and_families(
        self, validator: jsonschema.Draft202012Validator
    ) -> None:
        """The README examples and files with a second family or family = "lqr" are valid."""
        blocks = re.findall(r"```toml\n(.*?)```", README.read_text(encoding="utf-8"), re.DOTALL)
        assert schema_errors(validator, blocks[0] + blocks[1] + blocks[2]) == []
        assert schema_errors(validator, with_simulation() + LQR_SUB) == []
        lqr = BASE + '[controller]\nfamily = "lqr"\nr_per_n2 = 1e-6\n'
        assert schema_errors(validator, lqr) == []

    @pytest.mark.parametrize("case", MALFORMED)
    def test_rejects_each_rule_class(
        self, validator: jsonschema.Draft202012Validator, case: str
    ) -> None:
        """A malformed file of each rule class fails the schema, and the parser."""
        text = MALFORMED[case]
        assert schema_errors(validator, text), case
        with pytest.raises(ScenarioError):
            parse_scenario(text)

    def test_declarations_reach_the_schema(self) -> None:
        """Titles, descriptions, units, defaults and enums come from the declarations."""
        schema = json_schema()
        assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
        speed = schema["$defs"]["ModelSettings"]["properties"]["speed_kmh"]
        assert speed["unit"] == "km/h" and speed["exclusiveMinimum"] == 0
        assert speed["description"] == "Cruise (linearisation) speed [km/h]."
        linearisation = schema["$defs"]["ModelSettings"]["properties"]["linearisation"]
        assert (linearisation["enum"], linearisation["default"]) == (["jacobian", "book"],
                                                                     "jacobian")
        family = schema["properties"]["controller"]["properties"]["family"]
        assert family["enum"] == list(FAMILY_MODULES) and family["default"] == "mpc"
        limit = schema["$defs"]["ControllerSettings"]["properties"]["rate_limit_kn"]
        assert "default" not in limit and "omit for no limit" in limit["description"]
        assert "null" not in json.dumps(schema)

    def test_cli_prints_it(self, capsys: pytest.CaptureFixture[str]) -> None:
        """`trainctl schema` prints the schema as JSON; --markdown prints the tables."""
        assert main(["schema"]) == 0
        assert json.loads(capsys.readouterr().out) == json_schema()
        assert main(["schema", "--markdown"]) == 0
        out = capsys.readouterr().out
        assert "<!-- schema:model -->" in out and "| `speed_kmh` |" in out


def readme_sections() -> Iterator[str]:
    """The names of the generated tables marked in the README."""
    yield from re.findall(r"<!-- schema:([\w-]+) -->", README.read_text(encoding="utf-8"))


class TestReadmeTables:
    """The schema tables of analyses/README.md are the generated ones."""

    def test_tables_equal_the_generated_ones(self) -> None:
        """Regenerating the marked tables changes nothing."""
        text = README.read_text(encoding="utf-8")
        assert update_readme(text) == text, (
            "analyses/README.md schema tables drifted from the declarations; run "
            "'python -m trainctl.scenario.docs --write'"
        )

    def test_every_table_is_marked(self) -> None:
        """Each generated table appears once in the README."""
        assert sorted(readme_sections()) == sorted(markdown_tables())

    def test_expected_table_lists_every_check(self) -> None:
        """The hand-written [expected] table names the checks of the built-in families."""
        text = README.read_text(encoding="utf-8").split("### `[expected]`")[1]
        listed = re.findall(r"^\| `(\w+)`", text, re.MULTILINE)
        assert tuple(listed) == check_names(tuple(FAMILY_MODULES))


def toy_family(settings: type) -> SimpleNamespace:
    """A family defined here, registered at run time."""
    return SimpleNamespace(name="toy", title="Toy", strategies=("go",), check_names=("toy_ok",),
                           settings=settings)


class ToySettings(BaseModel):
    """A plug-in family's plain pydantic settings, using a trainctl rule."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    gain: Annotated[float, Number(gt=0)] = 1.0


@pytest.fixture
def toy() -> Iterator[SimpleNamespace]:
    """The toy family, registered for one test."""
    family = toy_family(ToySettings)
    register_family(family)  # type: ignore[arg-type]
    try:
        yield family
    finally:
        unregister_family("toy")


class TestFamilies:
    """[controller] family, [controller.<family>] sub-tables, qualified strategies."""

    def test_default_family_is_mpc(self) -> None:
        """Without a family key the primary family is MPC; controllers maps it."""
        scenario = parse_scenario(with_controller())
        assert isinstance(scenario.controller, ControllerSettings)
        assert dict(scenario.controllers) == {"mpc": scenario.controller}
        assert ControllerSettings.family == "mpc"

    def test_lqr_primary(self) -> None:
        """family = "lqr" validates the rest of the table with LQRSettings."""
        scenario = parse_scenario(BASE + '[controller]\nfamily = "lqr"\nr_per_n2 = 2e-6\n')
        lqr = scenario.controller
        assert isinstance(lqr, LQRSettings) and list(scenario.controllers) == ["lqr"]
        assert (lqr.input_weight, lqr.input_weight_unit, lqr.input_bounds) == (2e-6, "N", True)
        assert lqr.input_weight_per_kn2() == pytest.approx(2.0)

    def test_sub_table_and_qualified_strategy(self) -> None:
        """[controller.lqr] adds a family after the primary; 'lqr.centralised' runs it."""
        text = with_simulation().replace('"ndmpc"]', '"lqr.centralised"]') + LQR_SUB
        scenario = parse_scenario(text)
        assert list(scenario.controllers) == ["mpc", "lqr"]
        assert scenario.simulation is not None
        assert scenario.simulation.strategies[-1] == "lqr.centralised"
        with pytest.raises(TypeError):
            scenario.controllers["x"] = 1  # type: ignore[index]
        assert pickle.loads(pickle.dumps(scenario)) == scenario
        assert copy.deepcopy(scenario.controllers) == scenario.controllers

    def test_qualified_strategy_needs_its_family(self) -> None:
        """A strategy of a family the scenario lacks names the sub-table it needs."""
        text = with_simulation().replace('"ndmpc"]', '"lqr.centralised"]')
        with pytest.raises(ScenarioError, match=re.escape(
            "[simulation].strategies[2] must be one of 'centralised', 'decentralised', "
            "'ndmpc', 'cooperative', 'ndmpc-local' (got 'lqr.centralised', a string)"
        )) as info:
            parse_scenario(text)
        assert "needs that family's [controller.lqr] table" in str(info.value)

    @pytest.mark.parametrize(
        ("text", "message"),
        [
            (with_controller("[controller.lqq]", "r = 1"),
             "unknown section [controller.lqq]. Did you mean 'lqr'?"),
            (with_controller('family = "lqrr"'),
             "[controller].family must be one of 'mpc', 'lqr', 'potential', 'flocking', "
             "'synchronous', 'hinf' (got 'lqrr', a string). "
             "Did you "
             "mean 'lqr'?"),
            (with_controller("[controller.mpc]", 'form = "u"'),
             "[controller.mpc] repeats the primary family 'mpc'"),
            (with_controller("[controller.lqr]", "r_per_kn2 = 1.0", 'form = "u"'),
             "unknown key [controller.lqr].form. Allowed here: outputs, q_velocity"),
            (with_controller("[controller.lqr]", "r_per_kn2 = 0"),
             "[controller.lqr].r_per_kn2 must be a number > 0 (got 0)"),
            (with_controller("[controller.lqr]", "r_per_kn2 = 1.0", "q_force_per_kn2 = 1.0"),
             "[controller.lqr].q_force_per_kn2 must be 0 when [controller.lqr].outputs has no "
             "'force' (got 1.0 with outputs ['v'])"),
            (with_controller("lqr = 3"), "[controller.lqr] must be a table (got 3)"),
            (with_controller("[expected]", 'lqr_closed_loop = "pass"'),
             "[expected].lqr_closed_loop needs a controller of family 'lqr' (got mpc)"),
        ],
    )
    def test_errors(self, text: str, message: str) -> None:
        """Family errors name the key path and suggest the closest name."""
        with pytest.raises(ScenarioError, match=re.escape(f"<string>: {message}")):
            parse_scenario(text)

    def test_family_checks_are_accepted_with_the_family(self) -> None:
        """[expected] may name the checks of every family in the scenario."""
        text = with_controller(LQR_SUB + "[expected]", 'lqr_closed_loop = "pass"')
        assert dict(parse_scenario(text).expected) == {"lqr_closed_loop": "pass"}

    def test_runtime_family_in_a_file(self, toy: SimpleNamespace) -> None:
        """A family registered at run time is read from files, primary or sub-table."""
        primary = parse_scenario(BASE + '[controller]\nfamily = "toy"\ngain = 2\n')
        assert primary.controller == ToySettings(gain=2.0)
        assert list(primary.controllers) == ["toy"]
        text = with_simulation().replace('"ndmpc"]', '"toy.go"]') + "[controller.toy]\n"
        text += '[expected]\ntoy_ok = "pass"\n'
        scenario = parse_scenario(text)
        assert scenario.controllers["toy"] == ToySettings()
        assert scenario.expected == {"toy_ok": "pass"}
        with pytest.raises(ScenarioError, match=re.escape(
            "[controller.toy].gain must be a number > 0 (got -1)"
        )):
            parse_scenario(with_controller("[controller.toy]", "gain = -1"))

    def test_scenario_built_in_python(self) -> None:
        """Scenario(controllers=...) puts the primary first and checks the strategies."""
        base = parse_scenario(with_simulation())
        lqr = LQRSettings(input_weight=1.0)
        both = Scenario(name="x", description="y", train=base.train, model=base.model,
                        controllers={"mpc": base.controller, "lqr": lqr})
        assert both.controller is base.controller and list(both.controllers) == ["mpc", "lqr"]
        assert base.simulation is not None
        with pytest.raises(ModelError, match=re.escape("'strategies'[2] must be one of ('cen")):
            Scenario(name="x", description="y", train=base.train, model=base.model,
                     controller=lqr, simulation=base.simulation)


class TestOneDeclaration:
    """Rules and vocabularies are stated once and shared."""

    def test_families_point_at_the_settings(self) -> None:
        """The registry's families validate their tables with these settings classes."""
        assert get_family("mpc").settings is ControllerSettings
        assert get_family("lqr").settings is LQRSettings

    def test_lqr_and_mpc_share_the_weight_declarations(self) -> None:
        """outputs, q_velocity, q_force_per_kn2, r_per_kn2, r_per_n2: the same declarations."""
        fields = {}
        for cls in (ControllerSettings, LQRSettings):
            fields[cls] = file_model(cls).model_fields
        for key in ("outputs", "q_velocity", "q_force_per_kn2", "r_per_kn2", "r_per_n2"):
            mpc, lqr = fields[ControllerSettings][key], fields[LQRSettings][key]
            assert mpc.metadata == lqr.metadata and mpc.default == lqr.default

    @pytest.mark.parametrize(
        ("make", "message"),
        [
            (lambda: LQRSettings(input_weight=0.0),
             "LQRSettings: 'input_weight' must be a finite number > 0 (got 0.0)."),
            (lambda: LQRSettings(input_weight=1.0, q_force=1.0),
             "LQRSettings: 'q_force' must be 0 when 'outputs' has no 'force'"),
            (lambda: LQRSettings(input_weight=1.0, outputs=("v", "v")),
             "LQRSettings: 'outputs'[1] must not repeat an earlier output"),
            (lambda: LQRSettings(input_weight=1.0, input_bounds="yes"),
             "LQRSettings: 'input_bounds' must be True or False (got 'yes')."),
        ],
    )
    def test_python_construction_uses_the_rules(self, make: object, message: str) -> None:
        """Settings built in Python raise ModelError worded from the same rules."""
        with pytest.raises(ModelError, match=re.escape(message)):
            make()  # type: ignore[operator]

    def test_unknown_argument_is_a_type_error(self) -> None:
        """A misspelt keyword argument is a TypeError, as for any function."""
        with pytest.raises(TypeError, match="unexpected argument 'q_velocty'"):
            LQRSettings(input_weight=1.0, q_velocty=1.0)  # type: ignore[call-arg]

    def test_misspelt_required_argument_is_named_as_unknown(self) -> None:
        """A misspelt required argument is reported as unknown, with the right name as a hint.

        pydantic reports it twice (the misspelt name unexpected, the right one
        missing); the misspelling is the user's mistake to show.
        """
        from trainctl.scenario import ModelSettings

        with pytest.raises(TypeError) as caught:
            ModelSettings(speed=25.0, sample_tim=0.5)  # type: ignore[call-arg]
        assert str(caught.value) == ("ModelSettings: unexpected argument 'sample_tim'. "
                                     "Did you mean 'sample_time'?")
        with pytest.raises(TypeError) as caught:
            ModelSettings(speed=25.0, step=0.5)  # type: ignore[call-arg]
        assert str(caught.value) == "ModelSettings: unexpected argument 'step'."

    def test_vocabularies_come_from_where_they_live(self) -> None:
        """The scenario package re-exports, never copies, the vocabularies."""
        import trainctl.scenario as scenario
        from trainctl.analysis.check import LOOP_CHECK_NAMES, MODEL_CHECK_NAMES
        from trainctl.models.discrete import DISCRETISATIONS
        from trainctl.models.dynamics import ALLOCATIONS
        from trainctl.models.linear import LINEARISATIONS

        assert scenario.LINEARISATIONS is LINEARISATIONS
        assert scenario.DISCRETISATIONS is DISCRETISATIONS
        assert scenario.ALLOCATIONS is ALLOCATIONS
        assert SIMULATION_STRATEGIES is get_family("mpc").strategies
        assert CHECK_NAMES == (MODEL_CHECK_NAMES + get_family("mpc").check_names
                               + LOOP_CHECK_NAMES)

    def test_builtins_hold_the_same_settings(self) -> None:
        """A built-in's settings equal the ones built from Python with SI values."""
        ctl = load_scenario("crh2-dmpc").controller
        assert ctl == ControllerSettings(
            form="du", prediction_horizon=4, control_horizon=2, input_weight=10.0,
            iteration_tolerance=1e-4, coupler_force_limit=5e5,
        )
