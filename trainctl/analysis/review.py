# Design review: the named checks that `trainctl analyse` prints.
"""A design review of a scenario: named checks with status, value, threshold and hint.

The review answers, before any simulation, whether the design can work:
open-loop stability, controllability and observability, sampling adequacy,
and — when the scenario has a ``[controller]`` section — the unconstrained
MPC / N-DMPC / cooperative DMPC conditions of :mod:`trainctl.analysis.mpc`.

The MPC design model is the scenario's linear model without seed 000's
dummy state (which no input reaches and no output sees), discretised at the
scenario's sample time, with inputs in kN and coupler-force outputs in kN.
Weight thresholds are reported in the unit the scenario used (per kN² or per N²).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import control as ct
import numpy as np
from numpy.typing import NDArray

from ..models.discrete import discretise
from ..models.linear import linearise
from ..models.subsystems import coach_subsystems
from .controllability import analyse_controllability, analyse_observability
from .dmpc import analyse_dmpc
from .mpc import MPCDesign
from .sampling import analyse_sampling
from .stability import _direction, analyse_stability

if TYPE_CHECKING:
    from ..scenario import Scenario

__all__ = ["STATUSES", "Check", "DesignReview", "design_model", "review_design"]

STATUSES = ("pass", "warn", "fail")
"""Check statuses, from best to worst."""
MODEL_CHECK_NAMES = ("open_loop_stability", "controllability", "observability", "sampling", "input_collapse")  # noqa: E501

KN = 1e3
"""Newtons per kilonewton: inputs and coupler forces are in kN in the design model."""

_UNIT_TOL = 1e-9
"""Closed-loop eigenvalues within this of the unit circle count as marginal."""


@dataclass(frozen=True, kw_only=True)
class Check:
    """One named design check.

    Parameters
    ----------
    name : str
        Check name (see :data:`trainctl.scenario.CHECK_NAMES`).
    status : {"pass", "warn", "fail"}
        Outcome.
    value : float or None
        The measured number.
    threshold : float or None
        The number it is compared with.
    unit : str
        Unit of value and threshold ("" when dimensionless).
    message : str
        One line: what was found.
    hint : str
        One line: what to change ("" when nothing needs changing).
    details : dict
        JSON-safe supporting numbers (eigenvalues, directions, ...).
    """

    name: str
    status: str
    value: float | None
    threshold: float | None
    unit: str
    message: str
    hint: str = ""
    details: Mapping[str, object] = field(default_factory=dict)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict (non-finite numbers as None)."""
        return {"name": self.name, "status": self.status, "value": _finite(self.value),
                "threshold": _finite(self.threshold), "unit": self.unit,
                "message": self.message, "hint": self.hint, "details": dict(self.details)}


