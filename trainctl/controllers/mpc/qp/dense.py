# The dense solve path: DAQP (dual active set) on the data identified for OSQP.
"""DAQP driven directly with the QP data identified by :class:`.fastqp.FastOSQP`.

The per-coach QPs of the condensed MPC are small and dense (5–40 decisions,
tens of rows): the class that dual active-set solvers are made for. DAQP
(Arnström, Bemporad, Axehill) solves::

    minimise    ½ xᵀ H x + fᵀ x
    subject to  blower ≤ x[:ms] ≤ bupper[:ms]      (simple bounds)
                blower ≤ A x ≤ bupper               (general rows; hard, equality or soft)

and :class:`FastDAQP` hands it the same (P, q, A, l, u) that the OSQP fast
path solves — the affine map from the parameters that ``FastOSQP`` identified
from cvxpy — after an exact reduction of the rows, built once:

- Rows that are multiples of one another (cvxpy writes ``lb ≤ C z ≤ ub`` as
  the two rows ``-C z ≤ -lb`` and ``C z ≤ ub``) become one two-sided row,
  with the tightest of the members' bounds: the feasible set is unchanged.
- Rows of a single variable become DAQP simple bounds.
- Soft rows (``soft=True``): the slack variables s ≥ 0 of
  ``hl - s ≤ F z ≤ hu + s`` with the cost ``w1ᵀ s + ½ sᵀ diag(w2) s`` are
  removed and the rows marked soft (DAQP sense 8) with the linear weight w1
  and the reciprocal quadratic weight 1/w2 on either side. DAQP gives each
  side its own slack; the model has one slack per row. The two are the same
  problem exactly when hl ≤ hu on every soft row (then at most one side is
  violated, and s = max(0, hl - F z, F z - hu) is the shared slack at the
  optimum): that is checked at every solve, and a solve with hl > hu on a
  soft row goes to the slack form (counted in ``slack_solves``). The
  reduction is used only when the identified data have exactly this
  structure (each slack in its own rows with coefficient -1, a diagonal
  positive quadratic penalty, a constant non-negative linear one, a bound
  s ≥ 0); otherwise the slacks stay decision variables (``soft_reason``
  says why).

DAQP keeps its working set between solves: each solve starts from the
active set of the previous one (the warm start across Jacobi iterations and
samples); :meth:`FastDAQP.reset` starts the next solve from the empty set.
Its results are exact up to rounding once the active set is found (no
tolerance on optimality beyond ``primal_tol`` on feasibility), so they agree
with OSQP's polished solutions to OSQP's accuracy.

DAQP installs no signal handler: a Ctrl-C during a solve is seen by
Python's handler as soon as the solve returns (``KeyboardInterrupt``).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import cho_factor, cho_solve

from trainctl.controllers.mpc.qp.fast import FastOSQP, QPSolution, _as_slice
from trainctl.controllers.mpc.qp.status import from_daqp
from trainctl.exceptions import SolverError

__all__ = ["DAQP_SETTINGS", "FastDAQP"]

DAQP_SETTINGS = {"primal_tol": 1e-9, "iter_limit": 2000}
"""DAQP settings of the dense path: feasibility tolerance 1e-9 (solver units, kN here),
an iteration limit well above the few tens of active-set changes these QPs need."""

Array = NDArray[np.float64]
Index = NDArray[np.int64]
_HUGE = 1e19          # data beyond this came from an infinite bound (FastOSQP clips to 1e20)
_DAQP_INF = 1e30      # DAQP's infinity
_HARD, _EQUALITY, _SOFT = 0, 5, 8   # DAQP constraint senses
_CONTRADICTION = 1e-9  # a row with lower - upper above this (relative) cannot be met
_DAQP_STATUS = {1: "optimal", 2: "optimal"}  # the usual flags, without a function call


class _Rows:
    """The reduction of OSQP's rows to DAQP's constraints (bounds of each, per solve).

    Member k of constraint ``group[k]`` is OSQP row ``row[k]`` divided by
    ``factor[k]``: its datum d (u, and l = u for an equality row) bounds the
    constraint from above (factor > 0) or below (factor < 0) by d / factor.
    A datum of 1e19 or more stands for an infinite u (:class:`FastOSQP` clips
    infinite parameters to 1e20); it gives DAQP's infinity, as does a side
    without members.

    Both sides are gathered in one pass into a preallocated (members, 2n)
    array, upper bounds in the first n columns and the lower bounds negated
    in the last n: a lower bound d / f is taken as -(d · (-1/f)), the same
    number, so that one comparison finds every infinite datum and one running
    minimum over the members gives both sides (max(a, b) = -min(-a, -b),
    exactly, with the same choice between equal values). Per solve that is 5
    numpy calls instead of 5 per side and member.
    """

    def __init__(self, n_constraints: int, n_data: int, rows: list[int], groups: list[int],
                 factors: list[float], n_eq: int, *, base: int = 0) -> None:
        row, group = np.asarray(rows, dtype=np.int64), np.asarray(groups, dtype=np.int64)
        factor = np.asarray(factors, dtype=float)
        eq = row < n_eq
        upper, lower = (factor > 0) | eq, (factor < 0) | eq
        n = self.n = n_constraints
        # Each side of each constraint gathers its members (padded with a sentinel that
        # gives DAQP's infinity) from the data extended by that sentinel.
        self._base = base
        self._ext = np.zeros(base + n_data + 1)  # for bounds(): the data and the sentinel
        self._ext[-1] = _DAQP_INF
        up_src, up_scale = _gather(n, n_data, row[upper], group[upper], 1.0 / factor[upper], 1.0)
        lo_src, lo_scale = _gather(n, n_data, row[lower], group[lower], 1.0 / factor[lower],
                                   -1.0)
        width = max(up_src.shape[1], lo_src.shape[1])
        src = np.full((width, 2 * n), n_data, dtype=np.int64)
        scale = np.ones((width, 2 * n))
        src[:up_src.shape[1], :n], scale[:up_scale.shape[1], :n] = up_src.T, up_scale.T
        src[:lo_src.shape[1], n:], scale[:lo_scale.shape[1], n:] = lo_src.T, -lo_scale.T
        self._src, self._scale = src + base, scale
        self._huge = _HUGE * np.abs(scale)
        self._huge[src == n_data] = np.inf  # the sentinel is DAQP's infinity already
        self._cols = np.empty((width, 2 * n))
        self._mask = np.empty((width, 2 * n), dtype=bool)
        self._lower = np.empty(n)

    def bounds(self, d: Array) -> tuple[Array, Array]:
        """(lower, upper) of every constraint from OSQP's row data ``d`` (new arrays).

        Infinite bounds are DAQP's infinity, ±1e30.
        """
        self._ext[self._base:-1] = d
        lower, upper = self.gather(self._ext)
        return lower.copy(), upper.copy()

    def gather(self, ext: Array) -> tuple[Array, Array]:
        """:meth:`bounds` from ``ext`` = [``base`` entries; OSQP's row data; 1e30] (views of
        this object's buffers, rewritten by the next call)."""
        cols, n = self._cols, self.n
        np.take(ext, self._src, out=cols)
        np.multiply(cols, self._scale, out=cols)
        mask = np.greater_equal(cols, self._huge, out=self._mask)
        if mask.any():
            cols[mask] = _DAQP_INF
        acc = cols[0]
        for j in range(1, cols.shape[0]):  # members in order, as a chain of minima
            np.minimum(acc, cols[j], out=acc)
        np.negative(acc[n:], out=self._lower)
        return self._lower, acc[:n]


class _SoftSolution(QPSolution):
    """A :class:`QPSolution` of the soft form whose slacks are computed when first read.

    The slacks s = max(0, hl - F z, F z - hu) of the removed slack variables
    cost 5 numpy calls per solve (as much as DAQP's own update); the train
    MPC never reads them, the linear MPC core does. The value read is the one
    computed eagerly before, from the same numbers.
    """

    @classmethod
    def make(cls, z: Array, soft: tuple[Array, Array, Array, Array], status: str,
             iterations: int, solve_time: float) -> QPSolution:
        """The solution; ``soft`` = (x, F, hl, hu) of the slacks (kept until read)."""
        sol = object.__new__(cls)
        sol.__dict__.update(z=z, status=status, iterations=iterations, solve_time=solve_time,
                            _soft=soft)
        return sol

    def __getattr__(self, name: str) -> Any:
        if name != "slack" or "_soft" not in self.__dict__:
            raise AttributeError(name)
        x, F, lower, upper = self.__dict__.pop("_soft")
        Fz = F @ x
        slack = np.maximum(0.0, np.maximum(lower - Fz, Fz - upper))
        object.__setattr__(self, "slack", slack)
        return slack


def _gather(n: int, n_data: int, rows: Index, groups: Index, scales: Array,
            pad: float) -> tuple[Index, Array]:
    """Source rows and scales of each constraint's members, (n, most members), padded."""
    width = max(1, int(np.bincount(groups, minlength=n).max(initial=0)) if groups.size else 1)
    src = np.full((n, width), n_data, dtype=np.int64)
    scale = np.full((n, width), pad)
    slot = np.zeros(n, dtype=np.int64)
    for r, g, k in zip(rows, groups, scales, strict=True):
        src[g, slot[g]], scale[g, slot[g]] = r, k
        slot[g] += 1
    return src, scale


class FastDAQP:
    """DAQP on the dense QP data identified for OSQP (module docstring).

    Parameters
    ----------
    fast : FastOSQP
        The identified data: P, A and the affine map to (q, l, u).
    soft : bool
        Hand the soft rows to DAQP as soft constraints and drop their slack
        variables, where that is exactly equivalent (module docstring).
    settings : mapping or None
        DAQP settings overriding :data:`DAQP_SETTINGS`.

    Attributes
    ----------
    soft : bool
        True when the slacks were removed (soft constraints).
    soft_reason : str
        Why the slacks were kept ("" when ``soft``).
    n_vars, n_simple, n_rows : int
        DAQP's variables, simple bounds and general rows.
    slack_solves : int
        Solves that needed the slack form (hl > hu on a soft row).

    Examples
    --------
    >>> import numpy as np
    >>> from trainctl.controllers.mpc.qp.parametric import ParametricQP
    >>> qp = ParametricQP(np.eye(2), np.eye(2), np.ones((1, 2)), name="demo")
    >>> dense = FastDAQP(qp.fast_path)
    >>> dense.soft, dense.n_vars, dense.n_simple, dense.n_rows
    (True, 2, 2, 1)
    """

    def __init__(self, fast: FastOSQP, *, soft: bool = True,
                 settings: dict[str, Any] | None = None) -> None:
        import daqp

        self.fast, self.name = fast, fast.name
        self._settings = {**DAQP_SETTINGS, **(settings or {})}
        n, n_eq = fast.P.shape[0], fast.n_eq
        self._n, self._n_eq = n, n_eq
        P = fast.P.toarray()
        if not np.array_equal(P, P.T):  # only a triangle stored: DAQP needs the whole H
            P = np.triu(P) + np.triu(P, 1).T
        A = fast.Amat.toarray()
        s_cols = fast.z_index["s"]
        reason = self._soft_structure(P, A, s_cols) if soft and s_cols.size else \
            ("soft=False" if soft is False else "no soft rows")
        self.soft, self.soft_reason = reason == "", reason
        keep = np.setdiff1d(np.arange(n), s_cols) if self.soft else np.arange(n)
        self._keep = keep
        self._keep_index = _as_slice(keep)
        self.n_vars = keep.size
        position = np.full(n, -1, dtype=np.int64)
        position[keep] = np.arange(keep.size)
        self._z_pos = position[fast.z_index["z"]]
        self._s_pos = position[s_cols] if not self.soft else np.zeros(0, dtype=np.int64)
        self._build_rows(A, keep, s_cols)
        self.H = np.ascontiguousarray(P[np.ix_(keep, keep)])
        self._make = daqp.Model
        self._lower0, self._upper0, _ = self._bounds(fast.offset)
        self._f0 = np.ascontiguousarray(fast.offset[keep])
        self._setup()
        self.slack_solves = 0
        self._slack_form: FastDAQP | None = None

    # -- construction ------------------------------------------------------------------------
    def _soft_structure(self, P: Array, A: Array, s_cols: Index) -> str:
        """"" when the slacks can be replaced by DAQP soft constraints exactly, else why not."""
        fast, n = self.fast, self._n
        z_cols = np.setdiff1d(np.arange(n), s_cols)
        Pss = P[np.ix_(s_cols, s_cols)]
        if np.abs(P[np.ix_(z_cols, s_cols)]).max(initial=0.0) > 0 \
                or np.abs(Pss - np.diag(np.diag(Pss))).max(initial=0.0) > 0:
            return "the slacks' cost couples them to other variables"
        if (np.diag(Pss) <= 0).any():
            return "a slack has no quadratic penalty"
        if np.abs(fast.jac[s_cols]).max(initial=0.0) > 0 or (fast.offset[s_cols] < 0).any():
            return "a slack's linear penalty is negative or changes with the parameters"
        self._w1 = fast.offset[s_cols].copy()
        self._w2 = np.diag(Pss).copy()
        S = A[:, s_cols]
        nonneg = np.zeros(s_cols.size, dtype=bool)
        soft_rows: list[list[int]] = [[] for _ in s_cols]
        for r in np.flatnonzero((S != 0).any(axis=1)):
            entries = np.flatnonzero(S[r])
            if entries.size != 1 or S[r, entries[0]] >= 0 or r < self.fast.n_eq:
                return f"row {r} is not an inequality with one slack entering as -s"
            j = int(entries[0])
            zpart = A[r, z_cols]
            if not zpart.any():
                datum = n + r
                if fast.offset[datum] != 0 or np.abs(fast.jac[datum]).max(initial=0.0) > 0 \
                        or nonneg[j]:
                    return f"row {r} bounds a slack other than by s >= 0"
                nonneg[j] = True
            else:
                soft_rows[j].append(int(r))
        if not nonneg.all():
            return "a slack is not bounded by s >= 0"
        for j, rows in enumerate(soft_rows):
            if not rows:
                return "a slack enters no soft row"
            lead = A[rows[0], z_cols] / -S[rows[0], j]
            for row in rows[1:]:
                zpart = A[row, z_cols] / -S[row, j]
                if not (np.array_equal(zpart, lead) or np.array_equal(zpart, -lead)):
                    return "the rows of a slack are not one two-sided row"
        return ""

    def _build_rows(self, A: Array, keep: Index, s_cols: Index) -> None:
        """Group OSQP's rows into DAQP's simple bounds and general rows (exact reduction)."""
        n_vars = keep.size
        Az = A[:, keep]
        simple: dict[int, list[tuple[int, float]]] = {}
        general: dict[bytes, tuple[Array, list[tuple[int, float]]]] = {}
        soft: dict[int, tuple[Array, list[tuple[int, float]]]] = {}
        zero_rows: list[tuple[int, float]] = []
        S = A[:, s_cols] if self.soft else np.zeros((A.shape[0], 0))
        for r in range(A.shape[0]):
            a = Az[r]
            if self.soft and S[r].any():
                j = int(np.flatnonzero(S[r])[0])
                if not a.any():
                    continue  # s >= 0: DAQP's soft constraints need no slack variables
                c = -S[r, j]
                if j not in soft:
                    soft[j] = (a / c, [])
                lead = soft[j][0]
                soft[j][1].append((r, c if np.array_equal(a / c, lead) else -c))
                continue
            nz = np.flatnonzero(a)
            if nz.size == 0:
                zero_rows.append((r, 1.0))
                continue
            largest = float(np.abs(a[nz]).max())
            k = largest if a[nz[0]] > 0 else -largest
            if nz.size == 1:
                simple.setdefault(int(nz[0]), []).append((r, float(a[nz[0]])))
                continue
            canon = a / k + 0.0  # -0.0 becomes 0.0: a row and its negative group together
            general.setdefault(canon.tobytes(), (canon, []))[1].append((r, float(k)))
        self.n_simple = n_vars if simple else 0
        rows: list[int] = []
        groups: list[int] = []
        factors: list[float] = []

        def add(g: int, members: list[tuple[int, float]]) -> None:
            for r, k in members:
                rows.append(r)
                groups.append(g)
                factors.append(k)

        for var, members in simple.items():
            add(var, members)
        matrix: list[Array] = []
        senses: list[int] = []
        for canon, members in general.values():
            add(self.n_simple + len(matrix), members)
            matrix.append(canon)
            senses.append(_EQUALITY if any(r < self._n_eq for r, _ in members) else _HARD)
        self._soft_first = self.n_simple + len(matrix)
        self._soft_slack = np.array(sorted(soft), dtype=np.int64)
        for j in self._soft_slack:
            canon, members = soft[int(j)]
            add(self.n_simple + len(matrix), members)
            matrix.append(canon)
            senses.append(_SOFT)
        self.n_rows = len(matrix)
        self.A = np.ascontiguousarray(np.array(matrix).reshape(len(matrix), n_vars))
        simple_sense = [_HARD] * self.n_simple
        self._sense0 = np.array(simple_sense + senses, dtype=np.int32)
        m = A.shape[0]
        n = self._n
        self._rows = _Rows(self.n_simple + self.n_rows, m, rows, groups, factors, self._n_eq,
                           base=n)
        self._zero = _Rows(len(zero_rows), m, [r for r, _ in zero_rows],
                           list(range(len(zero_rows))), [1.0] * len(zero_rows), self._n_eq,
                           base=n)
        # The stacked data [q; b; h] and the sentinel the row reduction gathers for a side
        # without members; data_buffer is the part before the sentinel.
        self._ext = np.empty(n + m + 1)
        self._ext[-1] = _DAQP_INF
        self.data_buffer = self._ext[:-1]
        self._ones = np.ones(n + m)
        """OSQP's stacked data [q; b; h] of the next solve, composed in place (by
        :meth:`QPBlock.solve`): :meth:`solve_vector` given this array reads it without a
        copy. Rewritten by every solve."""
        self._hard = slice(0, self._soft_first)
        self._soft_part = slice(self._soft_first, self.n_simple + self.n_rows)
        self._A_soft = self.A[self._soft_first - self.n_simple:]

    def _setup(self) -> None:
        """A fresh DAQP workspace with the data at zero parameters (cold: empty working set).

        Without any constraint the QP is solved by a Cholesky factor of H instead.
        """
        self._used = False
        if self.n_simple + self.n_rows == 0:
            self._model = None
            self._chol = cho_factor(self.H)
            return
        lower, upper = self._lower0, self._upper0
        self._model = self._make()
        flag, _ = self._model.setup(self.H, self._f0, self.A, upper, lower,
                                    self._sense0.copy())
        if flag < 0:
            # A contradiction in the data at zero parameters; set up with open bounds.
            wide = np.full(upper.size, _DAQP_INF)
            flag, _ = self._model.setup(self.H, self._f0, self.A, wide, -wide,
                                        self._sense0.copy())
            if flag < 0:
                raise SolverError(f"{self.name}: DAQP setup failed (exit flag {flag}).")
        self._model.settings = self._settings
        if self.soft:
            n_all = self.n_simple + self.n_rows
            rho, w = np.full(n_all, 1.0), np.zeros(n_all)
            rho[self._soft_part] = 1.0 / self._w2[self._soft_slack]
            w[self._soft_part] = self._w1[self._soft_slack]
            self._model.soft_weights(rho_l=rho, rho_u=rho, w_l=w, w_u=w)

    def _bounds(self, data: Array) -> tuple[Array, Array, bool]:
        """DAQP's (lower, upper) for OSQP's stacked data (new arrays); True when a zero row
        is violated."""
        lower, upper, violated = self._bounds_view(data)
        return lower.copy(), upper.copy(), violated

    def _bounds_view(self, data: Array, *, in_place: bool = False) -> tuple[Array, Array, bool]:
        """:meth:`_bounds` in the row reduction's buffers (rewritten by the next solve);
        ``in_place``: ``data`` is ``self._ext[:-1]`` already."""
        ext = self._ext
        if not in_place:
            ext[:-1] = data
        lower, upper = self._rows.gather(ext)
        violated = False
        if self._zero.n:
            zl, zu = self._zero.gather(ext)
            violated = bool((zl > _CONTRADICTION).any() or (zu < -_CONTRADICTION).any())
        return lower, upper, violated

    # -- solving -----------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget the warm start: a new DAQP workspace, as after construction.

        The next solve starts from the empty working set and gives what a new
        ``FastDAQP`` gives, bit for bit. A workspace that has not solved yet
        is kept (it is already clean).
        """
        if self._used:
            self._setup()
        if self._slack_form is not None:
            self._slack_form.reset()

    def clear_working_set(self) -> None:
        """Start the next solve from the empty working set, in the same workspace.

        Cheaper than :meth:`reset` (no new setup); for measuring what the warm
        start saves.
        """
        if self._model is not None:
            self._model.update(sense=self._sense0.copy())

    def solve_vector(self, data: Array) -> QPSolution:
        """Solve with OSQP's stacked data [q; b; h] already composed (as ``FastOSQP``).

        Data with a NaN (or an infinite cost term) never reach DAQP: the
        solution is then NaN with status ``"error"``. Bounds that contradict
        (a constraint's lower bound above its upper bound, or a constant row
        outside its bounds) give ``"infeasible"`` without a solve; DAQP finds
        the other infeasible cases. A failed solve restarts the working set
        cold.

        Parameters
        ----------
        data : ndarray
            OSQP's stacked data [q; b; h] (:meth:`FastOSQP.compose`).

        Returns
        -------
        QPSolution
            The decision variable z (NaN when there is no solution), the
            soft-constraint slacks s >= 0 (the soft rows' violations when the
            slacks were removed), the step status, DAQP's iterations and the
            wall time [s].
        """
        start = time.perf_counter()
        buffer = self.data_buffer
        if data is not buffer or buffer.base is not self._ext:  # (a copied solver: no view)
            self._ext[:-1] = data
            buffer = self._ext[:-1]
        # One sum finds a NaN or an infinity (the data are clipped to ±1e20); then look closer.
        # The sum as a BLAS dot product with ones: the same test as data.sum() (a numpy
        # reduction) at a third of its cost.
        if not math.isfinite(np.dot(buffer, self._ones)) and (
                np.isnan(data).any() or not np.isfinite(data[:self._n]).all()):
            return self._failed("error", start)
        lower, upper, violated = self._bounds_view(buffer, in_place=True)
        if violated:
            return self._failed("infeasible", start)
        if (lower > upper).any():
            hard_gap = lower[self._hard] - upper[self._hard]
            if (hard_gap > _CONTRADICTION * np.maximum(1.0, np.abs(upper[self._hard]))).any():
                return self._failed("infeasible", start)
            if self.soft and (lower[self._soft_part] > upper[self._soft_part]).any():
                return self._solve_slack_form(data, start)
        self._used = True
        if self._model is None:  # unconstrained: H x = -f
            x, flag, info = -cho_solve(self._chol, data[self._keep_index]), 1, {"iterations": 0}
        else:
            self._model.update(f=data[self._keep_index], bupper=upper, blower=lower)
            x, _, flag, info = self._model.solve()
        elapsed = time.perf_counter() - start
        status = _DAQP_STATUS.get(flag) or from_daqp(flag)
        if status != "optimal":
            self.reset()
            x = np.asarray(x, dtype=float)
            if not np.isfinite(x).all():
                x = np.full(self.n_vars, np.nan)
        z = x[self._z_pos]
        if self.soft:  # the slacks when first read (the bounds' buffers are reused: copies)
            part = self._soft_part
            return _SoftSolution.make(z, (x, self._A_soft, lower[part].copy(),
                                          upper[part].copy()),
                                      status, int(info["iterations"]), elapsed)
        return QPSolution(z, x[self._s_pos], status, int(info["iterations"]), elapsed)

    def _failed(self, status: str, start: float) -> QPSolution:
        """No solve: NaN decisions and slacks with ``status``."""
        return QPSolution(np.full(self._z_pos.size, np.nan),
                          np.full(self.fast.z_index["s"].size, np.nan), status, 0,
                          time.perf_counter() - start)

    def _solve_slack_form(self, data: Array, start: float) -> QPSolution:
        """A solve with hl > hu on a soft row: DAQP with the slack variables kept."""
        if self._slack_form is None:
            self._slack_form = FastDAQP(self.fast, soft=False, settings=self._settings)
        self.slack_solves += 1
        sol = self._slack_form.solve_vector(data)
        return QPSolution(sol.z, sol.slack, sol.status, sol.iterations,
                          time.perf_counter() - start)

