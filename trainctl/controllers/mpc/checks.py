# The MPC family's design checks: N-DMPC convergence, relaxation, closed loops, Nash gap.
"""Design checks of the MPC family (unconstrained theory, :mod:`trainctl.controllers.mpc.theory`).

Weight thresholds are reported in the unit the scenario used (per kN² or per N²).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

from trainctl.analysis.check import Check, radius_check

if TYPE_CHECKING:
    from trainctl.controllers.mpc.family import MPCFamilyDesign

__all__ = ["mpc_checks"]


def mpc_checks(design: MPCFamilyDesign) -> list[Check]:
    """The MPC family's checks, in the order of ``FAMILY.check_names``.

    Parameters
    ----------
    design : MPCFamilyDesign
        The family's design (its analysis is computed on first use).

    Returns
    -------
    list of Check
        ``ndmpc_convergence``, ``relaxation``, ``closed_loop_nash``,
        ``closed_loop_iterations``, ``nash_gap``, ``cooperative_convergence``,
        ``centralised_closed_loop``, then the review()-grade checks of
        :mod:`~trainctl.controllers.mpc.review_checks`: ``prediction_horizon``,
        ``qp_conditioning``, ``rate_limit_conflict``, ``coupler_force_conflict``.

    Examples
    --------
    The design weight R = 10 per kN² is above the convergence threshold
    R* ≈ 2.25 per kN², so the Jacobi iterations of N-DMPC converge
    (ρ(D0) ≈ 0.31 < 1):

    >>> from trainctl.controllers.mpc.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> checks = {c.name: c for c in mpc_checks(design)}
    >>> len(checks), checks["ndmpc_convergence"].status
    (11, 'pass')
    >>> round(design.analysis.rho_d0, 2), round(design.analysis.threshold_weight, 2)
    (0.31, 2.25)
    """
    from trainctl.controllers.mpc.review_checks import (
        coupler_force_check,
        horizon_check,
        qp_conditioning_check,
        rate_limit_check,
    )

    ctl, res = design.settings, design.analysis
    unit_scale = 1.0 if ctl.input_weight_unit == "kN" else 1e-6   # per kN² -> per N²
    unit = f"per {ctl.input_weight_unit}²"
    labels = design.closed_loop_labels()
    plan = [f"plan[{i}]" for i in range(res.closed_loop_iterations.shape[0] - len(labels))]
    local = design.local_analysis if design.simulates_local else None
    return [
        _with_local(_convergence_check(res.rho_d0, res.threshold_weight * unit_scale, unit,
                                       res.relaxation), local, "rho_d0",
                    weight_unit=(unit_scale, unit)),
        _relaxation_check(res.rho_d0, res.relaxation),
        _with_local(_radius(design, "closed_loop_nash", res.closed_loop_nash, labels,
                            "converged N-DMPC (Nash point)"), local, "closed_loop_radius"),
        _with_local(_radius(design, "closed_loop_iterations", res.closed_loop_iterations,
                            labels + plan, f"N-DMPC with {ctl.iterations} iteration(s) per sample"),
                    local, "closed_loop_iterations_radius"),
        _gap_check(res.cost_gap),
        Check(name="cooperative_convergence", status="pass" if res.rho_cooperative < 1 else "fail",
              value=res.rho_cooperative, threshold=1.0, unit="",
              message=f"cooperative DMPC iteration: ρ = {res.rho_cooperative:.4g}; its fixed "
              "point is the centralised optimum",
              hint="" if res.rho_cooperative < 1 else "use convex weights summing to 1"),
        _radius(design, "centralised_closed_loop", res.closed_loop_centralised, labels,
                "centralised MPC"),
        horizon_check(design),
        qp_conditioning_check(design),
        rate_limit_check(design),
        coupler_force_check(design),
    ]


def _radius(design: MPCFamilyDesign, name: str, A_cl: Any, labels: list[str], what: str) -> Check:
    marginal = ("the Δu-form with velocity-only outputs leaves the internal-force directions "
                "unpenalised: add 'force' to [controller].outputs or use the u-form"
                if design.mpc.form == "du" else "penalise the states along these directions")
    return radius_check(name, A_cl, labels, what, marginal_hint=marginal,
                        unstable_hint="raise R, lengthen P, or penalise coupler forces")


def _with_local(check: Check, local: Any, what: str, *,
                weight_unit: tuple[float, str] | None = None) -> Check:
    """``check`` (of the global formulation) with the local formulation's number beside it.

    Only when the scenario simulates ``"ndmpc-local"``: the local number goes
    to the message and ``details["local"]``; a pass becomes a warn when the
    local formulation fails where the global one passes (ρ ≥ 1). With
    ``weight_unit`` (scale from design units, unit label) the message also
    gives the local threshold weight R*, when it was computed.
    """
    if local is None:
        return check
    value = float(getattr(local, what))
    label = "ρ(D0)" if what == "rho_d0" else "closed-loop ρ"
    if what == "closed_loop_iterations_radius":
        label = f"closed-loop ρ with {local.iterations} iteration(s)"
    message = f"{check.message}; local formulation (ndmpc-local): {label} = {value:.6g}"
    raise_r = "raise R"
    if weight_unit is not None:
        r_star = local.threshold_weight
        if r_star is None:
            message += (" (its R* is not computed at this size: call "
                        "trainctl.controllers.mpc.theory.local_iteration.local_threshold_weight)")
        elif math.isinf(r_star):
            message += ", no R makes it converge"
            raise_r = "no R makes it converge: shorten P or widen the neighbourhoods"
        else:
            scale, unit = weight_unit
            message += f", R* = {r_star * scale:.4g} {unit}"
            raise_r = f"raise R above its R* = {r_star * scale:.4g} {unit}"
    details = dict(check.details or {})
    details["local"] = local.to_dict()
    status, hint = check.status, check.hint
    if value >= 1 and status == "pass":
        status = "warn"
        hint = ("the neighbourhood-local formulation (ndmpc-local) "
                + (f"diverges: {raise_r}" if what == "rho_d0" else "is unstable")
                + "; see trainctl.controllers.mpc.theory.local_iteration")
    return dataclasses.replace(check, status=status, message=message, details=details,
                               hint=hint)


def _convergence_check(rho: float, r_star: float, unit: str, relax: Any) -> Check:
    finite = float(r_star) if math.isfinite(r_star) else None
    details = {"rho_D0": rho, "R_star": finite, "relaxation": relax.to_dict()}
    if rho < 1:
        return Check(name="ndmpc_convergence", status="pass", value=rho, threshold=1.0, unit="",
                     message=f"Jacobi iteration converges: ρ(D0) = {rho:.4g} < 1 "
                     f"(threshold weight R* = {r_star:.4g} {unit})", details=details)
    relax_hint = (f" or relax with ω ≤ {relax.omega_max:.3g} (best ω = {relax.omega_best:.3g}, "
                  f"rate {relax.rate:.3g})" if relax.exists else " (no relaxation factor helps)")
    return Check(name="ndmpc_convergence", status="fail", value=rho, threshold=1.0, unit="",
                 message=f"Jacobi iteration diverges: ρ(D0) = {rho:.4g} ≥ 1",
                 hint=f"raise R above R* = {r_star:.4g} {unit}{relax_hint}", details=details)


def _relaxation_check(rho: float, relax: Any) -> Check:
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


def _gap_check(gap: float) -> Check:
    status = "pass" if gap <= 0.1 else "warn"
    return Check(name="nash_gap", status=status, value=gap, threshold=0.1, unit="",
                 message=f"Nash cost exceeds the centralised optimum by {100 * gap:.3g} % for a "
                 "1 m/s error on every coach",
                 hint="" if status == "pass"
                 else "widen the neighbourhoods or use cooperative DMPC")
