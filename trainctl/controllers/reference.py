# The reference position the consensus laws integrate between their steps.
"""The reference position x̄_0(t) of the position-pinning consensus laws.

The potential (seed 001) and flocking (seed 002) laws pin each vehicle to a
slot that moves with the reference: x̄_0(t) = s(t_0) + ∫ v_r dt from the
head's measured position at the first step after a reset (so the head
starts with no position error), integrated by the trapezoid between
consecutive steps from the reference speed at both ends. The reference is
piecewise linear, so this is exact for every interval that does not straddle
a breakpoint; an interval that does is off by at most |Δa|·dt²/8 [m] (Δa the
jump of the reference acceleration), once per breakpoint. Vehicle i's slot
lies the nominal spacings behind, so its position error is the head's minus
the spacing deviations ahead of it (:func:`position_errors`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ReferencePosition", "position_errors"]


class ReferencePosition:
    """x̄_0(t) [m], integrated from the reference speed between calls.

    Examples
    --------
    >>> ref = ReferencePosition()
    >>> ref(0.0, 20.0, head=5.0), ref(2.0, 22.0, head=0.0)
    (5.0, 47.0)
    """

    def __init__(self) -> None:
        self._last: tuple[float, float, float] | None = None  # (t, v_r(t), x̄_0(t))

    def reset(self) -> None:
        """Forget the integral (the next call restarts at the head)."""
        self._last = None

    def __call__(self, t: float, speed: float, head: float) -> float:
        """x̄_0(t) [m]: the head's position at the first call, then the trapezoid of v_r.

        Parameters
        ----------
        t : float
            Time [s].
        speed : float
            v_r(t) [m/s].
        head : float
            The head's measured position [m] (used at the first call only).

        Returns
        -------
        float
            The reference position [m].
        """
        if self._last is None:
            x_ref = head
        else:
            t0, v0, x0 = self._last
            x_ref = x0 + 0.5 * (v0 + speed) * (t - t0)
        self._last = (t, speed, x_ref)
        return x_ref


def position_errors(head_error: float, spacing_deviations: ArrayLike) -> NDArray[np.float64]:
    """x̂_i = x̂_0 − Σ_{k<i} z_k [m]: each vehicle's error from the head's and the spacings.

    Parameters
    ----------
    head_error : float
        The head's position minus the reference position [m].
    spacing_deviations : array_like
        z_k, each spacing's deviation from nominal [m], head first, shape (n-1,).

    Returns
    -------
    ndarray
        Position errors [m], shape (n,).

    Examples
    --------
    >>> position_errors(1.0, [0.5, -0.25]).tolist()
    [1.0, 0.5, 0.75]
    """
    z = np.asarray(spacing_deviations, dtype=float)
    behind = np.empty(z.size + 1)  # [0, cumsum(z)], without concatenate's list (per step)
    behind[0] = 0.0
    z.cumsum(out=behind[1:])
    errors: NDArray[np.float64] = head_error - behind
    return errors
