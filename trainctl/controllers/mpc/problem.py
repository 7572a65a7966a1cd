# The train MPC's condensed QPs and their per-step parameters.
"""The problem of the train MPC: the condensed core plus the train's data.

With x̃ = [v - v_ref; delta - delta_ff] and ũ = u - u_ff (kN) about the
feedforward u_ff, the prediction of :mod:`trainctl.controllers.mpc.theory.mpc` gives
Y = Φx̃ + S_u ũ(k-1) + G U for the design outputs (speed errors,
coupler-force deviations in kN) and a second prediction for the coupler
forces that the constraints bound. The QPs are the blocks of
:mod:`.condensed` — one per optimiser of the strategy (:mod:`.strategies`) —
with the train's data:

- hard rows on the input moves (the traction/braking envelope less the
  feedforward, :class:`StepContext` ``bounds``) and on their rates, which
  include the feedforward's own change;
- soft rows on the absolute coupler forces (the feedforward's static forces
  plus the predicted deviations) at the chosen prediction steps;
- under speed limits (``speed_rows``), one-sided soft rows on every vehicle's
  predicted speed at the same steps: the predicted deviation
  v_i(k+j) - v_ref(k+j) at most ℓ - margin - v_ref(k+j), the bound of each
  step (:class:`StepContext` ``speed_bound``, from
  :class:`~.speed_limits.HorizonLimits`) less the free response;
- the cost of the outputs of the block's members (its neighbourhood).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.faults import safe_inputs
from trainctl.controllers.mpc.condensed import (
    BlockParameters,
    ParameterGather,
    QPBlock,
    build_block,
    input_rows,
    move_maps,
)
from trainctl.controllers.mpc.qp.parametric import ParametricQP
from trainctl.controllers.mpc.settings import MPCConstraints
from trainctl.controllers.mpc.strategies.base import Strategy
from trainctl.controllers.mpc.theory.mpc import MPCDesign, Prediction, prediction
from trainctl.exceptions import ModelError

if TYPE_CHECKING:
    from trainctl.controllers.mpc.local import LocalTrainProblem

__all__ = ["StepContext", "TrainProblem"]

KN = 1e3
Array = NDArray[np.float64]
Index = NDArray[np.int64]


@dataclass(frozen=True, slots=True)
class StepContext:
    """What one step of the train MPC works with (deviation coordinates, kN).

    Parameters
    ----------
    x : ndarray
        Deviation state x̃ = [v - v_ref; delta - delta_ff], (2n-1,).
    u_ff : ndarray
        Feedforward inputs at the M moves, (M, n) [kN].
    f_ff : ndarray
        Feedforward coupler forces at steps 1..P, stacked step by step (P·nf,) [kN].
    u_prev : ndarray
        The input applied at the previous sample (absolute) [kN].
    u_dev_prev : ndarray
        ũ(k-1) = u(k-1) - u_ff(k-1) (Δu-form; zeros in the u-form) [kN].
    u_dev_prev_tiled : ndarray
        ũ(k-1) repeated for every move, (M·n,) [kN].
    bounds : ndarray
        Lower and upper bounds of the input moves ũ, (2, M·n) [kN].
    applied : ndarray or None
        For a fallback (:meth:`TrainProblem.safe_plan`): the input the
        actuators applied at the previous sample, as far as the controller
        knows it (its request cut to the envelope at the speeds it measured
        then) [kN]; None: ``u_prev``.
    actuator : ndarray or None
        For a fallback: each vehicle's envelope at its measured speed now,
        [lower; upper], (2, n) [kN] (what the actuators can apply; ``bounds``
        are at the reference speeds); None: ``bounds`` only.
    speed_bound : ndarray or None
        The upper bound of every vehicle's speed deviation at steps 1..P,
        (P, n) [m/s] (inf where no limit applies); None for a problem without
        speed rows.

    Examples
    --------
    A step of a four-coach train at zero deviation, M = 2 moves and P = 4
    steps (three couplers), with moves bounded by ±100 kN:

    >>> ctx = StepContext(x=np.zeros(7), u_ff=np.zeros((2, 4)), f_ff=np.zeros(12),
    ...                   u_prev=np.zeros(4), u_dev_prev=np.zeros(4),
    ...                   u_dev_prev_tiled=np.zeros(8),
    ...                   bounds=np.vstack([np.full(8, -100.0), np.full(8, 100.0)]))
    >>> ctx.lb[:2].tolist(), ctx.ub[:2].tolist()  # [kN]
    ([-100.0, -100.0], [100.0, 100.0])
    """

    x: Array
    u_ff: Array
    f_ff: Array
    u_prev: Array
    u_dev_prev: Array
    u_dev_prev_tiled: Array
    bounds: Array
    applied: Array | None = None
    actuator: Array | None = None
    speed_bound: Array | None = None

    @property
    def lb(self) -> Array:
        """Lower bounds of the input moves ũ [kN]."""
        lower: Array = self.bounds[0]
        return lower

    @property
    def ub(self) -> Array:
        """Upper bounds of the input moves ũ [kN]."""
        upper: Array = self.bounds[1]
        return upper


class TrainProblem:
    """The QP blocks of a train MPC and their per-step parameters.

    Parameters
    ----------
    design : MPCDesign
        Discrete design model in kN.
    force_matrix : ndarray
        Rows mapping the design state to coupler-force deviations [kN].
    constraints : MPCConstraints
        Bounds.
    strategy : Strategy
        Decides the blocks, their costs and their force rows.
    name : str
        Label of the QPs.
    path : {"fast", "cvxpy"}
        QP solve path.
    qp_solver : {"auto", "osqp", "daqp"}
        QP solver of the fast path (:func:`~trainctl.controllers.mpc.qp.parametric.choose_solver`).
    fixed : tuple of int
        Coaches whose moves the envelope pins (:func:`~.controller.fixed_inputs`): a
        block of only such coaches is not built; their moves are the controller's.
    speed_rows : bool
        Bound every vehicle's predicted speed (soft, one-sided) at the
        coupler-force steps, each block its own vehicles'
        (:meth:`~.strategies.base.Strategy.vehicles`); each step's context
        then carries ``speed_bound``.

    Examples
    --------
    The centralised problem of the ``crh2-dmpc`` design has one block over
    the 2 moves of the 4 coaches; at zero deviation its optimal plan is zero.

    >>> from trainctl.controllers.mpc.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> from trainctl.controllers.mpc.strategies import make_strategy
    >>> strategy = make_strategy("centralised", max_iterations=1, tolerance=1e-6,
    ...                          relaxation=1.0, weights=np.full(4, 0.25))
    >>> problem = TrainProblem(design.mpc, design.model.force_rows() / 1e3,
    ...                        design.settings.mpc_constraints(), strategy, name="demo",
    ...                        path="fast")
    >>> len(problem.blocks), problem.blocks[0].inputs, problem.blocks[0].cols.size
    (1, (0, 1, 2, 3), 8)
    >>> ctx = StepContext(x=np.zeros(7), u_ff=np.zeros((2, 4)), f_ff=np.zeros(12),
    ...                   u_prev=np.zeros(4), u_dev_prev=np.zeros(4),
    ...                   u_dev_prev_tiled=np.zeros(8),
    ...                   bounds=np.vstack([np.full(8, -100.0), np.full(8, 100.0)]))
    >>> result = strategy.plan(problem, problem.parameters(ctx), np.zeros(8),
    ...                        lambda block: np.zeros(block.cols.size))
    >>> result.status, float(np.abs(result.plan).max().round(6))
    ('optimal', 0.0)
    """

    def __init__(self, design: MPCDesign, force_matrix: Array, constraints: MPCConstraints,
                 strategy: Strategy, *, name: str, path: str,
                 qp_solver: str = "auto", fixed: tuple[int, ...] = (),
                 speed_rows: bool = False) -> None:
        self.design, self.constraints, self.strategy = design, constraints, strategy
        self.fixed = frozenset(fixed)
        self.name, self.path, self.qp_solver = name, path, qp_solver
        n, M, P = design.n_inputs, design.control_horizon, design.prediction_horizon
        self.n, self.M, self.P = n, M, P
        self.pred: Prediction = prediction(design)
        self.fpred: Prediction = prediction(replace(design, C=force_matrix,
                                                    q=np.ones(force_matrix.shape[0]),
                                                    output_owner=tuple(range(force_matrix.shape[0]))))
        self.speed_rows = speed_rows
        # The speeds' prediction (deviations from the reference [m/s]); only with speed rows.
        self.vpred: Prediction | None = (
            prediction(replace(design, C=speed_matrix(design), q=np.ones(n),
                               output_owner=tuple(range(n)))) if speed_rows else None)
        self.maps = move_maps(n, M, design.form)
        self._du = design.form == "du"
        self._layout()
        self.blocks: list[QPBlock] = []
        g_start = self._source_g
        for inputs in strategy.block_inputs(n):
            if self.fixed.issuperset(inputs):
                continue  # pinned by its envelope: its moves are set by the controller
            self.blocks.append(self._build_block(inputs, g_start))
            g_start += self.blocks[-1].cols.size
        self._source_buffer(g_start)
        self.fast = all(b.offset is not None for b in self.blocks)
        self._gather = ParameterGather(self.blocks, fast=self.fast)
        covered = np.unique(np.concatenate([b.cols for b in self.blocks]))
        # Iteration residual over the blocks' columns; None: they cover the whole plan.
        self.residual_cols = None if covered.size == M * n else covered

    # -- construction -------------------------------------------------------------------------
    def _layout(self) -> None:
        """The bounded force rows and the source layout, before the blocks locate theirs in it."""
        P, MN = self.P, self.M * self.n
        nf = self.fpred.G.shape[0] // P
        chosen = self.constraints.force_steps
        steps = (range(P) if chosen is None
                 else sorted({int(j) - 1 for j in chosen if 1 <= j <= P}))
        self._force_steps = list(steps)
        if math.isfinite(self.constraints.coupler_force_limit):
            bounded = sorted({j * nf + c for j in steps for c in range(nf)})
        else:
            bounded = []
        self._bounded_rows = np.array(bounded, dtype=np.int64)
        self._fPhi = self.fpred.Phi[self._bounded_rows]
        self._fSu = self.fpred.Su[self._bounded_rows]
        n = self.n
        # Speed rows of vehicle i at step j: row j·n + i of the speed prediction.
        speeds = (sorted(j * n + i for j in steps for i in range(n)) if self.vpred is not None
                  else [])
        self._speed_rows = np.array(speeds, dtype=np.int64)
        if self.vpred is not None:
            self._vPhi = self.vpred.Phi[self._speed_rows]
            self._vSu = self.vpred.Su[self._speed_rows]
        nb = self._bounded_rows.size + self._speed_rows.size
        # Source layout (see sources): [lb_u; ub_u; lb_rate; ub_rate; hl; hu; g of each block],
        # hl and hu each the force rows, then the speed rows.
        self._source_hl, self._source_hu = 4 * MN, 4 * MN + nb
        self._source_g = 4 * MN + 2 * nb

    def _source_buffer(self, size: int) -> None:
        """The source vector of :meth:`sources` and views of the parts it writes.

        One buffer, rewritten every step; parts that no problem uses stay zero.
        """
        MN, nf, nv = self.M * self.n, self._bounded_rows.size, self._speed_rows.size
        nb = nf + nv
        self._src = np.zeros(size)
        self._src_bounds = self._src[:2 * MN].reshape(2, MN)
        self._src_rate = self._src[2 * MN:4 * MN].reshape(2, MN)
        soft = self._src[4 * MN:4 * MN + 2 * nb].reshape(2, nb)
        self._src_force = soft[:, :nf]
        self._src_speed = soft[1, nf:]  # hu of the speed rows; their hl stay -inf
        soft[0, nf:] = -np.inf
        self._src_g = [self._src[int(b.params["g"][0]):int(b.params["g"][-1]) + 1]
                       for b in self.blocks]
        limit = self.constraints.coupler_force_limit / KN
        rate = self.constraints.rate_limit / KN
        self._force_pair = np.array([[-limit], [limit]])  # hl, hu = ∓limit - f0
        self._rate_pair = np.array([[-rate], [rate]])     # rate bounds ∓du - offset

    def _build_block(self, inputs: tuple[int, ...], g_start: int) -> QPBlock:
        """The block of ``inputs``: its members' cost, its rows and its QP."""
        d, pred, c = self.design, self.pred, self.constraints
        cols = np.sort(np.concatenate([pred.columns[i] for i in inputs]))
        members = self.strategy.members(inputs, d)
        mask = np.array([o in members for o in d.output_owner], dtype=float)
        weight = np.tile(d.q * mask, self.P)
        Gi = pred.G[:, cols]
        H = 2.0 * (Gi.T @ (weight[:, None] * Gi) + pred.Rbar[np.ix_(cols, cols)])
        rows = self._force_rows(inputs)
        F = self.fpred.G[np.ix_(rows, cols)] if rows.size else np.zeros((0, cols.size))
        Fo = self.fpred.G[rows, :].copy()
        soft_linear: float | Array = c.soft_linear
        soft_quadratic: float | Array = c.soft_quadratic
        vrows = self._vehicle_rows(inputs)
        if self.vpred is not None and vrows.size:  # the speed rows follow the force rows
            F = np.vstack([F, self.vpred.G[np.ix_(vrows, cols)]])
            Fo = np.vstack([Fo, self.vpred.G[vrows, :]])
            soft_linear = np.concatenate([np.full(rows.size, c.soft_linear),
                                          np.full(vrows.size, c.speed_soft_linear)])
            soft_quadratic = np.concatenate([np.full(rows.size, c.soft_quadratic),
                                             np.full(vrows.size, c.speed_soft_quadratic)])
        hard = input_rows(self.maps, cols, bounds=c.input_bounds,
                          rate=math.isfinite(c.rate_limit))
        qp = ParametricQP(H, hard, F, soft_linear=soft_linear, soft_quadratic=soft_quadratic,
                          name=f"{self.name}[{','.join(map(str, inputs))}]",
                          fast=self.path == "fast", solver=self.qp_solver)
        Kc = 2.0 * Gi.T * weight[None, :]
        Ko = Kc @ pred.G
        Ko[:, cols] = 0.0
        Fo[:, cols] = 0.0
        return build_block(qp, inputs=inputs, cols=cols, Kc=Kc,
                           params=self._positions(cols, rows, g_start, vrows), Ko=Ko, Fo=Fo)

    def _force_rows(self, inputs: tuple[int, ...]) -> Index:
        """Rows of the force prediction that the block of ``inputs`` bounds."""
        if not math.isfinite(self.constraints.coupler_force_limit):
            return np.zeros(0, dtype=np.int64)
        nf = self.fpred.G.shape[0] // self.P
        couplers = self.strategy.couplers(inputs, nf)
        return np.array([j * nf + c for j in self._force_steps for c in couplers],
                        dtype=np.int64)

    def _vehicle_rows(self, inputs: tuple[int, ...]) -> Index:
        """Rows of the speed prediction that the block of ``inputs`` bounds (none without
        speed rows)."""
        if self.vpred is None:
            return np.zeros(0, dtype=np.int64)
        vehicles = self.strategy.vehicles(inputs, self.n)
        return np.array([j * self.n + i for j in self._force_steps for i in vehicles],
                        dtype=np.int64)

    def _positions(self, cols: Index, rows: Index, g_start: int,
                   vrows: Index | None = None) -> dict[str, Index]:
        """Positions of the block's g, lb, ub, hl, hu in the source vector (the force rows
        ``rows``, then the speed rows ``vrows``)."""
        MN = self.M * self.n
        empty = np.zeros(0, dtype=np.int64)
        bounds = self.constraints.input_bounds
        rate = math.isfinite(self.constraints.rate_limit)
        where = np.searchsorted(self._bounded_rows, rows)
        if vrows is not None and vrows.size:
            speeds = self._bounded_rows.size + np.searchsorted(self._speed_rows, vrows)
            where = np.concatenate([where, speeds])
        return {"g": g_start + np.arange(cols.size),
                "lb": np.concatenate([cols if bounds else empty,
                                      2 * MN + cols if rate else empty]),
                "ub": np.concatenate([MN + cols if bounds else empty,
                                      3 * MN + cols if rate else empty]),
                "hl": self._source_hl + where, "hu": self._source_hu + where}

    # -- one step -----------------------------------------------------------------------------
    def sources(self, ctx: StepContext) -> Array:
        """Every block's QP parameters at U = 0, stacked; each block gathers its own.

        Layout (M·n entries each for the first four): lower and upper bounds
        of the hard rows on the input moves, then on the move rates, then hl
        and hu for the bounded rows of the force prediction followed by the
        speed rows (their hl -inf, their hu ``ctx.speed_bound`` less the
        free response), then g of each block in turn (``QPBlock.params``
        holds the positions). Parts that no problem uses are zero. The array
        is the problem's buffer, rewritten by the next call.

        Input moves are ũ = L U + t0; absolute forces u_ff + ũ. The rate of
        move m is (u_ff(m) - u_ff(m-1)) + (ũ(m) - ũ(m-1)), with the applied
        u(k-1) before move 0. L and the difference matrix are block diagonal
        by coach, so the other coaches' moves do not enter a block's bounds.

        Parameters
        ----------
        ctx : StepContext
            This step's deviation state, feedforward [kN] and input bounds [kN].

        Returns
        -------
        ndarray
            The source vector (the problem's buffer, not a copy): bounds [kN],
            soft-row bounds [kN] and each block's g.
        """
        # In the u-form ũ(k-1) = 0 and S_u = 0: their terms are left out.
        pred = self.pred
        fill_move_sources(self, ctx)
        if self._bounded_rows.size:
            f0 = self._fPhi @ ctx.x
            if self._du:
                f0 += self._fSu @ ctx.u_dev_prev
            f0 += ctx.f_ff[self._bounded_rows]
            np.subtract(self._force_pair, f0, out=self._src_force)
        if self._speed_rows.size:
            if ctx.speed_bound is None:
                raise ModelError(f"{self.name}: the speed rows need this step's speed bounds "
                                 "(StepContext.speed_bound is None).")
            v0 = self._vPhi @ ctx.x
            if self._du:
                v0 += self._vSu @ ctx.u_dev_prev
            np.subtract(ctx.speed_bound.ravel()[self._speed_rows], v0, out=self._src_speed)
        c0 = pred.Phi @ ctx.x
        if self._du:
            c0 += pred.Su @ ctx.u_dev_prev
        for block, out in zip(self.blocks, self._src_g, strict=True):
            np.matmul(block.Kc, c0, out=out)  # block by block: stacking changes the rounding
        return self._src

    def parameters(self, ctx: StepContext) -> list[BlockParameters]:
        """Per-sample parameters of every block's QP (independent of the other plans).

        Parameters
        ----------
        ctx : StepContext
            This step's deviation state, feedforward [kN] and input bounds [kN].

        Returns
        -------
        list of BlockParameters
            One per block of :attr:`blocks`: OSQP's composed data on the fast
            path, else the vectors g, lb, ub, hl, hu.
        """
        return self._gather(self.sources(ctx))

    def reset(self) -> None:
        """Forget every QP's warm start (:meth:`ParametricQP.reset`)."""
        for block in self.blocks:
            block.qp.reset()

    def fallback(self, block: QPBlock, ctx: StepContext, plan0: Array) -> Array:
        """The block's part of the shifted previous plan, made safe (:meth:`safe_plan`).

        Parameters
        ----------
        block : QPBlock
            The block whose solve failed.
        ctx : StepContext
            This step's deviation state, feedforward [kN] and input bounds [kN].
        plan0 : ndarray, shape (M·n,)
            The shifted previous plan [kN].

        Returns
        -------
        ndarray
            The safe plan's entries in the block's columns [kN].
        """
        return self.safe_plan(ctx, plan0)[block.cols]

    def safe_plan(self, ctx: StepContext, plan: Array) -> Array:
        """``plan`` with its moves clipped to the envelope, then to the rate limit.

        Move by move, each coach's absolute force u_ff + ũ is clipped to its
        envelope at the previewed speed (the bounds of ``ctx``), then to
        within ``rate_limit`` of the force before it. Before the first move
        that is the input applied at the previous sample (``ctx.applied``,
        else ``ctx.u_prev``), and the first move, the one applied now, is
        then clipped to the actuators' envelope at the measured speeds
        (``ctx.actuator``, when given). The envelope at the reference speed
        is a planning bound: where it and the rate window do not meet (the
        reference ran ahead of the train) the rate limit wins; where the
        actuators' own envelope and the window do not meet (the train's
        speed moved the envelope further than the rate limit allows) the
        actuators' envelope wins (:func:`~trainctl.controllers.faults.safe_inputs`):
        the force is always one the vehicle can apply. Works in the u- and
        the Δu-form (the plan is converted to moves and back).

        Parameters
        ----------
        ctx : StepContext
            This step's deviation state, feedforward [kN] and input bounds [kN].
        plan : ndarray, shape (M·n,)
            A plan U in the design's form (moves or their increments) [kN].

        Returns
        -------
        ndarray, shape (M·n,)
            The clipped plan in the same form [kN] (a copy of ``plan`` when
            neither input bounds nor a rate limit are set).
        """
        bounds, rate = self.constraints.input_bounds, self.constraints.rate_limit / KN
        if not bounds and not math.isfinite(rate):
            return plan.copy()
        n, maps = self.n, self.maps
        ff = ctx.u_ff.ravel()
        force = maps.L @ plan + ctx.u_dev_prev_tiled + ff   # absolute forces [kN], move by move
        before = ctx.u_prev if ctx.applied is None else ctx.applied
        for m in range(self.M):
            now = force[m * n:(m + 1) * n]
            if bounds:
                np.clip(now, ctx.lb[m * n:(m + 1) * n] + ff[m * n:(m + 1) * n],
                        ctx.ub[m * n:(m + 1) * n] + ff[m * n:(m + 1) * n], out=now)
            if m == 0 and ctx.actuator is not None:
                now[:] = safe_inputs(now, before, rate, ctx.actuator[0], ctx.actuator[1])
            elif math.isfinite(rate):
                np.clip(now, before - rate, before + rate, out=now)
            before = now
        moves = force - ff
        if not self._du:
            return moves
        z = maps.D @ moves
        z[:n] -= ctx.u_dev_prev
        return z


