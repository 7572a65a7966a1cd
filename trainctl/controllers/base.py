# The controller protocol every trainctl controller follows.
"""One protocol for every controller: ``reset()`` and ``step()``.

A controller is called once per sample by the simulation loop
(:func:`trainctl.sim.simulate`) with the time, what it can measure and a
preview of the reference, and returns a :class:`StepRecord`. It may hold
explicit internal state (previous plan, previous input, warm starts, an
observer's estimate) that ``reset()`` clears; it never keeps history: the
simulation collects the records. Later controllers — continuous-time
consensus laws over a communication graph, networked controllers fed
delayed or interrupted neighbour data — fit the same protocol: the
measurement carries per-agent ``messages`` for them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from trainctl.exceptions import ModelError

if TYPE_CHECKING:
    from trainctl.models.envelope import EnvelopeBounds
    from trainctl.models.feedforward import ForceSplit

__all__ = [
    "STATUSES",
    "Controller",
    "LinearLaw",
    "Measurement",
    "PlainStep",
    "ReferencePreview",
    "StepRecord",
    "control_dt",
    "documented_as",
    "measured_speeds",
]

_F = TypeVar("_F", bound=Callable[..., Any])

STATUSES = ("optimal", "optimal_inaccurate", "max_iterations", "infeasible", "error")
"""Step statuses: the solver's outcome, mapped in one place (trainctl.controllers.mpc.qp.status).

