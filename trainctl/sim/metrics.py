# Performance numbers of one closed-loop run.
"""Tracking, coupler-force, energy, comfort, saturation and solver metrics of a run.

Maxima — the speed errors, the coupler force and the jerk — are taken over
the dense grid of a :class:`~trainctl.sim.SimulationResult` (the plant
between the samples, ``dense_*``), so that what happens inside a sample
interval counts: at T = 20 s the coupler oscillations inside an interval
make the largest coupler force. RMS values are taken at the samples (the
controller's view). The jerk is the finite difference of the head vehicle's
accelerations between grid points, a_j = Δv / Δt and j = Δa over the
spacing of the midpoints; a held input that steps changes the acceleration
at once, which on a grid of spacing h reads as Δa / h.

Coupler limits: each coupler's largest |f| over the dense grid, when it
happened, and, against the coupler's admissible force ``max_force``
(:class:`~trainctl.models.vehicle.Coupler`; ``coupler_limits``), the ratio
peak / limit and the time spent above the limit. That time is measured on
the piecewise-linear interpolant of the dense force: over a grid interval
of length h where f goes from a to b, f > L for h when both ends are above
L, for h · (max(a, b) - L) / |b - a| when one end is, and likewise f < -L.

Saturation: the time each vehicle's force was held at its traction or
braking limit (the samples flagged in ``result.saturation`` times their
intervals: requests cut to the envelope, or asking for its limit), and when
and where (the head position) it first happened.

Iteration limit: a controller that iterates within a step (N-DMPC,
cooperative DMPC) records its limit and tolerance in the result's ``meta``
(:func:`~trainctl.sim.simulate`); a step stopped at the limit unconverged
when it ran ``iteration_limit`` iterations and its last change (residual)
is still above ``iteration_tolerance``. A step that converged in exactly
``iteration_limit`` iterations does not count, and neither does a step with
no iteration (a fault held the input).

Energy quadrature: over interval k each vehicle's input u_k is held, and its
speed is taken as the trapezoid (v_k + v_{k+1}) / 2, so the work is
W_ik = u_ik (v_ik + v_i,k+1) / 2 · T — exact when the speed is linear over
the interval (constant force on a rigid vehicle without resistance).
Positive work is motoring; negative work is braking, of which the fraction
``regen_efficiency`` is recovered:

    E = Σ_ik max(W_ik, 0) - regen_efficiency · Σ_ik max(-W_ik, 0)    [J → kWh]

These fields (``energy``, ``motoring_energy``, ``braking_energy``) keep that
quadrature and its meaning, so that saved runs and sweeps compare. Given the
train (and track), :func:`compute_metrics` also makes the exact energy
account, :attr:`Metrics.energy_account` (:func:`trainctl.sim.energy.energy_account`):
the work u_ik times the distance each vehicle moved, the kinetic and spring
energy, the line work and the losses, and the residual of their balance.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_finite
from trainctl.exceptions import ModelError
from trainctl.models.track import Track
from trainctl.models.train import Train
from trainctl.sim.energy import (
    EnergyAccount,
    OperatingCost,
    energy_account,
    operating_cost,
    trains_in,
)
from trainctl.sim.results import SimulationResult
from trainctl.units import JOULES_PER_KWH

__all__ = ["Metrics", "compute_metrics"]

@dataclass(frozen=True, kw_only=True, eq=False)
class Metrics:
    """Numbers summarising one run.

    Parameters
    ----------
    settle_time : float
        Tracking errors use samples with t >= settle_time [s].
    rms_error : ndarray
        RMS of v_i - v_ref per vehicle after ``settle_time`` [m/s], shape (n,).
    max_error : ndarray
        Max |v_i - v_ref| per vehicle after ``settle_time`` over the dense
        grid [m/s], shape (n,).
    max_coupler_force : float
        Max |coupler force| over couplers and the dense grid [N] (0 for one
        vehicle).
    energy : float
        Net traction energy [kWh] (module docstring).
    motoring_energy : float
        Σ max(W, 0) [kWh].
    braking_energy : float
        Σ max(-W, 0) [kWh], before the regeneration efficiency.
    regen_efficiency : float
        Fraction of braking energy recovered [-].
    max_jerk : float
        Max |jerk| of the head vehicle over the dense grid [m/s³] (NaN with
        fewer than 3 grid points).
    rms_jerk : float
        RMS jerk of the head vehicle at the samples [m/s³] (NaN with fewer
        than 2 samples).
    iterations_mean : float
        Mean iterations per sample.
    iterations_max : int
        Max iterations in a sample.
    solve_time_median : float
        Median controller step time [s].
    solve_time_p95 : float
        95th percentile of the step time [s].
    solve_time_max : float
        Max step time [s].
    status_counts : mapping
        Samples per status.
    saturation_time : ndarray
        Time each vehicle's force was held at its traction or braking limit
        [s], shape (n,).
    braking_saturation_time : ndarray
        The part of it at the braking limit [s], shape (n,).
    first_saturation_time : ndarray
        Start of each vehicle's first saturated sample [s], NaN when none, shape (n,).
    first_saturation_position : ndarray
        Head position s at that instant [m], NaN when none, shape (n,).
    fallback_counts : mapping
        Samples per fallback applied (``"shifted plan"``, ...); empty when none.
    divergence : mapping or None
        Where the run stopped because the plant diverged
        (:attr:`SimulationResult.divergence`), None when it ran to the end.
    coupler_peak_force : ndarray
        Max |f| of each coupler over the dense grid [N], shape (n-1,).
    coupler_peak_time : ndarray
        When that peak happened (its first dense point) [s], shape (n-1,).
    coupler_limit : ndarray
        Each coupler's admissible force [N], inf where there is none, shape (n-1,).
    coupler_over_time : ndarray
        Time each coupler's |f| was above its limit [s] (module docstring), shape (n-1,).
    iteration_limit : int or None
        Most distributed iterations per step of an iterating controller
        (``meta["iteration_limit"]``); None when it does not iterate.
    iteration_limit_steps : int or None
        Steps that stopped at that limit unconverged: ``iteration_limit``
        iterations, the last change still above the tolerance
        (``meta["iteration_tolerance"]``, in the residuals' unit); None
        without a limit.
    energy_account : EnergyAccount or None
        The exact energy account of the run [J]
        (:func:`~trainctl.sim.energy.energy_account`); None when
        :func:`compute_metrics` was not given the train.
    operating_cost : OperatingCost or None
        The run's operating cost at the scenario's ``[cost]`` prices
        (:func:`~trainctl.sim.energy.operating_cost`); None without prices or
        without an energy account.

    Examples
    --------
    One vehicle pushed with 1 kN for one 10 s sample, from 10 to 20.5 m/s
    while the reference goes to 20 m/s: speed errors 0 and 0.5 m/s, so
    RMS √(0.25/2) = 0.3536 m/s; work 1000 N · (10 + 20.5)/2 m/s · 10 s =
    152.5 kJ = 0.04236 kWh.

    >>> from trainctl.sim.results import SimulationResult
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 10.0]), states=np.array([[10.0, 20.5], [0.0, 152.5]]),
    ...     velocities=np.array([[10.0, 20.5]]), coupler_forces=np.zeros((0, 2)),
    ...     inputs=np.array([[1000.0]]), reference_speed=np.array([10.0, 20.0]),
    ...     reference_acceleration=np.ones(2), statuses=("optimal",),
    ...     iterations=np.array([2]), residuals=((),), solve_times=np.array([0.01]),
    ...     fallbacks=("",), controller_name="demo", seed=0, dt=10.0)
    >>> m = compute_metrics(result, settle_time=0.0)
    >>> m.rms_error.round(4).tolist(), m.max_error.tolist()  # [m/s]
    ([0.3536], [0.5])
    >>> round(m.energy, 5), m.braking_energy, m.saturated  # [kWh]
    (0.04236, 0.0, False)
    >>> m.status_counts["optimal"], m.iterations_mean, m.worst_coupler
    (1, 2.0, None)
    """

    settle_time: float
    rms_error: NDArray[np.float64]
    max_error: NDArray[np.float64]
    max_coupler_force: float
    energy: float
    motoring_energy: float
    braking_energy: float
    regen_efficiency: float
    max_jerk: float
    rms_jerk: float
    iterations_mean: float
    iterations_max: int
    solve_time_median: float
    solve_time_p95: float
    solve_time_max: float
    status_counts: Mapping[str, int]
    saturation_time: NDArray[np.float64]
    braking_saturation_time: NDArray[np.float64]
    first_saturation_time: NDArray[np.float64]
    first_saturation_position: NDArray[np.float64]
    fallback_counts: Mapping[str, int]
    divergence: Mapping[str, object] | None = None
    coupler_peak_force: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    coupler_peak_time: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    coupler_limit: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    coupler_over_time: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    iteration_limit: int | None = None
    iteration_limit_steps: int | None = None
    energy_account: EnergyAccount | None = None
    operating_cost: OperatingCost | None = None

    @property
    def iterations_converged(self) -> bool | None:
        """True when no step stopped at the iteration limit unconverged; None when the
        controller does not iterate or no step was recorded."""
        if self.iteration_limit_steps is None or not sum(self.status_counts.values()):
            return None
        return self.iteration_limit_steps == 0

    @property
    def saturated(self) -> bool:
        """True when some vehicle's force was cut to its envelope."""
        return bool(np.any(self.saturation_time > 0))

    @property
    def coupler_ratio(self) -> NDArray[np.float64]:
        """Peak |f| / admissible force of each coupler [-], 0 where there is no limit."""
        return self.coupler_peak_force / self.coupler_limit

    @property
    def coupler_limited(self) -> bool:
        """True when some coupler has an admissible force."""
        return bool(np.any(np.isfinite(self.coupler_limit)))

    @property
    def couplers_over_limit(self) -> NDArray[np.intp]:
        """Indices of the couplers whose peak |f| exceeded their admissible force."""
        return np.flatnonzero(self.coupler_peak_force > self.coupler_limit)

    @property
    def worst_coupler(self) -> int | None:
        """Index of the coupler with the largest peak / limit, None when no coupler has one."""
        if not self.coupler_limited:
            return None
        return int(np.argmax(self.coupler_ratio))

    def coupler_verdict(self) -> dict[str, object] | None:
        """The coupler with the largest peak / limit, as a JSON-safe dict.

        Returns
        -------
        dict or None
            ``exceeded`` (bool: some coupler went above its limit),
            ``couplers_over`` (1-based numbers of those couplers), and of the
            worst coupler its 1-based number ``coupler``, ``ratio`` [-],
            ``peak_force`` and ``limit`` [N], ``time`` of the peak and
            ``over_time`` [s]; None when no coupler has a limit.
        """
        i = self.worst_coupler
        if i is None:
            return None
        return {
            "exceeded": bool(self.couplers_over_limit.size),
            "couplers_over": [int(c) + 1 for c in self.couplers_over_limit],
            "coupler": i + 1,
            "ratio": float(self.coupler_ratio[i]),
            "peak_force": float(self.coupler_peak_force[i]),
            "limit": float(self.coupler_limit[i]),
            "time": float(self.coupler_peak_time[i]),
            "over_time": float(self.coupler_over_time[i]),
        }

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict (arrays as lists, non-finite numbers as None).

        Returns
        -------
        dict of str to object
            Every field by name, in the field's unit, except that the energies
            are keyed ``energy_kwh``, ``motoring_energy_kwh`` and
            ``braking_energy_kwh`` [kWh]; plus ``diverged`` (bool),
            ``coupler_verdict`` (:meth:`coupler_verdict`) and
            ``iterations_converged``. Mappings become dicts, and
            ``energy_account`` its :meth:`EnergyAccount.to_dict` (None without one).
        """

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {
            "settle_time": self.settle_time,
            "rms_error": [num(x) for x in self.rms_error],
            "max_error": [num(x) for x in self.max_error],
            "max_coupler_force": num(self.max_coupler_force),
            "energy_kwh": num(self.energy),
            "motoring_energy_kwh": num(self.motoring_energy),
            "braking_energy_kwh": num(self.braking_energy),
            "regen_efficiency": self.regen_efficiency,
            "max_jerk": num(self.max_jerk),
            "rms_jerk": num(self.rms_jerk),
            "iterations_mean": num(self.iterations_mean),
            "iterations_max": self.iterations_max,
            "solve_time_median": num(self.solve_time_median),
            "solve_time_p95": num(self.solve_time_p95),
            "solve_time_max": num(self.solve_time_max),
            "status_counts": dict(self.status_counts),
            "saturation_time": [float(x) for x in self.saturation_time],
            "braking_saturation_time": [float(x) for x in self.braking_saturation_time],
            "first_saturation_time": [num(x) for x in self.first_saturation_time],
            "first_saturation_position": [num(x) for x in self.first_saturation_position],
            "fallback_counts": dict(self.fallback_counts),
            "diverged": self.divergence is not None,
            "divergence": None if self.divergence is None else dict(self.divergence),
            "coupler_peak_force": [float(x) for x in self.coupler_peak_force],
            "coupler_peak_time": [num(x) for x in self.coupler_peak_time],
            "coupler_limit": [num(x) for x in self.coupler_limit],
            "coupler_over_time": [float(x) for x in self.coupler_over_time],
            "coupler_verdict": self.coupler_verdict(),
            "iteration_limit": self.iteration_limit,
            "iteration_limit_steps": self.iteration_limit_steps,
            "iterations_converged": self.iterations_converged,
            "energy_account": (None if self.energy_account is None
                               else self.energy_account.to_dict()),
            "operating_cost": (None if self.operating_cost is None
                               else self.operating_cost.to_dict()),
        }


def compute_metrics(
    result: SimulationResult, *, settle_time: float = 0.0, regen_efficiency: float = 1.0,
    coupler_limits: ArrayLike | None = None, train: Train | None = None,
    track: Track | None = None, cost: Any = None,
) -> Metrics:
    """Metrics of a run.

    Parameters
    ----------
    result : SimulationResult
        The run.
    settle_time : float
        Ignore tracking errors before this time [s]; there must be at least
        one sample at or after it.
    regen_efficiency : float
        Fraction of braking energy recovered, in [0, 1].
    coupler_limits : array_like or None
        Admissible force of each coupler [N], shape (n-1,), > 0, inf for no
        limit (:attr:`trainctl.models.train.Train.max_coupler_force`); None:
        no limits.
    train : Train or None
        The simulated train: given, the metrics hold the run's exact energy
        account (:attr:`Metrics.energy_account`); None: no account.
    track : Track or None
        The track it ran on, for the account's line work; None: level and straight.
    cost : CostSettings or None
        Prices (:class:`~trainctl.scenario.cost.CostSettings`: ``energy_price``,
        ``train_hour_price``, ``drive_efficiency``, ``currency``) for
        :attr:`Metrics.operating_cost` (with ``train``); None: no cost.

    Returns
    -------
    Metrics
        The numbers: maxima over the dense grid, RMS values at the samples
        (module docstring). A run that diverged before ``settle_time`` has
        its errors taken over the whole run.

    Examples
    --------
    >>> import numpy as np
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 10.0]), states=np.array([[10.0, 20.0], [0.0, 150.0]]),
    ...     velocities=np.array([[10.0, 20.0]]), coupler_forces=np.zeros((0, 2)),
    ...     inputs=np.array([[1000.0]]), reference_speed=np.array([10.0, 20.0]),
    ...     reference_acceleration=np.ones(2), statuses=("optimal",),
    ...     iterations=np.array([2]), residuals=((),), solve_times=np.array([0.01]),
    ...     fallbacks=("",), controller_name="demo", seed=0, dt=10.0)
    >>> m = compute_metrics(result)
    >>> round(m.energy * 3.6e6)  # 1000 N over 150 m
    150000

    A coupler whose force rises linearly from 0 to 3 kN over 10 s, against
    a 2 kN limit: the peak is 1.5 times the limit, above it for the last third.

    >>> forces = SimulationResult(
    ...     time=np.array([0.0, 10.0]), states=np.array([[10.0, 10.0], [10.0, 10.0],
    ...     [0.0, 0.0], [0.0, 100.0]]), velocities=np.full((2, 2), 10.0),
    ...     coupler_forces=np.array([[0.0, 3000.0]]), inputs=np.zeros((2, 1)),
    ...     reference_speed=np.full(2, 10.0), reference_acceleration=np.zeros(2),
    ...     statuses=("optimal",), iterations=np.array([1]), residuals=((),),
    ...     solve_times=np.array([0.01]), fallbacks=("",), controller_name="demo", seed=0,
    ...     dt=10.0)
    >>> m = compute_metrics(forces, coupler_limits=[2000.0])
    >>> m.coupler_ratio.tolist(), round(float(m.coupler_over_time[0]), 6)
    ([1.5], 3.333333)
    """
    settle = check_finite("compute_metrics", "settle_time", settle_time)
    eta = check_finite("compute_metrics", "regen_efficiency", regen_efficiency)
    if not 0.0 <= eta <= 1.0:
        raise ModelError(
            f"compute_metrics: 'regen_efficiency' must be in [0, 1] (got {regen_efficiency!r})."
        )
    after, dense_after = _after(result, settle, settle_time)
    error = result.velocities[:, after] - result.reference_speed[after]
    rms_error = np.sqrt(np.mean(error**2, axis=1))
    dense_error = (result.dense_velocities[:, dense_after]
                   - result.dense_reference_speed[dense_after])
    max_error = np.abs(dense_error).max(axis=1)
    forces = result.dense_coupler_forces
    max_force = float(np.abs(forces).max()) if forces.size else 0.0
    limits = _coupler_limits(coupler_limits, forces.shape[0])

    v = result.velocities
    dt_k = np.diff(result.time)
    work = result.inputs * 0.5 * (v[:, :-1] + v[:, 1:]) * dt_k
    motoring = float(np.maximum(work, 0.0).sum()) / JOULES_PER_KWH
    braking = float(np.maximum(-work, 0.0).sum()) / JOULES_PER_KWH

    accel = np.diff(v[0]) / dt_k
    rms_jerk = (float(np.sqrt(np.mean((np.diff(accel) / dt_k[1:]) ** 2))) if accel.size >= 2
                else math.nan)
    iters = result.iterations
    times = result.solve_times
    limit, stopped = _iteration_limit(result)
    has = iters.size > 0
    account = None if train is None else energy_account(result, train, track,
                                                        regen_efficiency=eta)
    return Metrics(
        settle_time=settle,
        rms_error=rms_error,
        max_error=max_error,
        max_coupler_force=max_force,
        energy=motoring - eta * braking,
        motoring_energy=motoring,
        braking_energy=braking,
        regen_efficiency=eta,
        max_jerk=_max_jerk(result.dense_time, result.dense_velocities[0]),
        rms_jerk=rms_jerk,
        iterations_mean=float(iters.mean()) if has else math.nan,
        iterations_max=int(iters.max()) if has else 0,
        solve_time_median=float(np.median(times)) if has else math.nan,
        solve_time_p95=float(np.percentile(times, 95)) if has else math.nan,
        solve_time_max=float(times.max()) if has else math.nan,
        status_counts=result.status_counts(),
        **_saturation(result),
        fallback_counts=dict(Counter(f for f in result.fallbacks if f)),
        divergence=result.divergence,
        **_couplers(result.dense_time, forces, limits),
        iteration_limit=limit,
        iteration_limit_steps=stopped,
        energy_account=account,
        operating_cost=None if cost is None or account is None or train is None else
        operating_cost(account, duration=float(result.time[-1] - result.time[0]),
                       trains=trains_in(train), energy_price=cost.energy_price,
                       train_hour_price=cost.train_hour_price,
                       drive_efficiency=cost.drive_efficiency, currency=cost.currency),
    )


def _after(result: SimulationResult, settle: float,
           given: float) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Samples and dense points at or after the settle time (all of a run that diverged
    before it)."""
    tol = 1e-9 * max(1.0, abs(settle))
    after = result.time >= settle - tol
    if not np.any(after):
        if result.divergence is None:
            raise ModelError(
                f"compute_metrics: 'settle_time' must leave at least one sample "
                f"(got {given!r} s; the run ends at {result.time[-1]!r} s)."
            )
        return np.ones_like(after), np.ones(result.dense_time.shape, dtype=bool)
    return after, result.dense_time >= settle - tol


