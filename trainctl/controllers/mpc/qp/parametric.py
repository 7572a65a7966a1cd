# A parametric QP modelled once in cvxpy and re-solved fast.
"""Parametric quadratic programs for MPC: built once, re-solved many times.

Every MPC problem in trainctl (the core's, the train's centralised problem,
one coach's local problem) has the form::

    minimise    ½ zᵀ H z + gᵀ z + w1ᵀ s + ½ sᵀ diag(w2) s
    subject to  lb ≤ C z ≤ ub          (hard rows: input, rate, state bounds)
                hl - s ≤ F z ≤ hu + s  (soft rows: coupler forces, soft bounds), s ≥ 0

with constant matrices and the vectors g, lb, ub, hl, hu changing every
step. :class:`ParametricQP` models it once in cvxpy with those vectors as
``cp.Parameter`` s (checked DPP at build time) and offers two ways to solve:

``solve(..., path="cvxpy")``
    ``Problem.solve(warm_start=True)``: the plain re-solve, which pays
    cvxpy's per-solve canonicalisation (about 2 ms here).
``solve(..., path="fast")``
    The probed OSQP data of :class:`~trainctl.controllers.mpc.qp.fast.FastOSQP`:
    one matrix-vector product and a data update + solve, warm-started, by
    the QP solver ``solver`` chose: OSQP (ADMM, sparse) or DAQP (dual active
    set, dense; :class:`~trainctl.controllers.mpc.qp.dense.FastDAQP`) on the same
    data. ``solver="auto"`` takes DAQP up to :data:`DAQP_MAX_DECISIONS`
    decisions.

The solvers return the same solutions to OSQP's accuracy (tested to 1e-6).
"""

from __future__ import annotations

import copy
import sys
import time

import cvxpy as cp
import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.controllers.mpc.qp.dense import FastDAQP
from trainctl.controllers.mpc.qp.fast import (
    OSQP_SETTINGS,
    SOLVER_OUTPUT,
    FastOSQP,
    QPSolution,
    interrupt_record,
    pass_on_interrupt,
)
from trainctl.controllers.mpc.qp.status import from_cvxpy
from trainctl.exceptions import ModelError, SolverError

__all__ = ["DAQP_MAX_DECISIONS", "OSQP_SETTINGS", "QP_SOLVERS", "ParametricQP", "QPSolution",
           "choose_solver"]

QP_SOLVERS = ("auto", "osqp", "daqp")
"""QP solvers of the fast path: chosen by size, OSQP, DAQP."""

DAQP_MAX_DECISIONS = 240
"""Largest QP (decisions, slacks of soft rows not counted) that ``solver="auto"`` gives DAQP.

Measured (2026-11-30, 2 shared cores, both solvers interleaved on the identical
data of a closed loop from a 1 m/s error; centralised MPC with every coach in
the cost, T = 0.05 s, P = 40, M = 5, 50 kN coupler and 5 kN/step rate limits,
trains of the benchmark's T-M-M-T chain): OSQP fast path / DAQP path time per
QP = 11 (10 decisions), 51 (20), 168 (40), 430 (60), 774 (120), 272 (240), the
solutions equal to 6e-12 kN. No crossover was reached: DAQP's time grows
faster (0.34 ms at 120 decisions, 6.2 ms at 240) but OSQP's ADMM needs
thousands of iterations on these QPs. 240 is the largest size measured;
above it the dense matrices (rows x decisions) grow quadratically and OSQP
is kept until measured.
"""

Array = NDArray[np.float64]
PARAMETERS = ("g", "lb", "ub", "hl", "hu")
"""The parametric vectors, in the order of the stacked parameter vector."""


