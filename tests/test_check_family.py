"""The family conformance suite: check_family on every family, and the rules it enforces."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import control as ct
import numpy as np
import pytest

from tests.test_families import TOY_SCENARIO, ToyDesign, ToyFamily
from trainctl.analysis.check import Check
from trainctl.controllers import FamilyCheckError, check_family
from trainctl.controllers.base import StepRecord
from trainctl.controllers.check import RULES, free_growth
from trainctl.controllers.lqr.family import LQRDesign, LQRFamily
from trainctl.exceptions import ScenarioError
from trainctl.registry import ControllerFamily, family_names, register_family, unregister_family
from trainctl.scenario import Scenario, load_scenario


@pytest.mark.parametrize("name", family_names())
def test_builtin_family_conforms(name: str) -> None:
    """Every built-in family passes every rule on its built-in scenario."""
    assert check_family(name) == RULES


@pytest.fixture(scope="module")
def toy_scenario(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Scenario]:
    """The toy family registered, and its scenario loaded (the parser needs the family)."""
    register_family(ToyFamily())  # type: ignore[arg-type]
    try:
        path = tmp_path_factory.mktemp("toy") / "toy.toml"
        path.write_text(TOY_SCENARIO, encoding="utf-8")
        yield load_scenario(str(path))
    finally:
        unregister_family("toy")


def test_user_family_conforms(toy_scenario: Scenario) -> None:
    """The toy family of test_families, a user's family, passes on its own scenario."""
    assert check_family(ToyFamily(), toy_scenario) == RULES  # type: ignore[arg-type]


def test_user_family_needs_a_scenario(toy_scenario: Scenario) -> None:
    """No built-in scenario uses a user's family: check_family asks for one."""
    with pytest.raises(ScenarioError, match=r"no built-in scenario .* family 'toy'.*scenario="):
        check_family(ToyFamily())  # type: ignore[arg-type]
    with pytest.raises(ScenarioError, match=r"has no \[controller\] of family 'toy'"):
        check_family(ToyFamily(), "crh2-dmpc")  # type: ignore[arg-type]


# --------------------------------------------------------------------------- broken toys


class OneInputLoop(ToyFamily):
    """closed_loop() with one disturbance input for two vehicles."""

    def closed_loop(self, design: ToyDesign, strategy: str) -> ct.StateSpace:
        loop = super().closed_loop(design, strategy)
        return ct.ss(loop.A, loop.B[:, :1], loop.C, loop.D[:, :1], loop.dt)


class WrongSampleTime(ToyFamily):
    """closed_loop() discrete at twice the sample time."""

    def closed_loop(self, design: ToyDesign, strategy: str) -> ct.StateSpace:
        loop = super().closed_loop(design, strategy)
        return ct.ss(loop.A, loop.B, loop.C, loop.D, 2 * loop.dt)


class RenamedCheck(ToyFamily):
    """checks() names its check differently from check_names."""

    def checks(self, design: ToyDesign) -> list[object]:
        [check] = super().checks(design)
        return [Check(name="toy_other", status=check.status,  # type: ignore[attr-defined]
                      value=None, threshold=None, unit="", message="")]


class MissingCheck(ToyFamily):
    """checks() returns fewer checks than check_names."""

    check_names = ("toy_closed_loop", "toy_second")

    def checks(self, design: ToyDesign) -> list[object]:
        return super().checks(design)


class RepeatedStrategy(ToyFamily):
    """A strategy listed twice."""

    strategies = ("proportional", "proportional")


class ModelCheckName(ToyFamily):
    """A check named like a model check."""

    check_names = ("sampling",)


class PlainSettings(ToyFamily):
    """Settings that are not a pydantic model."""

    settings = dict  # type: ignore[assignment]


class NaNReport(ToyFamily):
    """report_data() with a NaN, which a saved run cannot hold."""

    def report_data(self, design: ToyDesign) -> dict[str, object]:
        return {"gain": math.nan}


class WrongInputs(ToyFamily):
    """A controller whose step gives one force for two vehicles."""

    def make(self, design: ToyDesign, strategy: str) -> object:
        controller = super().make(design, strategy)

        class Short:
            dt, name = controller.dt, controller.name  # type: ignore[attr-defined]

            def reset(self) -> None:
                pass

            def step(self, t: float, measurement: object, reference: object) -> StepRecord:
                return StepRecord(inputs=np.zeros(1))

        return Short()