def _iteration_limit(result: SimulationResult) -> tuple[int | None, int | None]:
    """The iteration limit of the run's controller and the steps that stopped at it
    unconverged (:class:`Metrics`), from ``meta`` (None, None when it does not iterate)."""
    limit = result.meta.get("iteration_limit")
    if limit is None or result.meta.get("iteration_tolerance") is None:
        return None, None
    return int(limit), sum(unconverged_steps(result))


def unconverged_steps(result: SimulationResult) -> list[bool]:
    """Per step, whether it stopped at the iteration limit with its last change still above
    the tolerance (all False when the run's controller does not iterate)."""
    limit = result.meta.get("iteration_limit")
    tolerance = result.meta.get("iteration_tolerance")
    if limit is None or tolerance is None:
        return [False] * len(result.residuals)
    return [len(r) >= limit and r[-1] > tolerance for r in result.residuals]


def _max_jerk(t: NDArray[np.float64], v: NDArray[np.float64]) -> float:
    """Max |jerk| [m/s³] from speeds v at the grid points t (module docstring)."""
    if t.size < 3:
        return math.nan
    step = np.diff(t)
    accel = np.diff(v) / step
    jerk = np.diff(accel) / (0.5 * (step[:-1] + step[1:]))
    return float(np.abs(jerk).max())


