# Delay-dependent LMI certificates (Lyapunov–Krasovskii with Jensen's inequality) in cvxpy.
"""Certified delay bounds for ẋ = A x(t) + A_d x(t − τ) (+ B_w w, s = Cx + Dw).

:mod:`trainctl.analysis.delay` finds where the loop loses stability (Padé,
the *exact-ish* margin). This module gives *certificates*: a
Lyapunov–Krasovskii functional

    V = xᵀPx + ∫_{t−τ}^{t} xᵀQx ds + h ∫_{−h}^{0} ∫_{t+θ}^{t} ẋᵀRẋ ds dθ,   h = τ_max,

whose derivative is negative along every solution when one LMI in
(P, Q, R) holds. With Jensen's inequality, for τ ∈ (0, h],
h ∫_{t−h}^{t} ẋᵀRẋ ≥ h ∫_{t−τ}^{t} ẋᵀRẋ ≥ (h/τ)|x − x_τ|²_R ≥ |x − x_τ|²_R,
so, with ξ = (x, x_τ) and ẋ = A x + A_d x_τ,

    V̇ ≤ ξᵀ( [[PA + AᵀP + Q − R, PA_d + R], [A_dᵀP + R, −Q − R]]
           + h² [A, A_d]ᵀ R [A, A_d] ) ξ,

and, by a Schur complement, V̇ < 0 when

    Ξ(h) = [[PA + AᵀP + Q − R, PA_d + R, h AᵀR],
            [A_dᵀP + R, −Q − R, h A_dᵀR],
            [h RA, h RA_d, −R]] ≺ 0,   P ≻ 0, Q ⪰ 0, R ≻ 0.

What it certifies:

- ``delay="constant"``: asymptotic stability for every *constant* delay
  τ ∈ [0, h] (τ = 0 too: [I, I] Ξ [I; I] ≺ 0 makes A + A_d Hurwitz);
- ``delay="varying"``: Q = 0, which removes the only term that needed τ
  constant (d/dt ∫_{t−τ(t)}^{t} xᵀQx contains (1 − τ̇)); the certificate
  then holds for any time-varying delay τ(t) ∈ [0, h], however fast it
  varies (the random GSM-R delays of seed 003). More conservative.

The condition is sufficient only (Jensen's inequality loses a factor: for
ẋ = −a x(t − τ) the exact bound is π/(2a) and this LMI certifies √2/a
for constant delays, 90 % of it, and 1/a for varying ones, see
:func:`max_certified_delay`), so a certified h is always below
the true margin; it is never above it.

:func:`max_certified_delay` bisects on h. h enters Ξ only as h·R A and
h·R A_d (a parameter times a variable), which is DPP, so one cvxpy problem
with h as a ``cp.Parameter`` is compiled once and re-solved. Measured on
the heavy-haul loop (7 states, a 21 × 21 LMI, Clarabel, a shared 2-core
machine): 50–55 ms per re-solve, of which Clarabel itself takes 35–40 ms,
against 65–75 ms for building and solving a fresh problem at every step;
at this size the solver dominates and the parameter saves the
canonicalisation, about a quarter of each step.

:func:`delay_hinf_gamma` adds a disturbance w and an output s: with ζ =
(x, x_τ, w) and V̇ + |s|² − γ²|w|² < 0 it certifies the L2 gain
‖s‖₂ < γ‖w‖₂ (zero initial function) for every delay in [0, h] (constant
or varying as above):

    [[PA + AᵀP + Q − R, PA_d + R, PB_w, h AᵀR, Cᵀ],
     [·, −Q − R, 0, h A_dᵀR, 0],
     [·, ·, −γ²I, h B_wᵀR, Dᵀ],
     [·, ·, ·, −R, 0],
     [·, ·, ·, ·, −I]] ≺ 0.

Every SDP runs on state-balanced data (one diagonal similarity for A and
A_d, ``scipy.linalg.matrix_balance`` of A + A_d), and every solution is
checked in floating point (eigenvalues of Ξ, P, Q, R) before it counts; a
solver status other than ``optimal`` is recorded, never ignored.

Examples
--------
>>> res = max_certified_delay([[0.0]], [[-1.0]])
>>> 0.9 < res.tau < math.pi / 2
True
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from trainctl.analysis.hinf import _solver_name, certified_level, parameter_terms, solve_quietly
from trainctl.exceptions import DimensionError, ModelError

if TYPE_CHECKING:
    import cvxpy as cp

__all__ = [
    "DELAY_KINDS", "LK_MARGIN", "DelayCertificate", "DelayHinf", "DelayHinfProblem",
    "KrasovskiiProblem",
    "MaxCertifiedDelay", "delay_hinf_gamma", "krasovskii_lmi", "max_certified_delay",
]

Array = NDArray[np.float64]

DELAY_KINDS = ("constant", "varying")
"""Constant delays in [0, h], or any time-varying delay τ(t) ∈ [0, h]."""

LK_MARGIN = 1e-7
"""ε of the strict LMIs of :func:`delay_hinf_gamma` (block ⪯ −εI, P, Q, R ⪰ εI), balanced data."""


def _pair(A: ArrayLike, A_d: ArrayLike, who: str) -> tuple[Array, Array]:
    Am = np.atleast_2d(np.asarray(A, dtype=float))
    Adm = np.atleast_2d(np.asarray(A_d, dtype=float))
    n = Am.shape[0]
    if Am.ndim != 2 or Am.shape != (n, n):
        raise DimensionError(f"{who}: 'A' must be a square (n, n) matrix (got shape "
                             f"{Am.shape}).")
    if Adm.shape != (n, n):
        raise DimensionError(f"{who}: 'A_d' must have the shape of A, ({n}, {n}) (got "
                             f"{Adm.shape}).")
    if not (np.all(np.isfinite(Am)) and np.all(np.isfinite(Adm))):
        raise ModelError(f"{who}: 'A' and 'A_d' must be finite (got NaN or inf).")
    return Am, Adm


def _kind(delay: str, who: str) -> str:
    if delay not in DELAY_KINDS:
        raise ModelError(f"{who}: 'delay' must be one of {DELAY_KINDS} (got {delay!r}).")
    return delay


def _tau(tau: float, name: str, who: str, *, positive: bool = True) -> float:
    ok = isinstance(tau, int | float | np.floating) and not isinstance(tau, bool) \
        and math.isfinite(tau) and (tau > 0 if positive else tau >= 0)
    if not ok:
        raise ModelError(f"{who}: '{name}' must be a finite number {'>' if positive else '>='} "
                         f"0 s (got {tau!r}).")
    return float(tau)


def _balance(A: Array, A_d: Array) -> Array:
    _, (scale, _) = scipy.linalg.matrix_balance(A + A_d, permute=False, separate=True)
    return np.asarray(scale, dtype=float)


@dataclass(frozen=True, kw_only=True)
class DelayCertificate:
    """One Lyapunov–Krasovskii certificate for delays in [0, tau_max].

    Parameters
    ----------
    tau_max : float
        h [s].
    certified : bool
        The LMI holds (checked in floating point).
    delay : str
        ``"constant"`` or ``"varying"`` (what is certified, module docstring).
    status : str
        cvxpy's status.
    solver : str
        Solver used.
    solve_time : float
        Wall time [s].
    max_eig : float
        Largest eigenvalue of Ξ at the solution, on the balanced data with
        tr P + tr Q + tr R = 1 (< 0 when certified; NaN without a solution).
    P, Q, R : ndarray or None
        The functional's matrices on the original state.
    message : str
        What happened.

    Examples
    --------
    ẋ = −x(t − τ) is stable for constant delays below π/2 s; the LMI certifies
    h = 1 s but not h = 2 s (unstable: beyond π/2).

    >>> cert = krasovskii_lmi([[0.0]], [[-1.0]], 1.0)
    >>> cert.certified, cert.status, cert.max_eig < 0, cert.P.shape
    (True, 'optimal', True, (1, 1))
    >>> bad = krasovskii_lmi([[0.0]], [[-1.0]], 2.0)
    >>> bad.certified, bad.P is None
    (False, True)
    """

    tau_max: float
    certified: bool
    delay: str
    status: str
    solver: str
    solve_time: float
    max_eig: float
    P: Array | None = None
    Q: Array | None = None
    R: Array | None = None
    message: str = ""


class KrasovskiiProblem:
    """The LK stability LMI of ẋ = Ax + A_dx(t − τ) with h = τ_max as a ``cp.Parameter``.

    Built (and compiled at the first solve) once; :meth:`certify` sets h and
    re-solves. The SDP is always feasible and bounded, so that the solver
    answers with a number rather than an infeasibility flag: minimise s
    subject to Ξ(h) ⪯ sI, P, Q, R ⪰ 0 (Q = 0 for ``"varying"``) and
    tr P + tr Q + tr R = 1 (the LMI is homogeneous; this fixes the scale),
    on balanced data. h is certified when the solution, checked in floating
    point, has max eig Ξ < 0 (then R ≻ 0 from the −R block, and P ≻ 0 with
    A + A_d Hurwitz from [I, I]Ξ[I; I] ≺ 0) and P, R ≻ 0; Q's rounding
    below zero is clipped before the check.

    Parameters
    ----------
    A, A_d : array_like
        (n, n) [1/s].
    delay : {"constant", "varying"}
        What the certificate covers.
    solver : str or None
        cvxpy solver (None: Clarabel, else SCS).

    Examples
    --------
    >>> prob = KrasovskiiProblem([[0.0]], [[-1.0]])
    >>> prob.certify(0.5).certified, prob.certify(2.0).certified
    (True, False)
    """

    def __init__(self, A: ArrayLike, A_d: ArrayLike, *, delay: str = "constant",
                 solver: str | None = None) -> None:
        import cvxpy as cp

        Am, Adm = _pair(A, A_d, "KrasovskiiProblem")
        self.delay = _kind(delay, "KrasovskiiProblem")
        self.solver = _solver_name(solver)
        d = _balance(Am, Adm)
        self._d = d
        self._A = Am / d[:, None] * d[None, :]
        self._Ad = Adm / d[:, None] * d[None, :]
        n = Am.shape[0]
        self.n = n
        self.h = cp.Parameter(nonneg=True, name="tau_max")
        P = cp.Variable((n, n), symmetric=True, name="P")
        R = cp.Variable((n, n), symmetric=True, name="R")
        Q = cp.Variable((n, n), symmetric=True, name="Q") if self.delay == "constant" else None
        self._P, self._Q, self._R = P, Q, R
        A_, Ad = self._A, self._Ad
        Qe = Q if Q is not None else np.zeros((n, n))
        PA = P @ A_
        PAd = P @ Ad
        xi = cp.bmat([
            [PA + PA.T + Qe - R, PAd + R, self.h * (A_.T @ R)],
            [PAd.T + R, -Qe - R, self.h * (Ad.T @ R)],
            [self.h * (R @ A_), self.h * (R @ Ad), -R]])
        self._s = cp.Variable(name="s")
        cons = [P >> 0, R >> 0, 0.5 * (xi + xi.T) << self._s * np.eye(3 * n)]
        trace = cp.trace(P) + cp.trace(R)
        if Q is not None:
            cons.append(Q >> 0)
            trace = trace + cp.trace(Q)
        cons.append(trace == 1.0)
        self._problem = cp.Problem(cp.Minimize(self._s), cons)
        if not self._problem.is_dpp():  # pragma: no cover - guards the construction
            raise ModelError("KrasovskiiProblem: the SDP is not DPP.")
        self.solve_times: list[float] = []

    @property
    def problem(self) -> cp.Problem:
        """The cvxpy problem."""
        return self._problem

    def xi(self, h: float, P: Array, Q: Array | None, R: Array) -> Array:
        """Ξ(h) on the balanced data for given (balanced) P, Q, R.

        Parameters
        ----------
        h : float
            The delay bound τ_max [s], >= 0.
        P : ndarray
            (n, n) symmetric, on the balanced state.
        Q : ndarray or None
            (n, n) symmetric, on the balanced state; None: zero (the
            ``"varying"`` functional has no Q).
        R : ndarray
            (n, n) symmetric, on the balanced state.

        Returns
        -------
        ndarray
            (3n, 3n) the LK block matrix Ξ(h) (module docstring); the
            certificate needs it negative definite.
        """
        n = self.n
        A_, Ad = self._A, self._Ad
        Qe = Q if Q is not None else np.zeros((n, n))
        return np.asarray(np.block([
            [P @ A_ + A_.T @ P + Qe - R, P @ Ad + R, h * A_.T @ R],
            [Ad.T @ P + R, -Qe - R, h * Ad.T @ R],
            [h * R @ A_, h * R @ Ad, -R]]), dtype=float)

    def certify(self, tau_max: float) -> DelayCertificate:
        """Solve at h = ``tau_max`` [s] and check the solution in floating point.

        Parameters
        ----------
        tau_max : float
            h [s], >= 0: the delays certified are [0, h].

        Returns
        -------
        DelayCertificate
            Certified or not, with the solver's status and time; P, Q, R
            (on the original state) only when certified (Q None for
            ``"varying"``).

        Raises
        ------
        ModelError
            If ``tau_max`` is not a finite number >= 0.
        """

        h = _tau(tau_max, "tau_max", "KrasovskiiProblem.certify", positive=False)
        self.h.value = h
        start = time.perf_counter()
        status = solve_quietly(self._problem, self.solver)
        elapsed = time.perf_counter() - start
        self.solve_times.append(elapsed)
        P = self._P.value
        R = self._R.value
        Q = None if self._Q is None else self._Q.value
        if P is None or R is None or (self._Q is not None and Q is None) \
                or status not in ("optimal", "optimal_inaccurate"):
            return DelayCertificate(tau_max=h, certified=False, delay=self.delay, status=status,
                                    solver=self.solver, solve_time=elapsed, max_eig=math.nan,
                                    message=f"no certificate at τ_max = {h:.6g} s: solver "
                                    f"status {status}")
        Pv = 0.5 * (np.asarray(P) + np.asarray(P).T)
        Rv = 0.5 * (np.asarray(R) + np.asarray(R).T)
        Qv = None
        if Q is not None:
            # Q ⪰ 0 is what V needs: clip the solver's rounding below zero, then check Ξ with it
            w, V = np.linalg.eigh(0.5 * (np.asarray(Q) + np.asarray(Q).T))
            Qv = (V * np.clip(w, 0.0, None)) @ V.T
        X = self.xi(h, Pv, Qv, Rv)
        top = float(np.max(np.linalg.eigvalsh(0.5 * (X + X.T))))
        ok = (top < 0.0 and float(np.min(np.linalg.eigvalsh(Pv))) > 0.0
              and float(np.min(np.linalg.eigvalsh(Rv))) > 0.0)
        d = self._d

        def back(M: Array | None) -> Array | None:
            return None if M is None else M / d[:, None] / d[None, :]

        if not ok:
            return DelayCertificate(tau_max=h, certified=False, delay=self.delay, status=status,
                                    solver=self.solver, solve_time=elapsed, max_eig=top,
                                    message=f"the solver's (P, Q, R) at τ_max = {h:.6g} s does "
                                    f"not verify (max eig Ξ = {top:.3g})")
        note = "" if status == "optimal" else f" (solver status {status}; verified anyway)"
        return DelayCertificate(tau_max=h, certified=True, delay=self.delay, status=status,
                                solver=self.solver, solve_time=elapsed, max_eig=top,
                                P=back(Pv), Q=back(Qv), R=back(Rv),
                                message=f"certified for {self.delay} delays in [0, {h:.6g}] s"
                                f"{note}")


def krasovskii_lmi(A: ArrayLike, A_d: ArrayLike, tau_max: float, *, delay: str = "constant",
                   solver: str | None = None) -> DelayCertificate:
    """One LK certificate of ẋ = Ax + A_dx(t − τ) for delays in [0, tau_max] (module docstring).

    Parameters
    ----------
    A, A_d : array_like
        (n, n) [1/s].
    tau_max : float
        h [s], >= 0.
    delay : {"constant", "varying"}
        Constant delays, or any time-varying τ(t) ∈ [0, h].
    solver : str or None
        cvxpy solver (None: Clarabel).

    Returns
    -------
    DelayCertificate

    Examples
    --------
    >>> krasovskii_lmi([[-2.0]], [[-1.0]], 100.0).certified  # stable for every delay
    True
    """
    return KrasovskiiProblem(A, A_d, delay=delay, solver=solver).certify(tau_max)


@dataclass(frozen=True, kw_only=True)
class MaxCertifiedDelay:
    """The largest τ_max the LK LMI certifies, by bisection.

    Parameters
    ----------
    tau : float
        Largest certified h [s] (0 when even a tiny h fails; ``tau_upper``
        when the search reached it certified).
    tau_failed : float
        Smallest h [s] tried that was not certified (inf when none).
    delay : str
        ``"constant"`` or ``"varying"``.
    certificate : DelayCertificate or None
        The certificate at ``tau``.
    solves : int
        SDP solves.
    first_solve_time : float
        Wall time of the first solve, including cvxpy's compilation [s].
    resolve_time : float
        Mean wall time of the later re-solves [s] (nan after a single solve).
    trouble : tuple of str
        Every solve whose status was not ``optimal`` (the problem is built
        feasible, so the bisection reads its answer from the certificate's
        value), e.g. a solver failure at the boundary, which counts as not
        certified.

    Examples
    --------
    ẋ = −2x − x(t − τ) is stable for every delay, so the search doubles up to
    ``tau_upper`` and never fails:

    >>> res = max_certified_delay([[-2.0]], [[-1.0]], tau_upper=10.0)
    >>> res.tau, res.tau_failed, res.certificate.certified  # [s]
    (10.0, inf, True)
    >>> res.to_dict()["tau_failed"]  # inf is written as None
    """

    tau: float
    tau_failed: float
    delay: str
    certificate: DelayCertificate | None
    solves: int
    first_solve_time: float
    resolve_time: float
    trouble: tuple[str, ...] = field(default=())

    def to_dict(self) -> dict[str, object]:
        """JSON-safe.

        Returns
        -------
        dict
            ``tau`` and ``tau_failed`` [s] (None when infinite),
            ``delay``, ``solves``, ``first_solve_time`` and
            ``resolve_time`` [s] (None after a single solve), and ``trouble``;
            the certificate is left out.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        return {"tau": f(self.tau), "tau_failed": f(self.tau_failed), "delay": self.delay,
                "solves": self.solves, "first_solve_time": self.first_solve_time,
                "resolve_time": f(self.resolve_time), "trouble": list(self.trouble)}


