# The MPC family: centralised, decentralised, N-DMPC and cooperative DMPC.
"""Model predictive controllers for the train, all on one condensed QP model.

Each controller works in deviation coordinates about a feedforward: the
quasi-static force distribution that makes the train follow the reference
speed and acceleration (:func:`trainctl.models.equilibrium` with the
``traction_share`` allocation, so the T-M-M-T static coupler forces are part
of it). With x̃ = [v - v_ref; delta - delta_ff] and ũ = u - u_ff (kN), the
prediction of :mod:`trainctl.analysis.mpc` gives Y = Φx̃ + S_u ũ(k-1) + G U
for the design outputs (speed errors, coupler-force deviations in kN) and a
second prediction for the coupler forces that the constraints bound.

Strategies (``strategy``):

``"centralised"``
    One QP over every coach's moves and the whole-train cost.
``"decentralised"``
    Coach i optimises its own outputs over its own moves, predicting with the
    other coaches' inputs at their feedforward (one solve, no exchange).
``"ndmpc"``
    Neighbourhood optimisation: coach i optimises the cost of its
    neighbourhood over its own moves with the others' plans fixed at the
    previous iterate; Jacobi iterations, relaxed by ``relaxation`` (ω), from
    the shifted previous plan, until every change is below ``tolerance`` [kN]
    or ``max_iterations``.
``"cooperative"``
    Every coach optimises the whole-train cost over its own moves; the new
    plan is the convex combination Σ_i w_i (plan with block i replaced).

Constraints: the traction/braking envelope of every coach at the reference
speed (hard; trailers brake only), the input rate (hard, per step), and the
absolute coupler force including its static part (soft, with slack
penalties). A local problem carries the bounds of its own inputs and the
force rows of the couplers next to its coach (centralised: all). A solve that
returns no usable solution is recorded and replaced by the shifted previous
plan (clipped to the bounds), or by the feedforward when there is none.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ...analysis.mpc import MPCDesign, Prediction, prediction
from ...exceptions import ModelError
from ...models.train import Train
from ...models.vehicle import TractionEnvelope, envelope_limit
from ..base import Measurement, ReferencePreview, StepRecord
from ..observer import KalmanObserver, ObserverSettings
from ..qp import ParametricQP
from ..status import is_usable
from .settings import STRATEGIES, MPCConstraints

__all__ = ["STRATEGIES", "MPCConstraints", "MPCController", "make_mpc"]

KN = 1e3
Array = NDArray[np.float64]

_ENVELOPE_LIMIT: Callable[..., Array] = envelope_limit
"""The stock envelope's limit function; elementwise numpy, so it also broadcasts over
vehicles given per-vehicle arrays (annotated for scalars, hence this alias)."""


@dataclass(frozen=True)
class _Block:
    """One optimiser: the coaches it decides for, its QP and its precomputed maps.

    With c0 = Φx̃ + S_u ũ(k-1) and f0 the force prediction without moves, the
    block's QP vectors are g = Kc c0 + Ko U, hl/hu = ∓limit - f0[rows] - Fo U
    (U the whole plan; Ko, Fo have the block's own columns zeroed); the bounds
    do not depend on the other coaches. Every step, the parameter vectors of
    all blocks at U = 0 are computed once, stacked in one source vector
    (:meth:`MPCController._sources`); ``params`` locates the block's g, lb,
    ub, hl and hu in it. The fast path folds all of it into the solver data:
    data = offset + J·clip(source[gather]) + Jo U. J is usually a scaled
    selection (at most one non-zero per row: every solver datum comes from
    one parameter); it is then stored as ``pick`` and ``scale``, with
    J·clip(source[gather]) = scale·clip(source)[pick], the same numbers
    without the dense product.
    """

    coaches: tuple[int, ...]
    cols: NDArray[np.int64]          # its columns in the decision vector
    force_rows: NDArray[np.int64]    # rows of the force prediction it bounds
    Kc: Array                        # 2 G_iᵀ W_i, maps c0 to g
    Ko: Array                        # 2 G_iᵀ W_i G (own columns zeroed)
    Fo: Array                        # force rows of G (own columns zeroed)
    Jo: Array | None                 # fast path: data sensitivity to U
    qp: ParametricQP
    params: dict[str, NDArray[np.int64]]  # positions of g, lb, ub, hl, hu in the source vector
    gather: NDArray[np.int64]        # the QP's parameters (its map's columns) in the source
    J: Array | None                  # fast path: data sensitivity to those parameters
    offset: Array | None             # fast path: data at zero parameters
    pick: NDArray[np.int64] | None   # fast path, J a scaled selection: source entry of each datum
    scale: Array | None              # ... and its factor (0 for constant data)


class MPCController:
    """An MPC controller of the train (see the module docstring).

    Build it with :func:`make_mpc`.

    Parameters
    ----------
    train : Train
        The train (for the feedforward and the envelopes).
    design : MPCDesign
        Discrete design model in kN (from :func:`trainctl.analysis.design_model`).
    force_matrix : ndarray
        Rows mapping the design state to coupler-force deviations [kN].
    dt : float
        Sample time [s].
    strategy : str
        One of :data:`STRATEGIES`.
    constraints : MPCConstraints
        Bounds.
    max_iterations : int
        Iteration limit for ``"ndmpc"`` / ``"cooperative"``.
    tolerance : float
        Stop when every coach's plan changes by less than this [kN].
    relaxation : float
        ω in (0, 1] for ``"ndmpc"``.
    cooperative_weights : ndarray or None
        Convex weights for ``"cooperative"`` (default 1/n).
    path : {"fast", "cvxpy"}
        QP solve path.
    name : str
        Label.
    observer : KalmanObserver or None
        With an observer the controller uses the measured speeds only
        (``measurement.outputs``) and compensates the estimated disturbance.
    """

    def __init__(self, train: Train, design: MPCDesign, force_matrix: Array, *, dt: float,
                 strategy: str, constraints: MPCConstraints, max_iterations: int = 50,
                 tolerance: float = 1e-6, relaxation: float = 1.0,
                 cooperative_weights: Array | None = None, path: str = "fast",
                 name: str | None = None, observer: KalmanObserver | None = None) -> None:
        if strategy not in STRATEGIES:
            raise ModelError(
                f"MPCController: 'strategy' must be one of {STRATEGIES} (got {strategy!r}).")
        if not 0 < relaxation <= 1:
            raise ModelError(f"MPCController: 'relaxation' must be in (0, 1] (got {relaxation!r}).")
        self.train, self.design, self.dt = train, design, float(dt)
        self.strategy, self.constraints, self.path = strategy, constraints, path
        self.max_iterations, self.tolerance, self.relaxation = max_iterations, tolerance, relaxation
        self.name = name or strategy
        self.observer = observer
        n, M = design.n_inputs, design.control_horizon
        self.n, self.M, self.P = n, M, design.prediction_horizon
        self.pred: Prediction = prediction(design)
        self.fpred: Prediction = prediction(replace(design, C=force_matrix,
                                                    q=np.ones(force_matrix.shape[0]),
                                                    output_owner=tuple(range(force_matrix.shape[0]))))
        self.weights = (np.full(n, 1 / n) if cooperative_weights is None
                        else np.asarray(cooperative_weights, dtype=float))
        # Decision -> input-deviation moves: u-form identity, Δu-form cumulative sums.
        self.L = (np.eye(M * n) if design.form == "u"
                  else np.kron(np.tril(np.ones((M, M))), np.eye(n)))
        self._D = np.kron(np.eye(M) - np.eye(M, k=-1), np.eye(n))  # move differences
        self._groups = [np.array(g) for g in train.groups]
        for idx in self._groups:
            if train.traction_share[idx].sum() <= 0:
                raise ModelError(f"{self.name}: vehicles {idx.tolist()} form a coupled group "
                                 "without traction (all traction_share are 0).")
        self._precompute()
        self.blocks = []
        g_start = self._source_g
        for coaches in self._block_coaches():
            self.blocks.append(self._build_block(coaches, g_start))
            g_start += self.blocks[-1].cols.size
        self._source_buffer(g_start)
        self._fast = all(b.offset is not None for b in self.blocks)
        covered = np.unique(np.concatenate([b.cols for b in self.blocks]))
        # Iteration residual over the blocks' columns; None: they cover the whole plan.
        self._residual_cols = None if covered.size == M * n else covered
        self.reset()

    # -- construction -------------------------------------------------------------------------
    def _precompute(self) -> None:
        """Per-step constants: feedforward shares, envelopes, bounded force rows, source layout.

        Built before the blocks, which locate their parameters in the source layout.
        """
        train, n, M, P = self.train, self.n, self.M, self.P
        shares = train.traction_share
        self._ff_groups = [(idx, shares[idx] / shares[idx].sum()) for idx in self._groups]
        self._stiff = np.where(train.virtual, 1.0, train.stiffness)
        self._any_virtual = bool(train.virtual.any())
        davis = train.davis
        self._davis = (tuple(float(a) for a in davis[:, 0])
                       if bool(np.all(davis == davis[:, :1])) else None)
        # Envelopes evaluated for all vehicles at once when they are all the stock envelope
        # (the function of TractionEnvelope.braking_limit/traction_limit, broadcast over
        # [braking; traction] x moves x vehicles).
        self._envelopes: tuple[Array, ...] | None = None
        if all(type(veh.envelope) is TractionEnvelope for veh in train.vehicles):
            env = [veh.envelope for veh in train.vehicles]

            def stack(*fields: str) -> Array:
                return np.array([[getattr(e, f) for e in env] for f in fields],
                                dtype=float)[:, None, :]

            self._envelopes = (stack("max_braking", "max_traction"),
                               stack("max_braking_power", "max_power"),
                               stack("adhesion", "adhesion"), train.mass.copy())
        self._du = self.design.form == "du"
        self._zeros_n, self._zeros_MN = np.zeros(n), np.zeros(M * n)  # u-form ũ(k-1), tiled
        self._zeros_n.flags.writeable = self._zeros_MN.flags.writeable = False
        self._L0 = np.ascontiguousarray(self.L[:n])  # first move from the decision vector
        # Shift of the plan by one move: u-form repeats the last move, Δu-form appends zero.
        last = np.arange((M - 1) * n, M * n)
        self._shift = np.concatenate([np.arange(n, M * n), last])
        # Source layout (see _sources): [lb_u; ub_u; lb_rate; ub_rate; hl; hu; g of each block].
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
        MN, nb = M * n, self._bounded_rows.size
        self._source_hl, self._source_hu = 4 * MN, 4 * MN + nb
        self._source_g = 4 * MN + 2 * nb

    def _source_buffer(self, size: int) -> None:
        """The source vector of :meth:`_sources` and views of the parts it writes.

        One buffer, rewritten every step; parts that no problem uses stay zero.
        """
        MN, nb = self.M * self.n, self._bounded_rows.size
        self._src = np.zeros(size)
        self._src_bounds = self._src[:2 * MN].reshape(2, MN)
        self._src_rate = self._src[2 * MN:4 * MN].reshape(2, MN)
        self._src_force = self._src[4 * MN:4 * MN + 2 * nb].reshape(2, nb)
        self._src_g = [self._src[int(b.params["g"][0]):int(b.params["g"][-1]) + 1]
                       for b in self.blocks]
        limit = self.constraints.coupler_force_limit / KN
        rate = self.constraints.rate_limit / KN
        self._force_pair = np.array([[-limit], [limit]])  # hl, hu = ∓limit - f0
        self._rate_pair = np.array([[-rate], [rate]])     # rate bounds ∓du - offset

    def _block_coaches(self) -> list[tuple[int, ...]]:
        if self.strategy == "centralised":
            return [tuple(range(self.n))]
        return [(i,) for i in range(self.n)]

    def _members(self, coaches: tuple[int, ...]) -> tuple[int, ...]:
        if self.strategy in ("centralised", "cooperative"):
            return tuple(range(self.n))
        if self.strategy == "decentralised":
            return coaches
        return self.design.neighbourhoods[coaches[0]]

    def _build_block(self, coaches: tuple[int, ...], g_start: int) -> _Block:
        d, pred = self.design, self.pred
        cols = np.sort(np.concatenate([pred.columns[i] for i in coaches]))
        members = self._members(coaches)
        mask = np.array([o in members for o in d.output_owner], dtype=float)
        weight = np.tile(d.q * mask, self.P)
        Gi = pred.G[:, cols]
        H = 2.0 * (Gi.T @ (weight[:, None] * Gi) + pred.Rbar[np.ix_(cols, cols)])
        nf = self.fpred.G.shape[0] // self.P
        couplers = sorted({c for i in coaches for c in (i - 1, i) if 0 <= c < nf})
        if self.strategy == "centralised":
            couplers = list(range(nf))
        rows = np.array([j * nf + c for j in self._force_steps for c in couplers],
                        dtype=np.int64)
        if not math.isfinite(self.constraints.coupler_force_limit):
            rows = np.zeros(0, dtype=np.int64)
        F = self.fpred.G[np.ix_(rows, cols)] if rows.size else np.zeros((0, cols.size))
        qp = ParametricQP(H, self._hard_rows(cols), F, soft_linear=self.constraints.soft_linear,
                          soft_quadratic=self.constraints.soft_quadratic,
                          name=f"{self.name}[{','.join(map(str, coaches))}]",
                          fast=self.path == "fast")
        Kc = 2.0 * Gi.T * weight[None, :]
        Ko = Kc @ pred.G
        Ko[:, cols] = 0.0
        Fo = self.fpred.G[rows, :].copy()
        Fo[:, cols] = 0.0
        MN = self.M * self.n
        empty = np.zeros(0, dtype=np.int64)
        bounds, rate = self.constraints.input_bounds, math.isfinite(self.constraints.rate_limit)
        where = np.searchsorted(self._bounded_rows, rows)
        params = {"g": g_start + np.arange(cols.size),
                  "lb": np.concatenate([cols if bounds else empty,
                                        2 * MN + cols if rate else empty]),
                  "ub": np.concatenate([MN + cols if bounds else empty,
                                        3 * MN + cols if rate else empty]),
                  "hl": self._source_hl + where, "hu": self._source_hu + where}
        # The map's columns are the QP's non-empty parameters in this order (ParametricQP).
        gather = np.concatenate([params[key] for key in ("g", "lb", "ub", "hl", "hu")
                                 if params[key].size])
        Jo = J = offset = pick = scale = None
        if qp.has_fast_path:
            offset, blocks = qp.data_map()
            Jo = blocks["g"] @ Ko - (blocks["hl"] + blocks["hu"]) @ Fo
            J = np.hstack([blocks[key] for key in ("g", "lb", "ub", "hl", "hu")
                           if blocks[key].size])
            if J.shape[1] != gather.size:
                raise ModelError(f"{self.name}: the QP's parameters do not match the blocks' "
                                 "(internal error).")
            nonzero = J != 0
            if J.shape[1] and nonzero.sum(axis=1).max() <= 1:
                column = nonzero.argmax(axis=1)  # 0 for rows without a parameter (scale 0)
                pick, scale = gather[column], J[np.arange(J.shape[0]), column]
                J = None
        return _Block(coaches=coaches, cols=cols, force_rows=rows, Kc=Kc, Ko=Ko, Fo=Fo, Jo=Jo,
                      qp=qp, params=params, gather=gather, J=J, offset=offset, pick=pick,
                      scale=scale)

    def _hard_rows(self, cols: NDArray[np.int64]) -> Array:
        """Rows of [bounds on ũ moves; rate of u moves] restricted to the block's columns."""
        rows = []
        if self.constraints.input_bounds:
            rows.append(self.L[np.ix_(cols, cols)])
        if math.isfinite(self.constraints.rate_limit):
            rows.append((self._D @ self.L)[np.ix_(cols, cols)])
        return np.vstack(rows) if rows else np.zeros((0, cols.size))

    # -- protocol -----------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget the previous plan and input."""
        self._plan: Array | None = None         # decision vector of the last step
        self._u_prev: Array | None = None       # last applied absolute input [kN]
        self._ff_prev: Array | None = None      # feedforward at the last step [kN]
        self._disturbance = 0.0                 # estimated specific force [m/s²]
        if self.observer is not None:
            self.observer.reset()

    @property
    def needs_full_state(self) -> bool:
        """False when an observer estimates the state from the measured speeds."""
        return self.observer is None

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """One MPC step: feedforward + optimised deviation, first move applied."""
        start = time.perf_counter()
        state = self._state(measurement)
        ctx = self._context(state, reference)
        plan0 = self._shifted_plan()
        if self.strategy in ("centralised", "decentralised"):
            U, status, iters, residuals, fallback = self._single(ctx, plan0)
        else:
            U, status, iters, residuals, fallback = self._iterate(ctx, plan0)
        moves = self._L0 @ U + ctx["u_dev_prev_tiled"][: self.n]
        u_abs = ctx["u_ff"][0] + moves
        self._plan, self._u_prev, self._ff_prev = U, u_abs, ctx["u_ff"][0]
        info: dict[str, object] = {}
        if self.observer is not None:
            self.observer.predict(u_abs * KN)
            info["disturbance"] = self._disturbance
        return StepRecord(inputs=u_abs * KN, status=status, iterations=iters,
                          residuals=tuple(residuals), solve_time=time.perf_counter() - start,
                          fallback=fallback, info=info)

    def _state(self, measurement: Measurement) -> Array:
        if self.observer is None:
            if measurement.state is None:
                raise ModelError(f"{self.name}: needs full-state measurement (got state=None); "
                                 "give the controller an observer to use measured speeds.")
            return measurement.state
        if measurement.outputs is None:
            raise ModelError(f"{self.name}: the observer needs the measured speeds "
                             "(measurement.outputs is None).")
        state, self._disturbance = self.observer.correct(measurement.outputs)
        return state

    # -- one step -----------------------------------------------------------------------------
    def _context(self, state: Array, ref: ReferencePreview) -> dict[str, Array]:
        n, P, M = self.n, self.P, self.M
        # An estimated disturbance is compensated like an extra acceleration.
        accel = ref.acceleration[: P + 1]
        if self._disturbance:
            accel = accel + self._disturbance
        u_ff, f_ff, elong0 = self._feedforward(ref.speed[: P + 1], accel)
        x_dev = np.empty(2 * n - 1)
        np.subtract(state[:n], ref.speed[0], out=x_dev[:n])
        np.subtract(state[n:2 * n - 1], elong0, out=x_dev[n:])
        u_prev = u_ff[0] if self._u_prev is None else self._u_prev
        ff_prev = u_ff[0] if self._ff_prev is None else self._ff_prev
        if self._du:
            u_dev_prev = u_prev - ff_prev
            tiled = np.tile(u_dev_prev, M)
        else:
            u_dev_prev, tiled = self._zeros_n, self._zeros_MN
        bounds = self._bound_pair(ref.speed[:M])
        bounds -= u_ff[:M].ravel()
        return {"x": x_dev, "u_ff": u_ff[:M], "f_ff": f_ff[1:P + 1].ravel(),
                "u_prev": u_prev, "u_dev_prev": u_dev_prev, "u_dev_prev_tiled": tiled,
                "bounds": bounds, "lb": bounds[0], "ub": bounds[1]}

    def _feedforward(self, speeds: Array, accels: Array) -> tuple[Array, Array, Array]:
        """Quasi-static inputs [kN], coupler forces [kN] and first elongations [m].

        Vectorised over the preview: the same allocation as
        :func:`trainctl.models.equilibrium` (traction shares within each
        physically coupled group; level track), for every (speed, acceleration).
        """
        train = self.train
        v = np.maximum(np.asarray(speeds, dtype=float), 0.1)
        accels = np.asarray(accels, dtype=float)
        if self._davis is not None:  # per unit mass, the same for every vehicle
            a0, a1, a2 = self._davis
            need = np.multiply.outer(a0 + a1 * v + a2 * v * v + accels, train.mass)
        else:
            a0v, a1v, a2v = train.davis
            column = v[:, None]
            need = train.mass * (a0v + a1v * column + a2v * column * column + accels[:, None])
        # np.add.reduce/accumulate are what sum/cumsum call, without their Python wrappers.
        # Each group's columns are gathered (a copy) before the sum: summing a view of 8 or
        # more columns adds in another order, which rounds differently.
        if len(self._ff_groups) == 1:
            group, share = self._ff_groups[0]
            inputs = np.add.reduce(need[:, group], axis=1, keepdims=True) * share
        else:
            inputs = np.empty_like(need)
            for group, share in self._ff_groups:
                inputs[:, group] = np.add.reduce(need[:, group], axis=1, keepdims=True) * share
        np.subtract(inputs, need, out=need)  # need is not used again
        forces = np.add.accumulate(need, axis=1, out=need)[:, :-1]
        if self._any_virtual:
            virtual = train.virtual
            forces[:, virtual] = 0.0
            elong = np.where(virtual, 0.0, forces[0] / self._stiff)
        else:
            elong = forces[0] / self._stiff
        return inputs / KN, forces / KN, elong

    def _bounds(self, speeds: Array) -> tuple[Array, Array]:
        """Absolute input bounds (lb, ub) [kN] at the previewed speeds, moves x vehicles."""
        pair = self._bound_pair(speeds)
        return pair[0], pair[1]

    def _bound_pair(self, speeds: Array) -> Array:
        """:meth:`_bounds` as one array [lb; ub] of shape (2, moves·n)."""
        v = np.asarray(speeds, dtype=float)
        if not self.constraints.input_bounds:
            pair = np.empty((2, v.size * self.n))
            pair[0], pair[1] = -np.inf, np.inf
            return pair
        if self._envelopes is not None:
            # Stock envelopes: one call for [braking; traction] x moves x vehicles.
            force, power, adhesion, mass = self._envelopes
            limits = _ENVELOPE_LIMIT(v[:, None], force, power, adhesion, mass)
            limits /= KN
        else:
            # One vectorised envelope call per vehicle over the previewed speeds: (moves, n).
            vehicles = self.train.vehicles
            limits = np.stack([
                np.column_stack([veh.envelope.braking_limit(v, mass=veh.mass)
                                 for veh in vehicles]),
                np.column_stack([veh.envelope.traction_limit(v, mass=veh.mass)
                                 for veh in vehicles])]) / KN
        np.negative(limits[0], out=limits[0])
        return limits.reshape(2, -1)

    def _shifted_plan(self) -> Array:
        n, M = self.n, self.M
        if self._plan is None:
            return np.zeros(M * n)
        shifted = self._plan[self._shift]  # moves 1..M-1, then the last move (Δu-form: 0)
        if self._du:
            shifted[(M - 1) * n:] = 0.0
        return shifted

    def _sources(self, ctx: dict[str, Array]) -> Array:
        """Every block's QP parameters at U = 0, stacked; each block gathers its own.

        Layout (M·n entries each for the first four): lower and upper bounds
        of the hard rows on the input moves, then on the move rates, then hl
        and hu for the bounded rows of the force prediction, then g of each
        block in turn (``_Block.params`` holds the positions). Parts that no
        problem uses are zero. The array is the controller's buffer, rewritten
        by the next call.

        Input moves are ũ = L U + t0; absolute forces u_ff + ũ. The rate of
        move m is (u_ff(m) - u_ff(m-1)) + (ũ(m) - ũ(m-1)), with the applied
        u(k-1) before move 0. L and the difference matrix are block diagonal
        by coach, so the other coaches' moves do not enter a block's bounds.
        """
        # In the u-form ũ(k-1) = 0 and S_u = 0: their terms are left out.
        pred, n = self.pred, self.n
        base = ctx["u_dev_prev_tiled"]
        if self.constraints.input_bounds:
            if self._du:
                np.subtract(ctx["bounds"], base, out=self._src_bounds)
            else:
                self._src_bounds[...] = ctx["bounds"]
        if math.isfinite(self.constraints.rate_limit):
            ff = ctx["u_ff"].ravel()
            # u_ff(m) - u_ff(m-1), with the applied u(k-1) before move 0
            offset = ff - np.concatenate((ctx["u_prev"], ff[:-n]))
            if self._du:
                offset += self._D @ base
            np.subtract(self._rate_pair, offset, out=self._src_rate)
        if self._bounded_rows.size:
            f0 = self._fPhi @ ctx["x"]
            if self._du:
                f0 += self._fSu @ ctx["u_dev_prev"]
            f0 += ctx["f_ff"][self._bounded_rows]
            np.subtract(self._force_pair, f0, out=self._src_force)
        c0 = pred.Phi @ ctx["x"]
        if self._du:
            c0 += pred.Su @ ctx["u_dev_prev"]
        for block, out in zip(self.blocks, self._src_g, strict=True):
            np.matmul(block.Kc, c0, out=out)  # block by block: stacking changes the rounding
        return self._src

    def _prepare(self, ctx: dict[str, Array]) -> list[dict[str, Array]]:
        """Per-sample constants of every block's QP (independent of the other plans).

        Fast path: ``{"data": solver data at U = 0}``; otherwise the parameter
        vectors ``g``, ``lb``, ``ub``, ``hl``, ``hu`` at U = 0.
        """
        src = self._sources(ctx)
        if self._fast:
            # The map was identified with parameters clipped to ±1e20 (ParametricQP);
            # maximum then minimum is np.clip, without its Python-level overhead.
            np.maximum(src, -1e20, out=src)
            np.minimum(src, 1e20, out=src)
            out = []
            for block in self.blocks:
                assert block.offset is not None
                if block.pick is not None and block.scale is not None:
                    data = src[block.pick]
                    data *= block.scale
                else:
                    assert block.J is not None
                    data = block.J @ src[block.gather]
                data += block.offset
                out.append({"data": data})
            return out
        return [{key: src[index] for key, index in block.params.items()}
                for block in self.blocks]

    def _solve_block(self, block: _Block, prep: dict[str, Array],
                     U: Array | None) -> tuple[Array, str]:
        """Solve the block's QP with the other blocks' moves U (None: zero)."""
        if block.Jo is not None:
            sol = block.qp.solve_data(prep["data"] if U is None else prep["data"] + block.Jo @ U)
        elif U is None:
            sol = block.qp.solve(prep["g"], prep["lb"], prep["ub"], prep["hl"], prep["hu"],
                                 path=self.path)
        else:
            shift = block.Fo @ U
            sol = block.qp.solve(prep["g"] + block.Ko @ U, prep["lb"], prep["ub"],
                                 prep["hl"] - shift, prep["hu"] - shift, path=self.path)
        return sol.z, sol.status

    def _single(self, ctx: dict[str, Array], plan0: Array):
        # Centralised: one block, no other moves; decentralised: the others' moves are not
        # known and taken as zero (their feedforward).
        U = np.zeros(plan0.shape)
        statuses, fallback = [], ""
        for block, prep in zip(self.blocks, self._prepare(ctx), strict=True):
            z, status = self._solve_block(block, prep, None)
            if not is_usable(status):
                z, fallback = self._fallback(block, ctx, plan0), "shifted plan"
            U[block.cols] = z
            statuses.append(status)
        return U, _worst(statuses, fallback), 1, [], fallback

    def _iterate(self, ctx: dict[str, Array], plan0: Array):
        U = plan0.copy()
        residuals: list[float] = []
        statuses, fallback = [], ""
        converged = False
        preps = self._prepare(ctx)
        cooperative, omega = self.strategy == "cooperative", self.relaxation
        cols = self._residual_cols
        for _ in range(self.max_iterations):
            new = U.copy()
            for block, prep in zip(self.blocks, preps, strict=True):
                z, status = self._solve_block(block, prep, U)
                if not is_usable(status):
                    z, fallback = self._fallback(block, ctx, plan0), "shifted plan"
                statuses.append(status)
                w = self.weights[block.coaches[0]] if cooperative else omega
                if w == 1.0:
                    new[block.cols] = z  # = 1·z + 0·U (up to the sign of a zero)
                else:
                    new[block.cols] = w * z + (1 - w) * U[block.cols]
            # Largest change of any block's moves (the blocks' columns, usually all of U).
            step = new - U if cols is None else new[cols] - U[cols]
            change = float(np.maximum.reduce(np.abs(step)))
            residuals.append(change)
            U = new
            if change <= self.tolerance:
                converged = True
                break
        status = _worst(statuses, fallback)
        if not converged and status == "optimal":
            status = "max_iterations"
        return U, status, len(residuals), residuals, fallback

    def _fallback(self, block: _Block, ctx: dict[str, Array], plan0: Array) -> Array:
        z = plan0[block.cols].copy()
        if self.constraints.input_bounds and self.design.form == "u":
            z = np.clip(z, ctx["lb"][block.cols], ctx["ub"][block.cols])
        return z


def _worst(statuses: list[str], fallback: str) -> str:
    if fallback:
        return "fallback"
    for status in ("error", "infeasible", "max_iterations", "optimal_inaccurate"):
        if status in statuses:
            return status
    return "optimal"


def make_mpc(train: Train, design: MPCDesign, *, dt: float, strategy: str = "ndmpc",
             constraints: MPCConstraints | None = None, max_iterations: int = 50,
             tolerance: float = 1e-6, relaxation: float = 1.0,
             cooperative_weights: Array | None = None, path: str = "fast",
             name: str | None = None, observer: ObserverSettings | None = None,
             design_speed: float | None = None) -> MPCController:
    """Build an MPC controller; every QP is modelled once here.

    Parameters
    ----------
    train : Train
        The train.
    design : MPCDesign
        Discrete design model, inputs in kN (:func:`trainctl.analysis.design_model`).
        Its first n outputs must be the coach speeds.
    dt : float
        Sample time [s] (the design's).
    strategy : str
        One of :data:`STRATEGIES`.
    constraints : MPCConstraints or None
        Bounds (default: envelope bounds only).
    max_iterations : int
        Iteration limit of the distributed strategies.
    tolerance : float
        Iteration tolerance [kN].
    relaxation : float
        N-DMPC relaxation ω in (0, 1].
    cooperative_weights : ndarray or None
        Convex weights of cooperative DMPC.
    path : {"fast", "cvxpy"}
        QP solve path.
    name : str or None
        Label (default: the strategy).
    observer : ObserverSettings or None
        Estimate the state and a disturbance from the measured speeds
        (output feedback, offset-free tracking) instead of measuring the state.
    design_speed : float or None
        Speed at which the observer gain is designed [m/s]; required with ``observer``.

    Returns
    -------
    MPCController
        Ready to ``step``.
    """
    from ...models.linear import linearise

    force_rows = np.asarray(linearise(train, 1.0, outputs=("force",)).C, dtype=float) / KN
    nx = design.A.shape[0]
    if force_rows.shape[1] != nx:
        raise ModelError(f"make_mpc: the design has {nx} states but the train's model has "
                         f"{force_rows.shape[1]}; build the design without the dummy state.")
    kalman = None
    if observer is not None:
        if design_speed is None:
            raise ModelError("make_mpc: 'design_speed' [m/s] is required with an observer.")
        kalman = KalmanObserver(train, dt, design_speed, observer)
    return MPCController(train, design, force_rows, dt=dt, strategy=strategy,
                         constraints=constraints or MPCConstraints(),
                         max_iterations=max_iterations, tolerance=tolerance,
                         relaxation=relaxation, cooperative_weights=cooperative_weights,
                         path=path, name=name, observer=kalman)
