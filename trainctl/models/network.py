# The radio network between the vehicles: delays, losses, outages and noise, message by message.
"""A discrete-event model of the network over which vehicles exchange data.

Cooperative controllers (the H∞ cooperative law of seed 003 over GSM-R, the
consensus laws of seeds 001 and 002) do not see their neighbours' speeds
directly: each value travels over a radio link that delays it, may lose it,
is cut during outages and adds noise. :class:`Network` models that medium
and nothing else — no plant, no controller — so it can be used alone, in a
test, in a notebook or, later, inside the simulation loop
(:mod:`trainctl.sim`). It lives at the top level of the package, beside
:mod:`trainctl.models.graphs` whose :class:`~trainctl.models.graphs.CommunicationGraph`
says who hears whom, rather than in :mod:`trainctl.sim`, because it depends
on neither the plant nor the loop; the loop will depend on it.

Nodes and numbering
-------------------
Vehicles are numbered from 0, head first, as in
:class:`~trainctl.models.graphs.CommunicationGraph`, in the state arrays and in
the scenario files (the ``[controller]`` ``neighbourhood`` key); text meant
for a person numbers them from 1 (:mod:`trainctl.naming`). The reference
(the speed command, the virtual leader) is a sender too, named
:data:`REFERENCE` (``"reference"``), as in the graph's networkx form; it is
never a receiver. A link is a pair ``(receiver, sender)``: receiver i hears
sender j when ``graph.adjacency[i, j] > 0``, and hears the reference when
``graph.pinning[i] > 0``. The weights themselves are the controller's
business; the network only uses which links exist.

What happens to one message
---------------------------
``send(t, sender, value)`` broadcasts ``value`` at time t [s] on every link
from ``sender``: one message per receiver, which draws, at send time,

- its delay: ``delay_s`` (constant), or uniform in ``delay_range_s = [lo,
  hi]``, independently per message; it arrives at ``t + delay``;
- its loss: lost with probability ``loss_probability``;
- its noise: the receiver gets ``value + std · z`` with z standard normal
  per component, std = ``communication_noise_std`` (``reference_noise_std``
  for the reference, when given).

Interruptions (outage windows ``[start, end)`` on some links or all) block
a link: a message is *blocked* when the link is down at any moment of its
transit, i.e. when ``t_sent < end`` and ``t_arrival >= start``. So nothing
sent during a window is delivered, and nothing arrives during it: a
receiver's data from a blocked link stay frozen over the whole window. A
blocked message is not also counted as lost.

The random stream, in a fixed order
-----------------------------------
The generator is ``numpy.random.default_rng(seed)``, drawn only by
:meth:`Network.send`. A send to k receivers (the vehicles that hear the
sender, increasing index; k = 0 draws nothing) makes exactly two calls,
whatever the settings (as the simulation draws its measurement noise):

1. ``u = rng.random((k, 2))``: ``delay = lo + (hi - lo) · u[:, 0]``
   (lo = hi for a constant delay) and lost when ``u[:, 1] < loss_probability``;
2. ``z = rng.standard_normal((k, *shape))`` with ``shape`` the value's shape.

:meth:`Network.send_all` sends the reference first (when given), then
vehicles 0 .. n-1. The same seed and the same calls give the same history,
message for message; a blocked or lost message consumes its draws too, so
changing a window or the loss rate does not shift the other draws.

Receiving: hold the last value
------------------------------
``receive(t, receiver)`` gives, for every sender the receiver hears, the
newest message that has arrived by t (within :data:`ARRIVAL_TOLERANCE`) as
``Received(t_sent, value)``: the time stamp lets a controller know the age
of its data. "Newest" is by send time: with random delays messages can
arrive out of order, and an older message arriving late never replaces a
newer one. When nothing new arrived (an outage, a loss, a long delay), the
last delivered message is held. A sender from which nothing has arrived yet
is absent from the mapping. Time only moves forward: every ``send`` and
``receive`` must be at a time >= the previous call's.

Examples
--------
>>> from trainctl.models.graphs import make_graph
>>> settings = NetworkSettings(delay_s=0.5)
>>> net = Network(settings, make_graph("predecessor", 3, pinned="head"), seed=1)
>>> net.links
((0, 'reference'), (1, 0), (2, 1))
>>> net.send_all(0.0, [20.0, 21.0, 22.0], reference=20.5)
>>> net.receive(0.4, 1)
{}
>>> net.receive(0.5, 1)
{0: Received(t_sent=0.0, value=20.0)}
>>> net.messages(1.0)[(0, "reference")].value
20.5
>>> log = net.history()
>>> len(log), log.t_arrival.tolist()
(3, [0.5, 0.5, 0.5])
"""

from __future__ import annotations

import heapq
import math
import numbers
from dataclasses import dataclass
from typing import Annotated, Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydantic import TypeAdapter, ValidationError, ValidationInfo, model_validator
from pydantic_core import CoreSchema, InitErrorDetails, core_schema

from trainctl.declare.constraints import Array, Number, Rule, Violation, fail, raise_at
from trainctl.declare.keys import Key, python_error, settings
from trainctl.exceptions import DimensionError, ModelError
from trainctl.models.graphs import REFERENCE, CommunicationGraph

