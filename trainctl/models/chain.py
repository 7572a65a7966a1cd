# The coupled chain: the one definition of the couplers' and kinematics' linear structure.
"""The linear structure of a coupled chain of vehicles, defined once.

Vehicle i (mass m_i) is joined to vehicle i+1 by coupler i with stiffness
k_i and damping d_i (both 0 for a virtual link). With a speed damping c_i
per unit mass, the chain's linear dynamics on the state
``[v_0 .. v_{n-1}, delta_0 .. delta_{n-2}]`` are

    dv_i/dt     = -c_i v_i + (f_{i-1} - f_i) / m_i + u_i / m_i
    ddelta_i/dt = v_i - v_{i+1}

with coupler forces f_i = k_i delta_i + d_i (v_i - v_{i+1}) (tension
positive; f_{-1} = f_{n-1} = 0). Optionally the state carries seed 000's
dummy elongation ``delta_{n-1}`` (an all-zero row and column) and then the
head position s with ds/dt = v_0.

:class:`Chain` offers this x' = A x + B u three ways, all from the same
parameters: the dense (A, B) (:meth:`Chain.matrices`), the product A @ Y in
O(n) per column (:meth:`Chain.product`), and the coupling alone added to
given per-vehicle accelerations (:meth:`Chain.couple`), which the nonlinear
right-hand side :func:`~trainctl.models.train_rhs` uses with its own Davis
and track terms. The linear deviation model
(:func:`~trainctl.models.linear_matrices`), the nonlinear model and the
plant's exponential integrator (:class:`~trainctl.models.Plant`) all build on
it.

The dense diagonal is accumulated as ((-c_i) - d_{i-1}/m_i) - d_i/m_i, the
order the linear model always used (the plant's dense A used to subtract
d_i/m_i first: the same number wherever neighbouring couplers have the same
damping, as in every built-in train, and within one rounding elsewhere); the
structured product and :meth:`Chain.couple` add -f_i/m_i and then
+f_{i-1}/m_i to the vehicle's own term, the order of the nonlinear model and
of the plant's structured product.

A ``scipy.sparse`` CSR matrix of the same A multiplies 2–3x faster per call
(measured: 2.6 against 7.8 µs for the CRH2 half train, 3.7 against 8.1 µs at
204 vehicles, one column), but it sums each row in another order. The
structured product is kept: it is what the nonlinear model needs
(:meth:`Chain.couple`) and keeps the old arithmetic. The plant uses it only to
locate section crossings (about a fifth of a 20 s CRH2 sample on a track with
a boundary every 200 m, none on flat track).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import scipy.sparse
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import DimensionError, ModelError
from trainctl.models.train import Train

__all__ = ["Chain", "train_chain"]

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True, eq=False)
class Chain:
    """Linear dynamics x' = A x + B u of a coupled chain of n vehicles.

    Parameters
    ----------
    mass : array_like
        Vehicle masses m_i [kg], shape (n,), > 0.
    stiffness : array_like
        Coupler stiffnesses k_i [N/m], shape (n-1,); 0 for virtual links.
    damping : array_like
        Coupler damping d_i [N·s/m], shape (n-1,); 0 for virtual links.
    virtual : array_like of bool
        True where link i is virtual (it must then have k_i = d_i = 0).
    speed_damping : array_like
        Speed damping per unit mass c_i [1/s], shape (n,): the term -c_i v_i.
    dummy_state : bool
        Append seed 000's dummy elongation ``delta[n-1]`` (zero row and column).
    position : bool
        Append the head position s (ds/dt = v_0) as the last state.

    Examples
    --------
    >>> import numpy as np
    >>> chain = Chain(mass=[2.0, 4.0], stiffness=[8.0], damping=[0.0], virtual=[False],
    ...               speed_damping=[0.5, 0.25])
    >>> A, B = chain.matrices()
    >>> A.tolist()
    [[-0.5, 0.0, -4.0], [0.0, -0.25, 2.0], [1.0, -1.0, 0.0]]
    >>> chain.product(np.array([1.0, 0.0, 0.5])).tolist()
    [-2.5, 1.0, 1.0]
    """

    mass: Array
    stiffness: Array
    damping: Array
    virtual: NDArray[np.bool_]
    speed_damping: Array
    dummy_state: bool = False
    position: bool = False
    _columns: dict[int, tuple[Array, Array, Array]] = field(
        default_factory=dict, init=False, repr=False
    )

    def __post_init__(self) -> None:
        mass = np.asarray(self.mass, dtype=float)
        n = mass.size
        arrays = {
            "stiffness": np.asarray(self.stiffness, dtype=float),
            "damping": np.asarray(self.damping, dtype=float),
            "virtual": np.asarray(self.virtual, dtype=bool),
            "speed_damping": np.asarray(self.speed_damping, dtype=float),
        }
        if mass.ndim != 1 or n < 1 or not np.all(mass > 0):
            raise ModelError(f"Chain: 'mass' must be a 1-D array of masses > 0 (got {mass!r}).")
        for name, value in arrays.items():
            size = n if name == "speed_damping" else n - 1
            if value.shape != (size,):
                raise DimensionError(
                    f"Chain: '{name}' must have shape ({size},) for {n} vehicles "
                    f"(got {value.shape})."
                )
        virtual = arrays["virtual"]
        if np.any(arrays["stiffness"][virtual] != 0) or np.any(arrays["damping"][virtual] != 0):
            raise ModelError("Chain: a virtual link must have zero stiffness and damping.")
        object.__setattr__(self, "mass", mass)
        for name, value in arrays.items():
            object.__setattr__(self, name, value)

    @classmethod
    def from_train(
        cls,
        train: Train,
        speed_damping: ArrayLike | None = None,
        *,
        dummy_state: bool = False,
        position: bool = False,
    ) -> Chain:
        """The chain of a :class:`~trainctl.models.Train`.

        Parameters
        ----------
        train : Train
            The train.
        speed_damping : array_like or None
            Speed damping per unit mass c_i [1/s], shape (n,); None for zero.
        dummy_state : bool
            Append seed 000's dummy elongation.
        position : bool
            Append the head position s.

        Returns
        -------
        Chain
            The chain's linear structure.

        Examples
        --------
        >>> from trainctl.models.presets import crh2_half
        >>> Chain.from_train(crh2_half(), position=True).n_states
        8
        """
        n = train.n_vehicles
        return cls(
            mass=train.mass,
            stiffness=train.stiffness,
            damping=train.damping,
            virtual=train.virtual,
            speed_damping=(np.zeros(n) if speed_damping is None
                           else np.asarray(speed_damping, dtype=float)),
            dummy_state=dummy_state,
            position=position,
        )

    @property
    def n_vehicles(self) -> int:
        """Number of vehicles n."""
        return int(self.mass.size)

    @property
    def n_states(self) -> int:
        """State dimension: 2n - 1, plus one each for the dummy state and the position."""
        return 2 * self.n_vehicles - 1 + int(self.dummy_state) + int(self.position)

    def matrices(self) -> tuple[Array, Array]:
        """Dense state and input matrices (A, B).

        Returns
        -------
        A : ndarray
            Shape (nx, nx) with nx = :attr:`n_states` [SI].
        B : ndarray
            Shape (nx, n) [1/kg]: 1/m_i on the speed rows.

        Examples
        --------
        >>> chain = Chain(mass=[1.0], stiffness=[], damping=[], virtual=[],
        ...               speed_damping=[0.5], position=True)
        >>> [a.tolist() for a in chain.matrices()]
        [[[-0.5, 0.0], [1.0, 0.0]], [[1.0], [0.0]]]
        """
        n, nx = self.n_vehicles, self.n_states
        m, k, d = self.mass, self.stiffness, self.damping
        A = np.zeros((nx, nx))
        diag = np.arange(n)
        A[diag, diag] = -self.speed_damping
        if n > 1:
            i = np.arange(n - 1)
            # f_i = k delta_i + d (v_i - v_{i+1}) pulls vehicle i back and vehicle i+1 forward.
            A[i + 1, i + 1] -= d / m[1:]
            A[i, i] -= d / m[:-1]
            A[i, i + 1] += d / m[:-1]
            A[i + 1, i] += d / m[1:]
            A[i, n + i] -= k / m[:-1]
            A[i + 1, n + i] += k / m[1:]
            A[n + i, i] = 1.0
            A[n + i, i + 1] = -1.0
        if self.position:
            A[nx - 1, 0] = 1.0
        B = np.zeros((nx, n))
        B[diag, diag] = 1.0 / m
        return A, B

    @cached_property
    def sparse(self) -> Any:
        """A as a ``scipy.sparse.csr_array``, built in O(n) (kept on the chain).

        The entries of :meth:`matrices` (the diagonal accumulated in the same
        order), without the zeros of virtual links. The banded plant
        (:mod:`trainctl.models._plant_banded`) uses it for its Taylor terms
        inside a substep, where one product costs ~4 µs against ~30 µs for
        :meth:`product` on a few columns at 204 vehicles (measured).

        Examples
        --------
        >>> chain = Chain(mass=[2.0, 4.0], stiffness=[8.0], damping=[1.0], virtual=[False],
        ...               speed_damping=[0.5, 0.25], position=True)
        >>> bool((chain.sparse.toarray() == chain.matrices()[0]).all())
        True
        """
        n, nx = self.n_vehicles, self.n_states
        m, k, d = self.mass, self.stiffness, self.damping
        diag = -self.speed_damping
        rows, cols, vals = [np.arange(n)], [np.arange(n)], [diag]
        if n > 1:
            diag[1:] -= d / m[1:]
            diag[:-1] -= d / m[:-1]
            i = np.arange(n - 1)
            rows += [i, i + 1, i, i + 1, n + i, n + i]
            cols += [i + 1, i, n + i, n + i, i, i + 1]
            vals += [d / m[:-1], d / m[1:], -k / m[:-1], k / m[1:], np.ones(n - 1),
                     -np.ones(n - 1)]
        if self.position:
            rows.append(np.array([nx - 1]))
            cols.append(np.array([0]))
            vals.append(np.array([1.0]))
        A = scipy.sparse.csr_array(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nx, nx)
        )
        A.eliminate_zeros()
        A.sort_indices()
        return A

    def product(self, Y: ArrayLike) -> Array:
        """A @ Y in O(n) per column, from the chain structure.

        Parameters
        ----------
        Y : array_like
            States, shape (nx,) or (nx, m).

        Returns
        -------
        ndarray
            A @ Y, the shape of ``Y``.
        """
        Y = np.asarray(Y, dtype=float)
        n = self.n_vehicles
        if Y.shape[0] != self.n_states:
            raise DimensionError(
                f"Chain.product: 'Y' must have {self.n_states} rows (got {Y.shape[0]})."
            )
        out = np.empty_like(Y)
        c = self.speed_damping
        out[:n] = -(c if Y.ndim == 1 else c.reshape((n,) + (1,) * (Y.ndim - 1))) * Y[:n]
        self.couple(Y, out)
        return out

    def forces(self, Y: ArrayLike) -> Array:
        """Coupler forces f_i = k_i delta_i + d_i (v_i - v_{i+1}) [N], tension positive.

        Parameters
        ----------
        Y : array_like
            States ``[v, delta, ...]``, shape (nx,) or (nx, m); rows after the
            elongations are ignored.

        Returns
        -------
        ndarray
            Forces, shape (n-1,) or (n-1, m).
        """
        Y = np.asarray(Y, dtype=float)
        n = self.n_vehicles
        _, k, d = self._shaped(Y.ndim)
        forces: Array = k * Y[n : 2 * n - 1] + d * (Y[: n - 1] - Y[1:n])
        return forces

    def couple(self, Y: Array, out: Array) -> None:
        """Add the chain's coupling to the vehicles' own accelerations, in place.

        On entry ``out[:n]`` holds each vehicle's own acceleration (anything
        but the coupler forces: traction, resistance, speed damping). On exit
        the speed rows also carry -f_i/m_i and +f_{i-1}/m_i, and the other
        rows hold the kinematics: v_i - v_{i+1}, 0 for the dummy state, v_0
        for the position.

        Parameters
        ----------
        Y : ndarray
            States, shape (nx,) or (nx, m) (nx = :attr:`n_states`).
        out : ndarray
            Rates, the shape of ``Y`` (or broadcast with it); overwritten as described.
        """
        n = self.n_vehicles
        v = Y[:n]
        if n > 1:
            m, k, d = self._shaped(Y.ndim)
            rel = v[:-1] - v[1:]
            f = k * Y[n : 2 * n - 1] + d * rel
            out[: n - 1] -= f / m[:-1]
            out[1:n] += f / m[1:]
            out[n : 2 * n - 1] = rel
        if self.dummy_state:
            out[2 * n - 1] = 0.0
        if self.position:
            out[self.n_states - 1] = v[0]

    def _shaped(self, ndim: int) -> tuple[Array, Array, Array]:
        """(m, k, d) shaped to broadcast along the rows of an ndim-dimensional state."""
        if ndim == 1:
            return self.mass, self.stiffness, self.damping
        cached = self._columns.get(ndim)
        if cached is None:
            shape = (-1,) + (1,) * (ndim - 1)
            cached = self._columns[ndim] = (
                self.mass.reshape(shape), self.stiffness.reshape(shape), self.damping.reshape(shape)
            )
        return cached


_CACHE: dict[int, tuple[Train, Chain]] = {}
_CACHE_SIZE = 16


def train_chain(train: Train) -> Chain:
    """The chain of ``train`` with the head position and no speed damping (cached).

    What the nonlinear model needs from the chain: :meth:`Chain.couple` and
    :meth:`Chain.forces` on the state ``[v, delta, s]``. Kept for the last few
    trains so that the right-hand side does not rebuild it at every call.

    Parameters
    ----------
    train : Train
        The train.

    Returns
    -------
    Chain
        ``Chain.from_train(train, position=True)``.

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> train = crh2_half()
    >>> train_chain(train) is train_chain(train)
    True
    """
    cached = _CACHE.get(id(train))
    if cached is not None and cached[0] is train:
        return cached[1]
    chain = Chain.from_train(train, position=True)
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[id(train)] = (train, chain)
    return chain
