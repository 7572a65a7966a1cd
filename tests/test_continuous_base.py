# A minimal continuous-law family on the shared base: a proportional speed law, registered and run.
"""What a new continuous-time law family needs (``trainctl.controllers.continuous``).

The family below is complete: a law (its nonlinear force and linear gain),
settings, a design function, its checks and the family's vocabulary. The
controller, the closed loop, the loop held over an interval and the glue
come from :class:`~trainctl.controllers.continuous.family.ContinuousFamily`
and :class:`~trainctl.controllers.continuous.family.SampledDesign`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from trainctl.controllers.continuous.family import ContinuousFamily, SampledDesign
from trainctl.controllers.continuous.loops import closed_loop_matrices, hurwitz_check
from trainctl.controllers.continuous.sampled import control_interval, sampling_check

# ---------------------------------------------------------------- the minimal family


@dataclass(frozen=True)
class SpeedLaw:
    """u_i = -k m_i v̂_i [N] about the feedforward."""

    mass: np.ndarray
    gain: float

    @property
    def n(self) -> int:
        return int(self.mass.size)

    def force(self, v_err, z, x_err):
        return -self.gain * self.mass * v_err

    def feedback(self):
        F = np.zeros((self.n, 2 * self.n - 1))
        F[:, :self.n] = -self.gain * np.diag(self.mass)
        return F


@dataclass(frozen=True)
class SpeedSettings:
    gain: float = 0.5  # [1/s]
    control_interval: float | None = None  # [s]; None: the model's sample time
    input_bounds: bool = True


class SpeedDesign(SampledDesign[SpeedSettings, SpeedLaw]):
    pass


def design_speed(scenario, model, settings):
    law = SpeedLaw(mass=np.asarray(scenario.train.mass, dtype=float), gain=settings.gain)
    return SpeedDesign(scenario=scenario, model=model, settings=settings, law=law,
                       control_interval=control_interval(scenario, model, settings, "speed"),
                       loops=closed_loop_matrices(model, law.feedback()))


def speed_checks(design):
    return [hurwitz_check("speed_closed_loop", design.A_cl, hint="raise the gain",
                          unstable="unstable: max Re λ = {alpha:.4g} 1/s",
                          stable="Hurwitz: max Re λ = {alpha:.4g} 1/s"),
            sampling_check("speed_sampling", design.A_cl, design.sampled_matrix(),
                           design.control_interval)]


class SpeedFamily(ContinuousFamily[SpeedDesign, SpeedSettings]):
    name = "speed"
    title = "Proportional speed law"
    strategies = ("proportional",)
    check_names = ("speed_closed_loop", "speed_sampling")
    settings_path = f"{__name__}:SpeedSettings"
    checks_path = f"{__name__}:speed_checks"
    controller_path = "trainctl.controllers.continuous.controller:SampledLawController"
    _design = staticmethod(design_speed)


# ---------------------------------------------------------------- the tests


@pytest.fixture
def family():
    from trainctl.registry import get_family, register_family, unregister_family

    register_family(SpeedFamily())
    yield get_family("speed")
    unregister_family("speed")


@pytest.fixture
def design(family):
    from trainctl.design import build_model
    from trainctl.scenario import load_scenario

    scenario = load_scenario("crh2-dmpc-well-sampled")
    return family.design(scenario, build_model(scenario), SpeedSettings())


def test_the_family_is_registered_and_follows_the_protocol(family):
    from trainctl.registry import ControllerFamily, family_names

    assert "speed" in family_names()
    assert isinstance(family, ControllerFamily)
    assert family.settings is SpeedSettings
    assert family.report_data(None) == {} and family.report_figures({}) == []


def test_design_checks_and_closed_loop(family, design):
    assert design.control_interval == 0.05  # the model's sample time
    assert [c.name for c in family.checks(design)] == list(family.check_names)
    assert family.checks(design)[0].status == "pass"
    sys = family.closed_loop(design, "proportional")
    assert sys.name == "speed_proportional" and sys.isctime()
    assert sys.ninputs == 4 and sys.noutputs == len(design.model.loop_outputs()[1])
    assert np.max(np.linalg.eigvals(sys.A).real) < 0.0
    rho = np.max(np.abs(np.linalg.eigvals(design.sampled_matrix())))
    assert rho < 1.0


def test_controller_holds_the_equilibrium(family, design):
    from trainctl.controllers.base import Measurement, ReferencePreview
    from trainctl.models import equilibrium

    ctl = family.make(design, "proportional")
    assert ctl.name == "proportional" and ctl.dt == 0.05
    speed = float(design.model.settings.speed)
    eq = equilibrium(design.scenario.train, speed)
    ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, speed), acceleration=np.zeros(1))
    rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    assert rec.status == "optimal"
    assert np.allclose(rec.inputs, eq.inputs)
    faster = eq.state(position=0.0).copy()
    faster[0] += 1.0  # the head 1 m/s too fast is braked by k m_0 · 1 m/s
    rec = ctl.step(0.05, Measurement(state=faster), ref)
    assert rec.inputs[0] < eq.inputs[0]
