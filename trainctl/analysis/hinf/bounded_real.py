# The bounded-real lemma as a cvxpy SDP: a certified bound ‖G‖∞ ≤ γ.
"""The bounded-real lemma as an SDP in cvxpy (:class:`BoundedRealProblem`), and the
helpers the delay LMIs share with it (quiet solving, certified levels, parameter terms).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.analysis.hinf.balancing import _as_matrices, gramian_transform, state_balance
from trainctl.analysis.hinf.level_set import _sigma_max
from trainctl.exceptions import DimensionError, ModelError

if TYPE_CHECKING:
    import cvxpy as cp

__all__ = [
    "BRL_MARGIN", "CLARABEL_THREADS", "BoundedRealProblem", "BoundedRealResult",
    "bounded_real_gamma", "certified_level", "parameter_terms", "solve_quietly",
]

Array = NDArray[np.float64]

BRL_MARGIN = 1e-8
"""ε of the strict bounded-real LMI (M ⪯ −εI on the balanced, normalised data)."""


def certified_level(M0: Array, level: Sequence[int]) -> float:
    """Smallest t with M0 − t·E ≺ 0, E the identity on the indices ``level`` (else inf).

    An LMI that is linear in t = γ² with −tI on the diagonal block ``level``
    (and nothing else in that block) holds for t exactly when the rest R of
    M0 is negative definite and t > λ_max(−M_LR R⁻¹ M_RL) (Schur complement
    on R). This turns a solver's P into a certified γ in floating point.

    Parameters
    ----------
    M0 : ndarray
        Symmetric (k, k), the LMI at t = 0.
    level : sequence of int
        The indices of the −tI block.

    Returns
    -------
    float
        The level t (≥ 0), or inf when the rest of M0 is not negative definite.

    Examples
    --------
    [[−1, 1], [1, −t]] ≺ 0 for t > 1:

    >>> certified_level(np.array([[-1.0, 1.0], [1.0, 0.0]]), [1])
    1.0
    """
    M = 0.5 * (np.asarray(M0, dtype=float) + np.asarray(M0, dtype=float).T)
    k = M.shape[0]
    lv = np.asarray(list(level), dtype=int)
    rest = np.setdiff1d(np.arange(k), lv)
    Rm = M[np.ix_(rest, rest)]
    eig_r = np.linalg.eigvalsh(Rm) if rest.size else np.zeros(0)
    if rest.size and eig_r.max() >= -1e-14 * max(1.0, float(np.abs(eig_r).max())):
        return math.inf
    L = M[np.ix_(lv, lv)] - (M[np.ix_(lv, rest)] @ np.linalg.solve(Rm, M[np.ix_(rest, lv)])
                             if rest.size else 0.0)
    return max(float(np.max(np.linalg.eigvalsh(0.5 * (L + L.T)))), 0.0)


@dataclass(frozen=True, kw_only=True)
class BoundedRealResult:
    """A bounded-real certificate ‖G‖∞ ≤ γ.

    Parameters
    ----------
    gamma : float
        Certified γ [output unit per input unit]: recomputed in floating
        point from the solver's P (:func:`certified_level`), not the
        solver's objective; inf when nothing is certified.
    gamma_solver : float
        √t of the solver's objective (NaN without a solution).
    P : ndarray or None
        The certificate on the original state (V = xᵀPx for the original
        G; the LMI holds for it with γ), None when none.
    status : str
        cvxpy's status (``"optimal"``, ``"infeasible"``, ``"optimal_inaccurate"``,
        ``"solver_error: …"``).
    solver : str
        The solver used.
    solve_time : float
        Wall time of the solve [s].
    parameters : dict
        The parameter values of this solve.
    message : str
        What happened, for a report.

    Examples
    --------
    >>> res = bounded_real_gamma([[-2.0]], [[1.0]], [[1.0]])  # 1/(s + 2): ‖G‖∞ = 1/2
    >>> res.certified, round(res.gamma, 5), res.P.shape
    (True, 0.5, (1, 1))
    >>> bad = bounded_real_gamma([[1.0]], [[1.0]], [[1.0]])  # unstable: no certificate
    >>> bad.certified, bad.status, bad.P is None, bad.to_dict()["gamma"]
    (False, 'infeasible', True, None)
    """

    gamma: float
    gamma_solver: float
    P: Array | None
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
        """JSON-safe, without P.

        Returns
        -------
        dict
            ``gamma`` and ``gamma_solver`` [output unit per input unit]
            (None when not finite), ``status``, ``solver``, ``solve_time``
            [s], ``parameters`` (a copy), ``certified`` and ``message``.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        return {"gamma": f(self.gamma), "gamma_solver": f(self.gamma_solver),
                "status": self.status, "solver": self.solver, "solve_time": self.solve_time,
                "parameters": dict(self.parameters), "certified": self.certified,
                "message": self.message}


