# The [model] and [simulation] settings, each key declared once (SI field, file key, unit, rule).
"""Settings of the ``[model]`` and ``[simulation]`` tables.

Each field is declared once (:mod:`trainctl.declare.keys`): its SI type and rule,
its file key with unit and converter, its default and one line of
documentation. Objects built in Python and tables read from files are
checked by the same declarations and validators.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Annotated, Any, ClassVar

import numpy as np
from numpy.typing import NDArray
from pydantic import TypeAdapter, ValidationError, ValidationInfo, model_validator

from trainctl.declare.constraints import (
    Array,
    Choice,
    Flag,
    Integer,
    NameList,
    Number,
    Violation,
    raise_at,
)
from trainctl.declare.keys import Alt, Key, python_error, settings
from trainctl.declare.limits import (
    DURATION,
    MAX_SAMPLES,
    SAMPLE_TIME,
    SAMPLES_WHY,
    SPEED,
    SPEED_ERROR,
    SPEED_NOISE,
    SPEED_POINTS,
)
from trainctl.exceptions import ModelError
from trainctl.models.discrete import DISCRETISATIONS
from trainctl.models.feedforward import ALLOCATIONS
from trainctl.models.linear import LINEARISATIONS
from trainctl.units import kmh_to_ms

__all__ = ["ModelSettings", "SimulationSettings"]

_MULTIPLE_TOL = 1e-9  # relative tolerance of "duration is a whole multiple of sample_time"


@settings
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

    speed: Annotated[float, SPEED, Key(
        "Cruise (linearisation) speed", file="speed_kmh", unit="km/h", to_si=kmh_to_ms,
        si_unit="m/s")]
    linearisation: Annotated[str, Choice(LINEARISATIONS), Key(
        "Jacobian of the Davis law at the cruise speed, or the book's printed matrices"
    )] = "jacobian"
    dummy_state: Annotated[bool, Flag(), Key(
        "Keep the book's dummy state in the linear model")] = True
    allocation: Annotated[str, Choice(ALLOCATIONS), Key(
        "Cruise traction spread by traction_share within each coupled group, or each "
        "vehicle carrying its own resistance")] = "shares"
    sample_time: Annotated[float, SAMPLE_TIME, Key(
        "Sample time of the discrete model", unit="s")]
    discretisation: Annotated[str, Choice(DISCRETISATIONS), Key(
        "Continuous-to-discrete method")] = "zoh"


def _strategies(context: dict[str, Any] | None) -> tuple[str, ...]:
    """The strategies of the scenario's families, or of every family."""
    if isinstance(context, dict) and "strategies" in context:
        return tuple(context["strategies"])
    from trainctl.scenario.core import strategy_names

    return strategy_names()


def _qualified_hint(item: object) -> str:
    """How to name another family's strategy, for a qualified name that is not offered."""
    if not (isinstance(item, str) and "." in item):
        return ""
    return (f" A strategy of another controller family ({item!r}) needs that family's "
            f"[controller.{item.split('.')[0]}] table.")


_STRATEGIES = NameList(_strategies, noun="strategy", hint=_qualified_hint)
_STRATEGY_LIST: TypeAdapter[tuple[str, ...]] = TypeAdapter(
    Annotated[tuple[str, ...], _STRATEGIES]
)
_SAMPLE_TIME: TypeAdapter[float] = TypeAdapter(Annotated[float, SAMPLE_TIME])
_TIMES = Array(Number(ge=0))
BASELINES = ("ideal", "delay-free")
"""Baseline networks of ``[simulation] baseline_network`` (:mod:`trainctl.run.repetitions`)."""
MAX_REPETITIONS = 1000
"""Most runs per strategy of one scenario (``[simulation] repetitions``); more is a sweep."""
_SPACING_ERROR = Number(ge=-5000.0, le=5000.0, why="a virtual link's gap is not off by more "
                        "than 5 km (a physical coupler's elongation by more than 10 m: "
                        "check_vehicles)")
_PHYSICAL_SPACING_ERROR = 10.0  # [m] largest |initial elongation offset| of a physical coupler
_SPEEDS = Array(SPEED_POINTS)


