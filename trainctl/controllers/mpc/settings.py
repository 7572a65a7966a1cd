# Settings of the MPC family, light to import: strategy names, constraints, the [controller] schema.
"""Names and settings of the MPC family (no solver imports).

:class:`ControllerSettings` is the schema of the family's ``[controller]``
table: every key is declared once here (type, unit and converter to SI,
constraint, default, one line of documentation, :mod:`trainctl.declare.keys`);
the scenario package derives the file table, its messages, documentation and
JSON Schema from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar

from pydantic import (
    TypeAdapter,
    ValidationError,
    ValidationInfo,
    model_validator,
)

from trainctl.controllers.mpc.rules import (
    NEIGHBOURHOODS,
    CooperativeWeightsRule,
    NeighbourhoodRule,
    coaches,
)
from trainctl.controllers.tracking import (
    InputWeight,
    InputWeightUnit,
    Outputs,
    QForce,
    QVelocity,
    check_force_weight,
    check_outputs_fit,
    per_kn2,
)
from trainctl.declare.constraints import Array, Choice, Flag, Integer, Number, Violation, raise_at
from trainctl.declare.keys import Key, python_error, settings
from trainctl.declare.limits import HORIZON, ITERATIONS
from trainctl.units import kmh_to_ms, kn_to_n

__all__ = [
    "CONTROLLER_FORMS",
    "NEIGHBOURHOODS",
    "LOCAL_BOUNDARIES",
    "LOCAL_HOLDS",
    "OBSERVERS",
    "QP_SOLVERS",
    "SOLVER_PATHS",
    "STRATEGIES",
    "ControllerSettings",
    "MPCConstraints",
]

STRATEGIES = ("centralised", "decentralised", "ndmpc", "cooperative", "ndmpc-local")
"""The MPC strategies (``"ndmpc-local"``: N-DMPC on the neighbourhood models only)."""

CONTROLLER_FORMS = ("u", "du")
"""Penalise the input (``"u"``) or its increments (``"du"``)."""

SOLVER_PATHS = ("fast", "cvxpy")
"""QP solve paths of the MPC."""

QP_SOLVERS = ("auto", "osqp", "daqp")
"""QP solvers of the fast path (``trainctl.controllers.mpc.qp.parametric.QP_SOLVERS``):
``"auto"`` takes DAQP for QPs of at most
``trainctl.controllers.mpc.qp.parametric.DAQP_MAX_DECISIONS`` decisions, OSQP above."""

LOCAL_HOLDS = ("foh", "zoh")
"""ndmpc-local: first- or zero-order hold of the exchanged outer states."""

LOCAL_BOUNDARIES = ("state", "force")
"""ndmpc-local: what a neighbourhood takes from outside
(trainctl.controllers.mpc.theory.local_iteration)."""

OBSERVERS = ("none", "kalman")
"""Full-state feedback, or a Kalman observer of the state and a grade-like disturbance."""


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
        Prediction steps (1..P) at which the coupler forces (and the speeds,
        under speed limits) are bounded; None for every step. Bounding a
        subset (e.g. the first few steps, then every fifth) shrinks each QP
        with little effect when the bound is far from active.
    speed_limits : bool
        Bound each vehicle's predicted speed by the track's speed limit at its
        predicted position (soft) when the controller is given a track with
        speed limits; False: ignore them.
    speed_limit_margin : float
        How far under the limit the predicted speeds are kept [m/s], >= 0.
    speed_soft_linear : float
        Linear penalty per m/s of speed over a limit.
    speed_soft_quadratic : float
        Quadratic penalty per (m/s)² of speed over a limit, > 0.

    Examples
    --------
    >>> limits = MPCConstraints(rate_limit=50e3, coupler_force_limit=200e3)
    >>> limits.input_bounds, limits.rate_limit / 1e3, limits.coupler_force_limit / 1e3  # [kN]
    (True, 50.0, 200.0)
    >>> MPCConstraints().rate_limit  # no rate limit by default
    inf
    """

    input_bounds: bool = True
    rate_limit: float = math.inf
    coupler_force_limit: float = math.inf
    soft_linear: float = 1e3
    soft_quadratic: float = 1e2
    force_steps: tuple[int, ...] | None = None
    speed_limits: bool = True
    speed_limit_margin: float = 0.0
    speed_soft_linear: float = 1e4
    speed_soft_quadratic: float = 1e3


