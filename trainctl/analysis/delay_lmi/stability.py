# Delay-dependent stability certificates (Lyapunov–Krasovskii with Jensen's inequality).
"""The Lyapunov–Krasovskii stability LMI Ξ(h) ≺ 0 for ẋ = A x + A_d x(t − τ), and the
largest delay bound it certifies (a bisection on h).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from trainctl.analysis.hinf.bounded_real import _solver_name, solve_quietly
from trainctl.exceptions import DimensionError, ModelError

if TYPE_CHECKING:
    import cvxpy as cp

__all__ = [
    "DELAY_KINDS", "DelayCertificate", "KrasovskiiProblem", "MaxCertifiedDelay", "krasovskii_lmi",
    "max_certified_delay",
]

Array = NDArray[np.float64]

DELAY_KINDS = ("constant", "varying")
"""Constant delays in [0, h], or any time-varying delay τ(t) ∈ [0, h]."""


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
