# Pair potentials on the spacing deviation between coupled cars (seed 001).
"""Spacing-deviation pair potentials of the potential family (seed 001, spec §2.2).

``u_4i = -m_i sum_j grad U_ij`` with a potential on the spacing deviation z
[m]: the linear spring :class:`QuadraticPotential`, the barrier
:class:`BarrierPotential` and :class:`SigmaNormPotential` (the flocking
potential seen as a function of the deviation from the desired gap), each
following :class:`PairPotential`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import brentq

from trainctl._validation import check_finite
from trainctl.controllers.continuous.potentials.flocking import FlockingPotential
from trainctl.controllers.continuous.potentials.sigma import Floats, _array, _out, _positive
from trainctl.exceptions import ModelError

__all__ = ["BarrierPotential", "PairPotential", "QuadraticPotential", "SigmaNormPotential"]


@runtime_checkable
class PairPotential(Protocol):
    """A pair potential per unit mass on the spacing deviation z [m] (seed 001, spec §2.2).

    z is the elongation of the pair (gap minus nominal gap): positive when the
    cars are farther apart than nominal. The rear car's specific force is
    ``+gradient(z)`` and the front car's ``-gradient(z)`` [m/s²], i.e.
    ``u_4i = -m_i sum_j grad_{x_i} U_ij``.

    Examples
    --------
    The quadratic spring and the barrier both provide the four methods; near
    z = 0 the barrier κ/2 ln(Δ²/(Δ² - z²)) ≈ κ z²/(2Δ²) is a spring of
    stiffness κ/Δ²:

    >>> members = ("energy", "gradient", "curvature", "bound")
    >>> for p in (QuadraticPotential(0.5), BarrierPotential(kappa=0.02, delta=0.2)):
    ...     print(type(p).__name__, all(hasattr(p, m) for m in members), round(p.curvature(), 6))
    QuadraticPotential True 0.5
    BarrierPotential True 0.5
    """

    def energy(self, z: ArrayLike) -> Floats:
        """U(z) [m²/s²].

        Parameters
        ----------
        z : array_like
            Spacing deviations z [m] (positive: elongation).

        Returns
        -------
        float or numpy.ndarray
            The potential per unit mass U(z) [m²/s²], elementwise.
        """
        ...

    def gradient(self, z: ArrayLike) -> Floats:
        """dU/dz [m/s²].

        Parameters
        ----------
        z : array_like
            Spacing deviations z [m] (positive: elongation).

        Returns
        -------
        float or numpy.ndarray
            The gradient dU/dz [m/s²], elementwise: the rear car's specific
            force (the front car's is its opposite).
        """
        ...

    def curvature(self) -> float:
        """d²U/dz² at z = 0 [1/s²]: the linearisation's stiffness.

        Returns
        -------
        float
            The stiffness d²U/dz² at z = 0 [1/s²], > 0.
        """
        ...

    def bound(self, energy_budget: float) -> float:
        """Largest |z| [m] reachable with ``energy_budget`` [m²/s²] of potential energy.

        Parameters
        ----------
        energy_budget : float
            Energy per unit mass available to the potential [m²/s²], >= 0.

        Returns
        -------
        float
            The largest spacing deviation |z| [m] with U(z) <= energy_budget,
            >= 0 (inf if unbounded).
        """
        ...


def _budget(where: str, energy_budget: float) -> float:
    e = check_finite(where, "energy_budget", energy_budget)
    if e < 0.0:
        raise ModelError(f"{where}: 'energy_budget' must be >= 0 m²/s² (got {energy_budget!r}).")
    return e


@dataclass(frozen=True)
class QuadraticPotential:
    """Linear virtual spring (P1): ``U(z) = kappa z² / 2`` per unit mass.

    Parameters
    ----------
    kappa : float
        Stiffness per unit mass [1/s²], > 0.

    Examples
    --------
    >>> p = QuadraticPotential(0.5)
    >>> p.energy(2.0), p.gradient(2.0), p.curvature(), p.bound(1.0)
    (1.0, 1.0, 0.5, 2.0)
    """

    kappa: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "kappa",
                           _positive("QuadraticPotential", "kappa", self.kappa, " 1/s²"))

    def energy(self, z: ArrayLike) -> Floats:
        """U(z) = kappa z² / 2 [m²/s²] for spacing deviations z [m].

        Parameters
        ----------
        z : array_like
            Spacing deviations z [m] (positive: elongation).

        Returns
        -------
        float or numpy.ndarray
            The potential per unit mass U(z) [m²/s²], >= 0, elementwise.
        """
        arr, scalar = _array(z)
        return _out(0.5 * self.kappa * arr * arr, scalar)

    def gradient(self, z: ArrayLike) -> Floats:
        """dU/dz = kappa z [m/s²] for spacing deviations z [m].

        Parameters
        ----------
        z : array_like
            Spacing deviations z [m] (positive: elongation).

        Returns
        -------
        float or numpy.ndarray
            The gradient kappa z [m/s²], elementwise: the rear car's specific
            force (the front car's is its opposite).
        """
        arr, scalar = _array(z)
        return _out(self.kappa * arr, scalar)

    def curvature(self) -> float:
        """kappa [1/s²].

        Returns
        -------
        float
            The stiffness kappa [1/s²], > 0 (the curvature is the same for every z).
        """
        return self.kappa

    def bound(self, energy_budget: float) -> float:
        """sqrt(2 E / kappa) [m] for a budget E [m²/s²].

        Parameters
        ----------
        energy_budget : float
            Energy per unit mass E available to the spring [m²/s²], >= 0.

        Returns
        -------
        float
            The largest spacing deviation |z| = sqrt(2 E / kappa) [m], >= 0.

        Raises
        ------
        ModelError
            If energy_budget is negative or not finite.
        """
        return math.sqrt(2.0 * _budget("QuadraticPotential.bound", energy_budget) / self.kappa)


@dataclass(frozen=True)
class BarrierPotential:
    """Logarithmic barrier (P2): ``U(z) = (kappa/2) ln(delta² / (delta² - z²))`` per unit mass.

    Defined on ``|z| < delta`` (e.g. the coupler stroke or a safety margin):
    U -> inf at the boundary, so a non-increasing Lyapunov function keeps
    ``|z(t)| < delta``. Outside (|z| >= delta) :meth:`energy` is ``+inf`` and
    :meth:`gradient` is NaN (the force is undefined there; an integrator that
    steps out must shorten its step), with no warning raised.

    Parameters
    ----------
    kappa : float
        Barrier strength [m²/s²], > 0 (the log is dimensionless); the
        stiffness at z = 0 is ``kappa / delta²`` [1/s²]
        (:meth:`with_stiffness` builds it from that stiffness).
    delta : float
        Half-width of the admissible band [m], > 0.

    Examples
    --------
    >>> p = BarrierPotential(kappa=2.0, delta=1.0)
    >>> p.gradient(0.5), p.curvature()  # 2 * 0.5 / 0.75, 2 / 1
    (1.3333333333333333, 2.0)
    >>> p.energy(1.0), round(p.bound(1.0), 4)  # sqrt(1 - exp(-1))
    (inf, 0.7951)
    """

    kappa: float
    delta: float

    def __post_init__(self) -> None:
        where = "BarrierPotential"
        object.__setattr__(self, "kappa", _positive(where, "kappa", self.kappa, " m²/s²"))
        object.__setattr__(self, "delta", _positive(where, "delta", self.delta, " m"))

    @classmethod
    def with_stiffness(cls, stiffness: float, delta: float) -> BarrierPotential:
        """The barrier whose curvature at z = 0 is ``stiffness`` [1/s²] (kappa = stiffness delta²).

        Parameters
        ----------
        stiffness : float
            d²U/dz² at 0 [1/s²], > 0.
        delta : float
            Half-width of the band [m], > 0.

        Returns
        -------
        BarrierPotential
            With kappa = stiffness * delta² [m²/s²].

        Examples
        --------
        >>> BarrierPotential.with_stiffness(0.5, 2.0).kappa
        2.0
        """
        k = _positive("BarrierPotential.with_stiffness", "stiffness", stiffness, " 1/s²")
        dd = _positive("BarrierPotential.with_stiffness", "delta", delta, " m")
        return cls(kappa=k * dd * dd, delta=dd)

    def _split(self, z: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.bool_], bool]:
        arr, scalar = _array(z)
        inside = np.abs(arr) < self.delta
        return np.where(inside, arr, 0.0) / self.delta, inside, scalar

    def energy(self, z: ArrayLike) -> Floats:
        """U(z) [m²/s²] for deviations z [m]; +inf where |z| >= delta.

        Parameters
        ----------
        z : array_like
            Spacing deviations z [m] (positive: elongation).

        Returns
        -------
        float or numpy.ndarray
            The potential per unit mass U(z) [m²/s²], >= 0, elementwise; +inf
            where |z| >= delta.
        """
        u, inside, scalar = self._split(z)
        value = -0.5 * self.kappa * np.log1p(-u * u)
        return _out(np.where(inside, value, np.inf), scalar)

    def gradient(self, z: ArrayLike) -> Floats:
        """dU/dz = kappa z / (delta² - z²) [m/s²] for z [m]; NaN where |z| >= delta.

        Parameters
        ----------
        z : array_like
            Spacing deviations z [m] (positive: elongation).

        Returns
        -------
        float or numpy.ndarray
            The gradient dU/dz [m/s²], elementwise: the rear car's specific
            force (the front car's is its opposite); NaN where |z| >= delta.
        """
        u, inside, scalar = self._split(z)
        value = self.kappa * u / (self.delta * (1.0 - u * u))
        return _out(np.where(inside, value, np.nan), scalar)

    def curvature(self) -> float:
        """kappa / delta² [1/s²].

        Returns
        -------
        float
            The stiffness d²U/dz² at z = 0, kappa / delta² [1/s²], > 0.
        """
        return self.kappa / self.delta**2

    def bound(self, energy_budget: float) -> float:
        """``delta sqrt(1 - exp(-2E/kappa))`` [m] for a budget E [m²/s²]: always < delta.

        Parameters
        ----------
        energy_budget : float
            Energy per unit mass E available to the barrier [m²/s²], >= 0.

        Returns
        -------
        float
            The largest spacing deviation |z| [m], in [0, delta).

        Raises
        ------
        ModelError
            If energy_budget is negative or not finite.
        """
        e = _budget("BarrierPotential.bound", energy_budget)
        return self.delta * math.sqrt(-math.expm1(-2.0 * e / self.kappa))


@dataclass(frozen=True)
class SigmaNormPotential:
    """The flocking potential (P3) on the spacing deviation ``z = gap - desired_gap`` [m].

    ``U(z) = flocking.energy(d + z)``; the nominal spacing is the flocking
    potential's desired gap d (for a centre-distance spacing, the nominal
    is ``L + d`` and the deviation is the same). Defined for ``z >= -d``
    (gap >= 0); smaller deviations raise :class:`~trainctl.exceptions.ModelError`.
    Unlike P1 and P2 it is not even: the repulsion (z < 0) is bounded by the
    collision barrier and the attraction (z > 0) vanishes beyond the range.

    Parameters
    ----------
    flocking : FlockingPotential
        The pair potential on the gap (physical units).

    Examples
    --------
    >>> p = SigmaNormPotential(FlockingPotential())
    >>> p.energy(0.0), p.gradient(0.0)
    (0.0, 0.0)
    >>> p.curvature() == FlockingPotential().stiffness()
    True
    """

    flocking: FlockingPotential

    def energy(self, z: ArrayLike) -> Floats:
        """U(z) [m²/s²] for deviations z [m] >= -desired_gap.

        Parameters
        ----------
        z : array_like
            Deviations z = gap - desired_gap [m], >= -desired_gap.

        Returns
        -------
        float or numpy.ndarray
            The flocking energy at gap d + z [m²/s²], >= 0, elementwise: 0 at
            z = 0, constant beyond the range.

        Raises
        ------
        ModelError
            If a deviation is below -desired_gap (a negative gap) or not finite.
        """
        arr, scalar = _array(z)
        return _out(np.asarray(self.flocking.energy(self.flocking.desired_gap + arr)), scalar)

    def gradient(self, z: ArrayLike) -> Floats:
        """dU/dz [m/s²] = the flocking acceleration of the rear train at gap d + z.

        Parameters
        ----------
        z : array_like
            Deviations z = gap - desired_gap [m], >= -desired_gap.

        Returns
        -------
        float or numpy.ndarray
            The gradient dU/dz [m/s²], elementwise (:meth:`FlockingPotential.acceleration`
            at gap d + z): positive for z > 0 and negative for z < 0 inside the
            range; 0 at z = 0, at gap 0 and beyond the range.

        Raises
        ------
        ModelError
            If a deviation is below -desired_gap (a negative gap) or not finite.
        """
        arr, scalar = _array(z)
        accel = self.flocking.acceleration(self.flocking.desired_gap + arr)
        return _out(np.asarray(accel), scalar)

    def curvature(self) -> float:
        """The lattice stiffness k_eff [1/s²] (:meth:`FlockingPotential.stiffness`).

        Returns
        -------
        float
            The stiffness d²U/dz² at z = 0 [1/s²], > 0.
        """
        return self.flocking.stiffness()

    def bound(self, energy_budget: float) -> float:
        """Largest |z| [m] with U(z) <= budget [m²/s²], on either side of 0.

        inf when the budget reaches the energy at the range (the pair can
        separate); ``desired_gap`` when it reaches the collision barrier.

        Parameters
        ----------
        energy_budget : float
            Energy per unit mass E available to the potential [m²/s²], >= 0.

        Returns
        -------
        float
            The largest deviation |z| [m] with U(z) <= E, >= 0: 0 for E = 0,
            inf when E reaches the energy at the range; at least desired_gap
            (the larger of it and the attraction-side deviation) when E
            reaches the collision barrier.

        Raises
        ------
        ModelError
            If energy_budget is negative or not finite.
        """
        e = _budget("SigmaNormPotential.bound", energy_budget)
        d, r = self.flocking.desired_gap, self.flocking.r
        if e == 0.0:
            return 0.0
        if e >= float(self.energy(r - d)):
            return math.inf
        ahead = brentq(lambda z: float(self.energy(z)) - e, 0.0, r - d, xtol=1e-12)
        if e >= self.flocking.collision_energy_bound().energy:
            return float(max(ahead, d))
        behind = brentq(lambda z: float(self.energy(-z)) - e, 0.0, d, xtol=1e-12)
        return float(max(ahead, behind))
