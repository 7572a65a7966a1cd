# Pair potentials shared by the flocking (seed 002) and potential-gradient (seed 001) controllers.
"""Potential functions of the distributed train controllers.

Two families of controllers use a pairwise potential between neighbouring
trains (or cars):

* seed 002 (virtual coupling of heavy-haul trains) uses the flocking
  primitives of Olfati-Saber, R. (2006), "Flocking for multi-agent dynamic
  systems: algorithms and theory", IEEE Trans. Automatic Control 51(3),
  pp. 401-420: the sigma-norm, the bump function rho_h, the action function
  phi_alpha and the pairwise potential psi_alpha. :class:`FlockingPotential`
  applies them to the *gap* between two trains (tail-to-head distance, not
  the centre distance, so that a zero gap is a collision), with distances
  normalised by a length scale and the action scaled to a physical specific
  force;
* seed 001 (high-speed train cars) uses ``u_4i = -m_i sum_j grad U_ij`` with a
  potential on the spacing deviation: :class:`QuadraticPotential`,
  :class:`BarrierPotential` and :class:`SigmaNormPotential` (the flocking
  potential seen as a function of the deviation from the desired gap).

Sign conventions (spec §5 item 8). For a pair, the *front* train j leads the
*rear* (follower) train i; the gap is ``s = x_j - x_i - L_j`` [m] (L_j the
length of the front train) and the spacing deviation is ``z = s - d`` [m]
(positive: farther apart than desired, an elongation). Every potential here
is per unit mass [m²/s²]: a potential ``U(s)`` gives the rear train the
specific force ``-dU/dx_i = +dU/ds`` [m/s²] and the front train
``-dU/dx_j = -dU/ds``. So a follower that is too far behind is pulled
forward, a follower that is too close is pushed back (and its leader pushed
forward).

The primitives act elementwise on arrays (each entry is a scalar distance on
a line of trains, so ``||z|| = |z|``); a scalar argument gives a float.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import quad
from scipy.optimize import brentq

from trainctl._validation import check_finite
from trainctl.exceptions import ModelError

__all__ = [
    "BarrierPotential",
    "CollisionBound",
    "FlockingPotential",
    "PairPotential",
    "QuadraticPotential",
    "SigmaNormPotential",
    "bump",
    "phi",
    "phi_alpha",
    "psi_alpha",
    "sigma1",
    "sigma_grad",
    "sigma_norm",
]

Floats = float | NDArray[np.float64]
"""A float for a scalar argument, else an array of the argument's shape."""

_QUAD_EPSREL = 1e-12
_QUAD_EPSABS = 1e-15


# ---------------------------------------------------------------- helpers

def _array(z: ArrayLike) -> tuple[NDArray[np.float64], bool]:
    """The argument as a float array and whether it was a scalar."""
    arr = np.asarray(z, dtype=float)
    return arr, arr.ndim == 0


def _out(arr: NDArray[np.float64], scalar: bool) -> Floats:
    """A float for a scalar argument, the array otherwise."""
    return float(arr) if scalar else arr


def _positive(where: str, name: str, value: float, unit: str = "") -> float:
    x = check_finite(where, name, value)
    if x <= 0.0:
        raise ModelError(f"{where}: {name!r} must be > 0{unit} (got {value!r}).")
    return x


def _check_h(where: str, h: float) -> float:
    """The bump parameter, refused unless 0 < h < 1 (h = 1 explained)."""
    x = check_finite(where, "h", h)
    if x == 1.0:
        raise ModelError(
            f"{where}: 'h' must satisfy 0 < h < 1 (got {h!r}). With h = 1 (the patent's "
            "value) rho_1 is the discontinuous indicator of [0, 1): the adjacency jumps "
            "from 1 to 0 at the interaction range, which makes the adjacency and the "
            "closed loop non-Lipschitz; use h < 1 (Olfati-Saber uses h = 0.2).")
    if not 0.0 < x < 1.0:
        raise ModelError(f"{where}: 'h' must satisfy 0 < h < 1 (got {h!r}).")
    return x


