# The train MPC: feedforward, envelopes and observer around the condensed core.
"""Model predictive controllers for the train, on the condensed MPC core.

Each controller works in deviation coordinates about a feedforward: the
quasi-static force distribution that makes the train follow the reference
speed and acceleration (:func:`trainctl.models.equilibrium` with the
``traction_share`` allocation, so the T-M-M-T static coupler forces are part
of it). The QPs (:mod:`.problem`) are the condensed blocks of the MPC core
(:mod:`.condensed`, the same building blocks as
:func:`~trainctl.controllers.mpc.make_linear_mpc`) with the train's data; the
strategy (:mod:`.strategies`) decides the blocks and combines their plans:

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
``"ndmpc-local"``
    N-DMPC as the seed defines it: coach i predicts only its neighbourhood,
    with its own sampled neighbourhood model, the states just outside taken
    from the trajectories the other coaches predicted for their own states
    (exchanged every iteration with the plans); its QP's size and build cost
    do not depend on the train length (:mod:`.local`,
    :mod:`trainctl.controllers.mpc.theory.local_iteration`). Needs ``local_model``.

Constraints: the traction/braking envelope of every coach at the reference
speed (hard; trailers brake only), the input rate (hard, per step), and the
absolute coupler force including its static part (soft, with slack
penalties) and, on a track with speed limits (``track``, with
``MPCConstraints.speed_limits``), every vehicle's predicted speed under the
limit at its predicted position less ``speed_limit_margin`` (soft,
one-sided, at the coupler-force steps; :mod:`.speed_limits`). A local
problem carries the bounds of its own inputs, the force rows of the couplers
next to its coach and the speed rows of its own vehicle (centralised: all).
Without speed limits there are no speed rows at all.

Faults (:mod:`trainctl.controllers.faults`): a solve that returns no usable
solution keeps its outcome as the step status (``"infeasible"``,
``"max_iterations"``, ``"error"``), and a solve that raises is ``"error"``
with the exception in ``info["reason"]``; either is replaced by the shifted
previous plan, or the feedforward when there is none (fallback ``"shifted
plan"``). A measurement (or reference) that is not finite never reaches a
solver or the observer: the step is ``"error"`` with the reason in
``info["reason"]`` and applies the feedforward of the reference plus the
last correction u(k-1) - u_ff(k-1) (fallback ``"hold correction"``; the
observer predicts without a correction); the next finite measurement is
handled as usual. Without a finite reference the previous input is held.
Every fallback is clipped to the envelope at the reference speed, then to
within the rate limit of the input applied at the previous sample (the
request cut to the envelope at the speeds measured then), then to the
actuators' envelope at the measured speeds (the last finite ones for a
non-finite measurement; before any, the envelope at the reference speed):
where the planning envelope and the rate limit conflict the rate limit
wins, and only the actuators' own envelope can overrule it
(:meth:`TrainProblem.safe_plan`).
:meth:`MPCController.reset` also restarts every QP workspace cold.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import Measurement, ReferencePreview, StepRecord
from trainctl.controllers.faults import safe_inputs
from trainctl.controllers.mpc.condensed import QPBlock, shifted
from trainctl.controllers.mpc.local import LocalTrainProblem
from trainctl.controllers.mpc.observer import KalmanObserver, ObserverSettings
from trainctl.controllers.mpc.problem import StepContext, TrainProblem
from trainctl.controllers.mpc.settings import QP_SOLVERS, STRATEGIES, MPCConstraints
from trainctl.controllers.mpc.speed_limits import HorizonLimits
from trainctl.controllers.mpc.strategies.coordinators import make_strategy
from trainctl.controllers.mpc.theory.local_iteration.model import LocalModel
from trainctl.controllers.mpc.theory.mpc import MPCDesign
from trainctl.exceptions import ModelError
from trainctl.models.dynamics import vehicle_positions
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.feedforward import ForceSplit
from trainctl.models.track import Track
from trainctl.models.train import Train

__all__ = ["HOLD_INPUT", "ITERATING", "STRATEGIES", "MPCConstraints", "MPCController", "make_mpc"]

KN = 1e3
HOLD_INPUT = "hold correction"
"""Fallback of a step whose measurement was not finite: the feedforward plus the last
correction, within the rate limit and the envelope."""
Array = NDArray[np.float64]

ITERATING = ("ndmpc", "cooperative")
"""The strategies that iterate within a step, up to ``max_iterations`` times."""

_DESIGN_MSG = (
    "{where}: the train MPC needs a design model of this train's deviation dynamics, "
    "{nx} state(s) [v (n = {n}); delta (n-1)] and {n} input(s), one force per vehicle "
    "(got {got_x} state(s) and {got_u} input(s)). For an MPC on any other discrete (A, B) model "
    "use trainctl.controllers.mpc.make_linear_mpc(sysd, Q=..., R=..., prediction_horizon=...)."
    "{hint}"
)


class MPCController:
    """An MPC controller of the train (see the module docstring).

    Build it with :func:`make_mpc`.

    Parameters
    ----------
    train : Train
        The train (for the feedforward and the envelopes).
    design : MPCDesign
        Discrete design model in kN (:class:`~trainctl.controllers.mpc.family.MPCFamilyDesign`).
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
    qp_solver : {"auto", "osqp", "daqp"}
        QP solver of the fast path (:func:`~trainctl.controllers.mpc.qp.parametric.choose_solver`).
    name : str
        Label.
    observer : KalmanObserver or None
        With an observer the controller uses the measured speeds only
        (``measurement.outputs``) and compensates the estimated disturbance.
    local_model : LocalModel or None
        The continuous design model partitioned by coach
        (:func:`trainctl.controllers.mpc.theory.local_iteration.local_model`); required by
        ``"ndmpc-local"``, ignored otherwise.
    track : Track or None
        The track the train runs on: with speed limits (and
        ``constraints.speed_limits``) every QP bounds its vehicles' predicted
        speeds; the measurements then need the vehicles' positions
        (``positions``, or a full state with the head position).

    Examples
    --------
    On the reference at the cruise speed, at the equilibrium state, there is
    nothing to correct: N-DMPC's plan is the feedforward, the equilibrium
    forces of the two motor cars [kN].

    >>> from trainctl.controllers.mpc.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> from trainctl.models import equilibrium
    >>> v = scenario.model.speed  # 83.3 m/s
    >>> eq = equilibrium(scenario.train, v)
    >>> ref = ReferencePreview(times=20.0 * np.arange(5), speed=np.full(5, v),
    ...                        acceleration=np.zeros(5))
    >>> ctl = FAMILY.make(design, "ndmpc")
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> rec.status, bool(np.allclose(rec.inputs, eq.inputs))
    ('optimal', True)
    >>> (rec.inputs / 1e3).round(2).tolist()
    [0.0, 11.79, 11.79, 0.0]
    """

    def __init__(self, train: Train, design: MPCDesign, force_matrix: Array, *, dt: float,
                 strategy: str, constraints: MPCConstraints, max_iterations: int = 50,
                 tolerance: float = 1e-6, relaxation: float = 1.0,
                 cooperative_weights: Array | None = None, path: str = "fast",
                 qp_solver: str = "auto", name: str | None = None,
                 observer: KalmanObserver | None = None,
                 local_model: LocalModel | None = None, track: Track | None = None) -> None:
        if strategy not in STRATEGIES:
            raise ModelError(
                f"MPCController: 'strategy' must be one of {STRATEGIES} (got {strategy!r}).")
        if not 0 < relaxation <= 1:
            raise ModelError(f"MPCController: 'relaxation' must be in (0, 1] (got {relaxation!r}).")
        if path not in ("fast", "cvxpy"):
            raise ModelError(f"MPCController: 'path' must be 'fast' or 'cvxpy' (got {path!r}).")
        if qp_solver not in QP_SOLVERS:
            raise ModelError(f"MPCController: 'qp_solver' must be one of {QP_SOLVERS} "
                             f"(got {qp_solver!r}).")
        _check_design("MPCController", train, design, force_matrix)
        self.train, self.design, self.dt = train, design, float(dt)
        self.strategy, self.constraints, self.path = strategy, constraints, path
        self.qp_solver = qp_solver
        self.max_iterations, self.tolerance, self.relaxation = max_iterations, tolerance, relaxation
        self.name = name or strategy
        self.observer = observer
        n, M = design.n_inputs, design.control_horizon
        self.n, self.M, self.P = n, M, design.prediction_horizon
        self.weights = (np.full(n, 1 / n) if cooperative_weights is None
                        else np.asarray(cooperative_weights, dtype=float))
        self._groups = [np.array(g) for g in train.groups]
        for idx in self._groups:
            if train.traction_share[idx].sum() <= 0:
                raise ModelError(f"{self.name}: vehicles {idx.tolist()} form a coupled group "
                                 "without traction (all traction_share are 0).")
        self._precompute()
        limited = (constraints.speed_limits and track is not None
                   and bool(track.speed_limits))
        self.speed_limits: HorizonLimits | None = (
            HorizonLimits(track, constraints.speed_limit_margin)
            if limited and track is not None else None)
        """The speed rows' bounds (None: no speed rows, the track has no limits or the
        constraints ignore them)."""
        self.fixed_inputs = fixed_inputs(train, design, constraints)
        """Coaches whose force the envelope pins (no traction, no braking: an unpowered
        wagon); u-form with input bounds only. They get no QP: their moves are the bound."""
        self._fixed_cols = (np.array([m * n + i for m in range(M) for i in self.fixed_inputs],
                                     dtype=np.int64))
        self._strategy = make_strategy(strategy, max_iterations=max_iterations,
                                       tolerance=tolerance, relaxation=relaxation,
                                       weights=self.weights)
        self.problem: TrainProblem
        if strategy == "ndmpc-local":
            if local_model is None:
                raise ModelError(f"{self.name}: 'ndmpc-local' needs the continuous design model "
                                 "partitioned by coach (local_model=trainctl.analysis."
                                 "local_iteration.local_model(design, A, B, dt, owners)).")
            self.problem = LocalTrainProblem(design, local_model, force_matrix, constraints,
                                             self._strategy, name=self.name, path=path,
                                             qp_solver=qp_solver, fixed=self.fixed_inputs,
                                             speed_rows=limited)
        else:
            self.problem = TrainProblem(design, force_matrix, constraints, self._strategy,
                                        name=self.name, path=path, qp_solver=qp_solver,
                                        fixed=self.fixed_inputs, speed_rows=limited)
        self.reset()

    @property
    def iteration_limit(self) -> int | None:
        """Most distributed iterations of one step (``max_iterations``) for the iterating
        strategies (``"ndmpc"``, ``"cooperative"``); None for the single-solve ones.

        The simulation records it with :attr:`iteration_tolerance` in the result's
        ``meta``, so that its metrics count the steps that stopped at the limit
        (:class:`trainctl.sim.Metrics`).
        """
        return self.max_iterations if self.strategy in ITERATING else None

    @property
    def iteration_tolerance(self) -> float | None:
        """The change [kN] below which an iterating strategy's step has converged
        (``tolerance``: the unit of the step residuals); None for the single-solve ones."""
        return float(self.tolerance) if self.strategy in ITERATING else None

    @property
    def blocks(self) -> list[QPBlock]:
        """The QP blocks, one per optimiser of the strategy."""
        return self.problem.blocks

    def _precompute(self) -> None:
        """Per-step constants of the feedforward, the envelopes and the step context."""
        train, n, M = self.train, self.n, self.M
        self._split = ForceSplit(train, where=self.name)
        self._input_bounds = EnvelopeBounds(train, enabled=self.constraints.input_bounds)
        self._du = self.design.form == "du"
        self._zeros_n, self._zeros_MN = np.zeros(n), np.zeros(M * n)  # u-form ũ(k-1), tiled
        self._zeros_n.flags.writeable = self._zeros_MN.flags.writeable = False

    # -- protocol -----------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget the previous plan and input, the estimate and every QP's warm start."""
        self._plan: Array | None = None         # decision vector of the last step
        self._u_prev: Array | None = None       # last applied absolute input [kN]
        self._ff_prev: Array | None = None      # feedforward at the last step [kN]
        self._speeds_prev: Array | None = None  # speeds measured at the last finite step [m/s]
        self._disturbance = 0.0                 # estimated specific force [m/s²]
        self._ff_key: tuple[bytes, bytes] | None = None  # the preview of _ff_cache
        self._ff_cache: tuple[Array, Array, Array, Array] | None = None
        if self.observer is not None:
            self.observer.reset()
        self.problem.reset()

    @property
    def needs_full_state(self) -> bool:
        """False when an observer estimates the state from the measured speeds."""
        return self.observer is None

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """One MPC step: feedforward + optimised deviation, first move applied.

        Parameters
        ----------
        t : float
            Time of the sample [s] (unused: the preview carries the times).
        measurement : Measurement
            The full state ``[v (n) [m/s], delta (n-1) [m], s [m]]``, or with an
            observer the measured speeds (``outputs``) [m/s].
        reference : ReferencePreview
            The reference over at least P+1 samples (speed [m/s],
            acceleration [m/s²]).

        Returns
        -------
        StepRecord
            Force per vehicle [N] (the first move of the plan), the strategy's
            status, iterations, residuals [kN] and fallback; ``info`` holds
            the estimated disturbance [m/s²] with an observer. A non-finite
            measurement or preview gives status ``"error"``, the fallback
            ``"hold correction"`` and the ``"reason"`` in ``info``.

        Raises
        ------
        ModelError
            If the measurement lacks what the controller uses (the state, or
            the outputs with an observer).
        """
        start = time.perf_counter()
        reason = self._fault(measurement, reference)
        if reason:
            return self._hold(reference, reason, start)
        state = self._state(measurement)
        ctx = self._context(state, reference)
        if self.speed_limits is not None:
            ctx = replace(ctx, speed_bound=self.speed_limits.bounds(
                self._positions(measurement), reference.times[:self.P + 1],
                reference.speed[:self.P + 1]))
        problem = self.problem
        plan0 = shifted(problem.maps, self._plan)
        pinned = self._fixed_cols
        if pinned.size:  # u-form: the moves of a pinned coach are its (equal) bounds
            plan0[pinned] = ctx.bounds[0, pinned]
        speeds = np.array(state[:self.n], dtype=float)
        safe: list[StepContext] = []  # the fallbacks' context, built on the first failure

        def fault_context() -> StepContext:
            if not safe:
                safe.append(self._fault_context(ctx, speeds))
            return safe[0]

        result = self._strategy.plan(problem, problem.parameters(ctx), plan0,
                                     lambda block: problem.fallback(block, fault_context(),
                                                                    plan0))
        U = result.plan
        if pinned.size:
            U[pinned] = ctx.bounds[0, pinned]
        if result.fallback:  # the combined plan too: within the rate limit and the envelope
            U = problem.safe_plan(fault_context(), U)
        moves = problem.maps.first @ U + ctx.u_dev_prev_tiled[: self.n]
        u_abs = ctx.u_ff[0] + moves
        self._plan, self._u_prev, self._ff_prev = U, u_abs, ctx.u_ff[0]
        self._speeds_prev = speeds
        info: dict[str, object] = {}
        if result.reason:
            info["reason"] = result.reason
        if self.observer is not None:
            self.observer.predict(u_abs * KN)
            info["disturbance"] = self._disturbance
        return StepRecord(inputs=u_abs * KN, status=result.status, iterations=result.iterations,
                          residuals=tuple(result.residuals),
                          solve_time=time.perf_counter() - start, fallback=result.fallback,
                          info=info)

    def _fault(self, measurement: Measurement, reference: ReferencePreview) -> str:
        """Why the step cannot be solved ("" when it can): a non-finite measurement or preview."""
        used = measurement.state if self.observer is None else measurement.outputs
        P1 = self.P + 1
        # One test of all the values used; when it fails, look closer.
        parts = [np.asarray(reference.speed[:P1], dtype=float).ravel(),
                 np.asarray(reference.acceleration[:P1], dtype=float).ravel()]
        if used is not None:
            parts.append(np.asarray(used, dtype=float).ravel())
        positions = None
        if self.speed_limits is not None:
            positions = self._positions(measurement)
            parts.append(positions)
            parts.append(np.asarray(reference.times[:P1], dtype=float).ravel())
        if np.isfinite(np.concatenate(parts)).all():
            return ""
        if used is not None:
            values = np.asarray(used, dtype=float)
            if not np.isfinite(values).all():
                bad = int(np.flatnonzero(~np.isfinite(values))[0])
                what = "state" if self.observer is None else "outputs"
                return f"non-finite measurement: {what}[{bad}] = {values[bad]!r}"
        if positions is not None and not np.isfinite(positions).all():
            bad = int(np.flatnonzero(~np.isfinite(positions))[0])
            return f"non-finite measurement: positions[{bad}] = {positions[bad]!r}"
        for name in ("speed", "acceleration") + (("times",) if positions is not None else ()):
            preview = np.asarray(getattr(reference, name)[:P1], dtype=float)
            if not np.isfinite(preview).all():
                return f"non-finite reference {name} in the preview"
        return ""

    def _positions(self, measurement: Measurement) -> Array:
        """Each vehicle's position [m], head first, for the speed rows: the measured
        ``positions``, else from the full state
        (:func:`~trainctl.models.dynamics.vehicle_positions`)."""
        if measurement.positions is not None:
            return np.asarray(measurement.positions, dtype=float)
        state = measurement.state
        if state is None or np.shape(state) != (2 * self.n,):
            raise ModelError(f"{self.name}: the speed-limit rows need the vehicles' positions: "
                             "give the measurement 'positions' [m] or the full state "
                             "[v (n), delta (n-1), s] with the head position s.")
        return vehicle_positions(self.train, np.asarray(state, dtype=float))

    def _applied(self) -> Array | None:
        """The input the actuators applied at the previous sample, as far as the controller
        knows: its request cut to the envelope at the speeds it measured then [kN]."""
        if self._u_prev is None or self._speeds_prev is None:
            return self._u_prev
        low, high = self._input_bounds.at(self._speeds_prev)
        return np.clip(self._u_prev, low / KN, high / KN)

    def _fault_context(self, ctx: StepContext, speeds: Array) -> StepContext:
        """``ctx`` with what a fallback needs: the applied input and the actuators' envelope
        at the measured ``speeds`` [m/s] (:meth:`TrainProblem.safe_plan`)."""
        actuator = None
        if self.constraints.input_bounds:
            actuator = np.vstack(self._input_bounds.at(speeds)) / KN
        return replace(ctx, applied=self._applied(), actuator=actuator)

    def _hold(self, reference: ReferencePreview, reason: str, start: float) -> StepRecord:
        """The step of a fault: the feedforward plus the last correction, made safe (error)."""
        speed = np.asarray(reference.speed[:1], dtype=float)
        accel = np.asarray(reference.acceleration[:1], dtype=float)
        if np.isfinite(speed).all() and np.isfinite(accel).all():
            ff = self._feedforward(speed, accel + self._disturbance)[0][0]
            u = ff.copy()
            if self._u_prev is not None and self._ff_prev is not None:
                u += self._u_prev - self._ff_prev
            low, high = (np.full(self.n, -np.inf), np.full(self.n, np.inf))
            if self.constraints.input_bounds:
                lb, ub = self._bounds(speed)
                np.clip(u, lb, ub, out=u)
                # the actuators' envelope at the last measured speeds (this sample's are not
                # known), or, before any, the one at the reference speed
                low, high = ((lb, ub) if self._speeds_prev is None else
                             (b / KN for b in self._input_bounds.at(self._speeds_prev)))
            u = safe_inputs(u, self._applied(), self.constraints.rate_limit / KN, low, high)
            self._ff_prev = ff
        else:  # no reference to follow: the previous input as it was (or none)
            u = np.zeros(self.n) if self._u_prev is None else self._u_prev.copy()
        self._u_prev = u
        self._plan = None if self._plan is None else shifted(self.problem.maps, self._plan)
        if self.observer is not None:
            self.observer.skip()
            self.observer.predict(u * KN)
        return StepRecord(inputs=u * KN, status="error", iterations=0,
                          solve_time=time.perf_counter() - start, fallback=HOLD_INPUT,
                          info={"reason": reason})

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
    def _context(self, state: Array, ref: ReferencePreview) -> StepContext:
        n, P, M = self.n, self.P, self.M
        # An estimated disturbance is compensated like an extra acceleration.
        speed, accel = ref.speed[: P + 1], ref.acceleration[: P + 1]
        if self._disturbance:
            accel = accel + self._disturbance
        # The feedforward and the move bounds depend on the previewed speeds and
        # accelerations only: a preview equal to the last one (a constant reference)
        # reuses them. Read-only, so that no step changes what the next one reuses.
        key = (np.asarray(speed, dtype=float).tobytes(), np.asarray(accel, dtype=float).tobytes())
        if key != self._ff_key:
            u_ff, f_ff, elong0 = self._feedforward(speed, accel)
            bounds = self._bound_pair(ref.speed[:M])
            bounds -= u_ff[:M].ravel()
            cached = (u_ff[:M], f_ff[1:P + 1].ravel(), elong0, bounds)
            for array in cached:
                array.flags.writeable = False
            self._ff_key, self._ff_cache = key, cached
        assert self._ff_cache is not None
        u_ff, f_ff, elong0, bounds = self._ff_cache
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
        return StepContext(x=x_dev, u_ff=u_ff, f_ff=f_ff, u_prev=u_prev,
                           u_dev_prev=u_dev_prev, u_dev_prev_tiled=tiled, bounds=bounds)

    def _feedforward(self, speeds: Array, accels: Array) -> tuple[Array, Array, Array]:
        """Quasi-static inputs [kN], coupler forces [kN] and first elongations [m].

        Vectorised over the preview: :class:`trainctl.models.ForceSplit`, the
        split :func:`trainctl.models.equilibrium` uses (traction shares within
        each physically coupled group; level track), for every (speed, acceleration).
        """
        v = np.maximum(np.asarray(speeds, dtype=float), 0.1)
        ff = self._split(v, accels)
        return ff.inputs / KN, ff.coupler_forces / KN, ff.elongations[0]

    def _bounds(self, speeds: Array) -> tuple[Array, Array]:
        """Absolute input bounds (lb, ub) [kN] at the previewed speeds, moves x vehicles."""
        pair = self._bound_pair(speeds)
        return pair[0], pair[1]

    def _bound_pair(self, speeds: Array) -> Array:
        """:meth:`_bounds` as one array [lb; ub] of shape (2, moves·n)."""
        return self._input_bounds.pair(speeds)


