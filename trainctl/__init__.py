# trainctl package root: version, errors and the scenario loader.
"""trainctl: analysis, distributed MPC and reports for distributed train control.

Importing :mod:`trainctl` is light: it loads the errors eagerly and the
scenario machinery only when ``trainctl.load_scenario`` is first used, so
``import trainctl`` imports neither cvxpy nor matplotlib.

Examples
--------
>>> import trainctl
>>> trainctl.__version__
'0.1.0'
>>> issubclass(trainctl.ScenarioError, trainctl.TrainctlError)
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from trainctl.exceptions import ConvergenceWarning as ConvergenceWarning
from trainctl.exceptions import DimensionError as DimensionError
from trainctl.exceptions import InaccurateSolutionWarning as InaccurateSolutionWarning
from trainctl.exceptions import MissingDependencyError as MissingDependencyError
from trainctl.exceptions import ModelError as ModelError
from trainctl.exceptions import ScenarioError as ScenarioError
from trainctl.exceptions import SolverError as SolverError
from trainctl.exceptions import TrainctlError as TrainctlError
from trainctl.exceptions import UnknownNameError as UnknownNameError

if TYPE_CHECKING:
    from trainctl.scenario import load_scenario as load_scenario

__version__ = "0.1.0"

DISTRIBUTION = "trainctl-toolbox"
"""The name trainctl is installed under (``pip install trainctl-toolbox``); the
import name is ``trainctl``. The index's ``trainctl`` is another project."""

__all__ = [
    "DISTRIBUTION",
    "ConvergenceWarning",
    "DimensionError",
    "InaccurateSolutionWarning",
    "MissingDependencyError",
    "ModelError",
    "ScenarioError",
    "SolverError",
    "TrainctlError",
    "UnknownNameError",
    "__version__",
    "load_scenario",
]

_LAZY = {"load_scenario": ".scenario"}


def __getattr__(name: str) -> Any:
    """Import the lazily re-exported names on first access (PEP 562)."""
    if name in _LAZY:
        from importlib import import_module

        value = getattr(import_module(_LAZY[name], __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
