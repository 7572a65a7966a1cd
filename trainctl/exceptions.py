# trainctl exceptions and warnings: one place for every error class.
"""Errors and warnings raised by trainctl.

Every error subclasses :class:`TrainctlError` and a builtin, so that callers'
``except ValueError`` clauses keep working. The CLI catches
:class:`TrainctlError` only, prints ``trainctl: error: <message>`` and exits
with status 2; anything else is a bug and shows its traceback.
"""

from __future__ import annotations

__all__ = [
    "ConvergenceWarning",
    "DimensionError",
    "InaccurateSolutionWarning",
    "MissingDependencyError",
    "ModelError",
    "ScenarioError",
    "SolverError",
    "TrainctlError",
    "UnknownNameError",
]


class TrainctlError(Exception):
    """Base class for all trainctl errors."""


class ScenarioError(TrainctlError, ValueError):
    """A scenario file is malformed: unknown key, bad value, not TOML."""


class ModelError(TrainctlError, ValueError):
    """A model parameter is invalid (non-positive mass, wrong length, ...)."""


class DimensionError(TrainctlError, ValueError):
    """A matrix or vector has the wrong shape."""


class SolverError(TrainctlError, RuntimeError):
    """An optimisation solver failed and no solution is available."""


class MissingDependencyError(TrainctlError, ImportError):
    """An optional dependency needed for this feature is not installed."""


class UnknownNameError(TrainctlError, KeyError):
    """A name (a check of a review, ...) that is not there; the message lists the known ones.

    Also a ``KeyError`` (and so a ``LookupError``), so that ``except KeyError``
    keeps working; unlike a plain ``KeyError`` its ``str()`` is the message
    itself, not its quoted repr.
    """

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class ConvergenceWarning(UserWarning):
    """An iteration (DMPC, consensus) stopped before reaching its tolerance."""


class InaccurateSolutionWarning(UserWarning):
    """A solver returned a solution flagged as inaccurate."""