def make_mpc(train: Train, design: MPCDesign, *, dt: float, strategy: str = "ndmpc",
             constraints: MPCConstraints | None = None, max_iterations: int = 50,
             tolerance: float = 1e-6, relaxation: float = 1.0,
             cooperative_weights: Array | None = None, path: str = "fast",
             qp_solver: str = "auto", name: str | None = None,
             observer: ObserverSettings | None = None,
             design_speed: float | None = None,
             local_model: LocalModel | None = None,
             track: Track | None = None) -> MPCController:
    """Build an MPC controller; every QP is modelled once here.

    Parameters
    ----------
    train : Train
        The train.
    design : MPCDesign
        Discrete design model, inputs in kN (``MPCFamilyDesign.mpc``).
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
    qp_solver : {"auto", "osqp", "daqp"}
        QP solver of the fast path (:func:`~trainctl.controllers.mpc.qp.parametric.choose_solver`).
    name : str or None
        Label (default: the strategy).
    observer : ObserverSettings or None
        Estimate the state and a disturbance from the measured speeds
        (output feedback, offset-free tracking) instead of measuring the state.
    design_speed : float or None
        Speed at which the observer gain is designed [m/s]; required with ``observer``.
    local_model : LocalModel or None
        Required by ``"ndmpc-local"`` (see :class:`MPCController`).
    track : Track or None
        The track: its speed limits bound the predicted speeds (see
        :class:`MPCController`).

    Returns
    -------
    MPCController
        Ready to ``step``.

    Examples
    --------
    A centralised MPC on the ``crh2-dmpc`` design, stepped at the
    equilibrium state on a constant reference: it keeps the equilibrium
    forces.

    >>> from trainctl.controllers.mpc.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> from trainctl.models import equilibrium
    >>> v = scenario.model.speed  # 83.3 m/s
    >>> eq = equilibrium(scenario.train, v)
    >>> ref = ReferencePreview(times=20.0 * np.arange(5), speed=np.full(5, v),
    ...                        acceleration=np.zeros(5))
    >>> ctl = make_mpc(scenario.train, design.mpc, dt=20.0, strategy="centralised")
    >>> ctl.name, len(ctl.problem.blocks)  # one QP over the four coaches
    ('centralised', 1)
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> rec.status, bool(np.allclose(rec.inputs, eq.inputs))
    ('optimal', True)
    """
    from trainctl.models.linear import linearise

    _check_design("make_mpc", train, design, np.zeros((train.n_vehicles - 1, design.A.shape[0])))
    force_rows = np.asarray(linearise(train, 1.0, outputs=("force",)).C, dtype=float) / KN
    kalman = None
    if observer is not None:
        if design_speed is None:
            raise ModelError("make_mpc: 'design_speed' [m/s] is required with an observer.")
        kalman = KalmanObserver(train, dt, design_speed, observer)
    return MPCController(train, design, force_rows, dt=dt, strategy=strategy,
                         constraints=constraints or MPCConstraints(),
                         max_iterations=max_iterations, tolerance=tolerance,
                         relaxation=relaxation, cooperative_weights=cooperative_weights,
                         path=path, qp_solver=qp_solver, name=name, observer=kalman,
                         local_model=local_model, track=track)


