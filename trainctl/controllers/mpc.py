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
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..analysis.mpc import MPCDesign, Prediction, prediction
from ..exceptions import ModelError
from ..models.train import Train
from .base import Measurement, ReferencePreview, StepRecord
from .observer import KalmanObserver, ObserverSettings
from .qp import ParametricQP
from .status import is_usable

__all__ = ["STRATEGIES", "MPCConstraints", "MPCController", "make_mpc"]

STRATEGIES = ("centralised", "decentralised", "ndmpc", "cooperative")
"""The MPC strategies."""

KN = 1e3
Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class MPCConstraints:
    """Constraint settings of an MPC controller.

    Parameters
    ----------
    input_bounds : bool
        Bound every coach's force by its traction/braking envelope (hard).
    rate_limit : float
        Largest change of a coach's force per sample [N] (hard); inf for none.
    coupler_force_limit : float
        Largest absolute coupler force |f| [N] (soft); inf for none.
    soft_linear : float
        Linear penalty per kN of coupler-force violation.
    soft_quadratic : float
        Quadratic penalty per kN² of violation.
    force_steps : tuple of int or None
        Prediction steps (1..P) at which the coupler forces are bounded; None
        for every step. Bounding a subset (e.g. the first few steps, then every
        fifth) shrinks each QP with little effect when the bound is far from active.
    """

    input_bounds: bool = True
    rate_limit: float = math.inf
    coupler_force_limit: float = math.inf
    soft_linear: float = 1e3
    soft_quadratic: float = 1e2
    force_steps: tuple[int, ...] | None = None