def max_certified_delay(A: ArrayLike, A_d: ArrayLike, *, delay: str = "constant",
                        tau_upper: float | None = None, rel_tol: float = 1e-3,
                        solver: str | None = None) -> MaxCertifiedDelay:
    """The largest h for which the LK LMI certifies ẋ = Ax + A_dx(t − τ), τ ∈ [0, h].

    From h₀ = 1/‖A_d‖₂ (clipped to ``tau_upper``), doubling while certified
    (halving while not, down to h₀·2⁻³⁰), then bisection to a relative
    ``rel_tol``; one :class:`KrasovskiiProblem` re-solved throughout.

    Parameters
    ----------
    A, A_d : array_like
        (n, n) [1/s].
    delay : {"constant", "varying"}
        What the certificate covers (module docstring).
    tau_upper : float or None
        Largest h tried [s] (None: 1e3 · h₀).
    rel_tol : float
        Relative width of the final bracket, in (0, 1).
    solver : str or None
        cvxpy solver.

    Returns
    -------
    MaxCertifiedDelay
        The certified bound [s] (never above the true delay margin).

    Examples
    --------
    ẋ = −x(t − τ): exact margin π/2 = 1.571 s for a constant delay.

    >>> res = max_certified_delay([[0.0]], [[-1.0]], rel_tol=1e-4)
    >>> round(res.tau, 3)  # √2: a·h = √2 for constant delays
    1.414
    >>> round(max_certified_delay([[0.0]], [[-1.0]], delay="varying", rel_tol=1e-4).tau, 3)
    1.0
    """
    Am, Adm = _pair(A, A_d, "max_certified_delay")
    _kind(delay, "max_certified_delay")
    if not (isinstance(rel_tol, float | int) and 0 < rel_tol < 1):
        raise ModelError(f"max_certified_delay: 'rel_tol' must be in (0, 1) (got {rel_tol!r}).")
    norm = float(np.linalg.norm(Adm, 2))
    if norm == 0.0:
        raise ModelError("max_certified_delay: 'A_d' is zero: no delayed term, nothing to "
                         "bound (check A alone for stability).")
    h0 = 1.0 / norm
    upper = 1e3 * h0 if tau_upper is None else _tau(tau_upper, "tau_upper",
                                                    "max_certified_delay")
    h0 = min(h0, upper)
    prob = KrasovskiiProblem(Am, Adm, delay=delay, solver=solver)
    trouble: list[str] = []
    best: DelayCertificate | None = None

    def run(h: float) -> DelayCertificate:
        nonlocal best
        cert = prob.certify(h)
        if cert.status != "optimal":
            trouble.append(f"τ_max={h:.6g} s: {cert.status}")
        if cert.certified and (best is None or h > best.tau_max):
            best = cert
        return cert

    lo, hi = 0.0, math.inf
    h = h0
    if run(h).certified:
        lo = h
        while lo < upper:
            h = min(2.0 * lo, upper)
            if run(h).certified:
                lo = h
            else:
                hi = h
                break
    else:
        hi = h
        for _ in range(30):
            h = 0.5 * hi
            if run(h).certified:
                lo = h
                break
            hi = h
    if lo > 0.0 and math.isfinite(hi):
        while hi - lo > rel_tol * hi:
            mid = 0.5 * (lo + hi)
            if run(mid).certified:
                lo = mid
            else:
                hi = mid
    times = prob.solve_times
    return MaxCertifiedDelay(tau=lo, tau_failed=hi, delay=delay, certificate=best,
                             solves=len(times), first_solve_time=times[0],
                             resolve_time=float(np.mean(times[1:])) if len(times) > 1 else
                             math.nan, trouble=tuple(trouble))