def _whole_steps(duration: float, sample_time: float) -> int | None:
    """``duration / sample_time`` if it is a whole number >= 1 (relative 1e-9), else None."""
    steps = round(duration / sample_time)
    if steps < 1 or abs(steps * sample_time - duration) > _MULTIPLE_TOL * duration:
        return None
    return steps


def _samples_violation(duration: float, sample_time: float) -> Violation | None:
    """The violation of a run longer than :data:`~trainctl.declare.limits.MAX_SAMPLES` samples."""
    samples = duration / sample_time
    if samples <= MAX_SAMPLES * (1 + _MULTIPLE_TOL):
        return None
    return Violation(
        text=f"must be at most {MAX_SAMPLES} samples of [model].sample_time = "
        f"{sample_time!r} s, i.e. <= {MAX_SAMPLES * sample_time:.6g} s",
        python_text=f"must be at most {MAX_SAMPLES} samples of the sample time "
        f"{sample_time!r} s",
        got_text=f"{duration!r} s, {samples:.6g} samples", hint=f" {SAMPLES_WHY}")


def _duration_violation(duration: float, sample_time: float) -> Violation:
    steps = duration / sample_time
    below = max(math.floor(steps), 1) * sample_time
    above = max(math.ceil(steps), 1) * sample_time
    options = f"{below!r}" if below == above else f"{below!r} or {above!r}"
    return Violation(
        text=f"must be a whole multiple of [model].sample_time = {sample_time!r} s",
        python_text=f"must be a whole multiple of the sample time {sample_time!r} s",
        got_text=f"{duration!r} s, {steps:.6g} samples",
        hint=f" Use e.g. {options}.",
    )


