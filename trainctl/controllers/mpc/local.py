# Neighbourhood-local N-DMPC of the train: per-coach QPs on the local model only.
"""The QPs of neighbourhood-local N-DMPC (strategy ``"ndmpc-local"``).

Coach i's QP is built from its neighbourhood model alone
(:mod:`trainctl.controllers.mpc.theory.local_iteration`): its decision is its own M moves,
its cost the outputs of its neighbourhood N_i over P steps, its rows its own
input bounds and rates, the soft force rows of the couplers next to it and,
under speed limits, the soft rows on its own predicted speed — all of a size
that does not depend on the train length. The rest of the
train enters through the exchange vector ξ_i = [U_j for the other inputs
acting on the neighbourhood; the outer states' predicted trajectory], in
the QP's data only:

    g_i = Kc_i c0_i + Ko_i ξ_i,   hl_i, hu_i = ∓limit - f0_i - Fo_i ξ_i,

(a speed row: hl = -inf, hu = the step's speed bound - v0_i - Fo_i ξ_i) with
c0_i, f0_i, v0_i the free responses of the local model (measured x_S, x_O,
u(k-1) of the members). After its solve coach i publishes its plan and the
trajectory of its own states that its local model predicts with it.

Coaches whose local QPs have the same matrices (same neighbour masses and
couplers, the same rows — every interior T-M-M-T pattern of a long train)
share one canonicalised cvxpy problem and its identified OSQP data map;
each gets its own OSQP workspace (:meth:`ParametricQP.clone`), so the
probing cost is paid per distinct structure, not per coach.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.mpc.condensed import (
    BlockParameters,
    ParameterGather,
    QPBlock,
    build_block,
    input_rows,
    move_maps,
)
from trainctl.controllers.mpc.problem import (
    KN,
    StepContext,
    TrainProblem,
    fill_move_sources,
    speed_matrix,
)
from trainctl.controllers.mpc.qp.parametric import ParametricQP
from trainctl.controllers.mpc.qp.status import is_usable
from trainctl.controllers.mpc.settings import MPCConstraints
from trainctl.controllers.mpc.strategies.base import (
    FALLBACK,
    FallbackPlan,
    PlanResult,
    Strategy,
    _PerCoach,
    solve_block,
    worst_status,
)
from trainctl.controllers.mpc.theory.local_iteration.model import LocalModel
from trainctl.controllers.mpc.theory.local_iteration.predictions import (
    CoachPrediction,
    LocalResponse,
    coach_predictions,
    rows_response,
)
from trainctl.controllers.mpc.theory.mpc import MPCDesign
from trainctl.exceptions import ModelError

__all__ = ["LocalNDMPC", "LocalTrainProblem"]

Array = NDArray[np.float64]
Index = NDArray[np.int64]


@dataclass
class _Coach:
    """Coach i's data beyond its QP block (the exchange and its own-state prediction)."""

    pred: CoachPrediction
    block: QPBlock
    other_cols: Index      # the other inputs' moves in U entering its prediction
    outer_idx: Index       # the outer states' trajectory in X
    own_idx: Index         # its own states' trajectory in X
    up_idx: Index          # its inputs I in u(k-1)
    y: LocalResponse       # cost rows
    f: LocalResponse | None  # bounded force rows
    v: LocalResponse | None  # its own speed (speed rows)
    f_rows: Index          # the bounded rows in the stacked feedforward forces
    f_sel: Index           # ... and in the force response
    Gz_own: Array          # own-state trajectory from its own moves
    Gz_xi: Array           # ... from ξ_i
    g: slice               # its g and its force rows' hl, hu in the source vector
    hl: slice
    hu: slice
    v_sel: Index           # the speed rows' steps in its speed response
    v_bound: Index         # ... and in the stacked speed bounds (step-major, (P·n,))
    hu_speed: slice        # the speed rows' hu in the source vector


