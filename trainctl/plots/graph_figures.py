# The communication-graph figure of the consensus families, stored as data and redrawn from it.
"""The communication graph of a controller family's report section.

The potential and flocking families exchange data over the scenario's
``[communication]`` graph (:meth:`trainctl.scenario.Scenario.graph`). Their
``report_data`` stores the graph with :func:`graph_report_data` (its
defining fields, JSON-safe, so a saved run re-renders it), and their
``report_figures`` redraw it with :func:`graph_figure`: a small drawing
(:func:`trainctl.plots.time.graph_plot`) placed in the family's own section of the
page, its caption giving the topology, the pinning, the algebraic
connectivity and whether the reference reaches every vehicle
(:meth:`trainctl.models.graphs.CommunicationGraph.summary`, recomputed from the
stored fields, so caption and drawing cannot disagree).

Examples
--------
>>> from trainctl.models.graphs import make_graph
>>> data = graph_report_data(make_graph("predecessor", 3, pinned="head"))
>>> data["adjacency"], data["pinning"]
([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [1.0, 0.0, 0.0])
>>> graph_from_data(data).reference_reaches_all()
True
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.figure import Figure

from trainctl._format import format_number
from trainctl.models.graphs import CommunicationGraph
from trainctl.plots import time as plot
from trainctl.plots._common import fixed_margins
from trainctl.plots.svg import encode, family_section

if TYPE_CHECKING:
    from trainctl.plots.svg import ReportFigure

__all__ = ["GRAPH_FIGSIZE", "graph_caption", "graph_figure", "graph_figure_key",
           "graph_from_data", "graph_report_data"]

GRAPH_FIGSIZE = (4.8, 1.7)
"""Size of the graph figure [in]: a handful of nodes in a row, the reference above."""


def graph_report_data(graph: CommunicationGraph) -> dict[str, Any]:
    """A communication graph as JSON-safe report data.

    Parameters
    ----------
    graph : CommunicationGraph
        The scenario's graph.

    Returns
    -------
    dict
        ``topology`` (str), ``adjacency`` (n lists of n weights a_ij [-],
        row i: what vehicle i receives from each vehicle j, head first) and
        ``pinning`` (n weights p_i [-] with which each vehicle receives the
        reference): the fields :class:`~trainctl.models.graphs.CommunicationGraph`
        is built from. The vehicles are drawn and named by their number
        (1 = head), so no labels are stored.

    Examples
    --------
    A bidirectional graph of two vehicles, both hearing the reference:

    >>> from trainctl.models.graphs import make_graph
    >>> data = graph_report_data(make_graph("bidirectional", 2, pinned="all"))
    >>> data["adjacency"], data["pinning"]
    ([[0.0, 1.0], [1.0, 0.0]], [1.0, 1.0])
    """
    return {"topology": graph.topology,
            "adjacency": [[float(x) for x in row] for row in graph.adjacency],
            "pinning": [float(x) for x in graph.pinning]}


def graph_from_data(data: Mapping[str, Any]) -> CommunicationGraph:
    """The graph stored by :func:`graph_report_data`.

    Parameters
    ----------
    data : mapping
        ``topology``, ``adjacency`` and ``pinning``.

    Returns
    -------
    CommunicationGraph
        The graph (validated again: a damaged saved run raises
        :class:`~trainctl.exceptions.ModelError`).

    Examples
    --------
    Vehicle 2 hears vehicle 1 and vehicle 1 the reference (3 vehicles):

    >>> data = {"topology": "predecessor", "pinning": [1.0, 0.0, 0.0],
    ...         "adjacency": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]}
    >>> graph = graph_from_data(data)
    >>> graph.topology, graph.reference_reaches_all()
    ('predecessor', True)
    """
    return CommunicationGraph(np.asarray(data["adjacency"], dtype=float),
                              np.asarray(data["pinning"], dtype=float),
                              topology=str(data["topology"]))


def graph_figure_key(family: str) -> str:
    """Key (HTML anchor ``figure-<key>``) of a family's graph figure, e.g. ``graph-potential``.

    Parameters
    ----------
    family : str
        The family's name.

    Returns
    -------
    str
        The figure's key.

    Examples
    --------
    >>> graph_figure_key("flocking")
    'graph-flocking'
    """
    return f"graph-{family}"


def graph_figure(data: Mapping[str, Any], *, family: str, usage: str = "",
                 make: Callable[..., ReportFigure] = encode) -> ReportFigure:
    """The communication-graph figure of a family's report section, drawn from its data.

    Parameters
    ----------
    data : mapping
        :func:`graph_report_data`.
    family : str
        The family's name: the figure goes to its section
        (:func:`~trainctl.plots.svg.family_section`).
    usage : str
        A sentence on what the family's law does with the links and the
        reference, appended to the caption.
    make : callable
        ``make(key, title, caption, figure, section=...)``, as
        :func:`~trainctl.plots.svg.encode`.

    Returns
    -------
    ReportFigure
        Key :func:`graph_figure_key`, section ``family-<family>``.

    Examples
    --------
    A predecessor graph of three vehicles pinned at the head: two one-way
    links, and λ₂ = 0.5 of the symmetrised path (1 − 2 − 3, Laplacian
    eigenvalues 0, 1 and 3, halved by the symmetrisation's weight 1/2):

    >>> from trainctl.models.graphs import make_graph
    >>> data = graph_report_data(make_graph("predecessor", 3, pinned="head"))
    >>> f = graph_figure(data, family="potential")
    >>> f.key, f.section
    ('graph-potential', 'family-potential')
    >>> "2 one-way links among 3 vehicles" in f.caption, "λ₂ = 0.5 [-]" in f.caption
    (True, True)
    """
    graph = graph_from_data(data)
    figure = Figure(figsize=GRAPH_FIGSIZE)
    ax = plot.graph_plot(graph, ax=figure.add_subplot())
    ax.set_title("")  # the caption says it
    fixed_margins(figure, left=0.05, right=0.05, bottom=0.05, top=0.05)  # no tick labels
    return make(graph_figure_key(family), f"Communication graph ({graph.topology})",
                graph_caption(graph.summary(), usage), figure, section=family_section(family))


def graph_caption(summary: Mapping[str, Any], usage: str = "") -> str:
    """The caption of a graph figure from :meth:`CommunicationGraph.summary`.

    Parameters
    ----------
    summary : mapping
        ``topology``, ``n``, ``links``, ``undirected``, ``connected``,
        ``pinned``, ``reference_reaches_all``, ``unreached`` and
        ``algebraic_connectivity``.
    usage : str
        A closing sentence, or "".

    Returns
    -------
    str
        Topology, links, pinning, algebraic connectivity λ₂ [-] and whether
        the reference reaches every vehicle.

    Examples
    --------
    >>> from trainctl.models.graphs import make_graph
    >>> print(graph_caption(make_graph("predecessor", 3, pinned="head").summary()))
    ... # doctest: +NORMALIZE_WHITESPACE
    Topology predecessor: 2 one-way links among 3 vehicles (numbered from the head, on
    the left), each arrow from sender to receiver; the reference (dashed) pins vehicle 1.
    Algebraic connectivity λ₂ = 0.5 [-] (of the symmetrised graph). The reference reaches
    every vehicle, directly or relayed.
    """
    n, links = int(summary["n"]), int(summary["links"])
    undirected = bool(summary["undirected"])
    if undirected:
        kind = f"{links // 2} two-way link{'s' if links != 2 else ''}"
        arrows = "arrowheads at both ends: heard both ways"
    else:
        kind = f"{links} one-way link{'s' if links != 1 else ''}"
        arrows = "each arrow from sender to receiver"
    text = (f"Topology {summary['topology']}: {kind} among {n} vehicles (numbered from the "
            f"head, on the left), {arrows}; the reference (dashed) pins "
            f"{_vehicles(summary['pinned'], n, none='no vehicle')}. Algebraic connectivity "
            f"λ₂ = {format_number(summary['algebraic_connectivity'], 4)} [-]"
            f"{'' if undirected else ' (of the symmetrised graph)'}"
            f"{'' if summary['connected'] else ': the vehicles are not connected'}. ")
    unreached = [int(i) for i in summary["unreached"]]
    if summary["reference_reaches_all"]:
        text += "The reference reaches every vehicle, directly or relayed."
    elif len(unreached) == n:
        text += "The reference reaches no vehicle."
    else:
        text += f"The reference does not reach {_vehicles(unreached, n, none='')}."
    return f"{text} {usage}".strip()


def _vehicles(numbers: Sequence[int], n: int, *, none: str) -> str:
    """``vehicle 1``, ``vehicles 1, 3``, ``every vehicle (1–8)``, or ``none`` for no number."""
    numbers = [int(i) for i in numbers]
    if not numbers:
        return none
    if len(numbers) == n and n > 1:
        return f"every vehicle (1–{n})"
    if len(numbers) == 1:
        return f"vehicle {numbers[0]}"
    return "vehicles " + ", ".join(str(i) for i in numbers)
