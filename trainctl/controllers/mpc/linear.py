# The MPC core: linear MPC on any discrete state-space model.
"""Linear MPC on any discrete state-space model (the MPC core).

For a discrete model x(k+1) = A x(k) + B u(k), y(k) = C x(k) (a
``control.StateSpace`` with dt > 0 and no feedthrough), :func:`make_linear_mpc`
models once, in cvxpy with parameters (DPP, warm-started), the condensed QP

    minimise    Σ_{j=1..P} ‖y(k+j) - r(k+j)‖²_Q + ‖x(k+P)‖²_Qf + Σ_{m=0..M-1} ‖v(k+m)‖²_R
                + Σ (w1 s + ½ w2 s²) over the slacks s of the soft bounds
    subject to  u_min ≤ u(k+m) ≤ u_max,  |u(k+m) - u(k+m-1)| ≤ du_max   (m = 0..M-1)
                x_min ≤ x(k+j) ≤ x_max,  y_min ≤ y(k+j) ≤ y_max         (j = 1..P)

over the plan v of M moves: the inputs u (``form="u"``) or their increments
Δu (``form="du"``), the input held after move M. Q weights the outputs,
Qf the terminal state, R the plan; every bound may be hard or soft. The
states are eliminated with the prediction of
:func:`trainctl.controllers.mpc.theory.mpc.prediction_matrices`, and the QP is a block of
:mod:`.condensed` — the building blocks the train MPC is made of — solved
through the probed OSQP data (``path="fast"``) or ``Problem.solve``
(``path="cvxpy"``).

The cost counts y(k+1..k+P): python-control's ``solve_ocp`` and MPT3 also
count the constant ‖y(k)‖²_Q term (add it to compare costs). In the u-form
R penalises u itself, so tracking a reference that needs a non-zero input
leaves an offset; the Δu-form does not.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.controllers.base import Measurement, ReferencePreview, StepRecord
from trainctl.controllers.mpc import validate as check
from trainctl.controllers.mpc.condensed import block_parameters, build_block, move_maps
from trainctl.controllers.mpc.qp.parametric import QP_SOLVERS, ParametricQP
from trainctl.controllers.mpc.qp.status import is_usable
from trainctl.controllers.mpc.rows import constraint_rows
from trainctl.controllers.mpc.strategies.base import solve_block
from trainctl.controllers.mpc.theory.mpc import prediction_matrices
from trainctl.exceptions import DimensionError, ModelError

__all__ = ["LinearMPC", "LinearMPCController", "MPCSolution", "make_linear_mpc"]

Array = NDArray[np.float64]
PATHS = ("fast", "cvxpy")
"""QP solve paths."""


@dataclass(frozen=True)
class MPCSolution:
    """One solve of a :class:`LinearMPC`.

    Parameters
    ----------
    inputs : ndarray
        Planned inputs u(k), ..., u(k+P-1), shape (P, nu) (held after move M).
    states : ndarray
        Predicted states x(k), ..., x(k+P), shape (P+1, nx).
    outputs : ndarray
        Predicted outputs y(k), ..., y(k+P), shape (P+1, ny).
    plan : ndarray
        The decision: M moves of u (u-form) or Δu (Δu-form), shape (M, nu).
    status : str
        Step status (:mod:`trainctl.controllers.mpc.qp.status`); the arrays are NaN
        unless it is ``"optimal"`` or ``"optimal_inaccurate"``.
    cost : float
        The objective of the module docstring at the solution.
    slack : ndarray
        Slacks of the soft bound rows (empty without soft bounds).
    iterations : int
        Solver iterations.
    solve_time : float
        Wall time of the QP solve [s].

    Examples
    --------
    The MPT3 regulation problem of :func:`make_linear_mpc` from x = (4, 0):
    the first move is at its bound -1, which takes x to (4 - 1, -0.5).

    >>> import control as ct
    >>> sysd = ct.ss([[1, 1], [0, 1]], [[1], [0.5]], np.eye(2), 0, dt=1)
    >>> mpc = make_linear_mpc(sysd, Q=np.eye(2), R=1, prediction_horizon=4,
    ...                       u_min=-1, u_max=1, x_min=-5, x_max=5)
    >>> sol = mpc.solve([4.0, 0.0])
    >>> sol.inputs.shape, sol.states.shape  # (P, nu), (P + 1, nx)
    ((4, 1), (5, 2))
    >>> sol.first_move.round(4).tolist(), sol.states[1].round(4).tolist()
    ([-1.0], [3.0, -0.5])
    """

    inputs: Array
    states: Array
    outputs: Array
    plan: Array
    status: str
    cost: float
    slack: Array
    iterations: int
    solve_time: float

    @property
    def first_move(self) -> Array:
        """u(k), the input to apply now."""
        move: Array = self.inputs[0]
        return move

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict (arrays as nested lists).

        Returns
        -------
        dict of str to object
            The fields ``inputs``, ``states``, ``outputs``, ``plan``,
            ``status``, ``cost``, ``slack``, ``iterations`` and ``solve_time``
            [s], arrays as nested lists (NaN kept as float NaN).
        """
        return {"inputs": self.inputs.tolist(), "states": self.states.tolist(),
                "outputs": self.outputs.tolist(), "plan": self.plan.tolist(),
                "status": self.status, "cost": self.cost, "slack": self.slack.tolist(),
                "iterations": self.iterations, "solve_time": self.solve_time}