def _saturation(result: SimulationResult) -> dict[str, NDArray[np.float64]]:
    """Saturation times per vehicle [s] and the first saturated sample's time and place."""
    flags = result.saturation
    step = np.diff(result.time)
    first_time = np.full(result.n_vehicles, math.nan)
    first_position = np.full(result.n_vehicles, math.nan)
    hit = flags != 0
    for i in np.flatnonzero(hit.any(axis=1)):
        k = int(np.argmax(hit[i]))
        first_time[i], first_position[i] = result.time[k], result.positions[k]
    return {"saturation_time": hit @ step, "braking_saturation_time": (flags < 0) @ step,
            "first_saturation_time": first_time, "first_saturation_position": first_position}


def _coupler_limits(limits: ArrayLike | None, count: int) -> NDArray[np.float64]:
    """The admissible force of each of ``count`` couplers [N] (inf when ``limits`` is None)."""
    if limits is None:
        return np.full(count, math.inf)
    try:
        values = np.asarray(limits, dtype=float)
    except (TypeError, ValueError):
        values = np.full(0, math.nan)
    if values.shape != (count,) or not np.all(values > 0) or np.any(np.isnan(values)):
        raise ModelError(
            f"compute_metrics: 'coupler_limits' must hold one number > 0 (inf for no limit) "
            f"per coupler, {count} in all (got {limits!r}). Pass the train's "
            "max_coupler_force, or None for no limits."
        )
    return values


