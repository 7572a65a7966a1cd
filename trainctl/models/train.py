# A train: vehicles joined by couplers (physical or virtual).
"""The :class:`Train` container and its vectorised parameter arrays.

Index 0 is the head vehicle; positions increase in the direction of travel.
Coupler i joins vehicle i (front) and vehicle i+1 (rear). Its elongation
delta_i = (p_i - p_{i+1}) - spacing_i is positive in tension.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from trainctl.exceptions import ModelError
from trainctl.models.vehicle import Coupler, Vehicle

__all__ = ["Train"]


@dataclass(frozen=True, kw_only=True)
class Train:
    """A chain of vehicles joined by n-1 couplers or virtual links.

    Parameters
    ----------
    vehicles : tuple of Vehicle
        The vehicles, head first; at least one.
    couplers : tuple of Coupler
        The n-1 links, coupler i between vehicle i and vehicle i+1.
    name : str
        Label used in summaries.

    Examples
    --------
    >>> car = Vehicle(mass=4.0e4, a0=0.01, a1=1e-4, a2=1e-5)
    >>> train = Train(vehicles=(car, car), couplers=(Coupler(stiffness=1e7),))
    >>> train.n_vehicles, train.n_states
    (2, 3)
    """

    vehicles: tuple[Vehicle, ...]
    couplers: tuple[Coupler, ...]
    name: str = "train"

    def __post_init__(self) -> None:
        object.__setattr__(self, "vehicles", tuple(self.vehicles))
        object.__setattr__(self, "couplers", tuple(self.couplers))
        if not self.vehicles:
            raise ModelError("Train: 'vehicles' must hold at least one Vehicle (got none).")
        if len(self.couplers) != len(self.vehicles) - 1:
            raise ModelError(
                f"Train: a train of {len(self.vehicles)} vehicles needs "
                f"{len(self.vehicles) - 1} couplers (got {len(self.couplers)})."
            )
        for i, vehicle in enumerate(self.vehicles):
            if not isinstance(vehicle, Vehicle):
                raise ModelError(
                    f"Train: vehicles[{i}] must be a Vehicle (got {type(vehicle).__name__})."
                )
        for i, coupler in enumerate(self.couplers):
            if not isinstance(coupler, Coupler):
                raise ModelError(
                    f"Train: couplers[{i}] must be a Coupler (got {type(coupler).__name__})."
                )

    @property
    def n_vehicles(self) -> int:
        """Number of vehicles n."""
        return len(self.vehicles)

    @property
    def n_couplers(self) -> int:
        """Number of couplers (links) n - 1."""
        return len(self.couplers)

    @property
    def n_states(self) -> int:
        """Dimension of the linear model state [v; delta], 2n - 1."""
        return 2 * self.n_vehicles - 1

    @cached_property
    def mass(self) -> NDArray[np.float64]:
        """Vehicle masses [kg], shape (n,)."""
        return np.array([v.mass for v in self.vehicles])

    @cached_property
    def davis(self) -> NDArray[np.float64]:
        """Davis coefficients per unit mass, shape (3, n): rows a0 [m/s²], a1 [1/s], a2 [1/m]."""
        return np.array([[v.a0, v.a1, v.a2] for v in self.vehicles]).T.copy()

    @cached_property
    def stiffness(self) -> NDArray[np.float64]:
        """Coupler stiffnesses [N/m], shape (n-1,); 0 for virtual links."""
        return np.array([c.stiffness for c in self.couplers], dtype=float)

    @cached_property
    def damping(self) -> NDArray[np.float64]:
        """Coupler damping coefficients [N·s/m], shape (n-1,)."""
        return np.array([c.damping for c in self.couplers], dtype=float)

    @cached_property
    def spacing(self) -> NDArray[np.float64]:
        """Nominal centre-to-centre spacings [m], shape (n-1,)."""
        return np.array([c.spacing for c in self.couplers], dtype=float)

    @cached_property
    def max_coupler_force(self) -> NDArray[np.float64]:
        """Admissible coupler forces |f| [N], shape (n-1,); inf where there is no limit."""
        return np.array([c.max_force for c in self.couplers], dtype=float)

    @cached_property
    def virtual(self) -> NDArray[np.bool_]:
        """True where link i is virtual (no force), shape (n-1,)."""
        return np.array([c.virtual for c in self.couplers], dtype=bool)

    @cached_property
    def traction_share(self) -> NDArray[np.float64]:
        """Relative cruise-traction shares [-], shape (n,)."""
        return np.array([v.traction_share for v in self.vehicles])

    @cached_property
    def groups(self) -> tuple[tuple[int, ...], ...]:
        """Index tuples of the physically coupled groups (split at virtual links)."""
        groups: list[list[int]] = [[0]]
        for i, virtual in enumerate(self.virtual):
            if virtual:
                groups.append([i + 1])
            else:
                groups[-1].append(i + 1)
        return tuple(tuple(g) for g in groups)

    def state_labels(self, *, position: bool = False) -> list[str]:
        """Names of the states ``v[i]``, ``delta[i]`` (and ``s`` for position).

        Parameters
        ----------
        position : bool
            Append the head position ``s`` (the nonlinear model's last state).

        Returns
        -------
        list of str
            State names in python-control's indexed-signal syntax.
        """
        labels = [f"v[{i}]" for i in range(self.n_vehicles)]
        labels += [f"delta[{i}]" for i in range(self.n_couplers)]
        return labels + (["s"] if position else [])
