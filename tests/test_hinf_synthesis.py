"""The hinf family's H∞ gains: one loop for synthesis and law, the hinf_gamma check, settings.

The family's own linear loop (built from its law: feedforward slope, pinning
and consensus, the F₀/K split) against the affine consensus loop the
synthesis runs on; the synthesised gains in the law and the controller; the
certified γ against norms computed without the LMI, on disturbance columns
built here from the family's law (delay-free and through Padé loops); the
verdict of hinf_gamma against the scaling; bad settings through the command
line. Searches are kept small (a 2 × 2 grid, a few refinement solves).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import control as ct
import numpy as np
import pytest

from tests.test_cli import assert_refused
from trainctl.analysis.delay import pade_loop
from trainctl.analysis.delay_lmi import DelayHinfProblem, delay_hinf_gamma
from trainctl.analysis.hinf import hinf_norm
from trainctl.controllers.hinf.synthesis import consensus_loop
from trainctl.design import build_design
from trainctl.registry import get_family
from trainctl.scenario import Scenario, builtin_scenario_text, load_scenario

FAMILY = get_family("hinf")

SMALL = {"synthesis_grid": 2, "synthesis_evaluations": 4}
"""A search small enough for a test: 4 grid points and 4 Nelder–Mead solves."""


def _scenario(controller: dict[str, Any] | None = None, *,
              communication: dict[str, Any] | None = None,
              linearisation: str | None = None) -> Scenario:
    """heavy-haul-hinf (4 locomotive subsystems of 5184 t) with family = "hinf"."""
    sc = load_scenario("heavy-haul-hinf").replace(
        "controller", {"family": "hinf", **(controller or {})})
    if communication is not None:
        sc = sc.replace("communication", communication)
    if linearisation is not None:
        sc = sc.replace("model.linearisation", linearisation)
    return sc


def _design(controller: dict[str, Any] | None = None, **kwargs: Any) -> Any:
    return build_design(_scenario(controller, **kwargs)).family("hinf")


def _gamma_check(design: Any) -> Any:
    return next(c for c in FAMILY.checks(design) if c.name == "hinf_gamma")


def _channels(design: Any) -> tuple[np.ndarray, list[str]]:
    """The scaled disturbance columns [state derivative per unit], built from the family's law.

    Force on vehicle i [m/s²]: the plant's input column of i times m_i (the
    family's ``w[i]``); noise on the reference vehicle i receives: κ_p b_i
    times that column; noise on j's speed as i receives it: κ_c a_ij times
    it. Each times its scale from the settings.
    """
    law, s = design.law, design.settings
    unit = design.loops.B_open * law.mass[None, :]
    cols, groups = [], []
    for i in range(law.n):
        cols.append(unit[:, i] * s.force_scale)
        groups.append("force")
    for i in range(law.n):
        if law.pinning[i] > 0:
            cols.append(unit[:, i] * law.kappa_p * law.pinning[i] * s.noise_scale)
            groups.append("reference")
    for i in range(law.n):
        for j in range(law.n):
            if law.adjacency[i, j] > 0:
                cols.append(unit[:, i] * law.kappa_c * law.adjacency[i, j] * s.noise_scale)
                groups.append("link")
    return np.column_stack(cols), groups


def _speed_rows(design: Any) -> np.ndarray:
    """The tracking output in units of the output scale: the speed rows of the family's loop."""
    n = design.law.n
    return np.eye(n, design.loops.A_cl.shape[0]) / design.settings.output_scale


