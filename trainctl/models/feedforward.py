# The quasi-static force split: cruise equilibrium and MPC feedforward, defined once.
"""The quasi-static distribution of traction over a train, vectorised.

When every vehicle runs at the same speed v and acceleration a, vehicle i
needs w_i = m_i (a0_i + a1_i v + a2_i v² + a) [N] (plus m_i r_i for a line
resistance r_i). With the ``"shares"`` allocation each physically coupled
group (vehicles between virtual links) supplies its total need in proportion
to the vehicles' ``traction_share``: u_i = (sum_group w) · s_i / sum_group s.
The couplers then carry the static forces f_i = sum_{j<=i} (u_j - w_j)
(virtual links carry none) and stretch by f_i / k_i. With ``"own"`` every
vehicle supplies its own need and no coupler is loaded.

:class:`ForceSplit` is this split, precomputed for a train and evaluated for
many (speed, acceleration) pairs at once. :func:`~trainctl.models.equilibrium`
(one pair) and the MPC feedforward (a whole preview) both use it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import ModelError
from trainctl.models.train import Train

__all__ = ["ALLOCATIONS", "ForceSplit", "QuasiStaticForces"]

Array = NDArray[np.float64]

ALLOCATIONS = ("shares", "own")
"""Ways to spread the traction over the vehicles (see :class:`ForceSplit`)."""


@dataclass(frozen=True, kw_only=True, eq=False)
class QuasiStaticForces:
    """Quasi-static forces for k (speed, acceleration) pairs.

    Parameters
    ----------
    inputs : ndarray
        Traction per vehicle [N], shape (k, n).
    coupler_forces : ndarray
        Static coupler forces [N], tension positive, shape (k, n-1).
    elongations : ndarray
        Static elongations f / k [m] (0 for virtual links), shape (k, n-1).
    resistance : ndarray
        Each vehicle's need w [N] (resistance plus m·a), shape (k, n).

    Examples
    --------
    A locomotive hauling one wagon (100 t each, 0.01 m/s² of resistance) at
    cruise, then accelerating at 0.1 m/s²: each needs 1 kN, then
    1 kN + 100 t · 0.1 m/s² = 11 kN; the locomotive supplies both needs and the
    coupler passes the wagon's on.

    >>> from trainctl.models.train import Train
    >>> from trainctl.models.vehicle import Coupler, Vehicle
    >>> loco = Vehicle(mass=1e5, a0=0.01, a1=0.0, a2=0.0, traction_share=1.0)
    >>> wagon = Vehicle(mass=1e5, a0=0.01, a1=0.0, a2=0.0, traction_share=0.0)
    >>> train = Train(vehicles=(loco, wagon), couplers=(Coupler(stiffness=1e6),))
    >>> q = ForceSplit(train)([20.0, 20.0], [0.0, 0.1])
    >>> (q.inputs / 1e3).round(3).tolist(), (q.coupler_forces / 1e3).round(3).tolist()  # [kN]
    ([[2.0, 0.0], [22.0, 0.0]], [[1.0], [11.0]])
    >>> q.elongations.round(4).tolist()  # f / k [m]
    [[0.001], [0.011]]
    """

    inputs: Array
    coupler_forces: Array
    elongations: Array
    resistance: Array


class ForceSplit:
    """The quasi-static force split of a train, precomputed once.

    Parameters
    ----------
    train : Train
        The train.
    allocation : {"shares", "own"}
        Traction shares within each coupled group, or every vehicle its own need.
    where : str
        Name used in error messages (the caller).

    Raises
    ------
    ModelError
        For an unknown allocation, or with ``"shares"`` when a coupled group
        has no traction (all its ``traction_share`` are 0).

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> split = ForceSplit(crh2_half())
    >>> q = split([300 / 3.6, 300 / 3.6], [0.0, 0.1])
    >>> (q.coupler_forces[0] / 1e3).round(3).tolist()
    [-5.627, -0.151, 5.521]
    >>> q.inputs.shape
    (2, 4)
    """

    def __init__(self, train: Train, *, allocation: str = "shares", where: str = "ForceSplit"):
        if allocation not in ALLOCATIONS:
            raise ModelError(
                f"{where}: 'allocation' must be one of {ALLOCATIONS} (got {allocation!r})."
            )
        self.train = train
        self.allocation = allocation
        shares = train.traction_share
        groups: list[tuple[NDArray[np.intp], Array]] = []
        if allocation == "shares":
            for group in train.groups:
                idx = np.array(group)
                total = shares[idx].sum()
                if total <= 0:
                    names = [train.vehicles[i].name for i in group]
                    raise ModelError(
                        f"{where}: vehicles {list(group)} ({names}) form a coupled group with "
                        "no traction (all traction_share are 0). Give one a traction_share > 0 "
                        "or use allocation='own'."
                    )
                groups.append((idx, shares[idx] / total))
        self._groups = groups
        self._virtual = train.virtual
        self._any_virtual = bool(train.virtual.any())
        self._stiffness = np.where(train.virtual, 1.0, train.stiffness)
        davis = train.davis
        # Per unit mass and the same for every vehicle: evaluated once per pair.
        self._uniform = (tuple(float(a) for a in davis[:, 0])
                         if bool(np.all(davis == davis[:, :1])) else None)
        self._last: tuple[float, float, Array, Array] | None = None
        """:meth:`single`'s last pair and result (the reference is often constant)."""

    def __call__(
        self, speeds: ArrayLike, accelerations: ArrayLike, line: ArrayLike | None = None
    ) -> QuasiStaticForces:
        """Inputs, coupler forces and elongations for each (speed, acceleration) pair.

        Parameters
        ----------
        speeds : array_like
            Common speeds v [m/s], shape (k,).
        accelerations : array_like
            Common accelerations a [m/s²], shape (k,).
        line : array_like or None
            Line resistance per unit mass r_i [m/s²] of each vehicle (grade and
            curves; any extra specific force): shape (n,), the same for every
            pair, or (k, n), one row per pair (the vehicles' sections along a
            route); None for none. Added as m_i r_i after m_i (davis + a).

        Returns
        -------
        QuasiStaticForces
            Arrays with one row per pair.
        """
        train = self.train
        v = np.asarray(speeds, dtype=float)
        accels = np.asarray(accelerations, dtype=float)
        if self._uniform is not None:
            a0, a1, a2 = self._uniform
            need = np.multiply.outer(a0 + a1 * v + a2 * v * v + accels, train.mass)
        else:
            a0v, a1v, a2v = train.davis
            column = v[:, None]
            need = train.mass * (a0v + a1v * column + a2v * column * column + accels[:, None])
        if line is not None:
            need += train.mass * np.asarray(line, dtype=float)
        inputs = self._share(need)
        forces = np.add.accumulate(inputs - need, axis=1)[:, :-1]
        if self._any_virtual:
            forces[:, self._virtual] = 0.0
            elong = np.where(self._virtual, 0.0, forces / self._stiffness)
        else:
            elong = forces / self._stiffness
        return QuasiStaticForces(
            inputs=inputs, coupler_forces=forces, elongations=elong, resistance=need
        )

    def single(self, speed: float, acceleration: float) -> tuple[Array, Array]:
        """The inputs and elongations of one (speed, acceleration) pair, no line resistance.

        Row 0 of :meth:`__call__`'s, bit for bit: the same operations on the
        pair's row, without the arrays of one pair (a closed loop calls it every
        sample). The last pair's arrays are kept and returned again for it, so
        they are read-only.

        Parameters
        ----------
        speed : float
            Common speed v [m/s].
        acceleration : float
            Common acceleration a [m/s²].

        Returns
        -------
        (ndarray, ndarray)
            Inputs [N], shape (n,), and coupler elongations [m], shape (n-1,).

        Examples
        --------
        >>> from trainctl.models.presets import crh2_half
        >>> split = ForceSplit(crh2_half())
        >>> inputs, elongations = split.single(80.0, 0.1)
        >>> bool(np.array_equal(inputs, split([80.0], [0.1]).inputs[0]))
        True
        """
        v, accel = float(speed), float(acceleration)
        last = self._last
        if last is not None and last[0] == v and last[1] == accel:
            return last[2], last[3]
        train = self.train
        if self._uniform is not None:
            a0, a1, a2 = self._uniform
            need = (a0 + a1 * v + a2 * v * v + accel) * train.mass
        else:
            a0v, a1v, a2v = train.davis
            need = train.mass * (a0v + a1v * v + a2v * v * v + accel)
        inputs = self._share(need[None, :])[0]
        forces = np.add.accumulate(inputs - need)[:-1]
        if self._any_virtual:
            forces[self._virtual] = 0.0
            elong = np.where(self._virtual, 0.0, forces / self._stiffness)
        else:
            elong = forces / self._stiffness
        inputs.setflags(write=False)
        elong.setflags(write=False)
        self._last = (v, accel, inputs, elong)
        return inputs, elong

    def _share(self, need: Array) -> Array:
        """Each group's total need spread by the traction shares (or a copy, for "own")."""
        if self.allocation == "own":
            return need.copy()
        # np.add.reduce is what sum calls, without its Python wrapper. Each group's columns
        # are gathered (a copy) before the sum: summing a view of 8 or more columns adds in
        # another order, which rounds differently.
        if len(self._groups) == 1:
            group, share = self._groups[0]
            return np.add.reduce(need[:, group], axis=1, keepdims=True) * share
        inputs = np.empty_like(need)
        for group, share in self._groups:
            inputs[:, group] = np.add.reduce(need[:, group], axis=1, keepdims=True) * share
        return inputs
