"""Tests for controller families: the registry, the design stage and the LQR family."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace

import control as ct
import numpy as np
import pydantic
import pytest
import scipy.linalg

from trainctl.controllers.lqr.family import FAMILY as LQR
from trainctl.controllers.lqr.family import design_lqr
from trainctl.controllers.mpc.family import FAMILY as MPC
from trainctl.design import build_design, build_model
from trainctl.exceptions import ScenarioError
from trainctl.models.linear import linearise
from trainctl.registry import (
    family_names,
    get_family,
    register_family,
    unregister_family,
)
from trainctl.scenario import load_scenario


def _zoh(A: np.ndarray, B: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order hold by the matrix exponential of [[A, B], [0, 0]] (independent of c2d)."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = scipy.linalg.expm(M * T)
    return E[:n, :n], E[:n, n:]


def _lqr_settings(**changes: object) -> SimpleNamespace:
    base = {"outputs": ("v", "force"), "q_velocity": 1.0, "q_force": 1e-4,
            "input_weight_per_kn2": lambda: 1e-3, "input_bounds": True}
    base.update(changes)
    return SimpleNamespace(**base)


class TestRegistry:
    """family_names / get_family / register_family (the protocol: tests/test_check_family.py)."""

    def test_unknown_family_is_a_scenario_error_with_a_suggestion(self) -> None:
        """A misspelt family name is refused with the closest name."""
        with pytest.raises(ScenarioError, match=r"'mcp' is not known\. Did you mean 'mpc'\?"):
            get_family("mcp")

    def test_builtins_cannot_be_replaced(self) -> None:
        """register_family refuses a built-in name and a non-identifier."""
        with pytest.raises(ValueError, match="built-in family"):
            register_family(SimpleNamespace(name="mpc"))  # type: ignore[arg-type]
        with pytest.raises(ValueError, match="identifier"):
            register_family(SimpleNamespace(name="not ok"))  # type: ignore[arg-type]

    def test_register_and_unregister(self) -> None:
        """A registered family is listed and found until it is removed."""
        toy = SimpleNamespace(name="toy_registry_probe")
        register_family(toy)  # type: ignore[arg-type]
        try:
            assert "toy_registry_probe" in family_names()
            assert get_family("toy_registry_probe") is toy
        finally:
            unregister_family("toy_registry_probe")
        assert "toy_registry_probe" not in family_names()


class TestDesignStage:
    """build_model / build_design: one linearisation, derived models."""

    def test_design_model_is_the_zoh_of_an_independent_linearisation(self) -> None:
        """discrete = expm ZOH of linearise(no dummy), inputs in kN, forces in kN."""
        scenario = load_scenario("crh2-dmpc")
        model = build_model(scenario)
        cfg = scenario.model
        sys = linearise(scenario.train, cfg.speed, method=cfg.linearisation,
                        outputs=("v", "force"))
        Ad, Bd = _zoh(np.asarray(sys.A), np.asarray(sys.B) * 1e3, cfg.sample_time)
        np.testing.assert_allclose(model.discrete.A, Ad, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(model.discrete.B, Bd, rtol=1e-9, atol=1e-15)
        n = scenario.train.n_vehicles
        np.testing.assert_allclose(model.discrete.C[n:], np.asarray(sys.C)[n:] / 1e3)
        assert model.discrete.dt == cfg.sample_time
        assert model.linear.nstates == 2 * n and model.has_dummy

    def test_disturbance_matrix_is_the_zoh_of_a_specific_force(self) -> None:
        """B_w = ZOH of e_i on the speed rows (a disturbance w_i in m/s² per vehicle)."""
        scenario = load_scenario("crh2-dmpc-well-sampled")
        model = build_model(scenario)
        n, nx = model.n_vehicles, model.n_states
        E = np.zeros((nx, n))
        E[:n] = np.eye(n)
        _, Bw = _zoh(np.asarray(model.design.A), E, scenario.model.sample_time)
        np.testing.assert_allclose(model.disturbance_matrix(), Bw, rtol=1e-9, atol=1e-15)

    def test_design_pickles(self) -> None:
        """A design (StateSpace inside) survives pickling, for worker processes."""
        import pickle

        design = build_design(load_scenario("crh2-dmpc"))
        copy = pickle.loads(pickle.dumps(design))
        np.testing.assert_array_equal(copy.model.discrete.A, design.model.discrete.A)
        assert copy.model.discrete.dt == design.model.discrete.dt
        assert copy.family("mpc").mpc.form == design.family("mpc").mpc.form

    def test_missing_family_is_named(self) -> None:
        """Asking a design for a family it does not have names the ones it has."""
        design = build_design(load_scenario("crh2-dmpc"))
        with pytest.raises(ScenarioError, match=r"no \[controller\] of family 'lqr'.*mpc"):
            design.family("lqr")

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_report_linearises_once_per_model(self, monkeypatch: pytest.MonkeyPatch,
                                              tmp_path: object) -> None:
        """`trainctl report crh2-dmpc` linearises and discretises the train model once."""
        import trainctl.design.model as model_module
        import trainctl.models.discrete as discrete_module
        import trainctl.models.linear as linear_module
        from trainctl.cli.main import main

        calls = {"linearise": 0, "discretise": 0}

        def counting(module: object, name: str) -> None:
            original = getattr(module, name)

            def wrapper(*args: object, **kwargs: object) -> object:
                calls[name] += 1
                return original(*args, **kwargs)

            monkeypatch.setattr(module, name, wrapper)

        for module in (linear_module, model_module):
            counting(module, "linearise")
        for module in (discrete_module, model_module):
            counting(module, "discretise")
        out = f"{tmp_path}/r.html"
        assert main(["report", "crh2-dmpc", "-o", out, "--deterministic", "--jobs", "1"]) == 0
        assert calls == {"linearise": 1, "discretise": 1}


class TestMPCClosedLoop:
    """The MPC family's linear closed loops."""

    @pytest.mark.parametrize("name", ["crh2-dmpc", "crh2-dmpc-well-sampled"])
    def test_poles_are_the_analysed_closed_loops(self, name: str) -> None:
        """closed_loop() poles = eigenvalues of the matrices the checks judge."""
        design = build_design(load_scenario(name)).family("mpc")
        res = design.analysis
        for strategy, A_cl in (("centralised", res.closed_loop_centralised),
                               ("ndmpc", res.closed_loop_nash)):
            sys = MPC.closed_loop(design, strategy)
            assert sys.dt == design.model.settings.sample_time
            got = np.sort_complex(sys.poles())
            want = np.sort_complex(np.linalg.eigvals(A_cl))
            np.testing.assert_allclose(got, want, atol=1e-9)

    def test_decentralised_loop_is_one_sweep_of_own_cost(self) -> None:
        """Decentralised: U = D1(self) e, the closed loop of the coaches' own problems."""
        from trainctl.controllers.mpc.theory.iteration import closed_loop_matrix, iteration_matrices

        design = build_design(load_scenario("crh2-dmpc-well-sampled")).family("mpc")
        own = design.mpc.with_neighbourhoods([(i,) for i in range(design.mpc.n_inputs)])
        _, D1 = iteration_matrices(own)
        want = np.linalg.eigvals(closed_loop_matrix(own, D1))
        got = MPC.closed_loop(design, "decentralised").poles()
        np.testing.assert_allclose(np.sort_complex(got), np.sort_complex(want), atol=1e-9)


