# Connectivity of a communication graph over time: interruption windows and joint connectivity.
"""Which vehicles the reference reaches while links are interrupted, and whether it comes back.

A ``[network]`` section cuts links over interruption windows
(:class:`trainctl.models.network.Interruption`). Between the window edges the
graph in force is constant: :func:`graph_segments` splits ``[0, duration)``
there and gives each piece's graph (the scenario's graph without the links
cut then; a cut ``("reference")`` link removes that vehicle's pinning).
A consensus law keeps tracking over a piece whose graph has a directed
spanning tree rooted at the reference; over an outage that breaks it the
unreached vehicles drift, and tracking is restored only if the graph is
*jointly connected* afterwards: the union of the graphs over a dwell window
([0, T_dwell) after the outage, here the rest of the run) has such a tree
(spec §4.3 item 4). :func:`joint_connectivity` reports, per window, the
vehicles cut off during it and whether they are reached again before the
run ends.

Examples
--------
>>> from trainctl.models.graphs import make_graph
>>> from trainctl.models.network import Interruption
>>> g = make_graph("predecessor", 3, pinned="head")
>>> cut = [Interruption(start=10.0, end=20.0, links=[[1, 0]])]
>>> [(s.start, s.end, s.unreached) for s in graph_segments(g, cut, 60.0)]
[(0.0, 10.0, ()), (10.0, 20.0, (1, 2)), (20.0, 60.0, ())]
>>> joint_connectivity(g, cut, 60.0)[0].recovered
True
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from trainctl.exceptions import ModelError
from trainctl.models.graphs import REFERENCE, CommunicationGraph

if TYPE_CHECKING:
    from trainctl.models.network.schema import Interruption

__all__ = ["GraphSegment", "WindowConnectivity", "cut_graph", "graph_segments",
           "joint_connectivity", "union_graph"]


def cut_graph(graph: CommunicationGraph, windows: Sequence[Interruption]) -> CommunicationGraph:
    """The graph without every link that one of ``windows`` cuts.

    Parameters
    ----------
    graph : CommunicationGraph
        The full graph.
    windows : sequence of Interruption
        The windows in force.

    Returns
    -------
    CommunicationGraph
        Same vehicles; cut adjacency entries and pinnings set to 0.

    Examples
    --------
    >>> from trainctl.models.graphs import make_graph
    >>> from trainctl.models.network import Interruption
    >>> g = make_graph("predecessor", 3, pinned="head")
    >>> c = cut_graph(g, [Interruption(start=10.0, end=20.0, links=[[1, 0]])])
    >>> c.adjacency.tolist()  # only vehicle 2 still hears vehicle 1
    [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    >>> c.unreached()  # vehicle 1 lost its only source, and 2 hears only 1
    (1, 2)
    """
    a = np.array(graph.adjacency, dtype=float)
    p = np.array(graph.pinning, dtype=float)
    for w in windows:
        if isinstance(w.links, str):  # "all"
            a[:] = 0.0
            p[:] = 0.0
            continue
        for receiver, sender in w.links:
            if not 0 <= int(receiver) < graph.n:
                continue
            if sender == REFERENCE:
                p[int(receiver)] = 0.0
            elif isinstance(sender, int | np.integer) and 0 <= int(sender) < graph.n:
                a[int(receiver), int(sender)] = 0.0
    return CommunicationGraph(a, p, topology=f"{graph.topology} (cut)")


def union_graph(graphs: Sequence[CommunicationGraph]) -> CommunicationGraph:
    """The union of graphs on the same vehicles: the largest weight of each link and pinning.

    Parameters
    ----------
    graphs : sequence of CommunicationGraph
        At least one, all on n vehicles.

    Returns
    -------
    CommunicationGraph
        Links present in any of them.

    Examples
    --------
    Cutting the 1 → 0 link in one graph and the reference pinning in the
    other: the union has every link back.

    >>> from trainctl.models.graphs import make_graph
    >>> from trainctl.models.network import Interruption
    >>> g = make_graph("predecessor", 3, pinned="head")
    >>> a = cut_graph(g, [Interruption(start=0.0, end=1.0, links=[[1, 0]])])
    >>> b = cut_graph(g, [Interruption(start=0.0, end=1.0, links=[[0, "reference"]])])
    >>> a.reference_reaches_all(), b.reference_reaches_all()
    (False, False)
    >>> u = union_graph([a, b])
    >>> u.pinning.tolist(), u.reference_reaches_all()
    ([1.0, 0.0, 0.0], True)
    """
    if not graphs:
        raise ModelError("union_graph: 'graphs' must hold at least one graph (got none).")
    n = graphs[0].n
    if any(g.n != n for g in graphs):
        raise ModelError(f"union_graph: every graph must have {n} vehicles (got "
                         f"{[g.n for g in graphs]}).")
    a = np.max([np.asarray(g.adjacency, dtype=float) for g in graphs], axis=0)
    p = np.max([np.asarray(g.pinning, dtype=float) for g in graphs], axis=0)
    return CommunicationGraph(a, p, topology="union")


@dataclass(frozen=True, kw_only=True)
class GraphSegment:
    """A time interval with a constant communication graph.

    Parameters
    ----------
    start, end : float
        The interval ``[start, end)`` [s].
    graph : CommunicationGraph
        The graph in force.
    windows : tuple of int
        Indices of the interruption windows open over it.

    Examples
    --------
    >>> from trainctl.models.graphs import make_graph
    >>> from trainctl.models.network import Interruption
    >>> g = make_graph("predecessor", 3, pinned="head")
    >>> seg = graph_segments(g, [Interruption(start=10.0, end=20.0, links=[[1, 0]])], 60.0)[1]
    >>> seg.start, seg.end, seg.windows  # [s], window 0 open
    (10.0, 20.0, (0,))
    >>> seg.unreached
    (1, 2)
    """

    start: float
    end: float
    graph: CommunicationGraph
    windows: tuple[int, ...]

    @property
    def unreached(self) -> tuple[int, ...]:
        """Vehicles (0-based) the reference does not reach over the segment."""
        return self.graph.unreached()


def graph_segments(graph: CommunicationGraph, windows: Sequence[Interruption],
                   duration: float) -> list[GraphSegment]:
    """``[0, duration)`` split at every window edge, with the graph in force on each piece.

    Parameters
    ----------
    graph : CommunicationGraph
        The scenario's graph.
    windows : sequence of Interruption
        Interruption windows (``[network] interruption``).
    duration : float
        Run length [s], > 0.

    Returns
    -------
    list of GraphSegment
        In time order, covering [0, duration).

    Examples
    --------
    Two overlapping windows split a 60 s run at 10, 20 and 30 s:

    >>> from trainctl.models.graphs import make_graph
    >>> from trainctl.models.network import Interruption
    >>> g = make_graph("predecessor", 3, pinned="head")
    >>> cuts = [Interruption(start=10.0, end=30.0, links=[[2, 1]]),
    ...         Interruption(start=20.0, end=30.0, links=[[1, 0]])]
    >>> for s in graph_segments(g, cuts, 60.0):
    ...     print(s.start, s.end, s.windows, s.unreached)
    0.0 10.0 () ()
    10.0 20.0 (0,) (2,)
    20.0 30.0 (0, 1) (1, 2)
    30.0 60.0 () ()
    """
    if not (isinstance(duration, int | float | np.floating) and math.isfinite(duration)
            and duration > 0):
        raise ModelError(f"graph_segments: 'duration' must be a finite number > 0 s (got "
                         f"{duration!r}).")
    edges = {0.0, float(duration)}
    for w in windows:
        edges.update(t for t in (float(w.start), float(w.end)) if 0.0 < t < duration)
    times = sorted(edges)
    out = []
    for lo, hi in zip(times[:-1], times[1:], strict=True):
        open_ = tuple(k for k, w in enumerate(windows) if w.start <= lo and hi <= w.end)
        out.append(GraphSegment(start=lo, end=hi, windows=open_,
                                graph=cut_graph(graph, [windows[k] for k in open_])))
    return out


@dataclass(frozen=True, kw_only=True)
class WindowConnectivity:
    """What one interruption window does to the reference's reach.

    Parameters
    ----------
    window : int
        Index of the window.
    start, end : float
        The window [s].
    cut_off : tuple of int
        Vehicles (0-based) unreached at some time in the window.
    recovered : bool
        The union of the graphs from the window's end to the end of the run
        has a spanning tree rooted at the reference (jointly connected
        afterwards); True when nobody was cut off.
    recovery_time : float or None
        The window's end when recovered [s], None when not (or when the
        window lasts to the end of the run).

    Examples
    --------
    A cut that lasts to the end of the run leaves no time to recover:

    >>> from trainctl.models.graphs import make_graph
    >>> from trainctl.models.network import Interruption
    >>> g = make_graph("predecessor", 3, pinned="head")
    >>> w = joint_connectivity(g, [Interruption(start=10.0, end=60.0, links=[[1, 0]])], 60.0)[0]
    >>> w.cut_off, w.recovered, w.recovery_time
    ((1, 2), False, None)
    >>> w.to_dict()["cut_off_vehicles"]  # 1-based
    [2, 3]
    """

    window: int
    start: float
    end: float
    cut_off: tuple[int, ...]
    recovered: bool
    recovery_time: float | None

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe, vehicles 1-based as in messages (``cut_off_vehicles``).

        Returns
        -------
        dict
            ``window``, ``start`` and ``end`` [s], ``cut_off_vehicles`` (list
            of int, 1-based), ``recovered`` and ``recovery_time`` [s] (None
            when not recovered).
        """
        return {"window": self.window, "start": self.start, "end": self.end,
                "cut_off_vehicles": [i + 1 for i in self.cut_off], "recovered": self.recovered,
                "recovery_time": self.recovery_time}


