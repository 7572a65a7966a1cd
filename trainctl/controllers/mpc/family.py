# The MPC family as a registry entry: vocabulary, schema, design, controllers, checks, report.
"""The MPC family object (:data:`FAMILY`), see :mod:`trainctl.controllers.registry`."""

from __future__ import annotations

from typing import Any

from .settings import STRATEGIES

__all__ = ["FAMILY", "MPCFamily"]

CHECK_NAMES = (
    "ndmpc_convergence",
    "relaxation",
    "closed_loop_nash",
    "closed_loop_iterations",
    "nash_gap",
    "cooperative_convergence",
    "centralised_closed_loop",
)
"""The MPC family's design checks."""


class MPCFamily:
    """Centralised, decentralised, N-DMPC and cooperative DMPC of the train."""

    name = "mpc"
    title = "Model predictive control"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    report_partial = ""

    @property
    def settings(self) -> type[Any]:
        """The schema of the family's ``[controller]`` table."""
        from .settings import ControllerSettings

        return ControllerSettings


FAMILY = MPCFamily()
"""The registry entry of the MPC family."""
