"""Fault injection over every family and strategy of the registry (issue 25).

Each case runs one strategy of one family on its built-in scenario for a few samples and
injects one fault kind:

- ``nan``: the measurement (state and outputs) is all NaN at two samples;
- ``infeasible``: the solver finds no solution at two samples (a QP reports
  ``"infeasible"``; a feedback law gives non-finite forces);
- ``exception``: the solver raises ``RuntimeError`` at two samples;
- ``divergence``: the reference accelerates at 3 m/s², beyond any train, and
  the run is stopped when a speed error exceeds 1 m/s.

At every sample the applied inputs are finite, within each vehicle's envelope at its speed
and within the family's rate limit of the previous input (where the envelope allows it;
else on the envelope's side nearest, as the actuator must), the statuses and fallbacks are
recorded, and the run completes (or stops with its divergence recorded).
"""

from __future__ import annotations

import math
import warnings
from functools import cache

import numpy as np
import pytest

from trainctl.controllers.base import STATUSES, Measurement
from trainctl.controllers.mpc.qp.fast import QPSolution
from trainctl.design import build_design
from trainctl.exceptions import InaccurateSolutionWarning
from trainctl.models import ActuatorLimits, Plant, equilibrium
from trainctl.models.actuator import SATURATION_TOLERANCE
from trainctl.registry import family_names, get_family
from trainctl.scenario import load_scenario
from trainctl.scenario.core import family_of
from trainctl.scenario.files import builtin_scenarios
from trainctl.sim import HOLD_FALLBACK, SpeedProfile, simulate

FAULTY = frozenset({2, 3})
"""The samples at which a fault is injected."""

RATE_LIMIT_KN = 1.0
"""The rate limit given to the families that have one (MPC) [kN per sample]."""


def _solver_points():
    """Where each family's step calls its solver: (class, method, the method's 'no solution')."""
    from trainctl.controllers.flocking.law import FlockingLaw
    from trainctl.controllers.hinf.law import HinfLaw
    from trainctl.controllers.lqr.controller import LQRController
    from trainctl.controllers.mpc.condensed import QPBlock
    from trainctl.controllers.potential.law import PotentialLaw
    from trainctl.controllers.synchronous.law import SynchronousLaw

    def no_qp_solution(self, *args):
        return QPSolution(np.full(self.cols.size, np.nan), np.zeros(0), "infeasible", 0, 0.0)

    def nan_like(original):
        def none(self, *args):
            return np.full_like(np.asarray(original(self, *args), dtype=float), np.nan)
        return none

    return {
        "mpc": (QPBlock, "solve", lambda original: no_qp_solution),
        "lqr": (LQRController, "_feedback", nan_like),
        "potential": (PotentialLaw, "force", nan_like),
        "flocking": (FlockingLaw, "force", nan_like),
        "synchronous": (SynchronousLaw, "command", lambda original: lambda self, *a: math.nan),
        "hinf": (HinfLaw, "commands", nan_like),
    }


CASES = [(family, strategy) for family in family_names()
         for strategy in get_family(family).strategies]
KINDS = ("nan", "infeasible", "exception", "divergence")


@cache
def family_setup(family: str):
    """The family's first built-in scenario with a simulation, its rate limit set, and its
    design."""
    for builtin in builtin_scenarios():
        scenario = load_scenario(builtin.name)
        if family in scenario.controllers and scenario.simulation is not None:
            break
    else:  # pragma: no cover - a family without a built-in scenario
        pytest.fail(f"family {family!r} has no built-in scenario with a [simulation]")
    if family_of(scenario.controller) == family and hasattr(scenario.controller, "rate_limit"):
        scenario = scenario.replace("controller.rate_limit_kn", RATE_LIMIT_KN)
    return scenario, build_design(scenario)


@cache
def controller(family: str, strategy: str):
    """The strategy's controller, built once (its QPs are modelled once); reset per run."""
    scenario, design = family_setup(family)
    return get_family(family).make(design.family(family), strategy)


