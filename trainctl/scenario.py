# Scenario files: the one module that reads TOML and turns it into SI objects.
"""Read scenario files (TOML) into frozen dataclasses with SI values inside.

A scenario names a train (a preset or explicit vehicle groups), an optional
track, the model settings (cruise speed, linearisation, sampling), optionally
a (D)MPC design with its constraints (``[controller]``), a closed-loop
simulation run (``[simulation]``) and the declared outcome of the design
checks (``[expected]``). Keys
whose name carries a unit (``mass_t``, ``speed_kmh``, ``stiffness_kn_per_m``)
are converted once, here, with :mod:`trainctl.units`; every other number is
already SI. The schema is documented in ``analyses/README.md``.

Every malformed input raises :class:`~trainctl.exceptions.ScenarioError`
whose message names the file, the key path (``[train.vehicle][2].mass_t``;
array indices count from 0, head vehicle first), what must hold and what was
given.

Built-in scenarios are the ``*.toml`` files shipped in
``trainctl/builtin_analyses/`` (an installed wheel) or, in a source checkout,
the top-level ``analyses/`` directory. A bare name such as ``crh2-dmpc``
selects one; anything that looks like a path is read as a file.
"""

from __future__ import annotations

import datetime
import difflib
import inspect
import math
import numbers
import os
import re
import tomllib
import unicodedata
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeVar

from .exceptions import ModelError, ScenarioError
from .models.track import RESISTANCE_FORMULAS, Track, TrackSection
from .models.train import Train
from .models.vehicle import Coupler, TractionEnvelope, Vehicle
from .units import (
    davis_book_literal,
    davis_from_unit_resistance_kmh,
    kmh_to_ms,
    kn_per_m_to_n_per_m,
    kn_s_per_m_to_n_s_per_m,
    kn_to_n,
    kw_to_w,
    tonnes_to_kg,
)

if TYPE_CHECKING:
    from .controllers.mpc import MPCConstraints

__all__ = [
    "ALLOCATIONS",
    "CHECK_NAMES",
    "CHECK_STATUSES",
    "CONTROLLER_FORMS",
    "CONTROLLER_OUTPUTS",
    "DISCRETISATIONS",
    "LINEARISATIONS",
    "NEIGHBOURHOODS",
    "RESERVED_SECTIONS",
    "SCHEMA_VERSION",
    "SIMULATION_STRATEGIES",
    "OBSERVERS",
    "SOLVER_PATHS",
    "BuiltinScenario",
    "ControllerSettings",
    "ModelSettings",
    "Scenario",
    "SimulationSettings",
    "builtin_scenario_text",
    "builtin_scenarios",
    "load_scenario",
    "parse_scenario",
    "read_scenario_text",
    "slugify",
]

SCHEMA_VERSION = 1
"""The only ``schema_version`` this release reads."""

RESERVED_SECTIONS = ("report", "communication", "sweep")
"""Top-level sections reserved for later releases (rejected today)."""

LINEARISATIONS = ("jacobian", "book")
"""Accepted values of ``[model].linearisation``."""

ALLOCATIONS = ("shares", "own")
"""Accepted values of ``[model].allocation``."""

DISCRETISATIONS = ("zoh", "tustin")
"""Accepted values of ``[model].discretisation``."""

CONTROLLER_FORMS = ("u", "du")
"""Accepted values of ``[controller].form``: penalise the input or its increments."""

CONTROLLER_OUTPUTS = ("v", "force")
"""Accepted items of ``[controller].outputs``: velocities [m/s], coupler forces [kN]."""

NEIGHBOURHOODS = ("adjacent", "all", "self")
"""Named kinds of ``[controller].neighbourhood`` (an explicit list is also accepted)."""

SOLVER_PATHS = ("fast", "cvxpy")
"""Accepted values of ``[controller].solver_path``: the QP solve path of the MPC."""

OBSERVERS = ("none", "kalman")
"""Accepted values of ``[controller].observer``: full-state feedback, or a Kalman
observer that estimates the state and a grade-like disturbance from the speeds."""

SIMULATION_STRATEGIES = ("centralised", "decentralised", "ndmpc", "cooperative")
"""Accepted items of ``[simulation].strategies``.

The same names as :data:`trainctl.controllers.mpc.STRATEGIES`, repeated here
so that ``import trainctl.scenario`` does not import the MPC solvers.
"""

CHECK_NAMES = (
    "open_loop_stability",
    "controllability",
    "observability",
    "sampling",
    "input_collapse",
    "ndmpc_convergence",
    "relaxation",
    "closed_loop_nash",
    "closed_loop_iterations",
    "nash_gap",
    "cooperative_convergence",
    "centralised_closed_loop",
)
"""Names of the design checks whose outcome ``[expected]`` may declare.

``open_loop_stability``
    Modes of the open-loop linear model.
``controllability`` / ``observability``
    Rank tests of the design model.
``sampling``
    Fastest coupler mode times the sample time, against pi (aliasing).
``input_collapse``
    Whether every input acts almost alike over one sample.
``ndmpc_convergence``
    Convergence of the N-DMPC (Jacobi) iteration, rho(D0) < 1.
``relaxation``
    Whether a relaxation factor makes the N-DMPC iteration converge.
``closed_loop_nash``
    Closed loop with the converged N-DMPC (Nash point).
``closed_loop_iterations``
    Closed loop with ``[controller].iterations`` N-DMPC iterations per sample.
``nash_gap``
    Cost of the Nash point above the centralised optimum.
``cooperative_convergence``
    Convergence of the cooperative DMPC iteration.
``centralised_closed_loop``
    Closed loop with centralised MPC.
"""

CHECK_STATUSES = ("pass", "warn", "fail")
"""Accepted statuses in ``[expected]``."""

_SLUG_MAX = 60
_MAX_VEHICLES = 10_000
_MISSING: Any = object()
_T = TypeVar("_T")

_TOP_KEYS = (
    "schema_version", "name", "description", "seed", "train", "track", "model", "controller",
    "simulation", "expected",
)  # fmt: skip
_TRAIN_KEYS = ("preset", "preset_options", "vehicle", "coupler")
_DAVIS_KEYS = ("davis_n_per_kn_kmh", "davis_si", "davis_book_literal")
_VEHICLE_KEYS = (
    "name", "count", "mass_t", "length", *_DAVIS_KEYS, "traction_share",
    "max_traction_kn", "max_power_kw", "max_braking_kn", "max_braking_power_kw", "adhesion",
)  # fmt: skip
_COUPLER_KEYS = ("stiffness_kn_per_m", "damping_kn_s_per_m", "virtual", "gap")
_TRACK_KEYS = ("formula", "wheelbase", "section")
_SECTION_KEYS = ("start", "grade_permille", "curve_radius")
_MODEL_KEYS = (
    "speed_kmh", "linearisation", "dummy_state", "allocation", "sample_time", "discretisation",
)  # fmt: skip
_CONTROLLER_KEYS = (
    "form", "prediction_horizon", "control_horizon", "outputs", "q_velocity", "q_force_per_kn2",
    "r_per_kn2", "r_per_n2", "neighbourhood", "iterations", "cooperative_weights",
    "max_iterations", "iteration_tolerance_kn", "relaxation", "input_bounds", "rate_limit_kn",
    "coupler_force_limit_kn", "soft_penalty_linear", "soft_penalty_quadratic", "solver_path",
    "observer", "observer_disturbance_noise", "coupler_force_steps",
)  # fmt: skip
_SIMULATION_KEYS = (
    "duration", "strategies", "initial_speed_error", "measurement_noise", "settle_time",
    "tracking_tolerance", "regen_efficiency", "reference",
)  # fmt: skip
_REFERENCE_KEYS = ("times", "speeds_kmh", "speeds")
_REFERENCE_SPEED_KEYS = {"speeds_kmh": "km/h", "speeds": "m/s"}
_MULTIPLE_TOL = 1e-9  # relative tolerance of "duration is a whole multiple of sample_time"
_INPUT_WEIGHT_KEYS = {"r_per_kn2": "kN", "r_per_n2": "N"}
_N2_PER_KN2 = kn_to_n(1.0) ** 2  # a weight per N^2 times this is the weight per kN^2
_WEIGHT_SUM_TOL = 1e-9
_CONTROLLER_CHECKS = (
    "ndmpc_convergence", "relaxation", "closed_loop_nash", "closed_loop_iterations", "nash_gap",
    "cooperative_convergence", "centralised_closed_loop",
)  # fmt: skip
_DAVIS_CONVERTERS: dict[str, Callable[[float, float, float], tuple[float, float, float]]] = {
    "davis_n_per_kn_kmh": davis_from_unit_resistance_kmh,
    "davis_si": lambda c0, c1, c2: (c0, c1, c2),
    "davis_book_literal": davis_book_literal,
}
_NO_LIMIT = " Omit the key for no limit."
_STRAIGHT = " Omit the key for straight track."
_BOUNDS = {None: "", "pos": " > 0", "nonneg": " >= 0"}