__all__ = [
    "ARRIVAL_TOLERANCE",
    "FATES",
    "REFERENCE",
    "Interruption",
    "MessageLog",
    "Network",
    "NetworkSettings",
    "Received",
]

FATES = ("delivered", "lost", "blocked")
"""What became of a message: it arrives, the radio lost it, an interruption blocked it."""

ARRIVAL_TOLERANCE = 1e-9
"""A message due at t_arrival has arrived by t when t_arrival <= t + 1e-9·max(1, |t|) [s].

Sample times are sums of floats (k·T), and so are arrival times (t + delay):
without this tolerance a delay of exactly three samples could land a rounding
error after the third sample and be seen one sample late."""

Sender = int | str
"""A sender: a vehicle index (0-based) or :data:`REFERENCE`."""

Link = tuple[int, Sender]
"""A link ``(receiver, sender)``: the receiver hears the sender."""

_DELIVERED, _LOST, _BLOCKED = 0, 1, 2


# -- settings ---------------------------------------------------------------------------------


def _integral(value: Any) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


class LinksRule(Rule):
    """``"all"``, or a non-empty array of distinct ``[receiver, sender]`` pairs.

    Receivers are vehicle indices (from 0); a sender is a vehicle index or
    ``"reference"``. With the number of vehicles in the validation context
    (``n_vehicles``) the indices are checked against the train.
    """

    def want(self, *, python: bool = False) -> str:
        """What a valid value is."""
        return ("'all' or a non-empty array of [receiver, sender] pairs (vehicle indices "
                "from 0; sender 'reference' for the reference)")

    def doc_type(self) -> str:
        """The type column of the documentation."""
        return '`"all"` or array of `[receiver, sender]` pairs'

    def schema(self, handler: Any) -> CoreSchema:
        """Anything; :meth:`check` does the work."""
        return core_schema.any_schema()

    def check(self, value: Any, info: ValidationInfo | None) -> Any:
        """The pairs as a tuple of tuples (``"all"`` as is)."""
        if value == "all":
            return "all"
        if not isinstance(value, list | tuple) or not value:
            raise fail(Violation(text=f"must be {self.want()}", got=value))
        context = info.context if info is not None and isinstance(info.context, dict) else {}
        n = context.get("n_vehicles")
        pairs: list[Link] = []
        for k, pair in enumerate(value):
            if not isinstance(pair, list | tuple) or len(pair) != 2:
                raise_at((k,), Violation(text="must be a [receiver, sender] pair", got=pair,
                                         hint=" Write e.g. [1, 0]: vehicle 1 hears vehicle 0."),
                         pair)
            receiver = int(_vehicle_index((k, 0), pair[0], n, "receiver", reference=False))
            sender = _vehicle_index((k, 1), pair[1], n, "sender", reference=True)
            if receiver == sender:
                raise_at((k,), Violation(
                    text="must join two different vehicles", got=list(pair),
                    hint=" No vehicle hears itself."), pair)
            if (receiver, sender) in pairs:
                raise_at((k,), Violation(
                    text="must not repeat an earlier pair", got_text=f"{list(pair)} again",
                    hint=" List each link once."), pair)
            pairs.append((receiver, sender))
        return tuple(pairs)

    def json_extra(self) -> dict[str, Any]:
        """``"all"`` or an array of pairs."""
        index = {"type": "integer", "minimum": 0}
        pair = {"type": "array", "minItems": 2, "maxItems": 2,
                "prefixItems": [index, {"anyOf": [index, {"const": REFERENCE}]}]}
        return {"anyOf": [{"const": "all"}, {"type": "array", "minItems": 1, "items": pair}]}


def _vehicle_index(loc: tuple[int, int], value: Any, n: int | None, role: str, *,
                   reference: bool) -> Sender:
    """A receiver's or sender's index, checked (against ``n`` vehicles when known)."""
    if reference and value == REFERENCE:
        return REFERENCE
    span = f"from 0 to {n - 1}" if n is not None else ">= 0"
    want = f"the {role}: a vehicle index {span}" + (" or 'reference'" if reference else "")
    train = f" The train has {n} vehicle{'s' if n != 1 else ''}, numbered from 0." \
        if n is not None else ""
    if not _integral(value) or value < 0 or (n is not None and value >= n):
        hint = train if _integral(value) else (
            " The reference only sends; it is never a receiver." if value == REFERENCE
            else train)
        raise_at(loc, Violation(text=f"must be {want}", got=value, hint=hint),
                 value)
    return int(value)


_LINKS = LinksRule()
_LINKS_ADAPTER: TypeAdapter[Any] = TypeAdapter(Annotated[Any, _LINKS])
_TIME = Number(ge=0)
_DELAY = Number(ge=0)
_NOISE = Number(ge=0)


