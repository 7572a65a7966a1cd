# The MPC family: centralised, decentralised, N-DMPC and cooperative DMPC of the train.
"""The MPC controller family.

Importing this package is light (no cvxpy): the controller, its QPs and the
family's design are imported on first use of :func:`make_mpc`,
:class:`MPCController` or the family's methods.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .family import FAMILY as FAMILY
from .settings import STRATEGIES as STRATEGIES
from .settings import MPCConstraints as MPCConstraints

if TYPE_CHECKING:
    from .controller import MPCController as MPCController
    from .controller import make_mpc as make_mpc

__all__ = ["FAMILY", "STRATEGIES", "MPCConstraints", "MPCController", "make_mpc"]

_LAZY = {"MPCController": ".controller", "make_mpc": ".controller"}


def __getattr__(name: str) -> Any:
    """Import the solver-backed names on first access (PEP 562)."""
    if name in _LAZY:
        from importlib import import_module

        value = getattr(import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