class Faulty:
    """Wraps a controller: marks the faulty samples, spoils the measurement for ``nan``."""

    def __init__(self, inner, kind: str, state) -> None:
        self.inner, self.kind, self.state = inner, kind, state
        self.dt, self.name = inner.dt, inner.name
        self.records = []
        self.k = 0

    def reset(self) -> None:
        self.inner.reset()
        self.records.clear()
        self.k = 0

    def step(self, t, measurement, reference):
        self.state.on = self.k in FAULTY and self.kind in ("infeasible", "exception")
        if self.kind == "nan" and self.k in FAULTY:
            measurement = Measurement(
                state=None if measurement.state is None else np.full_like(measurement.state,
                                                                          np.nan),
                outputs=np.full_like(measurement.outputs, np.nan),
                messages=measurement.messages, positions=measurement.positions)
        try:
            record = self.inner.step(t, measurement, reference)
        finally:
            self.state.on = False
        self.k += 1
        self.records.append(record)
        return record


class Switch:
    on = False


def inject(monkeypatch, family: str, kind: str, state: Switch) -> None:
    """Patch the family's solver call: raise, or give no solution, while ``state.on``."""
    points = _solver_points()
    assert family in points, f"declare where family {family!r} calls its solver"
    owner, method, no_solution = points[family]
    original = getattr(owner, method)
    failed = no_solution(original)

    def patched(self, *args):
        if state.on and kind == "exception":
            raise RuntimeError("injected solver failure")
        if state.on and kind == "infeasible":
            return failed(self, *args)
        return original(self, *args)

    monkeypatch.setattr(owner, method, patched)


def run_case(family: str, strategy: str, kind: str, monkeypatch):
    scenario, design = family_setup(family)
    state = Switch()
    if kind in ("infeasible", "exception"):
        inject(monkeypatch, family, kind, state)
    inner = controller(family, strategy)
    ctl = Faulty(inner, kind, state)
    T = ctl.dt
    samples = max(8, math.ceil(2.0 / T))
    sim = scenario.simulation
    v0 = float(sim.reference_speeds[0]) or float(scenario.model.speed)  # not at standstill
    if kind == "divergence":
        end = samples * T
        profile = SpeedProfile(times=np.array([0.0, end]), speeds=np.array([v0, v0 + 3.0 * end]))
        bound = 1.0
    else:
        profile = SpeedProfile(times=np.array([0.0, 1.0]), speeds=np.array([v0, v0]))
        bound = math.inf
    x0 = equilibrium(scenario.train, v0).state(position=0.0)
    preview = getattr(inner, "preview_steps", None)
    preview = int(getattr(inner, "P", 1)) if preview is None else preview
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InaccurateSolutionWarning)
        result = simulate(Plant(train=scenario.train), ctl, profile, duration=samples * T,
                          initial_state=x0, preview_steps=preview,
                          full_state=getattr(inner, "needs_full_state", True),
                          divergence_speed_error=bound)
    constraints = getattr(inner, "constraints", None)
    rate = getattr(constraints, "rate_limit", math.inf)
    return scenario, ctl, result, samples, rate