class ProbabilityRule(Rule):
    """A probability in [0, 1): a number >= 0 and < 1."""

    def want(self, *, python: bool = False) -> str:
        """``"a number in [0, 1)"``."""
        return f"a {'finite ' if python else ''}number in [0, 1)"

    def schema(self, handler: Any) -> CoreSchema:
        """Strict float in [0, 1); integers widen."""
        number = core_schema.float_schema(ge=0.0, lt=1.0, strict=True, allow_inf_nan=False)
        return core_schema.no_info_before_validator_function(
            lambda v: float(v) if _integral(v) else v, number)

    def explain(self, error_type: str, value: Any) -> Violation:
        """Out of [0, 1) or not a number; 1 gets a hint."""
        violation = super().explain(error_type, value)
        if error_type == "less_than":
            return Violation(text=violation.text, python_text=violation.python_text, got=value,
                             hint=" A link that loses every message is no link: use an "
                             "interruption window for an outage.")
        return violation


@settings
class Interruption:
    """An outage window: links that carry nothing over ``[start, end)``.

    A message is blocked when the link is down at any moment of its transit
    (``t_sent < end`` and ``t_arrival >= start``).

    Parameters
    ----------
    start : float
        Start of the outage [s], >= 0.
    end : float
        End of the outage [s], > ``start``; the window is ``[start, end)``.
    links : "all" or tuple of (int, int or str)
        ``"all"``: every link, the reference's included; else the blocked
        links as ``(receiver, sender)`` pairs, vehicles numbered from 0 head
        first, sender ``"reference"`` for the reference. A pair that is not
        a link of the graph blocks nothing.

    Examples
    --------
    >>> Interruption(start=100.0, end=130.0, links=[[1, 0], [0, "reference"]]).links
    ((1, 0), (0, 'reference'))
    >>> Interruption(start=5.0, end=4.0)
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: Interruption: 'end' must be greater than 'start' = 5.0 s \
(got 4.0). The window is [start, end).
    """

    start: Annotated[float, _TIME, Key("Start of the outage", unit="s")]
    end: Annotated[float, _TIME, Key("End of the outage (> start): the window is [start, end)",
                                     unit="s")]
    links: Annotated[str | tuple[tuple[int, Sender], ...], _LINKS, Key(
        "Links cut: 'all', or [receiver, sender] pairs (vehicles from 0, head first; sender "
        "'reference' for the reference)")] = "all"

    @model_validator(mode="after")
    def _window(self) -> Interruption:
        if not self.end > self.start:
            raise_at(("end",), Violation(
                text=f"must be greater than {{start}} = {self.start!r} s", got=self.end,
                hint=" The window is [start, end)."), self.end)
        return self

    def blocks(self, link: Link) -> bool:
        """True when the window cuts ``link`` = ``(receiver, sender)``.

        Parameters
        ----------
        link : tuple of (int, int or str)
            ``(receiver, sender)``: the receiving vehicle (0-based) and the
            sending vehicle (0-based) or ``"reference"``.

        Returns
        -------
        bool
            True when :attr:`links` is ``"all"`` or lists ``link``; the times of
            the window are not considered.
        """
        return self.links == "all" or link in self.links


class WindowsRule(Rule):
    """One ``[network.interruption]`` table or an array of them, as Interruption objects."""

    model = Interruption

    def want(self, *, python: bool = False) -> str:
        """``"a table or an array of tables"`` (Python: a sequence of Interruption)."""
        if python:
            return "a sequence of Interruption objects (or of dicts with their fields)"
        return "a table or an array of tables (start, end, links)"

    def schema(self, handler: Any) -> CoreSchema:
        """Anything; :meth:`check` validates the windows."""
        return core_schema.any_schema()

    def check(self, value: Any, info: ValidationInfo | None) -> Any:
        """The windows as a tuple of :class:`Interruption`."""
        context = info.context if info is not None else None
        single = isinstance(value, dict | Interruption)
        if not single and not isinstance(value, list | tuple):
            raise fail(Violation(text=f"must be {self.want()}", got=value))
        items = [value] if single else list(value)
        for i, item in enumerate(items):
            unknown = [k for k in item if k not in _WINDOW_KEYS] if isinstance(item, dict) else []
            if unknown:  # worded as an unknown key of a table, with a suggestion
                loc = (unknown[0],) if single else (i, unknown[0])
                raise ValidationError.from_exception_data("Interruption", [InitErrorDetails(
                    type="extra_forbidden", loc=loc, input=item[unknown[0]])])
        if single:
            return (TypeAdapter(Interruption).validate_python(value, context=context),)
        return TypeAdapter(tuple[Interruption, ...]).validate_python(items, context=context)

    def json_extra(self) -> dict[str, Any]:
        """One window, or an array of windows."""
        table = TypeAdapter(Interruption).json_schema()
        return {"anyOf": [table, {"type": "array", "items": table}]}


_WINDOW_KEYS = ("start", "end", "links")
_WINDOWS = WindowsRule()


