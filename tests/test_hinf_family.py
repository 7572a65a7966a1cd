"""Tests of the hinf family (seed 003's distributed robust H∞ cooperative law).

Law and linear loops against the controller's own step, delays and outages
through the simulation's network, the checks against simulations, seeds,
the report and the command line.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import control as ct
import numpy as np
import pytest

from tests.test_cli import assert_refused, run_module
from trainctl.analysis.connectivity import joint_connectivity
from trainctl.analysis.delay import discrete_delay_loop
from trainctl.controllers.base import Measurement, ReferencePreview
from trainctl.design import build_design
from trainctl.models.dynamics import train_rhs
from trainctl.models.network import REFERENCE, Received
from trainctl.registry import get_family
from trainctl.run.analysis import simulate_strategy
from trainctl.scenario import Scenario, builtin_scenario_text, load_scenario
from trainctl.sim.results import SimulationResult

FAMILY = get_family("hinf")


def _scenario(controller: dict[str, Any] | None = None, *,
              simulation: dict[str, Any] | None = None,
              network: dict[str, Any] | None = None,
              communication: dict[str, Any] | None = None,
              vehicles: int | None = None) -> Scenario:
    """heavy-haul-hinf (4 locomotive subsystems of 5184 t) with family = "hinf"."""
    sc = load_scenario("heavy-haul-hinf").replace(
        "controller", {"family": "hinf", **(controller or {})})
    if vehicles is not None:
        sc = sc.replace("train.vehicle[0].count", vehicles)
    if communication is not None:
        sc = sc.replace("communication", communication)
    if network is not None:
        sc = sc.replace("network", network)
    if simulation is not None:
        sim = {"duration": 60.0, "strategies": ["distributed"], "settle_time": 30.0,
               "reference": {"times": [0.0], "speeds_kmh": [70.0]}, "plant_saturation": False,
               **simulation}
        sc = sc.replace("simulation", sim)
    return sc


def _checks(sc: Scenario) -> dict[str, Any]:
    design = build_design(sc).family("hinf")
    return {c.name: c for c in FAMILY.checks(design)}


def _commands(sc: Scenario, result: SimulationResult) -> np.ndarray:
    """Each vehicle's applied specific force minus its own resistance at its speed [m/s²], (n, N).

    The resistance is the Davis law per unit mass from the train's
    coefficients at the simulated sample speeds (the speeds the controller
    measured: no measurement noise in these runs).
    """
    train = sc.train
    v = np.asarray(result.velocities)[:, :-1]
    a0, a1, a2 = (c[:, None] for c in train.davis)
    return np.asarray(result.inputs) / train.mass[:, None] - (a0 + a1 * v + a2 * v * v)


def _errors(result: SimulationResult) -> tuple[np.ndarray, np.ndarray]:
    """Speed errors v − v_d [m/s] at the samples, and the sample times [s]."""
    err = np.asarray(result.velocities) - np.asarray(result.reference_speed)[None, :]
    return err, np.asarray(result.time)


# -- the law and its linear loops ---------------------------------------------------------------


def test_law_by_hand_on_three_vehicles() -> None:
    """a_i = v̇_d − κ_p b_i (v_i − v_d) − κ_c Σ_j a_ij (v_i − v_j), on a bidirectional chain."""
    sc = _scenario({"kappa_p_per_s": 0.2, "kappa_c_per_s": 0.05, "input_bounds": False},
                   vehicles=3)
    design = build_design(sc).family("hinf")
    ctl = FAMILY.make(design, "distributed")
    ctl.reset()
    v = np.array([19.0, 19.6, 19.3])
    preview = ReferencePreview(times=np.zeros(1), speed=np.full(1, 19.5),
                               acceleration=np.full(1, 0.01))
    u = ctl.step(0.0, Measurement(outputs=v), preview).inputs
    expected = 0.01 - 0.2 * (v - 19.5) - 0.05 * np.array(
        [v[0] - v[1], (v[1] - v[0]) + (v[1] - v[2]), v[2] - v[1]])
    assert np.allclose(design.law.commands(0.01, v - 19.5, v[:, None] - v[None, :]), expected,
                       rtol=0, atol=1e-15)
    assert np.allclose(u, sc.train.mass * expected + design.law.feedforward(v), rtol=1e-12)


def _controller_rhs(design: Any, xi: np.ndarray) -> np.ndarray:
    """x̂' of the nonlinear train under the controller's own step (no network)."""
    train, n = design.scenario.train, design.law.n
    v_r = float(design.model.settings.speed)
    controller = FAMILY.make(design, "distributed")
    controller.reset()
    preview = ReferencePreview(times=np.zeros(1), speed=np.full(1, v_r),
                               acceleration=np.zeros(1))
    u = controller.step(0.0, Measurement(outputs=v_r + xi[:n]), preview).inputs
    state = np.concatenate([v_r + xi[:n], xi[n:], [0.0]])
    return np.asarray(train_rhs(train, state, u)[:2 * n - 1])


@pytest.mark.parametrize(("name", "communication"), [
    ("heavy-haul-hinf", None),
    ("crh2-dmpc-well-sampled", {"topology": "predecessor", "pinned": "head"}),
])
def test_linear_closed_loop_is_the_jacobian_of_the_nonlinear_one(
        name: str, communication: dict[str, Any] | None) -> None:
    """A_cl equals a central finite-difference Jacobian of plant + controller at the cruise.

    heavy-haul-hinf: four equal subsystems on the default bidirectional chain,
    all pinned; the CRH2 cars: unequal masses on a directed predecessor
    graph pinned at the head.
    """
    sc = load_scenario(name)
    settings = {"input_bounds": False, "kappa_p_per_s": 0.3, "kappa_c_per_s": 0.2}
    sc = (sc.replace("controller", {"family": "hinf", **settings})
          if sc.controllers == {} else sc.replace("controller.hinf", settings))
    if communication is not None:
        sc = sc.replace("communication", communication)
    design = build_design(sc).family("hinf")
    N = design.loops.A_cl.shape[0]
    n = design.law.n
    assert np.allclose(_controller_rhs(design, np.zeros(N)), 0.0, atol=1e-9)
    steps = np.where(np.arange(N) < n, 1e-4, 1e-7)
    J = np.empty((N, N))
    for k in range(N):
        e = np.zeros(N)
        e[k] = steps[k]
        J[:, k] = (_controller_rhs(design, e) - _controller_rhs(design, -e)) / (2 * steps[k])
    scale = np.abs(J).max(axis=0)
    assert np.allclose(J / scale, design.loops.A_cl / scale, atol=1e-6)
    # what the law adds to the plant: −(κ_p P + κ_c L) and the feedforward's slope
    graph = sc.graph()
    Lp = 0.3 * np.diag(graph.pinning) + 0.2 * graph.laplacian()
    davis, v_r = sc.train.davis, float(design.model.settings.speed)
    law_part = -Lp + np.diag(davis[1] + 2 * davis[2] * v_r)
    assert np.allclose(J[:n, :n] - design.loops.A_open[:n, :n], law_part, atol=1e-6)
    assert np.allclose(J[:n, n:], design.loops.A_open[:n, n:], rtol=1e-6)
    loop = FAMILY.closed_loop(design, "distributed")
    assert loop.dt == 0
    assert loop.input_labels == [f"w[{i}]" for i in range(n)]
    assert loop.output_labels[:n + 1] == [f"v[{i}]" for i in range(n)] + ["f[0]"]
    assert np.allclose(np.sort_complex(loop.poles()), np.sort_complex(np.linalg.eigvals(J)),
                       atol=1e-6 * np.abs(J).max())
    # a disturbance w_i [m/s²] accelerates vehicle i by w_i
    assert np.allclose(np.asarray(loop.B)[:n], np.eye(n), atol=1e-12)


@pytest.mark.parametrize("own_speed", ["delayed", "current"])
def test_delayed_part_is_what_the_step_does_with_old_data(own_speed: str) -> None:
    """∂u/∂(old data) = K and ∂u/∂(current speeds) = F₀, from the step with hand-built messages.

    Vehicle speeds v_old are measured at t = 0 and sent; at t = τ the
    speeds are v_now and every vehicle holds the data of t = 0. The law's
    split of F into F₀ (current) and K (delayed) is the one of the delay
    analysis: A₀ = A + B F₀, and B K x̂(t − τ).
    """
    sc = _scenario({"own_speed": own_speed, "input_bounds": False, "kappa_p_per_s": 0.3,
                    "kappa_c_per_s": 0.2},
                   communication={"topology": "predecessor", "pinned": "head"})
    design = build_design(sc).family("hinf")
    law, n = design.law, design.law.n
    v_r = float(design.model.settings.speed)
    links = [(i, j) for i in range(n) for j in range(n) if law.adjacency[i, j] > 0]

    def u(v_old: np.ndarray, v_now: np.ndarray) -> np.ndarray:
        ctl = FAMILY.make(design, "distributed")
        ctl.reset()
        preview = ReferencePreview(times=np.zeros(1), speed=np.full(1, v_r),
                                   acceleration=np.zeros(1))
        ctl.step(0.0, Measurement(outputs=v_old), preview)
        messages: dict[Any, Received] = {(i, j): Received(0.0, float(v_old[j]))
                                         for i, j in links}
        messages[(0, REFERENCE)] = Received(0.0, v_r)
        return ctl.step(1.5, Measurement(outputs=v_now, messages=messages), preview).inputs

    base = np.full(n, v_r)
    h = 1e-4
    d_old = np.column_stack([(u(base + h * e, base) - u(base - h * e, base)) / (2 * h)
                             for e in np.eye(n)])
    d_now = np.column_stack([(u(base, base + h * e) - u(base, base - h * e)) / (2 * h)
                             for e in np.eye(n)])
    scale = float(np.abs(d_now).max())
    assert np.allclose(d_old, law.delayed_feedback()[:, :n], atol=1e-6 * scale)
    assert np.allclose(d_now, law.undelayed_feedback(v_r)[:, :n], atol=1e-6 * scale)
    K = design.loops.K_delay
    assert np.allclose(design.loops.A0 + design.loops.B_open @ K, design.loops.A_cl)
    if own_speed == "delayed":  # the whole consensus/pinning feedback is delayed
        assert np.allclose(K[:, :n], -np.diag(law.mass) @ law.pinned_laplacian())
    else:  # only the neighbours' values: the head, pinned, hears nobody
        assert np.allclose(K[0], 0.0) and np.any(K[1:] != 0.0)


def test_a_term_never_received_is_left_out() -> None:
    """Vehicle 2 has heard vehicle 1 but neither the reference nor vehicle 3 yet."""
    sc = _scenario({"input_bounds": False, "kappa_p_per_s": 0.2, "kappa_c_per_s": 0.05},
                   vehicles=3)
    design = build_design(sc).family("hinf")
    ctl = FAMILY.make(design, "distributed")
    ctl.reset()
    v = np.array([19.0, 19.6, 19.3])
    preview = ReferencePreview(times=np.zeros(1), speed=np.full(1, 19.5),
                               acceleration=np.zeros(1))
    messages = {(1, 0): Received(0.0, 19.1)}
    rec = ctl.step(0.0, Measurement(outputs=v, messages=messages), preview)
    a = (rec.inputs - design.law.feedforward(v)) / sc.train.mass
    assert np.allclose(a, [0.0, -0.05 * (19.6 - 19.1), 0.0], rtol=0, atol=1e-15)
    # 3 pinnings and 4 links of the chain, one of them heard
    assert rec.info["missing_terms"] == 6


# -- simulations on the nonlinear plant ---------------------------------------------------------


def test_tracks_a_speed_step_through_an_ideal_network() -> None:
    """No delay, no noise: the train starts off a 70 km/h reference and converges on it.

    The four subsystems start with different errors (a step of the
    reference seen differently by each, which loads the couplers); after 60 s
    every error is below 2 mm/s (the slowest mode decays at κ_p = 0.1 1/s:
    e^{−6} of 0.3 m/s is 0.7 mm/s), with the traction envelope enforced. A
    zero-delay [network] repeats the run without one exactly: the messages
    carry the measured speeds unchanged.
    """
    sim = {"duration": 120.0, "initial_speed_errors": [0.3, -0.2, 0.1, 0.0],
           "plant_saturation": True}
    sc = _scenario(simulation=sim)
    networked = _scenario(simulation=sim, network={"delay_s": 0.0})
    result = simulate_strategy(sc, "distributed")
    through = simulate_strategy(networked, "distributed")
    assert through.meta["network"]["delivered"] == 1200 * 10  # 4 pinnings + 6 chain links
    err, t = _errors(result)
    assert np.abs(err[:, 0]).max() == pytest.approx(0.3)
    assert np.abs(err[:, t >= 60.0]).max() < 2e-3
    assert np.abs(err[:, t >= 100.0]).max() < 1e-4
    # vehicle 2, slow between two fast ones, asks more than its traction in the first 2 s
    saturated = np.flatnonzero(np.asarray(result.saturation).any(axis=0))
    assert 0 < saturated.size and t[saturated].max() < 2.0
    assert np.array_equal(result.inputs, through.inputs)
    assert np.array_equal(result.states, through.states)


@pytest.mark.parametrize("own_speed", ["delayed", "current"])
def test_constant_delay_uses_the_values_sent_d_samples_earlier(own_speed: str) -> None:
    """delay_s = 0.5 s = 5 samples on three subsystems: the applied commands, exactly.

    From the simulated speeds (no noise, no saturation): a_i(k) = v̇_d(k)
    − κ_p (v_i(k') − v_d(k − 5)) − κ_c Σ_j a_ij (v_i(k') − v_j(k − 5)) with
    k' = k − 5 ("delayed") or k ("current"); before the first arrival
    (k < 5) a_i = v̇_d. The reference ramps between breakpoints off the
    sample grid, so that its delayed value differs from the current one.
    """
    d = 5
    sim = {"duration": 30.0, "settle_time": 20.0, "initial_speed_errors": [0.2, -0.1, 0.0],
           "reference": {"times": [0.0, 5.05, 15.05], "speeds_kmh": [70.0, 70.0, 72.0]}}
    sc = _scenario({"input_bounds": False, "own_speed": own_speed}, simulation=sim,
                   network={"delay_s": 0.5}, vehicles=3)
    result = simulate_strategy(sc, "distributed")
    a = _commands(sc, result)
    v = np.asarray(result.velocities)[:, :-1]
    vd = np.asarray(result.reference_speed)[:-1]
    acc = np.asarray(result.reference_acceleration)[:-1]
    assert np.ptp(acc) > 0.01  # the reference moves: its delay shows
    kp, kc = 0.1, 0.1
    own = v[:, :-d] if own_speed == "delayed" else v[:, d:]
    old = v[:, :-d]
    expected = acc[d:] - kp * (own - vd[None, :-d])
    expected[0] -= kc * (own[0] - old[1])
    expected[1] -= kc * ((own[1] - old[0]) + (own[1] - old[2]))
    expected[2] -= kc * (own[2] - old[1])
    scale = np.abs(a).max()
    assert np.allclose(a[:, d:], expected, rtol=0, atol=1e-9 * scale)
    assert np.allclose(a[:, :d], acc[None, :d], rtol=0, atol=1e-9 * scale)
    # and not the undelayed law
    undelayed = acc[d:] - kp * (v[:, d:] - vd[None, d:])
    assert np.abs(a[:, d:] - undelayed).max() > 1e-3


@pytest.mark.parametrize("own_speed", ["delayed", "current"])
def test_constant_delay_with_hand_built_messages(own_speed: str) -> None:
    """The step with messages sent d = 3 samples earlier: the differences use those values.

    Random speeds every sample; the messages hold each sender's speed and
    the reference's of three samples before, stamped with that time. The
    vehicle's own speed is its record of that time ("delayed") or now.
    """
    rng = np.random.default_rng(12)
    d, T, steps = 3, 0.1, 12
    sc = _scenario({"input_bounds": False, "own_speed": own_speed, "kappa_p_per_s": 0.2,
                    "kappa_c_per_s": 0.05}, vehicles=3)
    design = build_design(sc).family("hinf")
    law = design.law
    ctl = FAMILY.make(design, "distributed")
    ctl.reset()
    speeds = 19.4 + 0.3 * rng.random((steps, 3))
    ref = 19.5 + 0.1 * rng.random(steps)
    for k in range(steps):
        t = k * T
        preview = ReferencePreview(times=np.full(1, t), speed=np.full(1, ref[k]),
                                   acceleration=np.full(1, 0.002))
        messages: dict[Any, Received] | None = None
        if k >= d:
            sent = (k - d) * T
            messages = {(i, REFERENCE): Received(sent, float(ref[k - d])) for i in range(3)}
            messages.update({(i, j): Received(sent, float(speeds[k - d, j]))
                             for i in range(3) for j in range(3) if law.adjacency[i, j] > 0})
        else:
            messages = {}
        rec = ctl.step(t, Measurement(outputs=speeds[k], messages=messages), preview)
        a = (rec.inputs - law.feedforward(speeds[k])) / sc.train.mass
        if k < d:
            assert np.allclose(a, 0.002, rtol=0, atol=1e-15)
            continue
        own = speeds[k - d] if own_speed == "delayed" else speeds[k]
        old = speeds[k - d]
        expected = 0.002 - 0.2 * (own - ref[k - d]) - 0.05 * np.array(
            [own[0] - old[1], (own[1] - old[0]) + (own[1] - old[2]), own[2] - old[1]])
        assert np.allclose(a, expected, rtol=0, atol=1e-14)
        assert rec.info["oldest_data_age"] == pytest.approx(d * T)


@pytest.mark.parametrize("own_speed", ["delayed", "current"])
def test_interruption_recovers_only_when_jointly_connected(own_speed: str) -> None:
    """Every link cut from 10 s while the reference ramps 70 → 72 km/h over [20, 30] s.

    Cut over [10, 40): joint connectivity says recovered, the check passes,
    and every error is below 2 mm/s after 100 s. Cut to the end of the run
    (120 s): not recovered, the check fails, and the errors stay over
    0.1 m/s (held data: "current" holds the old reference speed, "delayed"
    a frozen correction).
    """
    sim = {"duration": 120.0, "initial_speed_errors": [0.3, -0.2, 0.1, 0.0],
           "reference": {"times": [0.0, 20.0, 30.0], "speeds_kmh": [70.0, 70.0, 72.0]}}
    late: dict[float, float] = {}
    for end in (40.0, 120.0):
        sc = _scenario({"own_speed": own_speed}, simulation=sim,
                       network={"interruption": {"start": 10.0, "end": end}})
        windows = joint_connectivity(sc.graph(), sc.network.interruptions, 120.0)
        assert windows[0].cut_off == (0, 1, 2, 3)
        assert windows[0].recovered == (end < 120.0)
        check = _checks(sc)["hinf_connectivity"]
        assert check.status == ("pass" if end < 120.0 else "fail"), check.message
        assert "vehicles 1, 2, 3 and 4" in check.message
        result = simulate_strategy(sc, "distributed")
        assert result.meta["network"]["blocked"] > 0
        err, t = _errors(result)
        late[end] = float(np.abs(err[:, t >= 100.0]).max())
    assert late[40.0] < 2e-3
    assert late[120.0] > 0.1


def test_connectivity_check_on_a_partial_cut() -> None:
    """Predecessor chain pinned at the head: cutting [1, 0] cuts off vehicles 2–4 (1-based)."""
    communication = {"topology": "predecessor", "pinned": "head"}
    sim = {"duration": 60.0}
    ok = _scenario(communication=communication, simulation=sim, network={
        "interruption": {"start": 10.0, "end": 20.0, "links": [[1, 0]]}})
    check = _checks(ok)["hinf_connectivity"]
    assert check.status == "pass"
    assert "vehicles 2, 3 and 4, reached again from 20 s" in check.message
    lasting = ok.replace("network", {"interruption": {"start": 10.0, "end": 80.0,
                                                      "links": [[1, 0]]}})
    check = _checks(lasting)["hinf_connectivity"]
    assert check.status == "fail"
    assert "vehicles 2, 3 and 4" in check.message and "60 s" in check.message
    # a cut link another path replaces cuts nobody off: all pinned, bidirectional
    spare = _scenario(simulation=sim, network={
        "interruption": {"start": 10.0, "end": 80.0, "links": [[1, 0]]}})
    assert _checks(spare)["hinf_connectivity"].status == "pass"


def test_same_seed_same_run() -> None:
    """Random delays, losses, noise, an outage and measurement noise: a seed repeats the run."""
    network = {"delay_range_s": [0.0, 0.3], "loss_probability": 0.2,
               "communication_noise_std": 0.01, "reference_noise_std": 0.02,
               "interruption": {"start": 10.0, "end": 15.0}}
    sim = {"duration": 30.0, "settle_time": 20.0, "initial_speed_error": -0.2,
           "measurement_noise": 0.01}
    sc = _scenario(simulation=sim, network=network)
    first, second = (simulate_strategy(sc, "distributed") for _ in range(2))
    assert np.array_equal(first.inputs, second.inputs)
    assert np.array_equal(first.states, second.states)
    assert first.meta["network"] == second.meta["network"]
    assert first.meta["network"]["lost"] > 0 and first.meta["network"]["blocked"] > 0
    other = simulate_strategy(sc.replace("seed", 4), "distributed")
    assert not np.array_equal(first.inputs, other.inputs)


# -- the checks ---------------------------------------------------------------------------------


def test_closed_loop_check_and_the_spanning_tree() -> None:
    """Default gains: Hurwitz, slowest mode −κ_p; nothing pinned: fails, naming the vehicles."""
    checks = _checks(_scenario())
    assert checks["hinf_closed_loop"].status == "pass"
    assert checks["hinf_closed_loop"].value == pytest.approx(-0.1, rel=1e-9)
    unpinned = _scenario(communication={"pinned": "none"})
    check = _checks(unpinned)["hinf_closed_loop"]
    assert check.status == "fail"
    assert "no spanning tree rooted at the reference" in check.message
    assert "vehicles 1, 2, 3 and 4" in check.message
    assert _checks(unpinned)["hinf_connectivity"].status == "fail"


def _gsmr_margin() -> float:
    return float(build_design(_scenario()).family("hinf").delay.margin)


@pytest.mark.parametrize(("factor", "status", "stable"), [(0.9, "pass", True),
                                                          (1.0, "fail", None),
                                                          (1.1, "fail", False)])
def test_delay_margin_check_around_the_margin(factor: float, status: str,
                                              stable: bool | None) -> None:
    """heavy-haul-hinf, κ_p = κ_c = 0.1 1/s: margin ≈ 0.57 s; the check turns at it.

    The sampled delay loop (the plant's exact ZOH at τ/50, the delayed
    feedback K buffered 50 samples) decays at 0.9 × the margin and grows at
    1.1 ×. The first-order consensus bound π/(2 λ_max(κ(I + L))) ≈ 3.56 s,
    six times as much, is in the message.
    """
    margin = _gsmr_margin()
    assert 0.5 < margin < 0.65
    worst = factor * margin
    sc = _scenario(network={"delay_range_s": [0.0, worst]})
    design = build_design(sc).family("hinf")
    check = {c.name: c for c in FAMILY.checks(design)}["hinf_delay_margin"]
    assert check.status == status, check.message
    assert check.value == pytest.approx(margin)
    assert check.threshold == pytest.approx(worst)
    assert design.delay.agree
    path = np.diag([1.0, 2.0, 2.0, 1.0]) - np.diag(np.ones(3), 1) - np.diag(np.ones(3), -1)
    bound = math.pi / (2 * 0.1 * np.linalg.eigvalsh(np.eye(4) + path).max())
    assert check.details["consensus_bound"] == pytest.approx(bound)
    assert f"{bound:.4g} s" in check.message
    assert "coupler modes make the full margin smaller" in check.message
    if stable is None:
        return
    loops, d = design.loops, 50
    dt = worst / d
    sysd = ct.c2d(ct.ss(loops.A0, loops.B_open, np.eye(loops.A0.shape[0]), 0), dt, method="zoh")
    K = loops.K_delay
    loop = discrete_delay_loop(sysd.A, sysd.B, np.zeros_like(K), K, d, dt)
    A = np.asarray(loop.A)
    assert (np.abs(np.linalg.eigvals(A)).max() < 1.0) == stable
    x = np.zeros(loop.nstates)
    x[0] = 1.0  # the head 1 m/s off
    steps = int(round(300.0 / dt))
    early = late = 0.0
    for k in range(steps):
        x = A @ x
        if k < steps // 2:
            early = max(early, float(np.abs(x[:4]).max()))
        else:
            late = max(late, float(np.abs(x[:4]).max()))
    assert (late < early) == stable


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_delay_margin_confirmed_on_the_nonlinear_plant() -> None:
    """T_c = 0.01 s, delay_s = 0.52 s (0.91 × the margin) decays, 0.63 s (1.1 ×) grows.

    The delayed data reach the law through the simulation's network; the
    coupler forces after 130 s against those of the first 20 s.
    """
    margin = _gsmr_margin()
    assert 0.52 < 0.95 * margin and 1.05 * margin < 0.63
    controller = {"input_bounds": False, "control_interval": 0.01}
    sim = {"duration": 150.0, "initial_speed_errors": [0.1, 0.0, 0.0, 0.0]}
    ratios = {}
    for tau in (0.52, 0.63):
        result = simulate_strategy(_scenario(controller, simulation=sim,
                                             network={"delay_s": tau}), "distributed")
        f, t = np.abs(np.asarray(result.coupler_forces)), np.asarray(result.time)
        ratios[tau] = f[:, t > 130.0].max() / f[:, t < 20.0].max()
    assert ratios[0.52] < 0.1 < 2.0 < ratios[0.63]


def test_delay_margin_without_network_and_with_current_own_speed() -> None:
    """No [network]: warn with the margin. own_speed = "current": the own-speed terms are
    undelayed and outweigh the delayed neighbour terms: no margin below 10 s, 2 s passes."""
    check = _checks(_scenario())["hinf_delay_margin"]
    assert check.status == "warn" and check.threshold is None
    assert 0.5 < check.value < 0.65
    current = _checks(_scenario({"own_speed": "current"},
                                network={"delay_range_s": [0.0, 2.0]}))["hinf_delay_margin"]
    assert current.status == "pass", current.message
    assert math.isinf(current.value) and "above 10 s" in current.message
    directed = _checks(_scenario(communication={"topology": "predecessor", "pinned": "head"}))
    assert "needs an undirected graph" in directed["hinf_delay_margin"].message


def test_sampling_check() -> None:
    """T = 0.1 s against the 4 rad/s coupler mode warns; 0.02 s passes."""
    assert _checks(_scenario())["hinf_sampling"].status == "warn"
    assert _checks(_scenario({"control_interval": 0.02}))["hinf_sampling"].status == "pass"


# -- report, settings and the command line ------------------------------------------------------


def test_report_data_and_page() -> None:
    """The quantity table, JSON-safe data, the family's section with its graph figure."""
    from trainctl.report import build_report_context, collect_report_data, render_report
    from trainctl.run.analysis import run_scenario

    sc = _scenario(network={"delay_range_s": [0.0, 2.0]})
    design = build_design(sc).family("hinf")
    data = FAMILY.report_data(design)
    json.dumps(data)
    rows = {r["name"]: r["value"] for r in data["rows"]}
    assert rows["Pinning gain κ_p [1/s]"] == "0.1"
    assert rows["Consensus gain κ_c [1/s]"] == "0.1"
    assert rows["Own speed in the differences"] == "delayed"
    assert rows["Network worst-case delay [s]"] == "2"
    assert float(rows["Delay margin, full loop [s]"]) == pytest.approx(design.delay.margin,
                                                                        rel=1e-3)
    assert float(rows["First-order consensus bound [s]"]) == pytest.approx(3.558, rel=1e-3)
    assert float(rows["Slowest mode, max Re λ [1/s]"]) == pytest.approx(-0.1)
    assert data["graph"]["pinning"] == [1.0, 1.0, 1.0, 1.0]
    run = run_scenario(sc, simulate=False)
    page = collect_report_data(run, scenario_text="", command="test")
    html = render_report(build_report_context(page, generated_at="2025-01-01T00:00:00Z",
                                              deterministic=True))
    assert FAMILY.title in html
    assert "Delay margin, full loop [s]" in html and "First-order consensus bound [s]" in html
    assert 'id="figure-graph-hinf"' in html


