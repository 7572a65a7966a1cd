# Design review: the named checks that `trainctl analyse` prints.
"""A design review of a scenario: named checks with status, value, threshold and hint.

The review answers, before any simulation, whether the design can work:
open-loop stability, controllability and observability, sampling adequacy
(:func:`model_checks`, on the run's :class:`~trainctl.design.DesignModel`),
whether every vehicle can supply its force where the train runs and whether
the physical values are plausible (:func:`scenario_checks`), then the checks
of every controller family of the scenario (``checks()`` of each
:mod:`~trainctl.controllers.registry` family, e.g. the N-DMPC conditions of
the MPC family).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import control as ct
import numpy as np
from numpy.typing import NDArray

from trainctl.analysis.check import STATUSES, Check, DesignReview
from trainctl.analysis.controllability import analyse_controllability, analyse_observability
from trainctl.analysis.sampling import analyse_sampling
from trainctl.analysis.stability import analyse_stability, mode_direction
from trainctl.analysis.string_stability import string_stability_check
from trainctl.naming import describe_direction

if TYPE_CHECKING:
    from collections.abc import Mapping

    from trainctl.design import Design, DesignModel
    from trainctl.scenario import Scenario
    from trainctl.sim.results import SimulationResult

__all__ = [
    "LOOP_CHECK_NAMES", "MODEL_CHECK_NAMES", "SAMPLING_FAIL", "SAMPLING_PASS", "STATUSES",
    "Check", "DesignReview", "model_checks", "radius_check", "review_design", "scenario_checks",
    "with_simulations",
]

MODEL_CHECK_NAMES = (
    "open_loop_stability", "controllability", "observability", "sampling", "input_collapse",
    "feasibility", "plausibility",
)

LOOP_CHECK_NAMES = ("string_stability",)
"""Checks of the primary family's linear closed loop, whatever the family (after its own)."""
"""Names of the checks that need no controller: the linear model's (:func:`model_checks`),
then the scenario's (:func:`scenario_checks`); controller families add their own."""

SAMPLING_PASS = math.pi / 2
"""ω_max·T [rad] below which the sampling resolves the fastest coupler mode (pass): at
least four samples per period of the fastest mode. The sampling hint asks for
T < SAMPLING_PASS / ω_max."""

SAMPLING_FAIL = math.pi
"""ω_max·T [rad] at and above which the fastest coupler mode is aliased (Nyquist, fail)."""

KN = 1e3
"""Newtons per kilonewton: inputs and coupler forces are in kN in the design model."""

_UNIT_TOL = 1e-9
"""Closed-loop eigenvalues within this of the unit circle count as marginal."""


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
    from trainctl.controllers.registry import get_family
    from trainctl.design import build_design

    if design is None:
        design = build_design(scenario)
    primary = next(iter(design.families), None)
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

    >>> from trainctl.run import simulate_strategy
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
    from trainctl.controllers.registry import get_family

    found: dict[str, Check] = {}
    for strategy, result in simulations.items():
        family, name = design.resolve(strategy)
        judge = getattr(get_family(family), "trajectory_checks", None)
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


def radius_check(name: str, A_cl: NDArray[np.float64], labels: list[str], what: str, *,
                 marginal_hint: str, unstable_hint: str) -> Check:
    """Judge a discrete closed loop by its spectral radius (fail > 1, warn on the circle).

    Parameters
    ----------
    name : str
        Check name.
    A_cl : ndarray
        Closed-loop state matrix (discrete).
    labels : list of str
        State names (eigenvector directions are described with them).
    what : str
        What the closed loop is, for the message.
    marginal_hint, unstable_hint : str
        Hints when eigenvalues sit on the unit circle / outside it.

    Returns
    -------
    Check
        Value ρ, threshold 1; details with the eigenvalues on the circle.

    Examples
    --------
    >>> import numpy as np
    >>> def judge(A):
    ...     return radius_check("demo", A, ["v[0]", "v[1]"], "toy loop",
    ...                         marginal_hint="on the circle", unstable_hint="outside")
    >>> judge(np.diag([0.5, 0.9])).status, judge(np.diag([0.5, 0.9])).value
    ('pass', 0.9)
    >>> c = judge(np.diag([0.5, 1.0]))  # v[1] never decays
    >>> c.status, c.details["unit_circle"][0]["direction"]
    ('warn', {'v[1]': 1.0})
    >>> judge(np.diag([0.5, 1.1])).message
    'toy loop: closed loop unstable, ρ = 1.1'
    """
    lam, vec = np.linalg.eig(A_cl)
    rho = float(np.max(np.abs(lam)))
    on_circle = np.flatnonzero(np.abs(np.abs(lam) - 1) <= _UNIT_TOL)
    directions = [mode_direction(vec[:, k], labels) for k in on_circle]
    circle = [{"eigenvalue": [float(lam[k].real), float(lam[k].imag)], "direction": d}
              for k, d in zip(on_circle, directions, strict=True)]
    details = {"spectral_radius": rho, "unit_circle": circle}
    if rho > 1 + _UNIT_TOL:
        return Check(name=name, status="fail", value=rho, threshold=1.0, unit="",
                     message=f"{what}: closed loop unstable, ρ = {rho:.6g}",
                     hint=unstable_hint, details=details)
    if circle:
        return Check(name=name, status="warn", value=rho, threshold=1.0, unit="",
                     message=f"{what}: {len(circle)} eigenvalue(s) on the unit circle, e.g. "
                     f"direction {describe_direction(directions[0])}",
                     hint=marginal_hint, details=details)
    return Check(name=name, status="pass", value=rho, threshold=1.0, unit="",
                 message=f"{what}: ρ = {rho:.6g} < 1", details=details)


def _stability_check(stab) -> Check:
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


def _rank_check(name: str, res, extra: list[bool] | None = None, virtual: bool = False) -> Check:
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


def _sampling_check(samp) -> Check:
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


def _collapse_check(samp) -> Check:
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
