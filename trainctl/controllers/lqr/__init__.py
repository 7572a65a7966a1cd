# The LQR family: centralised and decentralised discrete LQR with feedforward and saturation.
"""The LQR controller family (see :mod:`trainctl.controllers.lqr.family`)."""

from __future__ import annotations

from trainctl.controllers.lqr.family import FAMILY as FAMILY
from trainctl.controllers.lqr.family import STRATEGIES as STRATEGIES

__all__ = ["FAMILY", "STRATEGIES"]