def _check_design(where: str, train: Train, design: MPCDesign, force_matrix: Array) -> None:
    """Raise ModelError unless ``design`` is a model of ``train`` (states and inputs)."""
    n = train.n_vehicles
    nx, nu = design.B.shape
    if nx == 2 * n - 1 and nu == n and force_matrix.shape == (n - 1, nx):
        return
    # A trailing dummy state: nothing depends on it (zero column in A above it, in C).
    dummy = (nx == 2 * n and nu == n and not np.any(design.A[:-1, -1])
             and not np.any(design.C[:, -1]))
    hint = (" Nothing depends on the last state, as on the dummy state: build the design "
            "without it (linearise(..., dummy_state=False), as "
            "the design model of trainctl.design.build_model does)." if dummy else "")
    raise ModelError(_DESIGN_MSG.format(where=where, nx=2 * n - 1, n=n, got_x=nx, got_u=nu,
                                        hint=hint))


def fixed_inputs(train: Train, design: MPCDesign, constraints: MPCConstraints) -> tuple[int, ...]:
    """Coaches whose envelope pins their force at zero: no traction and no braking.

    Only in the u-form with input bounds, where such a coach's admissible moves are
    the single point ũ = -u_ff: its QP has nothing to decide, so none is built or
    solved (an unpowered heavy-haul wagon whose air brake the MPC does not command).

    Examples
    --------
    >>> from trainctl.models import heavy_haul_1p2p1
    >>> from types import SimpleNamespace
    >>> train = heavy_haul_1p2p1(detail="full", wagons_per_group=2)
    >>> fixed_inputs(train, SimpleNamespace(form="u"), MPCConstraints())
    (1, 2, 5, 6)
    >>> fixed_inputs(train, SimpleNamespace(form="du"), MPCConstraints())
    ()
    """
    if design.form != "u" or not constraints.input_bounds:
        return ()
    return tuple(i for i, v in enumerate(train.vehicles) if v.envelope.pins_force)
