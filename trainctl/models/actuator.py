# The actuators of a train: each vehicle's force saturated to its envelope at its own speed.
"""Actuator limits: what force each vehicle can actually apply.

A controller asks for a force per vehicle; the traction and braking
equipment can give at most its envelope at the vehicle's current speed —
the force, power and adhesion limits of its
:class:`~trainctl.models.TractionEnvelope` (trailers without traction give
none). :class:`ActuatorLimits` clips a request to that envelope and says,
per vehicle, whether and on which side it saturated: the force is held at
a limit, because the request went beyond it (and was cut) or asked for the
limit itself (a controller that bounds its own inputs). A limit of zero —
the traction of a trailer — counts only when a request is cut to it. The
simulation loop
(:func:`trainctl.sim.simulate`) applies it to every controller's inputs at
each sample, at the speeds measured then, and holds the result over the
sample interval (the drive latches its force command).

A request beyond the envelope by at most ``tolerance`` [N] is applied as
asked and not flagged: solver tolerances put the inputs of a controller that
respects the envelope a few mN outside it, which is not saturation.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_nonnegative
from trainctl.exceptions import DimensionError
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.train import Train

__all__ = ["SATURATION_TOLERANCE", "ActuatorLimits"]

SATURATION_TOLERANCE = 1.0
"""Excess over the envelope [N] applied as asked and not counted as saturation."""


class ActuatorLimits:
    """Saturate requested forces to each vehicle's envelope at its own speed.

    Parameters
    ----------
    train : Train
        The train (its vehicles' envelopes and masses).
    enabled : bool
        False: apply every request as asked (a linear-analysis study).
    tolerance : float
        Excess over the envelope [N] applied as asked (module docstring), >= 0.

    Examples
    --------
    >>> import numpy as np
    >>> from trainctl.models import crh2_half
    >>> limits = ActuatorLimits(crh2_half())
    >>> applied, side = limits.apply(np.full(4, 1e5), np.full(4, 80.0))
    >>> (applied / 1e3).round(1).tolist(), side.tolist()
    ([0.0, 15.0, 15.0, 0.0], [1, 1, 1, 1])
    >>> applied, side = limits.apply([0.0, 15e3, -1e6, 0.0], np.full(4, 80.0))
    >>> side.tolist()  # at the traction limit, cut to the braking limit, trailers coasting
    [0, 1, -1, 0]
    """

    def __init__(self, train: Train, *, enabled: bool = True,
                 tolerance: float = SATURATION_TOLERANCE) -> None:
        self.train, self.enabled = train, bool(enabled)
        self.tolerance = check_nonnegative("ActuatorLimits", "tolerance", tolerance)
        self._bounds = EnvelopeBounds(train, enabled=True)

    def limits(self, speeds: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Each vehicle's braking (negative) and traction limit [N] at its speed [m/s].

        Parameters
        ----------
        speeds : array_like
            One speed per vehicle [m/s], shape (n,).

        Returns
        -------
        (ndarray, ndarray)
            Lower and upper force limits [N], shape (n,), whether or not the
            limits are ``enabled``.
        """
        v = self._vector("speeds", speeds)
        return self._bounds.at(v)

    def apply(self, requested: ArrayLike,
              speeds: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
        """The forces the vehicles apply, and where they saturated.

        Parameters
        ----------
        requested : array_like
            Force per vehicle asked for [N], finite, shape (n,).
        speeds : array_like
            Each vehicle's speed [m/s], shape (n,).

        Returns
        -------
        applied : ndarray
            The forces applied [N]: the request clipped to the envelope where
            it exceeds it by more than ``tolerance``, else the request itself.
        side : ndarray of int8
            +1 where the force is held at the traction limit, -1 at the
            braking limit (module docstring), 0 elsewhere (always 0 when not
            ``enabled``).
        """
        u = self._vector("requested", requested).copy()
        side = np.zeros(u.size, dtype=np.int8)
        if not self.enabled:
            return u, side
        low, high = self._bounds.at(self._vector("speeds", speeds))
        tol = self.tolerance
        over, under = u > high + tol, u < low - tol
        # Where-copies in place of ``if over.any() or under.any(): u[over], u[under] = ...``:
        # the same values, without two reductions (~2.5 µs each in numpy 2.4) per sample.
        np.copyto(u, high, where=over)
        np.copyto(u, low, where=under)
        side[over | ((high > tol) & (u >= high - tol))] = 1
        side[under | ((low < -tol) & (u <= low + tol))] = -1
        return u, side

    def _vector(self, name: str, value: ArrayLike) -> NDArray[np.float64]:
        x = np.asarray(value, dtype=float)
        n = self._bounds.n
        if x.shape != (n,):
            raise DimensionError(
                f"ActuatorLimits: {name!r} must have shape ({n},), one per vehicle "
                f"(got {x.shape}).")
        return x