@dataclass(frozen=True, kw_only=True)
class DelayHinf:
    """A delay-dependent H∞ certificate: ‖s‖₂ < γ‖w‖₂ for every delay in [0, tau_max].

    Parameters
    ----------
    gamma : float
        Certified γ (recomputed in floating point from the solver's P, Q, R;
        inf when none).
    gamma_solver : float
        √t of the solver's objective.
    tau_max : float
        h [s].
    delay : str
        ``"constant"`` or ``"varying"``.
    status, solver : str
        cvxpy's status and the solver.
    solve_time : float
        [s].
    parameters : dict
        The parameter values of this solve.
    message : str
        What happened.

    Examples
    --------
    ẋ = −x(t − τ) + w, s = x: without delay the gain is max |1/(jω + 1)| = 1,
    and the certified γ grows as the delay range approaches the margin π/2 s.

    >>> res = delay_hinf_gamma([[0.0]], [[-1.0]], [[1.0]], [[1.0]], None, 0.0)
    >>> res.certified, round(res.gamma, 3)
    (True, 1.0)
    >>> g = [delay_hinf_gamma([[0.0]], [[-1.0]], [[1.0]], [[1.0]], None, h).gamma
    ...      for h in (0.5, 1.0)]
    >>> 1.0 < g[0] < g[1]
    True
    """

    gamma: float
    gamma_solver: float
    tau_max: float
    delay: str
    status: str
    solver: str
    solve_time: float
    parameters: dict[str, float] = field(default_factory=dict)
    message: str = ""

    @property
    def certified(self) -> bool:
        """A finite γ is certified."""
        return math.isfinite(self.gamma)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe.

        Returns
        -------
        dict
            ``gamma`` and ``gamma_solver`` [-] (None when not finite),
            ``tau_max`` [s], ``delay``, ``status``, ``solver``,
            ``solve_time`` [s], ``parameters`` (a copy), ``certified`` and
            ``message``.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        return {"gamma": f(self.gamma), "gamma_solver": f(self.gamma_solver),
                "tau_max": self.tau_max, "delay": self.delay, "status": self.status,
                "solver": self.solver, "solve_time": self.solve_time,
                "parameters": dict(self.parameters), "certified": self.certified,
                "message": self.message}


