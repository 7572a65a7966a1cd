# The conformance suite of a controller family: check_family, modelled on scikit-learn's.
"""Check that a controller family follows :class:`~trainctl.registry.ControllerFamily`.

:func:`check_family` runs a family through the rules below, each named; the
first rule broken raises :class:`FamilyCheckError` with the rule's name. It
is the test suite of every built-in family and of a user's own (the
counterpart of scikit-learn's ``check_estimator``). The rules, in order
(:data:`RULES`):

``vocabulary``
    ``name`` an identifier; ``title`` non-empty; ``strategies`` and
    ``check_names`` non-empty tuples of distinct names (letters, digits,
    ``_`` and, for strategies, ``-``), no check named like a model check or
    another family's; ``trajectory_check_names``, when given, among
    ``check_names``; ``report_partial`` a str; every protocol method there.
``settings``
    ``settings`` is a pydantic model class (a ``pydantic.BaseModel`` or a
    pydantic dataclass), the scenario's settings are an instance of it, and
    it is constructible with no argument or from the scenario's
    ``[controller]`` table.
``design``
    ``design(scenario, model, settings)`` returns a design (built once; the
    other rules reuse it).
``checks_named``
    ``checks(design)`` returns one :class:`~trainctl.analysis.check.Check`
    per name of ``check_names``, in that order, each with a known status.
``closed_loop``
    For every strategy, ``closed_loop(design, strategy)`` is None or a
    ``control.StateSpace`` whose matrices agree with its numbers of states,
    inputs (one disturbance per vehicle) and outputs, finite, discrete at
    the model's sample time or continuous; its poles agree with the growth
    rate of its free response x_k = A^k x_0 (continuous: x(t) = e^(At) x_0),
    simulated over 2^30 samples by repeated squaring (:func:`free_growth`).
``design_pickles``
    The design survives a pickle round trip (worker processes receive it so)
    and the copy gives the same closed loops.
``controllers_step``
    For every strategy, ``make(design, strategy)`` follows
    :class:`~trainctl.controllers.base.Controller` and takes a few steps on
    the linear design model, from the cruise equilibrium with a speed error:
    each returns a :class:`~trainctl.controllers.base.StepRecord` with one
    finite force per vehicle and a status that is not ``"error"``.
``report_data``
    ``report_data(design)`` is a dict with str keys that
    ``json.dumps(..., allow_nan=False)`` writes (what a saved run holds).

A built-in family is checked on the first built-in scenario with the family
alone (else the first whose primary family it is, else the first that has
it); a user's family on the scenario given. No ``[simulation]`` runs: the
steps of ``controllers_step`` are the only simulation.
"""

from __future__ import annotations

import json
import math
import os
import pickle
import re
from collections.abc import Callable, Mapping
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.exceptions import ScenarioError, TrainctlError
from trainctl.registry import ControllerFamily, family_names, get_family

if TYPE_CHECKING:
    import control as ct

    from trainctl.design import DesignModel
    from trainctl.scenario import Scenario

__all__ = ["RULES", "FamilyCheckError", "check_family", "free_growth"]

RULES = ("vocabulary", "settings", "design", "checks_named", "closed_loop", "design_pickles",
         "controllers_step", "report_data")
"""The rules of :func:`check_family`, in the order they run (module docstring)."""

Array = NDArray[np.float64]

_STRATEGY = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")
_CHECK = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_METHODS = ("design", "make", "checks", "closed_loop", "report_data", "report_figures")
_SQUARINGS = 30
"""Free responses run over 2^30 samples: log ρ to about log(κ)/2^30 (κ the eigenvector
condition number), far below the tolerance."""
_GROWTH_TOL = 1e-6
"""Largest difference between the poles' and the free response's growth per sample
(ρ for a discrete loop, α·T for a continuous one)."""
_SPEED_ERROR = 0.1
"""Initial speed error of every vehicle in ``controllers_step`` [m/s]."""


class FamilyCheckError(TrainctlError, AssertionError):
    """A controller family breaks a rule of :func:`check_family`.

    Also an ``AssertionError``, like the failures of scikit-learn's
    ``check_estimator``.

    Parameters
    ----------
    rule : str
        The rule broken, one of :data:`RULES`.
    message : str
        What was found, naming the family (and the strategy).

    Examples
    --------
    >>> err = FamilyCheckError("vocabulary", "family 'toy': 'title' is empty.")
    >>> err.rule, str(err)
    ('vocabulary', "check_family [vocabulary]: family 'toy': 'title' is empty.")
    """

    def __init__(self, rule: str, message: str) -> None:
        super().__init__(rule, message)
        self.rule = rule
        self.message = message

    def __str__(self) -> str:
        return f"check_family [{self.rule}]: {self.message}"


