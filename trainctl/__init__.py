# trainctl package root: version, errors and the scenario loader.
"""trainctl: analysis, distributed MPC and reports for distributed train control.

Importing :mod:`trainctl` is light: it loads the errors eagerly and the
scenario machinery only when ``trainctl.load_scenario`` is first used, so
``import trainctl`` imports neither cvxpy nor matplotlib. The stage packages
re-export their names the same way (:func:`_lazy_exports`): ``from
trainctl.models import Train`` imports the module of ``Train``, not every model
module, so a command loads only what it uses (``tests/test_import_graph.py``).

Examples
--------
>>> import trainctl
>>> trainctl.__version__
'0.1.0'
>>> issubclass(trainctl.ScenarioError, trainctl.TrainctlError)
True
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from importlib import import_module
from types import ModuleType
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

def _lazy_exports(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A package's ``__getattr__`` and ``__dir__`` that import its re-exports on first use.

    ``exports`` maps each re-exported name to the module defining it (PEP 562).
    A name that is not re-exported but names a submodule imports the submodule,
    as an eager ``__init__`` would have (``trainctl.models.discrete`` after
    ``import trainctl.models``). A re-exported name that is also its module's
    name (``trainctl.analysis.string_stability``, the function) stays the
    re-exported object when that submodule is imported, as it was eagerly: the
    package's module class sees the import set the attribute. The package keeps
    the same names under ``if TYPE_CHECKING:`` for the type checker.

    Examples
    --------
    >>> import sys, types
    >>> pkg = types.ModuleType("pkg")
    >>> pkg.__path__ = []  # a package: pkg.nothing could be a submodule
    >>> pkg.__getattr__, pkg.__dir__ = _lazy_exports("pkg", {"dumps": "json"})
    >>> sys.modules["pkg"] = pkg
    >>> import json
    >>> pkg.dumps is json.dumps, "dumps" in vars(pkg), "dumps" in dir(pkg)
    (True, True, True)
    >>> pkg.nothing
    Traceback (most recent call last):
    ...
    AttributeError: module 'pkg' has no attribute 'nothing'
    >>> del sys.modules["pkg"]
    """

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is not None:
            value = getattr(import_module(module), name)
        elif name.startswith("__") or "__path__" not in vars(sys.modules[package]):
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        else:
            try:
                value = import_module(f"{package}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{package}.{name}":
                    raise
                raise AttributeError(
                    f"module {package!r} has no attribute {name!r}") from None
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    shadowed = {name for name, module in exports.items() if module == f"{package}.{name}"}
    if shadowed:

        class _Package(ModuleType):
            def __setattr__(self, name: str, value: Any) -> None:
                if (name in shadowed and isinstance(value, ModuleType)
                        and value.__name__ == f"{package}.{name}"):
                    value = getattr(value, name)   # the import of the submodule
                super().__setattr__(name, value)

        sys.modules[package].__class__ = _Package
    return __getattr__, __dir__


__getattr__, __dir__ = _lazy_exports(__name__, {"load_scenario": "trainctl.scenario"})
