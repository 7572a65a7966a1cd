# What the H∞ family's design costs: the budget's calibration of its semidefinite programs.
"""The budget's time model of the H∞ family's design and review (:func:`design_cost`).

Its certificates and synthesis solve SDPs in a dense P on the 2n − 1 loop
states: the certified γ and its per-group and per-channel parts (about
n + 6 solves), plus grid² + evaluations solves when ``synthesise = true``;
each delay-dependent one (``delay_certificate_s``) costs about
:data:`SDP_DELAY` delay-free ones. Measured on ``heavy-haul-hinf`` with
synthesis: 7 states 2.4 s, 15 states 24 s for about 100 solves.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from trainctl.controllers.hooks import DesignCost

if TYPE_CHECKING:
    from trainctl.controllers.hinf.settings import HinfSettings
    from trainctl.scenario import Scenario

__all__ = ["SDP_DELAY", "SDP_SECONDS", "SDP_SIZE_SECONDS", "design_cost"]

SDP_SECONDS = 0.02
"""One small SDP [s] (cvxpy + Clarabel overhead)."""

SDP_SIZE_SECONDS = 0.2
"""One of the family's SDPs [s], × (states / 15)⁴."""

SDP_DELAY = 3.0
"""A Lyapunov–Krasovskii SDP against a delay-free one (3 blocks of P)."""


def design_cost(scenario: Scenario, settings: HinfSettings,
                strategies: Sequence[str]) -> DesignCost:
    """Seconds of the semidefinite programs of the family's design and review.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    settings : HinfSettings
        The family's settings (``synthesise``, ``synthesis_grid``,
        ``synthesis_evaluations``, ``delay_certificate``).
    strategies : sequence of str
        The family's simulated strategies (unused).

    Returns
    -------
    DesignCost
        Seconds [s] and the words naming the keys (memory negligible).

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf-delay")
    >>> cost = design_cost(scenario, scenario.controllers["hinf"], ())
    >>> cost.seconds > 0.1, cost.dominant.split(" (")[0]
    (True, 'the H∞ certificates')
    """
    n = scenario.train.n_vehicles
    solves = n + 6.0
    if getattr(settings, "synthesise", False):
        grid = int(getattr(settings, "synthesis_grid", 7) or 7)
        solves += grid * grid + int(getattr(settings, "synthesis_evaluations", 40) or 40)
    if getattr(settings, "delay_certificate", None):
        solves *= SDP_DELAY
    states = 2.0 * n - 1.0
    seconds = solves * (SDP_SECONDS + SDP_SIZE_SECONDS * (states / 15.0) ** 4)
    return DesignCost(seconds=seconds, memory_bytes=0.0, dominant=(
        f"the H∞ certificates (SDPs) of {n} vehicles ({2 * n - 1} states; [train] "
        "vehicles, [controller] synthesise)"))
