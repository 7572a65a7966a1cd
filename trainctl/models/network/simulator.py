# The radio network as a discrete-event simulator: messages sent, delayed, lost, received.
"""The discrete-event simulator of the network (:class:`Network`): every message with
its delay and fate, what each receiver holds, and the log of the messages
(:class:`MessageLog`).
"""

from __future__ import annotations

import heapq
import math
import numbers
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import DimensionError, ModelError
from trainctl.models.graphs import REFERENCE, CommunicationGraph
from trainctl.models.network.schema import Link, NetworkSettings, Sender, _integral

__all__ = ["ARRIVAL_TOLERANCE", "FATES", "MessageLog", "Network", "Received"]

FATES = ("delivered", "lost", "blocked")
"""What became of a message: it arrives, the radio lost it, an interruption blocked it."""

ARRIVAL_TOLERANCE = 1e-9
"""A message due at t_arrival has arrived by t when t_arrival <= t + 1e-9·max(1, |t|) [s].

Sample times are sums of floats (k·T), and so are arrival times (t + delay):
without this tolerance a delay of exactly three samples could land a rounding
error after the third sample and be seen one sample late."""

_DELIVERED, _LOST, _BLOCKED = 0, 1, 2


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

    >>> from trainctl.models.network.schema import Interruption
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
