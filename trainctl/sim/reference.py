# Reference speed profiles for the simulation loop.
"""Reference speed profiles and their preview over a controller's horizon.

A :class:`SpeedProfile` is piecewise linear in time through breakpoints and
constant after the last one; its acceleration is the slope of the current
segment. Any object with the methods of :class:`Reference` can drive
:func:`trainctl.sim.simulate`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_nonnegative, check_positive
from trainctl.controllers.base import ReferencePreview
from trainctl.exceptions import ModelError

__all__ = ["Reference", "SpeedProfile", "ramp_profile"]


@runtime_checkable
class Reference(Protocol):
    """What the simulation needs from a reference: speed, acceleration, preview.

    Examples
    --------
    A :class:`SpeedProfile` is one; so is a small class of one's own, e.g. a
    constant 25 m/s:

    >>> isinstance(SpeedProfile(times=(0.0,), speeds=(20.0,)), Reference)
    True
    >>> class Cruise:
    ...     def speed(self, t):
    ...         return np.full(np.shape(t), 25.0)
    ...     def acceleration(self, t):
    ...         return np.zeros(np.shape(t))
    ...     def preview(self, t, dt, steps):
    ...         times = t + dt * np.arange(steps + 1)
    ...         return ReferencePreview(times=times, speed=self.speed(times),
    ...                                 acceleration=self.acceleration(times))
    >>> isinstance(Cruise(), Reference), Cruise().preview(0.0, 0.5, 2).speed.tolist()
    (True, [25.0, 25.0, 25.0])
    """

    def speed(self, t: ArrayLike) -> NDArray[np.float64]:
        """Reference speed [m/s] at times ``t`` [s].

        Parameters
        ----------
        t : array_like
            Times [s].

        Returns
        -------
        ndarray
            Speeds [m/s], same shape as ``t``.
        """
        ...

    def acceleration(self, t: ArrayLike) -> NDArray[np.float64]:
        """Reference acceleration [m/s²] at times ``t`` [s].

        Parameters
        ----------
        t : array_like
            Times [s].

        Returns
        -------
        ndarray
            Accelerations [m/s²], same shape as ``t``.
        """
        ...

    def preview(self, t: float, dt: float, steps: int) -> ReferencePreview:
        """The reference at t, t + dt, ..., t + steps·dt.

        Parameters
        ----------
        t : float
            First sample time [s].
        dt : float
            Sample time [s], > 0.
        steps : int
            Number of steps P >= 0 of the horizon.

        Returns
        -------
        ReferencePreview
            Times [s], speeds [m/s] and accelerations [m/s²] at the
            ``steps + 1`` samples, each of shape (steps + 1,).
        """
        ...


@dataclass(frozen=True, kw_only=True)
class SpeedProfile:
    """Piecewise-linear reference speed, constant after the last breakpoint.

    Parameters
    ----------
    times : sequence of float or ndarray
        Breakpoint times [s]: finite, strictly increasing, the first 0.
        Stored as a tuple of float.
    speeds : sequence of float or ndarray
        Speeds at the breakpoints [m/s], finite and >= 0, same length.
        Stored as a tuple of float.

    Examples
    --------
    >>> profile = SpeedProfile(times=(0.0, 100.0), speeds=(0.0, 50.0))
    >>> profile.speed([0.0, 50.0, 100.0, 200.0]).tolist()
    [0.0, 25.0, 50.0, 50.0]
    >>> profile.acceleration([0.0, 99.0, 100.0]).tolist()
    [0.5, 0.5, 0.0]
    >>> profile.preview(90.0, 5.0, 2).speed.tolist()
    [45.0, 47.5, 50.0]
    """

    times: Sequence[float] | NDArray[np.float64]
    speeds: Sequence[float] | NDArray[np.float64]

    def __post_init__(self) -> None:
        times = _floats("SpeedProfile", "times", self.times)
        speeds = _floats("SpeedProfile", "speeds", self.speeds)
        if not times:
            raise ModelError(
                "SpeedProfile: 'times' must hold at least one breakpoint (got none). "
                "Use times=(0.0,) for a constant speed."
            )
        if len(speeds) != len(times):
            raise ModelError(
                f"SpeedProfile: 'speeds' must have one value per time ({len(times)}) "
                f"(got {len(speeds)})."
            )
        if times[0] != 0.0:
            raise ModelError(f"SpeedProfile: 'times' must start at 0 s (got {times[0]!r}).")
        if any(b <= a for a, b in zip(times, times[1:], strict=False)):
            raise ModelError(
                f"SpeedProfile: 'times' must increase strictly (got {list(times)}). "
                "Give each breakpoint once, in order."
            )
        if any(v < 0.0 for v in speeds):
            raise ModelError(
                f"SpeedProfile: 'speeds' must be >= 0 m/s (got {list(speeds)}). "
                "The Davis resistance law assumes forward running."
            )
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "speeds", speeds)

    @property
    def duration(self) -> float:
        """Time of the last breakpoint [s]; the speed is constant afterwards."""
        return float(self.times[-1])

    @cached_property
    def _arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Breakpoint times, speeds, and slopes with a 0 before and after: (m+1,)."""
        t = np.asarray(self.times)
        v = np.asarray(self.speeds)
        return t, v, np.concatenate([[0.0], np.diff(v) / np.diff(t), [0.0]])

    def speed(self, t: ArrayLike) -> NDArray[np.float64]:
        """Reference speed [m/s] at times ``t`` [s] (vectorised).

        Parameters
        ----------
        t : array_like
            Times [s]; before 0 the first speed applies.

        Returns
        -------
        ndarray
            Speeds [m/s], same shape as ``t``.
        """
        times, speeds, _ = self._arrays
        speed: NDArray[np.float64] = np.interp(np.asarray(t, dtype=float), times, speeds)
        return speed

    def acceleration(self, t: ArrayLike) -> NDArray[np.float64]:
        """Reference acceleration [m/s²]: the slope of the segment containing ``t``.

        At a breakpoint the slope of the segment that starts there applies;
        after the last breakpoint (and before 0) it is 0.

        Parameters
        ----------
        t : array_like
            Times [s].

        Returns
        -------
        ndarray
            Accelerations [m/s²], same shape as ``t``.
        """
        times, _, slopes = self._arrays
        return slopes[np.searchsorted(times, np.asarray(t, dtype=float), side="right")]

    def preview(self, t: float, dt: float, steps: int) -> ReferencePreview:
        """The reference at ``steps + 1`` samples t, t + dt, ..., t + steps·dt.

        Parameters
        ----------
        t : float
            First sample time [s].
        dt : float
            Sample time [s], > 0.
        steps : int
            Number of steps P >= 0 of the horizon.

        Returns
        -------
        ReferencePreview
            Times, speeds and accelerations, each of shape (steps + 1,).
        """
        dt = check_positive("SpeedProfile.preview", "dt", dt)
        if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 0:
            raise ModelError(f"SpeedProfile.preview: 'steps' must be an int >= 0 (got {steps!r}).")
        times = float(t) + dt * np.arange(int(steps) + 1, dtype=np.float64)
        return ReferencePreview(
            times=times, speed=self.speed(times), acceleration=self.acceleration(times)
        )

    def previews(self, starts: NDArray[np.float64], dt: float,
                 steps: int) -> tuple[NDArray[np.float64], ...]:
        """:meth:`preview` at many sample times at once (a closed loop's chunk of samples).

        Row k of each array is ``preview(starts[k], dt, steps)``'s, bit for bit
        (the same elementwise operations).

        Parameters
        ----------
        starts : ndarray
            First sample times [s], shape (m,).
        dt : float
            Sample time [s], > 0.
        steps : int
            Number of steps P >= 0 of the horizon.

        Returns
        -------
        (ndarray, ndarray, ndarray)
            Times [s], speeds [m/s] and accelerations [m/s²], each of shape
            (m, steps + 1).

        Examples
        --------
        >>> profile = ramp_profile(10.0, 20.0, 0.0, 10.0)
        >>> times, speed, accel = profile.previews(np.array([0.0, 5.0]), 1.0, 2)
        >>> speed.tolist(), bool(np.array_equal(speed[1], profile.preview(5.0, 1.0, 2).speed))
        ([[10.0, 11.0, 12.0], [15.0, 16.0, 17.0]], True)
        """
        dt = check_positive("SpeedProfile.previews", "dt", dt)
        times = np.asarray(starts, dtype=float)[:, None] + dt * np.arange(
            int(steps) + 1, dtype=np.float64)
        return times, self.speed(times), self.acceleration(times)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict of the breakpoints.

        Returns
        -------
        dict of str to object
            ``times`` [s] and ``speeds`` [m/s], each a list of float.
        """
        return {"times": [float(t) for t in self.times], "speeds": [float(v) for v in self.speeds]}


def ramp_profile(
    v_start: float, v_end: float, ramp_start: float, ramp_end: float
) -> SpeedProfile:
    """Constant ``v_start``, a linear ramp to ``v_end``, then constant.

    Parameters
    ----------
    v_start : float
        Speed before the ramp [m/s], >= 0.
    v_end : float
        Speed after the ramp [m/s], >= 0.
    ramp_start : float
        Time the ramp starts [s], >= 0.
    ramp_end : float
        Time the ramp ends [s], > ``ramp_start``.

    Returns
    -------
    SpeedProfile
        The profile.

    Examples
    --------
    >>> profile = ramp_profile(0.0, 80.0, 0.0, 400.0)
    >>> profile.times, profile.speeds
    ((0.0, 400.0), (0.0, 80.0))
    >>> ramp_profile(10.0, 20.0, 50.0, 150.0).speed([0.0, 100.0]).tolist()
    [10.0, 15.0]
    """
    v0 = check_nonnegative("ramp_profile", "v_start", v_start)
    v1 = check_nonnegative("ramp_profile", "v_end", v_end)
    t0 = check_nonnegative("ramp_profile", "ramp_start", ramp_start)
    t1 = check_positive("ramp_profile", "ramp_end", ramp_end)
    if t1 <= t0:
        raise ModelError(
            f"ramp_profile: 'ramp_end' must be > 'ramp_start' (got ramp_start={ramp_start!r}, "
            f"ramp_end={ramp_end!r})."
        )
    if t0 == 0.0:
        return SpeedProfile(times=(0.0, t1), speeds=(v0, v1))
    return SpeedProfile(times=(0.0, t0, t1), speeds=(v0, v0, v1))


def _floats(where: str, name: str, values: Sequence[float] | ArrayLike) -> tuple[float, ...]:
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or isinstance(values, str) or arr.ndim != 1:
        raise ModelError(f"{where}: {name!r} must be a 1-D sequence of numbers (got {values!r}).")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: {name!r} must be finite (got {arr.tolist()}).")
    return tuple(float(x) for x in arr)