def speed_matrix(design: MPCDesign) -> Array:
    """The rows picking the n speeds [m/s] out of the design state [v; delta] (n, 2n-1).

    Parameters
    ----------
    design : MPCDesign
        The train's design (n inputs, 2n-1 states).

    Returns
    -------
    ndarray
        [I_n, 0].

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> speed_matrix(SimpleNamespace(n_inputs=2, A=np.zeros((3, 3)))).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    """
    n = design.n_inputs
    return np.eye(n, design.A.shape[0])


def fill_move_sources(problem: TrainProblem | LocalTrainProblem, ctx: StepContext) -> None:
    """Fill ``problem._src_bounds`` and ``problem._src_rate``: the input-bound and rate rows'
    parameters at ξ = 0, shared by :class:`TrainProblem` and the local problem.

    Parameters
    ----------
    problem : TrainProblem or LocalTrainProblem
        Has ``constraints``, ``maps``, ``n``, ``_du``, ``_src_bounds``, ``_src_rate`` and
        ``_rate_pair``.
    ctx : StepContext
        This step's context.
    """
    base = ctx.u_dev_prev_tiled
    if problem.constraints.input_bounds:
        if problem._du:
            np.subtract(ctx.bounds, base, out=problem._src_bounds)
        else:
            problem._src_bounds[...] = ctx.bounds
    if math.isfinite(problem.constraints.rate_limit):
        ff = ctx.u_ff.ravel()
        # u_ff(m) - u_ff(m-1), with the applied u(k-1) before move 0
        offset = ff - np.concatenate((ctx.u_prev, ff[:-problem.n]))
        if problem._du:
            offset += problem.maps.D @ base
        np.subtract(problem._rate_pair, offset, out=problem._src_rate)