class LocalTrainProblem(TrainProblem):
    """Per-coach QPs of neighbourhood-local N-DMPC and their exchange.

    Parameters
    ----------
    design : MPCDesign
        Discrete design model in kN (weights, horizons, form, neighbourhoods).
    model : LocalModel
        Its continuous model partitioned by coach (hold, substeps, boundary).
    force_matrix : ndarray
        Rows mapping the design state to coupler-force deviations [kN].
    constraints : MPCConstraints
        Bounds.
    strategy : Strategy
        The strategy (:class:`LocalNDMPC`).
    name : str
        Label of the QPs.
    path : {"fast", "cvxpy"}
        QP solve path.
    qp_solver : {"auto", "osqp", "daqp"}
        The fast path's QP solver (:func:`trainctl.controllers.mpc.qp.parametric.choose_solver`).
    fixed : tuple of int
        Coaches whose moves the envelope pins (:func:`~.controller.fixed_inputs`): no QP
        is solved for them; they still publish their predicted own-state trajectory.
    speed_rows : bool
        Bound each coach's own predicted speed (soft, one-sided) at the
        coupler-force steps; each step's context then carries ``speed_bound``.

    Examples
    --------
    The problem of the ``"ndmpc-local"`` controller: one QP per coach.

    >>> from trainctl.controllers.mpc.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> problem = FAMILY.make(design, "ndmpc-local").problem
    >>> type(problem).__name__, [block.inputs for block in problem.blocks]
    ('LocalTrainProblem', [(0,), (1,), (2,), (3,)])
    """

    def __init__(self, design: MPCDesign, model: LocalModel, force_matrix: Array,
                 constraints: MPCConstraints, strategy: Strategy, *, name: str,
                 path: str, qp_solver: str = "auto", fixed: tuple[int, ...] = (),
                 speed_rows: bool = False) -> None:
        self.design, self.constraints, self.strategy = design, constraints, strategy
        self.speed_rows = speed_rows
        self.fixed = frozenset(fixed)
        self.model, self.name, self.path = model, name, path
        n, M, P = design.n_inputs, design.control_horizon, design.prediction_horizon
        self.n, self.M, self.P, self.nx = n, M, P, design.A.shape[0]
        self.N = model.substeps
        self.maps = move_maps(n, M, design.form)
        self._du = design.form == "du"
        self.residual_cols = None
        nf = force_matrix.shape[0]
        chosen = constraints.force_steps
        self._force_steps = (list(range(P)) if chosen is None
                             else sorted({int(j) - 1 for j in chosen if 1 <= j <= P}))
        self._bounded = math.isfinite(constraints.coupler_force_limit)
        self.predictions = coach_predictions(design, model)
        one = move_maps(1, M, design.form)
        hard = input_rows(one, np.arange(M), bounds=constraints.input_bounds,
                          rate=math.isfinite(constraints.rate_limit))
        MN = M * n
        start = 4 * MN
        shared: dict[bytes, ParametricQP] = {}
        self._speed_hl: list[slice] = []  # the speed rows' hl: -inf throughout
        self.coaches: list[_Coach] = []
        self.distinct = 0
        for c in self.predictions:
            i, nI = c.coach, c.inputs.size
            own_cols = np.arange(M) * nI + c.own_input
            others = np.setdiff1d(np.arange(M * nI), own_cols)
            q = np.tile(design.q[c.rows], P)
            Gii = c.y.G[:, own_cols]
            H = 2.0 * (Gii.T @ (q[:, None] * Gii) + np.eye(M) * design.r[i])
            couplers = [k for k in (i - 1, i) if 0 <= k < nf] if self._bounded else []
            f = (rows_response(design, model, c, force_matrix[couplers], every=self.N)
                 if couplers else None)
            steps = np.array(self._force_steps, dtype=np.int64)
            sel = (steps[:, None] * len(couplers) + np.arange(len(couplers))[None, :]).ravel()
            f_rows = (steps[:, None] * nf + np.array(couplers, dtype=np.int64)[None, :]).ravel()
            F = f.G[np.ix_(sel, own_cols)] if f is not None else np.zeros((0, M))
            v = (rows_response(design, model, c, speed_matrix(design)[[i]], every=self.N)
                 if speed_rows else None)
            soft_linear: float | Array = constraints.soft_linear
            soft_quadratic: float | Array = constraints.soft_quadratic
            nF = F.shape[0]
            nV = steps.size if v is not None else 0
            if v is not None:  # its speed rows follow the force rows
                F = np.vstack([F, v.G[np.ix_(steps, own_cols)]])
                soft_linear = np.concatenate([np.full(nF, constraints.soft_linear),
                                              np.full(nV, constraints.speed_soft_linear)])
                soft_quadratic = np.concatenate([np.full(nF, constraints.soft_quadratic),
                                                 np.full(nV, constraints.speed_soft_quadratic)])
            key = b"".join(np.ascontiguousarray(a).tobytes() + str(a.shape).encode()
                           for a in (H, hard, F))
            label = f"{name}[{i}]"
            if key in shared:
                qp = shared[key].clone(name=label)
            else:
                qp = ParametricQP(H, hard, F, soft_linear=soft_linear,
                                  soft_quadratic=soft_quadratic, name=label,
                                  fast=path == "fast", solver=qp_solver)
                shared[key] = qp
            Kc = 2.0 * Gii.T * q[None, :]
            Ko = Kc @ np.hstack([c.y.G[:, others], c.y.Psi])
            Fo = (np.hstack([f.G[np.ix_(sel, others)], f.Psi[sel]]) if f is not None
                  else np.zeros((0, Ko.shape[1])))
            if v is not None:
                Fo = np.vstack([Fo, np.hstack([v.G[np.ix_(steps, others)], v.Psi[steps]])])
            cols = np.arange(M) * n + i
            nb = F.shape[0]
            g, hl, hu = (slice(start, start + M), slice(start + M, start + M + nb),
                         slice(start + M + nb, start + M + 2 * nb))
            rate = math.isfinite(constraints.rate_limit)
            empty = np.zeros(0, dtype=np.int64)
            params = {"g": np.arange(g.start, g.stop),
                      "lb": np.concatenate([cols if constraints.input_bounds else empty,
                                            2 * MN + cols if rate else empty]),
                      "ub": np.concatenate([MN + cols if constraints.input_bounds else empty,
                                            3 * MN + cols if rate else empty]),
                      "hl": np.arange(hl.start, hl.stop), "hu": np.arange(hu.start, hu.stop)}
            start = hu.stop
            block = build_block(qp, inputs=(i,), cols=cols, Kc=Kc, params=params, Ko=Ko, Fo=Fo)
            fine = np.arange(P * self.N)
            self.coaches.append(_Coach(
                pred=c, block=block,
                other_cols=(np.arange(M)[:, None] * n + c.inputs[None, :]).ravel()[others],
                outer_idx=(fine[:, None] * self.nx + c.outer[None, :]).ravel(),
                own_idx=(fine[:, None] * self.nx + c.own[None, :]).ravel(),
                up_idx=c.inputs, y=c.y, f=f,
                f_rows=f_rows if f is not None else empty, f_sel=sel, Gz_own=c.z.G[:, own_cols],
                Gz_xi=np.hstack([c.z.G[:, others], c.z.Psi]), g=g,
                hl=slice(hl.start, hl.start + nF), hu=slice(hu.start, hu.start + nF), v=v,
                v_sel=steps if v is not None else empty, v_bound=steps * n + i,
                hu_speed=slice(hu.start + nF, hu.stop)))
            self._speed_hl.append(slice(hl.start + nF, hl.stop))
        self.distinct = len(shared)
        self.blocks = [c.block for c in self.coaches]
        self._src = np.zeros(start)
        for where in self._speed_hl:
            self._src[where] = -np.inf
        self._src_bounds = self._src[:2 * MN].reshape(2, MN)
        self._src_rate = self._src[2 * MN:4 * MN].reshape(2, MN)
        self._rate_pair = np.array([[-constraints.rate_limit / KN], [constraints.rate_limit / KN]])
        self._limit = constraints.coupler_force_limit / KN
        self.fast = all(b.offset is not None for b in self.blocks)
        self._gather = ParameterGather(self.blocks, fast=self.fast)
        self._free_z: list[Array] = [np.zeros(0)] * n
        self._X: Array | None = None

    # -- one step -----------------------------------------------------------------------------
    def sources(self, ctx: StepContext) -> Array:
        """Every coach's QP parameters at ξ = 0; stores each coach's own free response too.

        The layout is that of :class:`TrainProblem`, then per coach g, hl and
        hu.

        Parameters
        ----------
        ctx : StepContext
            This step's deviation state, feedforward [kN] and input bounds [kN].

        Returns
        -------
        ndarray
            The source vector (the problem's buffer, not a copy): bounds [kN],
            each coach's g and its soft-row bounds [kN].
        """
        fill_move_sources(self, ctx)
        x, up = ctx.x, ctx.u_dev_prev
        src = self._src
        for k, c in enumerate(self.coaches):
            xs, xo = x[c.pred.states], x[c.pred.outer]
            c0 = c.y.Phi @ xs + c.y.Phi_o @ xo
            z0 = c.pred.z.Phi @ xs + c.pred.z.Phi_o @ xo
            if self._du:
                c0 += c.y.Su @ up[c.up_idx]
                z0 += c.pred.z.Su @ up[c.up_idx]
            src[c.g] = c.block.Kc @ c0
            self._free_z[k] = z0
            if c.f is not None and c.f_rows.size:
                f = c.f
                f0 = f.Phi @ xs + f.Phi_o @ xo
                if self._du:
                    f0 += f.Su @ up[c.up_idx]
                f0 = f0[c.f_sel] + ctx.f_ff[c.f_rows]
                src[c.hl] = -self._limit - f0
                src[c.hu] = self._limit - f0
            if c.v is not None:
                if ctx.speed_bound is None:
                    raise ModelError(f"{self.name}: the speed rows need this step's speed "
                                     "bounds (StepContext.speed_bound is None).")
                v = c.v
                v0 = v.Phi @ xs + v.Phi_o @ xo
                if self._du:
                    v0 += v.Su @ up[c.up_idx]
                src[c.hu_speed] = ctx.speed_bound.ravel()[c.v_bound] - v0[c.v_sel]
        self._x = x
        return src

    def parameters(self, ctx: StepContext) -> list[BlockParameters]:
        """Per-sample parameters of every coach's QP (at zero exchange).

        Parameters
        ----------
        ctx : StepContext
            This step's deviation state, feedforward [kN] and input bounds [kN].

        Returns
        -------
        list of BlockParameters
            One per coach: OSQP's composed data on the fast path, else the
            vectors g, lb, ub, hl, hu.
        """
        return self._gather(self.sources(ctx))

    def reset(self) -> None:
        """Forget every QP's warm start and the exchanged trajectories."""
        super().reset()
        self._X = None

    def initial_trajectories(self) -> Array:
        """The exchanged trajectories to start from.

        The last ones shifted by one sample (the last sample repeated), or the
        measured state held at the first step.

        Returns
        -------
        ndarray, shape (P·N·nx,)
            The deviation state x̃ (speeds [m/s], elongations [m]) at each of
            the P·N substeps of the horizon, stacked substep by substep.

        Raises
        ------
        RuntimeError
            Before the first :meth:`sources` (or :meth:`parameters`) since
            the problem was built: there is no measured state to hold.
        """
        nx, fine, N = self.nx, self.P * self.N, self.N
        if self._X is None:
            x = getattr(self, "_x", None)
            if x is None:
                raise RuntimeError("LocalTrainProblem.initial_trajectories: no state yet; "
                                   "call sources() or parameters() with this step's context "
                                   "first.")
            return np.tile(x, fine)
        X = self._X.reshape(fine, nx)
        return np.vstack([X[N:], np.repeat(X[-1:], N, axis=0)]).ravel()

    def iterate(self, params: Sequence[BlockParameters], plan0: Array, fallback: FallbackPlan,
                *, max_iterations: int, tolerance: float, relaxation: float) -> PlanResult:
        """Relaxed Jacobi iterations on [plans; trajectories] from the shifted previous ones.

        Stops when the largest change of any plan is at most ``tolerance`` [kN].

        Parameters
        ----------
        params : sequence of BlockParameters
            This step's parameters of each coach's QP (:meth:`parameters`).
        plan0 : ndarray, shape (M·n,)
            The starting plan (the shifted previous plan, pinned coaches'
            moves set) [kN].
        fallback : callable
            ``fallback(block) -> z``: a coach's moves [kN] when its solve
            gives no usable solution.
        max_iterations : int
            Largest number of Jacobi iterations, >= 1.
        tolerance : float
            Convergence tolerance on the largest change of the plan [kN], >= 0.
        relaxation : float
            Relaxation factor ω in (0, 1].

        Returns
        -------
        PlanResult
            The last plan [kN], the worst coach status (``"max_iterations"``
            when it did not converge), the iterations, the largest change of
            each [kN] and the fallback applied. The last trajectories are kept
            for the next step's :meth:`initial_trajectories`.
        """
        U, X = plan0.copy(), self.initial_trajectories()
        residuals: list[float] = []
        statuses, applied, reason = [], "", ""
        converged = False
        w = relaxation
        for _ in range(max_iterations):
            newU, newX = U.copy(), X.copy()
            for k, (c, prep) in enumerate(zip(self.coaches, params, strict=True)):
                xi = np.concatenate([U[c.other_cols], X[c.outer_idx]])
                cols = c.block.cols
                if c.pred.coach in self.fixed:  # pinned moves (set in plan0 by the controller)
                    newX[c.own_idx] = self._free_z[k] + c.Gz_xi @ xi + c.Gz_own @ U[cols]
                    continue
                sol, why = solve_block(c.block, prep, xi, self.path)
                reason = reason or why
                z, status = sol.z, sol.status
                if not is_usable(status):
                    z, applied = fallback(c.block), FALLBACK
                statuses.append(status)
                newU[cols] = z if w == 1.0 else w * z + (1 - w) * U[cols]
                newX[c.own_idx] = self._free_z[k] + c.Gz_xi @ xi + c.Gz_own @ newU[cols]
            change = float(np.max(np.abs(newU - U)))
            residuals.append(change)
            U, X = newU, newX
            if change <= tolerance:
                converged = True
                break
        self._X = X
        status = worst_status(statuses, applied)
        if not converged and status == "optimal":
            status = "max_iterations"
        return PlanResult(U, status, len(residuals), residuals, applied, reason)