def assert_safe_inputs(train, result, rate: float) -> None:
    """Finite, within the envelope at each vehicle's speed, within the rate limit of the
    previous applied input where the envelope allows it (else on the envelope nearest)."""
    assert np.isfinite(result.inputs).all() and np.isfinite(result.requested_inputs).all()
    limits = ActuatorLimits(train)
    tol = SATURATION_TOLERANCE + 1e-6
    for k in range(result.n_samples):
        low, high = limits.limits(result.velocities[:, k])
        u = result.inputs[:, k]
        assert np.all(u >= low - tol) and np.all(u <= high + tol), k
        if k == 0 or not math.isfinite(rate):
            continue
        prev = result.inputs[:, k - 1]
        lo, hi = np.maximum(prev - rate, low), np.minimum(prev + rate, high)
        meets = lo <= hi
        assert np.all(u[meets] >= lo[meets] - 1.0) and np.all(u[meets] <= hi[meets] + 1.0), (
            k, (u - prev).tolist())
        nearest = np.where(prev + rate < low, low, high)
        assert np.allclose(u[~meets], nearest[~meets], atol=1.0), k


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize(("family", "strategy"), CASES)
def test_faults_keep_the_inputs_safe_and_are_recorded(family, strategy, kind, monkeypatch):
    scenario, ctl, result, samples, rate = run_case(family, strategy, kind, monkeypatch)
    assert set(result.statuses) <= set(STATUSES)
    assert len(result.statuses) == len(result.fallbacks) == result.n_samples
    # one rule: the controller itself applies its fallback, the loop never has to hold
    assert HOLD_FALLBACK not in result.fallbacks
    assert_safe_inputs(scenario.train, result, rate)
    if kind == "divergence":
        assert result.divergence is not None and result.divergence["bound"] == 1.0
        assert result.n_samples < samples and "diverged in sample" in result.divergence["message"]
        return
    assert result.divergence is None and result.n_samples == samples  # the run went on
    for k in range(samples):
        record = ctl.records[k]
        if k not in FAULTY:
            assert result.statuses[k] != "error", (k, record.info)
            continue
        assert result.fallbacks[k] == record.fallback != "", k
        if kind == "infeasible" and family == "mpc":
            assert result.statuses[k] == "infeasible", k
            continue
        assert result.statuses[k] == "error", k
        reason = str(record.info.get("reason", ""))
        expected = {"nan": "non-finite measurement", "exception": "RuntimeError: injected",
                    "infeasible": ""}[kind]
        assert reason and expected in reason, reason


def test_every_family_declares_its_solver_call():
    """A new family must say where its step calls its solver, or it is not fault-tested."""
    assert set(family_names()) <= set(_solver_points())