@settings
class NetworkSettings:
    """Delays, losses, noise and outages of the radio links between the vehicles.

    Give at most one of ``delay_s`` (constant) and ``delay_range_s``
    (uniform per message); with neither, messages arrive when sent.

    Parameters
    ----------
    delay_s : float or None
        Constant delay of every message [s], >= 0.
    delay_range_s : tuple of float or None
        ``(lo, hi)`` [s], 0 <= lo <= hi: each message's delay is drawn
        uniformly in [lo, hi].
    loss_probability : float
        Probability that a message is lost [-], 0 <= p < 1, independently per
        message.
    communication_noise_std : float
        Standard deviation of the Gaussian noise added to every transmitted
        value, in the value's unit (m/s for speeds), >= 0.
    reference_noise_std : float or None
        The same for the reference's messages (the broadcast command) [value's
        unit], >= 0; None: ``communication_noise_std``.
    interruptions : tuple of Interruption
        Outage windows (file: ``[[network.interruption]]``); none by default.

    Examples
    --------
    >>> s = NetworkSettings(delay_range_s=(0.0, 2.0), loss_probability=0.05,
    ...                     communication_noise_std=1.0)
    >>> s.delay_bounds(), s.noise_std("reference"), s.noise_std(2)
    ((0.0, 2.0), 1.0, 1.0)
    >>> NetworkSettings(delay_range_s=(2.0, 1.0))
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: NetworkSettings: 'delay_range_s' must be [lo, hi] with \
lo <= hi (got [2.0, 1.0]).
    """

    delay_s: Annotated[Annotated[float, _DELAY] | None, Key(
        "Constant delay of every message (not with delay_range_s)", unit="s",
        omitted="no delay, or delay_range_s")] = None
    delay_range_s: Annotated[Annotated[tuple[float, ...], Array(_DELAY, length=2)] | None, Key(
        "Delay drawn uniformly in [lo, hi] for each message (not with delay_s)", unit="s",
        omitted="the constant delay_s")] = None
    loss_probability: Annotated[float, ProbabilityRule(), Key(
        "Probability that a message is lost, independently per message")] = 0.0
    communication_noise_std: Annotated[float, _NOISE, Key(
        "Standard deviation of the Gaussian noise added to every transmitted value",
        unit="value's unit, m/s for speeds")] = 0.0
    reference_noise_std: Annotated[Annotated[float, _NOISE] | None, Key(
        "Standard deviation of the noise on the reference's messages",
        unit="value's unit, m/s for speeds", omitted="communication_noise_std")] = None
    interruptions: Annotated[tuple[Interruption, ...], _WINDOWS, Key(
        "Outage windows: nothing sent or arriving on their links while they last",
        file="interruption", omitted="no outage")] = ()

    @model_validator(mode="after")
    def _delays(self) -> NetworkSettings:
        if self.delay_s is not None and self.delay_range_s is not None:
            raise_at(("delay_range_s",), Violation(
                text="cannot be combined with {delay_s}",
                got_text=f"delay_s = {self.delay_s!r} and delay_range_s = "
                f"{list(self.delay_range_s)!r}",
                hint=" Give a constant delay_s or a random delay_range_s = [lo, hi], not both.",
                value=False))
        if self.delay_range_s is not None:
            lo, hi = self.delay_range_s
            if lo > hi:
                raise_at(("delay_range_s",), Violation(
                    text="must be [lo, hi] with lo <= hi", got_text=f"[{lo!r}, {hi!r}]"),
                    self.delay_range_s)
        return self

    def delay_bounds(self) -> tuple[float, float]:
        """The delay range ``(lo, hi)`` [s]: equal bounds for a constant delay.

        Returns
        -------
        tuple of float
            ``delay_range_s`` when given; else ``(delay_s, delay_s)``, or
            ``(0.0, 0.0)`` without a delay [s].
        """
        if self.delay_range_s is not None:
            return float(self.delay_range_s[0]), float(self.delay_range_s[1])
        delay = 0.0 if self.delay_s is None else float(self.delay_s)
        return delay, delay

    def noise_std(self, sender: Sender) -> float:
        """The noise standard deviation on ``sender``'s messages [value's unit].

        Parameters
        ----------
        sender : int or str
            A vehicle index (0-based) or ``"reference"``.

        Returns
        -------
        float
            ``reference_noise_std`` for the reference when it is given, else
            ``communication_noise_std`` [value's unit, m/s for speeds].
        """
        if sender == REFERENCE and self.reference_noise_std is not None:
            return float(self.reference_noise_std)
        return float(self.communication_noise_std)

    def check_vehicles(self, n: int) -> None:
        """Check the interruption links against a formation of ``n`` vehicles.

        Parameters
        ----------
        n : int
            Vehicles [-], >= 1.

        Raises
        ------
        ModelError
            If a link names a vehicle index outside 0 .. n-1.

        Examples
        --------
        >>> NetworkSettings(interruptions=[Interruption(start=0.0, end=1.0, links=[[4, 0]])]
        ...                 ).check_vehicles(4)
        Traceback (most recent call last):
        ...
        trainctl.exceptions.ModelError: NetworkSettings: 'interruptions'[0]['links'][0][0] \
must be the receiver: a vehicle index from 0 to 3 (got 4). The train has 4 vehicles, \
numbered from 0.
        """
        for w, window in enumerate(self.interruptions):
            try:
                _LINKS_ADAPTER.validate_python(window.links, context={"n_vehicles": int(n)})
            except ValidationError as exc:
                raise python_error("NetworkSettings", exc,
                                   prefix=("interruptions", w, "links")) from None


# -- the network ------------------------------------------------------------------------------