def _file(tmp_path: Path, *lines: str) -> Path:
    text = builtin_scenario_text("heavy-haul-hinf")
    path = tmp_path / "hinf.toml"
    path.write_text(text + "\n[controller]\nfamily = \"hinf\"\n" + "\n".join(lines)
                    + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(("line", "match"), [
    ("kappa_p_per_s = 0.0", "kappa_p_per_s"),
    ("kappa_c_per_s = -0.1", "kappa_c_per_s"),
    ('own_speed = "now"', "own_speed"),
    ("control_interval = 0.0", "control_interval"),
    ("kappa_p = 0.1", "kappa_p"),
    ('input_bounds = "yes"', "input_bounds"),
])
def test_bad_settings_exit_2(tmp_path: Path, line: str, match: str,
                             capsys: pytest.CaptureFixture[str]) -> None:
    """A wrong [controller] value of the family is a clean scenario error (exit 2)."""
    assert_refused(_file(tmp_path, line), match, capsys)


def test_cli_analyse_json(tmp_path: Path) -> None:
    """`trainctl analyse FILE --json`: the four checks with their numbers, the frequency loop."""
    path = _file(tmp_path, "", "[network]", "delay_range_s = [0.0, 2.0]")
    result = run_module("analyse", str(path), "--json", "--no-simulate")
    assert result.returncode == 0, result.stderr
    out = json.loads(result.stdout)
    checks = {c["name"]: c for c in out["checks"]}
    assert checks["hinf_closed_loop"]["status"] == "pass"
    assert checks["hinf_sampling"]["status"] == "warn"
    margin = checks["hinf_delay_margin"]
    assert margin["status"] == "fail" and margin["threshold"] == 2.0
    assert 0.5 < margin["value"] < 0.65
    assert checks["hinf_connectivity"]["status"] == "pass"
    assert "string_stability" in checks
    assert "distributed" in out["frequency"]