@pytest.fixture(scope="module")
def case() -> tuple[object, object]:
    """The well-sampled CRH2 scenario and an LQR design on it."""
    scenario = load_scenario("crh2-dmpc-well-sampled")
    return scenario, design_lqr(scenario, build_model(scenario), _lqr_settings())


class TestLQR:
    """The LQR family against python-control's dlqr on independently built matrices."""

    def test_centralised_gain_is_dlqr(self, case: tuple) -> None:
        """K equals ct.dlqr on the ZOH model and Q = Cᵀ diag(q) C, R = r I, built here."""
        scenario, design = case
        cfg, n = scenario.model, scenario.train.n_vehicles
        sys = linearise(scenario.train, cfg.speed, outputs=("v", "force"))
        Ad, Bd = _zoh(np.asarray(sys.A), np.asarray(sys.B) * 1e3, cfg.sample_time)
        C = np.asarray(sys.C) / np.r_[np.ones(n), np.full(n - 1, 1e3)][:, None]
        q = np.r_[np.full(n, 1.0), np.full(n - 1, 1e-4)]
        K, S, _ = ct.dlqr(Ad, Bd, C.T @ np.diag(q) @ C, 1e-3 * np.eye(n))
        np.testing.assert_allclose(design.gains["centralised"], K, rtol=1e-6, atol=1e-9)
        # And the Riccati equation holds for the design's own gain.
        Kd = design.gains["centralised"]
        R = 1e-3 * np.eye(n)
        np.testing.assert_allclose(Kd, np.linalg.solve(R + Bd.T @ S @ Bd, Bd.T @ S @ Ad),
                                   rtol=1e-6, atol=1e-9)

    def test_decentralised_gains_are_per_coach_dlqr(self, case: tuple) -> None:
        """Row i of K is dlqr of coach i's own (A_ii, B_i) with the weights it owns."""
        scenario, design = case
        train, T = scenario.train, scenario.model.sample_time
        n = train.n_vehicles
        K = design.gains["decentralised"]
        speed, d = scenario.model.speed, train.damping
        for i in range(n):
            m = train.mass[i]
            a1, a2 = train.davis[1][i], train.davis[2][i]
            d_front = d[i - 1] if i > 0 else 0.0
            d_rear = d[i] if i < n - 1 else 0.0
            a00 = -(a1 + 2 * a2 * speed) - (d_front + d_rear) / m
            if i < n - 1:
                k = train.stiffness[i]
                A = np.array([[a00, -k / m], [1.0, 0.0]])
                B = np.array([[1e3 / m], [0.0]])
                Cf = np.array([[d[i] / 1e3, k / 1e3]])  # coupler behind coach i [kN], own states
                Q = np.diag([1.0, 0.0]) + 1e-4 * Cf.T @ Cf
                cols = [i, n + i]
            else:
                A = np.array([[a00]])
                B = np.array([[1e3 / m]])
                Q = np.eye(1)
                cols = [i]
            Ad, Bd = _zoh(A, B, T)
            Ki, _, _ = ct.dlqr(Ad, Bd, Q, 1e-3 * np.eye(1))
            np.testing.assert_allclose(K[i, cols], Ki[0], rtol=1e-6, atol=1e-9)
            others = np.setdiff1d(np.arange(2 * n - 1), cols)
            assert np.all(K[i, others] == 0.0)

    @pytest.mark.parametrize("strategy", ["centralised", "decentralised"])
    def test_closed_loop_poles(self, case: tuple, strategy: str) -> None:
        """closed_loop() poles = eig(A - B K), the matrix the checks judge."""
        _, design = case
        sys = LQR.closed_loop(design, strategy)
        want = np.linalg.eigvals(design.A - design.B @ design.gains[strategy])
        np.testing.assert_allclose(np.sort_complex(sys.poles()), np.sort_complex(want),
                                   atol=1e-12)
        [check] = [c for c in LQR.checks(design)
                   if c.name == dict(zip(LQR.strategies, LQR.check_names, strict=True))[strategy]]
        assert check.value == pytest.approx(float(np.max(np.abs(want))), rel=1e-12)
        assert check.status == "pass"

    def test_saturation_keeps_the_envelope(self, case: tuple) -> None:
        """A large error saturates: forces stay within each vehicle's envelope."""
        from trainctl.controllers.base import Measurement, ReferencePreview
        from trainctl.models.dynamics import equilibrium

        scenario, design = case
        train = scenario.train
        controller = LQR.make(design, "centralised")
        state = equilibrium(train, 60.0).state(position=0.0)
        ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 80.0),
                               acceleration=np.zeros(1))
        record = controller.step(0.0, Measurement(state=state), ref)
        high = [veh.envelope.traction_limit(60.0, mass=veh.mass) for veh in train.vehicles]
        low = [-veh.envelope.braking_limit(60.0, mass=veh.mass) for veh in train.vehicles]
        assert np.all(record.inputs <= np.asarray(high) + 1e-9)
        assert np.all(record.inputs >= np.asarray(low) - 1e-9)
        assert record.info["saturated"] > 0
        unbounded = LQR.make(dataclasses.replace(design, settings=_lqr_settings(
            input_bounds=False)), "centralised")
        assert np.max(unbounded.step(0.0, Measurement(state=state), ref).inputs) > max(high)


