# The results of the rank tests: controllability and observability, each its own type.
"""Result types of the controllability and observability analyses.

:func:`~trainctl.analysis.analyse_controllability` returns a
:class:`ControllabilityResult`, :func:`~trainctl.analysis.analyse_observability`
an :class:`ObservabilityResult`: the same numbers, each worded for what it tests.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

__all__ = ["ControllabilityResult", "ObservabilityResult", "UncontrollableMode",
           "UnobservableMode"]


@dataclass(frozen=True, kw_only=True)
class UncontrollableMode:
    """An eigenvalue that the inputs cannot move.

    Parameters
    ----------
    eigenvalue : complex
        The eigenvalue.
    pbh_margin : float
        Smallest singular value of [A - lambda I, B] relative to the largest.
    direction : dict of str to float
        Largest components of the left eigenvector (w^T A = lambda w^T,
        w^T B = 0), by state name.

    Examples
    --------
    >>> import control as ct
    >>> from trainctl.analysis import analyse_controllability, analyse_observability
    >>> # Two decoupled states; the input drives and the output sees only "a".
    >>> sys = ct.ss([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [0.0]], [[1.0, 0.0]], 0, states=["a", "b"])
    >>> (mode,) = analyse_controllability(sys).uncontrollable
    >>> mode.eigenvalue, mode.direction, mode.pbh_margin  # [A + 2I, B] loses rank
    ((-2+0j), {'b': 1.0}, 0.0)
    >>> mode.to_dict()["eigenvalue"]
    [-2.0, 0.0]
    """

    eigenvalue: complex
    pbh_margin: float
    direction: dict[str, float]

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``eigenvalue`` as [re, im], ``pbh_margin`` [-] and
            ``direction`` (a copy: eigenvector components by state name).
        """
        return {"eigenvalue": [self.eigenvalue.real, self.eigenvalue.imag],
                "pbh_margin": self.pbh_margin, "direction": dict(self.direction)}


@dataclass(frozen=True, kw_only=True)
class UnobservableMode(UncontrollableMode):
    """An eigenvalue that the outputs cannot see.

    Parameters
    ----------
    eigenvalue : complex
        The eigenvalue.
    pbh_margin : float
        Smallest singular value of [A - lambda I; C] relative to the largest.
    direction : dict of str to float
        Largest components of the right eigenvector (A v = lambda v,
        C v = 0), by state name: the state combination the outputs miss.

    Examples
    --------
    >>> import control as ct
    >>> from trainctl.analysis import analyse_controllability, analyse_observability
    >>> # Two decoupled states; the input drives and the output sees only "a".
    >>> sys = ct.ss([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [0.0]], [[1.0, 0.0]], 0, states=["a", "b"])
    >>> (mode,) = analyse_observability(sys).unobservable
    >>> mode.eigenvalue, mode.direction  # C v = 0 for v = e_b
    ((-2+0j), {'b': 1.0})
    """


@dataclass(frozen=True, kw_only=True)
class _RankTest:
    """The numbers a Kalman-rank test gives (both result types share them)."""

    n_states: int
    rank: int
    tol: float
    singular_values: NDArray[np.float64]
    condition_number: float
    gramian_horizon: float
    gramian_eigenvalues: NDArray[np.float64]

    @property
    def full_rank(self) -> bool:
        """True when the Kalman rank equals the state dimension."""
        return self.rank == self.n_states

    def _numbers(self) -> dict[str, object]:
        cond = None if math.isinf(self.condition_number) else self.condition_number
        return {"n_states": self.n_states, "rank": self.rank, "tol": self.tol,
                "full_rank": self.full_rank, "condition_number": cond,
                "singular_values": self.singular_values.tolist(),
                "gramian_horizon": self.gramian_horizon,
                "gramian_eigenvalues": self.gramian_eigenvalues.tolist()}


