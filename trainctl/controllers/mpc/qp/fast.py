# The fast solve path: OSQP driven directly with data identified from cvxpy.
"""OSQP driven directly with data probed from a cvxpy problem at build time.

A parametric QP modelled once in cvxpy
(:class:`~trainctl.controllers.mpc.qp.parametric.ParametricQP`)
whose parameters enter only the vectors of OSQP's data (q, l, u) — no
parameter multiplies a variable, so P and A are constant — has an affine map
from the parameters to that data. :class:`FastOSQP` identifies it once
through ``Problem.get_problem_data(cp.OSQP)`` (at the zero parameter and at
each unit parameter), checks it at a random point, locates the cvxpy
variables in the solver's variable vector, and then solves by one
matrix-vector product and an OSQP data update + solve, warm-started, through
:func:`osqp_runner`.

This module owns what both solve paths share: :data:`OSQP_SETTINGS` and the
result record :class:`QPSolution`.
"""

from __future__ import annotations

import ctypes
import functools
import signal
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import cvxpy as cp
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from trainctl.controllers.mpc.qp.status import from_osqp
from trainctl.exceptions import SolverError

__all__ = ["OSQP_SETTINGS", "SOLVER_OUTPUT", "FastOSQP", "QPSolution", "SolverOutput",
           "interrupt_record", "osqp_runner", "pass_on_interrupt"]

OSQP_SETTINGS = {"eps_abs": 1e-6, "eps_rel": 1e-6, "max_iter": 20000, "polishing": True}
"""OSQP settings used by both solve paths."""

Array = NDArray[np.float64]
_ProblemData = dict[str, Any]
"""cvxpy's ``get_problem_data`` for OSQP by key: vectors, sparse matrices, the inverse data."""
_HUGE = 1e19  # data beyond this came from an infinite bound
_OSQP_SIGINT = (10,)  # osqp.SolverStatus.OSQP_SIGINT: "interrupted by user"

