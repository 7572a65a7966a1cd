# What every controller does when a step cannot be computed: one rule, one place.
"""Faults at a controller's solver boundary, and the safe input of a faulty step.

One rule for every family: a step whose measurement is not finite, whose
solver raised, or whose solver (or law) gave no usable answer records the
outcome as its status (``"error"`` for the first two, the solver's own
``"infeasible"``/``"max_iterations"`` otherwise), names its fallback in
:attr:`~trainctl.controllers.base.StepRecord.fallback` and the reason in
``info["reason"]``, and applies a finite fallback input within the rate
limit (where the family has one) and the actuator envelope; the run goes on.

- :func:`call_solver` is the narrow ``try`` around one solver call: any
  ``Exception`` the call raises becomes a reason string (the step is then
  ``"error"``); ``MemoryError``, ``KeyboardInterrupt`` (the signals of
  :mod:`trainctl.run._signals`) and ``SystemExit`` pass through.
- :func:`safe_inputs` clips a fallback to the rate window about the last
  applied input, then to the envelope: where the two do not meet (the
  envelope moved further in one sample than the rate limit allows) the
  envelope's side nearest the window, the input the actuator can give.
- :func:`fault_record` is the step record of a law family's faulty step.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.controllers.base import StepRecord

__all__ = ["SUPERVISOR_BRAKING", "call_solver", "fault_record", "finite", "non_finite_reason",
           "safe_inputs"]

T = TypeVar("T")
Array = NDArray[np.float64]

SUPERVISOR_BRAKING = "supervisor_braking"
"""The fallback name of a step at which a safety supervisor overrode the law with full braking.

