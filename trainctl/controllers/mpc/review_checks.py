# The MPC family's review()-grade checks: horizon, QP conditioning, constraint conflicts.
"""Design checks in the spirit of MATLAB's MPC ``review()``.

- ``prediction_horizon``: does the horizon P·T cover the dynamics the
  controller shapes? The judged time scale is τ, the time constant of the
  centralised unconstrained closed loop's rigid-body (common-speed) mode —
  how fast the design removes a speed error. MathWorks' guideline is
  P·T ≈ the closed-loop response time ("Choose Sample Time and Horizons",
  MPC Toolbox documentation [recalled]); a horizon-limited design settles in
  about P·T/1.5, while a horizon far shorter than τ leaves the loop set by
  weights whose predictions never see the loop act. The check warns below
  :data:`HORIZON_WARN` and fails below :data:`HORIZON_FAIL` of τ
  [reconstructed: trainctl's bounds, placed so that the book's T = 20 s,
  P = 4 (P·T/τ ≈ 0.8) and the well-sampled T = 0.05 s, P = 40 (≈ 0.07) pass
  and T = 0.05 s, P = 4 (≈ 0.0015) fails].
- ``qp_conditioning``: condition number of the centralised condensed QP's
  Hessian H = GᵀQG + R (design units), with the condition number after a
  diagonal (Jacobi) scaling as the scaling hint. Double precision has about
  16 digits; a solve loses about log10(cond) of them, and first-order
  solvers (OSQP's ADMM) slow down on ill-conditioned problems (Stellato et
  al. 2020, OSQP paper §5.1, which is why OSQP equilibrates the data
  [recalled]). Warn at :data:`COND_WARN`, fail at :data:`COND_FAIL`.
- ``rate_limit_conflict``: the force the train needs along the reference
  (the quasi-static split with the line resistance,
  :func:`~trainctl.analysis.feasibility.route_forces`) against the rate
  limit, sample by sample: a steady ramp that needs more than the limit
  fails (the MPC cannot follow it); jumps at the reference's corners and at
  section entries that need more warn (the MPC lags there).
- ``coupler_force_conflict``: the static coupler forces of the formation
  along the route (every section, the acceleration phases) against the
  coupler-force bound: a bound below them is violated in steady state and
  fails.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from trainctl.analysis.check import Check

if TYPE_CHECKING:
    from trainctl.controllers.mpc.family import MPCFamilyDesign

__all__ = [
    "COND_FAIL", "COND_WARN", "HORIZON_FAIL", "HORIZON_WARN", "coupler_force_check",
    "horizon_check", "qp_conditioning_check", "rate_limit_check",
]

HORIZON_WARN = 0.05
"""P·T / τ below which the horizon is short (warn), τ the closed-loop speed time constant."""

HORIZON_FAIL = 0.01
"""P·T / τ below which the horizon is far too short (fail)."""

COND_WARN = 1e6
"""Hessian condition number from which the QP is ill-conditioned (warn)."""

COND_FAIL = 1e12
"""Hessian condition number from which a double-precision solve keeps < 4 digits (fail)."""

_MAX_SAMPLES = 200_000
"""Most sample instants the rate check evaluates (longer runs are strided)."""

KN = 1e3


def horizon_check(design: MPCFamilyDesign) -> Check:
    """``prediction_horizon``: P·T against the closed-loop speed time constant τ.

    Parameters
    ----------
    design : MPCFamilyDesign
        The family's design.

    Returns
    -------
    Check
        Value P·T / τ, threshold :data:`HORIZON_WARN`.

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> check = horizon_check(build_design(load_scenario("crh2-dmpc")).family("mpc"))
    >>> check.status, round(check.details["tau_s"])
    ('pass', 101)
    """
    T = design.model.settings.sample_time
    P = design.mpc.prediction_horizon
    tau, eigenvalue = _speed_mode(design)
    span = P * T
    ratio = span / tau if math.isfinite(tau) else 0.0
    details = {"horizon_s": span, "tau_s": tau if math.isfinite(tau) else None,
               "eigenvalue": [eigenvalue.real, eigenvalue.imag], "ratio": ratio,
               "warn_below": HORIZON_WARN, "fail_below": HORIZON_FAIL}
    sim = design.scenario.simulation
    settle = ""
    if sim is not None and math.isfinite(tau) and 3 * tau > sim.settle_time:
        settle = f"; 3τ = {3 * tau:.4g} s exceeds the settle_time {sim.settle_time:g} s"
    message = (f"P·T = {P} × {T:g} s = {span:.4g} s covers {100 * ratio:.3g} % of the "
               f"closed-loop speed time constant τ = {tau:.4g} s{settle}")
    if ratio >= HORIZON_WARN:
        return Check(name="prediction_horizon", status="pass", value=ratio,
                     threshold=HORIZON_WARN, unit="", message=message, details=details)
    status = "fail" if ratio < HORIZON_FAIL else "warn"
    if not math.isfinite(tau):
        message = (f"the closed loop's speed mode does not decay (|λ| = {abs(eigenvalue):.6g}):"
                   f" P·T = {span:.4g} s cannot cover it")
    need = math.ceil(HORIZON_WARN * tau / T) if math.isfinite(tau) else None
    steps = f"; today's τ asks for P ≥ {need}, and τ shortens as P grows" if need else ""
    return Check(name="prediction_horizon", status=status, value=ratio, threshold=HORIZON_WARN,
                 unit="", message=message,
                 hint=f"lengthen the prediction horizon until P·T ≥ {100 * HORIZON_WARN:g} % of τ"
                 f"{steps} (or sample slower where the coupler modes allow): predictions that "
                 "end long before the loop settles never see the controller act",
                 details=details)


def qp_conditioning_check(design: MPCFamilyDesign) -> Check:
    """``qp_conditioning``: condition number of the centralised QP Hessian.

    Parameters
    ----------
    design : MPCFamilyDesign
        The family's design.

    Returns
    -------
    Check
        Value cond(H), threshold :data:`COND_WARN`; details with the
        condition number after diagonal scaling.

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> check = qp_conditioning_check(build_design(load_scenario("crh2-dmpc")).family("mpc"))
    >>> check.status, round(check.value, 2)
    ('pass', 1.74)
    """
    from trainctl.controllers.mpc.theory.mpc import prediction

    H = prediction(design.mpc).hessian()
    cond = float(np.linalg.cond(H))
    d = 1 / np.sqrt(np.diag(H))
    scaled = float(np.linalg.cond(H * d[:, None] * d[None, :]))
    details = {"condition_number": cond, "scaled_condition_number": scaled,
               "size": int(H.shape[0]), "warn_from": COND_WARN, "fail_from": COND_FAIL}
    message = (f"centralised QP Hessian ({H.shape[0]} × {H.shape[0]}): condition number "
               f"{cond:.3g} ({scaled:.3g} after diagonal scaling)")
    if cond < COND_WARN:
        return Check(name="qp_conditioning", status="pass", value=cond, threshold=COND_WARN,
                     unit="", message=message, details=details)
    if scaled < cond / 100:
        hint = ("the spread is in the scales of the decision variables: express the weights "
                "in the design units (r_per_kn2, q per kN²) or rescale them; diagonal scaling "
                f"alone brings it to {scaled:.3g}")
    else:
        hint = ("the moves are nearly collinear: raise R (it regularises H), shorten the "
                "control horizon M, or sample slower")
    status = "fail" if cond >= COND_FAIL else "warn"
    return Check(name="qp_conditioning", status=status, value=cond, threshold=COND_WARN,
                 unit="", message=message, hint=hint, details=details)


def rate_limit_check(design: MPCFamilyDesign) -> Check:
    """``rate_limit_conflict``: the force the reference needs per sample against the rate limit.

    Parameters
    ----------
    design : MPCFamilyDesign
        The family's design.

    Returns
    -------
    Check
        Value: the largest change per sample of a vehicle's needed force
        [kN]; threshold the rate limit [kN].

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc").replace("controller.rate_limit_kn", 2.0)
    >>> check = rate_limit_check(build_design(scenario).family("mpc"))
    >>> check.status, round(check.details["jump"]["kn"], 2)
    ('warn', 8.96)
    """
    limit = design.settings.rate_limit
    sim = design.scenario.simulation
    if not math.isfinite(limit) or sim is None:
        why = "no rate limit" if not math.isfinite(limit) else "no [simulation] reference"
        return Check(name="rate_limit_conflict", status="pass", value=None,
                     threshold=None if not math.isfinite(limit) else limit / KN, unit="kN",
                     message=f"{why}: nothing to compare")
    steady, jump = _force_steps(design)
    details = {"steady": steady, "jump": jump, "rate_limit_kn": limit / KN}
    worst = max(steady["kn"], jump["kn"])
    where = "; ".join(f"{kind} {d['kn']:.4g} kN (vehicle {d['vehicle']}, t = {d['time']:.6g} s)"
                      for kind, d in (("steady ramp", steady), ("jump", jump)) if d["kn"] > 0)
    message = (f"largest change of a vehicle's needed force per sample: {where or '0 kN'}; "
               f"rate limit {limit / KN:g} kN")
    if steady["kn"] > limit / KN * (1 + 1e-9):
        return Check(name="rate_limit_conflict", status="fail", value=worst,
                     threshold=limit / KN, unit="kN", message=message,
                     hint="the reference's ramp needs faster force changes than rate_limit_kn "
                     "allows, so the MPC cannot follow it: raise rate_limit_kn or ramp the "
                     "reference more gently", details=details)
    if jump["kn"] > limit / KN * (1 + 1e-9):
        lag = math.ceil(jump["kn"] / (limit / KN))
        return Check(name="rate_limit_conflict", status="warn", value=worst,
                     threshold=limit / KN, unit="kN", message=message,
                     hint=f"at the reference's corners and section entries the needed force "
                     f"jumps by more than the rate limit: the MPC lags there for about {lag} "
                     "samples; round the reference's corners or raise rate_limit_kn",
                     details=details)
    return Check(name="rate_limit_conflict", status="pass", value=worst, threshold=limit / KN,
                 unit="kN", message=message, details=details)


def coupler_force_check(design: MPCFamilyDesign) -> Check:
    """``coupler_force_conflict``: static coupler forces along the route against the bound.

    Parameters
    ----------
    design : MPCFamilyDesign
        The family's design.

    Returns
    -------
    Check
        Value: the largest static |coupler force| [kN]; threshold the
        coupler-force bound [kN].

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> check = coupler_force_check(build_design(load_scenario("crh2-dmpc")).family("mpc"))
    >>> check.status, round(check.value, 3)
    ('pass', 7.564)
    """
    from trainctl.analysis.feasibility import route_forces

    limit = design.settings.coupler_force_limit
    train = design.scenario.train
    if not math.isfinite(limit) or train.n_couplers == 0:
        return Check(name="coupler_force_conflict", status="pass", value=None, threshold=None,
                     unit="kN", message="no coupler-force bound: nothing to compare")
    route = route_forces(design.scenario)
    forces = np.abs(route.coupler_forces)
    k, c = np.unravel_index(int(np.argmax(forces)), forces.shape)
    peak = float(forces[k, c]) / KN
    when = (f"t = {route.times[k]:.6g} s" if route.mode == "reference"
            else f"cruise on section {int(route.sections[k, c]) + 1}")
    details = {"max_static_kn": peak, "coupler": int(c) + 1, "limit_kn": limit / KN,
               "mode": route.mode}
    message = (f"largest static coupler force {peak:.4g} kN (coupler {c + 1}, {when}, "
               f"{route.speeds[k] * 3.6:.4g} km/h) against the bound {limit / KN:g} kN "
               f"({100 * peak / (limit / KN):.3g} %)")
    if peak > limit / KN * (1 + 1e-9):
        return Check(name="coupler_force_conflict", status="fail", value=peak,
                     threshold=limit / KN, unit="kN", message=message,
                     hint="the soft bound is violated even in steady state, so its penalty "
                     "fights the tracking: raise coupler_force_limit_kn above the static "
                     "forces or spread the traction differently (traction_share)",
                     details=details)
    return Check(name="coupler_force_conflict", status="pass", value=peak, threshold=limit / KN,
                 unit="kN", message=message, details=details)


# -- helpers ------------------------------------------------------------------------------------
def _speed_mode(design: MPCFamilyDesign) -> tuple[float, complex]:
    """Time constant [s] and eigenvalue of the centralised loop's common-speed mode."""
    A = design.analysis.closed_loop_centralised
    n, nx = design.model.n_vehicles, design.model.n_states
    lam, vec = np.linalg.eig(A)
    states = vec[:nx]
    norm = np.linalg.norm(states, axis=0)
    share = np.abs(states[:n].sum(axis=0)) / (np.sqrt(n) * np.where(norm > 0, norm, 1.0))
    k = int(np.argmax(share))
    mag = float(abs(lam[k]))
    T = design.model.settings.sample_time
    tau = -T / math.log(mag) if 0 < mag < 1 else (math.inf if mag >= 1 else 0.0)
    return tau, complex(lam[k])