def check_family(
    family: ControllerFamily[Any, Any] | str,
    scenario: Scenario | str | os.PathLike[str] | None = None,
    *,
    steps: int = 3,
) -> tuple[str, ...]:
    """Check a controller family against the protocol, rule by rule (module docstring).

    One design is built, from ``scenario``, and every rule reuses it; no
    ``[simulation]`` runs. A family's own checks (``checks(design)``) run
    once, and take most of the time (seconds for the H∞ family's delay
    margin and SDP).

    Parameters
    ----------
    family : ControllerFamily or str
        The family object (registered or not), or a registered name.
    scenario : Scenario, str, os.PathLike or None
        A scenario with a ``[controller]`` of the family (loaded, or a path
        or built-in name for :func:`~trainctl.scenario.load_scenario`; a
        user's family must be registered before its file is loaded). None:
        the first built-in scenario with the family alone, else the first
        whose primary family it is, else the first that has it.
    steps : int
        Controller steps per strategy in ``controllers_step``, >= 1.

    Returns
    -------
    tuple of str
        The rules checked (:data:`RULES`), all passed.

    Raises
    ------
    FamilyCheckError
        At the first rule broken; ``rule`` names it, and the message says
        what was found.
    ScenarioError
        If no scenario is given and no built-in scenario has the family, or
        the scenario has no ``[controller]`` of it.

    Examples
    --------
    >>> check_family("lqr")  # on crh2-dmpc-well-sampled's [controller.lqr]
    ('vocabulary', 'settings', 'design', 'checks_named', 'closed_loop', 'design_pickles', \
'controllers_step', 'report_data')

    A family whose closed loop is not one disturbance per vehicle:

    >>> import control as ct
    >>> from trainctl.controllers.lqr.family import LQRFamily
    >>> class OneInput(LQRFamily):
    ...     def closed_loop(self, design, strategy):
    ...         loop = super().closed_loop(design, strategy)
    ...         return ct.ss(loop.A, loop.B[:, :1], loop.C, loop.D[:, :1], loop.dt)
    >>> try:
    ...     check_family(OneInput())
    ... except FamilyCheckError as err:
    ...     print(err.rule)
    closed_loop
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ValueError(f"check_family: 'steps' must be an int >= 1 (got {steps!r}).")
    if isinstance(family, str):
        family = get_family(family)
    _vocabulary(family)
    name = family.name
    case = _scenario(name, scenario)
    _settings(family, case)
    from trainctl.design import build_model

    model = build_model(case)
    design = _run("design", f"family {name!r}: design()", family.design, case, model,
                  case.controllers[name])
    _checks_named(family, design)
    loops = {strategy: _closed_loop(family, design, strategy, model)
             for strategy in family.strategies}
    _design_pickles(family, design, loops)
    for strategy in family.strategies:
        _controller_steps(family, design, strategy, model, case, steps)
    _report_data(family, design)
    return RULES


def free_growth(A: Array, squarings: int = _SQUARINGS) -> float:
    """log ρ(A) measured from the free response x_k = A^k x_0, over 2^squarings samples.

    A^(2^J) is formed by J squarings, each normalised (its norm kept as a
    logarithm, so that neither a growing nor a decaying response over- or
    underflows): log ‖A^k‖ / k tends to log ρ(A), the largest |eigenvalue|,
    as k grows, from above, by about log(κ)/k (κ the condition number of
    the eigenvectors; a Jordan block adds log(k)·(m-1)/k). No eigenvalue is
    computed.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        A discrete state matrix (for a continuous one, e^(A T)).
    squarings : int
        J: the response runs over k = 2^J samples.

    Returns
    -------
    float
        The logarithm of ρ(A) [per sample]; -inf when A^k vanishes (a
        nilpotent A).

    Examples
    --------
    A rotation by 0.5 rad scaled by 0.9 and a lower-triangular coupling:
    ρ = 0.9 whatever the coupling, and log 0.9 = -0.105361:

    >>> A = 0.9 * np.array([[np.cos(0.5), -np.sin(0.5)], [np.sin(0.5), np.cos(0.5)]])
    >>> A = np.block([[A, np.zeros((2, 1))], [np.ones((1, 2)), np.full((1, 1), 0.5)]])
    >>> round(free_growth(A), 6), round(float(np.log(0.9)), 6)
    (-0.105361, -0.105361)
    """
    power = np.array(A, dtype=float)
    log_scale = 0.0
    for _ in range(int(squarings)):
        size = float(np.linalg.norm(power))
        if size == 0.0 or not math.isfinite(size):
            return -math.inf if size == 0.0 else math.nan
        power, log_scale = power / size, log_scale + math.log(size)
        power, log_scale = power @ power, 2.0 * log_scale
    size = float(np.linalg.norm(power))
    if size == 0.0:
        return -math.inf
    return (log_scale + math.log(size)) / 2.0 ** int(squarings)


# --------------------------------------------------------------------------- the rules


_fail = FamilyCheckError


def _run(rule: str, what: str, call: Callable[..., Any], *args: Any) -> Any:
    """``call(*args)``, an exception from the family's code reported under ``rule``."""
    try:
        return call(*args)
    except FamilyCheckError:
        raise
    except Exception as exc:  # the family's own code: any error breaks the rule
        raise _fail(rule, f"{what} raised {type(exc).__name__}: {exc}") from exc