def _check_ab(where: str, a: float, b: float) -> tuple[float, float]:
    """The action-function levels, refused unless 0 < a <= b."""
    xa = check_finite(where, "a", a)
    xb = check_finite(where, "b", b)
    if xa <= 0.0:
        raise ModelError(f"{where}: 'a' must satisfy 0 < a <= b (got a={a!r}, b={b!r}).")
    if xa > xb:
        raise ModelError(
            f"{where}: 'b' must satisfy b >= a > 0 (got a={a!r}, b={b!r}): b is the "
            "repulsion level, a the attraction level, and phi's shift c assumes a <= b.")
    return xa, xb


def _check_range(where: str, d_alpha: float, r_alpha: float) -> tuple[float, float]:
    d = _positive(where, "d_alpha", d_alpha)
    r = check_finite(where, "r_alpha", r_alpha)
    if r <= d:
        raise ModelError(
            f"{where}: 'r_alpha' must be > d_alpha (got r_alpha={r_alpha!r}, "
            f"d_alpha={d_alpha!r}): the interaction range must exceed the desired distance.")
    return d, r


# ---------------------------------------------------------------- primitives

def sigma_norm(z: ArrayLike, eps: float) -> Floats:
    """Sigma-norm ``||z||_sigma = (sqrt(1 + eps z²) - 1) / eps`` (Olfati-Saber 2006, eq. 8).

    Unlike ``|z|`` it is differentiable at 0; it grows like ``|z| / sqrt(eps)``.

    Parameters
    ----------
    z : array_like
        Distances, elementwise [any length unit, usually normalised: -].
    eps : float
        Sigma-norm parameter [1/(unit of z)²], > 0.

    Returns
    -------
    float or numpy.ndarray
        The sigma-norms [unit of z], >= 0.

    Examples
    --------
    >>> sigma_norm(0.0, 0.1)
    0.0
    >>> round(sigma_norm(10.0, 0.1), 4)  # (sqrt(11) - 1) / 0.1
    23.1662
    """
    e = _positive("sigma_norm", "eps", eps)
    arr, scalar = _array(z)
    return _out((np.sqrt(1.0 + e * arr * arr) - 1.0) / e, scalar)


def sigma_grad(z: ArrayLike, eps: float) -> Floats:
    """Gradient of the sigma-norm, ``sigma_eps(z) = z / sqrt(1 + eps z²)``.

    It is odd in z and saturates at ``±1/sqrt(eps)``; ``n_ij = sigma_eps(x_j - x_i)``
    points from agent i to agent j.

    Parameters
    ----------
    z : array_like
        Distances, elementwise [unit of z].
    eps : float
        Sigma-norm parameter [1/(unit of z)²], > 0.

    Returns
    -------
    float or numpy.ndarray
        The gradient d ||z||_sigma / dz [-].

    Examples
    --------
    >>> round(sigma_grad(10.0, 0.1), 4)  # 10 / sqrt(11)
    3.0151
    """
    e = _positive("sigma_grad", "eps", eps)
    arr, scalar = _array(z)
    return _out(arr / np.sqrt(1.0 + e * arr * arr), scalar)


def _bump(x: NDArray[np.float64], h: float) -> NDArray[np.float64]:
    cosine = 0.5 * (1.0 + np.cos(np.pi * (x - h) / (1.0 - h)))
    return np.where(x < 0.0, 0.0, np.where(x < h, 1.0, np.where(x <= 1.0, cosine, 0.0)))


