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
    """Base class for all trainctl errors.

    Examples
    --------
    Catching the base class catches every trainctl error, whatever builtin
    it also derives from:

    >>> import trainctl
    >>> try:
    ...     trainctl.load_scenario("no-such-scenario")
    ... except TrainctlError as exc:
    ...     print(type(exc).__name__, isinstance(exc, TrainctlError))
    ScenarioError True
    """


class ScenarioError(TrainctlError, ValueError):
    """A scenario file is malformed: unknown key, bad value, not TOML.

    Examples
    --------
    A misspelt key is refused, with a suggestion of the key meant:

    >>> import trainctl
    >>> scenario = trainctl.load_scenario("crh2-dmpc")
    >>> scenario.replace("simulation.durationx", 3.0)
    Traceback (most recent call last):
        ...
    trainctl.exceptions.ScenarioError: builtin:crh2-dmpc (simulation.durationx = 3.0): \
unknown key [simulation].durationx. Did you mean 'duration'?
    """


class ModelError(TrainctlError, ValueError):
    """A model parameter is invalid (non-positive mass, wrong length, ...).

    Examples
    --------
    A physical coupler needs a positive spring stiffness [N/m]:

    >>> from trainctl.models import Coupler
    >>> Coupler(stiffness=0.0)
    Traceback (most recent call last):
        ...
    trainctl.exceptions.ModelError: Coupler: 'stiffness' must be > 0 for a physical coupler \
(got 0.0). Use virtual=True for a link without coupling.
    >>> issubclass(ModelError, ValueError)
    True
    """


class DimensionError(TrainctlError, ValueError):
    """A matrix or vector has the wrong shape.

    Examples
    --------
    An LQR gain for n = 2 vehicles must map the 2n - 1 = 3 design states to
    the 2 inputs, so a (2, 2) gain is refused:

    >>> import numpy as np
    >>> from trainctl.controllers.lqr.controller import LQRController
    >>> from trainctl.models import Coupler, Train, Vehicle
    >>> car = Vehicle(mass=4.0e4, a0=0.01, a1=1e-4, a2=1e-5)
    >>> train = Train(vehicles=(car, car), couplers=(Coupler(stiffness=1e7),))
    >>> LQRController(train, np.zeros((2, 2)), dt=0.1)
    Traceback (most recent call last):
        ...
    trainctl.exceptions.DimensionError: LQRController: 'gain' must have shape (2, 3) for \
2 vehicles (got (2, 2)).
    """


class SolverError(TrainctlError, RuntimeError):
    """An optimisation solver failed and no solution is available.

    Examples
    --------
    A QP built without its fast path has no solver data to hand out:

    >>> import numpy as np
    >>> from trainctl.controllers.mpc.qp.parametric import ParametricQP
    >>> qp = ParametricQP(np.eye(1), np.zeros((0, 1)), np.zeros((0, 1)), name="demo",
    ...                   fast=False)
    >>> qp.data_map()
    Traceback (most recent call last):
        ...
    trainctl.exceptions.SolverError: demo: built without the fast path (fast=False).
    """


class MissingDependencyError(TrainctlError, ImportError):
    """An optional dependency needed for this feature is not installed.

    Examples
    --------
    :meth:`trainctl.sim.SimulationResult.to_pandas` needs pandas; hiding
    pandas from the import system shows the error a user without it gets:

    >>> import sys
    >>> from unittest import mock
    >>> import numpy as np
    >>> from trainctl.sim import SimulationResult
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 1.0]), states=np.array([[10.0, 10.0], [0.0, 10.0]]),
    ...     velocities=np.array([[10.0, 10.0]]), coupler_forces=np.zeros((0, 2)),
    ...     inputs=np.array([[0.0]]), reference_speed=np.array([10.0, 10.0]),
    ...     reference_acceleration=np.zeros(2), statuses=("optimal",),
    ...     iterations=np.array([1]), residuals=((),), solve_times=np.array([1e-3]),
    ...     fallbacks=("",), controller_name="demo", seed=0, dt=1.0)
    >>> with mock.patch.dict(sys.modules, {"pandas": None}):
    ...     result.to_pandas()
    Traceback (most recent call last):
        ...
    trainctl.exceptions.MissingDependencyError: SimulationResult.to_pandas: pandas must be \
installed (got ImportError). pip install 'trainctl-toolbox[pandas]'
    >>> issubclass(MissingDependencyError, ImportError)
    True
    """


class UnknownNameError(TrainctlError, KeyError):
    """A name (a check of a review, ...) that is not there; the message lists the known ones.

    Also a ``KeyError`` (and so a ``LookupError``), so that ``except KeyError``
    keeps working; unlike a plain ``KeyError`` its ``str()`` is the message
    itself, not its quoted repr.

    Examples
    --------
    Asking a design review for a check it does not have:

    >>> from trainctl.analysis.check import Check, DesignReview
    >>> review = DesignReview(scenario_name="toy", checks=(
    ...     Check(name="sampling", status="pass", value=None, threshold=None, unit="",
    ...           message=""),))
    >>> try:
    ...     review.check("sampling_rate")
    ... except KeyError as exc:
    ...     print(str(exc))
    the review of 'toy' has no check 'sampling_rate'. Did you mean 'sampling'? Checks: sampling.
    """

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class ConvergenceWarning(UserWarning):
    """An iteration (DMPC, consensus) stopped before reaching its tolerance.

    Examples
    --------
    It is a ``UserWarning``, so the standard :mod:`warnings` filters apply;
    a strict run can turn it into an error:

    >>> import warnings
    >>> issubclass(ConvergenceWarning, UserWarning)
    True
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("error", ConvergenceWarning)
    ...     try:
    ...         warnings.warn("DMPC: 20 iterations, residual 1e-2 > tol 1e-4",
    ...                       ConvergenceWarning, stacklevel=1)
    ...     except ConvergenceWarning as exc:
    ...         print(type(exc).__name__)
    ConvergenceWarning
    """


class InaccurateSolutionWarning(UserWarning):
    """A solver returned a solution flagged as inaccurate.

    Examples
    --------
    It is a ``UserWarning``; an ``"ignore"`` filter silences it only, not
    other warnings:

    >>> import warnings
    >>> issubclass(InaccurateSolutionWarning, UserWarning)
    True
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warnings.filterwarnings("ignore", category=InaccurateSolutionWarning)
    ...     warnings.warn("OSQP: solved inaccurate", InaccurateSolutionWarning, stacklevel=1)
    ...     warnings.warn("something else", UserWarning, stacklevel=1)
    >>> [str(w.message) for w in caught]
    ['something else']
    """