class DelayHinfProblem:
    """The delay-dependent H∞ SDP with affine parameters, built once, re-solved.

    ẋ = A(θ) x + A_d(θ) x(t − τ) + B_w(θ) w, s = Cx + Dw with
    A(θ) = A_0 + Σ_k θ_k A_k, A_d(θ) = A_d0 + Σ_k θ_k A_dk and
    B_w(θ) = B_w0 + Σ_k θ_k B_k, delays in [0, h] (h fixed: it multiplies R
    and the θ_k would multiply it too, which DPP forbids). The LMI of the
    module docstring in P, Q, R, t = γ²: every θ_k multiplies a variable
    (P A_k, h A_kᵀR, P A_dk, h A_dkᵀR, P B_k, h B_kᵀR), which is DPP.
    Strictness: P, R ⪰ εI, Q ⪰ εI (``"constant"``; Q = 0 for
    ``"varying"``), block ⪯ −εI, ε = :data:`LK_MARGIN`, on data balanced with
    one diagonal similarity (A + A_d(θ_ref)). γ is recomputed from the
    solution in floating point.

    Parameters
    ----------
    A, A_d : array_like
        (n, n) [1/s]; A is A_0, A_d is A_d0.
    B_w, C, D : array_like
        (n, m), (p, n), (p, m) (D None: 0); B_w is B_w0.
    tau_max : float
        h [s], >= 0.
    A_d_terms, B_terms : mapping of str to array_like
        Per parameter name, A_dk (n, n) and B_k (n, m).
    A_terms : mapping of str to array_like
        Per parameter name, A_k (n, n): the parameter's undelayed part
        (a feedback on current data beside the delayed one).
    reference : mapping of str to float
        Parameter values for the balancing (default 1 each).
    delay : {"constant", "varying"}
        What is certified.
    solver : str or None
        cvxpy solver (None: Clarabel).

    Examples
    --------
    >>> prob = DelayHinfProblem([[-2.0]], [[0.0]], [[1.0]], [[1.0]], None, 0.1,
    ...                         A_d_terms={"k": [[-1.0]]})
    >>> g1, g3 = prob.solve(k=1.0).gamma, prob.solve(k=3.0).gamma
    >>> 1 / 3 <= g1 < 0.4 and 1 / 5 <= g3 < g1
    True
    """

    def __init__(self, A: ArrayLike, A_d: ArrayLike, B_w: ArrayLike, C: ArrayLike,
                 D: ArrayLike | None, tau_max: float, *,
                 A_d_terms: Mapping[str, ArrayLike] | None = None,
                 B_terms: Mapping[str, ArrayLike] | None = None,
                 A_terms: Mapping[str, ArrayLike] | None = None,
                 reference: Mapping[str, float] | None = None, delay: str = "constant",
                 solver: str | None = None) -> None:
        import cvxpy as cp

        who = "DelayHinfProblem"
        Am, Adm = _pair(A, A_d, who)
        self.delay = _kind(delay, who)
        h = _tau(tau_max, "tau_max", who, positive=False)
        self.tau_max = h
        n = Am.shape[0]
        Bm = np.atleast_2d(np.asarray(B_w, dtype=float))
        Cm = np.atleast_2d(np.asarray(C, dtype=float))
        if Bm.ndim != 2 or Bm.shape[0] != n or Cm.ndim != 2 or Cm.shape[1] != n:
            raise DimensionError(f"{who}: 'B_w' must be ({n}, m) and 'C' (p, {n}) (got "
                                 f"{Bm.shape} and {Cm.shape}).")
        m, p = Bm.shape[1], Cm.shape[0]
        Dm = np.zeros((p, m)) if D is None else np.atleast_2d(np.asarray(D, dtype=float))
        if Dm.shape != (p, m):
            raise DimensionError(f"{who}: 'D' must be ({p}, {m}) (got {Dm.shape}).")
        if not (np.all(np.isfinite(Bm)) and np.all(np.isfinite(Cm))
                and np.all(np.isfinite(Dm))):
            raise ModelError(f"{who}: 'B_w', 'C' and 'D' must be finite (got NaN or inf).")
        At = parameter_terms(who, "A_terms", A_terms, (n, n))
        Adt = parameter_terms(who, "A_d_terms", A_d_terms, (n, n))
        Bt = parameter_terms(who, "B_terms", B_terms, (n, m))
        self.names: tuple[str, ...] = tuple(dict.fromkeys([*At, *Adt, *Bt]))
        ref = {k: 1.0 for k in self.names}
        ref.update(reference or {})
        A_ref = Am + sum((ref[k] * M for k, M in At.items()), np.zeros((n, n)))
        Ad_ref = Adm + sum((ref[k] * M for k, M in Adt.items()), np.zeros((n, n)))
        d = _balance(A_ref, Ad_ref)

        def sim(M: Array) -> Array:
            return M / d[:, None] * d[None, :]

        self.solver = _solver_name(solver)
        self.shape = (n, m, p)
        self._A, self._Ad0, self._B0 = sim(Am), sim(Adm), Bm / d[:, None]
        self._At = {k: sim(M) for k, M in At.items()}
        self._Adt = {k: sim(M) for k, M in Adt.items()}
        self._Bt = {k: M / d[:, None] for k, M in Bt.items()}
        self._C, self._D = Cm * d[None, :], Dm
        self.parameters = {k: cp.Parameter(name=k) for k in self.names}
        P = cp.Variable((n, n), symmetric=True, name="P")
        R = cp.Variable((n, n), symmetric=True, name="R")
        Q = cp.Variable((n, n), symmetric=True, name="Q") if self.delay == "constant" else None
        t = cp.Variable(name="t")
        self._P, self._Q, self._R, self._t = P, Q, R, t
        A_ = self._A
        PA = P @ A_
        hAR = h * (A_.T @ R)
        for k, M in self._At.items():
            PA = PA + self.parameters[k] * (P @ M)
            hAR = hAR + self.parameters[k] * (h * (M.T @ R))
        PAd = P @ self._Ad0
        hAdR = h * (self._Ad0.T @ R)
        for k, M in self._Adt.items():
            PAd = PAd + self.parameters[k] * (P @ M)
            hAdR = hAdR + self.parameters[k] * (h * (M.T @ R))
        PB = P @ self._B0
        hBR = h * (self._B0.T @ R)
        for k, M in self._Bt.items():
            PB = PB + self.parameters[k] * (P @ M)
            hBR = hBR + self.parameters[k] * (h * (M.T @ R))
        Qe = Q if Q is not None else np.zeros((n, n))
        Z = np.zeros
        Cw, Dw = self._C, self._D
        blocks = cp.bmat([
            [PA + PA.T + Qe - R, PAd + R, PB, hAR, Cw.T],
            [PAd.T + R, -Qe - R, Z((n, m)), hAdR, Z((n, p))],
            [PB.T, Z((m, n)), -t * np.eye(m), hBR, Dw.T],
            [hAR.T, hAdR.T, hBR.T, -R, Z((n, p))],
            [Cw, Z((p, n)), Dw, Z((p, n)), -np.eye(p)]])
        size = 3 * n + m + p
        eps = LK_MARGIN * np.eye(n)
        cons = [P >> eps, R >> eps, 0.5 * (blocks + blocks.T) << -LK_MARGIN * np.eye(size)]
        if Q is not None:
            cons.append(Q >> eps)
        self._problem = cp.Problem(cp.Minimize(t), cons)
        if not self._problem.is_dpp():  # pragma: no cover - guards the construction
            raise ModelError(f"{who}: the SDP is not DPP.")

    @property
    def problem(self) -> cp.Problem:
        """The cvxpy problem."""
        return self._problem

    def _values(self, values: Mapping[str, float]) -> dict[str, float]:
        unknown = set(values) - set(self.names)
        missing = set(self.names) - set(values)
        if unknown or missing:
            raise ModelError(f"DelayHinfProblem.solve: give exactly the parameters "
                             f"{list(self.names)} (unknown {sorted(unknown)}, missing "
                             f"{sorted(missing)}).")
        out: dict[str, float] = {}
        for k, v in values.items():
            if not (isinstance(v, int | float | np.floating) and math.isfinite(v)):
                raise ModelError(f"DelayHinfProblem.solve: parameter {k!r} must be a finite "
                                 f"number (got {v!r}).")
            out[k] = float(v)
        return out

    def solve(self, **values: float) -> DelayHinf:
        """Solve at the given parameter values; γ certified in floating point.

        Parameters
        ----------
        **values : float
            One finite value θ_k per parameter name of the problem (its
            ``names``), no other; none when it has no parameters.

        Returns
        -------
        DelayHinf
            The certified γ for delays in [0, tau_max] (inf when the
            solver found nothing or its solution does not verify), with the
            solver's status and time and the values given.

        Raises
        ------
        ModelError
            If a parameter is missing or unknown, or a value is not a
            finite number.
        """
        theta = self._values(values)
        for k, v in theta.items():
            self.parameters[k].value = v
        n, m, p = self.shape
        h = self.tau_max
        start = time.perf_counter()
        status = solve_quietly(self._problem, self.solver)
        elapsed = time.perf_counter() - start
        Ps, Rs, ts = self._P.value, self._R.value, self._t.value
        Qs = None if self._Q is None else self._Q.value
        if Ps is None or Rs is None or ts is None or (self._Q is not None and Qs is None) \
                or status not in ("optimal", "optimal_inaccurate"):
            return DelayHinf(gamma=math.inf, gamma_solver=math.nan, tau_max=h, delay=self.delay,
                             status=status, solver=self.solver, solve_time=elapsed,
                             parameters=theta, message=f"no certificate: solver status {status}")
        Pv = 0.5 * (Ps + Ps.T)
        Rv = 0.5 * (Rs + Rs.T)
        Qv = np.zeros((n, n)) if Qs is None else 0.5 * (Qs + Qs.T)
        A_ = self._A + sum((theta[k] * M for k, M in self._At.items()), np.zeros((n, n)))
        Ad = self._Ad0 + sum((theta[k] * M for k, M in self._Adt.items()), np.zeros((n, n)))
        Bw = self._B0 + sum((theta[k] * M for k, M in self._Bt.items()), np.zeros((n, m)))
        Cw, Dw = self._C, self._D
        Z = np.zeros
        M0 = np.block([
            [Pv @ A_ + A_.T @ Pv + Qv - Rv, Pv @ Ad + Rv, Pv @ Bw, h * A_.T @ Rv, Cw.T],
            [Ad.T @ Pv + Rv, -Qv - Rv, Z((n, m)), h * Ad.T @ Rv, Z((n, p))],
            [Bw.T @ Pv, Z((m, n)), Z((m, m)), h * Bw.T @ Rv, Dw.T],
            [h * Rv @ A_, h * Rv @ Ad, h * Rv @ Bw, -Rv, Z((n, p))],
            [Cw, Z((p, n)), Dw, Z((p, n)), -np.eye(p)]])
        tc = certified_level(M0, range(2 * n, 2 * n + m))
        ok = (math.isfinite(tc) and float(np.min(np.linalg.eigvalsh(Pv))) > 0.0
              and float(np.min(np.linalg.eigvalsh(Rv))) > 0.0
              and float(np.min(np.linalg.eigvalsh(Qv))) >= 0.0)
        gamma_solver = math.sqrt(max(float(ts), 0.0))
        if not ok:
            return DelayHinf(gamma=math.inf, gamma_solver=gamma_solver, tau_max=h,
                             delay=self.delay, status=status, solver=self.solver,
                             solve_time=elapsed, parameters=theta,
                             message="the solver's (P, Q, R) does not verify in floating point")
        gamma = math.sqrt(tc) * (1.0 + 1e-12)
        note = "" if status == "optimal" else f" (solver status {status}; verified anyway)"
        return DelayHinf(gamma=gamma, gamma_solver=gamma_solver, tau_max=h, delay=self.delay,
                         status=status, solver=self.solver, solve_time=elapsed,
                         parameters=theta,
                         message=f"certified L2 gain < {gamma:.6g} for {self.delay} delays in "
                         f"[0, {h:.6g}] s{note}")