CLARABEL_THREADS = 1
"""Threads of Clarabel's factorisation in every trainctl solve (its ``max_threads``).

One, for two reasons. Clarabel factorises with faer on a global rayon thread
pool, which a forked process (a pool worker, :mod:`trainctl.run.pool`)
inherits without its threads: a multi-threaded solve there waits forever for
them (it hung the test suite's pool tests). And a parallel factorisation's
rounding depends on the number of threads, so the certificates' last digits
would depend on the machine. trainctl's LMIs are small enough that the
threads gained nothing (heavy-haul-hinf-delay's review took 6.4 s of CPU on one
thread against 7.1 s on two)."""


def solve_quietly(problem: cp.Problem, solver: str, **options: Any) -> str:
    """Solve a cvxpy problem and return its status; solver trouble becomes the status.

    cvxpy's "solution may be inaccurate" warning is swallowed because the
    status (``optimal_inaccurate``) says the same and every caller records
    it; a ``cvxpy.error.SolverError`` becomes ``"solver_error: …"``. Clarabel
    runs on :data:`CLARABEL_THREADS` unless ``max_threads`` is given.

    Parameters
    ----------
    problem : cvxpy.Problem
        The problem.
    solver : str
        Solver name.
    **options
        Passed to ``problem.solve``.

    Returns
    -------
    str
        The status.

    Examples
    --------
    >>> import cvxpy as cp
    >>> x = cp.Variable()
    >>> solve_quietly(cp.Problem(cp.Minimize(x), [x >= 2]), "CLARABEL"), round(float(x.value), 6)
    ('optimal', 2.0)
    >>> solve_quietly(cp.Problem(cp.Minimize(x), [x >= 2, x <= 1]), "CLARABEL")
    'infeasible'
    """
    import warnings

    import cvxpy as cp

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Solution may be inaccurate")
        if solver == cp.CLARABEL:
            options = {"max_threads": CLARABEL_THREADS, **options}
        try:
            problem.solve(solver=solver, **options)
        except cp.error.SolverError as exc:
            return f"solver_error: {str(exc).split('.')[0]}"
    return str(problem.status)


def _solver_name(solver: str | None) -> str:
    import cvxpy as cp

    if solver is None:
        return str(cp.CLARABEL) if cp.CLARABEL in cp.installed_solvers() else str(cp.SCS)
    if solver not in cp.installed_solvers():
        raise ModelError(f"'solver' must be an installed cvxpy solver, one of "
                         f"{sorted(cp.installed_solvers())} (got {solver!r}).")
    return solver


