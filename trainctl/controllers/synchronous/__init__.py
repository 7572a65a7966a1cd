# The synchronous family: the lead locomotive's speed loop relayed to the remotes by radio.
"""The synchronous controller family (see :mod:`trainctl.controllers.synchronous.family`)."""

from __future__ import annotations

from trainctl.controllers.synchronous.family import FAMILY as FAMILY
from trainctl.controllers.synchronous.family import STRATEGIES as STRATEGIES

__all__ = ["FAMILY", "STRATEGIES"]
