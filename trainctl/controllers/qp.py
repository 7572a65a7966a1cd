# A parametric QP modelled once in cvxpy and re-solved fast.
"""Parametric quadratic programs for MPC: built once, re-solved many times.

Every MPC problem in trainctl (centralised, one coach's local problem) has the
form

    minimise    ½ zᵀ H z + gᵀ z + w1·Σ s + ½ w2·Σ s²
    subject to  lb ≤ C z ≤ ub          (hard rows: input and rate bounds)
                hl - s ≤ F z ≤ hu + s  (soft rows: coupler forces), s ≥ 0

with constant matrices and the vectors g, lb, ub, hl, hu changing every
step. :class:`ParametricQP` models it once in cvxpy with those vectors as
``cp.Parameter`` s (checked DPP at build time) and offers two ways to solve:

``solve(..., path="cvxpy")``
    ``Problem.solve(warm_start=True)``: the plain re-solve, which pays
    cvxpy's per-solve canonicalisation (about 2 ms here).
``solve(..., path="fast")``
    Build time: probe ``Problem.get_problem_data(cp.OSQP)`` at the zero
    parameter and at each unit parameter, which identifies the affine map
    from the parameters to OSQP's (q, l, u) (P and A are constant because no
    parameter multiplies a variable), check the map at a random point, and
    locate z in the solver's variable vector. Solve time: one matrix-vector
    product and an OSQP data update + solve, warm-started, through
    ``_osqp_runner`` (the compiled solver called directly, without the
    per-call bookkeeping of ``osqp.OSQP.update``/``solve``).

Both paths use OSQP with the same settings, so they return the same
solutions to solver tolerance (tested).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cvxpy as cp
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from ..exceptions import SolverError
from .status import from_cvxpy, from_osqp

__all__ = ["OSQP_SETTINGS", "ParametricQP", "QPSolution"]

OSQP_SETTINGS = {"eps_abs": 1e-6, "eps_rel": 1e-6, "max_iter": 20000, "polishing": True}
"""OSQP settings used by both solve paths."""

Array = NDArray[np.float64]
_HUGE = 1e19  # data beyond this came from an infinite bound

_OSQPRunner = Callable[[Array, Array | None, Array], tuple[Array | None, int, int]]
"""``run(q, l, u) -> (x, status_val, iterations)``: update OSQP's vectors, solve, report."""