@settings
class SimulationSettings:
    """A closed-loop simulation run: duration, strategies, reference, judgement.

    Each field is declared once, with its ``[simulation]`` key; invalid values
    raise :class:`~trainctl.exceptions.ModelError`. The check against the
    sample time happens in :meth:`n_steps`, the check against the scenario's
    controller families in :meth:`check_strategies` (and, with key paths,
    when a scenario file is read).

    Parameters
    ----------
    duration : float
        Simulated time [s], > 0; a whole multiple of the sample time.
    strategies : tuple of str
        Strategies to simulate, distinct, at least one, in this order:
        strategy names of the primary controller family (e.g. ``"ndmpc"``),
        ``"family.strategy"`` for another family of the scenario (e.g.
        ``"lqr.centralised"``).
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
    initial_speed_errors : tuple of float or None
        Per-vehicle speed offsets at t = 0 [m/s], one per vehicle (head
        first), added to ``initial_speed_error``; None: none. The scenario
        checks the count against the train (:meth:`check_vehicles`).
    initial_spacing_errors : tuple of float or None
        Per-coupler elongation offsets at t = 0 [m] from the start
        equilibrium, one per coupler (head first, positive: stretched);
        None: none.
    measurement_noise : float
        Standard deviation of the Gaussian speed-measurement noise [m/s], >= 0.
    settle_time : float
        Tracking is judged after this time [s], 0 <= settle_time < duration.
    tracking_tolerance : float
        Largest admissible absolute speed error after ``settle_time`` [m/s], > 0.
    regen_efficiency : float
        Share of the braking energy credited back [-], 0 to 1.
    plant_saturation : bool
        Saturate every vehicle's force to its envelope at its speed in the
        plant (False: a linear-analysis study; the results say so).
    max_saturation_time : float
        Longest admissible time a vehicle's force may stay saturated [s],
        >= 0; inf (the default) for no limit (judged by ``--strict``).
    output_interval : float or None
        Spacing of the dense output grid between the samples [s], > 0,
        rounded to whole plant substeps (or whole points per substep); None:
        fine enough for the plant's fastest mode (capped, see
        :func:`trainctl.sim.dense_grid`).
    divergence_speed_error : float
        Speed error at which a diverging run is stopped [m/s], > 0; inf: only
        an overflow stops it.
    repetitions : int
        Runs of every strategy, >= 1: run r (from 0) uses the seed
        ``seed + r`` for every random stream (network delays, losses and
        noise, the relay's, the measurement noise); run 0 is the one shown,
        and the report gives the spread (median and range) of each
        strategy's measures over all of them
        (:mod:`trainctl.run.repetitions`).
    baseline_network : {"ideal", "delay-free"} or None
        Also run every strategy once over a baseline network, the
        denominator of the report's deviation ratios
        (:mod:`trainctl.run.repetitions`): ``"ideal"``, the scenario without its
        ``[network]`` (no delay, loss, noise or outage); ``"delay-free"``,
        its ``[network]`` with every delay 0 (the same noise, losses and
        outages, drawn the same); None: no baseline run.

    Examples
    --------
    >>> sim = SimulationSettings(duration=1200.0, strategies=("ndmpc",),
    ...                          reference_times=(0.0, 600.0), reference_speeds=(20.0, 80.0))
    >>> sim.n_steps(20.0), sim.tracking_tolerance, sim.regen_efficiency
    (60, 1.0, 1.0)
    """

    tables: ClassVar[dict[str, str]] = {
        "reference": "Reference speed profile: piecewise linear through the breakpoints, "
        "constant after the last one",
    }

    duration: Annotated[float, DURATION, Key(
        "Simulated time, a whole multiple of [model].sample_time (relative 1e-9)", unit="s")]
    strategies: Annotated[tuple[str, ...], _STRATEGIES, Key(
        "Strategies to simulate, in this order: the primary family's by name, another "
        "family's as 'family.strategy'")]
    reference_times: Annotated[tuple[float, ...], _TIMES, Key(
        "Breakpoint times: the first exactly 0, strictly increasing", file="reference.times",
        unit="s")]
    reference_speeds: Annotated[tuple[float, ...], _SPEEDS, Key(
        "Reference speed at each breakpoint, one per time", si_unit="m/s",
        one_of=(Alt("reference.speeds_kmh", unit="km/h", to_si=kmh_to_ms),
                Alt("reference.speeds", unit="m/s")),
        hint=" speeds_kmh is in km/h, speeds in m/s.")]
    initial_speed_error: Annotated[float, SPEED_ERROR, Key(
        "Common speed offset of every vehicle at t = 0", unit="m/s")] = 0.0
    initial_speed_errors: Annotated[Annotated[tuple[float, ...], Array(SPEED_ERROR)] | None, Key(
        "Per-vehicle speed offsets at t = 0, head first, added to initial_speed_error",
        unit="m/s", omitted="none")] = None
    initial_spacing_errors: Annotated[
        Annotated[tuple[float, ...], Array(_SPACING_ERROR)] | None, Key(
        "Per-coupler elongation offsets at t = 0 from the start equilibrium, head first "
        "(positive: stretched)", unit="m", omitted="none")] = None
    measurement_noise: Annotated[float, SPEED_NOISE, Key(
        "Standard deviation of Gaussian speed-measurement noise (drawn with seed)",
        unit="m/s")] = 0.0
    settle_time: Annotated[float, Number(ge=0), Key(
        "Tracking is judged after this time (< duration)", unit="s")] = 0.0
    tracking_tolerance: Annotated[float, Number(gt=0), Key(
        "Largest admissible |speed error| after settle_time", unit="m/s")] = 1.0
    regen_efficiency: Annotated[float, Number(ge=0, le=1), Key(
        "Share of the braking energy credited back",
        hint=" It is the share of the braking energy credited back.")] = 1.0
    plant_saturation: Annotated[bool, Flag(), Key(
        "Saturate each vehicle's force to its envelope at its speed in the plant (false: "
        "forces applied as asked, for a linear-analysis study)")] = True
    max_saturation_time: Annotated[float, Number(ge=0, allow_inf=True), Key(
        "Longest time a vehicle's force may stay saturated (--strict)", unit="s",
        omitted="no limit")] = math.inf
    output_interval: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Spacing of the dense output grid between the samples (rounded to the plant's "
        "substeps)", unit="s",
        omitted="fine enough for the fastest coupler mode, at most 200 000 points")] = None
    divergence_speed_error: Annotated[float, Number(gt=0, allow_inf=True), Key(
        "Stop a run whose speed error exceeds this (diverged)", unit="m/s")] = 50.0
    repetitions: Annotated[int, Integer(ge=1, le=MAX_REPETITIONS), Key(
        "Runs of every strategy with seeds seed, seed + 1, ...: the first is the one shown, "
        "the report gives the spread over all")] = 1
    baseline_network: Annotated[Annotated[str, Choice(BASELINES)] | None, Key(
        "Also run every strategy over a baseline network, the denominator of the deviation "
        "ratios: 'ideal' (no [network]) or 'delay-free' (the [network] with every delay 0)",
        omitted="no baseline run")] = None

    @model_validator(mode="after")
    def _cross_field_rules(self, info: ValidationInfo) -> SimulationSettings:
        context = info.context if isinstance(info.context, dict) else {}
        dt = context.get("sample_time")
        if dt is not None:
            too_long = _samples_violation(self.duration, dt)
            if too_long is not None:
                raise_at(("duration",), too_long, self.duration)
            if _whole_steps(self.duration, dt) is None:
                raise_at(("duration",), _duration_violation(self.duration, dt), self.duration)
        if self.settle_time >= self.duration:
            raise_at(("settle_time",), Violation(
                text=f"must be less than {{duration}} = {self.duration!r} s",
                got=self.settle_time, hint=" Tracking is judged after settle_time."),
                self.settle_time)
        self._check_reference()
        return self

    def _check_reference(self) -> None:
        times, speeds = self.reference_times, self.reference_speeds
        if times[0] != 0.0:
            raise_at(("reference_times", 0), Violation(
                text="must be 0", got=times[0], hint=" The reference starts at t = 0."))
        for i in range(1, len(times)):
            if times[i] <= times[i - 1]:
                raise_at(("reference_times", i), Violation(
                    text=f"must be greater than the previous time {times[i - 1]!r}",
                    got=times[i], hint=" List the times in increasing order."))
        if len(speeds) != len(times):
            raise_at(("reference_speeds",), Violation(
                text="must have as many entries as {reference_times}",
                got_text=f"{len(speeds)} for {len(times)} time{'s' if len(times) > 1 else ''}",
                hint=" Give one speed per time.", value=False))
        lowest = self.initial_speed_error + min(self.initial_speed_errors or (0.0,))
        if speeds[0] + lowest < 0 and speeds[0] + self.initial_speed_error >= 0:
            raise_at(("initial_speed_errors",), Violation(
                text=f"must keep every initial speed >= 0 (the reference starts at "
                f"{speeds[0]!r} m/s, plus initial_speed_error = {self.initial_speed_error!r})",
                got=min(self.initial_speed_errors or (0.0,))))
        if speeds[0] + self.initial_speed_error < 0:
            raise_at(("initial_speed_error",), Violation(
                text=f"must be >= {-speeds[0]!r} m/s, minus the reference speed at t = 0, so "
                "that no vehicle starts backwards", got=self.initial_speed_error))
        if abs(self.initial_speed_error) >= self.divergence_speed_error:
            raise_at(("initial_speed_error",), Violation(
                text=f"must be smaller in magnitude than {{divergence_speed_error}} = "
                f"{self.divergence_speed_error!r} m/s, the speed error of a diverged run",
                got=self.initial_speed_error,
                hint=" Raise divergence_speed_error to start this far off the reference."))

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
            If ``sample_time`` is outside its bounds, or ``duration`` is not a
            whole multiple of it (relative tolerance 1e-9) or more than
            :data:`~trainctl.declare.limits.MAX_SAMPLES` samples.

        Examples
        --------
        >>> sim = SimulationSettings(duration=1.5, strategies=("centralised",),
        ...                          reference_times=(0.0,), reference_speeds=(25.0,))
        >>> sim.n_steps(0.1)
        15
        """
        try:
            dt = _SAMPLE_TIME.validate_python(sample_time)
        except ValidationError as exc:
            raise python_error("SimulationSettings", exc, prefix=("sample_time",)) from None
        steps = _whole_steps(self.duration, dt)
        problem = _samples_violation(self.duration, dt)
        if steps is None or problem is not None:
            try:
                raise_at(("duration",), problem or _duration_violation(self.duration, dt))
            except ValidationError as exc:
                raise python_error("SimulationSettings", exc) from None
        return steps

    def check_vehicles(self, n: int, virtual: Sequence[bool] | None = None) -> None:
        """Check the per-vehicle initial errors against a train of ``n`` vehicles.

        Parameters
        ----------
        n : int
            Vehicles [-], >= 1.
        virtual : sequence of bool or None
            Which links are virtual (n - 1 entries); a physical coupler's
            ``initial_spacing_errors`` entry must be within ±10 m, a virtual
            link's (a gap deviation) within ±5 km. None: every link physical.

        Raises
        ------
        ModelError
            If ``initial_speed_errors`` does not have n entries,
            ``initial_spacing_errors`` does not have n - 1, or a physical
            coupler's entry exceeds 10 m.

        Examples
        --------
        >>> sim = SimulationSettings(duration=1.0, strategies=("centralised",),
        ...                          reference_times=(0.0,), reference_speeds=(25.0,),
        ...                          initial_spacing_errors=(0.1, -0.1))
        >>> sim.check_vehicles(3)
        """
        for key, want in (("initial_speed_errors", n), ("initial_spacing_errors", n - 1)):
            given = getattr(self, key)
            if given is not None and len(given) != want:
                what = "vehicle" if key == "initial_speed_errors" else "coupler"
                raise ModelError(
                    f"SimulationSettings: {key!r} must have {want} entries, one per {what} of "
                    f"the {n}-vehicle train (got {len(given)}).")
        links = [False] * (n - 1) if virtual is None else list(virtual)
        for k, error in enumerate(self.initial_spacing_errors or ()):
            if not links[k] and abs(error) > _PHYSICAL_SPACING_ERROR:
                raise ModelError(
                    f"SimulationSettings: 'initial_spacing_errors'[{k}] must be within "
                    f"±{_PHYSICAL_SPACING_ERROR:g} m for a physical coupler, which is not "
                    f"stretched or compressed by more than that (got {error!r} m).")

    def initial_offsets(self, n: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The start's offsets from the equilibrium of the reference at t = 0.

        Parameters
        ----------
        n : int
            Vehicles of the train [-] (the per-vehicle lists have n and n - 1 entries).

        Returns
        -------
        (ndarray, ndarray)
            Speed offsets [m/s], shape (n,): ``initial_speed_error`` plus each
            ``initial_speed_errors`` entry; elongation offsets [m], shape (n-1,):
            ``initial_spacing_errors`` (zeros when omitted).

        Examples
        --------
        >>> sim = SimulationSettings(duration=1.0, strategies=("centralised",),
        ...                          reference_times=(0.0,), reference_speeds=(25.0,),
        ...                          initial_speed_error=0.5, initial_spacing_errors=(0.01,))
        >>> [a.tolist() for a in sim.initial_offsets(2)]
        [[0.5, 0.5], [0.01]]
        """
        speeds = np.full(n, float(self.initial_speed_error))
        if self.initial_speed_errors is not None:
            speeds += np.asarray(self.initial_speed_errors, dtype=float)
        spacings = np.zeros(max(n - 1, 0))
        if self.initial_spacing_errors is not None:
            spacings += np.asarray(self.initial_spacing_errors, dtype=float)
        return speeds, spacings

    def check_strategies(self, names: tuple[str, ...]) -> None:
        """Check :attr:`strategies` against the strategies a scenario offers.

        Parameters
        ----------
        names : tuple of str
            The strategy names of the scenario's controller families
            (:func:`trainctl.scenario.strategy_names`).

        Raises
        ------
        ModelError
            If a strategy is not among ``names``.
        """
        try:
            _STRATEGY_LIST.validate_python(self.strategies, context={"strategies": names})
        except ValidationError as exc:
            raise python_error("SimulationSettings", exc, prefix=("strategies",)) from None