@dataclass(frozen=True, kw_only=True)
class ModelSettings:
    """How the train model is linearised and sampled.

    Parameters
    ----------
    speed : float
        Cruise (linearisation) speed [m/s], > 0.
    linearisation : {"jacobian", "book"}
        Jacobian of the Davis law at ``speed``, or the book's printed matrices.
    dummy_state : bool
        Keep the book's dummy state in the linear model.
    allocation : {"shares", "own"}
        Cruise traction spread by ``traction_share`` within each physically
        coupled group, or each vehicle carrying its own resistance.
    sample_time : float
        Sample time of the discrete model [s], > 0.
    discretisation : {"zoh", "tustin"}
        Continuous-to-discrete method.

    Examples
    --------
    >>> ModelSettings(speed=25.0, sample_time=0.1).discretisation
    'zoh'
    """

    speed: float
    linearisation: str = "jacobian"
    dummy_state: bool = True
    allocation: str = "shares"
    sample_time: float
    discretisation: str = "zoh"

    def __post_init__(self) -> None:
        for name in ("speed", "sample_time"):
            value = float(getattr(self, name))
            if not math.isfinite(value) or value <= 0:
                raise ModelError(f"ModelSettings: {name!r} must be > 0 (got {value!r}).")
            object.__setattr__(self, name, value)
        for name, options in (
            ("linearisation", LINEARISATIONS),
            ("allocation", ALLOCATIONS),
            ("discretisation", DISCRETISATIONS),
        ):
            if getattr(self, name) not in options:
                raise ModelError(
                    f"ModelSettings: {name!r} must be one of {options} "
                    f"(got {getattr(self, name)!r})."
                )