class Received(NamedTuple):
    """The newest message a receiver holds from one sender.

    Parameters
    ----------
    t_sent : float
        When the sender sent it [s]: its age at time t is ``t - t_sent``.
    value : float or ndarray
        The value received, noise included (a float for scalar values).

    Examples
    --------
    With a constant 1 s delay, vehicle 1 holds nothing from vehicle 0 until
    the message sent at t = 0 arrives:

    >>> from trainctl.models.graphs import make_graph
    >>> net = Network(NetworkSettings(delay_s=1.0), make_graph("predecessor", 2, pinned="none"))
    >>> net.send(0.0, 0, 15.0)
    >>> net.receive(0.5, 1)
    {}
    >>> got = net.receive(1.5, 1)[0]
    >>> got, 1.5 - got.t_sent  # the value [m/s] and its age [s]
    (Received(t_sent=0.0, value=15.0), 1.5)
    """

    t_sent: float
    value: float | NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class MessageLog:
    """Every message of a run, in send order (one row per receiver of each send).

    Parameters
    ----------
    t_sent : ndarray
        Send times [s], shape (m,).
    delay : ndarray
        Drawn delays [s], shape (m,) (drawn for lost and blocked messages too).
    t_arrival : ndarray
        Arrival times ``t_sent + delay`` [s] of delivered messages, NaN for
        lost or blocked ones, shape (m,).
    receiver : ndarray
        Receiving vehicle (0-based), int, shape (m,).
    sender : tuple of int or str
        Sending vehicle (0-based) or :data:`REFERENCE`, length m.
    fate : ndarray
        One of :data:`FATES` per message, shape (m,).
    sent : ndarray
        Value sent, shape (m, ``*value_shape``).
    delivered : ndarray
        Value delivered (sent plus noise), NaN for lost or blocked messages,
        shape (m, ``*value_shape``).
    noise : ndarray
        Noise drawn (standard deviation times z), shape (m, ``*value_shape``).

    Examples
    --------
    Vehicle 1 hears vehicle 0 with a 1 s delay; the link is cut over
    [0.5, 1.5) s, so the message sent at 0 s (due at 1 s) and the one sent at
    1 s are blocked, the one sent at 2 s arrives at 3 s.

    >>> from trainctl.models.graphs import make_graph
    >>> cut = Interruption(start=0.5, end=1.5, links=[[1, 0]])
    >>> net = Network(NetworkSettings(delay_s=1.0, interruptions=[cut]),
    ...               make_graph("predecessor", 2, pinned="none"))
    >>> for t in (0.0, 1.0, 2.0):
    ...     net.send_all(t, [15.0 + t, 14.0])
    >>> log = net.history()
    >>> len(log), log.fate.tolist(), log.t_arrival.tolist()
    (3, ['blocked', 'blocked', 'delivered'], [nan, nan, 3.0])
    >>> log.rows()[2]["delivered"], log.sender  # vehicle 0's speed [m/s]
    (17.0, (0, 0, 0))
    """

    t_sent: NDArray[np.float64]
    delay: NDArray[np.float64]
    t_arrival: NDArray[np.float64]
    receiver: NDArray[np.int64]
    sender: tuple[Sender, ...]
    fate: NDArray[np.str_]
    sent: NDArray[np.float64]
    delivered: NDArray[np.float64]
    noise: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.t_sent.size)

    def held_noise_square(self, times: ArrayLike) -> NDArray[np.float64]:
        """Σ over the links of the squared noise of the message each receiver holds at ``times``.

        At time t a link's receiver holds the newest delivered message (by
        send time) that has arrived by t (within :data:`ARRIVAL_TOLERANCE`),
        as :meth:`Network.receive` gives it; a link with nothing yet adds 0.
        With a controller reading the network at samples t_k and holding
        what it read until t_{k+1}, Δt·Σ_k of this is the energy ∫‖w(t)‖² dt
        of the noise it acted on (components summed for vector values).

        Parameters
        ----------
        times : array_like
            Times [s], shape (K,).

        Returns
        -------
        ndarray
            Shape (K,), in the values' unit squared.

        Examples
        --------
        >>> from trainctl.models.graphs import make_graph
        >>> net = Network(NetworkSettings(delay_s=1.0, communication_noise_std=0.1),
        ...               make_graph("predecessor", 2, pinned="none"), seed=0)
        >>> for k in range(3):
        ...     net.send_all(float(k), [0.0, 0.0])
        >>> log = net.history()
        >>> n = log.noise[log.fate == "delivered"].ravel()
        >>> bool(np.allclose(log.held_noise_square([0.5, 1.0, 2.5]), [0.0, n[0]**2, n[1]**2]))
        True
        """
        t = np.atleast_1d(np.asarray(times, dtype=float))
        out = np.zeros(t.size)
        delivered = np.flatnonzero(self.fate == "delivered")
        if delivered.size == 0:
            return out
        square = np.sum(self.noise.reshape(len(self), -1) ** 2, axis=1)
        due = t + ARRIVAL_TOLERANCE * np.maximum(1.0, np.abs(t))
        links: dict[tuple[int, Sender], list[int]] = {}
        for m in delivered.tolist():
            links.setdefault((int(self.receiver[m]), self.sender[m]), []).append(m)
        for members in links.values():
            idx = np.asarray(members)
            idx = idx[np.argsort(self.t_arrival[idx], kind="stable")]
            sent = self.t_sent[idx]
            # the newest send time among the messages arrived so far, and which one it is
            newest = np.maximum.accumulate(np.where(sent >= np.maximum.accumulate(sent),
                                                    np.arange(idx.size), 0))
            k = np.searchsorted(self.t_arrival[idx], due, side="right") - 1
            has = k >= 0
            out[has] += square[idx[newest[k[has]]]]
        return out

    def rows(self) -> list[dict[str, Any]]:
        """The messages as JSON-safe dicts; ``t_arrival`` and ``delivered`` None when dropped.

        Returns
        -------
        list of dict
            Keys ``t_sent``, ``t_arrival``, ``delay``, ``receiver``, ``sender``,
            ``fate``, ``sent``, ``delivered`` (values as floats or lists).
        """
        out = []
        for k in range(len(self)):
            dropped = self.fate[k] != "delivered"
            out.append({
                "t_sent": float(self.t_sent[k]),
                "t_arrival": None if dropped else float(self.t_arrival[k]),
                "delay": float(self.delay[k]),
                "receiver": int(self.receiver[k]),
                "sender": self.sender[k],
                "fate": str(self.fate[k]),
                "sent": self.sent[k].tolist(),
                "delivered": None if dropped else self.delivered[k].tolist(),
            })
        return out