# -- one loop -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("own_speed", "communication", "linearisation"), [
    ("delayed", None, None),
    ("current", None, None),
    ("delayed", {"topology": "predecessor", "pinned": "head"}, None),
    ("current", {"topology": "predecessor", "pinned": "head"}, "book"),
])
def test_family_loop_is_the_consensus_loop(own_speed: str, communication: dict[str, Any] | None,
                                           linearisation: str | None) -> None:
    """closed_loop()'s A and force columns, and the delay split, equal consensus_loop's."""
    design = _design({"own_speed": own_speed, "kappa_p_per_s": 0.07, "kappa_c_per_s": 0.13},
                     communication=communication, linearisation=linearisation)
    kp, kc = design.law.kappa_p, design.law.kappa_c
    family_loop = FAMILY.closed_loop(design, "distributed")
    loop = design.consensus
    ours = loop.system(kp, kc)
    A = np.asarray(family_loop.A)
    assert np.allclose(np.asarray(ours.A), A, rtol=1e-12, atol=1e-15)
    force = loop.columns("force")
    assert np.allclose(np.asarray(ours.B)[:, force], np.asarray(family_loop.B),
                       rtol=1e-12, atol=1e-18)
    # the part a delay acts on: the family's A₀ and B K against the consensus loop's split
    A_now, A_delayed = loop.delay_matrices(kp, kc)
    assert np.allclose(A_now, design.loops.A0, rtol=1e-12, atol=1e-15)
    assert np.allclose(A_delayed, design.loops.B_open @ design.loops.K_delay,
                       rtol=1e-12, atol=1e-15)
    # the resistance damping is what the local feedback removes: without it the loops differ
    sc = design.scenario
    plain = consensus_loop(design.model, sc.graph(), own_speed=own_speed).system(kp, kc)
    n = design.law.n
    gap = np.diag(np.asarray(plain.A) - A)[:n]
    c = design.law.davis[1] + 2.0 * design.law.davis[2] * design.model.settings.speed
    assert np.all(gap < 0)
    if linearisation is None:   # Jacobian design model: the gap is exactly the damping
        assert np.allclose(-gap, c, rtol=1e-9)


def test_delay_problem_with_an_undelayed_parameter_term() -> None:
    """A_terms moves a parameter's part to current data: equal to the fixed problem."""
    prob = DelayHinfProblem([[-1.0]], [[0.0]], [[1.0]], [[1.0]], None, 0.5,
                            A_terms={"k": [[-1.0]]}, A_d_terms={"k": [[-0.5]]})
    for k in (0.5, 2.0):
        fixed = delay_hinf_gamma([[-1.0 - k]], [[-0.5 * k]], [[1.0]], [[1.0]], None, 0.5)
        assert prob.solve(k=k).gamma == pytest.approx(fixed.gamma, rel=1e-4)
        assert prob.solve(k=k).gamma >= 1.0 / (1.0 + 1.5 * k) * (1 - 1e-9)


# -- synthesis ----------------------------------------------------------------------------------


def test_synthesised_gains_are_the_laws_and_bound_the_norm() -> None:
    """synthesise = true: the law, the loops and the controller use the synthesis's gains."""
    settings = {"synthesise": True, **SMALL, "kappa_p_bounds_per_s": [0.02, 0.15],
                "kappa_c_bounds_per_s": [0.0, 0.1], "force_scale_m_s2": 0.05,
                "noise_scale_m_s": 0.5, "output_scale_m_s": 2.0}
    design = _design(settings)
    syn = design.synthesis
    assert syn is not None and design.gains_source == "synthesised"
    assert design.gamma is syn and math.isfinite(syn.gamma)
    assert (design.law.kappa_p, design.law.kappa_c) == (syn.kp, syn.kc)
    assert 0.02 <= syn.kp <= 0.15 and 0.0 <= syn.kc <= 0.1
    assert (syn.kp, syn.kc) != (design.settings.kappa_p, design.settings.kappa_c)
    assert FAMILY.make(design, "distributed").law is design.law
    assert np.allclose(design.loops.A_cl, design.loops.A_open
                       + design.loops.B_open @ design.law.feedback(design.model.settings.speed))
    assert syn.gamma <= float(np.min(syn.gamma_grid)) * (1 + 1e-12)
    # the family's closed loop, every channel built from its law and scaled: norm ≤ certified γ
    Bw, groups = _channels(design)
    C = _speed_rows(design)
    A = design.loops.A_cl
    norm = hinf_norm(ct.ss(A, Bw, C, 0))
    assert norm.agree
    assert norm.norm <= syn.gamma * (1 + 1e-9)
    assert syn.gamma <= norm.norm * (1 + 1e-4)           # the bounded-real lemma is exact
    for group, cert in syn.group_certificates.items():
        cols = [j for j, g in enumerate(groups) if g == group]
        assert hinf_norm(ct.ss(A, Bw[:, cols], C, 0)).norm <= cert.gamma * (1 + 1e-9) + 1e-12
    # the family's force input w[i] [m/s²], scaled: the force group's γ
    loop = FAMILY.closed_loop(design, "distributed")
    v = [k for k, name in enumerate(loop.output_labels) if name.startswith("v[")]
    force = ct.ss(loop.A, np.asarray(loop.B) * 0.05, np.asarray(loop.C)[v] / 2.0, 0)
    assert hinf_norm(force).norm <= syn.group_certificates["force"].gamma * (1 + 1e-9)


