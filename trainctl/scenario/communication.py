# The [communication] table: the graph over which consensus controllers exchange data.
"""Settings of the ``[communication]`` table (:mod:`trainctl.models.graphs`)."""

from __future__ import annotations

from typing import Annotated

from pydantic import model_validator

from trainctl.declare.constraints import Array, Choice, Number, Violation, raise_at
from trainctl.declare.keys import Key, settings
from trainctl.exceptions import ModelError
from trainctl.models.graphs import PINNING, TOPOLOGIES, CommunicationGraph, make_graph

__all__ = ["CommunicationSettings"]

_ROW = Array(Number(ge=0))


@settings
class CommunicationSettings:
    """Who hears whom in a formation, and who hears the reference.

    Parameters
    ----------
    topology : {"bidirectional", "predecessor", "all-to-all", "explicit"}
        The links between the vehicles (:func:`trainctl.models.graphs.make_graph`).
    pinned : {"all", "head", "none"}
        Which vehicles receive the reference (the timetable or virtual leader).
    weight : float
        Weight of every link and of the reference [-], > 0 (the adjacency
        entries a_ij of a named topology).
    adjacency : tuple of tuple of float or None
        The weights a_ij [-] of an ``"explicit"`` topology, one row per
        receiving vehicle (head first), zero diagonal; None otherwise.

    Examples
    --------
    >>> c = CommunicationSettings(topology="predecessor", pinned="head")
    >>> c.graph(3).reference_reaches_all()
    True
    """

    topology: Annotated[str, Choice(TOPOLOGIES), Key(
        "Links between the vehicles: bidirectional (ahead and behind), predecessor (the "
        "one ahead), all-to-all, or explicit (adjacency given)")] = "bidirectional"
    pinned: Annotated[str, Choice(PINNING), Key(
        "Vehicles that receive the reference: all, head, or none")] = "all"
    weight: Annotated[float, Number(gt=0), Key(
        "Weight of every link and of the reference pinning")] = 1.0
    adjacency: Annotated[tuple[tuple[float, ...], ...] | None, Array(_ROW), Key(
        "Explicit weights a_ij: row i lists what vehicle i hears from each vehicle j "
        "(zero diagonal); only with topology = 'explicit'",
        omitted="the named topology's links")] = None

    @model_validator(mode="after")
    def _explicit(self) -> CommunicationSettings:
        hint = (" Give topology = 'explicit' with the adjacency, or a named topology "
                "without it.")
        if self.topology == "explicit" and self.adjacency is None:
            raise_at(("adjacency",), Violation(
                text="must be given when {topology} = 'explicit'", got_text="none",
                hint=hint, value=False))
        if self.topology != "explicit" and self.adjacency is not None:
            raise_at(("adjacency",), Violation(
                text="is allowed only with {topology} = 'explicit'",
                got_text=f"topology {self.topology!r}", hint=hint, value=False))
        return self

    def check_vehicles(self, n: int) -> None:
        """Check an explicit adjacency against the formation's ``n`` vehicles.

        Does nothing without an explicit ``adjacency``.

        Parameters
        ----------
        n : int
            Vehicles (or unit trains) in the formation [-], >= 1.

        Raises
        ------
        ModelError
            If the adjacency is not n × n.
        """
        if self.adjacency is None:
            return
        shape = f"{len(self.adjacency)} x {max(len(r) for r in self.adjacency)}"
        if len(self.adjacency) != n or any(len(row) != n for row in self.adjacency):
            raise ModelError(f"CommunicationSettings: 'adjacency' must be {n} x {n}, one row "
                             f"and one column per vehicle (got {shape}).")

    def graph(self, n: int) -> CommunicationGraph:
        """The graph on ``n`` vehicles.

        Parameters
        ----------
        n : int
            Vehicles (or unit trains) in the formation [-], >= 1.

        Returns
        -------
        CommunicationGraph
            The graph; an explicit adjacency must be n × n.

        Raises
        ------
        ModelError
            If the explicit adjacency is not n × n or breaks the graph rules.
        """
        self.check_vehicles(n)
        return make_graph(self.topology, n, pinned=self.pinned, weight=self.weight,
                          adjacency=self.adjacency)
