# A certified L2 gain (H∞ bound) for every delay in [0, τ_max], by the Krasovskii LMI.
"""The delay-dependent bounded-real LMI: a certified bound ‖s‖₂ < γ‖w‖₂ for every delay
in [0, h] (:func:`delay_hinf_gamma`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.analysis.delay_lmi.stability import _balance, _kind, _pair, _tau
from trainctl.analysis.hinf.bounded_real import (
    _solver_name,
    certified_level,
    parameter_terms,
    solve_quietly,
)
from trainctl.exceptions import DimensionError, ModelError

if TYPE_CHECKING:
    import cvxpy as cp

__all__ = ["LK_MARGIN", "DelayHinf", "DelayHinfProblem", "delay_hinf_gamma"]

Array = NDArray[np.float64]

LK_MARGIN = 1e-7
"""ε of the strict LMIs of :func:`delay_hinf_gamma` (block ⪯ −εI, P, Q, R ⪰ εI), balanced data."""


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