# --------------------------------------------------------------------------- a toy family

TOY_SCENARIO = """\
schema_version = 1
name = "Two coaches under a toy controller"
description = "A family defined in the test file, run through analyse and report"

[[train.vehicle]]
name = "M"
mass_t = 40.0
count = 2
davis_si = [0.01, 0.0, 1e-5]
max_traction_kn = 200.0
max_braking_kn = 200.0

[train.coupler]
stiffness_kn_per_m = 10000.0
damping_kn_s_per_m = 20.0

[model]
speed_kmh = 90.0
sample_time = 0.05

[controller]
family = "toy"
gain_per_s = 0.4

[simulation]
duration = 30.0
strategies = ["proportional"]
initial_speed_error = -1.0
settle_time = 20.0
tracking_tolerance = 0.5

[simulation.reference]
times = [0.0]
speeds_kmh = [90.0]

[expected]
toy_closed_loop = "pass"
"""


class ToySettings(pydantic.BaseModel):
    """The toy family's [controller] table: one speed-feedback gain."""

    model_config = pydantic.ConfigDict(extra="forbid", frozen=True)
    gain_per_s: float = pydantic.Field(default=0.2, gt=0)


@dataclasses.dataclass(frozen=True)
class ToyDesign:
    """Per-vehicle speed feedback u_i = u_ff,i + g m_i (v_ref - v_i) on the design model."""

    model: object
    settings: ToySettings

    def gain(self) -> np.ndarray:
        model = self.model
        n, nx = model.n_vehicles, model.n_states  # type: ignore[attr-defined]
        K = np.zeros((n, nx))
        K[:, :n] = np.diag(self.settings.gain_per_s * model.train.mass / 1e3)  # type: ignore
        return K