@dataclass(frozen=True)
class _Block:
    """One optimiser: the coaches it decides for, its QP and its precomputed maps.

    With c0 = Φx̃ + S_u ũ(k-1) and f0 the force prediction without moves, the
    block's QP vectors are g = Kc c0 + Ko U, hl/hu = ∓limit - f0[rows] - Fo U
    (U the whole plan; Ko, Fo have the block's own columns zeroed); the bounds
    do not depend on the other coaches. The fast path folds all of it into
    the solver data: data = base(step) + Jo U.
    """

    coaches: tuple[int, ...]
    cols: NDArray[np.int64]          # its columns in the decision vector
    force_rows: NDArray[np.int64]    # rows of the force prediction it bounds
    Kc: Array                        # 2 G_iᵀ W_i, maps c0 to g
    Ko: Array                        # 2 G_iᵀ W_i G (own columns zeroed)
    Fo: Array                        # force rows of G (own columns zeroed)
    Jo: Array | None                 # fast path: data sensitivity to U
    qp: ParametricQP


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
        self.blocks = [self._build_block(c) for c in self._block_coaches()]
        self.reset()

    # -- construction -------------------------------------------------------------------------
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

    def _build_block(self, coaches: tuple[int, ...]) -> _Block:
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
        chosen = self.constraints.force_steps
        steps = (range(self.P) if chosen is None
                 else sorted({int(j) - 1 for j in chosen if 1 <= j <= self.P}))
        rows = np.array([j * nf + c for j in steps for c in couplers], dtype=np.int64)
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
        Jo = None
        if qp.has_fast_path:
            _, blocks = qp.data_map()
            Jo = blocks["g"] @ Ko - (blocks["hl"] + blocks["hu"]) @ Fo
        return _Block(coaches=coaches, cols=cols, force_rows=rows, Kc=Kc, Ko=Ko, Fo=Fo, Jo=Jo,
                      qp=qp)

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
        moves = self.L @ U + ctx["u_dev_prev_tiled"]
        u_abs = ctx["u_ff"][0] + moves[: self.n]
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
        accel = ref.acceleration[: P + 1] + self._disturbance
        u_ff, f_ff, elong0 = self._feedforward(ref.speed[: P + 1], accel)
        v = state[:n]
        delta = state[n:2 * n - 1]
        x_dev = np.concatenate([v - ref.speed[0], delta - elong0])
        u_prev = u_ff[0] if self._u_prev is None else self._u_prev
        ff_prev = u_ff[0] if self._ff_prev is None else self._ff_prev
        u_dev_prev = u_prev - ff_prev if self.design.form == "du" else np.zeros(n)
        lb, ub = self._bounds(ref.speed[:M])
        return {"x": x_dev, "u_ff": u_ff[:M], "f_ff": f_ff[1:P + 1].ravel(),
                "u_prev": u_prev, "u_dev_prev": u_dev_prev,
                "u_dev_prev_tiled": np.tile(u_dev_prev, M) if self.design.form == "du"
                else np.zeros(M * n),
                "lb": lb - u_ff[:M].ravel(), "ub": ub - u_ff[:M].ravel()}

    def _feedforward(self, speeds: Array, accels: Array) -> tuple[Array, Array, Array]:
        """Quasi-static inputs [kN], coupler forces [kN] and first elongations [m].

        Vectorised over the preview: the same allocation as
        :func:`trainctl.models.equilibrium` (traction shares within each
        physically coupled group; level track), for every (speed, acceleration).
        """
        train = self.train
        v = np.maximum(np.asarray(speeds, dtype=float), 0.1)[:, None]
        a0, a1, a2 = train.davis
        need = train.mass * (a0 + a1 * v + a2 * v * v + np.asarray(accels, dtype=float)[:, None])
        inputs = np.zeros_like(need)
        shares = train.traction_share
        for idx in self._groups:
            share = shares[idx] / shares[idx].sum()
            inputs[:, idx] = need[:, idx].sum(axis=1, keepdims=True) * share
        forces = np.cumsum(inputs - need, axis=1)[:, :-1]
        forces[:, train.virtual] = 0.0
        stiff = np.where(train.virtual, 1.0, train.stiffness)
        elong = np.where(train.virtual, 0.0, forces[0] / stiff)
        return inputs / KN, forces / KN, elong

    def _bounds(self, speeds: Array) -> tuple[Array, Array]:
        if not self.constraints.input_bounds:
            size = speeds.size * self.n
            return np.full(size, -np.inf), np.full(size, np.inf)
        v = np.asarray(speeds, dtype=float)
        # One vectorised envelope call per vehicle over the previewed speeds: (moves, n).
        up = np.column_stack([veh.envelope.traction_limit(v, mass=veh.mass)
                              for veh in self.train.vehicles])
        down = np.column_stack([veh.envelope.braking_limit(v, mass=veh.mass)
                                for veh in self.train.vehicles])
        return -down.ravel() / KN, up.ravel() / KN

    def _shifted_plan(self) -> Array:
        n, M = self.n, self.M
        if self._plan is None:
            return np.zeros(M * n)
        moves = self._plan.reshape(M, n)
        shifted = np.vstack([moves[1:], moves[-1:]]) if self.design.form == "u" \
            else np.vstack([moves[1:], np.zeros((1, n))])
        return shifted.ravel()

    def _prepare(self, ctx: dict[str, Array]) -> list[dict[str, Array]]:
        """Per-sample constants of every block's QP (independent of the other plans)."""
        pred, fpred = self.pred, self.fpred
        c0 = pred.Phi @ ctx["x"] + pred.Su @ ctx["u_dev_prev"]
        f0 = fpred.Phi @ ctx["x"] + fpred.Su @ ctx["u_dev_prev"] + ctx["f_ff"]
        limit = self.constraints.coupler_force_limit / KN
        out = []
        for block in self.blocks:
            lb, ub = self._hard_bounds(block, ctx)
            prep = {"g": block.Kc @ c0, "lb": lb, "ub": ub,
                    "hl": -limit - f0[block.force_rows], "hu": limit - f0[block.force_rows]}
            if block.Jo is not None:
                offset, maps = block.qp.data_map()
                base = offset.copy()
                for key, vec in prep.items():
                    if vec.size:
                        base += maps[key] @ np.clip(vec, -1e20, 1e20)
                prep["data"] = base
            out.append(prep)
        return out

    def _solve_block(self, block: _Block, prep: dict[str, Array],
                     U: Array) -> tuple[Array, str]:
        if self.strategy == "decentralised":
            U = np.zeros_like(U)  # the other coaches' moves are not known
        if block.Jo is not None:
            sol = block.qp.solve_data(prep["data"] + block.Jo @ U)
        else:
            shift = block.Fo @ U
            sol = block.qp.solve(prep["g"] + block.Ko @ U, prep["lb"], prep["ub"],
                                 prep["hl"] - shift, prep["hu"] - shift, path=self.path)
        return sol.z, sol.status

    def _hard_bounds(self, block: _Block, ctx: dict[str, Array]) -> tuple[Array, Array]:
        """Bounds of the block's hard rows.

        Input moves are ũ = L U + t0; absolute forces u_ff + ũ. The rate of
        move m is (u_ff(m) - u_ff(m-1)) + (ũ(m) - ũ(m-1)), with the applied
        u(k-1) before move 0. L and the difference matrix are block diagonal
        by coach, so the other coaches' moves do not enter.
        """
        cols = block.cols
        base = ctx["u_dev_prev_tiled"]
        lbs, ubs = [], []
        if self.constraints.input_bounds:
            lbs.append((ctx["lb"] - base)[cols])
            ubs.append((ctx["ub"] - base)[cols])
        if math.isfinite(self.constraints.rate_limit):
            ff = ctx["u_ff"]
            ff_step = np.vstack([ff[:1] - ctx["u_prev"][None, :], np.diff(ff, axis=0)]).ravel()
            offset = (ff_step + self._D @ base)[cols]
            du = self.constraints.rate_limit / KN
            lbs.append(-du - offset)
            ubs.append(du - offset)
        if not lbs:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(lbs), np.concatenate(ubs)

    def _single(self, ctx: dict[str, Array], plan0: Array):
        U = np.zeros_like(plan0)
        statuses, fallback = [], ""
        for block, prep in zip(self.blocks, self._prepare(ctx), strict=True):
            z, status = self._solve_block(block, prep, U)
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
        for _ in range(self.max_iterations):
            new = U.copy()
            for block, prep in zip(self.blocks, preps, strict=True):
                z, status = self._solve_block(block, prep, U)
                if not is_usable(status):
                    z, fallback = self._fallback(block, ctx, plan0), "shifted plan"
                statuses.append(status)
                if self.strategy == "cooperative":
                    w = self.weights[block.coaches[0]]
                    new[block.cols] = w * z + (1 - w) * U[block.cols]
                else:
                    new[block.cols] = self.relaxation * z + (1 - self.relaxation) * U[block.cols]
            change = max(float(np.max(np.abs(new[b.cols] - U[b.cols]))) for b in self.blocks)
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
    from ..models.linear import linearise

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