@dataclass(frozen=True, kw_only=True)
class ControllabilityResult(_RankTest):
    """Kalman rank, PBH test and Gramian of (A, B).

    Parameters
    ----------
    n_states : int
        State dimension.
    rank : int
        Numerical rank of the controllability matrix [B, AB, ...].
    tol : float
        Relative singular-value tolerance used for ranks.
    singular_values : ndarray
        Singular values of the scaled Kalman matrix (see :mod:`trainctl.analysis.controllability`).
    condition_number : float
        Largest over n-th singular value of the scaled Kalman matrix.
    gramian_horizon : float
        Horizon T [s] (continuous) or number of steps N (discrete) of the Gramian.
    gramian_eigenvalues : ndarray
        Eigenvalues of the finite-horizon controllability Gramian, ascending.
    uncontrollable : tuple of UncontrollableMode
        Modes failing the PBH test.
    kind : str
        ``"controllability"``.

    Examples
    --------
    >>> import control as ct
    >>> from trainctl.analysis import analyse_controllability, analyse_observability
    >>> # Two decoupled states; the input drives and the output sees only "a".
    >>> sys = ct.ss([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [0.0]], [[1.0, 0.0]], 0, states=["a", "b"])
    >>> res = analyse_controllability(sys)
    >>> res.rank, res.n_states, res.full_rank, res.condition_number
    (1, 2, False, inf)
    >>> # Gramian over T = 10 s: "a" gets ∫ e^{-2t} dt = 0.5, "b" nothing.
    >>> res.gramian_horizon, res.gramian_eigenvalues.round(4).tolist()
    (10.0, [0.0, 0.5])
    """

    uncontrollable: tuple[UncontrollableMode, ...]
    kind: str = "controllability"

    @property
    def modes(self) -> tuple[UncontrollableMode, ...]:
        """The uncontrollable modes (:attr:`uncontrollable`)."""
        return self.uncontrollable

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``kind``, ``n_states``, ``rank``, ``tol``, ``full_rank``,
            ``condition_number`` (None when infinite), ``singular_values``,
            ``gramian_horizon`` ([s] or steps), ``gramian_eigenvalues``,
            and ``uncontrollable`` (each mode's dict).
        """
        return {"kind": self.kind, **self._numbers(),
                "uncontrollable": [m.to_dict() for m in self.uncontrollable]}

    def _repr_html_(self) -> str:
        return _html("Controllability", self, "uncontrollable")


@dataclass(frozen=True, kw_only=True)
class ObservabilityResult(_RankTest):
    """Kalman rank, PBH test and Gramian of (A, C): what the outputs can see.

    Parameters
    ----------
    n_states : int
        State dimension.
    rank : int
        Numerical rank of the observability matrix [C; CA; ...].
    tol : float
        Relative singular-value tolerance used for ranks.
    singular_values : ndarray
        Singular values of the scaled observability matrix (computed as the
        Kalman matrix of the dual pair (A^T, C^T), see
        :mod:`trainctl.analysis.controllability`).
    condition_number : float
        Largest over n-th singular value of the scaled observability matrix.
    gramian_horizon : float
        Horizon T [s] (continuous) or number of steps N (discrete) of the Gramian.
    gramian_eigenvalues : ndarray
        Eigenvalues of the finite-horizon observability Gramian, ascending.
    unobservable : tuple of UnobservableMode
        Modes failing the PBH test: state directions the outputs do not see.

    Examples
    --------
    >>> import control as ct
    >>> from trainctl.analysis import analyse_controllability, analyse_observability
    >>> # Two decoupled states; the input drives and the output sees only "a".
    >>> sys = ct.ss([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [0.0]], [[1.0, 0.0]], 0, states=["a", "b"])
    >>> res = analyse_observability(sys)
    >>> res.kind, res.rank, res.full_rank, len(res.modes)
    ('observability', 1, False, 1)
    >>> res.to_dict()["condition_number"]  # inf is written as None
    """

    unobservable: tuple[UnobservableMode, ...]
    kind: ClassVar[str] = "observability"

    @property
    def modes(self) -> tuple[UnobservableMode, ...]:
        """The unobservable modes."""
        return self.unobservable

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``kind``, ``n_states``, ``rank``, ``tol``, ``full_rank``,
            ``condition_number`` (None when infinite), ``singular_values``,
            ``gramian_horizon`` ([s] or steps), ``gramian_eigenvalues``,
            and ``unobservable`` (each mode's dict).
        """
        return {"kind": self.kind, **self._numbers(),
                "unobservable": [m.to_dict() for m in self.unobservable]}

    def _repr_html_(self) -> str:
        return _html("Observability", self, "unobservable")


def _html(title: str, res: ControllabilityResult | ObservabilityResult, word: str) -> str:
    return (f"<p><b>{title}</b>: rank {res.rank}/{res.n_states}, cond "
            f"{res.condition_number:.3g}, {len(res.modes)} {word} mode(s)</p>")