def test_synthesis_that_certifies_nothing_keeps_the_given_gains() -> None:
    """Bounds whose loops no delay certificate covers: given gains, recorded, hinf_gamma says so."""
    design = _design({"synthesise": True, "synthesis_grid": 1, "synthesis_evaluations": 0,
                      "kappa_p_bounds_per_s": [0.8, 0.8], "kappa_c_bounds_per_s": [0.8, 0.8],
                      "delay_certificate_s": 2.0})
    assert design.synthesis is None and design.gains_source == "given (synthesis failed)"
    assert "no gains on the grid are certified" in design.synthesis_error
    assert (design.law.kappa_p, design.law.kappa_c) == (0.1, 0.1)
    check = _gamma_check(design)
    assert check.status == "fail"           # κ = 0.1 is unstable within 2 s of delay
    assert "the requested synthesis certified nothing" in check.message
    assert "unstable" in check.message and check.details["synthesis_error"]


# -- hinf_gamma ---------------------------------------------------------------------------------


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_gamma_verdict_flips_with_the_output_scale() -> None:
    """γ scales with 1/output_scale: twice the unit-scale γ passes, half of it fails."""
    unit = _gamma_check(_design())
    g1 = unit.value
    assert unit.status == "fail" and g1 > 1
    assert unit.details["groups"]["force"] > 1 and "force channels" in unit.message
    assert "depends on the scaling" in unit.message
    # the DC floor: a common reference noise passes with gain 1 whatever the gains
    assert unit.details["groups"]["reference"] >= 1.0 - 1e-9
    assert "at DC the tracking error follows a noise common" in unit.message
    big, small = 2.0 * g1, 0.5 * g1
    passed = _gamma_check(_design({"output_scale_m_s": big}))
    failed = _gamma_check(_design({"output_scale_m_s": small}))
    assert passed.status == "pass" and failed.status == "fail"
    assert passed.value == pytest.approx(g1 / big, rel=1e-4)
    assert failed.value == pytest.approx(g1 / small, rel=1e-4)
    assert passed.details["scaling"] == {"force_m_s2": 1.0, "noise_m_s": 1.0, "output_m_s": big}
    assert passed.details["norm"] <= passed.value
    assert f"output {big:g} m/s" in passed.message
    # below the DC floor only the disagreement output gets there
    dis = _gamma_check(_design({"performance": "disagreement"}))
    assert dis.details["groups"]["reference"] < 1.0


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
@pytest.mark.parametrize(("own_speed", "kp", "kc"), [("delayed", 0.02, 0.01),
                                                      ("current", 0.1, 0.1)])
