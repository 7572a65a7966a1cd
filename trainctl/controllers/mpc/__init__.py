# The MPC family: centralised, decentralised, N-DMPC and cooperative DMPC of the train.
"""The MPC controller family and the MPC core.

:func:`make_linear_mpc` builds an MPC on any discrete linear model (the
core); :func:`make_mpc` the train MPC of the four strategies, made of the
same building blocks. Importing this package is light (no cvxpy): the
controllers, their QPs and the family's design are imported on first use of
:func:`make_mpc`, :class:`MPCController`, :func:`make_linear_mpc`,
:class:`LinearMPC` or the family's methods.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from trainctl.controllers.mpc.family import FAMILY as FAMILY
from trainctl.controllers.mpc.settings import STRATEGIES as STRATEGIES
from trainctl.controllers.mpc.settings import MPCConstraints as MPCConstraints

if TYPE_CHECKING:
    from trainctl.controllers.mpc.controller import MPCController as MPCController
    from trainctl.controllers.mpc.controller import make_mpc as make_mpc
    from trainctl.controllers.mpc.linear import LinearMPC as LinearMPC
    from trainctl.controllers.mpc.linear import LinearMPCController as LinearMPCController
    from trainctl.controllers.mpc.linear import MPCSolution as MPCSolution
    from trainctl.controllers.mpc.linear import make_linear_mpc as make_linear_mpc

__all__ = ["FAMILY", "STRATEGIES", "LinearMPC", "LinearMPCController", "MPCConstraints",
           "MPCController", "MPCSolution", "make_linear_mpc", "make_mpc"]

_LAZY = {"MPCController": ".controller", "make_mpc": ".controller", "LinearMPC": ".linear",
         "LinearMPCController": ".linear", "MPCSolution": ".linear",
         "make_linear_mpc": ".linear"}


def __getattr__(name: str) -> Any:
    """Import the solver-backed names on first access (PEP 562)."""
    if name in _LAZY:
        from importlib import import_module

        value = getattr(import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