OSQPRunner = Callable[[Array, Array | None, Array], tuple[Array | None, int, int]]
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
        Step status (:mod:`trainctl.controllers.mpc.qp.status`).
    iterations : int
        Solver iterations.
    solve_time : float
        Wall time of the solve [s].

    Examples
    --------
    >>> sol = QPSolution(np.array([0.5, 1.0]), np.zeros(0), "optimal", 25, 1e-4)
    >>> sol.status, sol.z.tolist(), sol.slack.size
    ('optimal', [0.5, 1.0], 0)
    """

    z: Array
    slack: Array
    status: str
    iterations: int
    solve_time: float


class SolverOutput:
    r"""Where ``sys.stdout`` points while OSQP solves: the text is dropped (and counted).

    OSQP 1.x prints "Polishing not needed - no active set detected at optimal
    point" whenever polishing finds no active constraint, whatever ``verbose``
    says, and it prints through Python's ``sys.stdout``
    (``PySys_WriteStdout``). Both solve paths point ``sys.stdout`` here for
    the duration of the solve (two attribute assignments, nothing per step
    beyond that), so solver chatter never mixes with a command's output.
    Text printed by other threads during a solve is dropped too.

    Examples
    --------
    >>> sink = SolverOutput()
    >>> sink.write("Polishing not needed"), sink.dropped
    (20, 20)
    """

    def __init__(self) -> None:
        self.dropped = 0

    def write(self, text: str) -> int:
        """Drop ``text``; return its length.

        Parameters
        ----------
        text : str
            What the solver printed.

        Returns
        -------
        int
            ``len(text)``, as ``io.TextIOBase.write`` returns (it is added to
            :attr:`dropped`).
        """
        self.dropped += len(text)
        return len(text)

    def flush(self) -> None:
        """Nothing to flush."""


SOLVER_OUTPUT = SolverOutput()
"""The sink of both solve paths."""


def pass_on_interrupt(status_val: int, caught: int = 0) -> None:
    """Deliver a Ctrl-C that OSQP caught during a solve to Python.

    OSQP installs its own SIGINT handler for the whole of a solve (from
    before the first ADMM iteration until the solution is stored) and
    restores the previous one on return; a SIGINT in between reaches only
    OSQP's handler, which sets a flag, never Python's. OSQP looks at that
    flag once per ADMM iteration: a signal seen there ends the solve with
    the status "interrupted", and a closed loop would record a failed step
    and go on. A signal that arrives after the last look (during the final
    termination check, polishing, storing the solution) is not reported
    at all: the status says solved and the signal is gone — the run went on
    and exited 0. Called right after a solve with the status and OSQP's
    flag (:func:`interrupt_record`), this re-raises the signal in either
    case, so Python's handler (``KeyboardInterrupt``) stops the run.

    Parameters
    ----------
    status_val : int
        OSQP's ``info.status_val`` after a solve.
    caught : int
        OSQP's own record of a SIGINT during that solve (nonzero: caught),
        read by :func:`interrupt_record` right after the solve.

    Examples
    --------
    >>> pass_on_interrupt(1)  # solved, no signal: nothing happens
    """
    if caught or int(status_val) in _OSQP_SIGINT:
        signal.raise_signal(signal.SIGINT)


def _never() -> int:
    return 0


@functools.cache
def _flag_reader(library: str) -> Callable[[], int]:
    try:
        read = ctypes.CDLL(library).osqp_is_interrupted
    except (OSError, AttributeError):  # not a shared object, or built without Ctrl-C support
        return _never
    read.argtypes, read.restype = [], ctypes.c_int
    return read


def interrupt_record(solver: Any) -> Callable[[], int]:
    """Reader of OSQP's record of a SIGINT caught during the latest solve (0: none).

    OSQP's compiled library exports ``osqp_is_interrupted``: the flag its
    SIGINT handler sets, cleared when the next solve starts (it is shared
    by every solver of the library). Reading it costs a foreign call, no
    system call. Where the library or the symbol cannot be found, the
    reader always answers 0 (the status "interrupted" is then the only
    evidence, as before).

    Parameters
    ----------
    solver : osqp.OSQP or None
        A solver; its compiled module (``solver.ext``) is the library read.

    Returns
    -------
    callable
        ``read() -> int``, nonzero when the latest solve caught a SIGINT.

    Examples
    --------
    >>> import osqp
    >>> interrupt_record(osqp.OSQP())()  # no solve has caught a signal
    0
    >>> interrupt_record(None)()
    0
    """
    library = getattr(getattr(solver, "ext", None), "__file__", None)
    return _flag_reader(library) if isinstance(library, str) else _never


def osqp_runner(solver: Any, *, internal: bool = True) -> tuple[OSQPRunner, str]:
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
    >>> run, route = osqp_runner(solver)
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


class FastOSQP:
    """OSQP driven directly with data identified from a cvxpy problem at build time.

    Parameters
    ----------
    problem : cvxpy.Problem
        A DPP problem whose parameters enter OSQP's q, l and u only.
    params : mapping of str to cvxpy.Parameter
        Every parameter, in the order of the stacked parameter vector; empty
        ones are allowed (they take no columns).
    z : cvxpy.Variable
        The decision variable returned by the solves.
    s : cvxpy.Variable or None
        The slack variable, if any.
    name : str
        Label for error messages.

    Attributes
    ----------
    offset : ndarray
        OSQP's stacked data [q; b; h] at zero parameters.
    jac : ndarray
        Its sensitivity to the stacked parameter vector.
    blocks : dict of str to ndarray
        ``jac``'s columns of each parameter (keys of ``params``).
    P, Amat : scipy.sparse matrix
        OSQP's constant cost and constraint matrices.
    route : {"internal", "public"}
        How OSQP is called (:func:`osqp_runner`).

    Examples
    --------
    Project a parameter p onto the box z <= 1: minimise ‖z - p‖² subject to
    z <= 1, whose solution is min(p, 1) entrywise.

    >>> z, p = cp.Variable(2), cp.Parameter(2)
    >>> problem = cp.Problem(cp.Minimize(cp.sum_squares(z - p)), [z <= 1.0])
    >>> qp = FastOSQP(problem, {"p": p}, z, None, name="demo")
    >>> sol = qp.solve({"p": np.array([0.5, 3.0])})
    >>> sol.status, np.round(sol.z, 4).tolist()
    ('optimal', [0.5, 1.0])
    """

    def __init__(self, problem: cp.Problem, params: Mapping[str, cp.Parameter],
                 z: cp.Variable, s: cp.Variable | None, *, name: str) -> None:
        import osqp

        self.problem, self.name = problem, name
        self._all = dict(params)
        self._params = [p for p in self._all.values() if p.size]
        self._vars = {"z": z, "s": s}
        self._k = int(sum(p.size for p in self._params))
        base = self._data(np.zeros(self._k))
        self.P = base["P"]
        self.Amat = sp.vstack([base["A"], base["F"]]).tocsc()
        self.offset = self._vector(base)
        self.jac = self._probe(self.offset)
        self.blocks: dict[str, Array] = {}
        start = 0
        for key, p in self._all.items():
            self.blocks[key] = self.jac[:, start:start + p.size]
            start += p.size
        self.n_eq = base["A"].shape[0]
        self.z_index = self._locate(base)
        self._n = self.P.shape[0]
        self._lower = np.full(self.Amat.shape[0], -np.inf)  # template of l (inequality rows)
        self._zi, self._si = _as_slice(self.z_index["z"]), _as_slice(self.z_index["s"])
        self._setup(osqp.OSQP, internal=True)

    def _setup(self, make: Callable[[], Any], *, internal: bool) -> None:
        """A fresh OSQP workspace with the data at zero parameters (cold: no warm start)."""
        self.solver = make()
        q, lower, upper = self.qlu(self.offset)
        P_triu = sp.csc_matrix(sp.triu(self.P, format="csc"))  # OSQP wants csc_matrix
        self.solver.setup(P_triu, q, sp.csc_matrix(self.Amat), lower, upper, verbose=False,
                          warm_starting=True, **OSQP_SETTINGS)
        self._run, self.route = osqp_runner(self.solver, internal=internal)
        self._caught = interrupt_record(self.solver)
        self._used = False

    def reset(self) -> None:
        """Forget the warm start: a new OSQP workspace, as after construction.

        A workspace that has not solved yet is kept (it is already clean).
        """
        if self._used:
            self._setup(type(self.solver), internal=self.route == "internal")

    def _probe(self, vec0: Array) -> Array:
        """The map's columns from unit probes, checked affine at a random point."""
        cols = []
        for k in range(self._k):
            probe = np.zeros(self._k)
            probe[k] = 1.0
            data = self._data(probe)
            self._check_constant(data, f"unit probe {k}")
            cols.append(self._vector(data) - vec0)
        jac = np.column_stack(cols) if cols else np.zeros((vec0.size, 0))
        check = np.random.default_rng(0).normal(size=self._k)
        if not np.allclose(self._vector(self._data(check)), vec0 + jac @ check,
                           rtol=1e-9, atol=1e-9):
            raise SolverError(f"{self.name}: the problem data are not affine in the parameters; "
                              "the fast path cannot be used (solve with path='cvxpy').")
        return jac

    def _data(self, flat: Array) -> _ProblemData:
        start = 0
        for p in self._params:
            p.value = flat[start:start + p.size].reshape(p.shape)
            start += p.size
        data: _ProblemData
        data, _, inverse = self.problem.get_problem_data(cp.OSQP)
        data["_inverse"] = inverse
        return data

    def _check_constant(self, data: _ProblemData, where: str) -> None:
        A = sp.vstack([data["A"], data["F"]]).tocsc()
        if _differs(data["P"], self.P) or _differs(A, self.Amat):
            raise SolverError(f"{self.name}: a parameter changes the QP matrices ({where}); "
                              "the fast path needs parameters in q, l, u only.")

    @staticmethod
    def _vector(data: _ProblemData) -> Array:
        return np.concatenate([data["q"], data["b"], data["G"]])

    def qlu(self, vec: Array) -> tuple[Array, Array, Array]:
        """OSQP's (q, l, u) from the stacked data [q; b; h]: l = [b; -inf], u = [b; h].

        l and u are new arrays; q is a view of ``vec``.

        Parameters
        ----------
        vec : ndarray
            OSQP's stacked data [q; b; h], as :meth:`compose` gives it.

        Returns
        -------
        (ndarray, ndarray, ndarray)
            The linear cost q and the constraint bounds l and u (entries at
            ±1e19 and beyond turned into ±inf).
        """
        q, upper = self._qu(vec)
        lower = self._lower.copy()
        if self.n_eq:
            lower[:self.n_eq] = vec[self._n:self._n + self.n_eq]
            lower[lower <= -_HUGE] = -np.inf
        return q, lower, upper

    def _qu(self, vec: Array) -> tuple[Array, Array]:
        """q and u of :meth:`qlu` (without equality rows, l = -inf throughout)."""
        q = vec[:self._n]
        upper = vec[self._n:].copy()
        # Parameters were clipped to ±1e20 for the map; give OSQP true infinities.
        upper[upper >= _HUGE] = np.inf
        return q, upper

    def _locate(self, data: _ProblemData) -> dict[str, NDArray[np.int64]]:
        # The solver's variable vector stacks cvxpy variables at recorded offsets.
        offsets: dict[int, int] = {}
        for inv in data["_inverse"]:
            offsets.update(getattr(inv, "var_offsets", {}) or {})
        out = {}
        for key, var in self._vars.items():
            if var is None:
                out[key] = np.zeros(0, dtype=np.int64)
                continue
            if var.id not in offsets:
                raise SolverError(f"{self.name}: cannot locate {var.name()} in the solver data.")
            out[key] = np.arange(offsets[var.id], offsets[var.id] + var.size)
        return out

    def compose(self, values: Mapping[str, Array]) -> Array:
        """OSQP's stacked data [q; b; h] for the parameter values (clipped to ±1e20).

        Parameters
        ----------
        values : mapping of str to ndarray
            A value for every non-empty parameter, keyed as ``params``, each
            of the parameter's size (flattened in C order).

        Returns
        -------
        ndarray
            ``offset + jac @ p``, p the stacked parameter values.
        """
        flat = np.concatenate([np.clip(np.asarray(values[key], dtype=float).ravel(), -1e20, 1e20)
                               for key, p in self._all.items() if p.size])
        composed: Array = self.offset + self.jac @ flat
        return composed

    def solve(self, values: Mapping[str, Array]) -> QPSolution:
        """Solve for the parameter values (keys of ``params``; clipped to ±1e20).

        Parameters
        ----------
        values : mapping of str to ndarray
            A value for every non-empty parameter, keyed as ``params``.

        Returns
        -------
        QPSolution
            As :meth:`solve_vector` returns it for :meth:`compose`'s data.
        """
        return self.solve_vector(self.compose(values))

    def solve_vector(self, data: Array) -> QPSolution:
        """Solve with OSQP's stacked data [q; b; h] already composed.

        Data with a NaN (or an infinite cost term) never reach OSQP: the
        solution is then NaN with status ``"error"``. A solve that leaves no
        finite solution with status ``"error"`` restarts the workspace cold,
        so that no later solve warm-starts from it.

        Parameters
        ----------
        data : ndarray
            OSQP's stacked data [q; b; h] (:meth:`compose`).

        Returns
        -------
        QPSolution
            The decision variable z and slack s from OSQP's solution (NaN when
            there is none), the step status, OSQP's iterations and the wall
            time [s].

        Raises
        ------
        KeyboardInterrupt
            When OSQP caught a Ctrl-C during the solve (:func:`pass_on_interrupt`).
        """
        start = time.perf_counter()
        if np.isnan(data).any() or not np.isfinite(data[:self._n]).all():
            nan = np.full(self._n, np.nan)
            return QPSolution(nan[self._zi], nan[self._si], "error", 0,
                              time.perf_counter() - start)
        self._used = True
        stdout, sys.stdout = sys.stdout, SOLVER_OUTPUT
        try:
            if self.n_eq:
                q, lower, upper = self.qlu(data)
                x, status_val, iters = self._run(q, lower, upper)
            else:  # l = -inf, as set up: update q and u only
                q, upper = self._qu(data)
                x, status_val, iters = self._run(q, None, upper)
        finally:
            sys.stdout = stdout
        elapsed = time.perf_counter() - start
        pass_on_interrupt(status_val, self._caught())
        status = from_osqp(status_val)
        x = np.full(self._n, np.nan) if x is None else np.asarray(x, dtype=float)
        if status == "error" and not np.isfinite(x).all():
            self.reset()
        return QPSolution(x[self._zi], x[self._si], status, int(iters), elapsed)

    def use_public_route(self) -> None:
        """Call OSQP through its public ``update``/``solve`` from now on (for tests)."""
        self._run, self.route = osqp_runner(self.solver, internal=False)


def _differs(a: sp.spmatrix, b: sp.spmatrix) -> bool:
    differs: bool = a.shape != b.shape or (a != b).nnz > 0  # scipy.sparse is untyped
    return differs


def _as_slice(index: NDArray[np.int64]) -> slice | NDArray[np.int64]:
    """A run of consecutive indices as a slice (indexing gives a view), else the indices."""
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + index.size)
    return index