def bump(z: ArrayLike, h: float) -> Floats:
    """Bump function rho_h (Olfati-Saber 2006, eq. 10): a smooth step from 1 to 0.

    ``rho_h(z) = 1`` on [0, h), ``(1 + cos(pi (z - h) / (1 - h))) / 2`` on
    [h, 1] and 0 otherwise. It is C¹ for 0 < h < 1; h = 1 (the indicator
    of [0, 1), as in the seed-002 patent) is refused because it makes the
    adjacency and the closed loop non-Lipschitz.

    Parameters
    ----------
    z : array_like
        Normalised distances [-].
    h : float
        Start of the cosine ramp [-], 0 < h < 1.

    Returns
    -------
    float or numpy.ndarray
        The bump rho_h(z) in [0, 1] [-].

    Raises
    ------
    ModelError
        If h is not in (0, 1).

    Examples
    --------
    >>> bump(0.1, 0.2), round(bump(0.6, 0.2), 12), bump(1.5, 0.2)
    (1.0, 0.5, 0.0)
    """
    hh = _check_h("bump", h)
    arr, scalar = _array(z)
    return _out(_bump(arr, hh), scalar)


def sigma1(z: ArrayLike) -> Floats:
    """Uneven sigmoid ``sigma_1(z) = z / sqrt(1 + z²)``, in (-1, 1).

    Parameters
    ----------
    z : array_like
        Argument [-].

    Returns
    -------
    float or numpy.ndarray
        The sigmoid sigma_1(z) [-].

    Examples
    --------
    >>> round(sigma1(1.0), 4)  # 1 / sqrt(2)
    0.7071
    """
    arr, scalar = _array(z)
    return _out(arr / np.sqrt(1.0 + arr * arr), scalar)


def _shift(a: float, b: float) -> float:
    return abs(a - b) / math.sqrt(4.0 * a * b)


def _phi(z: NDArray[np.float64], a: float, b: float) -> NDArray[np.float64]:
    w = z + _shift(a, b)
    return 0.5 * ((a + b) * w / np.sqrt(1.0 + w * w) + (a - b))


def phi(z: ArrayLike, a: float, b: float) -> Floats:
    """Action function ``phi(z) = ((a + b) sigma_1(z + c) + (a - b)) / 2``.

    With ``c = |a - b| / sqrt(4ab)``, ``phi(0) = 0``: phi rises from -b
    (repulsion, z -> -inf) to a (attraction, z -> +inf), with slope
    ``phi'(0) = ((a + b)/2) (1 + c²)^(-3/2)``. Some public implementations use
    the signed shift ``c = (a - b)/sqrt(4ab)``, which gives ``phi(0) = a - b``
    (not 0) whenever a != b; they agree only for a = b.

    Parameters
    ----------
    z : array_like
        Argument (distance minus desired distance, in sigma-norm units) [-].
    a : float
        Attraction level [-], 0 < a <= b.
    b : float
        Repulsion level [-], b >= a.

    Returns
    -------
    float or numpy.ndarray
        The action phi(z) [-].

    Examples
    --------
    >>> abs(phi(0.0, 1.0, 5.0)) < 1e-12
    True
    >>> round(phi(1e9, 1.0, 5.0), 6), round(phi(-1e9, 1.0, 5.0), 6)
    (1.0, -5.0)
    """
    aa, bb = _check_ab("phi", a, b)
    arr, scalar = _array(z)
    return _out(_phi(arr, aa, bb), scalar)


def _phi_alpha(z: NDArray[np.float64], d_alpha: float, r_alpha: float, h: float,
               a: float, b: float) -> NDArray[np.float64]:
    return _bump(z / r_alpha, h) * _phi(z - d_alpha, a, b)