def joint_connectivity(graph: CommunicationGraph, windows: Sequence[Interruption],
                       duration: float) -> list[WindowConnectivity]:
    """Per window: who is cut off, and whether the graph is jointly connected after it.

    Parameters
    ----------
    graph : CommunicationGraph
        The scenario's graph.
    windows : sequence of Interruption
        Interruption windows.
    duration : float
        Run length [s].

    Returns
    -------
    list of WindowConnectivity
        One per window, in the given order.

    Examples
    --------
    The first window only drops the head's pinning and is over at 20 s, so the
    links are back afterwards; the second lasts to the end of the run.

    >>> from trainctl.models.graphs import make_graph
    >>> from trainctl.models.network import Interruption
    >>> g = make_graph("predecessor", 3, pinned="head")
    >>> cuts = [Interruption(start=10.0, end=20.0, links=[[0, "reference"]]),
    ...         Interruption(start=40.0, end=60.0, links=[[2, 1]])]
    >>> [(w.cut_off, w.recovered, w.recovery_time) for w in joint_connectivity(g, cuts, 60.0)]
    [((0, 1, 2), True, 20.0), ((2,), False, None)]
    """
    segments = graph_segments(graph, windows, duration)
    out = []
    for k, w in enumerate(windows):
        during = [s for s in segments if k in s.windows]
        cut = tuple(sorted({i for s in during for i in s.unreached}))
        after = [s for s in segments if s.start >= w.end]
        if not cut:
            recovered, when = True, float(min(w.end, duration))
        elif not after:
            recovered, when = False, None
        else:
            recovered = union_graph([s.graph for s in after]).reference_reaches_all()
            when = float(w.end) if recovered else None
        out.append(WindowConnectivity(window=k, start=float(w.start), end=float(w.end),
                                      cut_off=cut, recovered=recovered, recovery_time=when))
    return out
