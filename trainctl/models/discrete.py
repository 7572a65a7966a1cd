# Exact discretisation of linear train models.
"""Discretisation of continuous linear models (new systems, never mutated).

``"zoh"`` (default) is the exact zero-order-hold discretisation
A_d = e^{AT}, B_d = ∫_0^T e^{As} ds B, computed by python-control
(``StateSpace.sample``) through the matrix exponential of the augmented
matrix [[A, B], [0, 0]]. ``"tustin"`` (bilinear) is offered for comparison.

Forward Euler (A_d = I + T·A) is deliberately not offered: with CRH2
couplers (k/m ≈ 245 s⁻²) and seed 000's T = 20 s it produces entries near
20·245 = 4900 and an explosively unstable model, although the real train is
stable. Even at small T it only approximates; use ZOH.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from trainctl._validation import check_finite_arrays, check_positive
from trainctl.exceptions import ModelError

if TYPE_CHECKING:
    import control as ct

__all__ = ["DISCRETISATIONS", "discretise"]

DISCRETISATIONS = ("zoh", "tustin")
"""Names of the supported discretisation methods."""


def discretise(sys: ct.StateSpace, dt: float, *, method: str = "zoh") -> ct.StateSpace:
    """Discretise a continuous ``StateSpace`` with sample time ``dt``.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous-time system (``sys.dt == 0``).
    dt : float
        Sample time T [s], > 0.
    method : {"zoh", "tustin"}
        Exact zero-order hold (default) or the bilinear transform.

    Returns
    -------
    control.StateSpace
        A new discrete-time system with the same signal names; ``sys`` is
        left unchanged.

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> sys = ct.ss([[-1.0]], [[1.0]], [[1.0]], 0, states=["v[0]"])
    >>> sysd = discretise(sys, 0.1)
    >>> bool(np.isclose(sysd.A[0, 0], np.exp(-0.1))), sysd.state_labels, sys.dt
    (True, ['v[0]'], 0)
    """
    import control as ct

    dt = check_positive("discretise", "dt", dt)
    if method not in DISCRETISATIONS:
        hint = (
            " Forward Euler is not offered: it is unstable for stiff couplers."
            if method == "euler"
            else ""
        )
        raise ModelError(
            f"discretise: 'method' must be one of {DISCRETISATIONS} (got {method!r}).{hint}"
        )
    if not ct.isctime(sys, strict=True):
        raise ModelError(f"discretise: 'sys' must be a continuous-time system (got dt={sys.dt!r}).")
    check_finite_arrays("discretise", " The continuous model must be finite before sampling.",
                        A=sys.A, B=sys.B)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported below
        sysd = sys.sample(dt, method=method, name=f"{sys.name}_d")
    check_finite_arrays(
        "discretise", f" The model cannot be sampled with T = {dt!r} s: its fastest mode "
        f"(|λ| = {_fastest(sys):.3g} 1/s) overflows exp(A·T). Use a shorter sample time.",
        A=sysd.A, B=sysd.B)
    return sysd


def _fastest(sys: ct.StateSpace) -> float:
    """Largest |eigenvalue| of the continuous A (inf when it has non-finite entries)."""
    A = np.asarray(sys.A, dtype=float)
    if A.size == 0:
        return 0.0
    if not np.all(np.isfinite(A)):
        return float("inf")
    return float(np.max(np.abs(np.linalg.eigvals(A))))