class UnpicklableDesign(ToyFamily):
    """A design holding a lambda (worker processes could not receive it)."""

    def design(self, scenario: object, model: object, settings: Any) -> ToyDesign:
        design = super().design(scenario, model, settings)
        object.__setattr__(design, "hook", lambda: None)
        return design


@pytest.mark.parametrize(("family", "rule", "match"), [
    (OneInputLoop, "closed_loop", r"1 inputs, not one disturbance w\[i\] per vehicle \(2\)"),
    (WrongSampleTime, "closed_loop", r"dt must be the sample time 0\.05 s or 0"),
    (RenamedCheck, "checks_named", r"names \['toy_other'\], but check_names is"),
    (MissingCheck, "checks_named", r"but check_names is \['toy_closed_loop', 'toy_second'\]"),
    (RepeatedStrategy, "vocabulary", r"'strategies' repeats \['proportional'\]"),
    (ModelCheckName, "vocabulary", r"check names taken: 'sampling' \(a model check\)"),
    (PlainSettings, "settings", r"must be a pydantic model class"),
    (NaNReport, "report_data", r"not JSON-safe"),
    (WrongInputs, "controllers_step", r"step 0 gave inputs of shape \(1,\)"),
    (UnpicklableDesign, "design_pickles", r"pickle round trip of the design raised"),
], ids=lambda v: v.__name__ if isinstance(v, type) else None)
def test_broken_family_names_the_rule(toy_scenario: Scenario, family: type[ToyFamily],
                                      rule: str, match: str) -> None:
    """A family breaking one rule fails with that rule named, in `rule` and in the message."""
    with pytest.raises(FamilyCheckError, match=match) as caught:
        check_family(family(), toy_scenario)  # type: ignore[arg-type]
    assert caught.value.rule == rule
    assert str(caught.value).startswith(f"check_family [{rule}]: family 'toy'")
    assert isinstance(caught.value, AssertionError)


def test_wrapped_builtin_with_wrong_loop_dimensions() -> None:
    """A built-in family with one method overridden is checked on the built-in's scenario."""

    class RelabelledStates(LQRFamily):
        def closed_loop(self, design: LQRDesign, strategy: str) -> ct.StateSpace:
            loop = super().closed_loop(design, strategy)
            # States relabelled for a loop one state smaller: labels and A disagree.
            loop.state_labels = loop.state_labels[:-1]
            return loop

    match = r"6 states, 4 inputs, 10 outputs, but A is \(7, 7\)"
    with pytest.raises(FamilyCheckError, match=match) as caught:
        check_family(RelabelledStates())
    assert caught.value.rule == "closed_loop"


def test_not_a_family() -> None:
    """An object without the protocol's members fails the vocabulary rule."""
    from types import SimpleNamespace

    with pytest.raises(FamilyCheckError, match=r"missing methods design, make") as caught:
        check_family(SimpleNamespace(name="bare"))  # type: ignore[arg-type]
    assert caught.value.rule == "vocabulary"


def test_builtins_follow_the_protocol_statically() -> None:
    """The generic protocol names a family's design and settings types."""
    from trainctl.controllers.lqr.settings import LQRSettings

    family: ControllerFamily[LQRDesign, LQRSettings] = LQRFamily()
    assert isinstance(family, ControllerFamily)


def test_free_growth_against_eigenvalues() -> None:
    """The free response's growth is log ρ: stable, marginal (a Jordan block) and unstable."""
    rng = np.random.default_rng(3)
    for radius in (0.3, 1.0, 1.7):
        T = rng.standard_normal((5, 5))
        J = np.diag([radius, 0.5 * radius, 0.2, -0.1, 0.0]) + np.eye(5, k=1) * (radius == 1.0)
        A = T @ J @ np.linalg.inv(T)
        assert math.exp(free_growth(A)) == pytest.approx(radius, rel=1e-6)
    assert free_growth(np.eye(3, k=1)) == -math.inf  # nilpotent: the response vanishes