def _force_steps(design: MPCFamilyDesign) -> tuple[dict[str, float], dict[str, float]]:
    """Largest per-sample change of a needed force on steady ramps and at jumps [kN]."""
    from trainctl.analysis.feasibility import route_forces

    scenario = design.scenario
    sim = scenario.simulation
    assert sim is not None
    T = scenario.model.sample_time
    steps = sim.n_steps(T)
    stride = max(1, math.ceil(steps / _MAX_SAMPLES))
    times = np.arange(0, steps + 1, stride, dtype=np.float64) * T
    route = route_forces(scenario, times)
    change = np.abs(np.diff(route.inputs, axis=0)) / stride / KN
    corners = np.asarray(sim.reference_times, dtype=float)
    crosses = (times[:-1, None] < corners[None, :]) & (corners[None, :] <= times[1:, None])
    events = crosses.any(axis=1) | np.any(np.diff(route.sections, axis=0) != 0, axis=1)
    return (_largest(change, ~events, times), _largest(change, events, times))


def _largest(change: np.ndarray, rows: np.ndarray, times: np.ndarray) -> dict[str, float]:
    picked = np.where(rows[:, None], change, 0.0)
    if picked.size == 0:
        return {"kn": 0.0, "vehicle": 0, "time": 0.0}
    k, i = np.unravel_index(int(np.argmax(picked)), picked.shape)
    return {"kn": float(picked[k, i]), "vehicle": int(i) + 1, "time": float(times[k])}
