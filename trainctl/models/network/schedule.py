# A network's whole run laid out in advance: every draw, and what each link holds at each read.
"""What a :class:`~trainctl.models.network.Network` does over a run whose sends and reads
happen at known times, computed before the run (for batched simulation).

A network's draws (delay, loss, noise) and the fate of every message depend
only on the seed, the send times and the senders, never on the values sent
(:mod:`trainctl.models.network`). So when every sender in a fixed order sends
once at each time t_k and every link is read right after (the closed loop's
``send_all`` then ``messages``), :func:`plan` can make the draws the network
would make, in the same order from the same generator, and find for every
link and read k which message it then holds: the newest by (send time,
sequence number) among those delivered and arrived by t_k (within
:data:`~trainctl.models.network.simulator.ARRIVAL_TOLERANCE`), exactly as
:meth:`Network.receive` would. The values are filled in during the run
(:meth:`Plan.held`); :meth:`Plan.history` gives the
:class:`~trainctl.models.network.simulator.MessageLog` the network would have
kept, array for array.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trainctl.models.network._draws import draws, draws_by_calls
from trainctl.models.network.schema import Link, Sender
from trainctl.models.network.simulator import (
    _BLOCKED,
    _DELIVERED,
    _LOST,
    ARRIVAL_TOLERANCE,
    FATES,
    MessageLog,
    Network,
)

__all__ = ["Plan", "plan"]

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Plan:
    """A network's run: the draws per send and what each link holds at each read.

    Parameters
    ----------
    times : ndarray
        The send (and read) times t_k [s], shape (K,).
    senders : tuple
        The senders, in the order they send at each time.
    links : tuple of Link
        Every (receiver, sender) link, in the network's fanout order: sender
        by sender, receivers ascending.
    delay, noise : ndarray
        Shape (K, L): the delay [s] and noise drawn for link l's message sent at t_k.
    fate : ndarray of int8
        Shape (K, L): delivered, lost or blocked.
    source : ndarray of int
        Shape (K, L): the send index k' of the message link l holds at read
        k (-1: none yet).

    Examples
    --------
    With a constant 0.2 s delay, vehicle 1 holds at each sample vehicle 0's
    value of two samples (0.1 s apart) before:

    >>> from trainctl.models.graphs import make_graph
    >>> from trainctl.models.network.schema import NetworkSettings
    >>> net = Network(NetworkSettings(delay_s=0.2), make_graph("predecessor", 2, pinned="none"))
    >>> p = plan(net, 0.1 * np.arange(4), (0,))
    >>> p.links, p.source[:, 0].tolist()
    (((1, 0),), [-1, -1, 0, 1])
    """

    times: Array
    senders: tuple[Sender, ...]
    links: tuple[Link, ...]
    delay: Array
    noise: Array
    fate: NDArray[np.int8]
    source: NDArray[np.int64]

    def held(self, k: int, sent: Array) -> tuple[Array, NDArray[np.bool_]]:
        """The values the links hold at read k, and which hold one.

        Parameters
        ----------
        k : int
            The read (and send) index.
        sent : ndarray
            Shape (K, L): per send and link, the value its sender sent (the
            values of sends after k are not read).

        Returns
        -------
        (ndarray, ndarray of bool)
            The values held, noise included (NaN where none), and where one
            is held, shape (L,) each.
        """
        src = self.source[k]
        has = src >= 0
        idx = np.where(has, src, 0)
        cols = np.arange(src.size)
        values = sent[idx, cols] + self.noise[idx, cols]
        return np.where(has, values, np.nan), has

    def held_noise_square(self) -> Array:
        """:meth:`MessageLog.held_noise_square` of the whole run at the read times.

        From :attr:`source`, with the same sums: link by link, in the order of
        each link's first delivered message, as the log groups them.

        Returns
        -------
        ndarray
            Shape (K,), in the values' unit squared.
        """
        K, L = self.source.shape
        out = np.zeros(K)
        delivered = self.fate == _DELIVERED
        some = np.flatnonzero(delivered.any(axis=0))
        first = np.argmax(delivered[:, some], axis=0) * L + some
        square = self.noise**2
        for m in some[np.argsort(first)].tolist():
            src = self.source[:, m]
            has = src >= 0
            out[has] += square[src[has], m]
        return out

    def counts(self) -> dict[str, float]:
        """``meta["network"]`` of :func:`trainctl.sim.simulate` for the whole run.

        Returns
        -------
        dict
            The messages per fate (:data:`FATES`) and ``noise_square_sum``,
            Σ n² over the delivered ones, summed in the log's order.
        """
        codes = self.fate.ravel()
        out: dict[str, float] = {fate: int(np.count_nonzero(codes == code))
                                 for code, fate in enumerate(FATES)}
        out["noise_square_sum"] = float(np.sum(self.noise.ravel()[codes == _DELIVERED] ** 2))
        return out

    def history(self, done: int, sent: Array) -> MessageLog:
        """The :class:`MessageLog` of the first sends, as :meth:`Network.history` has it.

        Parameters
        ----------
        done : int
            How many sends (times) were made.
        sent : ndarray
            Shape (K, L): the value of each send, per link (a sender's value
            repeated over its links).

        Returns
        -------
        MessageLog
        """
        if done == 0 or not self.links:
            empty = np.zeros(0)
            return MessageLog(empty, empty, empty, np.zeros(0, dtype=np.int64), (),
                              np.zeros(0, dtype="<U9"), np.zeros(0), np.zeros(0), np.zeros(0))
        t_sent = np.repeat(self.times[:done], len(self.links))
        delay = self.delay[:done].ravel()
        codes = self.fate[:done].ravel()
        values = sent[:done].ravel()
        noise = self.noise[:done].ravel()
        delivered_mask = codes == _DELIVERED
        t_arrival = np.where(delivered_mask, t_sent + delay, np.nan)
        delivered = np.where(delivered_mask, values + noise, np.nan)
        receiver = np.tile(np.array([i for i, _ in self.links], dtype=np.int64), done)
        sender = tuple(s for _ in range(done) for _, s in self.links)
        return MessageLog(t_sent=t_sent, delay=delay, t_arrival=t_arrival, receiver=receiver,
                          sender=sender, fate=np.asarray(FATES)[codes], sent=values,
                          delivered=delivered, noise=noise)


def plan(network: Network, times: Array, senders: Sequence[Sender]) -> Plan:
    """The run of ``network`` (from its seed) when ``senders`` send at every time, then it is read.

    Parameters
    ----------
    network : Network
        The network (its settings, graph and seed; its own state is not touched).
    times : ndarray
        Send times t_k [s], increasing, shape (K,); each is also a read time.
    senders : sequence of int or str
        The senders, in their order at each time (``send_all``: the
        reference first, then every vehicle); scalar values only.

    Returns
    -------
    Plan

    Examples
    --------
    Every message of vehicle 0 to vehicle 1 lost or not, as the network draws it:

    >>> from trainctl.models.graphs import make_graph
    >>> from trainctl.models.network.schema import NetworkSettings
    >>> net = Network(NetworkSettings(loss_probability=0.5),
    ...               make_graph("predecessor", 2, pinned="none"), seed=1)
    >>> p = plan(net, np.arange(6.0), (0,))
    >>> for t in range(6):
    ...     net.send_all(float(t), [10.0 + t, 0.0])
    >>> bool(np.array_equal(np.asarray(FATES)[p.fate[:, 0]], net.history().fate))
    True
    """
    times = np.asarray(times, dtype=float)
    K = times.size
    fanouts = [network._fanout[s] for s in senders]
    widths = [len(f) for f in fanouts]
    links = tuple(link for f in fanouts for link, _ in f)
    L = len(links)
    # The draws in the network's order: per time, per sender u ~ U(w, 2), then z ~ N(w).
    drawn = draws(network.seed, widths, K)
    if drawn is None:
        drawn = draws_by_calls(np.random.default_rng(network.seed), widths, K)
    u, z = drawn
    assert u.shape == (K, L, 2)
    lo, hi = network._lo, network._hi
    delay = lo + (hi - lo) * u[:, :, 0]
    std = np.array([network._noise_std[s] for s, w in zip(senders, widths, strict=True)
                    for _ in range(w)])
    noise = std * z
    fate = np.where(u[:, :, 1] < network._loss, _LOST, _DELIVERED).astype(np.int8)
    arrival = times[:, None] + delay
    windows = [w for f in fanouts for _, w in f]
    for m, spans in enumerate(windows):
        for start, end in spans:
            fate[(times < end) & (arrival[:, m] >= start), m] = _BLOCKED
    due = times + ARRIVAL_TOLERANCE * np.maximum(1.0, np.abs(times))
    source = np.full((K, L), -1, dtype=np.int64)
    sends = np.arange(K, dtype=np.int64)
    for m in range(L):
        ok = fate[:, m] == _DELIVERED
        first = np.maximum(np.searchsorted(due, arrival[:, m], side="left"), sends)
        ok &= first < K
        newest = np.full(K, -1, dtype=np.int64)
        np.maximum.at(newest, first[ok], sends[ok])
        source[:, m] = np.maximum.accumulate(newest)
    return Plan(times=times, senders=tuple(senders), links=links, delay=delay, noise=noise,
                fate=fate, source=source)