def _vocabulary(family: object) -> None:
    rule = "vocabulary"
    name = getattr(family, "name", None)
    if not isinstance(name, str) or not name.isidentifier():
        raise _fail(rule, f"'name' must be an identifier str (got {name!r}).")
    where = f"family {name!r}"
    missing = [m for m in _METHODS if not callable(getattr(family, m, None))]
    if missing:
        raise _fail(rule, f"{where}: missing methods {', '.join(missing)} (the protocol "
                          "trainctl.registry.ControllerFamily).")
    title = getattr(family, "title", None)
    if not isinstance(title, str) or not title.strip():
        raise _fail(rule, f"{where}: 'title' must be a non-empty str (got {title!r}).")
    if not isinstance(getattr(family, "report_partial", None), str):
        raise _fail(rule, f"{where}: 'report_partial' must be a str (Jinja source, or \"\").")
    _names(family, "strategies", _STRATEGY, where)
    checks = _names(family, "check_names", _CHECK, where)
    if not isinstance(family, ControllerFamily):
        raise _fail(rule, f"{where}: not a trainctl.registry.ControllerFamily (its "
                          "'settings' is missing).")
    from trainctl.analysis.check import LOOP_CHECK_NAMES
    from trainctl.scenario.core import model_check_names

    taken = {c: "a model check" for c in (*model_check_names(), *LOOP_CHECK_NAMES)}
    for other in family_names():
        if other != name:
            taken.update({c: f"a check of family {other!r}"
                          for c in getattr(get_family(other), "check_names", ())
                          if c not in taken})
    clash = [f"{c!r} ({taken[c]})" for c in checks if c in taken]
    if clash:
        raise _fail(rule, f"{where}: check names taken: {', '.join(clash)}.")
    trajectory = getattr(family, "trajectory_check_names", ())
    if (not isinstance(trajectory, tuple) or not all(isinstance(c, str) for c in trajectory)
            or set(trajectory) - set(checks)):
        raise _fail(rule, f"{where}: 'trajectory_check_names' must be a tuple of names from "
                          f"'check_names' (got {trajectory!r}).")


def _names(family: object, attribute: str, pattern: re.Pattern[str], where: str) -> tuple[str, ...]:
    names = getattr(family, attribute, None)
    if not isinstance(names, tuple) or not names:
        raise _fail("vocabulary", f"{where}: {attribute!r} must be a non-empty tuple of str "
                                  f"(got {names!r}).")
    bad = [n for n in names if not isinstance(n, str) or not pattern.fullmatch(n)]
    if bad:
        raise _fail("vocabulary", f"{where}: {attribute!r} has names that are not "
                                  f"{pattern.pattern}: {bad!r}.")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise _fail("vocabulary", f"{where}: {attribute!r} repeats {repeated!r}.")
    return names


