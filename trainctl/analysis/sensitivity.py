# Input sensitivity S, complementary sensitivity T and bandwidth of a discrete closed loop.
"""S and T of the train's closed loops, broken at the plant input, and the bandwidth.

Sensitivities. The disturbance enters exactly where the controller acts:
the plant is x⁺ = A x + B (u + M w) with M = diag(m_i)/1000 [kN per m/s²]
(B in kN). Breaking the loop at the plant input, in specific-force units
(so that a uniform grade is the direction (1, …, 1)), a controller that
reads the plant state (and keeps states of its own, such as the previous
input of the Δu-form) gives the loop transfer L(z) and

    S = (I + L)⁻¹   (disturbance w → total specific force w + M⁻¹u),
    T = L (I + L)⁻¹ = I − S   (w → the controller's counter-force −M⁻¹u).

Neither needs the controller separately: with the closed-loop matrices
(A_cl, B_cl) whose first states are the plant's, B K_x = A_cl[plant rows] −
[A 0] recovers the controller's output u = K_x X on the closed-loop state X,
and S = I + M⁻¹K_x (zI − A_cl)⁻¹ B_cl. :func:`loop_sensitivity` does this and
checks that the loop has that structure (else S and T are not reported, and
G_wv, the disturbance → speed-error transfer, is the sensitivity-like
quantity left).

Bandwidth. python-control's definition (:func:`control.bandwidth`: the first
frequency where the gain falls ``dbdrop`` dB below the DC gain; NaN for an
infinite DC gain) on the common-mode complementary sensitivity
T_u = 1ᵀ T 1 / n, the controller's counter-force against a uniform grade. It
is evaluated on the unit circle, z = e^{jωT}: python-control 0.10 evaluates
discrete systems at z = jω (fixed upstream in python-control PR #1212), so
:func:`bandwidth` carries the corrected search. A closed-loop pole at z = 1
(the book's Δu-form loops) makes the DC gain infinite and the bandwidth NaN.
"""

from __future__ import annotations

import math

import control as ct
import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from trainctl.exceptions import DimensionError

__all__ = [
    "DECADES", "POINTS_PER_DECADE", "UNIT_CIRCLE_TOL", "bandwidth", "frequency_grid",
    "loop_sensitivity",
]

Array = NDArray[np.float64]

POINTS_PER_DECADE = 50
"""Grid density of :func:`frequency_grid`."""

DECADES = 5
"""Decades below the Nyquist frequency that :func:`frequency_grid` spans."""

UNIT_CIRCLE_TOL = 1e-9
"""A discrete pole within this distance of z = 1 counts as an integrator."""

_STRUCTURE_TOL = 1e-8
"""Relative residual up to which a loop counts as state feedback around the plant."""

def frequency_grid(dt: float, *, decades: int = DECADES,
                   points_per_decade: int = POINTS_PER_DECADE) -> Array:
    """Logarithmic frequencies from ``decades`` below the Nyquist frequency up to it.

    Parameters
    ----------
    dt : float
        Sample time T [s].
    decades, points_per_decade : int
        Span and density.

    Returns
    -------
    ndarray
        Frequencies [rad/s], the last one exactly π/T.

    Examples
    --------
    >>> w = frequency_grid(20.0)
    >>> w.size, float(w[-1]) == np.pi / 20.0
    (251, True)
    """
    top = math.log10(math.pi / dt)
    grid = np.logspace(top - decades, top, decades * points_per_decade + 1)
    nyquist = math.pi / dt
    while nyquist * dt > math.pi:  # python-control refuses ω·T > π, even by one rounding
        nyquist = math.nextafter(nyquist, 0.0)
    grid[-1] = nyquist  # logspace may land one rounding above (T = 0.1 s does)
    return grid