def parameter_terms(who: str, label: str, terms: Mapping[str, ArrayLike] | None,
                    shape: tuple[int, int]) -> dict[str, Array]:
    """The matrices multiplying each named parameter, checked: finite and of ``shape``.

    Parameters
    ----------
    who : str
        The caller, for the message.
    label : str
        The argument's name (``"A_terms"``, ...).
    terms : mapping of str to array_like or None
        Parameter name → matrix; None: none.
    shape : (int, int)
        The shape every matrix must have.

    Returns
    -------
    dict of str to ndarray
        The matrices as float arrays, in the given order.

    Raises
    ------
    DimensionError
        When a matrix has another shape or a non-finite entry.

    Examples
    --------
    >>> parameter_terms("demo", "A_terms", {"k": [[-1.0]]}, (1, 1))
    {'k': array([[-1.]])}
    >>> try:
    ...     parameter_terms("demo", "A_terms", {"k": np.eye(2)}, (1, 1))
    ... except DimensionError as err:
    ...     print(err)
    demo: A_terms['k'] must be a finite (1, 1) matrix (got shape (2, 2)).
    """
    out: dict[str, Array] = {}
    for name, M in (terms or {}).items():
        Mk = np.atleast_2d(np.asarray(M, dtype=float))
        if Mk.shape != shape or not np.all(np.isfinite(Mk)):
            raise DimensionError(f"{who}: {label}[{name!r}] must be a finite "
                                 f"({shape[0]}, {shape[1]}) matrix (got shape {Mk.shape}).")
        out[name] = Mk
    return out


