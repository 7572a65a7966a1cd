# The flocking family: Olfati-Saber's algorithm on virtually coupled heavy-haul trains (seed 002).
"""The flocking controller family (see :mod:`trainctl.controllers.flocking.family`)."""

from __future__ import annotations

from trainctl.controllers.flocking.family import FAMILY as FAMILY
from trainctl.controllers.flocking.family import STRATEGIES as STRATEGIES

__all__ = ["FAMILY", "STRATEGIES"]
