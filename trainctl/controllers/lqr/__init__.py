# The LQR family: centralised and decentralised discrete LQR with feedforward and saturation.
"""The LQR controller family (see :mod:`trainctl.controllers.lqr.family`)."""

from __future__ import annotations

from .family import FAMILY as FAMILY
from .family import STRATEGIES as STRATEGIES

__all__ = ["FAMILY", "STRATEGIES"]