class LinearMPC:
    """An MPC problem on a discrete linear model, modelled once (module docstring).

    Build it with :func:`make_linear_mpc`; call :meth:`solve` every sample.

    Parameters
    ----------
    sysd : control.StateSpace
        The discrete model.
    settings : CoreSettings
        The validated weights, horizons, form, bounds and soft groups.
    path : {"fast", "cvxpy"}
        QP solve path.
    name : str
        Label of the QP and of error messages.
    qp_solver : {"osqp", "daqp", "auto"}
        QP solver of the fast path.

    Attributes
    ----------
    sys : control.StateSpace
        The model.
    dt : float
        Its sample time [s].
    prediction_horizon, control_horizon : int
        P and M.
    form : {"u", "du"}
        The decision.
    path : {"fast", "cvxpy"}
        QP solve path.
    qp_solver : {"auto", "osqp", "daqp"}
        QP solver of the fast path (:func:`~trainctl.controllers.mpc.qp.parametric.choose_solver`).
    name : str
        Label of the QP.

    Examples
    --------
    The MPT3 regulation problem (python-control's pinned case), built by
    :func:`make_linear_mpc`; from x = (4, 0) the first move saturates at -1:

    >>> import control as ct
    >>> sysd = ct.ss([[1, 1], [0, 1]], [[1], [0.5]], np.eye(2), 0, dt=1)
    >>> mpc = make_linear_mpc(sysd, Q=np.eye(2), R=1, prediction_horizon=4,
    ...                       u_min=-1, u_max=1, x_min=-5, x_max=5)
    >>> type(mpc).__name__, mpc.prediction_horizon, mpc.control_horizon, mpc.form
    ('LinearMPC', 4, 4, 'u')
    >>> mpc.solve([4.0, 0.0]).first_move.round(4).tolist()
    [-1.0]
    """

    def __init__(self, sysd: ct.StateSpace, settings: check.CoreSettings, *, path: str,
                 name: str, qp_solver: str = "osqp") -> None:
        s = self._settings = settings
        self.sys, self.dt, self.path, self.name = sysd, s.dt, path, name
        self.qp_solver = qp_solver
        self.prediction_horizon, self.control_horizon, self.form = s.P, s.M, s.form
        nx, nu = s.B.shape
        self.n_states, self.n_inputs, self.n_outputs = nx, nu, s.C.shape[0]
        self.maps = move_maps(nu, s.M, s.form)
        self._y = prediction_matrices(s.A, s.B, s.C, prediction_horizon=s.P,
                                      control_horizon=s.M, form=s.form)
        self._x = prediction_matrices(s.A, s.B, np.eye(nx), prediction_horizon=s.P,
                                      control_horizon=s.M, form=s.form)
        self._Rbar = np.kron(np.eye(s.M), s.R)
        self._Qbar = np.kron(np.eye(s.P), s.Q)
        H, Kc = self._cost()
        self.hard, self.soft = constraint_rows(self.maps, self._x, self._y, s.bounds, s.soft)
        qp = ParametricQP(H, self.hard.rows, self.soft.rows, soft_linear=self.soft.linear,
                          soft_quadratic=self.soft.quadratic, name=name, fast=path == "fast",
                          solver=qp_solver)
        nz, nh, ns = H.shape[0], self.hard.size, self.soft.size
        ends = np.cumsum([0, nz, nh, nh, ns, ns])
        params = {key: np.arange(ends[i], ends[i + 1])
                  for i, key in enumerate(("g", "lb", "ub", "hl", "hu"))}
        self.block = build_block(qp, inputs=tuple(range(nu)), cols=np.arange(nz), Kc=Kc,
                                 params=params)
        self._size = int(ends[-1])

    @property
    def qp(self) -> ParametricQP:
        """The QP (cvxpy problem and fast path)."""
        return self.block.qp

    def _cost(self) -> tuple[Array, Array]:
        """Hessian H and the map Kc from the free response (minus reference) to g.

        The cost rows are the outputs at steps 1..P and, with a terminal
        weight, the state at step P.
        """
        s, (_, _, G), (_, _, Gx) = self._settings, self._y, self._x
        rows, weight = G, self._Qbar
        if s.Qf is not None:
            nx = self.n_states
            rows = np.vstack([G, Gx[-nx:]])
            weight = np.block([[self._Qbar, np.zeros((G.shape[0], nx))],
                               [np.zeros((nx, G.shape[0])), s.Qf]])
        Kc = 2.0 * rows.T @ weight
        return Kc @ rows + 2.0 * self._Rbar, Kc

    def solve(self, x: ArrayLike, *, u_prev: ArrayLike | None = None,
              reference: ArrayLike | None = None) -> MPCSolution:
        """Solve the MPC problem at state ``x``.

        Parameters
        ----------
        x : array_like
            The state x(k), length nx.
        u_prev : array_like or None
            The input applied at the previous sample, u(k-1), length nu;
            required in the Δu-form and with ``du_max``, ignored otherwise.
        reference : array_like or None
            Output reference r over the horizon: length ny (constant) or
            shape (P, ny) for r(k+1), ..., r(k+P); None for 0.

        Returns
        -------
        MPCSolution
            The plan, the predicted states and outputs, status and cost.

        Raises
        ------
        DimensionError
            An argument has the wrong shape.
        ModelError
            An argument is not finite, or ``u_prev`` is missing where needed.
        """
        where = f"{self.name}.solve"
        x0 = check.as_vector(where, "x", x, self.n_states, "states")
        u0 = self._previous(where, u_prev)
        ref = self._reference(where, reference)
        src = self._sources(x0, u0, ref)
        prep = block_parameters([self.block], src, self.block.offset is not None)[0]
        sol, _ = solve_block(self.block, prep, None, self.path)  # raised: status "error"
        return self._solution(x0, u0, ref, sol.z, sol.slack, sol.status, sol.iterations,
                              sol.solve_time)

    def _previous(self, where: str, u_prev: ArrayLike | None) -> Array:
        needed = self.form == "du" or "du" in self._settings.bounds
        if u_prev is None:
            if needed:
                raise ModelError(f"{where}: 'u_prev', the input applied at the previous "
                                 "sample, is required in the Δu-form and with du_max (got "
                                 "None). Pass u_prev=np.zeros(nu) at the first sample.")
            return np.zeros(self.n_inputs)
        return check.as_vector(where, "u_prev", u_prev, self.n_inputs, "inputs")

    def _reference(self, where: str, reference: ArrayLike | None) -> Array:
        P, ny = self.prediction_horizon, self.n_outputs
        if reference is None:
            return np.zeros((P, ny))
        try:
            ref = np.asarray(reference, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"{where}: 'reference' must be real numbers (got "
                             f"{reference!r}).") from None
        if ref.shape == (ny,):
            ref = np.tile(ref, (P, 1))
        if ref.shape != (P, ny):
            raise DimensionError(f"{where}: 'reference' must have length ny = {ny} or shape "
                                 f"(P, ny) = ({P}, {ny}) (got shape {ref.shape}).")
        if not np.all(np.isfinite(ref)):
            raise ModelError(f"{where}: 'reference' must be finite.")
        return ref

    def _sources(self, x: Array, u_prev: Array, ref: Array) -> Array:
        """The QP's parameters [g; lb; ub; hl; hu] at state x, u(k-1) and reference."""
        (Phi, Su, _), (Phix, Sux, _) = self._y, self._x
        free = Phi @ x + Su @ u_prev - ref.ravel()
        if self._settings.Qf is not None:
            free = np.concatenate([free, (Phix @ x + Sux @ u_prev)[-self.n_states:]])
        parts = [self.block.Kc @ free]
        for rows in (self.hard, self.soft):
            lower, upper = rows.bounds(x, u_prev)
            parts += [lower, upper]
        src = np.concatenate(parts)
        assert src.size == self._size
        return src

    def _solution(self, x: Array, u_prev: Array, ref: Array, z: Array, slack: Array,
                  status: str, iterations: int, solve_time: float) -> MPCSolution:
        s, nu = self._settings, self.n_inputs
        (Phi, Su, G), (Phix, Sux, Gx) = self._y, self._x
        if not is_usable(status):  # OSQP may leave its last iterate: report no solution
            z, slack = np.full(z.shape, np.nan), np.full(slack.shape, np.nan)
        moves = self.maps.L @ z + (np.tile(u_prev, s.M) if s.form == "du" else 0.0)
        moves = moves.reshape(s.M, nu)
        inputs = np.vstack([moves, np.repeat(moves[-1:], s.P - s.M, axis=0)])
        states = np.vstack([x, (Phix @ x + Sux @ u_prev + Gx @ z).reshape(s.P, -1)])
        error = (Phi @ x + Su @ u_prev + G @ z) - ref.ravel()
        cost = float(error @ self._Qbar @ error + z @ self._Rbar @ z
                     + self.soft.linear @ slack + 0.5 * slack @ (self.soft.quadratic * slack))
        if s.Qf is not None:
            cost += float(states[-1] @ s.Qf @ states[-1])
        return MPCSolution(inputs=inputs, states=states, outputs=states @ s.C.T,
                           plan=z.reshape(s.M, nu), status=status, cost=cost, slack=slack,
                           iterations=iterations, solve_time=solve_time)

    def controller(self, *, reference: ArrayLike | None = None,
                   initial_input: ArrayLike | None = None,
                   name: str | None = None) -> LinearMPCController:
        """This MPC as a controller of the :class:`~trainctl.controllers.Controller` protocol.

        Parameters
        ----------
        reference : array_like or None
            Output reference, as in :meth:`solve` (fixed for every step).
        initial_input : array_like or None
            u(k-1) before the first step (default zeros).
        name : str or None
            Label (default: this MPC's name).

        Returns
        -------
        LinearMPCController
            Call ``step(t, Measurement(state=x), None)`` once per sample.
        """
        return LinearMPCController(self, reference=reference, initial_input=initial_input,
                                   name=name)