def phi_alpha(z: ArrayLike, *, d_alpha: float, r_alpha: float, h: float = 0.2,
              a: float = 5.0, b: float = 5.0) -> Floats:
    """Action function with finite cut-off ``phi_alpha(z) = rho_h(z/r_alpha) phi(z - d_alpha)``.

    Zero at the desired distance d_alpha, negative (repulsive) below it,
    positive (attractive) above it, zero beyond the range r_alpha.

    Parameters
    ----------
    z : array_like
        Sigma-norm distances [-].
    d_alpha : float
        Sigma-norm of the desired distance [-], > 0.
    r_alpha : float
        Sigma-norm of the interaction range [-], > d_alpha.
    h : float
        Bump parameter [-], 0 < h < 1.
    a, b : float
        Attraction and repulsion levels [-], 0 < a <= b.

    Returns
    -------
    float or numpy.ndarray
        The action phi_alpha(z) [-].

    Examples
    --------
    >>> phi_alpha(5.0, d_alpha=5.0, r_alpha=6.0)
    0.0
    >>> phi_alpha(2.0, d_alpha=5.0, r_alpha=6.0) < 0.0 < phi_alpha(5.5, d_alpha=5.0, r_alpha=6.0)
    True
    """
    where = "phi_alpha"
    d, r = _check_range(where, d_alpha, r_alpha)
    hh = _check_h(where, h)
    aa, bb = _check_ab(where, a, b)
    arr, scalar = _array(z)
    return _out(_phi_alpha(arr, d, r, hh, aa, bb), scalar)


def _psi(z: float, d: float, r: float, h: float, a: float, b: float) -> float:
    """psi_alpha(z) by adaptive quadrature, split where the integrand is not smooth."""
    upper = min(max(z, 0.0), r)          # phi_alpha = 0 below 0 and beyond r
    lo, hi = min(d, upper), max(d, upper)
    knots = [lo] + [k for k in (h * r,) if lo < k < hi] + [hi]

    def integrand(s: float) -> float:
        return float(_phi_alpha(np.asarray(s), d, r, h, a, b))

    total = 0.0
    for left, right in zip(knots[:-1], knots[1:], strict=True):
        value, _ = quad(integrand, left, right, epsabs=_QUAD_EPSABS,
                        epsrel=_QUAD_EPSREL, limit=200)
        total += value
    return total if upper >= d else -total


def psi_alpha(z: ArrayLike, *, d_alpha: float, r_alpha: float, h: float = 0.2,
              a: float = 5.0, b: float = 5.0) -> Floats:
    """Pairwise potential ``psi_alpha(z) = integral from d_alpha to z of phi_alpha(s) ds``.

    It has no closed form (the bump); each value is an adaptive Gauss-Kronrod
    quadrature (:func:`scipy.integrate.quad`) split at the bump's knot
    ``h r_alpha``, accurate to about 1e-12 relative. It is 0 at d_alpha (its
    minimum), non-negative, and constant for z >= r_alpha (and for z <= 0,
    where rho_h vanishes); ``psi_alpha(0)`` is the energy barrier of a collision.

    Parameters
    ----------
    z : array_like
        Sigma-norm distances [-].
    d_alpha : float
        Sigma-norm of the desired distance [-], > 0.
    r_alpha : float
        Sigma-norm of the interaction range [-], > d_alpha.
    h : float
        Bump parameter [-], 0 < h < 1.
    a, b : float
        Attraction and repulsion levels [-], 0 < a <= b.

    Returns
    -------
    float or numpy.ndarray
        The potential psi_alpha(z) [-], >= 0.

    Examples
    --------
    >>> psi_alpha(5.0, d_alpha=5.0, r_alpha=6.0)
    0.0
    >>> psi_alpha(7.0, d_alpha=5.0, r_alpha=6.0) == psi_alpha(6.0, d_alpha=5.0, r_alpha=6.0)
    True
    """
    where = "psi_alpha"
    d, r = _check_range(where, d_alpha, r_alpha)
    hh = _check_h(where, h)
    aa, bb = _check_ab(where, a, b)
    arr, scalar = _array(z)
    flat = [_psi(float(v), d, r, hh, aa, bb) for v in arr.ravel()]
    return _out(np.asarray(flat, dtype=float).reshape(arr.shape), scalar)


# ---------------------------------------------------------------- physical flocking potential

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
        return self.force_scale / self.length_scale * weight * slope_phi * slope_sigma**2

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


# ------------------------------------------------ seed 001: spacing-deviation potentials

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
            return max(ahead, d)
        behind = brentq(lambda z: float(self.energy(-z)) - e, 0.0, d, xtol=1e-12)
        return float(max(ahead, behind))
