# The LQR family as a registry entry.
"""The LQR family object (:data:`FAMILY`), see :mod:`trainctl.controllers.registry`."""

from __future__ import annotations

from typing import Any

__all__ = ["CHECK_NAMES", "FAMILY", "STRATEGIES", "LQRFamily"]

STRATEGIES = ("centralised", "decentralised")
"""The LQR strategies: one gain on the whole train, or one per coach."""

CHECK_NAMES = ("lqr_closed_loop", "lqr_decentralised_closed_loop")
"""The LQR family's design checks."""


class LQRFamily:
    """Discrete LQR of the train: centralised and decentralised (per coach)."""

    name = "lqr"
    title = "Linear-quadratic regulator"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    report_partial = ""

    @property
    def settings(self) -> type[Any]:
        """The schema of the family's ``[controller]`` table."""
        from .settings import LQRSettings

        return LQRSettings


FAMILY = LQRFamily()
"""The registry entry of the LQR family."""
