"""The flocking family's braking supervisor (issue 28) and its check, flocking_braking_distance.

heavy-haul-flocking-outage: four 10,200 t unit trains 500 m apart at 80 km/h lose
their radio over [100, 130) s (0.5 s delay); the reference brakes from 105 s. A
follower that could not stop behind its leader braking at its strongest (460 kN /
10,200 t = 0.0451 m/s²) from its last received state brakes at full.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from trainctl.cli.main import main
from trainctl.controllers.faults import SUPERVISOR_BRAKING
from trainctl.controllers.flocking.checks import braking_margins
from trainctl.controllers.flocking.controller import FlockingController
from trainctl.controllers.flocking.settings import FlockingSettings
from trainctl.controllers.flocking.supervisor import BrakingSupervisor, supervisor_of
from trainctl.design import build_design
from trainctl.design.review import review_design
from trainctl.models.graphs import make_graph
from trainctl.models.network import Network
from trainctl.registry import get_family
from trainctl.run.simulate import _prepare, make_controller, simulate_strategy
from trainctl.scenario import load_scenario
from trainctl.sim.closed_loop import simulate

ANALYSES = Path(__file__).resolve().parent.parent / "analyses"
OUTAGE = ANALYSES / "heavy-haul-flocking-outage.toml"
FLOCKING = get_family("flocking")
V = 80.0 / 3.6          # the cruise speed [m/s]
BRAKE = 460e3 / 10.2e6  # every unit train's braking [m/s²]


@pytest.fixture(scope="module")
def outage():
    return load_scenario(str(OUTAGE))


@pytest.fixture(scope="module")
def runs(outage):
    """The outage scenario simulated with the supervisor on and off: (design, result) each."""
    out = {}
    for on in (True, False):
        sc = outage if on else outage.replace("controller.supervisor", False)
        design = build_design(sc)
        out[on] = (design, simulate_strategy(sc, "flocking", design))
    return out


def _gaps(design, result) -> np.ndarray:
    """Every gap [m] on the dense grid, (3, D)."""
    law = design.family("flocking").law
    return law.gaps(np.asarray(result.dense_states)[law.n:2 * law.n - 1])


def test_the_supervisor_brakes_the_followers_through_the_outage_and_no_gap_closes(runs,
                                                                                  outage):
    """(a) Gaps stay above the margin; the overrides are recorded, and replaying the run
    through ``step`` gives the same steps, each naming followers only."""
    design, result = runs[True]
    assert _gaps(design, result).min() >= 50.0  # the margin, kept by the worst case
    braked = [k for k, f in enumerate(result.fallbacks) if f == SUPERVISOR_BRAKING]
    assert braked  # the 500 m gap is below the 761 m the outage needs
    assert all(result.statuses[k] == "optimal" for k in braked)
    # messages are overdue from the second step of the window on; none before it
    assert 100.0 < result.time[braked[0]] < 130.0
    # the overridden followers hold their full braking, the head is never braked by it
    sup = supervisor_of(outage, outage.controllers["flocking"], 1.0)
    k = braked[0]
    full = sup.full_braking(result.states[:4, k])
    assert np.array_equal(result.inputs[1:, k], full[1:])
    assert result.inputs[0, k] > full[0]
    # replay the recorded states through step(): the same decisions, with info
    controller = make_controller(outage, "flocking")
    controller.reset()
    infos = {}
    for k in range(result.n_samples):
        record = controller.step(
            float(result.time[k]), _measurement(result.states[:, k]),
            _preview(result.reference_speed[k], result.reference_acceleration[k]))
        assert np.array_equal(record.inputs, result.requested_inputs[:, k])
        if record.fallback == SUPERVISOR_BRAKING:
            infos[k] = record.info["supervisor"]
    assert sorted(infos) == braked
    assert all(followers and set(followers) <= {1, 2, 3} for followers in infos.values())


def _measurement(state):
    from trainctl.controllers.base import Measurement

    return Measurement(state=np.array(state, dtype=float))


def _preview(speed, acceleration):
    from trainctl.controllers.base import ReferencePreview

    return ReferencePreview(times=np.zeros(1), speed=np.full(1, float(speed)),
                            acceleration=np.full(1, float(acceleration)))


def test_without_the_supervisor_the_run_breaks_the_relative_braking_distance(runs, outage,
                                                                             tmp_path, capsys):
    """(b) Supervisor off: the trajectory check fails with a negative simulated margin, and
    --strict exits 1; the same scenario with it on exits 0."""
    design, result = runs[False]
    assert SUPERVISOR_BRAKING not in result.fallbacks
    checks = {c.name: c for c in FLOCKING.trajectory_checks(design.family("flocking"),
                                                           "flocking", result)}
    check = checks["flocking_braking_distance"]
    assert check.status == "fail" and "below the relative braking distance" in check.message
    assert check.details["supervisor_activations"] == 0
    # A second route to the value: cruising at v in the outage, the newest state received
    # is the sample at 99 s (sent before 100 s - 0.5 s), the first fresh message arrives
    # by A = 99.5 + 30 + 2 × 0.5 = 130.5 s, and after it the follower reacts within
    # T_c = 1 s. With equal trains and equal brakes the leader braking from 99 s gains
    # nothing on the follower braking at A + T_c but the time between: the follower
    # needs d >= v·(A + T_c - 99) + margin, so the margin is 500 - 50 - 32.5 v.
    assert check.details["simulated_min_margin_m"] == pytest.approx(450.0 - 32.5 * V, rel=1e-9)
    assert 100.0 < check.details["simulated_min_margin_time_s"] < 130.0
    on = FLOCKING.trajectory_checks(runs[True][0].family("flocking"), "flocking", runs[True][1])
    assert on[-1].details["simulated_min_margin_m"] >= 0.0 and on[-1].status == "warn"

    text = OUTAGE.read_text(encoding="utf-8")
    assert text.count("\nsupervisor = true ") == 1
    path = tmp_path / "outage-off.toml"
    path.write_text(text.replace("\nsupervisor = true ", "\nsupervisor = false "),
                    encoding="utf-8")
    changed = outage.replace("controller.supervisor", False)
    assert load_scenario(str(path)).controllers["flocking"] == changed.controllers["flocking"]
    assert main(["analyse", str(path), "--strict"]) == 1
    out = capsys.readouterr().out
    assert "check     flocking_braking_distance:" in out
    assert main(["analyse", str(OUTAGE), "--strict"]) == 0


@pytest.mark.parametrize(("delay", "outage_s", "spacing", "want"), [
    (None, None, None, "warn"),          # the file's network: τ = 0.5 s, T = 30 s
    (2.0, 20.0, [-50.0, 0.0, 20.0], "warn"),
    (0.0, 0.0, None, "pass"),
])
def test_design_time_check_against_the_hand_computation(outage, delay, outage_s, spacing, want):
    """(c) Equal trains at v, equal brakes b, delay τ, outage T, control interval T_c.

    The leader brakes at b just after the last message the follower gets before the
    outage; messages in transit when the window opens are lost too, so the follower
    hears nothing for T + 2τ after that instant and reacts within T_c: it runs on at v
    for T_c + T + 2τ, then brakes at b. Both then follow the same braking motion, the
    follower that time behind, so it closes v·(T_c + T + 2τ) on the leader:

        required = v·(T_c + T + 2τ) + margin   (T_c + τ when there is no outage).
    """
    sc = outage
    if delay is not None:
        sc = sc.replace("controller.supervisor_delay_s", delay)
        sc = sc.replace("controller.supervisor_outage_s", outage_s)
    if spacing is not None:
        sc = sc.replace("simulation.initial_spacing_errors", spacing)
    tau, T = (0.5, 30.0) if delay is None else (delay, outage_s)
    lag = 1.0 + tau + (T + tau if T > 0 else 0.0)
    required = V * lag + 50.0
    smallest = 500.0 + min(0.0, *(spacing or [0.0]))
    check = review_design(sc).check("flocking_braking_distance")
    assert check.status == want
    assert check.value == pytest.approx(smallest - required, rel=1e-12)
    assert check.details["required_m"] == pytest.approx([required] * 3, rel=1e-12)
    assert check.details["leader_deceleration_m_s2"] == pytest.approx([BRAKE] * 3)
    off = review_design(sc.replace("controller.supervisor", False)).check(
        "flocking_braking_distance")
    assert off.status == ("pass" if want == "pass" else "fail")
    if off.status == "fail":
        assert "supervisor = true" in off.hint


def test_the_supervisor_is_off_by_default_and_never_called_then(monkeypatch) -> None:
    """(d) Settings default off; a supervisor-off run neither builds nor calls it, and its
    arrays equal those of the law without the supervisor hook at all."""
    assert FlockingSettings().supervisor is False
    sc = (load_scenario("heavy-haul-flocking").replace("simulation.settle_time", 60.0)
          .replace("simulation.duration", 120.0)
          .replace("simulation.strategies", ["flocking"]))
    assert sc.controllers["flocking"].supervisor is False
    design = build_design(sc)
    assert make_controller(sc, "flocking", design).supervisor is None

    def boom(*args, **kwargs):
        raise AssertionError("the supervisor was called")

    for name in ("__init__", "observe", "run_on_margins", "supervise", "full_braking"):
        monkeypatch.setattr(BrakingSupervisor, name, boom)
    hooked = simulate_strategy(sc, "flocking", design)
    monkeypatch.undo()
    from trainctl.controllers.continuous.controller import SampledLawController

    monkeypatch.setattr(FlockingController, "_law_inputs", SampledLawController._law_inputs)
    bare = simulate_strategy(sc, "flocking", design)
    for field in ("states", "inputs", "requested_inputs", "dense_states", "saturation"):
        np.testing.assert_array_equal(getattr(hooked, field), getattr(bare, field),
                                      err_msg=field)
    assert hooked.fallbacks == bare.fallbacks and hooked.statuses == bare.statuses


def test_the_plain_path_records_what_step_records_with_the_supervisor(outage, monkeypatch):
    """(e) ``step_inputs`` (the loop's plain path) against ``step``, supervisor on: every
    array and record the same, the overrides included."""
    design = build_design(outage)

    def run(plain: bool):
        prepared = _prepare(outage, "flocking", design)
        controller = prepared.controller
        used = []
        # patched where it is defined: the loop takes the plain path only when the class
        # that defines step defines step_inputs too
        owner = next(c for c in type(controller).__mro__ if "step_inputs" in vars(c))
        original = owner.step_inputs

        def counted(self, *args):
            used.append(1)
            return original(self, *args)

        monkeypatch.setattr(owner, "step_inputs", counted)
        if not plain:  # the loop's rule: a step set on the instance is called as such
            controller.step = controller.step
        result = simulate(prepared.plant, controller, prepared.profile,
                          duration=prepared.duration, initial_state=prepared.state,
                          warn=False, **prepared.options)
        monkeypatch.setattr(owner, "step_inputs", original)
        return result, len(used)

    fast, used_fast = run(True)
    slow, used_slow = run(False)
    assert used_fast == fast.n_samples and used_slow == 0
    assert SUPERVISOR_BRAKING in fast.fallbacks
    for field in dataclasses.fields(fast):
        if field.name in ("solve_times", "meta"):
            continue
        value = getattr(fast, field.name)
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(value, getattr(slow, field.name), err_msg=field.name)
        else:
            assert value == getattr(slow, field.name), field.name


def test_the_received_state_follows_the_network_blocking_rule(outage) -> None:
    """The supervisor's newest received sample at every step equals what the network
    simulator delivers over the same window and delay (a message in transit when the
    window opens is lost; one sent when it closes arrives τ later)."""
    sup = supervisor_of(outage, outage.controllers["flocking"], 1.0)
    net = Network(outage.network, make_graph("bidirectional", 4, pinned="none"))
    times = np.arange(0.0, 200.0, 1.0)
    for t in times:
        net.send_all(float(t), [20.0, 20.0, 20.0, 20.0])
        for follower in (1, 2, 3):
            held = net.receive(float(t), follower).get(follower - 1)
            newest = max((s for s in times if s <= sup.received(follower, float(t)) + 1e-9),
                         default=None)
            got = None if held is None else held.t_sent
            assert got == (newest if newest is not None and newest >= 0.0 else None), t
    assert sup.received(2, 115.0) == 99.5 and sup.received(2, 130.4) == 99.5
    assert sup.received(2, 131.0) == 130.5


def test_the_brake_now_margins_of_the_supervised_run_stay_positive(runs) -> None:
    """Along the supervised run every step keeps the supervisor's rule: ran on with a
    non-negative run-on margin, or braked at full with a non-negative brake-now margin."""
    design, result = runs[True]
    margins, braking = braking_margins(design.family("flocking"), result)
    assert margins.shape == (3, result.n_samples)
    assert margins.min() >= 0.0
    steps = {k for k, f in enumerate(result.fallbacks) if f == SUPERVISOR_BRAKING}
    assert steps <= set(np.flatnonzero(braking.any(axis=0)))


def test_a_power_limited_leader_is_assumed_at_its_strongest() -> None:
    """b_L is the envelope's braking at low speed; b_f the follower's at its own speed."""
    from trainctl.models import Coupler, TractionEnvelope, Train, Vehicle

    unit = Vehicle(mass=1e6, length=100.0, a0=0.0, a1=0.0, a2=0.0,
                   envelope=TractionEnvelope(max_braking=8e5, max_braking_power=8e6))
    pair = Train(vehicles=(unit, unit), couplers=(Coupler(stiffness=0.0, spacing=300.0,
                                                          virtual=True),))
    sup = BrakingSupervisor(pair, interval=1.0, margin=0.0)
    assert sup.leader_deceleration(0) == pytest.approx(0.8)   # 800 kN below 10 m/s
    assert sup.follower_deceleration(1, 20.0) == pytest.approx(0.4)  # 8 MW / 20 m/s
    fixed = BrakingSupervisor(pair, interval=1.0, margin=0.0, leader_braking=0.3)
    assert fixed.leader_deceleration(0) == 0.3


def test_a_faulty_step_keeps_its_fault_and_still_brakes() -> None:
    """A law that raises gives the feedforward fallback; the supervisor brakes on top."""
    sc = load_scenario(str(OUTAGE))
    design = build_design(sc)
    controller = make_controller(sc, "flocking", design)
    assert isinstance(controller, FlockingController)

    class Broken:
        """The law, its force raising."""

        def __init__(self, law):
            self.law = law

        def __getattr__(self, name):
            return getattr(self.law, name)

        def force(self, *args):
            raise RuntimeError("lost the law")

    controller.law = Broken(controller.law)
    state = np.array([V, V + 3.0, V, V, -300.0, 0.0, 0.0, 0.0])  # follower 1: 200 m, +3 m/s
    record = controller.step(0.0, _measurement(state), _preview(V, 0.0))
    assert record.status == "error" and record.fallback == "feedforward"
    assert "lost the law" in str(record.info["reason"])
    assert record.info["supervisor"] == [1]
    assert record.inputs[1] == controller.supervisor.full_braking(state[:4])[1]
