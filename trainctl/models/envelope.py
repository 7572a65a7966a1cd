# The traction and braking envelopes of a whole train, evaluated at once.
"""The traction/braking envelopes of a train, evaluated for all vehicles at once.

:meth:`EnvelopeBounds.pair` gives the bounds over a speed preview (every
vehicle at the previewed speed: the MPC's input bounds);
:meth:`EnvelopeBounds.at` gives each vehicle's bounds at its own speed (the
saturation of a feedback law).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from trainctl.models.train import Train
from trainctl.models.vehicle import _MIN_SPEED, TractionEnvelope, envelope_limit
from trainctl.units import GRAVITY

try:  # the ufunc np.clip ends in: 0.7 against 5.0 µs a call on 4 forces (np.clip's
    # wrappers), the same operation; called every sample of a closed loop.
    from numpy._core.umath import clip as _clip  # type: ignore[attr-defined]
except ImportError:  # pragma: no cover - another numpy layout: the public wrapper
    _clip = np.clip

_LAST_AT: dict[bytes, tuple[bytes, NDArray[np.float64], NDArray[np.float64]]] = {}
""":meth:`EnvelopeBounds.at`'s last speeds and bounds per set of envelopes: a closed loop
asks twice a sample at the same speeds (the controller's clip, then the actuators)."""

__all__ = ["EnvelopeBounds"]

KN = 1e3
Array = NDArray[np.float64]


class EnvelopeBounds:
    """Absolute input bounds [kN] of every vehicle at previewed speeds.

    Parameters
    ----------
    train : Train
        The train (its vehicles' envelopes and masses).
    enabled : bool
        False: no bounds (-inf, inf).

    Attributes
    ----------
    envelopes : tuple of ndarray or None
        The stock envelopes' parameters stacked for one broadcast evaluation
        (forces, powers, adhesions as [braking; traction] x 1 x vehicles, and
        the masses); None when some vehicle has another envelope type, which
        is then called one vehicle at a time.

    Examples
    --------
    The CRH2 half train (T-M-M-T): the motor coaches give 80 kN up to the
    speed where 1200 kW runs out, at 300 km/h 1200 kW / 83.33 m/s = 14.4 kN;
    the trailers only brake (40 kN).

    >>> from trainctl.models import crh2_half
    >>> bounds = EnvelopeBounds(crh2_half(), enabled=True)
    >>> lb, ub = bounds.pair(np.array([10.0, 300 / 3.6]))  # two previewed moves [kN]
    >>> ub.round(1).tolist()
    [0.0, 80.0, 80.0, 0.0, 0.0, 14.4, 14.4, 0.0]
    >>> lb.round(1).tolist()
    [-40.0, -40.0, -40.0, -40.0, -40.0, -14.4, -14.4, -40.0]
    >>> EnvelopeBounds(crh2_half(), enabled=False).pair(np.array([10.0]))[1].tolist()
    [inf, inf, inf, inf]
    """

    _at: tuple[Array, Array, Array]
    _key: bytes

    def __init__(self, train: Train, *, enabled: bool) -> None:
        self.train, self.enabled, self.n = train, enabled, train.n_vehicles
        self.envelopes: tuple[Array, ...] | None = None
        if all(type(veh.envelope) is TractionEnvelope for veh in train.vehicles):
            env = [veh.envelope for veh in train.vehicles]

            def stack(*fields: str) -> Array:
                return np.array([[getattr(e, f) for e in env] for f in fields],
                                dtype=float)[:, None, :]

            self.envelopes = (stack("max_braking", "max_traction"),
                              stack("max_braking_power", "max_power"),
                              stack("adhesion", "adhesion"), train.mass.copy())
            force, power, adhesion, mass = self.envelopes
            # :meth:`at`'s per-sample operands, (2, n): envelope_limit's, with its
            # speed-free product adhesion·m·g taken once (the same product, bit for bit).
            self._at = (force[:, 0], power[:, 0], (adhesion * mass * GRAVITY)[:, 0])
            self._key = b"".join(a.tobytes() for a in self._at)

    def pair(self, speeds: Array) -> Array:
        """Bounds [lb; ub] at ``speeds``, shape (2, moves·n), move by move.

        Parameters
        ----------
        speeds : ndarray, shape (moves,)
            The previewed speed of each move [m/s], >= 0, the same for
            every vehicle.

        Returns
        -------
        ndarray, shape (2, moves·n)
            Row 0 the lower bounds (minus each vehicle's braking limit),
            row 1 the upper bounds (its traction limit) [kN], move by move
            (all vehicles of move 0, then move 1, ...); -inf and inf when
            the bounds are not enabled.
        """
        v = np.asarray(speeds, dtype=float)
        if not self.enabled:
            pair = np.empty((2, v.size * self.n))
            pair[0], pair[1] = -np.inf, np.inf
            return pair
        if self.envelopes is not None:
            # Stock envelopes: one call for [braking; traction] x moves x vehicles.
            force, power, adhesion, mass = self.envelopes
            limits = envelope_limit(v[:, None], force, power, adhesion, mass)
            limits /= KN
        else:
            # One vectorised envelope call per vehicle over the previewed speeds: (moves, n).
            vehicles = self.train.vehicles
            limits = np.stack([
                np.column_stack([veh.envelope.braking_limit(v, mass=veh.mass)
                                 for veh in vehicles]),
                np.column_stack([veh.envelope.traction_limit(v, mass=veh.mass)
                                 for veh in vehicles])]) / KN
        np.negative(limits[0], out=limits[0])
        return limits.reshape(2, -1)

    def clip(self, inputs: Array, speeds: Array) -> tuple[Array, int]:
        """Forces cut to each vehicle's envelope at its own speed (nothing when not ``enabled``).

        Parameters
        ----------
        inputs : ndarray
            Requested force per vehicle [N], shape (n,).
        speeds : ndarray
            One speed per vehicle [m/s], shape (n,).

        Returns
        -------
        (ndarray, int)
            The forces within :meth:`at`'s bounds [N], and how many were cut.

        Examples
        --------
        >>> from trainctl.models import crh2_half
        >>> u, cut = EnvelopeBounds(crh2_half(), enabled=True).clip(np.full(4, 1e5),
        ...                                                          np.full(4, 80.0))
        >>> (u / 1e3).round(1).tolist(), cut
        ([0.0, 15.0, 15.0, 0.0], 4)
        """
        u = np.asarray(inputs, dtype=float)
        if not self.enabled:
            return u, 0
        low, high = self.at(speeds)
        clipped: Array = _clip(u, low, high)
        return clipped, int(np.count_nonzero(clipped != u))

    def at(self, speeds: Array) -> tuple[Array, Array]:
        """Each vehicle's braking (negative) and traction limits [N] at its own speed.

        Parameters
        ----------
        speeds : ndarray
            One speed per vehicle [m/s], shape (n,).

        Returns
        -------
        (ndarray, ndarray)
            Lower and upper bounds [N], shape (n,); (-inf, inf) when not ``enabled``.
            Read-only for stock envelopes (the last speeds' are kept and shared by
            the bounds of equal envelopes).

        Examples
        --------
        >>> from trainctl.models import crh2_half
        >>> low, high = EnvelopeBounds(crh2_half(), enabled=True).at(np.full(4, 80.0))
        >>> (high / 1e3).round(1).tolist(), bool(np.all(low < 0))
        ([0.0, 15.0, 15.0, 0.0], True)
        """
        v = np.asarray(speeds, dtype=float)
        if not self.enabled:
            return np.full(self.n, -np.inf), np.full(self.n, np.inf)
        if self.envelopes is not None and v.shape == (self.n,):
            # envelope_limit's operations on (2, n) without its broadcast wrapper, and the
            # last speeds' bounds again (read-only) when asked at the same speeds: a closed
            # loop asks twice a sample (the controller's clip and the actuators).
            seen = v.tobytes()
            last = _LAST_AT.get(self._key)
            if last is not None and last[0] == seen:
                return last[1], last[2]
            force, power, cap = self._at
            speed = np.abs(v)
            np.maximum(speed, _MIN_SPEED, out=speed)
            limits = np.divide(power, speed)
            np.minimum(force, limits, out=limits)
            np.minimum(limits, cap, out=limits)
            low, high = -limits[0], limits[1]
            low.setflags(write=False)
            high.setflags(write=False)
            _LAST_AT[self._key] = (seen, low, high)
            return low, high
        elif self.envelopes is not None:
            force, power, adhesion, mass = self.envelopes
            limits = envelope_limit(v[None, None, :], force, power, adhesion, mass)[:, 0]
        else:
            vehicles = self.train.vehicles
            limits = np.array([[veh.envelope.braking_limit(s, mass=veh.mass)
                                for veh, s in zip(vehicles, v, strict=True)],
                               [veh.envelope.traction_limit(s, mass=veh.mass)
                                for veh, s in zip(vehicles, v, strict=True)]], dtype=float)
        return -limits[0], limits[1]