@dataclass(frozen=True)
class QPSolution:
    """Result of one QP solve.

    Parameters
    ----------
    z : ndarray
        Decision vector (NaN when no solution is available).
    slack : ndarray
        Soft-constraint slacks s >= 0.
    status : str
        Step status (:mod:`trainctl.controllers.status`).
    iterations : int
        Solver iterations.
    solve_time : float
        Wall time of the solve [s].
    """

    z: Array
    slack: Array
    status: str
    iterations: int
    solve_time: float


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
    soft_linear : float
        Linear slack penalty w1 (>= 0) [cost per unit of violation].
    soft_quadratic : float
        Quadratic slack penalty w2 (> 0 when there are soft rows).
    name : str
        Label for error messages and variable names.
    fast : bool
        Build the fast path (probing) as well.

    Examples
    --------
    >>> import numpy as np
    >>> qp = ParametricQP(np.eye(2), np.eye(2), np.zeros((0, 2)), name="demo")
    >>> sol = qp.solve(g=np.array([-2.0, 1.0]), lb=np.full(2, -0.5), ub=np.full(2, 0.5))
    >>> sol.status, sol.z.round(6).tolist()
    ('optimal', [0.5, -0.5])
    """

    def __init__(self, H: Array, C: Array, F: Array, *, soft_linear: float = 1e3,
                 soft_quadratic: float = 1e2, name: str = "qp", fast: bool = True) -> None:
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
        cons = []
        if self.nh:
            cons += [C @ self._z >= self._lb, C @ self._z <= self._ub]
        if self._s is not None:
            cost = (cost + soft_linear * cp.sum(self._s)
                    + 0.5 * soft_quadratic * cp.sum_squares(self._s))
            cons += [F @ self._z >= self._hl - self._s, F @ self._z <= self._hu + self._s]
        self.problem = cp.Problem(cp.Minimize(cost), cons)
        if not self.problem.is_dpp():
            raise SolverError(f"{name}: the QP is not DPP; a parameter multiplies another "
                              "parameter or a variable. Precompute such products in numpy.")
        self._params = [p for p in (self._g, self._lb, self._ub, self._hl, self._hu) if p.size]
        self._fast: _FastOSQP | None = _FastOSQP(self) if fast else None

    @property
    def has_fast_path(self) -> bool:
        """True when the probed OSQP path was built."""
        return self._fast is not None

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
        """Fast path with the data vector already composed (see :meth:`data_map`)."""
        if self._fast is None:
            raise SolverError(f"{self.name}: built without the fast path (fast=False).")
        return self._fast.solve_vector(data)

    def _assign(self, values: dict[str, Array]) -> None:
        for p, key in ((self._g, "g"), (self._lb, "lb"), (self._ub, "ub"),
                       (self._hl, "hl"), (self._hu, "hu")):
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
            return self._fast.solve(values)
        if path not in ("fast", "cvxpy"):
            raise ValueError(
                f"ParametricQP.solve: 'path' must be 'fast' or 'cvxpy' (got {path!r}).")
        return self._solve_cvxpy(values)

    def _solve_cvxpy(self, values: dict[str, Array]) -> QPSolution:
        # cvxpy refuses infinite parameter values in constraints; clip to a huge finite bound.
        self._assign({k: np.clip(v, -1e20, 1e20) for k, v in values.items()})
        start = time.perf_counter()
        try:
            self.problem.solve(solver=cp.OSQP, warm_start=True, **OSQP_SETTINGS)
        except cp.SolverError as err:
            raise SolverError(f"{self.name}: OSQP failed: {err}") from err
        elapsed = time.perf_counter() - start
        status = from_cvxpy(self.problem.status)
        z = self._z.value if self._z.value is not None else np.full(self.nz, np.nan)
        s = (self._s.value if self._s is not None and self._s.value is not None
             else np.zeros(self.ns))
        iters = int(self.problem.solver_stats.num_iters or 0) if self.problem.solver_stats else 0
        return QPSolution(np.asarray(z, dtype=float), np.asarray(s, dtype=float), status, iters,
                          elapsed)


def _differs(a: sp.spmatrix, b: sp.spmatrix) -> bool:
    return a.shape != b.shape or (a != b).nnz > 0


def _or(x: Array | None, n: int, fill: float) -> Array:
    return np.full(n, fill) if x is None else np.asarray(x, dtype=float)


def _as_slice(index: NDArray[np.int64]) -> slice | NDArray[np.int64]:
    """A run of consecutive indices as a slice (indexing gives a view), else the indices."""
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + index.size)
    return index


def _osqp_runner(solver: Any, *, internal: bool = True) -> tuple[_OSQPRunner, str]:
    """Update-and-solve function of a set-up ``osqp.OSQP``; the one use of OSQP internals.

    ``osqp.OSQP.update`` and ``osqp.OSQP.solve`` (OSQP 1.x) are thin Python
    wrappers of the compiled solver object ``solver._solver``: ``update``
    clamps l and u to ±OSQP_INFTY (looking the constant up through
    ``importlib`` on every call), calls ``_solver.update_data_vec(q, l, u)``
    and refreshes a cache kept for OSQP's derivatives; ``solve`` calls
    ``_solver.solve()`` and copies every field of ``_solver.info`` into a new
    namespace. For the small QPs of MPC that bookkeeping costs about as much
    as the solve.

    The internal route makes the same compiled calls with the same data: it
    clamps l and u as ``update`` does, passes C-contiguous float64 arrays
    (the binding reads raw buffers and ignores strides) and reads only
    ``info.status_val``, ``info.iter`` and ``solution.x`` (a fresh copy per
    access). It does not maintain the derivative cache, so OSQP's
    ``adjoint_derivative_*`` methods are not available after it. It is used
    only when ``solver._solver`` has the expected attributes and the solver
    works in float64; otherwise, or with ``internal=False``, the public
    ``update`` + ``solve(raise_error=False)`` are called, so an OSQP release
    that changes the internals falls back to the public API instead of
    breaking.

    Parameters
    ----------
    solver : osqp.OSQP
        A solver after ``setup``.
    internal : bool
        Use the internal route when available.

    Returns
    -------
    run : callable
        ``run(q, l, u) -> (x, status_val, iterations)`` with x the primal
        solution (None when OSQP gives none), the OSQP status code and the
        ADMM iteration count; ``l=None`` keeps the current l. Its arguments
        are not modified.
    route : {"internal", "public"}
        The route taken.

    Examples
    --------
    >>> import numpy as np, osqp, scipy.sparse as sp
    >>> solver = osqp.OSQP()
    >>> eye = sp.csc_matrix(np.eye(2))
    >>> solver.setup(eye, np.zeros(2), eye, -np.ones(2), np.ones(2), verbose=False,
    ...              **OSQP_SETTINGS)
    >>> run, route = _osqp_runner(solver)
    >>> x, status, _ = run(np.array([-5.0, 0.5]), np.full(2, -np.inf), np.ones(2))
    >>> route, status, np.round(x, 6).tolist()
    ('internal', 1, [1.0, -0.5])
    """
    core = getattr(solver, "_solver", None)
    big = float(solver.constant("OSQP_INFTY")) if hasattr(solver, "constant") else 1e30
    if internal and core is not None and getattr(solver, "_dtype", None) is np.float64 \
            and all(hasattr(core, name) for name in ("update_data_vec", "solve", "info",
                                                      "solution")):
        update, solve = core.update_data_vec, core.solve

        def run_internal(q: Array, lower: Array | None,
                         upper: Array) -> tuple[Array | None, int, int]:
            update(np.ascontiguousarray(q, dtype=np.float64),
                   None if lower is None else np.maximum(lower, -big, dtype=np.float64),
                   np.minimum(upper, big, dtype=np.float64))
            solve()
            info = core.info
            return core.solution.x, info.status_val, info.iter

        return run_internal, "internal"

    def run_public(q: Array, lower: Array | None, upper: Array) -> tuple[Array | None, int, int]:
        solver.update(q=q, l=lower, u=upper)
        res = solver.solve(raise_error=False)
        return res.x, res.info.status_val, res.info.iter

    return run_public, "public"


class _FastOSQP:
    """OSQP driven directly with data identified from cvxpy at build time."""

    def __init__(self, qp: ParametricQP) -> None:
        import osqp

        self.qp = qp
        sizes = [p.size for p in qp._params]
        self._k = int(sum(sizes))
        base = self._data(np.zeros(self._k))
        self.P = base["P"]
        self.Amat = sp.vstack([base["A"], base["F"]]).tocsc()
        vec0 = self._vector(base)
        cols = []
        for k in range(self._k):
            probe = np.zeros(self._k)
            probe[k] = 1.0
            data = self._data(probe)
            self._check_constant(data, f"unit probe {k}")
            cols.append(self._vector(data) - vec0)
        self.offset = vec0
        self.jac = np.column_stack(cols) if cols else np.zeros((vec0.size, 0))
        self.blocks: dict[str, Array] = {}
        start = 0
        for key, p in zip(("g", "lb", "ub", "hl", "hu"), (qp._g, qp._lb, qp._ub, qp._hl, qp._hu),
                          strict=True):
            self.blocks[key] = self.jac[:, start:start + p.size]
            start += p.size
        check = np.random.default_rng(0).normal(size=self._k)
        if not np.allclose(self._vector(self._data(check)), vec0 + self.jac @ check,
                           rtol=1e-9, atol=1e-9):
            raise SolverError(f"{qp.name}: the problem data are not affine in the parameters; "
                              "the fast path cannot be used (solve with path='cvxpy').")
        self.n_eq = base["A"].shape[0]
        self.z_index = self._locate(base)
        self._n = self.P.shape[0]
        self._lower = np.full(self.Amat.shape[0], -np.inf)  # template of l (inequality rows)
        self._zi, self._si = _as_slice(self.z_index["z"]), _as_slice(self.z_index["s"])
        self.solver = osqp.OSQP()
        q, lower, upper = self._qlu(vec0)
        P_triu = sp.csc_matrix(sp.triu(self.P, format="csc"))  # OSQP wants csc_matrix
        self.solver.setup(P_triu, q, sp.csc_matrix(self.Amat), lower, upper, verbose=False,
                          warm_starting=True, **OSQP_SETTINGS)
        self._run, self.route = _osqp_runner(self.solver)

    def _data(self, flat: Array) -> dict:
        start = 0
        for p in self.qp._params:
            p.value = flat[start:start + p.size].reshape(p.shape)
            start += p.size
        data, _, inverse = self.qp.problem.get_problem_data(cp.OSQP)
        data["_inverse"] = inverse
        return data

    def _check_constant(self, data: dict, where: str) -> None:
        A = sp.vstack([data["A"], data["F"]]).tocsc()
        if _differs(data["P"], self.P) or _differs(A, self.Amat):
            raise SolverError(f"{self.qp.name}: a parameter changes the QP matrices ({where}); "
                              "the fast path needs parameters in q, l, u only.")

    @staticmethod
    def _vector(data: dict) -> Array:
        return np.concatenate([data["q"], data["b"], data["G"]])

    def _qlu(self, vec: Array) -> tuple[Array, Array, Array]:
        """OSQP's (q, l, u) from the stacked data [q; b; h]: l = [b; -inf], u = [b; h].

        l and u are new arrays; q is a view of ``vec``.
        """
        q, upper = self._qu(vec)
        lower = self._lower.copy()
        if self.n_eq:
            lower[:self.n_eq] = vec[self._n:self._n + self.n_eq]
            lower[lower <= -_HUGE] = -np.inf
        return q, lower, upper

    def _qu(self, vec: Array) -> tuple[Array, Array]:
        """q and u of :meth:`_qlu` (without equality rows, l = -inf throughout)."""
        q = vec[:self._n]
        upper = vec[self._n:].copy()
        # Parameters were clipped to ±1e20 for the map; give OSQP true infinities.
        upper[upper >= _HUGE] = np.inf
        return q, upper

    def _locate(self, data: dict) -> dict[str, NDArray[np.int64]]:
        # The solver's variable vector stacks cvxpy variables at recorded offsets.
        offsets: dict[int, int] = {}
        for inv in data["_inverse"]:
            offsets.update(getattr(inv, "var_offsets", {}) or {})
        out = {}
        for key, var in (("z", self.qp._z), ("s", self.qp._s)):
            if var is None:
                out[key] = np.zeros(0, dtype=np.int64)
                continue
            if var.id not in offsets:
                raise SolverError(f"{self.qp.name}: cannot locate {var.name()} in the solver data.")
            out[key] = np.arange(offsets[var.id], offsets[var.id] + var.size)
        return out

    def solve(self, values: dict[str, Array]) -> QPSolution:
        flat = np.concatenate([np.clip(np.asarray(values[key], dtype=float).ravel(), -1e20, 1e20)
                               for key, p in zip(("g", "lb", "ub", "hl", "hu"),
                                                 (self.qp._g, self.qp._lb, self.qp._ub,
                                                  self.qp._hl, self.qp._hu), strict=True)
                               if p.size])
        return self.solve_vector(self.offset + self.jac @ flat)

    def solve_vector(self, data: Array) -> QPSolution:
        start = time.perf_counter()
        if self.n_eq:
            q, lower, upper = self._qlu(data)
            x, status_val, iters = self._run(q, lower, upper)
        else:  # l = -inf, as set up: update q and u only
            q, upper = self._qu(data)
            x, status_val, iters = self._run(q, None, upper)
        elapsed = time.perf_counter() - start
        status = from_osqp(status_val)
        x = np.full(self._n, np.nan) if x is None else np.asarray(x, dtype=float)
        return QPSolution(x[self._zi], x[self._si], status, int(iters), elapsed)