Not a fault: the step keeps its status (``"optimal"`` when the law answered),
and ``info["supervisor"]`` names the vehicles braked
(:mod:`trainctl.controllers.flocking.supervisor`)."""


def call_solver(solve: Callable[..., T], *args: object,
                **kwargs: object) -> tuple[T | None, str]:
    """Call a solver; an exception it raises becomes a reason, not the end of the run.

    Parameters
    ----------
    solve : callable
        The solver call (a QP solve, a feedback law's evaluation).
    *args, **kwargs
        Its arguments.

    Returns
    -------
    (object or None, str)
        The call's result and ``""``; or None and the reason (the exception's
        type and message) when it raised an ``Exception``.

    Raises
    ------
    MemoryError
        Passed on: the process is out of memory, not the solver out of luck.
        ``KeyboardInterrupt`` and ``SystemExit`` are not caught either.

    Examples
    --------
    >>> call_solver(divmod, 7, 2)
    ((3, 1), '')
    >>> call_solver(divmod, 7, 0)
    (None, 'the solver raised ZeroDivisionError: integer division or modulo by zero')
    """
    try:
        return solve(*args, **kwargs), ""
    except MemoryError:
        raise
    except Exception as exc:  # the solver boundary: any failure of the call is a failed step
        message = str(exc).strip() or "(no message)"
        return None, f"the solver raised {type(exc).__name__}: {message}"


def finite(values: NDArray[np.float64]) -> bool:
    """True when every entry of an array is finite (a fast test for every sample).

    ``np.isfinite(x).all()`` without the reduction: ``argmin`` of the finite mask is
    its first False entry (or 0). 0.6 µs against 4.4 µs a call on 8 entries in
    numpy 2.4, whose reductions cost ~2.5 µs each; no floating-point flags raised.

    Parameters
    ----------
    values : ndarray
        Any float array.

    Returns
    -------
    bool
        No entry is NaN or infinite (True for an empty array).

    Examples
    --------
    >>> finite(np.array([1.0, 2.0])), finite(np.array([1.0, np.inf])), finite(np.empty(0))
    (True, False, True)
    """
    ok = np.isfinite(values)
    return not ok.size or bool(ok.flat[ok.argmin()])


def non_finite_reason(what: str, values: ArrayLike) -> str:
    """Why a measurement cannot be used ("" when it is finite).

    Parameters
    ----------
    what : str
        What the values are, e.g. ``"state"`` or ``"outputs"``.
    values : array_like
        The values.

    Returns
    -------
    str
        ``"non-finite measurement: what[i] = value"`` for the first
        non-finite entry, else ``""``.

    Examples
    --------
    >>> non_finite_reason("outputs", [20.0, float("nan")])
    'non-finite measurement: outputs[1] = nan'
    >>> non_finite_reason("outputs", [20.0, 19.0])
    ''
    """
    x = np.asarray(values, dtype=float)
    bad = np.flatnonzero(~np.isfinite(x))
    if not bad.size:
        return ""
    return f"non-finite measurement: {what}[{int(bad[0])}] = {float(x.flat[bad[0]])!r}"


def safe_inputs(inputs: ArrayLike, previous: ArrayLike | None, rate: float,
                low: ArrayLike, high: ArrayLike) -> Array:
    """A fallback input within the rate window of the last applied input and the envelope.

    Parameters
    ----------
    inputs : array_like
        The fallback wanted, one per vehicle (any force unit, the same for all
        arguments).
    previous : array_like or None
        The input applied at the previous sample (None: no rate window, the
        first sample).
    rate : float
        Largest change per sample (inf: none), >= 0.
    low, high : array_like
        The envelope: each vehicle's lower and upper bound (±inf: none).

    Returns
    -------
    ndarray
        ``inputs`` clipped to [previous - rate, previous + rate], then to
        [low, high]: in both where they meet, else on the envelope's side
        nearest the window.

    Examples
    --------
    A 1 kN rate limit about 23 kN, an envelope up to 27.4 kN: the wanted
    17.65 kN becomes 22 kN; when the envelope falls to 20 kN the rate limit
    cannot be met and the envelope's 20 kN is applied.

    >>> safe_inputs([17.65], [23.0], 1.0, [-40.0], [27.4]).tolist()
    [22.0]
    >>> safe_inputs([17.65], [23.0], 1.0, [-40.0], [20.0]).tolist()
    [20.0]
    """
    u = np.array(inputs, dtype=float)
    if previous is not None and np.isfinite(rate):
        prev = np.asarray(previous, dtype=float)
        np.clip(u, prev - rate, prev + rate, out=u)
    np.clip(u, np.asarray(low, dtype=float), np.asarray(high, dtype=float), out=u)
    return u


def fault_record(inputs: ArrayLike, *, reason: str, fallback: str,
                 start: float, status: str = "error") -> StepRecord:
    """The record of a faulty step: the fallback input [N], its name and the reason.

    Parameters
    ----------
    inputs : array_like
        The fallback input per vehicle [N], finite, already made safe
        (:func:`safe_inputs`).
    reason : str
        Why the step could not be computed (``info["reason"]``).
    fallback : str
        The fallback's name, e.g. ``"feedforward"``.
    start : float
        ``time.perf_counter()`` at the start of the step.
    status : str
        The step's status (``"error"`` unless a solver said otherwise).

    Returns
    -------
    StepRecord
        Status, fallback, reason and the step's wall time.

    Raises
    ------
    ValueError
        If ``inputs`` is not finite (a fallback must be).

    Examples
    --------
    >>> rec = fault_record([0.0, 12e3], reason="non-finite measurement: state[0] = nan",
    ...                    fallback="feedforward", start=time.perf_counter())
    >>> rec.status, rec.fallback, rec.info["reason"]
    ('error', 'feedforward', 'non-finite measurement: state[0] = nan')
    """
    u = np.array(inputs, dtype=float)
    if not np.isfinite(u).all():
        raise ValueError(f"fault_record: the fallback {fallback!r} must be finite "
                         f"(got {u.tolist()}).")
    return StepRecord(inputs=u, status=status, solve_time=time.perf_counter() - start,
                      fallback=fallback, info={"reason": reason})