class TestSolverExceptions:
    """A solver that raises fails its step, not the run (the narrow try at the solve call)."""

    @pytest.mark.parametrize("path", ["fast", "cvxpy"])
    def test_a_cvxpy_solver_error_is_an_error_step_with_the_fallback(self, monkeypatch, path):
        import cvxpy as cp

        from trainctl.controllers.mpc import MPCConstraints, make_mpc
        from trainctl.controllers.mpc.qp.parametric import ParametricQP
        from trainctl.sim import compute_metrics

        scenario, design = family_setup("mpc")
        ctl = make_mpc(scenario.train, design.family("mpc").mpc, dt=scenario.model.sample_time,
                       strategy="ndmpc", path=path,
                       constraints=MPCConstraints(rate_limit=RATE_LIMIT_KN * 1e3))
        assert ctl.problem.fast == (path == "fast")
        state = {"on": False, "raised": 0}
        for name in ("solve", "solve_data"):  # the cvxpy path and the fast path
            original = getattr(ParametricQP, name)

            def failing(self, *args, _original=original, **kwargs):
                if state["on"]:
                    state["raised"] += 1
                    raise cp.error.SolverError("injected: OSQP workspace lost")
                return _original(self, *args, **kwargs)

            monkeypatch.setattr(ParametricQP, name, failing)

        class At3:
            dt, name, P, needs_full_state = ctl.dt, "ndmpc", ctl.P, True

            def __init__(self):
                self.k = 0

            def reset(self):
                self.k = 0
                ctl.reset()

            def step(self, t, measurement, reference):
                state["on"] = self.k == 3
                self.k += 1
                try:
                    return ctl.step(t, measurement, reference)
                finally:
                    state["on"] = False

        v0 = float(scenario.model.speed)
        x0 = equilibrium(scenario.train, v0).state(position=0.0)
        with pytest.warns(InaccurateSolutionWarning,
                          match=r"1 of 6 samples of 'ndmpc' were not solved to optimality "
                                r"\(error 1\); 1 applied a fallback"):
            result = simulate(Plant(train=scenario.train), At3(),
                              SpeedProfile(times=np.array([0.0, 1.0]),
                                           speeds=np.array([v0, v0])),
                              duration=6 * ctl.dt, initial_state=x0, preview_steps=ctl.P)
        assert state["raised"] > 0
        assert result.statuses[3] == "error" and result.fallbacks[3] == "shifted plan"
        assert set(result.statuses[:3] + result.statuses[4:]) == {"optimal"}
        assert compute_metrics(result).fallback_counts == {"shifted plan": 1}
        assert_safe_inputs(scenario.train, result, RATE_LIMIT_KN * 1e3)

    def test_the_reason_names_the_exception(self, monkeypatch):
        from trainctl.controllers.mpc.condensed import QPBlock

        scenario, design = family_setup("mpc")
        ctl = controller("mpc", "centralised")
        ctl.reset()

        def broken(self, *args):
            raise RuntimeError("injected")

        monkeypatch.setattr(QPBlock, "solve", broken)
        v0 = float(scenario.model.speed)
        x = equilibrium(scenario.train, v0).state(position=0.0)
        times = ctl.dt * np.arange(ctl.P + 1)
        from trainctl.controllers.base import ReferencePreview

        ref = ReferencePreview(times=times, speed=np.full(times.size, v0),
                               acceleration=np.zeros(times.size))
        record = ctl.step(0.0, Measurement(state=x), ref)
        assert (record.status, record.fallback) == ("error", "shifted plan")
        assert record.info["reason"] == "the solver raised RuntimeError: injected"
        # no previous plan: the feedforward, the equilibrium forces
        np.testing.assert_allclose(record.inputs, equilibrium(scenario.train, v0).inputs,
                                   atol=1e-6)

    @pytest.mark.parametrize("exc", [MemoryError, KeyboardInterrupt, SystemExit])
    def test_memory_errors_and_interrupts_are_not_swallowed(self, monkeypatch, exc):
        from trainctl.controllers.mpc.condensed import QPBlock

        scenario, design = family_setup("mpc")
        ctl = controller("mpc", "ndmpc")
        ctl.reset()

        def broken(self, *args):
            raise exc()

        monkeypatch.setattr(QPBlock, "solve", broken)
        v0 = float(scenario.model.speed)
        x0 = equilibrium(scenario.train, v0).state(position=0.0)
        with pytest.raises(exc):
            simulate(Plant(train=scenario.train), ctl,
                     SpeedProfile(times=np.array([0.0, 1.0]), speeds=np.array([v0, v0])),
                     duration=2 * ctl.dt, initial_state=x0, preview_steps=ctl.P)

    def test_a_law_that_raises_is_an_error_step_with_the_feedforward(self, monkeypatch):
        """The same rule for a feedback law (here H∞'s commands)."""
        from trainctl.controllers.base import ReferencePreview
        from trainctl.controllers.hinf.law import HinfLaw

        scenario, design = family_setup("hinf")
        ctl = controller("hinf", "distributed")
        ctl.reset()
        v = float(scenario.model.speed)
        ref = ReferencePreview(times=np.zeros(2), speed=np.full(2, v),
                               acceleration=np.zeros(2))
        good = ctl.step(0.0, Measurement(outputs=np.full(4, v)), ref)

        def broken(self, *args):
            raise ValueError("injected")

        monkeypatch.setattr(HinfLaw, "commands", broken)
        bad = ctl.step(0.1, Measurement(outputs=np.full(4, v)), ref)
        assert (bad.status, bad.fallback) == ("error", "feedforward")
        assert bad.info["reason"] == "the solver raised ValueError: injected"
        # at the equilibrium the law's feedforward is the law's own answer
        np.testing.assert_allclose(bad.inputs, good.inputs, rtol=1e-9)

    def test_the_linear_mpc_core_applies_its_plan_when_the_solver_raises(self, monkeypatch):
        import control as ct

        from trainctl.controllers.mpc import make_linear_mpc
        from trainctl.controllers.mpc.condensed import QPBlock

        sysd = ct.ss([[1, 1], [0, 1]], [[1], [0.5]], np.eye(2), 0, dt=1)
        ctl = make_linear_mpc(sysd, Q=np.eye(2), R=1, prediction_horizon=4, control_horizon=3,
                              u_min=-1, u_max=1).controller()
        first = ctl.step(0.0, Measurement(state=np.array([4.0, 0.0])), None)
        planned = ctl._planned[0].copy()

        def broken(self, *args):
            raise RuntimeError("injected")

        monkeypatch.setattr(QPBlock, "solve", broken)
        bad = ctl.step(1.0, Measurement(state=np.array([3.0, 0.0])), None)
        assert first.status == "optimal"
        assert (bad.status, bad.fallback) == ("error", "shifted plan")
        np.testing.assert_array_equal(bad.inputs, planned)