_LIMIT = Number(gt=0, allow_inf=True)
_STEPS = Array(Integer(ge=1), extra={"uniqueItems": True})


@settings
class ControllerSettings:
    """A (D)MPC design: horizons, outputs, weights, neighbourhoods, constraints.

    Inputs are the coaches' traction/braking forces, one per vehicle; weights
    are given per squared design unit (velocity m/s, force kN), so that they
    are plain numbers. The design checks use the unconstrained part; the
    closed-loop simulation also uses the iteration settings and the
    constraints (:meth:`mpc_constraints`). Each field is declared once, with
    its ``[controller]`` key; invalid values raise
    :class:`~trainctl.exceptions.ModelError`. Checks that need the number of
    coaches ``n`` happen in :meth:`neighbourhoods` and
    :meth:`cooperative_weight_vector` (and, with key paths, when a scenario
    file is read).

    Parameters
    ----------
    form : {"u", "du"}
        Penalise the input deviation (``"u"``) or the input increments (``"du"``).
    prediction_horizon : int
        P [steps], >= 1.
    control_horizon : int
        M [steps], 1 <= M <= P.
    outputs : tuple of {"v", "force"}
        Controlled outputs in this order, distinct, non-empty: ``"v"`` the
        velocities [m/s], ``"force"`` the coupler forces [kN].
    q_velocity : float
        Weight on the velocity tracking error [per (m/s)^2], >= 0.
    q_force : float
        Weight on the coupler-force deviation [per kN^2], >= 0; > 0 needs
        ``"force"`` in ``outputs``.
    input_weight : float
        Input weight R as given, in ``input_weight_unit`` [per kN^2 or per
        N^2], > 0.
    input_weight_unit : {"kN", "N"}
        The force unit the user chose for R; reports quote thresholds in it.
    neighbourhood : {"adjacent", "all", "self"} or tuple of tuple of int
        Whose outputs coach i weighs: ``"adjacent"`` {i-1, i, i+1},
        ``"all"`` every coach, ``"self"`` {i} only, or one tuple of 0-based
        coach indices per coach (tuple i contains i, no repeats).
    iterations : int
        Fixed N-DMPC iteration count per sample analysed for the
        finite-iteration closed loop [-], >= 1.
    cooperative_weights : "uniform" or tuple of float
        Convex-combination weights of cooperative DMPC: ``"uniform"`` (1/n
        each) or one weight > 0 per coach, summing to 1 (within 1e-9).
    max_iterations : int
        Iteration limit per sample of the distributed strategies (N-DMPC,
        cooperative) in simulation [-], >= 1.
    iteration_tolerance : float
        The distributed iteration stops when every coach's plan changes by
        less than this [kN], > 0.
    relaxation : float
        N-DMPC relaxation factor omega [-], 0 < omega <= 1 (1: plain Jacobi).
    input_bounds : bool
        Bound each coach's force by its traction/braking envelope (hard).
    rate_limit : float
        Largest change of a coach's force per sample [N], > 0; ``math.inf``
        for no limit (hard).
    coupler_force_limit : float
        Largest absolute coupler force [N], > 0; ``math.inf`` for no limit
        (soft).
    soft_penalty_linear : float
        Linear penalty on a coupler-force violation [per kN], >= 0.
    soft_penalty_quadratic : float
        Quadratic penalty on a coupler-force violation [per kN^2], > 0.
    solver_path : {"fast", "cvxpy"}
        QP solve path of the MPC.
    qp_solver : {"auto", "osqp", "daqp"}
        QP solver of the fast path: OSQP (ADMM), DAQP (dual active set,
        dense) or ``"auto"``, DAQP for the small QPs (up to
        ``trainctl.controllers.mpc.qp.parametric.DAQP_MAX_DECISIONS`` decisions), OSQP
        for larger ones. The ``"cvxpy"`` path always uses OSQP.
    observer : {"none", "kalman"}
        ``"none"``: the controller measures the full state. ``"kalman"``: it
        measures the (noisy) speeds only and estimates the state and a
        specific-force disturbance (offset-free on grades).
    observer_disturbance_noise : float
        Random-walk step of the estimated disturbance per sample [m/s²], > 0.
    coupler_force_steps : tuple of int or None
        Prediction steps (1..P, increasing) at which the coupler-force bound
        and the speed-limit rows apply; None for every step.
    speed_limits : bool
        Keep every vehicle's predicted speed under the track's speed limit at
        its predicted position (soft rows) when ``[track]`` has speed limits;
        False: ignore them. No rows without limits.
    speed_limit_margin : float
        Keep the predicted speeds this far under the limits [m/s], >= 0 (file
        key ``speed_limit_margin_kmh``, km/h).
    speed_penalty_linear : float
        Linear penalty on a predicted speed over its limit [per m/s], >= 0.
    speed_penalty_quadratic : float
        Quadratic penalty on a predicted speed over its limit [per (m/s)^2], > 0.
    local_hold : {"foh", "zoh"}
        ``"ndmpc-local"``: the exchanged outer states between their samples,
        linear or constant (:func:`trainctl.controllers.mpc.theory.local_iteration.local_model`).
    local_substeps : int
        ``"ndmpc-local"``: exchanged trajectory samples per sample time, 1..64.
    local_boundary : {"state", "force"}
        ``"ndmpc-local"``: ``"state"`` the book's neighbourhood model,
        ``"force"`` the boundary coupler elongations exchanged too.

    Examples
    --------
    >>> ctl = ControllerSettings(form="du", prediction_horizon=4, control_horizon=2,
    ...                          input_weight=10.0, input_weight_unit="N")
    >>> ctl.input_weight_per_kn2()
    10000000.0
    >>> ctl.neighbourhoods(3)
    ((0, 1), (0, 1, 2), (1, 2))
    >>> ctl.max_iterations, ctl.iteration_tolerance, ctl.rate_limit, ctl.solver_path
    (50, 0.0001, inf, 'fast')
    """

    family: ClassVar[str] = "mpc"

    form: Annotated[str, Choice(CONTROLLER_FORMS), Key(
        "Penalise the input deviation ('u') or the input increments ('du')")]
    prediction_horizon: Annotated[int, HORIZON, Key("Prediction horizon P", unit="steps")]
    control_horizon: Annotated[int, Integer(ge=1), Key(
        "Control horizon M, the free moves inside P (M <= P)", unit="steps")]
    outputs: Outputs = ("v",)
    q_velocity: QVelocity = 1.0
    q_force: QForce = 0.0
    input_weight: InputWeight
    input_weight_unit: InputWeightUnit = "kN"
    neighbourhood: Annotated[str | tuple[tuple[int, ...], ...], NeighbourhoodRule(), Key(
        "Whose outputs coach i weighs: 'adjacent' {i-1, i, i+1}, 'all', 'self' {i}, "
        "or one array of coach indices per coach")] = "adjacent"
    iterations: Annotated[int, ITERATIONS, Key(
        "N-DMPC iterations per sample analysed for the finite-iteration closed loop")] = 10
    cooperative_weights: Annotated[str | tuple[float, ...], CooperativeWeightsRule(), Key(
        "Cooperative DMPC weights: 'uniform' (1/n each) or one weight per coach")] = "uniform"
    max_iterations: Annotated[int, ITERATIONS, Key(
        "Iteration limit per sample of N-DMPC / cooperative DMPC in simulation")] = 50
    iteration_tolerance: Annotated[float, Number(gt=0), Key(
        "Stop iterating when every coach's plan changes by less than this",
        file="iteration_tolerance_kn", unit="kN")] = 1e-4
    relaxation: Annotated[float, Number(gt=0, le=1), Key(
        "N-DMPC relaxation factor omega (1 = plain Jacobi iteration)",
        hint=" The N-DMPC relaxation factor omega blends each new plan with the previous "
        "one; 1 is the plain Jacobi iteration.")] = 1.0
    input_bounds: Annotated[bool, Flag(), Key(
        "Bound each coach's force by its traction/braking envelope (hard)")] = True
    rate_limit: Annotated[float, _LIMIT, Key(
        "Largest change of a coach's force per sample (hard)", file="rate_limit_kn",
        unit="kN", to_si=kn_to_n, si_unit="N", omitted="no limit")] = math.inf
    coupler_force_limit: Annotated[float, _LIMIT, Key(
        "Largest absolute coupler force (soft)", file="coupler_force_limit_kn", unit="kN",
        to_si=kn_to_n, si_unit="N", omitted="no limit")] = math.inf
    soft_penalty_linear: Annotated[float, Number(ge=0), Key(
        "Linear penalty on a coupler-force violation", unit="per kN")] = 1000.0
    soft_penalty_quadratic: Annotated[float, Number(gt=0), Key(
        "Quadratic penalty on a coupler-force violation", unit="per kN²")] = 100.0
    solver_path: Annotated[str, Choice(SOLVER_PATHS), Key("QP solve path")] = "fast"
    qp_solver: Annotated[str, Choice(QP_SOLVERS), Key(
        "QP solver of the fast path: 'osqp', 'daqp' (dense active set) or 'auto' (DAQP for "
        "small QPs, OSQP for large ones)")] = "auto"
    observer: Annotated[str, Choice(OBSERVERS), Key(
        "'kalman': measure the (noisy) speeds only and estimate the state and a grade-like "
        "disturbance, which the feedforward compensates")] = "none"
    observer_disturbance_noise: Annotated[float, Number(gt=0), Key(
        "Random-walk step of the estimated disturbance per sample", unit="m/s²")] = 1e-3
    coupler_force_steps: Annotated[Annotated[tuple[int, ...], _STEPS] | None, Key(
        "Prediction steps (1..P, increasing) at which the coupler-force bound and the "
        "speed-limit rows apply", omitted="every step")] = None
    speed_limits: Annotated[bool, Flag(), Key(
        "Keep every vehicle's predicted speed under the track's speed limit at its predicted "
        "position (soft) when [track] has speed limits; false: ignore them")] = True
    speed_limit_margin: Annotated[float, Number(ge=0), Key(
        "How far under the speed limits the predicted speeds are kept",
        file="speed_limit_margin_kmh", unit="km/h", to_si=kmh_to_ms, si_unit="m/s")] = 0.0
    speed_penalty_linear: Annotated[float, Number(ge=0), Key(
        "Linear penalty on a predicted speed over its limit", unit="per m/s")] = 1e4
    speed_penalty_quadratic: Annotated[float, Number(gt=0), Key(
        "Quadratic penalty on a predicted speed over its limit", unit="per (m/s)²")] = 1e3
    local_hold: Annotated[str, Choice(LOCAL_HOLDS), Key(
        "ndmpc-local: the exchanged outer states between their samples, 'foh' linear or "
        "'zoh' constant")] = "foh"
    local_substeps: Annotated[int, Integer(ge=1, le=64), Key(
        "ndmpc-local: exchanged trajectory samples per sample time")] = 1
    local_boundary: Annotated[str, Choice(LOCAL_BOUNDARIES), Key(
        "ndmpc-local: 'state' the book's neighbourhood model (outer states exchanged), "
        "'force' the boundary coupler elongations exchanged too")] = "state"

    @model_validator(mode="after")
    def _cross_field_rules(self, info: ValidationInfo) -> ControllerSettings:
        if self.control_horizon > self.prediction_horizon:
            raise_at(("control_horizon",), Violation(
                text=f"must be an integer from 1 to {{prediction_horizon}} = "
                f"{self.prediction_horizon}",
                got=self.control_horizon,
                hint=" The control horizon M counts the free moves inside the prediction "
                "horizon P.",
            ), self.control_horizon)
        check_force_weight(self.outputs, self.q_force)
        check_outputs_fit(self.outputs, coaches(info))
        steps = self.coupler_force_steps or ()
        for i, step in enumerate(steps):
            if step > self.prediction_horizon or (i and step <= steps[i - 1]):
                raise_at(("coupler_force_steps", i), Violation(
                    text="must be an increasing integer from 1 to {prediction_horizon} = "
                    f"{self.prediction_horizon}",
                    got=step,
                    hint=" Omit the key to bound the coupler forces at every prediction step.",
                ), step)
        return self

    def mpc_constraints(self) -> MPCConstraints:
        """The constraint settings in the form the MPC controller takes.

        Returns
        -------
        MPCConstraints
            ``input_bounds``, ``rate_limit`` [N], ``coupler_force_limit``
            [N], ``soft_linear`` [per kN], ``soft_quadratic`` [per kN^2],
            ``force_steps``, ``speed_limits``, ``speed_limit_margin`` [m/s],
            ``speed_soft_linear`` [per m/s] and ``speed_soft_quadratic``
            [per (m/s)^2] copied from these settings.

        Examples
        --------
        >>> ctl = ControllerSettings(form="u", prediction_horizon=1, control_horizon=1,
        ...                          input_weight=1.0, coupler_force_limit=5e5)
        >>> limits = ctl.mpc_constraints()
        >>> limits.input_bounds, limits.rate_limit, limits.coupler_force_limit
        (True, inf, 500000.0)
        >>> limits.soft_linear, limits.soft_quadratic
        (1000.0, 100.0)
        """
        return MPCConstraints(
            input_bounds=self.input_bounds,
            rate_limit=self.rate_limit,
            coupler_force_limit=self.coupler_force_limit,
            soft_linear=self.soft_penalty_linear,
            soft_quadratic=self.soft_penalty_quadratic,
            force_steps=self.coupler_force_steps,
            speed_limits=self.speed_limits,
            speed_limit_margin=self.speed_limit_margin,
            speed_soft_linear=self.speed_penalty_linear,
            speed_soft_quadratic=self.speed_penalty_quadratic,
        )

    def input_weight_per_kn2(self) -> float:
        """The input weight R converted to per kN^2 (the design unit).

        Returns
        -------
        float
            ``input_weight`` [per kN^2]; a weight given per N^2 is multiplied
            by 1e6.

        Examples
        --------
        >>> ControllerSettings(form="u", prediction_horizon=1, control_horizon=1,
        ...                    input_weight=2.0).input_weight_per_kn2()
        2.0
        """
        return per_kn2(self.input_weight, self.input_weight_unit)

    def neighbourhoods(self, n: int) -> tuple[tuple[int, ...], ...]:
        """Resolve the neighbourhood of every coach in a train of ``n`` coaches.

        Parameters
        ----------
        n : int
            Number of coaches (inputs) [-], >= 1.

        Returns
        -------
        tuple of tuple of int
            Entry i lists the 0-based coaches whose outputs coach i weighs,
            ascending; it always contains i.

        Raises
        ------
        ModelError
            If ``n`` < 1, or an explicit neighbourhood does not have ``n``
            entries or names a coach >= ``n``.

        Examples
        --------
        >>> ctl = ControllerSettings(form="u", prediction_horizon=2, control_horizon=1,
        ...                          input_weight=1.0, neighbourhood="self")
        >>> ctl.neighbourhoods(3)
        ((0,), (1,), (2,))
        """
        n = self._fits("neighbourhood", n)
        kind = self.neighbourhood
        if not isinstance(kind, str):
            return tuple(tuple(sorted(members)) for members in kind)
        if kind == "all":
            return (tuple(range(n)),) * n
        if kind == "self":
            return tuple((i,) for i in range(n))
        return tuple(tuple(range(max(0, i - 1), min(n, i + 2))) for i in range(n))

    def cooperative_weight_vector(self, n: int) -> tuple[float, ...]:
        """Resolve the cooperative DMPC weights for ``n`` coaches.

        Parameters
        ----------
        n : int
            Number of coaches [-], >= 1.

        Returns
        -------
        tuple of float
            One weight per coach [-], summing to 1 (``1/n`` each for
            ``"uniform"``).

        Raises
        ------
        ModelError
            If ``n`` < 1 or explicit weights do not have ``n`` entries.

        Examples
        --------
        >>> ControllerSettings(form="u", prediction_horizon=1, control_horizon=1,
        ...                    input_weight=1.0).cooperative_weight_vector(4)
        (0.25, 0.25, 0.25, 0.25)
        """
        n = self._fits("cooperative_weights", n)
        if isinstance(self.cooperative_weights, str):
            return (1.0 / n,) * n
        return self.cooperative_weights

    def _fits(self, name: str, n: int) -> int:
        """Check field ``name`` against a train of ``n`` coaches; return n."""
        try:
            n = _N_COACHES.validate_python(n)
        except ValidationError as exc:
            raise python_error("ControllerSettings", exc, prefix=("n",)) from None
        try:
            _FIELD_ADAPTERS[name].validate_python(getattr(self, name), context={"n_coaches": n})
        except ValidationError as exc:
            raise python_error("ControllerSettings", exc, prefix=(name,)) from None
        return n


_N_COACHES: TypeAdapter[int] = TypeAdapter(Annotated[int, Integer(ge=1)])
_FIELD_ADAPTERS: dict[str, TypeAdapter[Any]] = {
    "neighbourhood": TypeAdapter(Annotated[Any, NeighbourhoodRule()]),
    "cooperative_weights": TypeAdapter(Annotated[Any, CooperativeWeightsRule()]),
}