@lru_cache(maxsize=1)
def _builtin_cases() -> dict[str, str]:
    """Family name -> the built-in scenario to check it on: the first with the family alone,
    else the first with it as the primary family, else the first with it at all."""
    from trainctl.scenario import builtin_scenarios, load_scenario

    alone: dict[str, str] = {}
    primary: dict[str, str] = {}
    anywhere: dict[str, str] = {}
    for builtin in builtin_scenarios():
        families = list(load_scenario(builtin.name).controllers)
        if len(families) == 1:
            alone.setdefault(families[0], builtin.name)
        if families:
            primary.setdefault(families[0], builtin.name)
        for family in families:
            anywhere.setdefault(family, builtin.name)
    return {**anywhere, **primary, **alone}


def _scenario(name: str, scenario: Scenario | str | os.PathLike[str] | None) -> Scenario:
    from trainctl.scenario import load_scenario

    if scenario is None:
        builtin = _builtin_cases().get(name)
        if builtin is None:
            raise ScenarioError(f"check_family: no built-in scenario has a [controller] of "
                                f"family {name!r}; pass scenario= (a file using it, loaded "
                                "after register_family).")
        scenario = builtin
    if isinstance(scenario, str | os.PathLike):
        scenario = load_scenario(scenario)
    if name not in scenario.controllers:
        have = ", ".join(scenario.controllers) or "none"
        raise ScenarioError(f"check_family: {scenario.source} has no [controller] of family "
                            f"{name!r} (it has: {have}).")
    return scenario


def _settings(family: ControllerFamily[Any, Any], scenario: Scenario) -> None:
    import pydantic
    from pydantic.dataclasses import is_pydantic_dataclass

    rule, where = "settings", f"family {family.name!r}"
    cls = _run(rule, f"{where}: 'settings'", lambda: family.settings)
    if not isinstance(cls, type) or not (issubclass(cls, pydantic.BaseModel)
                                         or is_pydantic_dataclass(cls)):
        raise _fail(rule, f"{where}: 'settings' must be a pydantic model class (a BaseModel "
                          f"or a pydantic dataclass; got {cls!r}).")
    given = scenario.controllers[family.name]
    if not isinstance(given, cls):
        raise _fail(rule, f"{where}: the settings of {scenario.source} are a "
                          f"{type(given).__name__}, not a {cls.__name__}.")
    try:
        cls()
        return
    except (TypeError, ValueError):  # required fields: build it from the file's table
        pass
    table = _controller_table(scenario, family.name)
    if table is None:
        return  # a scenario built in Python: its settings, checked above, are all there is
    from trainctl.scenario.filemodel import load_settings

    made = _run(rule, f"{where}: {cls.__name__} from the [controller] table of "
                      f"{scenario.source}",
                load_settings, cls, table, {"n_coaches": scenario.train.n_vehicles})
    if not isinstance(made, cls):
        raise _fail(rule, f"{where}: the [controller] table gave a {type(made).__name__}, not "
                          f"a {cls.__name__}.")
    if made != given:
        raise _fail(rule, f"{where}: the [controller] table of {scenario.source} gives other "
                          "settings than the scenario holds.")


def _controller_table(scenario: Scenario, name: str) -> dict[str, Any] | None:
    """The scenario file's table of family ``name``, as the scenario parser reads it."""
    if scenario.document is None or "controller" not in scenario.document:
        return None
    from trainctl.scenario.replace import thaw

    raw = thaw(scenario.document["controller"])
    if isinstance(raw.get(name), dict):
        table: dict[str, Any] = raw[name]
        return table
    names = set(family_names())
    return {k: v for k, v in raw.items() if k != "family" and k not in names}


def _checks_named(family: ControllerFamily[Any, Any], design: Any) -> None:
    from trainctl.analysis.check import STATUSES, Check

    rule, where = "checks_named", f"family {family.name!r}"
    checks = _run(rule, f"{where}: checks()", family.checks, design)
    if not isinstance(checks, list | tuple) or not all(isinstance(c, Check) for c in checks):
        raise _fail(rule, f"{where}: checks() must return a list of "
                          f"trainctl.analysis.check.Check (got {checks!r:.200}).")
    names = tuple(c.name for c in checks)
    if names != family.check_names:
        raise _fail(rule, f"{where}: checks() names {list(names)}, but check_names is "
                          f"{list(family.check_names)} (one check per name, in that order).")
    bad = [f"{c.name}: {c.status!r}" for c in checks if c.status not in STATUSES]
    if bad:
        raise _fail(rule, f"{where}: statuses not in {STATUSES}: {', '.join(bad)}.")