class LinearMPCController:
    """A :class:`LinearMPC` behind the controller protocol (``reset``, ``step``).

    Each step solves at ``measurement.state`` with the input applied at the
    previous step and returns the first move. A solve without a usable
    solution keeps its outcome as the status (``"infeasible"``, ...) and
    applies the next input of the last good plan (fallback ``"shifted
    plan"``) or, when none is left, holds the previous input (fallback
    ``"hold input"``). A state that is not finite is not solved: the step is
    ``"error"`` (reason in ``info``) and holds the previous input. The
    ``reference`` argument of :meth:`step` (the
    train's speed preview) is ignored: the output reference is fixed when the
    controller is built. Build it with :meth:`LinearMPC.controller`.

    Parameters
    ----------
    mpc : LinearMPC
        The MPC solved every step.
    reference : array_like or None
        Output reference, fixed for every step.
    initial_input : array_like or None
        u(k-1) before the first step (None: zeros).
    name : str or None
        Label (None: the MPC's name).

    Examples
    --------
    The MPT3 problem of :func:`make_linear_mpc` in closed loop: the first
    step applies the saturated move -1; a state with a NaN is not solved, and
    the previous input is held.

    >>> import control as ct
    >>> sysd = ct.ss([[1, 1], [0, 1]], [[1], [0.5]], np.eye(2), 0, dt=1)
    >>> mpc = make_linear_mpc(sysd, Q=np.eye(2), R=1, prediction_horizon=4,
    ...                       u_min=-1, u_max=1, x_min=-5, x_max=5)
    >>> ctl = mpc.controller()
    >>> rec = ctl.step(0.0, Measurement(state=np.array([4.0, 0.0])))
    >>> rec.status, rec.inputs.round(4).tolist()
    ('optimal', [-1.0])
    >>> rec = ctl.step(1.0, Measurement(state=np.array([np.nan, 0.0])))
    >>> rec.status, rec.fallback, rec.inputs.round(4).tolist()
    ('error', 'hold input', [-1.0])
    """

    def __init__(self, mpc: LinearMPC, *, reference: ArrayLike | None,
                 initial_input: ArrayLike | None, name: str | None) -> None:
        where = "LinearMPC.controller"
        self.mpc, self.dt, self.name = mpc, mpc.dt, name or mpc.name
        self._ref = None if reference is None else mpc._reference(where, reference)
        self._initial = (np.zeros(mpc.n_inputs) if initial_input is None else
                         check.as_vector(where, "initial_input", initial_input, mpc.n_inputs,
                                         "inputs"))
        self.reset()

    def reset(self) -> None:
        """Forget the previous input and plan."""
        self._u_prev = self._initial.copy()
        self._planned = np.zeros((0, self.mpc.n_inputs))

    def step(self, t: float, measurement: Measurement,
             reference: ReferencePreview | None = None) -> StepRecord:
        """Solve at the measured state and return the first move.

        Parameters
        ----------
        t : float
            Time of the sample [s] (unused).
        measurement : Measurement
            Must hold the state x(k) (``measurement.state``), length nx, in
            the model's units.
        reference : ReferencePreview or None
            Ignored: the output reference is fixed when the controller is built.

        Returns
        -------
        StepRecord
            The input u(k) in the model's input units (the first move, or a
            fallback), the solve's status and iterations, the wall time [s]
            and ``info["cost"]``, the objective at the solution; a non-finite
            state gives status ``"error"`` and the previous input held.

        Raises
        ------
        ModelError
            If ``measurement.state`` is None.
        DimensionError
            If the state does not have length nx.
        """
        start = time.perf_counter()
        if measurement.state is None:
            raise ModelError(f"{self.name}: needs the state in measurement.state (got None).")
        if not np.isfinite(np.asarray(measurement.state, dtype=float)).all():
            self._planned = self._planned[1:]
            return StepRecord(inputs=self._u_prev.copy(), status="error",
                              solve_time=time.perf_counter() - start, fallback="hold input",
                              info={"reason": "non-finite measurement: state"})
        sol = self.mpc.solve(measurement.state, u_prev=self._u_prev, reference=self._ref)
        status, fallback = sol.status, ""
        if is_usable(status):
            u, self._planned = sol.first_move.copy(), sol.inputs[1:]
        else:
            fallback = "shifted plan" if len(self._planned) else "hold input"
            u = self._planned[0].copy() if len(self._planned) else self._u_prev.copy()
            self._planned = self._planned[1:]
        self._u_prev = u
        return StepRecord(inputs=u, status=status, iterations=sol.iterations,
                          solve_time=time.perf_counter() - start, fallback=fallback,
                          info={"cost": sol.cost})


