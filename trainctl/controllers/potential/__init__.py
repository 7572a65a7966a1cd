# The potential family: Zhao & Wang's consensus law with a pair potential between coupled cars.
"""The potential controller family (see :mod:`trainctl.controllers.potential.family`)."""

from __future__ import annotations

from trainctl.controllers.potential.family import FAMILY as FAMILY
from trainctl.controllers.potential.family import STRATEGIES as STRATEGIES

__all__ = ["FAMILY", "STRATEGIES"]