def test_delay_certificate_bounds_the_pade_loops(own_speed: str, kp: float, kc: float) -> None:
    """With delay_certificate_s, γ ≥ the norm of the family's loop through Padé delays in range."""
    design = _design({"own_speed": own_speed, "kappa_p_per_s": kp, "kappa_c_per_s": kc,
                      "delay_certificate_s": 2.0})
    check = _gamma_check(design)
    gamma = check.value
    assert math.isfinite(gamma) and check.details["delay_certificate"] == 2.0
    # every group is certified, never above all channels together (a subset of the LMI)
    assert all(v is not None and v <= gamma * (1 + 1e-12)
               for v in check.details["groups"].values())
    Bw, _ = _channels(design)
    C = _speed_rows(design)
    loops = design.loops
    free = hinf_norm(ct.ss(loops.A_cl, Bw, C, 0)).norm
    assert free <= gamma
    for tau in (0.4, 1.3, 2.0):
        loop = pade_loop(loops.A0, loops.B_open, loops.K_delay, tau, 8)
        N = loop.nstates
        B = np.zeros((N, Bw.shape[1]))
        B[:Bw.shape[0]] = Bw
        Cx = np.zeros((C.shape[0], N))
        Cx[:, :C.shape[1]] = C
        res = hinf_norm(ct.ss(loop.A, B, Cx, 0))
        assert res.stable and res.norm <= gamma * (1 + 1e-9)


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_gamma_check_for_delays_beyond_what_can_be_certified() -> None:
    """Whole law delayed at κ = 0.1: unstable within 2 s (fail), uncertified at 0.5 s (warn)."""
    unstable = _gamma_check(_design({"delay_certificate_s": 2.0}))
    assert unstable.status == "fail" and math.isinf(unstable.value)
    assert "unstable at" in unstable.message
    assert any(v is None for _, v in unstable.details["pade_norms"])
    design = _design({"delay_certificate_s": 0.5})
    assert design.delay.margin > 0.5              # stable at every delay up to 0.5 s …
    warned = _gamma_check(design)
    assert warned.status == "warn" and math.isinf(warned.value)   # … but not certified
    assert "certified no γ" in warned.message
    assert all(v is not None for _, v in warned.details["pade_norms"])
    assert any(t.startswith("all channels") for t in warned.details["trouble"])


# -- report and settings -----------------------------------------------------------------------


def test_report_rows_and_sentence() -> None:
    """Certified γ overall and per group, the scaling of each group, the sentence on γ = 1."""
    design = _design({"force_scale_m_s2": 0.1, "noise_scale_m_s": 0.2})
    data = FAMILY.report_data(design)
    json.dumps(data)
    rows = {r["name"]: r["value"] for r in data["rows"]}
    gamma = design.gamma
    assert float(rows["Certified γ, all channels [-]"]) == pytest.approx(gamma.gamma, rel=1e-3)
    for group, label in [("force", "force"), ("reference", "reference noise"),
                         ("link", "link noise")]:
        assert float(rows[f"Certified γ, {label} channels [-]"]) == pytest.approx(
            gamma.group_certificates[group].gamma, rel=1e-3)
    assert rows["Scaling of the force channels [m/s²]"] == "0.1"
    assert rows["Scaling of the reference and link noise channels [m/s]"] == "0.2"
    assert rows["Performance output"] == "tracking, scale 1 m/s"
    assert rows["γ certified for"].startswith("delay-free")
    assert "depends entirely on that scaling" in data["gamma_sentence"]
    assert data["gains_source"] == "given"


def _file(tmp_path: Path, *lines: str) -> Path:
    text = builtin_scenario_text("heavy-haul-hinf")
    path = tmp_path / "hinf.toml"
    path.write_text(text + "\n[controller]\nfamily = \"hinf\"\n" + "\n".join(lines)
                    + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(("line", "match"), [
    ("kappa_p_bounds_per_s = [0.3, 0.1]", "lo <= hi"),
    ("kappa_c_bounds_per_s = [0.2, 0.1]", "kappa_c_bounds_per_s"),
    ("kappa_p_bounds_per_s = [0.0, 0.1]", "kappa_p_bounds_per_s"),
    ("force_scale_m_s2 = -1.0", "force_scale_m_s2"),
    ("noise_scale_m_s = 0.0", "noise_scale_m_s"),
    ("output_scale_m_s = -0.1", "output_scale_m_s"),
    ("delay_certificate_s = 0.0", "delay_certificate_s"),
    ('performance = "both"', "performance"),
])
def test_bad_synthesis_settings_exit_2(tmp_path: Path, line: str, match: str,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    """A wrong value of a synthesis setting is a clean scenario error (exit 2)."""
    assert_refused(_file(tmp_path, line), match, capsys)