class BoundedRealProblem:
    """The bounded-real SDP of an affinely parametrised system, built once, re-solved.

    A(θ) = A₀ + Σ_k θ_k A_k and B(θ) = B₀ + Σ_k θ_k B_k (C, D fixed); the
    SDP in P = Pᵀ and t = γ² is

        minimise t  s.t.  P ⪰ 0,
        [[A(θ)ᵀP + PA(θ), PB(θ), Cᵀ], [B(θ)ᵀP, −tI, Dᵀ], [C, D, −I]] ⪯ −εI,

    whose (1,1) block makes AᵀP + PA ≺ −CᵀC, hence P ≻ 0 and A Hurwitz; by
    the bounded-real lemma (Schur complement of −I) V = xᵀPx then satisfies
    V̇ + |s|² − γ²|w|² ≤ 0, i.e. ‖G‖∞ ≤ γ. Each θ_k is a ``cp.Parameter``
    multiplying the variable P (DPP: parameter-affine × parameter-free), so
    cvxpy compiles the problem once and a re-solve only swaps the data.

    The data are transformed once, with the same similarity for every θ:
    the diagonal :func:`state_balance` of the system at θ_ref, then (with
    ``balance="gramian"``, when it exists) the square-root balanced
    realisation of :func:`gramian_transform`; the outputs are divided by
    ``output_scale`` (so γ ≈ 1); ε = :data:`BRL_MARGIN` on those data.

    Parameters
    ----------
    A0 : array_like
        (n, n) [1/s].
    B0 : array_like
        (n, m).
    C, D : array_like
        (p, n), (p, m) (D None: 0).
    A_terms, B_terms : mapping of str to array_like
        Per parameter name, its A_k (n, n) and B_k (n, m); a name may appear
        in either or both.
    reference : mapping of str to float
        Parameter values for the balancing (default: 1 each).
    output_scale : float or None
        Positive divisor of C and D for the SDP (None: a crude estimate of
        the norm at ``reference``).
    solver : str or None
        cvxpy solver (None: Clarabel, else SCS).
    balance : {"gramian", "diagonal"}
        Coordinates of the SDP (the diagonal scaling alone, or followed by
        the Gramian balancing where it exists; ``balancing`` says which was
        used).
    fallback : bool
        When the first solver gives no verified certificate, try SCS
        (``eps=1e-9``); the result's ``message`` records both attempts.

    Examples
    --------
    γ of 1/(s + a) over a = 2 + θ, one compiled SDP:

    >>> prob = BoundedRealProblem([[-2.0]], [[1.0]], [[1.0]], None, A_terms={"a": [[-1.0]]})
    >>> [round(prob.solve(a=th).gamma, 5) for th in (0.0, 2.0)]
    [0.5, 0.25]
    """

    def __init__(self, A0: ArrayLike, B0: ArrayLike, C: ArrayLike, D: ArrayLike | None,
                 *, A_terms: Mapping[str, ArrayLike] | None = None,
                 B_terms: Mapping[str, ArrayLike] | None = None,
                 reference: Mapping[str, float] | None = None,
                 output_scale: float | None = None, solver: str | None = None,
                 balance: str = "gramian", fallback: bool = True) -> None:
        import cvxpy as cp

        if balance not in ("gramian", "diagonal"):
            raise ModelError(f"BoundedRealProblem: 'balance' must be 'gramian' or 'diagonal' "
                             f"(got {balance!r}).")
        self.balancing = "diagonal"
        self.fallback = bool(fallback)
        A, B, Cm, Dm = _as_matrices(A0, B0, C, D, "BoundedRealProblem")
        n, m = B.shape
        p = Cm.shape[0]
        At = parameter_terms("BoundedRealProblem", "A_terms", A_terms, (n, n))
        Bt = parameter_terms("BoundedRealProblem", "B_terms", B_terms, (n, m))
        self.names: tuple[str, ...] = tuple(dict.fromkeys([*At, *Bt]))
        ref = {k: 1.0 for k in self.names}
        ref.update(reference or {})
        A_ref = A + sum((ref[k] * M for k, M in At.items()), np.zeros((n, n)))
        B_ref = B + sum((ref[k] * M for k, M in Bt.items()), np.zeros((n, m)))
        d = state_balance(A_ref, B_ref, Cm)
        T, Ti = np.diag(d), np.diag(1.0 / d)
        if balance == "gramian":
            tg = gramian_transform(Ti @ A_ref @ T, Ti @ B_ref, Cm @ T)
            if tg is not None:
                T, Ti = T @ tg[0], tg[1] @ Ti
                self.balancing = "gramian"
        self._T, self._Ti = T, Ti

        def sim(M: Array) -> Array:
            return np.asarray(Ti @ M @ T, dtype=float)

        if output_scale is None:
            lam = np.linalg.eigvals(A_ref)
            Ab, Bb, Cb = sim(A_ref), Ti @ B_ref, Cm @ T
            vals = [float(np.linalg.norm(Dm, 2))]
            for w in [0.0] + [abs(z) for z in lam] + [abs(z.imag) for z in lam]:
                try:
                    vals.append(_sigma_max(Ab, Bb, Cb, Dm, 1j * float(w)))
                except np.linalg.LinAlgError:
                    continue
            output_scale = max([v for v in vals if math.isfinite(v)] + [0.0])
            if output_scale <= 0.0:
                output_scale = 1.0
        if not (math.isfinite(output_scale) and output_scale > 0):
            raise ModelError(f"BoundedRealProblem: 'output_scale' must be a finite number > 0 "
                             f"(got {output_scale!r}).")
        self.output_scale = float(output_scale)
        self.solver = _solver_name(solver)
        self.shape = (n, m, p)
        self._A0, self._B0 = sim(A), Ti @ B
        self._At = {k: sim(M) for k, M in At.items()}
        self._Bt = {k: Ti @ M for k, M in Bt.items()}
        self._C, self._D = Cm @ T / self.output_scale, Dm / self.output_scale

        self.parameters = {k: cp.Parameter(name=k) for k in self.names}
        P = cp.Variable((n, n), symmetric=True, name="P")
        t = cp.Variable(name="t")
        AP = self._A0.T @ P
        for k, M in self._At.items():
            AP = AP + self.parameters[k] * (M.T @ P)
        PB = P @ self._B0
        for k, M in self._Bt.items():
            PB = PB + self.parameters[k] * (P @ M)
        blocks = cp.bmat([[AP + AP.T, PB, self._C.T],
                          [PB.T, -t * np.eye(m), self._D.T],
                          [self._C, self._D, -np.eye(p)]])
        size = n + m + p
        self._P, self._t = P, t
        self._problem = cp.Problem(cp.Minimize(t), [
            P >> 0, 0.5 * (blocks + blocks.T) << -BRL_MARGIN * np.eye(size)])
        if not self._problem.is_dpp():  # pragma: no cover - guards the construction above
            raise ModelError("BoundedRealProblem: the SDP is not DPP.")

    @property
    def problem(self) -> cp.Problem:
        """The compiled cvxpy problem (for inspection)."""
        return self._problem

    def matrices(self, **values: float) -> tuple[Array, Array, Array, Array]:
        """(A(θ), B(θ), C, D) on the original coordinates.

        Parameters
        ----------
        **values : float
            One finite value θ_k per parameter name of the problem (its
            ``names``), no other; none when it has no parameters.

        Returns
        -------
        A : ndarray
            (n, n) A₀ + Σ_k θ_k A_k [1/s].
        B : ndarray
            (n, m) B₀ + Σ_k θ_k B_k.
        C : ndarray
            (p, n), unscaled.
        D : ndarray
            (p, m), unscaled.

        Raises
        ------
        ModelError
            If a parameter is missing or unknown, or a value is not a
            finite number.
        """
        theta = self._values(values, "matrices")
        A = self._A0 + sum((theta[k] * M for k, M in self._At.items()), np.zeros_like(self._A0))
        B = self._B0 + sum((theta[k] * M for k, M in self._Bt.items()), np.zeros_like(self._B0))
        T, Ti = self._T, self._Ti
        return (T @ A @ Ti, T @ B, self._C @ Ti * self.output_scale,
                self._D * self.output_scale)

    def _values(self, values: Mapping[str, float], method: str = "solve") -> dict[str, float]:
        unknown = set(values) - set(self.names)
        missing = set(self.names) - set(values)
        if unknown or missing:
            raise ModelError(f"BoundedRealProblem.{method}: give exactly the parameters "
                             f"{list(self.names)} (unknown {sorted(unknown)}, missing "
                             f"{sorted(missing)}).")
        out: dict[str, float] = {}
        for k, v in values.items():
            if not (isinstance(v, int | float | np.floating) and math.isfinite(v)):
                raise ModelError(f"BoundedRealProblem.{method}: parameter {k!r} must be a finite "
                                 f"number (got {v!r}).")
            out[k] = float(v)
        return out

    def solve(self, **values: float) -> BoundedRealResult:
        """Solve at the given parameter values and certify γ in floating point.

        Parameters
        ----------
        **values : float
            One finite value θ_k per parameter name of the problem (its
            ``names``), no other; none when it has no parameters.

        Returns
        -------
        BoundedRealResult
            The level; γ = inf with the reason when the solver finds no certificate (an
            unstable A(θ) makes the SDP infeasible) or the check fails;
            a non-optimal status is reported in ``status`` and ``message``.

        Raises
        ------
        ModelError
            If a parameter is missing or unknown, or a value is not a
            finite number.
        """
        import cvxpy as cp

        theta = self._values(values)
        for k, v in theta.items():
            self.parameters[k].value = v
        solvers = [self.solver]
        if self.fallback and self.solver != cp.SCS and cp.SCS in cp.installed_solvers():
            solvers.append(str(cp.SCS))
        notes: list[str] = []
        result: BoundedRealResult | None = None
        for solver in solvers:
            start = time.perf_counter()
            options: dict[str, Any] = {"eps": 1e-9, "max_iters": 200_000} \
                if solver == cp.SCS else {}
            status = solve_quietly(self._problem, solver, **options)
            elapsed = time.perf_counter() - start
            result = self._certify(theta, status, elapsed, solver)
            if result.certified:
                break
            notes.append(f"{solver}: {result.message}")
        assert result is not None
        if notes:
            text = "; ".join(notes)
            result = replace(result, message=f"{result.message} (after {text})"
                             if result.certified else text)
        return result

    def _certify(self, theta: dict[str, float], status: str, elapsed: float, solver: str
                 ) -> BoundedRealResult:
        n, m, p = self.shape
        P = self._P.value
        t = self._t.value
        if P is None or t is None or status not in ("optimal", "optimal_inaccurate"):
            return BoundedRealResult(gamma=math.inf, gamma_solver=math.nan, P=None,
                                     status=status, solver=solver, solve_time=elapsed,
                                     parameters=theta,
                                     message=f"no certificate: solver status {status}")
        Pt = 0.5 * (np.asarray(P) + np.asarray(P).T)
        A = self._A0 + sum((theta[k] * M for k, M in self._At.items()), np.zeros((n, n)))
        B = self._B0 + sum((theta[k] * M for k, M in self._Bt.items()), np.zeros((n, m)))
        M0 = np.block([[A.T @ Pt + Pt @ A, Pt @ B, self._C.T],
                       [B.T @ Pt, np.zeros((m, m)), self._D.T],
                       [self._C, self._D, -np.eye(p)]])
        tcert = certified_level(M0, range(n, n + m))
        pos = float(np.min(np.linalg.eigvalsh(Pt))) > 0.0
        gamma_solver = math.sqrt(max(float(t), 0.0)) * self.output_scale
        if not (pos and math.isfinite(tcert)):
            return BoundedRealResult(gamma=math.inf, gamma_solver=gamma_solver, P=None,
                                     status=status, solver=solver, solve_time=elapsed,
                                     parameters=theta,
                                     message="the solver's P does not verify (P ≻ 0 and "
                                     "AᵀP + PA + CᵀC ≺ 0 checked in floating point)")
        # a hair above the Schur bound so that the strict LMI holds at γ itself
        gamma = math.sqrt(tcert) * (1.0 + 1e-12) * self.output_scale
        P_orig = self._Ti.T @ Pt @ self._Ti * self.output_scale ** 2
        note = "" if status == "optimal" else f" (solver status {status}; verified anyway)"
        return BoundedRealResult(gamma=gamma, gamma_solver=gamma_solver, P=P_orig,
                                 status=status, solver=solver, solve_time=elapsed,
                                 parameters=theta,
                                 message=f"certified ‖G‖∞ ≤ {gamma:.6g}{note}")