def _closed_loop(family: ControllerFamily[Any, Any], design: Any, strategy: str,
                 model: DesignModel) -> ct.StateSpace | None:
    import control as ct

    rule, where = "closed_loop", f"family {family.name!r}, strategy {strategy!r}"
    loop = _run(rule, f"{where}: closed_loop()", family.closed_loop, design, strategy)
    if loop is None:
        return None
    if not isinstance(loop, ct.StateSpace):
        raise _fail(rule, f"{where}: closed_loop() must return a control.StateSpace or None "
                          f"(got {type(loop).__name__}).")
    nx, nu, ny = int(loop.nstates), int(loop.ninputs), int(loop.noutputs)
    A, B, C, D = (np.asarray(m, dtype=float) for m in (loop.A, loop.B, loop.C, loop.D))
    shapes = {"A": (A.shape, (nx, nx)), "B": (B.shape, (nx, nu)), "C": (C.shape, (ny, nx)),
              "D": (D.shape, (ny, nu))}
    wrong = [f"{k} is {got}, not {want}" for k, (got, want) in shapes.items() if got != want]
    labels = {"states": (loop.state_labels, nx), "inputs": (loop.input_labels, nu),
              "outputs": (loop.output_labels, ny)}
    wrong += [f"{len(got)} {k} labels for {want}" for k, (got, want) in labels.items()
              if len(got) != want]
    if wrong or nx < 1 or ny < 1:
        raise _fail(rule, f"{where}: {nx} states, {nu} inputs, {ny} outputs, but "
                          f"{'; '.join(wrong) or 'no state or no output'}.")
    n = model.n_vehicles
    if nu != n:
        raise _fail(rule, f"{where}: {nu} inputs, not one disturbance w[i] per vehicle ({n}).")
    if not all(np.all(np.isfinite(m)) for m in (A, B, C, D)):
        raise _fail(rule, f"{where}: the matrices are not finite.")
    T = float(model.settings.sample_time)
    dt = loop.dt
    if dt is True or dt is None or (dt != 0 and dt != T):
        raise _fail(rule, f"{where}: dt must be the sample time {T!r} s or 0 (continuous), "
                          f"got {dt!r}.")
    poles = np.asarray(loop.poles(), dtype=complex)
    if poles.shape != (nx,) or not np.all(np.isfinite(poles)):
        raise _fail(rule, f"{where}: poles() gave {poles.shape[0]} values for {nx} states, "
                          "or values that are not finite.")
    _check_growth(where, A, poles, T, discrete=dt != 0)
    return loop


def _check_growth(where: str, A: Array, poles: NDArray[np.complex128], T: float, *,
                  discrete: bool) -> None:
    """The poles' largest growth per sample against the free response's (rule closed_loop)."""
    import scipy.linalg

    if discrete:
        got, want, text = math.exp(free_growth(A)), float(np.max(np.abs(poles))), "ρ"
    else:
        got = free_growth(scipy.linalg.expm(A * T)) / T
        want, text = float(np.max(poles.real)), "max Re λ [1/s]"
    scale = 1.0 if discrete else T
    if not abs(got - want) * scale <= _GROWTH_TOL * max(1.0, abs(want) * scale):
        raise _fail("closed_loop", f"{where}: the poles give {text} = {want:.9g}, the free "
                                   f"response of A grows at {got:.9g}.")


def _design_pickles(family: ControllerFamily[Any, Any], design: Any,
                    loops: Mapping[str, ct.StateSpace | None]) -> None:
    rule, where = "design_pickles", f"family {family.name!r}"
    copy = _run(rule, f"{where}: pickle round trip of the design",
                _round_trip, design)
    for strategy, loop in loops.items():
        again = _run(rule, f"{where}: closed_loop() of the unpickled design",
                     family.closed_loop, copy, strategy)
        same = (loop is None and again is None) or (
            loop is not None and again is not None and again.dt == loop.dt
            and all(np.array_equal(np.asarray(getattr(again, m)), np.asarray(getattr(loop, m)))
                    for m in "ABCD"))
        if not same:
            raise _fail(rule, f"{where}, strategy {strategy!r}: the unpickled design gives "
                              "another closed loop.")


def _round_trip(design: Any) -> Any:
    return pickle.loads(pickle.dumps(design, protocol=pickle.HIGHEST_PROTOCOL))