def _couplers(time: NDArray[np.float64], forces: NDArray[np.float64],
              limits: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
    """Each coupler's peak |f| [N] and its time [s], its limit [N] and the time above it [s]."""
    count = forces.shape[0]
    magnitude = np.abs(forces)
    peak = magnitude.max(axis=1) if forces.size else np.zeros(count)
    when = time[np.argmax(magnitude, axis=1)] if forces.size else np.full(count, math.nan)
    over = np.zeros(count)
    for i in np.flatnonzero(np.isfinite(limits)):
        over[i] = _time_above(time, forces[i], limits[i]) + _time_above(time, -forces[i],
                                                                         limits[i])
    return {"coupler_peak_force": peak, "coupler_peak_time": when, "coupler_limit": limits,
            "coupler_over_time": over}


def _time_above(t: NDArray[np.float64], f: NDArray[np.float64], level: float) -> float:
    """Time [s] the piecewise-linear interpolant of ``f`` on ``t`` spends above ``level``."""
    a, b, h = f[:-1] - level, f[1:] - level, np.diff(t)
    high, low = np.maximum(a, b), np.minimum(a, b)
    crossing = (high > 0) & (low <= 0)
    fraction = np.where(low > 0, 1.0, 0.0)
    fraction[crossing] = high[crossing] / (high[crossing] - low[crossing])
    return float(np.sum(h * fraction))
