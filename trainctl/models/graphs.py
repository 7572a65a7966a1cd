# Communication graphs between the vehicles (or trains) of a formation, built with networkx.
"""Communication graphs: who hears whom, and who hears the reference.

A consensus controller (the potential law of seed 001, flocking of seed 002,
the H∞ cooperative law of seed 003) combines each agent's own error with its
neighbours' data. The neighbours are a weighted directed graph on the
vehicles, numbered 0..n-1 head first, plus the *reference* (the timetable,
or a virtual leader) that pins some of them:

- ``adjacency[i, j] = a_ij > 0``: vehicle i receives vehicle j's data with
  weight a_ij (information flows j → i); ``a_ii = 0``;
- ``pinning[i] = p_i > 0``: vehicle i receives the reference with weight p_i.

From them: the Laplacian L = D − A with D = diag(Σ_j a_ij) (row sums, so
``L @ x`` is Σ_j a_ij (x_i − x_j)), the pinning matrix P = diag(p), whether
the reference reaches every vehicle (a directed spanning tree rooted at the
reference: the condition for leader-following consensus, e.g. Ren & Beard,
*Distributed Consensus in Multi-vehicle Cooperative Control*, 2008, ch. 2),
and the algebraic connectivity λ₂(L) of an undirected graph (Fiedler 1973).

Topologies by name (:func:`make_graph`): ``"bidirectional"`` (each vehicle
with its neighbours ahead and behind: the path graph), ``"predecessor"``
(each vehicle hears the one ahead), ``"all-to-all"`` (the complete graph),
and ``"explicit"`` (an adjacency matrix given in full).

Examples
--------
>>> g = make_graph("bidirectional", 4, pinned="head")
>>> g.laplacian().tolist()[1]
[-1.0, 2.0, -1.0, 0.0]
>>> g.reference_reaches_all(), round(g.algebraic_connectivity(), 6)
(True, 0.585786)
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import ModelError

if TYPE_CHECKING:
    import networkx as nx
    from matplotlib.axes import Axes

__all__ = [
    "PINNING", "REFERENCE", "TOPOLOGIES", "CommunicationGraph", "make_graph",
]

TOPOLOGIES = ("bidirectional", "predecessor", "all-to-all", "explicit")
"""Topology names :func:`make_graph` accepts."""

PINNING = ("all", "head", "none")
"""Which vehicles hear the reference: every one, the head only, none."""

REFERENCE = "reference"
"""The node name of the reference in :meth:`CommunicationGraph.to_networkx`."""

Array = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class CommunicationGraph:
    """A weighted directed communication graph on n vehicles, pinned to a reference.

    Parameters
    ----------
    adjacency : array_like
        (n, n) weights [-]: ``adjacency[i, j] > 0`` when vehicle i receives
        vehicle j's data; non-negative and finite, zero diagonal.
    pinning : array_like
        (n,) weights [-] with which each vehicle receives the reference,
        non-negative and finite.
    topology : str
        How the graph was made (a name of :data:`TOPOLOGIES`), for display.

    Examples
    --------
    >>> g = CommunicationGraph([[0, 0], [1, 0]], [1, 0], topology="predecessor")
    >>> g.n, g.is_undirected(), g.reference_reaches_all()
    (2, False, True)
    """

    adjacency: Array
    pinning: Array
    topology: str = "explicit"

    def __post_init__(self) -> None:
        a = np.array(self.adjacency, dtype=float)
        n = a.shape[0] if a.ndim == 2 else 0
        if a.ndim != 2 or a.shape != (n, n) or n < 1:
            raise ModelError(f"CommunicationGraph: 'adjacency' must be a square matrix of at "
                             f"least 1 x 1 (got shape {a.shape}).")
        if not np.all(np.isfinite(a)) or np.any(a < 0):
            raise ModelError("CommunicationGraph: 'adjacency' must hold finite weights >= 0 "
                             f"(got {a[~np.isfinite(a) | (a < 0)][0]!r}).")
        if np.any(np.diag(a) != 0):
            i = int(np.flatnonzero(np.diag(a))[0])
            raise ModelError(f"CommunicationGraph: 'adjacency' must have a zero diagonal (no "
                             f"vehicle hears itself; got {a[i, i]!r} at vehicle {i + 1}).")
        p = np.array(self.pinning, dtype=float).reshape(-1)
        if p.shape != (n,) or not np.all(np.isfinite(p)) or np.any(p < 0):
            raise ModelError(f"CommunicationGraph: 'pinning' must be {n} finite weights >= 0, "
                             f"one per vehicle (got {np.array(self.pinning).tolist()!r}).")
        a.setflags(write=False)
        p.setflags(write=False)
        object.__setattr__(self, "adjacency", a)
        object.__setattr__(self, "pinning", p)

    @cached_property
    def _graph(self) -> nx.DiGraph:
        """The networkx graph, built on first use (networkx is imported only then)."""
        import networkx as nx

        graph = nx.DiGraph()
        graph.add_node(REFERENCE)
        graph.add_nodes_from(range(self.n))
        rows, cols = np.nonzero(self.adjacency)
        graph.add_weighted_edges_from(
            (int(j), int(i), float(self.adjacency[i, j])) for i, j in zip(rows, cols, strict=True))
        graph.add_weighted_edges_from(
            (REFERENCE, int(i), float(self.pinning[i])) for i in np.flatnonzero(self.pinning))
        return graph

    @property
    def n(self) -> int:
        """Number of vehicles [-]."""
        return int(self.adjacency.shape[0])

    def to_networkx(self) -> nx.DiGraph:
        """The graph as a networkx ``DiGraph`` (a copy).

        Returns
        -------
        networkx.DiGraph
            Nodes 0..n-1 (vehicles, head first) and :data:`REFERENCE`; an
            edge j → i with attribute ``weight`` = a_ij for each received
            link (information flow), and reference → i with weight p_i.
        """
        return self._graph.copy()

    def laplacian(self) -> Array:
        """The graph Laplacian L = D − A [-] (row sums: in-degrees).

        Returns
        -------
        ndarray
            (n, n); ``L @ x`` is Σ_j a_ij (x_i − x_j) for each vehicle i.
        """
        return np.diag(self.adjacency.sum(axis=1)) - self.adjacency

    def pinning_matrix(self) -> Array:
        """P = diag(p) [-]: the weights with which the vehicles hear the reference.

        Returns
        -------
        ndarray
            (n, n), the pinning weights on the diagonal.
        """
        return np.diag(self.pinning)

    def is_undirected(self) -> bool:
        """True when every link is heard both ways with the same weight (A = Aᵀ).

        Returns
        -------
        bool
            Whether the adjacency matrix is symmetric.
        """
        return bool(np.array_equal(self.adjacency, self.adjacency.T))

    def reference_reaches_all(self) -> bool:
        """True when the graph has a directed spanning tree rooted at the reference.

        Every vehicle then receives the reference, directly or relayed, which
        leader-following consensus needs (L + P is then nonsingular, with
        eigenvalues in the open right half plane).

        Returns
        -------
        bool
            Whether every vehicle is reachable from the reference along links.
        """
        import networkx as nx

        return len(nx.descendants(self._graph, REFERENCE)) == self.n

    def unreached(self) -> tuple[int, ...]:
        """The vehicles (0-based) the reference does not reach, head first.

        Returns
        -------
        tuple of int
            Their indices in ``range(n)``; empty when
            :meth:`reference_reaches_all`.
        """
        import networkx as nx

        reached = nx.descendants(self._graph, REFERENCE)
        return tuple(i for i in range(self.n) if i not in reached)

    def is_connected(self) -> bool:
        """True when the vehicles form one weakly connected graph (ignoring the reference).

        Returns
        -------
        bool
            Whether the vehicle graph, with link directions ignored, is
            connected; True for one vehicle.
        """
        import networkx as nx

        vehicles = self._graph.subgraph(range(self.n))
        return self.n == 1 or bool(nx.is_weakly_connected(vehicles))

    def algebraic_connectivity(self) -> float:
        """λ₂ of the Laplacian of the undirected vehicle graph [-] (0 when disconnected).

        For a directed graph the symmetrised weights (A + Aᵀ)/2 are used, a
        common stand-in (λ₂ of a directed Laplacian is complex in general).

        Returns
        -------
        float
            The second-smallest Laplacian eigenvalue; 0.0 for one vehicle.
        """
        if self.n == 1:
            return 0.0
        sym = (self.adjacency + self.adjacency.T) / 2.0
        laplacian = np.diag(sym.sum(axis=1)) - sym
        return float(np.sort(np.linalg.eigvalsh(laplacian))[1])

    def pinned_rate(self) -> float:
        """min Re λ(L + P) [-]: how fast leader-following consensus converges per unit gain.

        Positive exactly when the reference reaches every vehicle.

        Returns
        -------
        float
            The smallest real part of the eigenvalues of L + P [-].
        """
        return float(np.min(np.linalg.eigvals(self.laplacian() + self.pinning_matrix()).real))

    def neighbours(self, i: int) -> tuple[int, ...]:
        """The vehicles (0-based) whose data vehicle ``i`` receives, in order.

        Parameters
        ----------
        i : int
            The receiving vehicle, 0-based: 0 <= i < n.

        Returns
        -------
        tuple of int
            The 0-based indices j with ``adjacency[i, j] > 0``, ascending; the
            reference is not included (see :attr:`pinning`).

        Raises
        ------
        ModelError
            When ``i`` is not a vehicle index (a negative one included: it
            would silently count from the end).
        """
        if isinstance(i, bool) or not isinstance(i, int | np.integer) or not 0 <= i < self.n:
            raise ModelError(f"CommunicationGraph.neighbours: 'i' must be a vehicle index from "
                             f"0 to {self.n - 1} (got {i!r}).")
        return tuple(int(j) for j in np.flatnonzero(self.adjacency[i]))

    def summary(self) -> dict[str, Any]:
        """The graph's properties as JSON-safe numbers (for ``analyse --json`` and reports).

        Returns
        -------
        dict of str to object
            ``topology``; ``n``; ``links``, the number of received links;
            ``undirected`` and ``connected`` (bool); ``pinned``, the 1-based
            vehicles that hear the reference; ``reference_reaches_all`` (bool);
            ``unreached``, the 1-based vehicles it does not reach;
            ``algebraic_connectivity`` and ``pinned_rate`` [-].
        """
        return {
            "topology": self.topology, "n": self.n, "links": int(np.count_nonzero(self.adjacency)),
            "undirected": self.is_undirected(), "connected": self.is_connected(),
            "pinned": [int(i) + 1 for i in np.flatnonzero(self.pinning)],
            "reference_reaches_all": self.reference_reaches_all(),
            "unreached": [i + 1 for i in self.unreached()],
            "algebraic_connectivity": self.algebraic_connectivity(),
            "pinned_rate": self.pinned_rate(),
        }

    def plot(self, *, ax: Axes | None = None) -> Axes:
        """Draw the graph: vehicles in a row (head left), links as arcs, the reference above.

        Parameters
        ----------
        ax : matplotlib.axes.Axes or None
            Axes to draw into; None creates a new Figure.

        Returns
        -------
        matplotlib.axes.Axes
            The axes.
        """
        from trainctl.plots.time import graph_plot

        return graph_plot(self, ax=ax)


def make_graph(topology: str, n: int, *, pinned: str | ArrayLike = "all",
               weight: float = 1.0, adjacency: ArrayLike | None = None) -> CommunicationGraph:
    """A communication graph on ``n`` vehicles by topology name.

    Parameters
    ----------
    topology : {"bidirectional", "predecessor", "all-to-all", "explicit"}
        The links (module docstring); ``"explicit"`` takes ``adjacency``.
    n : int
        Number of vehicles [-], >= 1.
    pinned : {"all", "head", "none"} or array_like
        Which vehicles hear the reference (each with weight ``weight``), or
        the (n,) pinning weights [-] themselves.
    weight : float
        Weight of every link of a named topology [-], > 0.
    adjacency : array_like, optional
        The (n, n) weights of an ``"explicit"`` graph (see
        :class:`CommunicationGraph`).

    Returns
    -------
    CommunicationGraph
        The graph.

    Raises
    ------
    ModelError
        For an unknown topology or pinning, ``n < 1``, a bad weight, or an
        adjacency given with a named topology (or missing with "explicit").

    Examples
    --------
    >>> make_graph("predecessor", 3, pinned="head").adjacency.tolist()
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    >>> make_graph("all-to-all", 3).laplacian().diagonal().tolist()
    [2.0, 2.0, 2.0]
    """
    if topology not in TOPOLOGIES:
        raise ModelError(f"make_graph: 'topology' must be one of {', '.join(TOPOLOGIES)} "
                         f"(got {topology!r}).")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ModelError(f"make_graph: 'n' must be an integer >= 1 (got {n!r}).")
    if not (np.isfinite(weight) and weight > 0):
        raise ModelError(f"make_graph: 'weight' must be a finite number > 0 (got {weight!r}).")
    if (adjacency is None) == (topology == "explicit"):
        raise ModelError("make_graph: 'adjacency' must be given exactly with topology "
                         f"'explicit' (got topology {topology!r} and "
                         f"{'no' if adjacency is None else 'an'} adjacency).")
    if adjacency is not None:
        a = np.asarray(adjacency, dtype=float)
    else:
        a = weight * _named(topology, int(n))
    return CommunicationGraph(a, _pinning(pinned, int(n), weight), topology=topology)


def _named(topology: str, n: int) -> Array:
    """The 0/1 adjacency (receiver rows) of a named topology, built with networkx."""
    import networkx as nx

    if topology == "all-to-all":
        graph = nx.complete_graph(n, create_using=nx.DiGraph)
    elif topology == "bidirectional":
        graph = nx.path_graph(n).to_directed()  # both directions of each link
    else:
        graph = nx.DiGraph()
        graph.add_nodes_from(range(n))
        graph.add_edges_from((i, i + 1) for i in range(n - 1))  # i's data flows to i + 1
    # networkx: entry [u, v] is the edge u → v (flow); trainctl's rows are receivers.
    return np.asarray(nx.to_numpy_array(graph, nodelist=range(n)), dtype=float).T


def _pinning(pinned: str | ArrayLike, n: int, weight: float) -> Array:
    if isinstance(pinned, str):
        if pinned not in PINNING:
            raise ModelError(f"make_graph: 'pinned' must be one of {', '.join(PINNING)} or "
                             f"{n} weights (got {pinned!r}).")
        p = np.zeros(n)
        if pinned == "all":
            p[:] = weight
        elif pinned == "head":
            p[0] = weight
        return p
    return np.asarray(pinned, dtype=float)