def delay_hinf_gamma(A: ArrayLike, A_d: ArrayLike, B_w: ArrayLike, C: ArrayLike,
                     D: ArrayLike | None, tau_max: float, *, delay: str = "constant",
                     solver: str | None = None) -> DelayHinf:
    """The smallest γ the delay-dependent LK LMI certifies for delays in [0, tau_max].

    ẋ = Ax + A_dx(t − τ) + B_w w, s = Cx + Dw; one solve of
    :class:`DelayHinfProblem` without parameters. The γ returned is
    recomputed from the solution (the −γ²I block by a Schur complement,
    :func:`~trainctl.analysis.hinf.certified_level`); it bounds the L2 gain
    for every delay in the range, so it is at least the delay-free norm
    ‖C(sI − A − A_d)⁻¹B_w + D‖∞ and at least the norm at any fixed delay in
    the range.

    Parameters
    ----------
    A, A_d : array_like
        (n, n) [1/s].
    B_w, C, D : array_like
        (n, m), (p, n), (p, m) (D None: 0).
    tau_max : float
        h [s], >= 0.
    delay : {"constant", "varying"}
        What is certified.
    solver : str or None
        cvxpy solver.

    Returns
    -------
    DelayHinf

    Examples
    --------
    ẋ = −2x − x(t − τ) + w, s = x: the delay-free gain is 1/3.

    >>> res = delay_hinf_gamma([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], None, 0.1)
    >>> 1 / 3 <= res.gamma < 0.4
    True
    """
    return DelayHinfProblem(A, A_d, B_w, C, D, tau_max, delay=delay, solver=solver).solve()
