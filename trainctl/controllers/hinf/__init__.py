# The hinf family: seed 003's distributed robust H∞ cooperative law over the radio network.
"""The hinf controller family (see :mod:`trainctl.controllers.hinf.family`)."""

from __future__ import annotations

from trainctl.controllers.hinf.family import FAMILY as FAMILY
from trainctl.controllers.hinf.family import STRATEGIES as STRATEGIES

__all__ = ["FAMILY", "STRATEGIES"]
