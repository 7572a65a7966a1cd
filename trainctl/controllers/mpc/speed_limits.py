# The speed limits each vehicle meets over the MPC's horizon, as bounds of its speed rows.
"""The upper bounds of the MPC's speed rows: the track's limits ahead of every vehicle.

At prediction step j (1..P) vehicle i is predicted at p_i(k+j) = p_i(k) +
d(j), its measured position moved by the distance d(j) the reference travels
from t_k to t_k+j (trapezoidal over the preview samples, exact for a
reference speed linear between samples). Its speed row at step j bounds the
predicted speed deviation::

    v_i(k+j) - v_ref(k+j) <= ℓ_ij - margin - v_ref(k+j)

with ℓ_ij the lowest limit the vehicle meets from its position at step j-1
to as far again beyond its position at step j: the speed at a sample must
already respect a restriction that starts within the sample interval after
it, since the vehicle enters it before the next sample. With the rows of
steps j and j+1 both bounded, the speed between two samples (between the
two sampled speeds on a smooth run) stays under every limit of the stretch
covered in between.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from trainctl.models.track import Track

__all__ = ["HorizonLimits"]

Array = NDArray[np.float64]


class HorizonLimits:
    """The bounds of every vehicle's speed rows over the horizon (module docstring).

    Parameters
    ----------
    track : Track
        The track; its ``speed_limits`` [m/s] are the limits.
    margin : float
        How far under each limit the speeds are kept [m/s], >= 0.

    Examples
    --------
    A 20 m/s limit from 100 m on: a vehicle at 90 m on a 10 m/s reference
    sampled every second reaches it between steps 1 and 2, so steps 1 and
    later are bounded to 20 - 10 = 10 m/s above the reference; a vehicle at
    50 m only from step 4 on (its step 4 interval reaches from 80 m to 100 m).

    >>> from trainctl.models.track import SpeedLimit
    >>> limits = HorizonLimits(Track(speed_limits=(SpeedLimit(start=100.0, limit=20.0),)), 0.0)
    >>> bounds = limits.bounds(np.array([90.0, 50.0]), np.arange(6.0), np.full(6, 10.0))
    >>> bounds.T.tolist()  # [m/s] above the reference, steps 1..5 of each vehicle
    [[10.0, 10.0, 10.0, 10.0, 10.0], [inf, inf, inf, 10.0, 10.0]]
    """

    def __init__(self, track: Track, margin: float) -> None:
        starts = np.array([s.start for s in track.speed_limits], dtype=float)
        limits = np.array([s.limit for s in track.speed_limits], dtype=float)
        self.starts, self.margin = starts, float(margin)
        # ext[m + 1] is restriction m's limit; ext[0] holds before the first start.
        self._ext = np.concatenate([[np.inf], limits])

    def lowest(self, a: Array, b: Array) -> Array:
        """The lowest limit over each stretch [a, b] of the track [m/s] (inf where none).

        Parameters
        ----------
        a, b : ndarray
            Start and end of each stretch [m], a <= b, the same shape.

        Returns
        -------
        ndarray
            The least limit ℓ over [a, b] of each stretch [m/s], the shape of ``a``.
        """
        starts, ext = self.starts, self._ext
        found: Array = ext[np.searchsorted(starts, a, side="right")]  # ℓ(a)
        # the few restrictions starting inside some stretch: start in (a, b]
        first, last = np.searchsorted(starts, (a.min(), b.max()), side="right")
        for m in range(int(first), int(last)):
            inside = (a < starts[m]) & (b >= starts[m])
            found[inside] = np.minimum(found[inside], ext[m + 1])
        return found

    def bounds(self, positions: Array, times: Array, speeds: Array) -> Array:
        """The upper bounds of the speed rows, ℓ_ij - margin - v_ref(k+j) [m/s].

        Parameters
        ----------
        positions : ndarray, shape (n,)
            Each vehicle's measured position [m], head first.
        times : ndarray, shape (P+1,)
            The preview's sample times t_k..t_k+P [s].
        speeds : ndarray, shape (P+1,)
            The reference speed at those times [m/s].

        Returns
        -------
        ndarray, shape (P, n)
            Row j-1 holds step j's bound of every vehicle's speed deviation
            [m/s]; inf where no limit lies ahead.
        """
        step = np.diff(times) * 0.5 * (speeds[:-1] + speeds[1:])
        travelled = np.concatenate([[0.0], np.cumsum(step)])  # d(0..P) [m]
        before, at = travelled[:-1], travelled[1:]
        a = positions[None, :] + before[:, None]
        b = positions[None, :] + (2.0 * at - before)[:, None]
        bound: Array = self.lowest(a, b) - self.margin - speeds[1:, None]
        return bound
