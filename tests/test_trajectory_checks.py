"""Checks a simulation decides (issue 11): judged again on the simulated trajectory.

The potential family's linearisation range and the flocking family's
connectivity and collision checks are design checks that a simulation can
settle; :func:`trainctl.design.review.with_simulations` replaces them after
``[simulation]``. These tests compute the trajectory quantities by a second
route (gaps by integrating the speeds, offsets by the linear loop's
matrix exponential) and compare.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from trainctl.cli.main import main
from trainctl.controllers.potential.checks import final_offset
from trainctl.design import build_design
from trainctl.design.review import review_design
from trainctl.run.analysis import run_scenario
from trainctl.scenario import load_scenario

ANALYSES = Path(__file__).resolve().parent.parent / "analyses"


@pytest.fixture(scope="module")
def splitting_run():
    """heavy-haul-flocking with the outer gaps opening at 4 m/s from 590 m: the range is left."""
    sc = (load_scenario("heavy-haul-flocking")
          .replace("simulation.initial_speed_errors", [2.0, -2.0, 2.0, -2.0])
          .replace("simulation.settle_time", 200.0)
          .replace("simulation.duration", 300.0)
          .replace("simulation.strategies", ["flocking"]))
    return sc, run_scenario(sc)


def _integrated_gaps(sc, result) -> np.ndarray:
    """Gaps [m] from the initial gaps and ∫(v_k − v_{k+1}) dt on the dense grid (trapezoid)."""
    from trainctl.controllers.flocking.checks import initial_errors

    design = build_design(sc).family("flocking")
    _, z0, _ = initial_errors(design)
    start = design.law.gaps(z0)
    t = np.asarray(result.dense_time)
    v = np.asarray(result.dense_velocities)
    closing = v[:-1] - v[1:]
    steps = 0.5 * (closing[:, 1:] + closing[:, :-1]) * np.diff(t)[None, :]
    return start[:, None] + np.hstack([np.zeros((len(start), 1)), np.cumsum(steps, axis=1)])


def test_connectivity_follows_the_trajectory(splitting_run) -> None:
    """Within range at t = 0 (design: warn), a gap leaves it in the simulation (run: fail)."""
    sc, run = splitting_run
    design_time = {c.name: c for c in review_design(sc, run.design).checks}
    assert design_time["flocking_connectivity"].status == "warn"
    check = run.review.check("flocking_connectivity")
    assert check.status == "fail"
    gaps = _integrated_gaps(sc, run.simulations["flocking"])
    r = build_design(sc).family("flocking").law.potential.r
    assert gaps.max() > r
    assert check.value == pytest.approx(gaps.max(), abs=0.5)
    assert check.threshold == pytest.approx(r)
    assert "the formation splits" in check.message
    # the order of the review is kept: the replaced check sits where the design put it
    assert run.review.names == tuple(design_time)


def test_collision_reports_the_simulated_smallest_gap(splitting_run) -> None:
    """The certificate's verdict stands; the smallest simulated gap joins it (second route)."""
    sc, run = splitting_run
    check = run.review.check("flocking_collision")
    gaps = _integrated_gaps(sc, run.simulations["flocking"])
    assert check.status == "pass"
    assert check.details["simulated_min_gap_m"] == pytest.approx(gaps.min(), abs=0.5)
    assert 0.0 < gaps.min() < gaps[:, 0].min()  # the compressed gap closed further


def test_unsimulated_run_does_not_compare_what_the_simulation_decides(splitting_run) -> None:
    """--no-simulate: the declared post-simulation verdicts are listed, not compared."""
    sc, _ = splitting_run
    run = run_scenario(load_scenario("heavy-haul-flocking"), simulate=False)
    assert run.review.check("flocking_connectivity").status == "warn"  # energy argument only
    assert set(run.unsimulated_checks) == {"flocking_collision", "flocking_connectivity",
                                           "flocking_braking_distance"}
    assert run.unexpected_checks() == {}
    assert "not compared without the simulation" in run.format_text()
    assert run.to_dict()["unsimulated_checks"] == list(run.unsimulated_checks)


def test_builtin_flocking_connectivity_passes_on_its_trajectory(capsys) -> None:
    """heavy-haul-flocking: [expected] declares the post-simulation verdicts and they match.

    Connectivity passes on the trajectory; the one reason --strict exits 1 is the
    relative braking distance, which the ±2 m/s start breaks (no supervisor).
    """
    assert main(["analyse", "heavy-haul-flocking", "--strict"]) == 1
    out = capsys.readouterr().out
    assert "every gap within the range along the simulated flocking run" in out
    assert "declared statuses match" in out
    assert "--strict exits 1 for:\n  check     flocking_braking_distance:" in out
    assert "1 reason --strict exits 1" in out


def test_linearisation_is_judged_on_the_simulated_speeds() -> None:
    """crh2-potential-unpinned: the largest |v̂| of the run, above the 2.5 m/s start."""
    sc = load_scenario("crh2-potential-unpinned")
    run = run_scenario(sc)
    res = run.simulations["consensus"]
    dev = np.abs(np.asarray(res.dense_velocities) - np.asarray(res.dense_reference_speed))
    check = run.review.check("potential_linearisation")
    assert check.value == pytest.approx(float(dev.max()), rel=1e-12)
    assert check.value > 2.5  # the couplers swing the cars past their start
    assert check.details["judged"] == "trajectory"
    assert check.status == "pass"
    # the unpinned train keeps a constant offset over the last 20 s of the run
    t = np.asarray(res.dense_time)
    ref = np.concatenate([[0.0], np.cumsum(0.5 * (res.dense_reference_speed[1:]
                                                   + res.dense_reference_speed[:-1])
                                            * np.diff(t))])
    offset = np.asarray(res.dense_states)[-1] - ref
    late = offset[t >= t[-1] - 20.0]
    assert np.ptp(late) < 1e-3 * abs(late.mean())
    assert late.mean() > 0.5  # ahead of the reference: the surplus speed was never taken back
    assert run.review.check("potential_position").status == "fail"


def test_final_offset_against_the_matrix_exponential() -> None:
    """p(∞) of an unpinned loop equals the last entry of expm(A t) ξ0 at large t."""
    sc = (load_scenario("crh2-potential-unpinned")
          .replace("simulation.initial_speed_errors", [1.0, 0.5, 0.8, 0.2, 0.0, -0.3, 0.4, 0.9]))
    design = build_design(sc).family("potential")
    xi0 = design.initial_errors
    late = scipy.linalg.expm(design.A_cl * 60.0) @ xi0
    assert np.abs(late[:-1]).max() < 1e-9  # speeds and spacings have converged
    assert final_offset(design.A_cl, xi0) == pytest.approx(late[-1], rel=1e-8)
    pinned = build_design(load_scenario("crh2-potential")).family("potential")
    assert final_offset(pinned.A_cl, pinned.initial_errors) == 0.0


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
@pytest.mark.parametrize(("name", "code"), [
    ("crh2-potential", 0), ("crh2-potential-unpinned", 1), ("heavy-haul-flocking-collision", 1),
    ("heavy-haul-flocking-outage", 0),
])
def test_strict_exit_codes_of_the_seed_001_002_scenarios(name: str, code: int, capsys) -> None:
    """Built-ins exit 0 under --strict (simulated), the rejected variants 1; [expected] matches."""
    assert main(["analyse", name, "--strict"]) == code
    out = capsys.readouterr().out
    assert "declared statuses match" in out