class ParametricQP:
    """A QP with fixed matrices and parametric vectors (module docstring).

    Parameters
    ----------
    H : ndarray
        Hessian (nz, nz), symmetric positive definite.
    C : ndarray
        Hard constraint rows (nh, nz); may have zero rows.
    F : ndarray
        Soft constraint rows (ns, nz); may have zero rows.
    soft_linear : float or array_like
        Linear slack penalty w1 (finite, >= 0) [cost per unit of violation];
        one number for every soft row or one per row.
    soft_quadratic : float or array_like
        Quadratic slack penalty w2 (finite, > 0); one number or one per row.
        Both are checked only when there are soft rows.
    name : str
        Label for error messages and variable names.
    fast : bool
        Build the fast path (probing) as well.
    solver : {"auto", "osqp", "daqp"}
        The fast path's QP solver (:func:`choose_solver`); the ``"cvxpy"``
        path always solves with OSQP through cvxpy.

    Raises
    ------
    ModelError
        If ``solver`` is unknown, or a slack penalty is not finite, negative
        (``soft_quadratic``: not positive) or of neither one nor ``ns`` entries.
    SolverError
        If the QP is not DPP.

    Examples
    --------
    >>> import numpy as np
    >>> qp = ParametricQP(np.eye(2), np.eye(2), np.zeros((0, 2)), name="demo")
    >>> sol = qp.solve(g=np.array([-2.0, 1.0]), lb=np.full(2, -0.5), ub=np.full(2, 0.5))
    >>> sol.status, sol.z.round(6).tolist()
    ('optimal', [0.5, -0.5])
    """

    def __init__(self, H: Array, C: Array, F: Array, *, soft_linear: float | ArrayLike = 1e3,
                 soft_quadratic: float | ArrayLike = 1e2, name: str = "qp",
                 fast: bool = True, solver: str = "osqp") -> None:
        if solver not in QP_SOLVERS:
            raise ModelError(f"{name}: 'solver' must be one of {QP_SOLVERS} (got {solver!r}).")
        self.nz = H.shape[0]
        self.nh, self.ns = C.shape[0], F.shape[0]
        self.name = name
        self._z = cp.Variable(self.nz, name=f"{name}.z")
        self._s = cp.Variable(self.ns, nonneg=True, name=f"{name}.s") if self.ns else None
        self._g = cp.Parameter(self.nz, name=f"{name}.g")
        self._lb = cp.Parameter(self.nh, name=f"{name}.lb")
        self._ub = cp.Parameter(self.nh, name=f"{name}.ub")
        self._hl = cp.Parameter(self.ns, name=f"{name}.hl")
        self._hu = cp.Parameter(self.ns, name=f"{name}.hu")
        H = 0.5 * (H + H.T)
        cost = 0.5 * cp.quad_form(self._z, cp.psd_wrap(H)) + self._g @ self._z
        cons: list[cp.Constraint] = []
        if self.nh:
            cons += [C @ self._z >= self._lb, C @ self._z <= self._ub]
        if self._s is not None:
            w1, w2 = _soft_weights(name, self.ns, soft_linear, soft_quadratic)
            linear, quadratic = _slack_penalty(self._s, w1, w2)
            cost = cost + linear + quadratic
            cons += [F @ self._z >= self._hl - self._s, F @ self._z <= self._hu + self._s]
        self.problem = cp.Problem(cp.Minimize(cost), cons)
        if not self.problem.is_dpp():
            raise SolverError(f"{name}: the QP is not DPP; a parameter multiplies another "
                              "parameter or a variable. Precompute such products in numpy.")
        self._all = dict(zip(PARAMETERS, (self._g, self._lb, self._ub, self._hl, self._hu),
                             strict=True))
        self._fast: FastOSQP | None = (FastOSQP(self.problem, self._all, self._z, self._s,
                                                name=name) if fast else None)
        self.solver = choose_solver(solver, self.nz)
        """The fast path's QP solver, ``"osqp"`` or ``"daqp"``."""
        self._dense: FastDAQP | None = (FastDAQP(self._fast) if self._fast is not None
                                        and self.solver == "daqp" else None)
        self._solve_vector = (self._dense.solve_vector if self._dense is not None
                              else self._fast.solve_vector if self._fast is not None else None)
        self._cold = False  # the next cvxpy solve sets OSQP up anew (after reset())

    def clone(self, *, name: str | None = None) -> ParametricQP:
        """The same QP with its own OSQP workspace, without modelling or probing it again.

        The clone shares the cvxpy problem (its ``path="cvxpy"`` solves then
        share cvxpy's warm start) and the identified data map; on the fast
        path it gets a fresh OSQP workspace set up with the same matrices, so
        its warm starts are its own.

        Parameters
        ----------
        name : str or None
            Label of the clone (default: this QP's).

        Returns
        -------
        ParametricQP
            The clone, cold.

        Examples
        --------
        >>> import numpy as np
        >>> qp = ParametricQP(np.eye(1), np.eye(1), np.zeros((0, 1)), name="a")
        >>> twin = qp.clone(name="b")
        >>> sol = twin.solve(g=np.array([-2.0]), lb=np.array([-1.0]), ub=np.array([1.0]))
        >>> twin.name, sol.z.round(6).tolist(), twin.fast_path is not qp.fast_path
        ('b', [1.0], True)
        """
        twin = copy.copy(self)
        twin.name = self.name if name is None else name
        if self._fast is not None:
            fast = copy.copy(self._fast)
            fast.name = twin.name
            fast._setup(type(self._fast.solver), internal=self._fast.route == "internal")
            twin._fast = fast
            # its own DAQP workspace too, and solve_vector bound to the clone's paths
            twin._dense = FastDAQP(fast) if self._dense is not None else None
            twin._solve_vector = (twin._dense.solve_vector if twin._dense is not None
                                  else fast.solve_vector)
        twin._cold = True
        return twin

    def reset(self) -> None:
        """Forget every warm start: the next solve starts cold, on either path."""
        if self._fast is not None:
            self._fast.reset()
        if self._dense is not None:
            self._dense.reset()
        self._cold = True

    @property
    def has_fast_path(self) -> bool:
        """True when the probed OSQP path was built."""
        return self._fast is not None

    @property
    def fast_path(self) -> FastOSQP | None:
        """The probed OSQP path (None when built with ``fast=False``)."""
        return self._fast

    @property
    def dense_path(self) -> FastDAQP | None:
        """The DAQP solver of the fast path (None unless ``solver`` chose DAQP)."""
        return self._dense

    def data_map(self) -> tuple[Array, dict[str, Array]]:
        """The identified affine map from parameters to OSQP's stacked (q, l, u) data.

        Returns
        -------
        offset : ndarray
            Data at zero parameters.
        blocks : dict of str to ndarray
            Column blocks of the map for ``"g"``, ``"lb"``, ``"ub"``, ``"hl"``, ``"hu"``.
        """
        if self._fast is None:
            raise SolverError(f"{self.name}: built without the fast path (fast=False).")
        return self._fast.offset, self._fast.blocks

    def solve_data(self, data: Array) -> QPSolution:
        """Fast path with the data vector already composed (see :meth:`data_map`).

        Parameters
        ----------
        data : ndarray
            OSQP's stacked data [q; b; h]: ``offset`` plus the map's blocks
            times the parameter vectors (:meth:`data_map`).

        Returns
        -------
        QPSolution
            Decision, slacks, status, iterations and time, from the fast
            path's solver (DAQP when :attr:`solver` is ``"daqp"``, else OSQP).

        Raises
        ------
        SolverError
            If the QP was built without the fast path (``fast=False``).
        """
        if self._solve_vector is None:
            raise SolverError(f"{self.name}: built without the fast path (fast=False).")
        return self._solve_vector(data)

    def _assign(self, values: dict[str, Array]) -> None:
        for key, p in self._all.items():
            if p.size:
                p.value = np.asarray(values[key], dtype=float)

    def solve(self, g: Array, lb: Array | None = None, ub: Array | None = None,
              hl: Array | None = None, hu: Array | None = None, *,
              path: str = "fast") -> QPSolution:
        """Solve for the given parameter vectors.

        Parameters
        ----------
        g : ndarray
            Linear cost term (nz,).
        lb, ub : ndarray or None
            Hard-row bounds (nh,); -inf/inf allowed.
        hl, hu : ndarray or None
            Soft-row bounds (ns,).
        path : {"fast", "cvxpy"}
            Solve through the probed OSQP data or through ``Problem.solve``.

        Returns
        -------
        QPSolution
            Decision, slacks, status, iterations and time.
        """
        values = {"g": g, "lb": _or(lb, self.nh, -np.inf), "ub": _or(ub, self.nh, np.inf),
                  "hl": _or(hl, self.ns, -np.inf), "hu": _or(hu, self.ns, np.inf)}
        if path == "fast" and self._fast is not None:
            if self._dense is not None:
                return self._dense.solve_vector(self._fast.compose(values))
            return self._fast.solve(values)
        if path not in ("fast", "cvxpy"):
            raise ModelError(
                f"ParametricQP.solve: 'path' must be 'fast' or 'cvxpy' (got {path!r}).")
        return self._solve_cvxpy(values)

    def _solve_cvxpy(self, values: dict[str, Array]) -> QPSolution:
        start = time.perf_counter()
        if any(np.isnan(v).any() for v in values.values()) or not np.isfinite(values["g"]).all():
            # A NaN never reaches cvxpy (or the solver's warm start): no solution.
            return QPSolution(np.full(self.nz, np.nan), np.zeros(self.ns), "error", 0,
                              time.perf_counter() - start)
        # cvxpy refuses infinite parameter values in constraints; clip to a huge finite bound.
        self._assign({k: np.clip(v, -1e20, 1e20) for k, v in values.items()})
        warm, self._cold = not self._cold, False
        stdout, sys.stdout = sys.stdout, SOLVER_OUTPUT
        try:
            self.problem.solve(solver=cp.OSQP, warm_start=warm, verbose=False, **OSQP_SETTINGS)
        except cp.SolverError as err:
            sys.stdout = stdout
            pass_on_interrupt(*_last_osqp_interrupt(self.problem))
            raise SolverError(f"{self.name}: OSQP failed: {err}") from err
        finally:
            sys.stdout = stdout
        pass_on_interrupt(*_last_osqp_interrupt(self.problem))
        elapsed = time.perf_counter() - start
        status = from_cvxpy(self.problem.status)
        z = self._z.value if self._z.value is not None else np.full(self.nz, np.nan)
        s = (self._s.value if self._s is not None and self._s.value is not None
             else np.zeros(self.ns))
        iters = int(self.problem.solver_stats.num_iters or 0) if self.problem.solver_stats else 0
        return QPSolution(np.asarray(z, dtype=float), np.asarray(s, dtype=float), status, iters,
                          elapsed)


