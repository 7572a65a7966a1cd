# Olfati-Saber's flocking primitives: sigma-norm, bump, action and pair potential functions.
"""Olfati-Saber's (2006) flocking primitives, elementwise on arrays.

The sigma-norm, the bump function rho_h, the action function phi_alpha and
the pairwise potential psi_alpha of Olfati-Saber, R. (2006), "Flocking for
multi-agent dynamic systems: algorithms and theory", IEEE Trans. Automatic
Control 51(3), pp. 401-420 (:mod:`trainctl.controllers.continuous.potentials`
for the conventions). Each entry is a scalar distance on a line of trains,
so ``||z|| = |z|``; a scalar argument gives a float.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import quad

from trainctl._validation import check_finite
from trainctl.exceptions import ModelError

__all__ = ["bump", "phi", "phi_alpha", "psi_alpha", "sigma1", "sigma_grad", "sigma_norm"]

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