def loop_sensitivity(
    loop: ct.StateSpace, plant: ct.StateSpace
) -> tuple[ct.StateSpace, ct.StateSpace] | None:
    """Input sensitivity S and complementary sensitivity T of a closed loop.

    Parameters
    ----------
    loop : control.StateSpace
        Discrete closed loop from the disturbances ``w`` [m/s²]; its first
        states are the plant's.
    plant : control.StateSpace
        The discrete plant (A, B) the loop is built on (B in the controller's
        input unit, kN for trainctl's design model).

    Returns
    -------
    (control.StateSpace, control.StateSpace) or None
        S and T from ``w`` to the total and to the controller's specific
        force at the plant input (module docstring); None when the loop is
        not state feedback around ``plant`` with the disturbance at its input.

    Examples
    --------
    An integrator plant x⁺ = x + u (T = 1 s) under u = −0.5 x, the disturbance
    entering with u (M = 1): A_cl = 0.5 and S(z) = 1 − 0.5/(z − 0.5), so S = 0
    at DC (a constant disturbance is fully rejected) and S(−1) = 4/3.

    >>> plant = ct.ss([[1.0]], [[1.0]], [[1.0]], 0, 1.0)
    >>> loop = ct.ss([[0.5]], [[1.0]], [[1.0]], 0, 1.0, inputs=["w[0]"], outputs=["v[0]"],
    ...              name="toy")
    >>> S, T = loop_sensitivity(loop, plant)
    >>> S.name, T.output_labels
    ('S_toy', ['c[0]'])
    >>> [round(float(abs(G(z))), 4) for G in (S, T) for z in (1.0, -1.0)]  # at DC, at π/T
    [0.0, 1.3333, 1.0, 0.3333]
    >>> loop_sensitivity(ct.ss([[0.5]], [[1.0]], [[1.0]], 0, 2.0), plant) is None  # other T
    True
    """
    A_cl, B_cl = (np.asarray(m, dtype=float) for m in (loop.A, loop.B))
    A, B = (np.asarray(m, dtype=float) for m in (plant.A, plant.B))
    nx, nz = A.shape[0], A_cl.shape[0]
    if nz < nx or B.shape[1] != B_cl.shape[1] or loop.dt != plant.dt:
        return None
    M = np.linalg.lstsq(B, B_cl[:nx], rcond=None)[0]  # the disturbance as plant input
    D = A_cl[:nx] - np.hstack([A, np.zeros((nx, nz - nx))])
    K = np.linalg.lstsq(B, D, rcond=None)[0]  # the controller's output on the loop state
    scale = max(float(np.linalg.norm(A)), float(np.linalg.norm(D)), 1e-300)
    if (np.linalg.norm(B @ M - B_cl[:nx]) > _STRUCTURE_TOL * np.linalg.norm(B_cl[:nx])
            or np.linalg.norm(B @ K - D) > _STRUCTURE_TOL * scale
            or np.any(B_cl[nx:]) or np.linalg.cond(M) > 1e12):
        return None
    F = np.linalg.solve(M, K)  # specific force [m/s²] the controller applies
    n = B.shape[1]
    names = {"inputs": list(loop.input_labels), "states": list(loop.state_labels)}
    S = ct.ss(A_cl, B_cl, F, np.eye(n), loop.dt, name=f"S_{loop.name}",
              outputs=[f"a[{i}]" for i in range(n)], **names)
    T = ct.ss(A_cl, B_cl, -F, np.zeros((n, n)), loop.dt, name=f"T_{loop.name}",
              outputs=[f"c[{i}]" for i in range(n)], **names)
    return S, T


def bandwidth(sys: ct.StateSpace, dbdrop: float = -3.0) -> float:
    """python-control's bandwidth, evaluated on the unit circle for discrete systems.

    The first frequency where |G| falls ``dbdrop`` dB below the DC gain,
    found as :func:`control.bandwidth` does (a bracket on a frequency grid,
    then bisection), with G evaluated at z = e^{jωT} for a discrete system
    (python-control 0.10 evaluates it at z = jω) and the grid running to the
    Nyquist frequency.

    Parameters
    ----------
    sys : control.StateSpace
        A SISO system, continuous or discrete.
    dbdrop : float
        The drop [dB], negative.

    Returns
    -------
    float
        Bandwidth [rad/s]; NaN for an infinite DC gain (a pole at s = 0 or
        z = 1), inf when the gain does not drop that far.

    Raises
    ------
    DimensionError
        If ``sys`` is not SISO.

    Examples
    --------
    >>> sys = ct.ss([[-1.0]], [[1.0]], [[1.0]], 0)
    >>> round(bandwidth(sys), 4) == round(float(ct.bandwidth(sys)), 4)
    True
    """
    if not sys.issiso():
        raise DimensionError(f"bandwidth: the system must be SISO (got {sys.noutputs} outputs, "
                             f"{sys.ninputs} inputs).")
    if not dbdrop < 0:
        raise ValueError(f"bandwidth: dbdrop must be negative (got {dbdrop!r}).")
    discrete = sys.isdtime(strict=True)
    poles = np.asarray(sys.poles())
    at_dc = np.abs(poles - 1.0) if discrete else np.abs(poles)
    with np.errstate(divide="ignore", invalid="ignore"):
        dc = abs(complex(np.squeeze(sys.dcgain())))
    if np.any(at_dc < UNIT_CIRCLE_TOL) or not math.isfinite(dc):
        return math.nan
    omega = (frequency_grid(float(sys.dt)) if discrete
             else np.asarray(ct.frequency_response(sys).omega, dtype=float))
    target = dc * 10.0 ** (dbdrop / 20.0)

    def gain(w: float) -> float:
        z = np.exp(1j * w * float(sys.dt)) if discrete else 1j * w
        return abs(complex(np.squeeze(sys(z))))

    mags = np.array([gain(w) for w in omega])
    below = np.nonzero(mags < target)[0]
    if below.size == 0:
        return math.inf
    low = omega[below[0] - 1] if below[0] > 0 else 0.0
    root = scipy.optimize.root_scalar(lambda w: gain(w) - target,
                                      bracket=[low, omega[below[0]]], method="bisect")
    return float(abs(root.root))