def choose_solver(solver: str, n_decisions: int) -> str:
    """The fast path's QP solver for a QP of ``n_decisions`` decisions.

    Parameters
    ----------
    solver : {"auto", "osqp", "daqp"}
        The choice; ``"auto"`` takes DAQP up to :data:`DAQP_MAX_DECISIONS`
        decisions (slacks of soft rows not counted), OSQP above.
    n_decisions : int
        Decisions of the QP [-].

    Returns
    -------
    {"osqp", "daqp"}
        The solver.

    Examples
    --------
    >>> choose_solver("auto", 5), choose_solver("osqp", 5)
    ('daqp', 'osqp')
    """
    if solver == "auto":
        return "daqp" if n_decisions <= DAQP_MAX_DECISIONS else "osqp"
    return solver


def _last_osqp_interrupt(problem: cp.Problem) -> tuple[int, int]:
    """OSQP's status code of the problem's last solve and its record of a caught SIGINT.

    cvxpy keeps the solver and its last result in the problem's solver cache;
    (0, 0) when there is none.
    """
    cached = (getattr(problem, "_solver_cache", None) or {}).get(cp.OSQP)
    if not (isinstance(cached, tuple) and len(cached) > 2):
        return 0, 0
    info = getattr(cached[2], "info", None)
    return int(getattr(info, "status_val", 0) or 0), interrupt_record(cached[0])()


