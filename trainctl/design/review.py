# Design review: the named checks that `trainctl analyse` prints.
"""A design review of a scenario: named checks with status, value, threshold and hint.

The review answers, before any simulation, whether the design can work:
open-loop stability, controllability and observability, sampling adequacy
(:func:`model_checks`, on the run's :class:`~trainctl.design.DesignModel`),
whether every vehicle can supply its force where the train runs and whether
the physical values are plausible (:func:`scenario_checks`), then the checks
of every controller family of the scenario (``checks()`` of each
:mod:`~trainctl.registry` family, e.g. the N-DMPC conditions of
the MPC family).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import control as ct
import numpy as np

from trainctl.analysis.check import (
    SAMPLING_FAIL,
    SAMPLING_PASS,
    STATUSES,
    Check,
    DesignReview,
)
from trainctl.analysis.controllability import analyse_controllability, analyse_observability
from trainctl.analysis.sampling import analyse_sampling
from trainctl.analysis.stability import analyse_stability
from trainctl.analysis.string_stability import string_stability_check
from trainctl.naming import describe_direction

if TYPE_CHECKING:
    from collections.abc import Mapping

    from trainctl.analysis.rank_results import ControllabilityResult, ObservabilityResult
    from trainctl.analysis.sampling import SamplingResult
    from trainctl.analysis.stability import StabilityResult
    from trainctl.design import Design, DesignModel
    from trainctl.scenario import Scenario
    from trainctl.sim.results import SimulationResult

__all__ = ["model_checks", "review_design", "scenario_checks", "with_simulations"]

KN = 1e3
"""Newtons per kilonewton: inputs and coupler forces are in kN in the design model."""

def review_design(scenario: Scenario, design: Design | None = None) -> DesignReview:
    """Run every design check that applies to ``scenario``.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    design : Design or None
        The run's design (:func:`trainctl.design.build_design`); built here
        when None.

    Returns
    -------
    DesignReview
        The model checks, the scenario checks, each controller family's
        checks (primary family first), then ``string_stability`` when the
        primary family has a linear closed loop
        (:func:`~trainctl.analysis.string_stability.string_stability_check`).

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> review = review_design(load_scenario("crh2-dmpc"))
    >>> review.check("sampling").status
    'fail'
    """
    from trainctl.design import build_design
    from trainctl.registry import get_family

    if design is None:
        design = build_design(scenario)
    primary = next(iter(design.families), None)
    # the hooks' defaults (trainctl.controllers.hooks.FamilyHooks) read here without importing
    # the controllers stage, which comes after this one
    gaps = primary is not None and bool(getattr(get_family(primary), "measures_gaps", False))
    checks = model_checks(design.model, measured_gaps=gaps) + scenario_checks(scenario)
    for name, family_design in design.families.items():
        checks += get_family(name).checks(family_design)
    string = string_stability_check(design)
    if string is not None:
        checks.append(string)
    return DesignReview(scenario_name=scenario.name, checks=tuple(checks))


def with_simulations(review: DesignReview, design: Design,
                     simulations: Mapping[str, SimulationResult]) -> DesignReview:
    """The review with the checks that the simulations decide judged on them.

    A family whose checks say something about the trajectory (the
    linearisation's validity range, the connectivity of a formation) has a
    ``trajectory_checks(design, strategy, result)`` method; each check it
    returns replaces the design-time check of the same name. When several
    strategies of the family were simulated, the worst verdict stands.

    Parameters
    ----------
    review : DesignReview
        The design review (:func:`review_design`).
    design : Design
        The run's design.
    simulations : mapping of str to SimulationResult
        Results by ``[simulation]`` strategy name.

    Returns
    -------
    DesignReview
        The same checks, in the same order, some replaced; ``review`` itself
        when nothing was simulated that a family judges.

    Examples
    --------
    Before the run, the flocking family can only warn that a gap may leave the
    communication range later; the simulated trajectory settles it.

    >>> from trainctl.run.analysis import simulate_strategy
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-flocking-collision").replace("simulation.duration", 450.0)
    >>> design = build_design(sc)
    >>> review = review_design(sc, design=design)
    >>> result = simulate_strategy(sc, "flocking", design)
    >>> judged = with_simulations(review, design, {"flocking": result})
    >>> review.check("flocking_connectivity").status, judged.check("flocking_connectivity").status
    ('warn', 'pass')
    >>> len(judged.checks) == len(review.checks)
    True
    """
    from trainctl.registry import get_family

    found: dict[str, Check] = {}
    for strategy, result in simulations.items():
        family, name = design.resolve(strategy)
        judge = getattr(get_family(family), "trajectory_checks", None)  # default: none
        if judge is None:
            continue
        for check in judge(design.family(family), strategy, result):
            old = found.get(check.name)
            if old is None or STATUSES.index(check.status) > STATUSES.index(old.status):
                found[check.name] = check
    if not found:
        return review
    checks = tuple(found.pop(c.name, c) for c in review.checks) + tuple(found.values())
    return DesignReview(scenario_name=review.scenario_name, checks=checks)


def model_checks(model: DesignModel, *, measured_gaps: bool = False) -> list[Check]:
    """The checks of the linear model: stability, rank tests, sampling.

    Parameters
    ----------
    model : DesignModel
        The run's design model.
    measured_gaps : bool
        The primary controller measures the gaps of the virtual links (a
        family with ``measures_gaps = True``, e.g. flocking): observability
        is judged with the virtual links' gap deviations added to the outputs.

    Returns
    -------
    list of Check
        In the order of :data:`MODEL_CHECK_NAMES`.

    Examples
    --------
    The CRH2 half train sampled at T = 20 s: its fastest coupler mode
    (27.77 rad/s) is far beyond the Nyquist limit, ω_max·T = 555.4 rad ≥ π.

    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> checks = model_checks(build_model(load_scenario("crh2-dmpc")))
    >>> [(c.name, c.status) for c in checks]  # doctest: +NORMALIZE_WHITESPACE
    [('open_loop_stability', 'pass'), ('controllability', 'pass'), ('observability', 'pass'),
     ('sampling', 'fail'), ('input_collapse', 'fail')]
    >>> round(checks[3].value, 1)  # ω_max·T [rad]
    555.4
    """
    train, cfg = model.train, model.settings
    n = train.n_vehicles
    stab = analyse_stability(model.speed_model(), n_vehicles=n)
    checks = [_stability_check(stab)]
    sys = model.select(model.design)
    ctrb = analyse_controllability(sys)
    obsv = analyse_observability(_with_gaps(sys, model) if measured_gaps else sys)
    checks.append(_rank_check("controllability", ctrb, extra=_local_controllability(model)))
    checks.append(_rank_check("observability", obsv, virtual=bool(np.any(train.virtual))))
    samp = analyse_sampling(sys, cfg.sample_time, n_vehicles=n, method=cfg.discretisation,
                            sysd=model.select(model.discrete))
    checks.append(_sampling_check(samp))
    checks.append(_collapse_check(samp))
    return checks


def _with_gaps(sys: ct.StateSpace, model: DesignModel) -> ct.StateSpace:
    """``sys`` with the virtual links' elongations (gap deviations [m]) as extra outputs."""
    n, virtual = model.n_vehicles, np.flatnonzero(model.train.virtual)
    rows = np.zeros((virtual.size, int(sys.nstates)))
    rows[np.arange(virtual.size), n + virtual] = 1.0
    return ct.ss(sys.A, sys.B, np.vstack([np.asarray(sys.C), rows]),
                 np.vstack([np.asarray(sys.D), np.zeros((virtual.size, int(sys.ninputs)))]),
                 sys.dt)


def scenario_checks(scenario: Scenario) -> list[Check]:
    """The checks of the scenario's physical values where the train runs.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.

    Returns
    -------
    list of Check
        ``feasibility`` (:func:`~trainctl.analysis.feasibility.feasibility_check`:
        every vehicle's force within its traction and braking envelope along
        the route) and ``plausibility``
        (:func:`~trainctl.analysis.plausibility.plausibility_check`: physical
        values in their usual ranges, likely unit slips named).

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> [c.status for c in scenario_checks(load_scenario("crh2-dmpc"))]
    ['pass', 'pass']
    """
    from trainctl.analysis.feasibility import feasibility_check
    from trainctl.analysis.plausibility import plausibility_check

    return [feasibility_check(scenario), plausibility_check(scenario)]


def _stability_check(stab: StabilityResult) -> Check:
    structural = [m for m in stab.modes if m.name == "dummy"]
    others = [m for m in stab.modes if m.name != "dummy"]
    worst = max((m.status for m in others), default="stable",
                key=("stable", "marginal-semisimple", "marginal-defective", "unstable").index)
    abscissa = max((m.eigenvalue.real for m in others), default=-math.inf)
    note = f"; dummy state: eigenvalue 0 ({len(structural)}), excluded" if structural else ""
    details = {"modes": [m.to_dict() for m in stab.modes]}
    if worst == "stable":
        return Check(name="open_loop_stability", status="pass", value=abscissa, threshold=0.0,
                     unit="1/s",
                     message=f"all modes decay; slowest Re(λ) = {abscissa:.3e} 1/s{note}",
                     details=details)
    if worst == "marginal-semisimple":
        count = sum(1 for m in others if m.status == worst)
        return Check(name="open_loop_stability", status="warn", value=abscissa, threshold=0.0,
                     unit="1/s", message=f"{count} marginal semisimple mode(s) at Re(λ) = 0 "
                     f"(integrators such as gap drift){note}",
                     hint="bounded but not decaying: the controller must act on these modes",
                     details=details)
    return Check(name="open_loop_stability", status="fail", value=abscissa, threshold=0.0,
                 unit="1/s", message=f"open loop is {worst}",
                 hint="check the model parameters (masses, damping)",
                 details=details)


def _local_controllability(model: DesignModel) -> list[bool]:
    """Per coach: is its own subsystem (A_ii, B_i) controllable (dummy state dropped)?"""
    train, sub = model.train, model.subsystems
    if train.n_vehicles < 2 or np.any(train.virtual):
        return []
    result = []
    for i in range(sub.n_coaches):
        keep = 1 if (i == sub.n_coaches - 1 and model.has_dummy) else sub.B[i].shape[0]
        local = ct.ss(sub.A[i, i][:keep, :keep], sub.B[i][:keep] * KN, sub.C[i][:, :keep], 0)
        result.append(analyse_controllability(local).full_rank)
    return result


_LISTED = 4
"""Modes a failing rank check names in its message (all are in its details)."""


def _rank_check(name: str, res: ControllabilityResult | ObservabilityResult,
                extra: list[bool] | None = None, virtual: bool = False) -> Check:
    word = "controllable" if name == "controllability" else "observable"
    local = ""
    if extra:
        local = f"; coach subsystems {word} locally: {sum(extra)}/{len(extra)}"
    details = res.to_dict()
    if res.full_rank:
        return Check(name=name, status="pass", value=float(res.rank), threshold=float(res.n_states),
                     unit="rank", message=f"rank {res.rank}/{res.n_states}, condition number "
                     f"{res.condition_number:.3g}{local}", details=details)
    dirs = "; ".join(describe_direction(m.direction) for m in res.modes[:_LISTED])
    if len(res.modes) > _LISTED:
        dirs += f"; … ({len(res.modes)} modes in all)"
    if name == "controllability":
        hint = "add inputs or couple the vehicles"
    elif virtual:
        hint = ("measure the gaps between virtually coupled trains: speeds alone cannot see "
                "gap drift")
    else:
        hint = "add outputs (e.g. 'force' in [controller].outputs)"
    return Check(name=name, status="fail", value=float(res.rank), threshold=float(res.n_states),
                 unit="rank", message=f"rank {res.rank}/{res.n_states}; not {word}: {dirs}{local}",
                 hint=hint, details=details)


def _sampling_check(samp: SamplingResult) -> Check:
    if samp.omega_max == 0:
        return Check(name="sampling", status="pass", value=0.0, threshold=math.pi, unit="rad",
                     message=f"no coupler modes; T = {samp.sample_time:g} s",
                     details=samp.to_dict())
    wt = samp.omega_t
    status = "pass" if wt < SAMPLING_PASS else ("warn" if wt < SAMPLING_FAIL else "fail")
    message = (f"ω_max·T = {samp.omega_max:.4g} rad/s × {samp.sample_time:g} s = {wt:.4g} rad "
               f"(π/ω_max = {samp.nyquist_sample_time:.4g} s)")
    hint = "" if status == "pass" else (
        f"the coupler modes are {'aliased' if status == 'fail' else 'barely resolved'}: use "
        f"T < {_round_down(SAMPLING_PASS / samp.omega_max)} s (ω_max·T < π/2) to act on them")
    return Check(name="sampling", status=status, value=wt, threshold=SAMPLING_FAIL, unit="rad",
                 message=message, hint=hint, details=samp.to_dict())


def _collapse_check(samp: SamplingResult) -> Check:
    c = samp.input_collapse
    status = "pass" if c >= 0.1 else ("warn" if c >= 0.01 else "fail")
    hint = "" if status == "pass" else (
        "over one sample every input acts almost the same way (the train moves as one body): "
        "distributed controllers fight over one direction; shorten T or raise R")
    return Check(name="input_collapse", status=status, value=c, threshold=0.1, unit="",
                 message=f"smallest normalised singular value of B_d: {c:.3g}", hint=hint,
                 details=samp.to_dict())


def _round_down(x: float, digits: int = 3) -> str:
    """``x`` to ``digits`` significant digits, never rounded up (a bound quoted in a hint)."""
    scale = 10.0 ** (digits - 1 - math.floor(math.log10(x)))
    return f"{math.floor(x * scale) / scale:.{digits}g}"
