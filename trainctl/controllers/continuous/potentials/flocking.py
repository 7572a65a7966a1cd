# Olfati-Saber's pair potential on the gap between two trains, in physical units (seed 002).
"""The flocking potential on the gap between two trains (seed 002, spec §3.3).

:class:`FlockingPotential` applies Olfati-Saber's primitives
(:mod:`~trainctl.controllers.continuous.potentials.sigma`) to the *gap*
between two trains (tail-to-head distance, not the centre distance, so that
a zero gap is a collision), with distances normalised by a length scale and
the action scaled to a physical specific force; :class:`CollisionBound` is
its collision barrier.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_finite
from trainctl.controllers.continuous.potentials.sigma import (
    Floats,
    _array,
    _bump,
    _check_ab,
    _check_h,
    _out,
    _phi_alpha,
    _positive,
    _shift,
    psi_alpha,
    sigma_grad,
    sigma_norm,
)
from trainctl.exceptions import ModelError

__all__ = ["CollisionBound", "FlockingPotential"]


class CollisionBound(NamedTuple):
    """Energy barrier of a collision (spec §3.4 item 1).

    Parameters
    ----------
    energy : float
        Pair potential at gap 0 minus its minimum [m²/s²] (per unit mass).
    relative_speed : float
        ``sqrt(2 energy)`` [m/s]: a pair closing faster than this (with no
        other energy in the loop) could overcome the barrier.

    Examples
    --------
    >>> b = CollisionBound(energy=50.0, relative_speed=math.sqrt(2 * 50.0))
    >>> b.relative_speed  # √(2·50 m²/s²) = 10 m/s
    10.0
    >>> isinstance(FlockingPotential().collision_energy_bound(), CollisionBound)
    True
    """

    energy: float
    relative_speed: float


@dataclass(frozen=True, kw_only=True)
class FlockingPotential:
    """Olfati-Saber's pair potential on the gap between two trains, in physical units.

    Distances are normalised by the length scale (``s~ = s / length_scale``)
    before the sigma-norm, and the dimensionless action is scaled by
    ``force_scale`` (spec §3.3, §5 item 9): with raw metres and eps = 0.1 the
    action saturates within a metre of the desired gap. The potential acts on
    the **gap** s (tail of the front train to head of the rear train) [m], so
    that gap 0 is a collision (spec §5 item 10). The defaults are the seed-002
    set of spec §3.5.

    Sign convention: :meth:`acceleration` is the specific force on the rear
    (follower) train, positive forward; the front train gets its opposite.

    Parameters
    ----------
    desired_gap : float
        d [m], > 0.
    interaction_range : float or None
        r [m], > d; None for 1.2 d. Beyond it the pair does not interact.
    length_scale : float
        l [m], > 0: distances enter the sigma-norm as s / l.
    eps : float
        Sigma-norm parameter [-] (on normalised distances), > 0.
    h : float
        Bump parameter [-], 0 < h < 1.
    a, b : float
        Attraction and repulsion levels of phi [-], 0 < a <= b.
    force_scale : float
        a_s [m/s²], > 0: the specific force of a unit action.

    Examples
    --------
    >>> p = FlockingPotential()
    >>> p.interaction_range
    600.0
    >>> round(p.d_alpha, 4), round(p.r_alpha, 4)  # (sqrt(11) - 1)/0.1, (sqrt(15.4) - 1)/0.1
    (23.1662, 29.2428)
    >>> p.acceleration(500.0)
    0.0
    >>> p.acceleration(450.0) < 0.0 < p.acceleration(550.0)  # pushed back / pulled forward
    True
    """

    desired_gap: float = 500.0
    interaction_range: float | None = None
    length_scale: float = 50.0
    eps: float = 0.1
    h: float = 0.2
    a: float = 1.0
    b: float = 1.0
    force_scale: float = 0.05

    def __post_init__(self) -> None:
        where = "FlockingPotential"
        d = _positive(where, "desired_gap", self.desired_gap, " m")
        r = 1.2 * d if self.interaction_range is None else check_finite(
            where, "interaction_range", self.interaction_range)
        if r <= d:
            raise ModelError(
                f"{where}: 'interaction_range' must be > desired_gap (got "
                f"interaction_range={self.interaction_range!r} m, desired_gap={d!r} m).")
        object.__setattr__(self, "desired_gap", d)
        object.__setattr__(self, "interaction_range", r)
        object.__setattr__(self, "length_scale",
                           _positive(where, "length_scale", self.length_scale, " m"))
        object.__setattr__(self, "eps", _positive(where, "eps", self.eps))
        object.__setattr__(self, "h", _check_h(where, self.h))
        a, b = _check_ab(where, self.a, self.b)
        object.__setattr__(self, "a", a)
        object.__setattr__(self, "b", b)
        object.__setattr__(self, "force_scale",
                           _positive(where, "force_scale", self.force_scale, " m/s²"))

    @property
    def r(self) -> float:
        """The interaction range r [m] (``interaction_range`` once resolved)."""
        assert self.interaction_range is not None  # set in __post_init__
        return self.interaction_range

    @property
    def d_alpha(self) -> float:
        """``||d / l||_sigma`` [-]: the desired gap in sigma-norm units."""
        return float(sigma_norm(self.desired_gap / self.length_scale, self.eps))

    @property
    def r_alpha(self) -> float:
        """``||r / l||_sigma`` [-]: the interaction range in sigma-norm units."""
        return float(sigma_norm(self.r / self.length_scale, self.eps))

    def _gaps(self, where: str, gap: ArrayLike) -> tuple[NDArray[np.float64], bool]:
        arr, scalar = _array(gap)
        bad = ~(np.isfinite(arr) & (arr >= 0.0))
        if np.any(bad):
            first = arr[bad].ravel()[0]
            raise ModelError(
                f"FlockingPotential.{where}: 'gap' must be finite and >= 0 m (got {first!r}); "
                "a negative gap means the trains overlap (a collision), where the potential "
                "is not defined.")
        return arr, scalar

    def _normalised(self, arr: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """Normalised gap, its sigma-norm and the sigma-norm's slope."""
        x = arr / self.length_scale
        root = np.sqrt(1.0 + self.eps * x * x)
        return x, (root - 1.0) / self.eps, x / root

    def acceleration(self, gap: ArrayLike) -> Floats:
        """Specific force on the rear train, ``a_s phi_alpha(||s/l||_sigma) sigma_eps(s/l)``.

        Positive (forward) when the gap exceeds the desired gap, negative
        (backward) when it is shorter, zero at the desired gap, beyond the
        range, and at gap 0 (the sigma-norm's slope vanishes there). The front
        train gets the opposite. It equals ``dE/ds`` with E = :meth:`energy`.

        Parameters
        ----------
        gap : array_like
            Gaps s [m], >= 0.

        Returns
        -------
        float or numpy.ndarray
            Specific force [m/s²].

        Raises
        ------
        ModelError
            If a gap is negative or not finite.

        Examples
        --------
        >>> p = FlockingPotential()
        >>> p.acceleration([700.0, 500.0]).tolist()
        [0.0, 0.0]
        """
        arr, scalar = self._gaps("acceleration", gap)
        _, z, slope = self._normalised(arr)
        action = _phi_alpha(z, self.d_alpha, self.r_alpha, self.h, self.a, self.b)
        return _out(self.force_scale * action * slope, scalar)

    def energy(self, gap: ArrayLike) -> Floats:
        """Pair potential per unit mass, ``E(s) = l a_s psi_alpha(||s/l||_sigma)`` [m²/s²].

        Chain rule: with ``z = ||s/l||_sigma``, ``dz/ds = sigma_eps(s/l) / l`` and
        ``psi_alpha' = phi_alpha``, so ``dE/ds = a_s phi_alpha(z) sigma_eps(s/l)``
        = :meth:`acceleration`. The gap is ``s = x_j - x_i - L`` (j front, i
        rear), so the rear train's force is ``-dE/dx_i = +dE/ds`` and the
        front train's ``-dE/dx_j = -dE/ds``: the potential's negative gradient
        with respect to each train's position.

        Parameters
        ----------
        gap : array_like
            Gaps s [m], >= 0.

        Returns
        -------
        float or numpy.ndarray
            E(s) [m²/s²]: 0 at the desired gap, >= 0, constant beyond the range.

        Examples
        --------
        >>> p = FlockingPotential()
        >>> p.energy(500.0)
        0.0
        >>> p.energy(0.0) > p.energy(250.0) > p.energy(499.0) > 0.0
        True
        """
        arr, scalar = self._gaps("energy", gap)
        _, z, _ = self._normalised(arr)
        psi = psi_alpha(z, d_alpha=self.d_alpha, r_alpha=self.r_alpha, h=self.h,
                        a=self.a, b=self.b)
        return _out(self.length_scale * self.force_scale * np.asarray(psi), scalar)

    def adjacency(self, gap: ArrayLike) -> Floats:
        """Adjacency weight ``rho_h(||s/l||_sigma / r_alpha)`` of the pair [-].

        Parameters
        ----------
        gap : array_like
            Gaps s [m], >= 0.

        Returns
        -------
        float or numpy.ndarray
            Weight in [0, 1]: 1 for short gaps, 0 at and beyond the range.

        Examples
        --------
        >>> FlockingPotential().adjacency([0.0, 600.0]).tolist()
        [1.0, 0.0]
        """
        arr, scalar = self._gaps("adjacency", gap)
        _, z, _ = self._normalised(arr)
        return _out(_bump(z / self.r_alpha, self.h), scalar)

    def stiffness(self) -> float:
        """Effective linear lattice stiffness k_eff [1/s²] at the desired gap (spec §3.4 item 3).

        ``k_eff = d(acceleration)/d(gap)`` at s = d. Since ``phi_alpha(d_alpha) = 0``
        only the derivative of the action survives:
        ``k_eff = (a_s / l) rho_h(d_alpha/r_alpha) phi'(0) sigma_eps(d/l)²`` with
        ``phi'(0) = ((a + b)/2) (1 + c²)^(-3/2)``. The bump factor makes the
        lattice softer than phi'(0) suggests when d_alpha / r_alpha > h.

        Returns
        -------
        float
            The stiffness k_eff [1/s²], > 0 (rear train: ``ddx_i ≈ k_eff (dx_j - dx_i)``).

        Examples
        --------
        >>> p = FlockingPotential()
        >>> round(p.stiffness() * 1e3, 2)  # 1e-3 * 0.1574 * 100/11 s^-2
        1.43
        """
        c = _shift(self.a, self.b)
        slope_phi = 0.5 * (self.a + self.b) * (1.0 + c * c) ** -1.5
        weight = float(_bump(np.asarray(self.d_alpha / self.r_alpha), self.h))
        slope_sigma = float(sigma_grad(self.desired_gap / self.length_scale, self.eps))
        slope: float = self.force_scale / self.length_scale * weight * slope_phi * slope_sigma**2
        return slope

    def collision_energy_bound(self) -> CollisionBound:
        """Energy barrier at gap 0, ``l a_s psi_alpha(0)`` [m²/s²], and its speed (spec §3.4, 1).

        If the scenario's energy (relative kinetic energy per unit mass plus
        the potential) starts below this barrier, the pair cannot reach gap 0.

        Returns
        -------
        CollisionBound
            ``energy`` [m²/s²] and ``relative_speed = sqrt(2 energy)`` [m/s].

        Examples
        --------
        >>> bound = FlockingPotential().collision_energy_bound()
        >>> bound.relative_speed == (2.0 * bound.energy) ** 0.5
        True
        """
        energy = float(self.energy(0.0))
        return CollisionBound(energy=energy, relative_speed=math.sqrt(2.0 * energy))

    def saturation_gap(self, fraction: float = 0.9,
                       side: Literal["attraction", "repulsion"] = "attraction") -> float:
        """Gap deviation |s - d| [m] at which the action phi reaches ``fraction`` of its level.

        On the attraction side (s > d) the level is ``a``, on the repulsion side
        (s < d) ``b``: the width of the quasi-linear band of the spacing loop
        (spec §3.3: 34 m for l = 50 m, d = 500 m, eps = 0.1, a = b). The bump
        is left out on purpose (it is a range cut-off, not a saturation); the
        acceleration's envelope is this times ``rho_h`` and ``sigma_eps``.
        Solved in closed form: invert phi, then the sigma-norm.

        Parameters
        ----------
        fraction : float
            Fraction of the level [-], 0 < fraction < 1.
        side : {"attraction", "repulsion"}
            Which side of the desired gap.

        Returns
        -------
        float
            Deviation [m], > 0; inf when the repulsion never reaches the
            fraction before gap 0.

        Examples
        --------
        >>> round(FlockingPotential().saturation_gap(0.9), 1)  # spec §3.3: 34 m
        34.1
        """
        f = check_finite("FlockingPotential.saturation_gap", "fraction", fraction)
        if not 0.0 < f < 1.0:
            raise ModelError("FlockingPotential.saturation_gap: 'fraction' must satisfy "
                             f"0 < fraction < 1 (got {fraction!r}).")
        if side not in ("attraction", "repulsion"):
            raise ModelError("FlockingPotential.saturation_gap: 'side' must be 'attraction' "
                             f"or 'repulsion' (got {side!r}).")
        level = f * self.a if side == "attraction" else -f * self.b
        t = (2.0 * level - (self.a - self.b)) / (self.a + self.b)   # sigma_1(w + c) = t
        z = self.d_alpha + t / math.sqrt(1.0 - t * t) - _shift(self.a, self.b)
        if z < 0.0:
            return math.inf
        x = math.sqrt(((1.0 + self.eps * z) ** 2 - 1.0) / self.eps)
        return abs(self.length_scale * x - self.desired_gap)