def make_linear_mpc(sysd: ct.StateSpace, *, Q: ArrayLike, R: ArrayLike, prediction_horizon: int,
                    control_horizon: int | None = None, terminal_weight: ArrayLike | None = None,
                    form: str = "u", u_min: ArrayLike | None = None,
                    u_max: ArrayLike | None = None, du_max: ArrayLike | None = None,
                    x_min: ArrayLike | None = None, x_max: ArrayLike | None = None,
                    y_min: ArrayLike | None = None, y_max: ArrayLike | None = None,
                    soft: Mapping[str, bool | tuple[float, float]] | None = None,
                    path: str = "fast", qp_solver: str = "osqp",
                    name: str = "mpc") -> LinearMPC:
    """Build an MPC on any discrete linear model; the QP is modelled once here.

    Parameters
    ----------
    sysd : control.StateSpace
        Discrete model (dt > 0, D = 0): x(k+1) = A x + B u, y = C x.
    Q : array_like
        Output weight: (ny, ny) symmetric positive semidefinite matrix, a
        length-ny diagonal or a scalar.
    R : array_like
        Weight of the plan (u or Δu): (nu, nu) matrix, diagonal or scalar.
    prediction_horizon : int
        P >= 1 steps.
    control_horizon : int or None
        M moves, 1 <= M <= P (default P); the input is held after move M.
    terminal_weight : array_like or None
        Qf, the weight of the state x(k+P): (nx, nx) matrix, diagonal or scalar.
        It is added to the output weight of step P, whose cost is
        x(k+P)ᵀ (CᵀQC + Qf) x(k+P): for a terminal cost xᵀSx (e.g. the
        Riccati solution of ``control.dlqr``, which makes the MPC equal to
        LQR while no constraint is active) pass ``S - C.T @ Q @ C``.
    form : {"u", "du"}
        Decide (and weight with R) the inputs or their increments.
    u_min, u_max : array_like or None
        Input bounds: scalar or length nu; ±inf or None for none.
    du_max : array_like or None
        Largest |u(k+m) - u(k+m-1)|: scalar or length nu, >= 0.
    x_min, x_max : array_like or None
        State bounds on x(k+1), ..., x(k+P).
    y_min, y_max : array_like or None
        Output bounds on y(k+1), ..., y(k+P).
    soft : mapping or None
        Soft bound groups: keys among ``"u"``, ``"du"``, ``"x"``, ``"y"``;
        value True (penalties (1e3, 1e2)) or a pair (linear, quadratic) of
        slack penalties w1 >= 0, w2 > 0. Other bounds are hard.
    path : {"fast", "cvxpy"}
        QP solve path: probed OSQP data or ``Problem.solve`` (same solutions).
    qp_solver : {"osqp", "daqp", "auto"}
        QP solver of the fast path: OSQP, DAQP (dense active set, on the same
        data) or ``"auto"`` (DAQP up to
        :data:`~trainctl.controllers.mpc.qp.parametric.DAQP_MAX_DECISIONS` decisions).
    name : str
        Label of the QP and of error messages.

    Returns
    -------
    LinearMPC
        Call ``solve(x, u_prev=..., reference=...)`` every sample.

    Raises
    ------
    TypeError
        ``sysd`` is not a ``control.StateSpace``.
    DimensionError
        A weight or bound has the wrong shape.
    ModelError
        A value is invalid (continuous-time system, weight not positive
        semidefinite, M > P, lower bound above upper bound, ...).

    Examples
    --------
    The MPT3 regulation problem (python-control's pinned case):

    >>> import control as ct, numpy as np
    >>> sysd = ct.ss([[1, 1], [0, 1]], [[1], [0.5]], np.eye(2), 0, dt=1)
    >>> mpc = make_linear_mpc(sysd, Q=np.eye(2), R=1, prediction_horizon=4,
    ...                       u_min=-1, u_max=1, x_min=-5, x_max=5)
    >>> sol = mpc.solve([4.0, 0.0])
    >>> sol.status, sol.inputs.ravel().round(4).tolist()
    ('optimal', [-1.0, -1.0, 0.1393, 0.3361])
    >>> round(sol.cost + 4.0**2, 4)  # python-control and MPT3 count ‖x(0)‖²_Q as well
    32.4898
    """
    settings = check.core_settings("make_linear_mpc", sysd, Q=Q, R=R, P=prediction_horizon,
                         M=control_horizon, Qf=terminal_weight, form=form,
                         bounds={"u": (u_min, u_max), "du": (None, du_max), "x": (x_min, x_max),
                                 "y": (y_min, y_max)}, soft=soft)
    if path not in PATHS:
        raise ModelError(f"make_linear_mpc: 'path' must be one of {PATHS} (got {path!r}).")
    if qp_solver not in QP_SOLVERS:
        raise ModelError(f"make_linear_mpc: 'qp_solver' must be one of {QP_SOLVERS} "
                         f"(got {qp_solver!r}).")
    return LinearMPC(sysd, settings, path=path, name=str(name), qp_solver=qp_solver)