A step that applied a fallback input keeps the solver's outcome as its status
(``"infeasible"``, ``"max_iterations"``, ``"error"``) and names the fallback in
:attr:`StepRecord.fallback`; a step whose measurement or inputs were not
finite, or whose solver raised, is ``"error"`` with the reason in
:attr:`StepRecord.info` (one rule for every family: :mod:`trainctl.controllers.faults`)."""


@dataclass(frozen=True, kw_only=True)
class Measurement:
    """What a controller receives at one sample.

    Parameters
    ----------
    state : ndarray or None
        Full plant state ``[v (n) [m/s], delta (n-1) [m], s [m]]`` when the
        controller is given full-state measurement, else None.
    outputs : ndarray or None
        Measured outputs (e.g. noisy speeds [m/s]) for output-feedback controllers.
    messages : mapping or None
        Networked controllers: per-agent data received over the communication
        network (with their own time stamps), e.g. ``{(i, j): (t_sent, value)}``
        for receiver i and sender j (0-based, or ``"reference"``), as
        :meth:`trainctl.models.network.Network.messages` gives them.
    positions : ndarray or None
        Each vehicle's position along the track [m], head first, as the
        plant evaluates the line resistance at it
        (:func:`trainctl.models.dynamics.vehicle_positions`): what a
        locomotive's odometry and line data give it, for laws that feed the
        grade forward; None when not given.

    Examples
    --------
    >>> m = Measurement(outputs=np.array([20.0, 19.5]))
    >>> m.outputs.tolist(), m.state is None  # two measured speeds [m/s]
    ([20.0, 19.5], True)
    """

    state: NDArray[np.float64] | None = None
    outputs: NDArray[np.float64] | None = None
    messages: Mapping[Any, Any] | None = None
    positions: NDArray[np.float64] | None = None


@dataclass(frozen=True, kw_only=True)
class ReferencePreview:
    """The reference over the controller's horizon.

    Parameters
    ----------
    times : ndarray
        Sample times t, t+T, ..., t+P·T [s], shape (P+1,).
    speed : ndarray
        Reference speed at those times [m/s], shape (P+1,).
    acceleration : ndarray
        Reference acceleration [m/s²], shape (P+1,).

    Examples
    --------
    >>> t = 0.5 * np.arange(3)  # P = 2 samples of T = 0.5 s
    >>> preview = ReferencePreview(times=t, speed=20.0 + 0.2 * t,
    ...                            acceleration=np.full(3, 0.2))
    >>> preview.speed.tolist()  # 20 m/s rising at 0.2 m/s²
    [20.0, 20.1, 20.2]
    """

    times: NDArray[np.float64]
    speed: NDArray[np.float64]
    acceleration: NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class StepRecord:
    """What one controller step produced.

    Parameters
    ----------
    inputs : ndarray
        Force per vehicle to apply until the next sample [N].
    status : str
        One of :data:`STATUSES`: the solver's outcome, also when a fallback
        was applied.
    iterations : int
        Distributed iterations (or solver iterations for centralised MPC).
    residuals : tuple of float
        Iteration residuals ‖U^(l) - U^(l-1)‖ per iteration [kN].
    solve_time : float
        Wall time spent in the step [s].
    fallback : str
        Name of the fallback applied ("" when none), e.g. ``"shifted plan"``.
    info : mapping
        Controller-specific extras (JSON-safe); ``"reason"`` says why a step
        is ``"error"``.

    Examples
    --------
    >>> record = StepRecord(inputs=np.array([120e3, -40e3]))
    >>> record.status, record.fallback, (record.inputs / 1e3).tolist()  # [kN]
    ('optimal', '', [120.0, -40.0])
    """

    inputs: NDArray[np.float64]
    status: str = "optimal"
    iterations: int = 0
    residuals: tuple[float, ...] = ()
    solve_time: float = 0.0
    fallback: str = ""
    info: Mapping[str, object] = field(default_factory=dict)


@runtime_checkable
class PlainStep(Protocol):
    """The optional fast form of :meth:`Controller.step` for full-state laws.

    A controller that reads only the state and the reference's first speed
    and acceleration may also define ``step_inputs``; the simulation loop
    (:func:`trainctl.sim.simulate`) then calls it instead of ``step`` when it
    runs without a network and with full-state measurement, and builds no
    :class:`Measurement`, :class:`ReferencePreview` or :class:`StepRecord`
    for the step. It must give what ``step`` gives, bit for bit: the same
    inputs, and a step ``step`` would record as ``"optimal"`` with no
    iteration, residual or fallback returns None; any other step returns
    ``step``'s record. The loop uses it only when the class that defines
    ``step`` defines it too (a subclass that overrides ``step`` alone is
    called through ``step``).

    Examples
    --------
    >>> class Hold:
    ...     dt, name = 0.5, "hold"
    ...     def reset(self):
    ...         pass
    ...     def step(self, t, measurement, reference):
    ...         return StepRecord(inputs=np.zeros(2))
    ...     def step_inputs(self, t, state, speed, acceleration, out):
    ...         out[:] = 0.0
    >>> isinstance(Hold(), PlainStep)
    True
    """

    def step_inputs(self, t: float, state: NDArray[np.float64], speed: float,
                    acceleration: float, out: NDArray[np.float64]) -> StepRecord | None:
        """Write the inputs [N] of the step at ``t`` [s] into ``out``.

        Parameters
        ----------
        t : float
            Time of the sample [s].
        state : ndarray
            The full plant state ``[v (n) [m/s], delta (n-1) [m], s [m]]``
            (a buffer the loop rewrites at the next sample: read it, do not
            keep it).
        speed, acceleration : float
            The reference's speed [m/s] and acceleration [m/s²] at ``t``.
        out : ndarray
            Shape (n,): the inputs [N] go here.

        Returns
        -------
        StepRecord or None
            None for a plain ``"optimal"`` step (the inputs are in ``out``);
            otherwise the step's record, as :meth:`Controller.step` returns it.
        """
        ...


@dataclass(frozen=True, eq=False)
class LinearLaw:
    """What a static full-state law u = clip(u_ff - scale · K x̃) is made of.

    x̃ = [v - v_ref; δ - δ_ff] and (u_ff, δ_ff) = ``split.single(max(v_ref, 0.1),
    a_ref)``; clip is ``envelope.clip`` at the measured speeds. A controller
    whose :class:`PlainStep` is exactly this law (faults aside: a state or a
    feedback that is not finite goes through ``step_inputs``) may say so with a
    method ``linear_law()`` returning one; the simulation loop may then run its
    samples compiled (:mod:`trainctl.sim.closed_loop`), bit for bit
    ``step_inputs``. Used only when the class that defines ``step`` defines
    ``linear_law`` too.

    Parameters
    ----------
    gain : ndarray
        K, shape (n, 2n-1), in units of ``scale``.
    scale : float
        Newtons per unit of K x̃ (1e3: K in kN).
    split : ForceSplit
        The feedforward of the reference.
    envelope : EnvelopeBounds
        The controller's own clip.

    Examples
    --------
    >>> from trainctl.controllers.lqr.controller import LQRController
    >>> from trainctl.models import crh2_half
    >>> law = LQRController(crh2_half(), np.zeros((4, 7)), dt=0.05).linear_law()
    >>> law.gain.shape, law.scale
    ((4, 7), 1000.0)
    """

    gain: NDArray[np.float64]
    scale: float
    split: ForceSplit
    envelope: EnvelopeBounds


@runtime_checkable
class Controller(Protocol):
    """The protocol of every trainctl controller.

    Attributes
    ----------
    dt : float
        Sample time T [s] at which the simulation calls :meth:`step`.
    name : str
        Label used in results and reports.

    Examples
    --------
    Any object with ``dt``, ``name``, ``reset()`` and ``step()`` is a
    controller; the protocol is checked at run time:

    >>> class Coast:
    ...     dt, name = 0.5, "coast"
    ...     def reset(self):
    ...         pass
    ...     def step(self, t, measurement, reference):
    ...         return StepRecord(inputs=np.zeros(2))
    >>> isinstance(Coast(), Controller), isinstance(object(), Controller)
    (True, False)
    """

    dt: float
    name: str

    def reset(self) -> None:
        """Clear internal state (previous plan, warm starts, estimates)."""
        ...

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """Compute the inputs to hold over [t, t + dt).

        Parameters
        ----------
        t : float
            Time of the sample [s].
        measurement : Measurement
            What the controller can measure at ``t`` (state, outputs,
            neighbour messages, positions).
        reference : ReferencePreview
            The reference over the controller's horizon, starting at ``t``.

        Returns
        -------
        StepRecord
            The force per vehicle to hold until the next sample [N], with the
            step's status, iterations and solve time.
        """
        ...


def control_dt(where: str, dt: float) -> float:
    """A controller's interval ``dt`` [s] as a float, refused unless > 0.

    Parameters
    ----------
    where : str
        The controller's class name, for the message.
    dt : float
        The interval [s].

    Returns
    -------
    float
        ``dt`` [s].

    Raises
    ------
    ModelError
        If ``dt`` is not > 0 (NaN included).

    Examples
    --------
    >>> control_dt("Demo", 0.5)
    0.5
    >>> control_dt("Demo", 0.0)
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: Demo: 'dt' must be > 0 s (got 0.0).
    """
    if not dt > 0:
        raise ModelError(f"{where}: 'dt' must be > 0 s (got {dt!r}).")
    return float(dt)


def measured_speeds(measurement: Measurement, n: int, name: str) -> NDArray[np.float64]:
    """The measured speeds [m/s] of a measurement: its outputs, else its state's speeds.

    Parameters
    ----------
    measurement : Measurement
        What the controller received.
    n : int
        Number of vehicles.
    name : str
        The controller's name, for the message.

    Returns
    -------
    ndarray
        Shape (n,).

    Raises
    ------
    ModelError
        When the measurement holds neither, or not n speeds.

    Examples
    --------
    The state ``[v1, v2, delta, s]`` of two vehicles gives its first two entries:

    >>> state = np.array([20.0, 19.0, 0.3, 100.0])
    >>> measured_speeds(Measurement(state=state), 2, "demo").tolist()  # [m/s]
    [20.0, 19.0]
    >>> measured_speeds(Measurement(), 2, "demo")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: demo: needs the measured speeds (Measurement.outputs) ...
    """
    if measurement.outputs is not None:
        speeds = np.asarray(measurement.outputs, dtype=float)
    elif measurement.state is not None:
        speeds = np.asarray(measurement.state, dtype=float)[:n]
    else:
        raise ModelError(f"{name}: needs the measured speeds (Measurement.outputs) "
                         "or the state (got neither).")
    if speeds.shape != (n,):
        raise ModelError(f"{name}: expected {n} measured speeds (got shape {speeds.shape}).")
    return speeds


def documented_as(protocol_method: Callable[..., Any]) -> Callable[[_F], _F]:
    """Give a method the docstring of the protocol method it implements (documented once).

    Parameters
    ----------
    protocol_method : callable
        The protocol's method, e.g. ``PlainStep.step_inputs``.

    Returns
    -------
    callable
        A decorator that sets the method's ``__doc__`` to the protocol method's.

    Examples
    --------
    >>> class Hold:
    ...     @documented_as(PlainStep.step_inputs)
    ...     def step_inputs(self, t, state, speed, acceleration, out):
    ...         out[:] = 0.0
    >>> Hold.step_inputs.__doc__ == PlainStep.step_inputs.__doc__
    True
    """
    def apply(method: _F) -> _F:
        method.__doc__ = protocol_method.__doc__
        return method
    return apply