@dataclass(frozen=True, kw_only=True)
class DesignReview:
    """The checks of one scenario, in a fixed order.

    Parameters
    ----------
    scenario_name : str
        Display name of the scenario.
    checks : tuple of Check
        The checks.
    """

    scenario_name: str
    checks: tuple[Check, ...]

    @property
    def failed_checks(self) -> tuple[str, ...]:
        """Names of the checks whose status is ``"fail"``."""
        return tuple(c.name for c in self.checks if c.status == "fail")

    def check(self, name: str) -> Check:
        """The check called ``name`` (KeyError if the review has none)."""
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict."""
        return {"scenario": self.scenario_name, "checks": [c.to_dict() for c in self.checks],
                "failed_checks": list(self.failed_checks)}

    def format_text(self) -> str:
        """The review as a plain-text table with hints."""
        lines = ["Design checks:",
                 f"  {'check':<24}{'status':<8}{'value':>12}{'threshold':>12}  unit"]
        for c in self.checks:
            lines.append(f"  {c.name:<24}{c.status.upper():<8}{_fmt(c.value):>12}"
                         f"{_fmt(c.threshold):>12}  {c.unit}")
            lines.append(f"      {c.message}")
            if c.hint:
                lines.append(f"      hint: {c.hint}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        from html import escape
        rows = "".join(
            f"<tr><td>{escape(c.name)}</td><td>{c.status}</td><td>{_fmt(c.value)}</td>"
            f"<td>{_fmt(c.threshold)}</td><td>{escape(c.unit)}</td><td>{escape(c.message)}</td></tr>"
            for c in self.checks)
        return ("<table><tr><th>check</th><th>status</th><th>value</th><th>threshold</th>"
                f"<th>unit</th><th>finding</th></tr>{rows}</table>")


def design_model(scenario: Scenario) -> tuple[ct.StateSpace, MPCDesign | None]:
    """The continuous design model and, with a ``[controller]``, the MPC design.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.

    Returns
    -------
    sys : control.StateSpace
        Continuous linear model without the dummy state, inputs in kN and
        outputs as the controller section asks (velocities [m/s], coupler
        forces [kN]).
    design : MPCDesign or None
        Discretised design (None without a ``[controller]`` section).
    """
    train, cfg, ctl = scenario.train, scenario.model, scenario.controller
    outputs = tuple(ctl.outputs) if ctl is not None else ("v",)
    sys = linearise(train, cfg.speed, method=cfg.linearisation, outputs=outputs)
    n = train.n_vehicles
    scale_out = np.concatenate([np.ones(n) if g == "v" else np.full(train.n_couplers, 1 / KN)
                                for g in outputs])
    sys = ct.ss(sys.A, sys.B * KN, scale_out[:, None] * sys.C, 0, states=sys.state_labels,
                inputs=sys.input_labels, outputs=sys.output_labels, name=sys.name)
    if ctl is None:
        return sys, None
    sysd = discretise(sys, cfg.sample_time, method=cfg.discretisation)
    weight = {"v": (n, ctl.q_velocity), "force": (train.n_couplers, ctl.q_force)}
    q = np.concatenate([np.full(*weight[g]) for g in outputs])
    owner = tuple(int(i) for g in outputs for i in range(n if g == "v" else train.n_couplers))
    design = MPCDesign(
        A=np.asarray(sysd.A, dtype=float), B=np.asarray(sysd.B, dtype=float),
        C=np.asarray(sysd.C, dtype=float), prediction_horizon=ctl.prediction_horizon,
        control_horizon=ctl.control_horizon, form=ctl.form, q=q,
        r=np.full(n, ctl.input_weight_per_kn2()), output_owner=owner,
        neighbourhoods=ctl.neighbourhoods(n))
    return sys, design


def review_design(scenario: Scenario) -> DesignReview:
    """Run every design check that applies to ``scenario``.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.

    Returns
    -------
    DesignReview
        Model checks always; MPC/DMPC checks when the scenario has a
        ``[controller]`` section.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> review = review_design(load_scenario("crh2-dmpc"))
    >>> review.check("sampling").status
    'fail'
    """
    sys, design = design_model(scenario)
    checks = list(_model_checks(scenario, sys))
    if design is not None:
        checks += _mpc_checks(scenario, design)
    return DesignReview(scenario_name=scenario.name, checks=tuple(checks))


def _model_checks(scenario: Scenario, sys: ct.StateSpace) -> list[Check]:
    train, cfg = scenario.train, scenario.model
    n = train.n_vehicles
    full = linearise(train, cfg.speed, method=cfg.linearisation, dummy_state=cfg.dummy_state)
    stab = analyse_stability(full, n_vehicles=n)
    checks = [_stability_check(stab)]
    ctrb = analyse_controllability(sys)
    obsv = analyse_observability(sys)
    local = _local_controllability(scenario)
    checks.append(_rank_check("controllability", ctrb, extra=local))
    checks.append(_rank_check("observability", obsv, virtual=bool(np.any(train.virtual))))
    samp = analyse_sampling(sys, cfg.sample_time, n_vehicles=n, method=cfg.discretisation)
    checks.append(_sampling_check(samp))
    checks.append(_collapse_check(samp))
    return checks


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


def _local_controllability(scenario: Scenario) -> list[bool]:
    train, cfg = scenario.train, scenario.model
    if train.n_vehicles < 2 or np.any(train.virtual):
        return []
    sub = coach_subsystems(train, cfg.speed, method=cfg.linearisation, dummy_state=False)
    result = []
    for i in range(sub.n_coaches):
        local = ct.ss(sub.A[i, i], sub.B[i] * KN, sub.C[i], 0)
        result.append(analyse_controllability(local).full_rank)
    return result


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
    dirs = "; ".join(str(m.direction) for m in res.uncontrollable)
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
    status = "pass" if wt < math.pi / 2 else ("warn" if wt < math.pi else "fail")
    message = (f"ω_max·T = {samp.omega_max:.4g} rad/s × {samp.sample_time:g} s = {wt:.4g} rad "
               f"(π/ω_max = {samp.nyquist_sample_time:.4g} s)")
    hint = "" if status == "pass" else (
        f"the coupler modes are {'aliased' if status == 'fail' else 'barely resolved'}: use "
        f"T ≤ {0.5 * samp.nyquist_sample_time:.3g} s to act on them")
    return Check(name="sampling", status=status, value=wt, threshold=math.pi, unit="rad",
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


def _mpc_checks(scenario: Scenario, design: MPCDesign) -> list[Check]:
    ctl = scenario.controller
    if ctl is None:
        return []
    unit_scale = 1.0 if ctl.input_weight_unit == "kN" else 1e-6   # per kN² -> per N²
    unit = f"per {ctl.input_weight_unit}²"
    weights = (None if ctl.cooperative_weights == "uniform"
               else np.asarray(ctl.cooperative_weights, dtype=float))
    res = analyse_dmpc(design, iterations=ctl.iterations, cooperative_weights=weights)
    labels = _closed_loop_labels(scenario, design)
    plan = [f"plan[{i}]" for i in range(res.closed_loop_iterations.shape[0] - len(labels))]
    checks = [
        _convergence_check(res.rho_d0, res.threshold_weight * unit_scale, unit, res.relaxation),
        _relaxation_check(res.rho_d0, res.relaxation),
        _radius_check("closed_loop_nash", res.closed_loop_nash, labels, design,
                      "converged N-DMPC (Nash point)"),
        _radius_check("closed_loop_iterations", res.closed_loop_iterations, labels + plan, design,
                      f"N-DMPC with {ctl.iterations} iteration(s) per sample"),
        _gap_check(res.cost_gap),
        Check(name="cooperative_convergence", status="pass" if res.rho_cooperative < 1 else "fail",
              value=res.rho_cooperative, threshold=1.0, unit="",
              message=f"cooperative DMPC iteration: ρ = {res.rho_cooperative:.4g}; its fixed "
              "point is the centralised optimum",
              hint="" if res.rho_cooperative < 1 else "use convex weights summing to 1"),
        _radius_check("centralised_closed_loop", res.closed_loop_centralised, labels, design,
                      "centralised MPC"),
    ]
    return checks


def _convergence_check(rho: float, r_star: float, unit: str, relax) -> Check:
    details = {"rho_D0": rho, "R_star": _finite(r_star), "relaxation": relax.to_dict()}
    if rho < 1:
        return Check(name="ndmpc_convergence", status="pass", value=rho, threshold=1.0, unit="",
                     message=f"Jacobi iteration converges: ρ(D0) = {rho:.4g} < 1 "
                     f"(threshold weight R* = {r_star:.4g} {unit})", details=details)
    relax_hint = (f" or relax with ω ≤ {relax.omega_max:.3g} (best ω = {relax.omega_best:.3g}, "
                  f"rate {relax.rate:.3g})" if relax.exists else " (no relaxation factor helps)")
    return Check(name="ndmpc_convergence", status="fail", value=rho, threshold=1.0, unit="",
                 message=f"Jacobi iteration diverges: ρ(D0) = {rho:.4g} ≥ 1",
                 hint=f"raise R above R* = {r_star:.4g} {unit}{relax_hint}", details=details)


def _relaxation_check(rho: float, relax) -> Check:
    if rho < 1:
        return Check(name="relaxation", status="pass", value=1.0, threshold=None, unit="",
                     message="not needed: plain Jacobi (ω = 1) converges", details=relax.to_dict())
    if relax.exists:
        return Check(name="relaxation", status="warn", value=relax.omega_best,
                     threshold=relax.omega_max, unit="",
                     message=f"relaxed Jacobi converges for ω ≤ {relax.omega_max:.3g}; best "
                     f"ω = {relax.omega_best:.3g} gives rate {relax.rate:.3g}",
                     hint="set the relaxation factor, or raise R", details=relax.to_dict())
    return Check(name="relaxation", status="fail", value=None, threshold=None, unit="",
                 message="no relaxation exists: an eigenvalue of D0 has real part ≥ 1",
                 hint="raise R above R* or shorten the sample time", details=relax.to_dict())


def _closed_loop_labels(scenario: Scenario, design: MPCDesign) -> list[str]:
    labels = scenario.train.state_labels()
    if design.form == "du":
        labels += [f"u_prev[{i}]" for i in range(design.n_inputs)]
    return labels


def _radius_check(name: str, A_cl: NDArray[np.float64], labels: list[str], design: MPCDesign,
                  what: str) -> Check:
    lam, vec = np.linalg.eig(A_cl)
    rho = float(np.max(np.abs(lam)))
    on_circle = np.flatnonzero(np.abs(np.abs(lam) - 1) <= _UNIT_TOL)
    circle = [{"eigenvalue": [float(lam[k].real), float(lam[k].imag)],
               "direction": _direction(vec[:, k], labels)} for k in on_circle]
    details = {"spectral_radius": rho, "unit_circle": circle}
    if rho > 1 + _UNIT_TOL:
        return Check(name=name, status="fail", value=rho, threshold=1.0, unit="",
                     message=f"{what}: closed loop unstable, ρ = {rho:.6g}",
                     hint="raise R, lengthen P, or penalise coupler forces", details=details)
    if circle:
        hint = ("the Δu-form with velocity-only outputs leaves the internal-force directions "
                "unpenalised: add 'force' to [controller].outputs or use the u-form"
                if design.form == "du" else "penalise the states along these directions")
        return Check(name=name, status="warn", value=rho, threshold=1.0, unit="",
                     message=f"{what}: {len(circle)} eigenvalue(s) on the unit circle, e.g. "
                     f"directions {circle[0]['direction']}", hint=hint, details=details)
    return Check(name=name, status="pass", value=rho, threshold=1.0, unit="",
                 message=f"{what}: ρ = {rho:.6g} < 1", details=details)


def _gap_check(gap: float) -> Check:
    status = "pass" if gap <= 0.1 else "warn"
    return Check(name="nash_gap", status=status, value=gap, threshold=0.1, unit="",
                 message=f"Nash cost exceeds the centralised optimum by {100 * gap:.3g} % for a "
                 "1 m/s error on every coach",
                 hint="" if status == "pass"
                 else "widen the neighbourhoods or use cooperative DMPC")


def _finite(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _fmt(x: float | None) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if math.isinf(x):
        return "inf"
    return f"{x:.4g}"