class ToyFamily:
    """A controller family that lives only in this test file."""

    name = "toy"
    title = "Toy speed feedback"
    strategies = ("proportional",)
    check_names = ("toy_closed_loop",)
    settings = ToySettings
    report_partial = "<p class=\"toy\">Toy gain {{ data.gain }} per second.</p>\n"

    def design(self, scenario: object, model: object, settings: ToySettings) -> ToyDesign:
        return ToyDesign(model=model, settings=settings)

    def make(self, design: ToyDesign, strategy: str) -> object:
        from trainctl.controllers.lqr.controller import LQRController

        return LQRController(design.model.train, design.gain(),  # type: ignore[attr-defined]
                             dt=design.model.settings.sample_time,  # type: ignore[attr-defined]
                             name=strategy)

    def checks(self, design: ToyDesign) -> list[object]:
        from trainctl.analysis.check import radius_check

        return [radius_check("toy_closed_loop", self._matrix(design),
                             design.model.train.state_labels(),  # type: ignore[attr-defined]
                             "toy feedback", marginal_hint="", unstable_hint="lower the gain")]

    def closed_loop(self, design: ToyDesign, strategy: str) -> ct.StateSpace:
        model = design.model
        return ct.ss(self._matrix(design), model.disturbance_matrix(),  # type: ignore
                     np.eye(model.n_states), 0, dt=model.settings.sample_time)  # type: ignore

    def report_data(self, design: ToyDesign) -> dict[str, object]:
        return {"gain": design.settings.gain_per_s}

    def report_figures(self, data: object) -> list[object]:
        return []

    @staticmethod
    def _matrix(design: ToyDesign) -> np.ndarray:
        sysd = design.model.discrete  # type: ignore[attr-defined]
        return np.asarray(sysd.A) - np.asarray(sysd.B) @ design.gain()


@pytest.fixture
def toy_family() -> Iterator[ToyFamily]:
    """The toy family, registered for one test."""
    family = ToyFamily()
    register_family(family)  # type: ignore[arg-type]
    try:
        yield family
    finally:
        unregister_family("toy")


class TestToyFamily:
    """A family defined in a test runs through `trainctl analyse` and `trainctl report`."""

    def test_analyse_and_report(self, toy_family: ToyFamily, tmp_path: Path,
                                capsys: pytest.CaptureFixture[str]) -> None:
        """Checks, the simulation, the report section and the closed loop, all from the toy."""
        import json

        from trainctl.cli.main import main

        path = tmp_path / "toy.toml"
        path.write_text(TOY_SCENARIO, encoding="utf-8")
        assert main(["analyse", str(path), "--json", "--strict"]) == 0
        result = json.loads(capsys.readouterr().out)
        checks = {c["name"]: c for c in result["checks"]}
        assert checks["toy_closed_loop"]["status"] == "pass"
        assert result["simulations"]["proportional"]["tracking_ok"] is True
        out = tmp_path / "toy.html"
        assert main(["report", str(path), "-o", str(out), "--deterministic"]) == 0
        html = out.read_text(encoding="utf-8")
        assert '<section id="family-toy">' in html and "Toy gain 0.4 per second." in html
        assert "toy_closed_loop" in html and ">proportional<" in html
        design = build_design(load_scenario(str(path)))
        loop = design.closed_loop("proportional")
        radius = checks["toy_closed_loop"]["value"]
        assert float(np.max(np.abs(loop.poles()))) == pytest.approx(radius, rel=1e-12)