def _controller_steps(family: ControllerFamily[Any, Any], design: Any, strategy: str,
                      model: DesignModel, scenario: Scenario, steps: int) -> None:
    from trainctl.controllers.base import (
        STATUSES,
        Controller,
        Measurement,
        ReferencePreview,
        StepRecord,
    )
    from trainctl.models.dynamics import vehicle_positions

    rule, where = "controllers_step", f"family {family.name!r}, strategy {strategy!r}"
    controller = _run(rule, f"{where}: make()", family.make, design, strategy)
    if not isinstance(controller, Controller):
        raise _fail(rule, f"{where}: make() gave a {type(controller).__name__}, not a "
                          "trainctl.controllers.base.Controller (dt, name, reset, step).")
    dt = controller.dt
    if isinstance(dt, bool) or not isinstance(dt, int | float) or not dt > 0 or dt == math.inf:
        raise _fail(rule, f"{where}: the controller's dt must be a finite number > 0 [s] "
                          f"(got {dt!r}).")
    if not isinstance(controller.name, str) or not controller.name:
        raise _fail(rule, f"{where}: the controller's name must be a non-empty str.")
    prepare = getattr(controller, "prepare", None)
    if callable(prepare):
        _run(rule, f"{where}: prepare(None, seed)", prepare, None, int(scenario.seed))
    _run(rule, f"{where}: reset()", controller.reset)
    n, nx = model.n_vehicles, model.n_states
    Ad, Bd = _zoh(np.asarray(model.design.A, dtype=float), np.asarray(model.design.B,
                                                                         dtype=float), dt)
    eq = model.equilibrium
    x_eq = eq.state(position=0.0)
    x = x_eq.copy()
    x[:n] -= _SPEED_ERROR
    horizon = _preview_steps(controller)
    full = bool(getattr(controller, "needs_full_state", True))
    for k in range(steps):
        t = k * float(dt)
        times = t + float(dt) * np.arange(horizon + 1, dtype=float)
        preview = ReferencePreview(times=times, speed=np.full(times.shape, eq.speed),
                                   acceleration=np.zeros(times.shape))
        measurement = Measurement(state=x.copy() if full else None, outputs=x[:n].copy(),
                                  positions=vehicle_positions(model.train, x))
        record = _run(rule, f"{where}: step {k}", controller.step, t, measurement, preview)
        if not isinstance(record, StepRecord):
            raise _fail(rule, f"{where}: step {k} gave a {type(record).__name__}, not a "
                              "trainctl.controllers.base.StepRecord.")
        inputs = np.asarray(record.inputs, dtype=float)
        if inputs.shape != (n,) or not np.all(np.isfinite(inputs)):
            raise _fail(rule, f"{where}: step {k} gave inputs of shape {inputs.shape} (one "
                              f"finite force per vehicle [N] wanted, {n}).")
        if record.status not in STATUSES or record.status == "error":
            reason = record.info.get("reason") if isinstance(record.info, Mapping) else None
            raise _fail(rule, f"{where}: step {k} has status {record.status!r}"
                              + (f" ({reason})." if reason else "."))
        deviation = Ad @ (x[:nx] - x_eq[:nx]) + Bd @ ((inputs - eq.inputs) / 1e3)
        head = x[0]
        x = x.copy()
        x[:nx] = x_eq[:nx] + deviation
        x[-1] += float(dt) * head


def _preview_steps(controller: object) -> int:
    """Samples of reference preview a controller reads (as the run gives them)."""
    steps: int | None = getattr(controller, "preview_steps", None)
    if steps is None:
        steps = int(getattr(controller, "P", 1))
    return int(steps)


def _zoh(A: Array, B: Array, dt: float) -> tuple[Array, Array]:
    """Zero-order hold of (A, B) at ``dt`` [s] by one matrix exponential."""
    import scipy.linalg

    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = scipy.linalg.expm(M * dt)
    return E[:n, :n], E[:n, n:]


def _report_data(family: ControllerFamily[Any, Any], design: Any) -> None:
    rule, where = "report_data", f"family {family.name!r}"
    data = _run(rule, f"{where}: report_data()", family.report_data, design)
    if not isinstance(data, dict) or not all(isinstance(k, str) for k in data):
        raise _fail(rule, f"{where}: report_data() must return a dict with str keys (got "
                          f"{type(data).__name__}).")
    try:
        json.dumps(data, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise _fail(rule, f"{where}: report_data() is not JSON-safe ({exc}).") from exc