@dataclass
class _Batch:
    """The messages of one send, kept as arrays until :meth:`Network.history`."""

    t: float
    sender: Sender
    receivers: NDArray[np.int64]
    delay: NDArray[np.float64]
    fate: NDArray[np.int8]
    value: NDArray[np.float64]
    noise: NDArray[np.float64]


class Network:
    """The radio links of a formation: delays, losses, outages, noise, hold-last-value.

    Parameters
    ----------
    settings : NetworkSettings
        Delays, losses, noise and outage windows.
    graph : CommunicationGraph
        Who hears whom (``adjacency[i, j] > 0``: i hears j) and who hears the
        reference (``pinning[i] > 0``).
    seed : int or numpy.random.SeedSequence
        Seed of the generator ``numpy.random.default_rng(seed)`` (module
        docstring: the order of the draws); :meth:`reset` starts it again.

    Raises
    ------
    ModelError
        If an interruption names a vehicle the graph does not have, or the
        seed is not an int >= 0 or a SeedSequence.

    Examples
    --------
    >>> from trainctl.models.graphs import make_graph
    >>> net = Network(NetworkSettings(), make_graph("bidirectional", 2, pinned="none"))
    >>> net.send(0.0, 0, 15.0)
    >>> net.receive(0.0, 1), net.receive(0.0, 0)
    ({0: Received(t_sent=0.0, value=15.0)}, {})
    """

    def __init__(self, settings: NetworkSettings, graph: CommunicationGraph, *,
                 seed: int | np.random.SeedSequence = 0) -> None:
        if not isinstance(settings, NetworkSettings):
            raise ModelError(f"Network: 'settings' must be a NetworkSettings (got "
                             f"{type(settings).__name__}).")
        if not isinstance(graph, CommunicationGraph):
            raise ModelError("Network: 'graph' must be a trainctl.models.graphs.CommunicationGraph "
                             f"(got {type(graph).__name__}).")
        if not isinstance(seed, np.random.SeedSequence) and (not _integral(seed) or seed < 0):
            raise ModelError(f"Network: 'seed' must be an int >= 0 or a "
                             f"numpy.random.SeedSequence (got {seed!r}).")
        settings.check_vehicles(graph.n)
        self.settings = settings
        self.graph = graph
        self.seed = seed
        n = graph.n
        hears = graph.adjacency > 0
        self._receivers: dict[Sender, NDArray[np.int64]] = {
            REFERENCE: np.flatnonzero(graph.pinning > 0).astype(np.int64)}
        for j in range(n):
            self._receivers[j] = np.flatnonzero(hears[:, j]).astype(np.int64)
        self._senders: list[tuple[Sender, ...]] = [
            ((REFERENCE,) if graph.pinning[i] > 0 else ()) + tuple(
                int(j) for j in np.flatnonzero(hears[i])) for i in range(n)]
        self._windows: dict[Link, tuple[tuple[float, float], ...]] = {
            link: tuple((w.start, w.end) for w in settings.interruptions if w.blocks(link))
            for link in self.links}
        # Per sender, its links in receiver order with their outage windows, and its noise.
        self._fanout: dict[Sender, tuple[tuple[Link, tuple[tuple[float, float], ...]], ...]] = {
            sender: tuple(((int(i), sender), self._windows[(int(i), sender)])
                          for i in receivers)
            for sender, receivers in self._receivers.items()}
        self._noise_std = {sender: float(settings.noise_std(sender))
                           for sender in self._receivers}
        self._lo, self._hi = settings.delay_bounds()
        self._loss = float(settings.loss_probability)
        self.reset()

    @property
    def n(self) -> int:
        """Number of vehicles [-]."""
        return self.graph.n

    @property
    def links(self) -> tuple[Link, ...]:
        """Every link ``(receiver, sender)``, by receiver, the reference first."""
        return tuple((i, s) for i in range(self.n) for s in self._senders[i])

    def senders(self, receiver: int) -> tuple[Sender, ...]:
        """The senders ``receiver`` hears: the reference first (when pinned), then vehicles.

        Parameters
        ----------
        receiver : int
            The receiving vehicle, 0-based: 0 <= receiver < n.

        Returns
        -------
        tuple of int or str
            ``"reference"`` when the receiver is pinned, then the 0-based
            indices of the vehicles it hears, ascending.

        Raises
        ------
        ModelError
            If ``receiver`` is not a vehicle index from 0 to n-1.
        """
        return self._senders[self._check_receiver(receiver)]

    def reset(self) -> None:
        """Forget every message and restart the generator from the seed."""
        self._rng = np.random.default_rng(self.seed)
        self._clock = -math.inf
        self._shape: tuple[int, ...] | None = None
        self._seq = 0
        self._pending: dict[Link, list[tuple[float, float, int, Any]]] = {
            link: [] for link in self.links}
        self._held: dict[Link, tuple[float, int, Received]] = {}
        self._batches: list[_Batch] = []

    def send(self, t: float, sender: Sender, value: ArrayLike) -> None:
        """Broadcast ``value`` at time ``t`` to every vehicle that hears ``sender``.

        Parameters
        ----------
        t : float
            Send time [s], finite, >= the time of the previous call.
        sender : int or str
            A vehicle index (0-based) or :data:`REFERENCE`.
        value : float or array_like
            The value sent (e.g. a speed [m/s]), finite; every value of a
            network has the same shape.

        Raises
        ------
        ModelError
            For an unknown sender, a time earlier than the previous call's,
            or a value that is not finite.
        DimensionError
            If the value's shape differs from the first value sent.
        """
        t = self._advance("send", t)
        self._emit(t, self._check_sender(sender), self._check_value(value))

    def _emit(self, t: float, sender: Sender, x: NDArray[np.float64]) -> None:
        """:meth:`send` after its checks (``x`` read-only, of the network's value shape)."""
        receivers = self._receivers[sender]
        k = receivers.size
        if k == 0:
            return
        u = self._rng.random((k, 2))
        z = self._rng.standard_normal((k, *x.shape))
        delay = self._lo + (self._hi - self._lo) * u[:, 0]
        noise = self._noise_std[sender] * z
        fate = np.where(u[:, 1] < self._loss, _LOST, _DELIVERED).astype(np.int8)
        scalar = x.ndim == 0
        delivered = x + noise
        for m, (link, windows) in enumerate(self._fanout[sender]):
            arrival = t + float(delay[m])
            if windows and any(t < end and arrival >= start for start, end in windows):
                fate[m] = _BLOCKED
            if fate[m] == _DELIVERED:
                item = float(delivered[m]) if scalar else delivered[m]
                heapq.heappush(self._pending[link], (arrival, t, self._seq, item))
            self._seq += 1
        self._batches.append(_Batch(t, sender, receivers, delay, fate, x, noise))

    def send_all(self, t: float, values: ArrayLike, *, reference: ArrayLike | None = None) -> None:
        """Send the reference's value (if given), then each vehicle's, at time ``t``.

        Parameters
        ----------
        t : float
            Send time [s].
        values : array_like
            One value per vehicle, head first: shape (n, ``*value_shape``).
        reference : float or array_like or None
            The reference's value; None: the reference sends nothing.

        Raises
        ------
        DimensionError
            If ``values`` does not hold one value per vehicle.
        """
        array = np.asarray(values, dtype=float)
        if array.ndim < 1 or array.shape[0] != self.n:
            raise DimensionError(f"Network.send_all: 'values' must hold one value per vehicle, "
                                 f"shape ({self.n}, ...) (got shape {array.shape}).")
        # The time and every value checked once, before anything is sent; then each
        # sender's messages, with the draws n + 1 calls of send would make.
        t = self._advance("send", t)
        shape = self._shape
        try:
            first = None if reference is None else self._check_value(reference)
            self._check_value(array[0])
            bad = ~np.isfinite(array.reshape(self.n, -1)).all(axis=1)
            if bad.any():
                j = int(np.argmax(bad))
                raise ModelError(f"Network.send_all: 'values' must be finite (got "
                                 f"{array[j].tolist()!r} for vehicle {j}); nothing was sent.")
        except (ModelError, DimensionError):
            self._shape = shape   # nothing was sent: the first value is still to come
            raise
        if first is not None:
            self._emit(t, REFERENCE, first)
        rows = array.copy()
        rows.setflags(write=False)
        for j in range(self.n):
            self._emit(t, j, rows[j, ...])

    def receive(self, t: float, receiver: int) -> dict[Sender, Received]:
        """The newest message from each sender ``receiver`` hears, arrived by ``t``.

        Parameters
        ----------
        t : float
            Time [s], >= the time of the previous call.
        receiver : int
            Receiving vehicle (0-based).

        Returns
        -------
        dict
            Sender → :class:`Received` ``(t_sent, value)``: the newest by send
            time among the messages arrived by t (held while nothing newer
            arrives); senders with no arrival yet are absent. The reference
            first, then vehicles in index order.
        """
        t = self._advance("receive", t)
        i = self._check_receiver(receiver)
        return self._collect(i, t + ARRIVAL_TOLERANCE * max(1.0, abs(t)))

    def _collect(self, i: int, due: float) -> dict[Sender, Received]:
        """:meth:`receive` after its checks: what receiver ``i`` holds at arrival time ``due``."""
        out: dict[Sender, Received] = {}
        for sender in self._senders[i]:
            link = (i, sender)
            queue = self._pending[link]
            held = self._held.get(link)
            while queue and queue[0][0] <= due:
                _, t_sent, seq, value = heapq.heappop(queue)
                if held is None or (t_sent, seq) > held[:2]:
                    held = (t_sent, seq, Received(t_sent, value))
            if held is not None:
                self._held[link] = held
                out[sender] = held[2]
        return out

    def messages(self, t: float) -> dict[Link, Received]:
        """What every vehicle holds at ``t``: ``{(receiver, sender): Received}``.

        The form of :attr:`trainctl.controllers.base.Measurement.messages`.

        Parameters
        ----------
        t : float
            Time [s], >= the time of the previous call.

        Returns
        -------
        dict
            ``(receiver, sender)`` → :class:`Received`, receivers in order.
        """
        t = self._advance("receive", t)
        due = t + ARRIVAL_TOLERANCE * max(1.0, abs(t))
        return {(i, s): msg for i in range(self.n) for s, msg in self._collect(i, due).items()}

    def history(self) -> MessageLog:
        """Every message sent since the last :meth:`reset`, in send order.

        Returns
        -------
        MessageLog
            Send and arrival times, delays, links, fates, values sent and
            delivered, noise.
        """
        shape = self._shape or ()
        batches = self._batches
        if not batches:
            empty = np.zeros(0)
            return MessageLog(empty, empty, empty, np.zeros(0, dtype=np.int64), (),
                              np.zeros(0, dtype="<U9"), np.zeros((0, *shape)),
                              np.zeros((0, *shape)), np.zeros((0, *shape)))
        counts = np.fromiter((b.receivers.size for b in batches), dtype=np.int64,
                             count=len(batches))
        t_sent = np.repeat(np.fromiter((b.t for b in batches), dtype=float, count=len(batches)),
                           counts)
        delay = np.concatenate([b.delay for b in batches])
        codes = np.concatenate([b.fate for b in batches])
        sent = np.repeat(np.stack([b.value for b in batches]), counts, axis=0)
        noise = np.concatenate([b.noise for b in batches])
        delivered_mask = codes == _DELIVERED
        t_arrival = np.where(delivered_mask, t_sent + delay, np.nan)
        mask = delivered_mask.reshape((-1,) + (1,) * len(shape))
        delivered = np.where(mask, sent + noise, np.nan)
        return MessageLog(
            t_sent=t_sent, delay=delay, t_arrival=t_arrival,
            receiver=np.concatenate([b.receivers for b in batches]),
            sender=tuple(np.repeat(np.array([b.sender for b in batches], dtype=object),
                                   counts).tolist()),
            fate=np.asarray(FATES)[codes], sent=sent, delivered=delivered, noise=noise)

    # -- checks ------------------------------------------------------------------------------

    def _advance(self, where: str, t: float) -> float:
        if isinstance(t, bool) or not isinstance(t, numbers.Real) or not math.isfinite(t):
            raise ModelError(f"Network.{where}: 't' must be a finite number (got {t!r}).")
        t = float(t)
        if t < self._clock:
            raise ModelError(f"Network.{where}: 't' must not go back in time: at least the "
                             f"previous call's {self._clock!r} s (got {t!r} s). Call reset() "
                             "to start again.")
        self._clock = t
        return t

    def _check_sender(self, sender: Sender) -> Sender:
        if sender == REFERENCE:
            return REFERENCE
        if not _integral(sender) or not 0 <= int(sender) < self.n:
            raise ModelError(f"Network: 'sender' must be a vehicle index from 0 to {self.n - 1} "
                             f"or {REFERENCE!r} (got {sender!r}).")
        return int(sender)

    def _check_receiver(self, receiver: int) -> int:
        if not _integral(receiver) or not 0 <= int(receiver) < self.n:
            raise ModelError(f"Network: 'receiver' must be a vehicle index from 0 to "
                             f"{self.n - 1} (got {receiver!r}).")
        return int(receiver)

    def _check_value(self, value: ArrayLike) -> NDArray[np.float64]:
        try:
            x = np.array(value, dtype=float)
        except (TypeError, ValueError):
            raise ModelError(f"Network.send: 'value' must be a number or an array of numbers "
                             f"(got {value!r}).") from None
        if not np.all(np.isfinite(x)):
            raise ModelError(f"Network.send: 'value' must be finite (got {value!r}).")
        if self._shape is None:
            self._shape = x.shape
        elif x.shape != self._shape:
            raise DimensionError(f"Network.send: every value must have the shape of the first "
                                 f"one sent, {self._shape} (got {x.shape}).")
        x.setflags(write=False)
        return x