def _or(x: Array | None, n: int, fill: float) -> Array:
    return np.full(n, fill) if x is None else np.asarray(x, dtype=float)


def _soft_weights(name: str, ns: int, linear: float | ArrayLike,
                  quadratic: float | ArrayLike) -> tuple[Array, Array]:
    """The slack penalties (w1, w2) as arrays, checked: finite, w1 >= 0, w2 > 0, 1 or ns each.

    :func:`_slack_penalty` wraps diag(w2) as positive semidefinite for cvxpy
    (``psd_wrap``, which checks nothing): a negative w2 would make a
    non-convex QP that cvxpy takes for convex, and a negative w1 rewards
    violations.
    """
    weights = []
    for label, value, positive in (("soft_linear", linear, False),
                                   ("soft_quadratic", quadratic, True)):
        try:
            w = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            w = np.full(0, np.nan)
        ok = w.ndim <= 1 and w.size in (1, ns) and bool(np.isfinite(w).all())
        if not (ok and bool(np.all(w > 0) if positive else np.all(w >= 0))):
            raise ModelError(
                f"{name}: {label!r} must be one finite number or one per soft row ({ns}), "
                f"{'> 0' if positive else '>= 0'} (got {value!r}).")
        weights.append(w)
    return weights[0], weights[1]


def _slack_penalty(s: cp.Variable, w1: Array,
                   w2: Array) -> tuple[cp.Expression, cp.Expression]:
    """The terms w1ᵀ s and ½ sᵀ diag(w2) s (scalar weights: w1·Σs and ½w2·Σs²)."""
    if w1.ndim == 0 and w2.ndim == 0:
        return float(w1) * cp.sum(s), 0.5 * float(w2) * cp.sum_squares(s)
    w1, w2 = np.broadcast_to(w1, s.shape), np.broadcast_to(w2, s.shape)
    # A constant quadratic form goes straight into P (no auxiliary variables), so the
    # slacks keep the structure that the dense path turns into soft constraints.
    return w1 @ s, 0.5 * cp.quad_form(s, cp.psd_wrap(np.diag(w2)))