@dataclass(frozen=True)
class LocalNDMPC(_PerCoach):
    """Neighbourhood-local N-DMPC: relaxed Jacobi on plans and exchanged trajectories.

    Parameters
    ----------
    max_iterations : int
        Largest number of Jacobi iterations per step.
    tolerance : float
        Convergence tolerance on the change of the plans.
    relaxation : float
        Relaxation factor ω in (0, 1].

    Examples
    --------
    At the equilibrium state on a constant reference the local iterations
    keep the equilibrium forces of the two motor cars [kN]:

    >>> from trainctl.controllers.mpc.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> from trainctl.controllers.base import Measurement, ReferencePreview
    >>> from trainctl.models import equilibrium
    >>> v = scenario.model.speed  # 83.3 m/s
    >>> eq = equilibrium(scenario.train, v)
    >>> ref = ReferencePreview(times=20.0 * np.arange(5), speed=np.full(5, v),
    ...                        acceleration=np.zeros(5))
    >>> ctl = FAMILY.make(design, "ndmpc-local")
    >>> type(ctl._strategy).__name__
    'LocalNDMPC'
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> rec.status, (rec.inputs / 1e3).round(2).tolist()
    ('optimal', [0.0, 11.79, 11.79, 0.0])
    """

    max_iterations: int
    tolerance: float
    relaxation: float
    name = "ndmpc-local"

    def members(self, inputs: tuple[int, ...], design: MPCDesign) -> tuple[int, ...]:
        """The coach's neighbourhood.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for: one coach.
        design : MPCDesign
            The design (its neighbourhoods).

        Returns
        -------
        tuple of int
            ``design.neighbourhoods[inputs[0]]``.
        """
        return design.neighbourhoods[inputs[0]]

    def plan(self, problem: object, params: Sequence[BlockParameters], plan0: Array,
             fallback: FallbackPlan) -> PlanResult:
        """Relaxed Jacobi iterations on the local problem's plans and trajectories.

        Parameters
        ----------
        problem : LocalTrainProblem
            The local problem.
        params : sequence of BlockParameters
            This step's parameters of each coach's QP.
        plan0 : ndarray, shape (M·n,)
            The starting plan (the shifted previous plan) [kN].
        fallback : callable
            ``fallback(block) -> z``: a coach's moves [kN] when its solve
            gives no usable solution.

        Returns
        -------
        PlanResult
            As :meth:`LocalTrainProblem.iterate` returns it, with this
            strategy's iteration settings.

        Raises
        ------
        TypeError
            If ``problem`` is not a :class:`LocalTrainProblem`.
        """
        if not isinstance(problem, LocalTrainProblem):
            raise TypeError("ndmpc-local plans on a LocalTrainProblem.")
        return problem.iterate(params, plan0, fallback, max_iterations=self.max_iterations,
                               tolerance=self.tolerance, relaxation=self.relaxation)