@dataclass(frozen=True, kw_only=True)
class ControllerSettings:
    """A (D)MPC design: horizons, outputs, weights, neighbourhoods, constraints.

    Inputs are the coaches' traction/braking forces, one per vehicle; weights
    are given per squared design unit (velocity m/s, force kN), so that they
    are plain numbers. The design checks use the unconstrained part; the
    closed-loop simulation also uses the iteration settings and the
    constraints (:meth:`mpc_constraints`). Built-in validation raises
    :class:`~trainctl.exceptions.ModelError`; checks that need the number of
    coaches ``n`` happen in :meth:`neighbourhoods` and
    :meth:`cooperative_weight_vector` (and, with key paths, in
    :func:`parse_scenario`).

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
    observer : {"none", "kalman"}
        ``"none"``: the controller measures the full state. ``"kalman"``: it
        measures the (noisy) speeds only and estimates the state and a
        specific-force disturbance (offset-free on grades).
    observer_disturbance_noise : float
        Random-walk step of the estimated disturbance per sample [m/s²], > 0.
    coupler_force_steps : tuple of int or None
        Prediction steps (1..P, increasing) at which the coupler-force bound
        applies; None for every step.

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

    form: str
    prediction_horizon: int
    control_horizon: int
    outputs: tuple[str, ...] = ("v",)
    q_velocity: float = 1.0
    q_force: float = 0.0
    input_weight: float
    input_weight_unit: str = "kN"
    neighbourhood: str | tuple[tuple[int, ...], ...] = "adjacent"
    iterations: int = 10
    cooperative_weights: str | tuple[float, ...] = "uniform"
    max_iterations: int = 50
    iteration_tolerance: float = 1e-4
    relaxation: float = 1.0
    input_bounds: bool = True
    rate_limit: float = math.inf
    coupler_force_limit: float = math.inf
    soft_penalty_linear: float = 1000.0
    soft_penalty_quadratic: float = 100.0
    solver_path: str = "fast"
    observer: str = "none"
    observer_disturbance_noise: float = 1e-3
    coupler_force_steps: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        def fail(message: str) -> NoReturn:
            raise ModelError(f"ControllerSettings: {message}")

        if self.form not in CONTROLLER_FORMS:
            fail(f"'form' must be one of {CONTROLLER_FORMS} (got {self.form!r}).")
        for name in ("prediction_horizon", "control_horizon", "iterations", "max_iterations"):
            value = getattr(self, name)
            if not _is_int(value) or value < 1:
                fail(f"{name!r} must be an integer >= 1 (got {value!r}).")
            object.__setattr__(self, name, int(value))
        if self.control_horizon > self.prediction_horizon:
            fail(
                f"'control_horizon' must be <= 'prediction_horizon' = "
                f"{self.prediction_horizon} (got {self.control_horizon})."
            )
        outputs = (self.outputs,) if isinstance(self.outputs, str) else tuple(self.outputs)
        if (
            not outputs
            or any(o not in CONTROLLER_OUTPUTS for o in outputs)
            or len(set(outputs)) != len(outputs)
        ):
            fail(
                f"'outputs' must be distinct items of {CONTROLLER_OUTPUTS}, at least one "
                f"(got {self.outputs!r})."
            )
        object.__setattr__(self, "outputs", outputs)
        for name, bound in (
            ("q_velocity", "nonneg"),
            ("q_force", "nonneg"),
            ("input_weight", "pos"),
            ("iteration_tolerance", "pos"),
            ("relaxation", "pos"),
            ("soft_penalty_linear", "nonneg"),
            ("soft_penalty_quadratic", "pos"),
        ):
            value = getattr(self, name)
            x = _as_float(value)
            if not math.isfinite(x) or x < 0 or (bound == "pos" and x == 0):
                fail(f"{name!r} must be a finite number{_BOUNDS[bound]} (got {value!r}).")
            object.__setattr__(self, name, x)
        if self.relaxation > 1.0:
            fail(f"'relaxation' must be in (0, 1] (got {self.relaxation!r}).")
        for name in ("rate_limit", "coupler_force_limit"):
            value = getattr(self, name)
            x = _as_float(value)
            if not x > 0:  # inf (no limit) is allowed, nan is not
                fail(f"{name!r} must be a number > 0 [N], or inf for no limit (got {value!r}).")
            object.__setattr__(self, name, x)
        if not isinstance(self.input_bounds, bool):
            fail(f"'input_bounds' must be True or False (got {self.input_bounds!r}).")
        if self.solver_path not in SOLVER_PATHS:
            fail(f"'solver_path' must be one of {SOLVER_PATHS} (got {self.solver_path!r}).")
        if self.observer not in OBSERVERS:
            fail(f"'observer' must be one of {OBSERVERS} (got {self.observer!r}).")
        if not (math.isfinite(self.observer_disturbance_noise)
                and self.observer_disturbance_noise > 0):
            fail("'observer_disturbance_noise' must be a number > 0 [m/s²] "
                 f"(got {self.observer_disturbance_noise!r}).")
        if self.q_force > 0 and "force" not in outputs:
            fail(f"'q_force' must be 0 without 'force' in 'outputs' (got {self.q_force!r}).")
        if self.input_weight_unit not in _INPUT_WEIGHT_KEYS.values():
            fail(f"'input_weight_unit' must be 'kN' or 'N' (got {self.input_weight_unit!r}).")
        object.__setattr__(self, "neighbourhood", _freeze_neighbourhood(self.neighbourhood))
        object.__setattr__(self, "cooperative_weights", _freeze_weights(self.cooperative_weights))

    def mpc_constraints(self) -> MPCConstraints:
        """The constraint settings in the form the MPC controller takes.

        Returns
        -------
        trainctl.controllers.mpc.MPCConstraints
            ``input_bounds``, ``rate_limit`` [N], ``coupler_force_limit``
            [N], ``soft_linear`` [per kN] and ``soft_quadratic`` [per kN^2]
            copied from these settings.

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
        from .controllers.mpc import MPCConstraints

        return MPCConstraints(
            input_bounds=self.input_bounds,
            rate_limit=self.rate_limit,
            coupler_force_limit=self.coupler_force_limit,
            soft_linear=self.soft_penalty_linear,
            soft_quadratic=self.soft_penalty_quadratic,
            force_steps=self.coupler_force_steps,
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
        if self.input_weight_unit == "N":
            return self.input_weight * _N2_PER_KN2
        return self.input_weight

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
        n = _coach_count(n)
        kind = self.neighbourhood
        if isinstance(kind, str):
            if kind == "all":
                return (tuple(range(n)),) * n
            if kind == "self":
                return tuple((i,) for i in range(n))
            return tuple(tuple(range(max(0, i - 1), min(n, i + 2))) for i in range(n))
        if len(kind) != n:
            raise ModelError(
                f"ControllerSettings: 'neighbourhood' has {len(kind)} entries for a train of "
                f"{n} coaches (one per coach needed)."
            )
        if any(j >= n for members in kind for j in members):
            raise ModelError(
                f"ControllerSettings: 'neighbourhood' names a coach >= {n} for a train of "
                f"{n} coaches (indices count from 0)."
            )
        return tuple(tuple(sorted(members)) for members in kind)

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
        n = _coach_count(n)
        if isinstance(self.cooperative_weights, str):
            return (1.0 / n,) * n
        if len(self.cooperative_weights) != n:
            raise ModelError(
                f"ControllerSettings: 'cooperative_weights' has "
                f"{len(self.cooperative_weights)} entries for a train of {n} coaches."
            )
        return self.cooperative_weights


@dataclass(frozen=True, kw_only=True)
class SimulationSettings:
    """A closed-loop simulation run: duration, strategies, reference, judgement.

    Built-in validation raises :class:`~trainctl.exceptions.ModelError`; the
    check against the sample time happens in :meth:`n_steps` (and, with key
    paths, in :func:`parse_scenario`).

    Parameters
    ----------
    duration : float
        Simulated time [s], > 0; a whole multiple of the sample time.
    strategies : tuple of str
        MPC strategies to simulate, distinct items of
        :data:`SIMULATION_STRATEGIES`, at least one, in this order.
    reference_times : tuple of float
        Breakpoint times of the reference speed [s]: finite, strictly
        increasing, the first 0. The reference is piecewise linear through
        the breakpoints and constant after the last one.
    reference_speeds : tuple of float
        Reference speed at each breakpoint [m/s], finite, >= 0, one per time.
    initial_speed_error : float
        Common speed offset of every vehicle at t = 0 [m/s], finite; the
        initial speed ``reference_speeds[0] + initial_speed_error`` must be
        >= 0.
    measurement_noise : float
        Standard deviation of the Gaussian speed-measurement noise [m/s], >= 0.
    settle_time : float
        Tracking is judged after this time [s], 0 <= settle_time < duration.
    tracking_tolerance : float
        Largest admissible absolute speed error after ``settle_time`` [m/s], > 0.
    regen_efficiency : float
        Share of the braking energy credited back [-], 0 to 1.

    Examples
    --------
    >>> sim = SimulationSettings(duration=1200.0, strategies=("ndmpc",),
    ...                          reference_times=(0.0, 600.0), reference_speeds=(20.0, 80.0))
    >>> sim.n_steps(20.0), sim.tracking_tolerance, sim.regen_efficiency
    (60, 1.0, 1.0)
    """

    duration: float
    strategies: tuple[str, ...]
    reference_times: tuple[float, ...]
    reference_speeds: tuple[float, ...]
    initial_speed_error: float = 0.0
    measurement_noise: float = 0.0
    settle_time: float = 0.0
    tracking_tolerance: float = 1.0
    regen_efficiency: float = 1.0

    def __post_init__(self) -> None:
        def fail(message: str) -> NoReturn:
            raise ModelError(f"SimulationSettings: {message}")

        for name, bound in (
            ("duration", "pos"),
            ("initial_speed_error", None),
            ("measurement_noise", "nonneg"),
            ("settle_time", "nonneg"),
            ("tracking_tolerance", "pos"),
            ("regen_efficiency", "nonneg"),
        ):
            value = getattr(self, name)
            x = _as_float(value)
            if not math.isfinite(x) or (bound and x < 0) or (bound == "pos" and x == 0):
                fail(f"{name!r} must be a finite number{_BOUNDS[bound]} (got {value!r}).")
            object.__setattr__(self, name, x)
        if self.regen_efficiency > 1.0:
            fail(f"'regen_efficiency' must be in [0, 1] (got {self.regen_efficiency!r}).")
        if self.settle_time >= self.duration:
            fail(
                f"'settle_time' must be less than 'duration' = {self.duration!r} "
                f"(got {self.settle_time!r})."
            )
        strategies = (
            (self.strategies,) if isinstance(self.strategies, str) else tuple(self.strategies)
        )
        if (
            not strategies
            or any(s not in SIMULATION_STRATEGIES for s in strategies)
            or len(set(strategies)) != len(strategies)
        ):
            fail(
                f"'strategies' must be distinct items of {SIMULATION_STRATEGIES}, at least "
                f"one (got {self.strategies!r})."
            )
        object.__setattr__(self, "strategies", strategies)
        times = _float_tuple(self.reference_times)
        speeds = _float_tuple(self.reference_speeds)
        if not times or not all(math.isfinite(t) for t in times) or times[0] != 0.0:
            fail(
                f"'reference_times' must be finite numbers starting at 0 "
                f"(got {self.reference_times!r})."
            )
        if any(times[i] <= times[i - 1] for i in range(1, len(times))):
            fail(f"'reference_times' must be strictly increasing (got {self.reference_times!r}).")
        if len(speeds) != len(times) or not all(math.isfinite(v) and v >= 0 for v in speeds):
            fail(
                f"'reference_speeds' must be {len(times)} finite numbers >= 0, one per "
                f"reference time (got {self.reference_speeds!r})."
            )
        object.__setattr__(self, "reference_times", times)
        object.__setattr__(self, "reference_speeds", speeds)
        if speeds[0] + self.initial_speed_error < 0:
            fail(
                f"'initial_speed_error' must be >= {-speeds[0]!r}, minus the reference speed "
                f"at t = 0 (got {self.initial_speed_error!r})."
            )

    def n_steps(self, sample_time: float) -> int:
        """The number of samples that make up :attr:`duration`.

        Parameters
        ----------
        sample_time : float
            Sample time of the model and controller [s], > 0.

        Returns
        -------
        int
            ``duration / sample_time`` [-], >= 1.

        Raises
        ------
        ModelError
            If ``sample_time`` is not a number > 0 or ``duration`` is not a
            whole multiple of it (relative tolerance 1e-9).

        Examples
        --------
        >>> sim = SimulationSettings(duration=1.5, strategies=("centralised",),
        ...                          reference_times=(0.0,), reference_speeds=(25.0,))
        >>> sim.n_steps(0.1)
        15
        """
        dt = _as_float(sample_time)
        if not (math.isfinite(dt) and dt > 0):
            raise ModelError(
                f"SimulationSettings: 'sample_time' must be a finite number > 0 "
                f"(got {sample_time!r})."
            )
        steps = _whole_steps(self.duration, dt)
        if steps is None:
            raise ModelError(
                f"SimulationSettings: 'duration' = {self.duration!r} s must be a whole "
                f"multiple of the sample time {dt!r} s (got {self.duration / dt!r} samples)."
            )
        return steps


class _FrozenMapping(Mapping[str, str]):
    """A read-only, hashable, picklable ``str -> str`` mapping in insertion order."""

    __slots__ = ("_data",)
    _data: dict[str, str]

    def __init__(self, items: Mapping[str, str] | Iterable[tuple[str, str]] = ()) -> None:
        object.__setattr__(self, "_data", dict(items))

    def __setattr__(self, name: str, value: Any) -> NoReturn:
        raise AttributeError(f"{type(self).__name__} is read-only")

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (tuple(self._data.items()),))

    def __getitem__(self, key: str) -> str:
        return self._data[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __hash__(self) -> int:
        return hash(frozenset(self._data.items()))

    def __repr__(self) -> str:
        return repr(self._data)


@dataclass(frozen=True, kw_only=True)
class Scenario:
    """A parsed scenario: train, track, model and controller settings, all SI.

    Parameters
    ----------
    name : str
        Display name (any text); see :attr:`slug` for a file-name-safe form.
    description : str
        One-line description shown by ``trainctl list``.
    seed : int
        Random seed [-], >= 0.
    train : Train
        The train, head vehicle first.
    track : Track or None
        Track grade and curvature; ``None`` for flat, straight track.
    model : ModelSettings
        Linearisation and sampling settings.
    controller : ControllerSettings or None
        The (D)MPC design; ``None`` when the file has no ``[controller]``.
    simulation : SimulationSettings or None
        The closed-loop simulation run; ``None`` when the file has no
        ``[simulation]``. Needs a ``controller``, and its duration must be a
        whole multiple of ``model.sample_time``.
    expected : Mapping of str to str
        Declared outcome of the design checks, check name (one of
        :data:`CHECK_NAMES`) to status (one of :data:`CHECK_STATUSES`), in
        file order; read-only, empty when the file has no ``[expected]``.
    source : str
        Where the scenario came from: the file path as given, ``"builtin:NAME"``
        or ``"<string>"``.

    Examples
    --------
    >>> scenario = load_scenario("crh2-dmpc")
    >>> scenario.slug
    'crh2-half-train-n-dmpc-as-printed-li-zheng-ch-12'
    >>> scenario.simulation.n_steps(scenario.model.sample_time)
    60
    """

    name: str
    description: str
    seed: int = 0
    train: Train
    track: Track | None = None
    model: ModelSettings
    controller: ControllerSettings | None = None
    simulation: SimulationSettings | None = None
    expected: Mapping[str, str] = field(default_factory=_FrozenMapping)
    source: str = "<string>"

    def __post_init__(self) -> None:
        expected = _FrozenMapping(self.expected)
        for check, status in expected.items():
            if check not in CHECK_NAMES:
                raise ModelError(
                    f"Scenario: 'expected' names an unknown check {check!r}."
                    f"{_suggest(check, CHECK_NAMES)} Checks: {', '.join(CHECK_NAMES)}."
                )
            if status not in CHECK_STATUSES:
                raise ModelError(
                    f"Scenario: 'expected'[{check!r}] must be one of {CHECK_STATUSES} "
                    f"(got {status!r})."
                )
            if self.controller is None and check in _CONTROLLER_CHECKS:
                raise ModelError(f"Scenario: 'expected'[{check!r}] needs a controller (got none).")
        object.__setattr__(self, "expected", expected)
        if self.controller is not None:
            self.controller.neighbourhoods(self.train.n_vehicles)
            self.controller.cooperative_weight_vector(self.train.n_vehicles)
        if self.simulation is not None:
            if self.controller is None:
                raise ModelError("Scenario: 'simulation' needs a controller (got none).")
            self.simulation.n_steps(self.model.sample_time)

    @property
    def slug(self) -> str:
        """File-name-safe form of :attr:`name` (see :func:`slugify`)."""
        return slugify(self.name)


@dataclass(frozen=True, kw_only=True)
class BuiltinScenario:
    """A scenario file shipped with trainctl.

    Parameters
    ----------
    name : str
        Built-in name (the file stem), e.g. ``"crh2-dmpc"``.
    description : str
        The file's one-line ``description``.
    path : pathlib.Path
        Location of the file.

    Examples
    --------
    >>> builtin_scenarios()[0].name
    'crh2-dmpc'
    """

    name: str
    description: str
    path: Path


# --------------------------------------------------------------------------- public API


def slugify(text: str) -> str:
    """Turn any text into a short, safe identifier ``[a-z0-9-]``.

    Accents are stripped, everything else that is not a letter or digit
    becomes one ``-``; the result is at most 60 characters (cut at a word
    boundary where possible) and never empty (``"scenario"`` is the fallback).

    Parameters
    ----------
    text : str
        Any text, e.g. a scenario's display name.

    Returns
    -------
    str
        The slug.

    Examples
    --------
    >>> slugify("CRH2 half train — N-DMPC (Li & Zheng)")
    'crh2-half-train-n-dmpc-li-zheng'
    >>> slugify("<script>alert(1)</script>")
    'script-alert-1-script'
    >>> slugify("  ")
    'scenario'
    """
    ascii_text = unicodedata.normalize("NFKD", str(text)).encode("ascii", "ignore").decode()
    slug = re.sub(r"[^a-z0-9]+", "-", ascii_text.lower()).strip("-")
    if len(slug) > _SLUG_MAX:
        cut = slug[: _SLUG_MAX + 1].rfind("-")
        slug = slug[: cut if cut >= _SLUG_MAX // 2 else _SLUG_MAX].rstrip("-")
    return slug or "scenario"


def builtin_scenarios() -> list[BuiltinScenario]:
    """List the built-in scenarios, sorted by name.

    Returns
    -------
    list of BuiltinScenario
        One entry per shipped ``*.toml`` file.

    Examples
    --------
    >>> [b.name for b in builtin_scenarios()][:2]
    ['crh2-dmpc', 'crh2-dmpc-well-sampled']
    """
    found = []
    for path in _builtin_paths():
        label = f"builtin:{path.stem}"
        data = _load_toml(_decode(path.read_bytes(), label), label)
        description = data.get("description", "")
        found.append(
            BuiltinScenario(
                name=path.stem,
                description=description if isinstance(description, str) else "",
                path=path,
            )
        )
    return found


def builtin_scenario_text(name: str) -> str:
    """Return the TOML text of a built-in scenario.

    Parameters
    ----------
    name : str
        Built-in name, e.g. ``"crh2-dmpc"``.

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    ScenarioError
        If there is no built-in of that name (the message lists them).

    Examples
    --------
    >>> builtin_scenario_text("crh2-dmpc").startswith("#")
    True
    """
    paths = {path.stem: path for path in _builtin_paths()}
    if name not in paths:
        hint = _suggest(name, paths)
        raise ScenarioError(
            f"builtin:{name}: no built-in scenario named {name!r}.{hint} Available: "
            f"{', '.join(sorted(paths)) or '(none)'}. To read a file, give a path "
            f"such as ./{name}.toml."
        )
    return _decode(paths[name].read_bytes(), f"builtin:{name}")


def load_scenario(source: str | os.PathLike[str]) -> Scenario:
    """Load a scenario from a built-in name or a file.

    Parameters
    ----------
    source : str or os.PathLike
        A bare name (no path separator, no ``.toml`` suffix) selects a
        built-in scenario; anything else is read as a UTF-8 TOML file.

    Returns
    -------
    Scenario
        The parsed scenario; its ``source`` is the path as given or
        ``"builtin:NAME"``.

    Raises
    ------
    ScenarioError
        If the file is missing, unreadable, not UTF-8, not TOML or does not
        follow the schema.

    Examples
    --------
    >>> scenario = load_scenario("crh2-dmpc")
    >>> scenario.source, scenario.train.mass.tolist()
    ('builtin:crh2-dmpc', [42800.0, 48000.0, 46500.0, 42000.0])
    >>> round(scenario.model.speed, 3), scenario.model.sample_time
    (83.333, 20.0)
    """
    text, label = read_scenario_text(source)
    return parse_scenario(text, source=label)


def read_scenario_text(source: str | os.PathLike[str]) -> tuple[str, str]:
    """The TOML text of a built-in name or a file, and its source label.

    Parameters
    ----------
    source : str or os.PathLike
        As for :func:`load_scenario`.

    Returns
    -------
    text : str
        The file's text (a report echoes it; ``parse_scenario(text,
        source=label)`` gives the scenario).
    label : str
        ``"builtin:NAME"`` or the path as given.

    Raises
    ------
    ScenarioError
        If the file is missing, unreadable or not UTF-8.

    Examples
    --------
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> label, parse_scenario(text, source=label).source
    ('builtin:crh2-dmpc', 'builtin:crh2-dmpc')
    """
    if isinstance(source, str) and _is_bare_name(source):
        return builtin_scenario_text(source), f"builtin:{source}"
    label = os.fspath(source)
    try:
        raw = Path(label).read_bytes()
    except FileNotFoundError:
        raise ScenarioError(
            f"{label}: file not found. Give an existing path, or a built-in name "
            f"({', '.join(_builtin_names())})."
        ) from None
    except IsADirectoryError:
        raise ScenarioError(
            f"{label}: is a directory, not a scenario file. Give a TOML file or a built-in "
            f"name ({', '.join(_builtin_names())})."
        ) from None
    except OSError as exc:
        raise ScenarioError(f"{label}: cannot read the file ({exc.strerror or exc}).") from None
    return _decode(raw, label), label


def parse_scenario(text: str, *, source: str = "<string>") -> Scenario:
    """Parse scenario TOML text.

    Parameters
    ----------
    text : str
        The TOML document.
    source : str
        Label used in error messages and stored as ``Scenario.source``.

    Returns
    -------
    Scenario
        The scenario, SI inside.

    Raises
    ------
    ScenarioError
        If the text is not TOML or does not follow the schema.

    Examples
    --------
    >>> text = '''
    ... schema_version = 1
    ... name = "Two coaches"
    ... description = "Smallest coupled train"
    ... [train]
    ... vehicle = [{mass_t = 40.0, count = 2, davis_si = [0.01, 0.0, 1e-5]}]
    ... coupler = {stiffness_kn_per_m = 10000.0}
    ... [model]
    ... speed_kmh = 90.0
    ... sample_time = 0.5
    ... '''
    >>> scenario = parse_scenario(text)
    >>> scenario.train.stiffness.tolist(), scenario.model.speed
    ([10000000.0], 25.0)
    >>> scenario.controller is None, dict(scenario.expected)
    (True, {})

    A controller design and the expected outcome of its checks:

    >>> text += '''
    ... [controller]
    ... form = "du"
    ... prediction_horizon = 4
    ... control_horizon = 2
    ... r_per_n2 = 1e-5
    ... [expected]
    ... ndmpc_convergence = "pass"
    ... '''
    >>> scenario = parse_scenario(text)
    >>> scenario.controller.input_weight_per_kn2(), scenario.controller.neighbourhoods(2)
    (10.0, ((0, 1), (0, 1)))
    >>> scenario.expected["ndmpc_convergence"]
    'pass'
    """
    if not isinstance(text, str):
        raise TypeError(f"parse_scenario: 'text' must be a str (got {type(text).__name__}).")
    top = _Table(source, _load_toml(text, source), _TOP_KEYS, dotted="", reserved=True)
    version = top.integer("schema_version", minimum=1)
    if version != SCHEMA_VERSION:
        top.fail(
            f"schema_version must be {SCHEMA_VERSION} (got {version}). This trainctl "
            f"release reads schema version {SCHEMA_VERSION} only."
        )
    name = top.string("name", nonblank=True)
    description = top.string("description", single_line=True)
    seed = top.integer("seed", minimum=0, default=0)
    train = _parse_train(top.section("train", _TRAIN_KEYS))
    track_table = top.optional_section("track", _TRACK_KEYS)
    track = None if track_table is None else _parse_track(track_table)
    model = _parse_model(top.section("model", _MODEL_KEYS))
    # Checks that depend on the number of coaches run here, after the train is built.
    controller_table = top.optional_section("controller", _CONTROLLER_KEYS)
    controller = (
        None if controller_table is None else _parse_controller(controller_table, train.n_vehicles)
    )
    simulation_table = top.optional_section("simulation", _SIMULATION_KEYS)
    simulation = (
        None
        if simulation_table is None
        else _parse_simulation(simulation_table, model.sample_time, controller is not None)
    )
    expected_table = top.optional_section("expected", CHECK_NAMES)
    expected = (
        _FrozenMapping() if expected_table is None else _parse_expected(expected_table, controller)
    )
    return Scenario(
        name=name,
        description=description,
        seed=seed,
        train=train,
        track=track,
        model=model,
        controller=controller,
        simulation=simulation,
        expected=expected,
        source=source,
    )


# --------------------------------------------------------------------------- sections


def _formation_name(vehicles: list[Vehicle]) -> str:
    """The formation: 'T-M-M-T', 'unit train ×4', run-length coded when long."""
    names = [v.name for v in vehicles]
    if len(set(names)) > 1 and len(names) <= 12:
        return "-".join(names)
    runs: list[tuple[str, int]] = []
    for v in vehicles:
        if runs and runs[-1][0] == v.name:
            runs[-1] = (v.name, runs[-1][1] + 1)
        else:
            runs.append((v.name, 1))
    return "-".join(name if count == 1 else f"{name} ×{count}" for name, count in runs)


def _parse_train(table: _Table) -> Train:
    if table.has("preset"):
        for key in ("vehicle", "coupler"):
            if table.has(key):
                table.fail(
                    f"{table.key('preset')} cannot be combined with {table.child_path(key)[0]}: "
                    f"give either a preset or explicit vehicles."
                )
        return _parse_preset(table)
    if table.has("preset_options"):
        where = table.child_path("preset_options")[0]
        table.fail(f"{where} needs {table.key('preset')} (got no preset).")
    if not table.has("vehicle"):
        table.fail(
            f"missing required key {table.key('preset')} or {table.child_path('vehicle')[0]}: the "
            f"train needs a preset name or at least one [[train.vehicle]] group."
        )
    vehicles = _parse_vehicles(table.sections("vehicle", _VEHICLE_KEYS))
    couplers = _parse_couplers(table, vehicles)
    return _build(
        table.file,
        table.path,
        lambda: Train(vehicles=tuple(vehicles), couplers=tuple(couplers),
                      name=_formation_name(vehicles)),
    )


def _parse_preset(table: _Table) -> Train:
    preset = table.string("preset")
    try:
        from .models.presets import PRESETS
    except ImportError as exc:
        table.fail(f"{table.key('preset')}: presets are not available ({exc}).")
    if preset not in PRESETS:
        table.fail(
            f"{table.key('preset')} must name a preset (got {preset!r}).{_suggest(preset, PRESETS)}"
            f" Available: {', '.join(sorted(PRESETS))}."
        )
    factory = PRESETS[preset]
    options = _preset_options(table, factory, preset)
    where = table.child_path("preset_options")[0] if options else table.key("preset")
    # A preset may also reject an option's value or type with ValueError / TypeError.
    train = _build(table.file, where, lambda: factory(**options), (ValueError, TypeError))
    if not isinstance(train, Train):
        table.fail(f"{table.key('preset')}: preset {preset!r} did not return a Train.")
    return train


def _preset_options(table: _Table, factory: Callable[..., Train], preset: str) -> dict[str, Any]:
    params = inspect.signature(factory).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        allowed = None
    else:
        keyword = (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)
        allowed = tuple(n for n, p in params.items() if p.kind in keyword)
    section = table.optional_section("preset_options", allowed)
    options = {} if section is None else dict(section.data)
    for name, param in params.items():
        if param.kind is inspect.Parameter.KEYWORD_ONLY and param.default is param.empty:
            if name not in options:
                table.fail(
                    f"missing required key {table.child_path('preset_options')[0]}.{name} "
                    f"(preset {preset!r} needs it)."
                )
    return options


def _parse_vehicles(groups: list[_Table]) -> list[Vehicle]:
    vehicles: list[Vehicle] = []
    for group in groups:
        count = group.integer("count", minimum=1, default=1)
        if len(vehicles) + count > _MAX_VEHICLES:
            group.fail(
                f"{group.key('count')} makes the train longer than {_MAX_VEHICLES} vehicles "
                f"(got {count} after {len(vehicles)})."
            )
        vehicles.extend([_parse_vehicle(group)] * count)
    return vehicles


def _parse_vehicle(group: _Table) -> Vehicle:
    a0, a1, a2 = _parse_davis(group)
    envelope = TractionEnvelope(
        max_traction=kn_to_n(group.number("max_traction_kn", "nonneg", math.inf)),
        max_power=kw_to_w(group.number("max_power_kw", "pos", math.inf)),
        max_braking=kn_to_n(group.number("max_braking_kn", "nonneg", math.inf)),
        max_braking_power=kw_to_w(group.number("max_braking_power_kw", "pos", math.inf)),
        adhesion=group.number("adhesion", "pos", math.inf),
    )
    return _build(
        group.file,
        group.path,
        lambda: Vehicle(
            mass=tonnes_to_kg(group.number("mass_t", "pos")),
            a0=a0,
            a1=a1,
            a2=a2,
            name=group.string("name", default="vehicle"),
            length=group.number("length", "pos", 25.0),
            traction_share=group.number("traction_share", "nonneg", 1.0),
            envelope=envelope,
        ),
    )


def _parse_davis(group: _Table) -> tuple[float, float, float]:
    given = [key for key in _DAVIS_KEYS if group.has(key)]
    if len(given) != 1:
        what = "none" if not given else " and ".join(given)
        group.fail(
            f"{group.path} needs exactly one of {', '.join(_DAVIS_KEYS)} (got {what}). "
            f"davis_n_per_kn_kmh is N/kN with V in km/h; davis_si is [a0 m/s², a1 1/s, a2 1/m]."
        )
    c0, c1, c2 = group.numbers(given[0], length=3, bound="nonneg")
    return _DAVIS_CONVERTERS[given[0]](c0, c1, c2)


def _parse_couplers(table: _Table, vehicles: Sequence[Vehicle]) -> list[Coupler]:
    n_links = len(vehicles) - 1
    raw = table.data.get("coupler", _MISSING)
    if raw is _MISSING:
        if n_links == 0:
            return []
        table.fail(
            f"missing required key [train.coupler]: a train of {len(vehicles)} vehicles "
            f"needs a [train.coupler] table or {n_links} [[train.coupler]] entries."
        )
    if isinstance(raw, dict):
        links = [table.section("coupler", _COUPLER_KEYS)] * n_links
    else:
        links = table.sections("coupler", _COUPLER_KEYS, allow_empty=True)
        if len(links) != n_links:
            table.fail(
                f"[[train.coupler]] must have exactly {n_links} entries, one per link "
                f"between {len(vehicles)} vehicles (got {len(links)}). Use a single "
                f"[train.coupler] table to apply one coupler to every link."
            )
    return [
        _parse_coupler(link, vehicles[i].length, vehicles[i + 1].length)
        for i, link in enumerate(links)
    ]


def _parse_coupler(link: _Table, front_length: float, rear_length: float) -> Coupler:
    virtual = link.boolean("virtual", default=False)
    if virtual:
        stiffness = link.number("stiffness_kn_per_m", "nonneg", 0.0)
    else:
        stiffness = link.number("stiffness_kn_per_m", "pos")
    spacing = (front_length + rear_length) / 2.0 + link.number("gap", "nonneg", 0.0)
    return _build(
        link.file,
        link.path,
        lambda: Coupler(
            stiffness=kn_per_m_to_n_per_m(stiffness),
            damping=kn_s_per_m_to_n_s_per_m(link.number("damping_kn_s_per_m", "nonneg", 0.0)),
            spacing=spacing,
            virtual=virtual,
        ),
    )


def _parse_track(table: _Table) -> Track:
    formula = table.choice("formula", RESISTANCE_FORMULAS, default="tbt")
    wheelbase = table.number("wheelbase", "pos", 1.83)
    sections: list[TrackSection] = []
    for item in table.sections("section", _SECTION_KEYS):
        sections.append(_parse_section(item, sections[-1].start if sections else None))
    return _build(
        table.file,
        table.path,
        lambda: Track(sections=tuple(sections), formula=formula, wheelbase=wheelbase),
    )


def _parse_section(item: _Table, previous_start: float | None) -> TrackSection:
    start = item.number("start")
    if previous_start is not None and start <= previous_start:
        item.fail(
            f"{item.key('start')} must be greater than the previous section's start "
            f"{previous_start!r} (got {start!r}). List sections in track order."
        )
    return _build(
        item.file,
        item.path,
        lambda: TrackSection(
            start=start,
            grade_permille=item.number("grade_permille", None, 0.0),
            curve_radius=item.number("curve_radius", "pos", math.inf, _STRAIGHT),
        ),
    )


def _parse_model(table: _Table) -> ModelSettings:
    return _build(
        table.file,
        table.path,
        lambda: ModelSettings(
            speed=kmh_to_ms(table.number("speed_kmh", "pos")),
            linearisation=table.choice("linearisation", LINEARISATIONS, default="jacobian"),
            dummy_state=table.boolean("dummy_state", default=True),
            allocation=table.choice("allocation", ALLOCATIONS, default="shares"),
            sample_time=table.number("sample_time", "pos"),
            discretisation=table.choice("discretisation", DISCRETISATIONS, default="zoh"),
        ),
    )


def _parse_controller(table: _Table, n: int) -> ControllerSettings:
    form = table.choice("form", CONTROLLER_FORMS)
    horizon = table.integer("prediction_horizon", minimum=1)
    moves = table.integer("control_horizon", minimum=1)
    if moves > horizon:
        table.fail(
            f"{table.key('control_horizon')} must be an integer from 1 to "
            f"{table.key('prediction_horizon')} = {horizon} (got {moves}). The control horizon "
            f"M counts the free moves inside the prediction horizon P."
        )
    outputs = _parse_outputs(table, n)
    q_velocity = table.number("q_velocity", "nonneg", 1.0)
    q_force = table.number("q_force_per_kn2", "nonneg", 0.0)
    if q_force > 0 and "force" not in outputs:
        table.fail(
            f"{table.key('q_force_per_kn2')} must be 0 when {table.key('outputs')} has no "
            f"'force' (got {q_force!r} with outputs {list(outputs)}). Add \"force\" to outputs "
            f"to weight the coupler forces, or omit q_force_per_kn2."
        )
    weight_key = _input_weight_key(table)
    input_weight = table.number(weight_key, "pos")
    neighbourhood = _parse_neighbourhood(table, n)
    iterations = table.integer("iterations", minimum=1, default=10)
    cooperative_weights = _parse_cooperative_weights(table, n)
    max_iterations = table.integer("max_iterations", minimum=1, default=50)
    tolerance = table.number("iteration_tolerance_kn", "pos", 1e-4)
    relaxation = table.number("relaxation", "pos", 1.0)
    if relaxation > 1.0:
        table.fail(
            f"{table.key('relaxation')} must be a number in (0, 1] (got {relaxation!r}). "
            f"The N-DMPC relaxation factor omega blends each new plan with the previous one; "
            f"1 is the plain Jacobi iteration."
        )
    input_bounds = table.boolean("input_bounds", default=True)
    rate_limit = kn_to_n(table.number("rate_limit_kn", "pos", math.inf))
    force_limit = kn_to_n(table.number("coupler_force_limit_kn", "pos", math.inf))
    soft_linear = table.number("soft_penalty_linear", "nonneg", 1000.0)
    soft_quadratic = table.number("soft_penalty_quadratic", "pos", 100.0)
    solver_path = table.choice("solver_path", SOLVER_PATHS, default="fast")
    observer = table.choice("observer", OBSERVERS, default="none")
    force_steps = _parse_force_steps(table, horizon)
    disturbance_noise = table.number("observer_disturbance_noise", "pos", 1e-3)
    return _build(
        table.file,
        table.path,
        lambda: ControllerSettings(
            form=form,
            prediction_horizon=horizon,
            control_horizon=moves,
            outputs=outputs,
            q_velocity=q_velocity,
            q_force=q_force,
            input_weight=input_weight,
            input_weight_unit=_INPUT_WEIGHT_KEYS[weight_key],
            neighbourhood=neighbourhood,
            iterations=iterations,
            cooperative_weights=cooperative_weights,
            max_iterations=max_iterations,
            iteration_tolerance=tolerance,
            relaxation=relaxation,
            input_bounds=input_bounds,
            rate_limit=rate_limit,
            coupler_force_limit=force_limit,
            soft_penalty_linear=soft_linear,
            soft_penalty_quadratic=soft_quadratic,
            solver_path=solver_path,
            observer=observer,
            observer_disturbance_noise=disturbance_noise,
            coupler_force_steps=force_steps,
        ),
    )


def _parse_force_steps(table: _Table, horizon: int) -> tuple[int, ...] | None:
    if not table.has("coupler_force_steps"):
        return None
    where = table.key("coupler_force_steps")
    value = table.data["coupler_force_steps"]
    want = f"a non-empty array of increasing integers from 1 to prediction_horizon = {horizon}"
    if not isinstance(value, list) or not value:
        table.fail(f"{where} must be {want} (got {_got(value)}).")
    for i, item in enumerate(value):
        bad = isinstance(item, bool) or not isinstance(item, int) or not 1 <= item <= horizon
        if bad or (i and item <= value[i - 1]):
            table.fail(f"{where}[{i}] must be {want} (got {_got(item)}). Omit the key to bound "
                       "the coupler forces at every prediction step.")
    return tuple(value)


def _parse_outputs(table: _Table, n: int) -> tuple[str, ...]:
    where = table.key("outputs")
    options = ", ".join(repr(o) for o in CONTROLLER_OUTPUTS)
    value = table.data.get("outputs", ["v"])
    if not isinstance(value, list) or not value:
        table.fail(
            f"{where} must be a non-empty array of distinct names from {options} "
            f"(got {_got(value)})."
        )
    for i, item in enumerate(value):
        if not isinstance(item, str) or item not in CONTROLLER_OUTPUTS:
            hint = _suggest(item, CONTROLLER_OUTPUTS) if isinstance(item, str) else ""
            table.fail(
                f"{where}[{i}] must be one of {options} (got {_got(item)}).{hint} 'v' selects "
                f"the velocities [m/s], 'force' the coupler forces [kN]."
            )
        if item in value[:i]:
            table.fail(
                f"{where}[{i}] must not repeat an earlier output (got {item!r} again). List "
                f"each output once."
            )
        if item == "force" and n < 2:
            table.fail(
                f"{where}[{i}] must be 'v' for a train of one vehicle, which has no couplers "
                f"(got 'force'). Remove 'force', or give the train at least two vehicles."
            )
    return tuple(value)


def _input_weight_key(table: _Table) -> str:
    given = [key for key in _INPUT_WEIGHT_KEYS if table.has(key)]
    if len(given) != 1:
        what = "none" if not given else " and ".join(given)
        table.fail(
            f"{table.path} needs exactly one of {', '.join(_INPUT_WEIGHT_KEYS)} (got {what}). "
            f"The input weight R is per kN² (r_per_kn2) or per N² (r_per_n2); "
            f"r_per_kn2 = r_per_n2 × 1e6."
        )
    return given[0]


def _parse_neighbourhood(table: _Table, n: int) -> str | tuple[tuple[int, ...], ...]:
    where = table.key("neighbourhood")
    value = table.data.get("neighbourhood", "adjacent")
    want = (
        f"one of {', '.join(repr(k) for k in NEIGHBOURHOODS)} or an array of {n} arrays of "
        f"coach indices, one per coach"
    )
    if isinstance(value, str):
        if value not in NEIGHBOURHOODS:
            table.fail(
                f"{where} must be {want} (got {_got(value)}).{_suggest(value, NEIGHBOURHOODS)}"
            )
        return value
    if not isinstance(value, list) or len(value) != n:
        table.fail(
            f"{where} must be {want} (got {_got(value)}). Entry i lists the coaches whose "
            f"outputs coach i weighs; the train has {n} coaches."
        )
    members_list: list[tuple[int, ...]] = []
    for i, members in enumerate(value):
        here = f"{where}[{i}]"
        if not isinstance(members, list):
            table.fail(f"{here} must be an array of coach indices (got {_got(members)}).")
        for k, j in enumerate(members):
            if isinstance(j, bool) or not isinstance(j, int) or not 0 <= j < n:
                table.fail(
                    f"{here}[{k}] must be a coach index from 0 to {n - 1} (got {_got(j)}). "
                    f"Indices count from 0, head coach first."
                )
        if len(set(members)) != len(members):
            table.fail(f"{here} must list distinct coach indices (got {members}).")
        if i not in members:
            table.fail(
                f"{here} must contain its own coach index {i} (got {members}). Every coach "
                f"weighs its own outputs."
            )
        members_list.append(tuple(members))
    return tuple(members_list)


def _parse_cooperative_weights(table: _Table, n: int) -> str | tuple[float, ...]:
    where = table.key("cooperative_weights")
    value = table.data.get("cooperative_weights", "uniform")
    if value == "uniform":
        return "uniform"
    if not isinstance(value, list) or len(value) != n:
        hint = _suggest(value, ("uniform",)) if isinstance(value, str) else ""
        table.fail(
            f"{where} must be 'uniform' or an array of {n} numbers > 0 summing to 1, one per "
            f"coach (got {_got(value)}).{hint}"
        )
    weights = tuple(
        _check_number(table.file, f"{where}[{i}]", w, "pos", "") for i, w in enumerate(value)
    )
    total = math.fsum(weights)
    if abs(total - 1.0) > _WEIGHT_SUM_TOL:
        table.fail(
            f"{where} must sum to 1 within 1e-9 (got sum {total!r}). Divide "
            f"each weight by the sum, or use 'uniform'."
        )
    return weights


def _parse_simulation(
    table: _Table, sample_time: float, has_controller: bool
) -> SimulationSettings:
    if not has_controller:
        table.fail(
            f"{table.path} needs a [controller] section (got none): the simulation runs the "
            f"MPC design given in [controller]. Add [controller] or remove [simulation]."
        )
    duration = table.number("duration", "pos")
    if _whole_steps(duration, sample_time) is None:
        steps = duration / sample_time
        below = max(math.floor(steps), 1) * sample_time
        above = max(math.ceil(steps), 1) * sample_time
        options = f"{below!r}" if below == above else f"{below!r} or {above!r}"
        table.fail(
            f"{table.key('duration')} must be a whole multiple of [model].sample_time = "
            f"{sample_time!r} s (got {duration!r} s, {steps:.6g} samples). Use e.g. {options}."
        )
    strategies = _parse_strategies(table)
    initial_speed_error = table.number("initial_speed_error", None, 0.0)
    measurement_noise = table.number("measurement_noise", "nonneg", 0.0)
    settle_time = table.number("settle_time", "nonneg", 0.0)
    if settle_time >= duration:
        table.fail(
            f"{table.key('settle_time')} must be less than {table.key('duration')} = "
            f"{duration!r} s (got {settle_time!r}). Tracking is judged after settle_time."
        )
    tracking_tolerance = table.number("tracking_tolerance", "pos", 1.0)
    regen_efficiency = table.number("regen_efficiency", "nonneg", 1.0)
    if regen_efficiency > 1.0:
        table.fail(
            f"{table.key('regen_efficiency')} must be a number from 0 to 1 (got "
            f"{regen_efficiency!r}). It is the share of the braking energy credited back."
        )
    times, speeds = _parse_reference(table.section("reference", _REFERENCE_KEYS))
    if speeds[0] + initial_speed_error < 0:
        table.fail(
            f"{table.key('initial_speed_error')} must be >= {-speeds[0]!r} m/s, minus the "
            f"reference speed at t = 0, so that no vehicle starts backwards (got "
            f"{initial_speed_error!r})."
        )
    return _build(
        table.file,
        table.path,
        lambda: SimulationSettings(
            duration=duration,
            strategies=strategies,
            reference_times=times,
            reference_speeds=speeds,
            initial_speed_error=initial_speed_error,
            measurement_noise=measurement_noise,
            settle_time=settle_time,
            tracking_tolerance=tracking_tolerance,
            regen_efficiency=regen_efficiency,
        ),
    )


def _parse_strategies(table: _Table) -> tuple[str, ...]:
    where = table.key("strategies")
    options = ", ".join(repr(s) for s in SIMULATION_STRATEGIES)
    value = table._get("strategies", _MISSING, f"an array of names from {options}")
    if not isinstance(value, list) or not value:
        table.fail(
            f"{where} must be a non-empty array of distinct names from {options} "
            f"(got {_got(value)})."
        )
    for i, item in enumerate(value):
        if not isinstance(item, str) or item not in SIMULATION_STRATEGIES:
            hint = _suggest(item, SIMULATION_STRATEGIES) if isinstance(item, str) else ""
            table.fail(f"{where}[{i}] must be one of {options} (got {_got(item)}).{hint}")
        if item in value[:i]:
            table.fail(
                f"{where}[{i}] must not repeat an earlier strategy (got {item!r} again). List "
                f"each strategy once."
            )
    return tuple(value)


def _parse_reference(table: _Table) -> tuple[tuple[float, ...], tuple[float, ...]]:
    given = [key for key in _REFERENCE_SPEED_KEYS if table.has(key)]
    if len(given) != 1:
        what = "none" if not given else " and ".join(given)
        table.fail(
            f"{table.path} needs exactly one of {', '.join(_REFERENCE_SPEED_KEYS)} (got "
            f"{what}). speeds_kmh is in km/h, speeds in m/s."
        )
    key = given[0]
    times = table.number_array("times", bound="nonneg")
    speeds = table.number_array(key, bound="nonneg")
    if len(times) != len(speeds):
        table.fail(
            f"{table.path}: times and {key} must have the same length (got {len(times)} and "
            f"{len(speeds)}). Give one speed per time."
        )
    if times[0] != 0.0:
        table.fail(
            f"{table.key('times')}[0] must be 0 (got {times[0]!r}). The reference starts at t = 0."
        )
    for i in range(1, len(times)):
        if times[i] <= times[i - 1]:
            table.fail(
                f"{table.key('times')}[{i}] must be greater than the previous time "
                f"{times[i - 1]!r} (got {times[i]!r}). List the times in increasing order."
            )
    if key == "speeds_kmh":
        speeds = [kmh_to_ms(v) for v in speeds]
    return tuple(times), tuple(speeds)


def _parse_expected(table: _Table, controller: ControllerSettings | None) -> _FrozenMapping:
    # Unknown check names were rejected (with a suggestion) when the table was opened.
    statuses = []
    for check in table.data:
        status = table.choice(check, CHECK_STATUSES)
        if controller is None and check in _CONTROLLER_CHECKS:
            table.fail(
                f"{table.key(check)} needs a [controller] section (got none): the check "
                f"{check!r} runs only for a controller design. Add [controller] or remove "
                f"the expectation."
            )
        statuses.append((check, status))
    return _FrozenMapping(statuses)


# --------------------------------------------------------------------------- table reader


class _Table:
    """Typed, key-path-aware access to one TOML table.

    ``path`` is the display key path (``"[model]"``, ``"[train.vehicle][2]"``,
    ``""`` for the document); ``dotted`` is the TOML table name used to form
    child section names, or None inside an array element.
    """

    def __init__(
        self,
        file: str,
        data: dict[str, Any],
        allowed: Iterable[str] | None,
        *,
        path: str = "",
        dotted: str | None = None,
        reserved: bool = False,
    ) -> None:
        self.file = file
        self.data = data
        self.path = path
        self.dotted = dotted
        if allowed is not None:
            self._check_keys(tuple(allowed), reserved)

    def _check_keys(self, allowed: tuple[str, ...], reserved: bool) -> None:
        known = allowed + (RESERVED_SECTIONS if reserved else ())
        for key, value in self.data.items():
            if key in allowed:
                continue
            if reserved and key in RESERVED_SECTIONS:
                self.fail(
                    f"section [{key}] is reserved for a later trainctl release and is not "
                    f"supported yet. Remove it to load this scenario."
                )
            where = self.child_path(key)[0] if isinstance(value, dict) else self.key(key)
            kind = "section" if isinstance(value, dict) else "key"
            hint = _suggest(key, known) or (
                f" Allowed here: {', '.join(allowed)}." if allowed else " No keys are allowed here."
            )
            self.fail(f"unknown {kind} {where}.{hint}")

    def fail(self, message: str) -> NoReturn:
        """Raise ScenarioError with the file name in front of ``message``."""
        raise ScenarioError(f"{self.file}: {message}")

    def key(self, name: str) -> str:
        """Display key path of ``name`` in this table."""
        return f"{self.path}.{name}" if self.path else name

    def child_path(self, name: str) -> tuple[str, str | None]:
        """Display path and dotted name of the sub-table ``name``."""
        if self.dotted is None:
            return self.key(name), None
        dotted = f"{self.dotted}.{name}" if self.dotted else name
        return f"[{dotted}]", dotted

    def has(self, name: str) -> bool:
        """True if the key is present."""
        return name in self.data

    def _get(self, name: str, default: Any, want: str) -> Any:
        value = self.data.get(name, _MISSING)
        if value is _MISSING and default is _MISSING:
            self.fail(f"missing required key {self.key(name)} ({want}).")
        return value

    def number(
        self, name: str, bound: str | None = None, default: Any = _MISSING, hint: str = ""
    ) -> float:
        """A finite float; ``bound`` is None, ``"pos"`` (> 0) or ``"nonneg"`` (>= 0)."""
        value = self._get(name, default, "a number" + _BOUNDS[bound])
        if value is _MISSING:
            return float(default)
        if not hint and default is not _MISSING and math.isinf(default):
            hint = _NO_LIMIT
        return _check_number(self.file, self.key(name), value, bound, hint)

    def numbers(self, name: str, *, length: int, bound: str | None) -> list[float]:
        """A list of exactly ``length`` finite floats."""
        want = f"an array of {length} numbers{_BOUNDS[bound]}"
        value = self._get(name, _MISSING, want)
        if not isinstance(value, list) or len(value) != length:
            self.fail(f"{self.key(name)} must be {want} (got {_got(value)}).")
        return [
            _check_number(self.file, f"{self.key(name)}[{i}]", item, bound, "")
            for i, item in enumerate(value)
        ]

    def number_array(self, name: str, *, bound: str | None) -> list[float]:
        """A non-empty list of finite floats, of any length."""
        want = f"a non-empty array of numbers{_BOUNDS[bound]}"
        value = self._get(name, _MISSING, want)
        if not isinstance(value, list) or not value:
            self.fail(f"{self.key(name)} must be {want} (got {_got(value)}).")
        return [
            _check_number(self.file, f"{self.key(name)}[{i}]", item, bound, "")
            for i, item in enumerate(value)
        ]

    def integer(self, name: str, *, minimum: int, default: Any = _MISSING) -> int:
        """An int (not a bool or float) >= ``minimum``."""
        want = f"an integer >= {minimum}"
        value = self._get(name, default, want)
        if value is _MISSING:
            return int(default)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            self.fail(f"{self.key(name)} must be {want} (got {_got(value)}).")
        return value

    def string(
        self,
        name: str,
        *,
        default: Any = _MISSING,
        nonblank: bool = False,
        single_line: bool = False,
    ) -> str:
        """A str, optionally non-blank and without line breaks."""
        value = self._get(name, default, "a string")
        if value is _MISSING:
            return str(default)
        if not isinstance(value, str):
            self.fail(f"{self.key(name)} must be a string (got {_got(value)}).")
        if nonblank and not value.strip():
            self.fail(f"{self.key(name)} must be a non-empty string (got {value!r}).")
        if single_line and ("\n" in value or "\r" in value):
            self.fail(f"{self.key(name)} must be a single line (got {_short(value)!r}).")
        return value

    def boolean(self, name: str, *, default: Any = _MISSING) -> bool:
        """A TOML boolean (``true`` / ``false``)."""
        value = self._get(name, default, "true or false")
        if value is _MISSING:
            return bool(default)
        if not isinstance(value, bool):
            self.fail(f"{self.key(name)} must be true or false (got {_got(value)}).")
        return value

    def choice(self, name: str, options: Sequence[str], *, default: Any = _MISSING) -> str:
        """One of ``options``."""
        want = "one of " + ", ".join(repr(o) for o in options)
        value = self._get(name, default, want)
        if value is _MISSING:
            return str(default)
        if not isinstance(value, str) or value not in options:
            hint = _suggest(value, options) if isinstance(value, str) else ""
            self.fail(f"{self.key(name)} must be {want} (got {_got(value)}).{hint}")
        return value

    def optional_section(self, name: str, allowed: Iterable[str] | None) -> _Table | None:
        """The sub-table ``name`` (``[a.name]``), or None if absent."""
        return self.section(name, allowed) if name in self.data else None

    def section(self, name: str, allowed: Iterable[str] | None) -> _Table:
        """The required sub-table ``name`` (``[a.name]``)."""
        where, dotted = self.child_path(name)
        value = self.data.get(name, _MISSING)
        if value is _MISSING:
            self.fail(f"missing required section {where}.")
        if not isinstance(value, dict):
            self.fail(f"{where} must be a table (got {_got(value)}).")
        return _Table(self.file, value, allowed, path=where, dotted=dotted)

    def sections(
        self, name: str, allowed: Iterable[str], *, allow_empty: bool = False
    ) -> list[_Table]:
        """The array of tables ``[[a.name]]``, each element a child table."""
        where = self.child_path(name)[0]
        value = self._get(name, _MISSING, f"an array of tables [{where}]")
        if not isinstance(value, list) or not (value or allow_empty):
            self.fail(
                f"{where} must be a non-empty array of tables, written [{where}] with "
                f"double brackets (got {_got(value)})."
            )
        allowed = tuple(allowed)
        tables = []
        for i, item in enumerate(value):
            if not isinstance(item, dict):
                self.fail(f"{where}[{i}] must be a table (got {_got(item)}).")
            tables.append(_Table(self.file, item, allowed, path=f"{where}[{i}]"))
        return tables


# --------------------------------------------------------------------------- helpers


def _is_int(value: Any) -> bool:
    """True for integers (Python or NumPy), False for bools and everything else."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def _as_float(value: Any) -> float:
    """``float(value)`` for real numbers (not bools); nan for anything else."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return math.nan
    try:
        return float(value)
    except OverflowError:
        return math.inf


def _whole_steps(duration: float, sample_time: float) -> int | None:
    """``duration / sample_time`` if it is a whole number >= 1 (relative 1e-9), else None."""
    steps = round(duration / sample_time)
    if steps < 1 or abs(steps * sample_time - duration) > _MULTIPLE_TOL * duration:
        return None
    return steps


def _float_tuple(value: Any) -> tuple[float, ...]:
    """``value`` as a tuple of floats (nan for non-numbers); ``(nan,)`` if not iterable."""
    if isinstance(value, str):
        return (math.nan,)
    try:
        return tuple(_as_float(x) for x in value)
    except TypeError:
        return (math.nan,)


def _coach_count(n: Any) -> int:
    if not _is_int(n) or n < 1:
        raise ModelError(f"ControllerSettings: 'n' must be an integer >= 1 (got {n!r}).")
    return int(n)


def _freeze_neighbourhood(value: Any) -> str | tuple[tuple[int, ...], ...]:
    """Validate a neighbourhood kind or explicit list; explicit lists become tuples."""
    bad_kind = ModelError(
        f"ControllerSettings: 'neighbourhood' must be one of {NEIGHBOURHOODS} or one "
        f"sequence of coach indices per coach (got {value!r})."
    )
    if isinstance(value, str):
        if value not in NEIGHBOURHOODS:
            raise bad_kind
        return value
    try:
        frozen = tuple(tuple(members) for members in value)
    except TypeError:
        raise bad_kind from None
    for i, members in enumerate(frozen):
        if (
            not all(_is_int(j) and j >= 0 for j in members)
            or len(set(members)) != len(members)
            or i not in members
        ):
            raise ModelError(
                f"ControllerSettings: 'neighbourhood'[{i}] must hold distinct coach indices "
                f">= 0 including {i} (got {members!r})."
            )
    if not frozen:
        raise ModelError("ControllerSettings: 'neighbourhood' must not be empty.")
    return tuple(tuple(int(j) for j in members) for members in frozen)


def _freeze_weights(value: Any) -> str | tuple[float, ...]:
    """Validate cooperative weights; an explicit sequence becomes a tuple of floats."""
    if isinstance(value, str):
        if value != "uniform":
            raise ModelError(
                f"ControllerSettings: 'cooperative_weights' must be 'uniform' or a sequence "
                f"of numbers > 0 summing to 1 (got {value!r})."
            )
        return value
    try:
        weights = tuple(_as_float(w) for w in value)
    except TypeError:
        weights = (math.nan,)
    total = math.fsum(weights) if all(math.isfinite(w) for w in weights) else math.nan
    if not weights or not all(w > 0 for w in weights) or not abs(total - 1.0) <= _WEIGHT_SUM_TOL:
        raise ModelError(
            f"ControllerSettings: 'cooperative_weights' must be numbers > 0 summing to 1 "
            f"within 1e-9 (got {value!r})."
        )
    return weights


def _check_number(file: str, where: str, value: Any, bound: str | None, hint: str) -> float:
    want = "a number" + _BOUNDS[bound]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        quote = " Write numbers without quotes." if isinstance(value, str) else ""
        raise ScenarioError(f"{file}: {where} must be {want} (got {_got(value)}).{quote}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x):
        raise ScenarioError(
            f"{file}: {where} must be a finite number{_BOUNDS[bound]} (got {x!r}).{hint}"
        )
    if (bound == "pos" and x <= 0.0) or (bound == "nonneg" and x < 0.0):
        raise ScenarioError(f"{file}: {where} must be {want} (got {value!r}).")
    return x


def _build(
    file: str,
    where: str,
    make: Callable[[], _T],
    catch: tuple[type[Exception], ...] = (ModelError,),
) -> _T:
    """Call ``make``; re-raise a model-level error as ScenarioError at ``where``."""
    try:
        return make()
    except ScenarioError:
        raise
    except catch as exc:
        raise ScenarioError(f"{file}: {where}: {exc}") from exc


def _load_toml(text: str, source: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}.") from None


def _decode(raw: bytes, label: str) -> str:
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ScenarioError(
            f"{label}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at line {line}, byte "
            f"offset {exc.start}). Save the file as UTF-8."
        ) from None


def _is_bare_name(source: str) -> bool:
    seps = {"/", "\\", os.sep} | ({os.altsep} if os.altsep else set())
    return not any(sep in source for sep in seps) and not source.lower().endswith(".toml")


def _builtin_dir() -> Path:
    try:
        candidate = resources.files("trainctl") / "builtin_analyses"
        if candidate.is_dir():
            return Path(str(candidate))
    except (ImportError, OSError, TypeError, ValueError):
        pass
    return Path(__file__).resolve().parent.parent / "analyses"


def _builtin_paths() -> list[Path]:
    directory = _builtin_dir()
    if not directory.is_dir():
        return []
    return sorted((p for p in directory.glob("*.toml") if p.is_file()), key=lambda p: p.stem)


def _builtin_names() -> list[str]:
    return [path.stem for path in _builtin_paths()]


def _suggest(word: str, choices: Iterable[str]) -> str:
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f" Did you mean {close[0]!r}?" if close else ""


def _short(text: str, limit: int = 60) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _got(value: Any) -> str:
    """Describe a TOML value for a '(got ...)' clause."""
    if isinstance(value, bool):
        return f"{str(value).lower()}, a boolean"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return f"{_short(value)!r}, a string"
    if isinstance(value, list):
        return f"an array of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, (datetime.date, datetime.time)):
        return f"{value.isoformat()}, a date/time"
    return type(value).__name__