def bounded_real_gamma(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike | None = None,
                       *, solver: str | None = None) -> BoundedRealResult:
    """The smallest γ the bounded-real lemma certifies for ẋ = Ax + Bw, s = Cx + Dw.

    One solve of :class:`BoundedRealProblem` without parameters: minimise
    t = γ² over P ⪰ 0 with [[AᵀP + PA, PB, Cᵀ], [BᵀP, −tI, Dᵀ], [C, D, −I]]
    ⪯ −εI. The bounded-real lemma is exact (‖G‖∞ < γ ⇔ a P ≻ 0 exists), so
    γ approaches ‖G‖∞ to within the solver tolerance; the γ returned is
    recomputed from the solver's P in floating point, so it is an upper
    bound whatever the solver's accuracy. Continuous systems only.

    Parameters
    ----------
    A, B, C, D : array_like
        (n, n) [1/s], (n, m), (p, n), (p, m) (D None: 0).
    solver : str or None
        cvxpy solver (None: Clarabel, SCS as fallback).

    Returns
    -------
    BoundedRealResult
        The level γ, the matrix P (V = xᵀPx) and the solver status.

    Examples
    --------
    >>> res = bounded_real_gamma([[-1.0, 0.0], [0.0, -4.0]], np.eye(2), np.eye(2))
    >>> round(res.gamma, 5), res.status
    (1.0, 'optimal')
    """
    return BoundedRealProblem(A, B, C, D, solver=solver).solve()
