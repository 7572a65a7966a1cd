# Exact linear steps of the plant's splitting integrator (private to models.plant).
"""The propagators of :class:`trainctl.models.Plant`: exact steps of the linear part.

Over a substep of length h the plant's linear part x' = A(v̄) x + B F (the
chain of :mod:`trainctl.models.chain` with the quadratic drag linearised about
the grid speed v̄) is solved exactly: [Φ | Γ] = the top rows of
expm([[A, B], [0, 0]] h), one ``scipy.linalg.expm``, cached per (h, v̄) on the
plant (:func:`propagator`). On a track the crossings also need the flow over
any t <= h, built from the binary ladder h/2^j (:func:`ladder`). The quadratic
drag's remainder -a2 (v - v̄)² has the exact flow :func:`drag_flow`.

For long trains (``Plant._banded``) the same matrices are banded CSR arrays
built in O(n) by :func:`trainctl.models._plant_banded.banded_flow`; ``step @ z``
and the ladder's products work on either.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple, TypeVar

import numpy as np
import scipy.linalg
import scipy.sparse
from numpy.typing import NDArray

from trainctl.models._plant_banded import banded_flow, sparse_nbytes

try:  # scipy's C++ CSR product, called without the ~10 µs of ``@`` dispatch per substep
    from scipy.sparse._sparsetools import csr_matvec as _csr_matvec
except ImportError:  # pragma: no cover - a scipy without the private module: use ``@``
    _csr_matvec = None

if TYPE_CHECKING:
    from trainctl.models.plant import Plant

__all__ = [
    "CACHE_BYTES", "LADDER_LEVELS", "LRU", "Propagator", "Split", "TrackArrays",
    "augmented_expm", "drag_flow", "grid_speed", "ladder", "matrix_a", "product", "propagator",
    "split_product",
]

LADDER_LEVELS = 4
"""Binary levels h/2^j, j = 0..4, used to build the flow over any t in [0, h]."""

SPEED_GRID = 2.0
"""Grid [m/s] of the speeds vbar about which the quadratic drag is linearised."""

CACHE_BYTES = 1 << 27
"""Byte budget of each propagator cache (128 MiB); least recently used entries go first."""

_T = TypeVar("_T")

TrackArrays = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]
]


def grid_speed(speed: float) -> float:
    """The grid speed nearest ``speed`` [m/s]."""
    return float(SPEED_GRID * round(float(speed) / SPEED_GRID))


def drag_flow(z: NDArray[np.float64], n: int, ta2: NDArray[np.float64], vbar: float) -> None:
    """Exact flow of dv/dt = -a2 (v - vbar)² over t [s], in place on z[:n]; ta2 = t·a2."""
    w = z[:n]  # in place, the same operations as vbar + w / (1 + ta2 w), w = v - vbar
    w -= vbar
    d = ta2 * w
    d += 1.0
    w /= d
    w += vbar


@dataclass(frozen=True)
class Propagator:
    """Exact linear step of length h about speed vbar on ``[v, delta, s]`` with forcing F [N]."""

    step: Any
    """[Φ | Γ] restricted to columns [v, delta, F], (2n, 3n-1); the last row is the
    increment of s (its own column, e_s, is left out so that s is added exactly).
    A dense ndarray, or a ``scipy.sparse.csr_array`` on the banded path
    (:mod:`trainctl.models._plant_banded`); ``step @ z`` either way."""
    apply: Callable[[NDArray[np.float64]], NDArray[np.float64]] = field(
        default=None, compare=False, repr=False)  # type: ignore[assignment]
    """``z -> step @ z`` (a new array), bit for bit, without the dispatch of ``@``
    on a CSR array (:func:`product`); set from ``step`` when not given."""
    split: Split | None = field(default=None, compare=False, repr=False)
    """Banded path: the step as Φ on [v, delta] plus Γ F, the latter computed only when
    F changes (:func:`split_product`); None on the dense path."""

    def __post_init__(self) -> None:
        if self.apply is None:
            object.__setattr__(self, "apply", product(self.step))


class Split(NamedTuple):
    """One step ``z -> [Φ | Γ] z`` in two parts, for inputs held over many substeps.

    F (the forces, z[2n-1:]) changes only when v̄ changes or a vehicle crosses a
    section boundary, a few times per sample, so Γ F is computed then
    (``forcing``) and each substep applies only Φ (``state(z, out)``: out += Φ
    z[:2n-1], scipy's ``csr_matvec`` accumulating into ``out``). At 204 vehicles
    Φ holds 17 000 of the step's 25 000 entries: measured 8.9 against 14.2 µs per
    product (``csr_matvec`` called directly, best of 5 x 20 000, same run). The
    sums are taken in another order (Γ F first): the same to rounding.
    """

    state: Callable[[NDArray[np.float64], NDArray[np.float64]], None]
    forcing: Callable[[NDArray[np.float64]], NDArray[np.float64]]


def split_product(step: Any, n: int) -> Split | None:
    """The :class:`Split` of a float64 CSR step on ``[v, delta, F]`` (None: not CSR, or
    no direct ``csr_matvec``)."""
    if isinstance(step, np.ndarray) or _csr_matvec is None or step.format != "csr" \
            or step.dtype != np.float64:
        return None
    rows, cols = step.shape
    coo = step.tocoo()
    state_part = coo.col < 2 * n - 1
    phi = scipy.sparse.csr_array(
        (coo.data[state_part], (coo.row[state_part], coo.col[state_part])), shape=(rows, cols))
    phi.sort_indices()
    gamma = scipy.sparse.csr_array(
        (coo.data[~state_part], (coo.row[~state_part], coo.col[~state_part] - (2 * n - 1))),
        shape=(rows, n))
    gamma.sort_indices()
    indptr, indices, data = phi.indptr, phi.indices, phi.data
    matvec = _csr_matvec

    def state(z: NDArray[np.float64], out: NDArray[np.float64]) -> None:
        matvec(rows, cols, indptr, indices, data, z, out)

    return Split(state, product(gamma))


def product(step: Any) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """``z -> step @ z`` for a dense array or a float64 CSR array (then scipy's
    ``csr_matvec`` called directly, as ``@`` calls it: the same sums, bit for bit)."""
    if isinstance(step, np.ndarray) or _csr_matvec is None or step.format != "csr" \
            or step.dtype != np.float64:
        matmul: Callable[[NDArray[np.float64]], NDArray[np.float64]] = step.__matmul__
        return matmul
    rows, cols = step.shape
    indptr, indices, data = step.indptr, step.indices, step.data
    matvec = _csr_matvec

    def apply(z: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros(rows)
        matvec(rows, cols, indptr, indices, data, z, out)
        return out

    return apply


class LRU(OrderedDict[tuple[Any, ...], _T]):
    """A small least-recently-used cache with a byte budget."""

    def __init__(self, budget: int = 1 << 27) -> None:
        super().__init__()
        self.budget = budget
        self.limit = 1 << 30

    def fetch(self, key: tuple[Any, ...]) -> _T | None:
        value = self.get(key)
        if value is not None:
            self.move_to_end(key)
        return value

    def store(self, key: tuple[Any, ...], value: _T, nbytes: int) -> None:
        self.limit = max(2, self.budget // max(nbytes, 1))
        self[key] = value
        while len(self) > self.limit:
            self.popitem(last=False)


def matrix_a(plant: Plant, vbar: float) -> NDArray[np.float64]:
    """A with the quadratic drag linearised about vbar: -(a1 + 2 a2 vbar) on the v rows."""
    A = plant._linear[0]
    if vbar == 0.0:
        return A
    n = plant.train.n_vehicles
    A = A.copy()
    A[np.arange(n), np.arange(n)] -= 2.0 * vbar * plant.train.davis[2]
    return A


def augmented_expm(plant: Plant, h: float, vbar: float) -> NDArray[np.float64]:
    """expm([[A(vbar), B], [0, 0]] h), shape (3n, 3n)."""
    B = plant._linear[1]
    n = plant.train.n_vehicles
    M = np.zeros((3 * n, 3 * n))
    M[: 2 * n, : 2 * n] = matrix_a(plant, vbar)
    M[: 2 * n, 2 * n :] = B
    return np.asarray(scipy.linalg.expm(M * h))


def propagator(plant: Plant, h: float, vbar: float) -> Propagator:
    """The exact step of length h about vbar (cached on the plant)."""
    cached = plant._cache.fetch((h, vbar))
    if cached is not None:
        return cached
    n = plant.train.n_vehicles
    track = plant._track_arrays
    banded = plant._banded
    E: Any
    if banded:  # its crossings work on windows (no ladder of the whole chain needed)
        E = banded_flow(plant, h, vbar).flow
    elif track is not None and track[0].size > 1:
        E = ladder(plant, h, vbar)[0]  # crossings will need the ladder anyway
    else:
        E = augmented_expm(plant, h, vbar)[: 2 * n]
    # Drop the s column: A has a zero s column, so Φ[:, s] = e_s exactly.
    cols = np.r_[0 : 2 * n - 1, 2 * n : 3 * n]
    if banded:
        step = E[:, cols]
        step.sort_indices()
        nbytes = 2 * sparse_nbytes(step)  # and its split
    else:
        step = np.ascontiguousarray(E[:, cols])
        nbytes = step.nbytes
    prop = Propagator(step=step, split=split_product(step, n) if banded else None)
    plant._cache.store((h, vbar), prop, nbytes)
    return prop


def ladder(plant: Plant, h: float, vbar: float) -> Any:
    """[Φ | Γ] for durations h/2^j, j = 0..L, shape (L+1, 2n, 3n).

    Dense: the finest level from ``expm``, the others by squaring. Banded: a
    list of the L+1 banded flows, each built directly
    (:func:`~trainctl.models._plant_banded.banded_flow`); on that path only
    the inner points of the dense output need it (crossings use windows).
    """
    cached = plant._ladders.fetch((h, vbar))
    if cached is not None:
        return cached
    n = plant.train.n_vehicles
    if plant._banded:
        flows = [banded_flow(plant, h / 2.0**j, vbar).flow for j in range(LADDER_LEVELS + 1)]
        plant._ladders.store((h, vbar), flows, sum(sparse_nbytes(f) for f in flows))
        return flows
    levels = np.empty((LADDER_LEVELS + 1, 2 * n, 3 * n))
    levels[LADDER_LEVELS] = augmented_expm(plant, h / 2.0**LADDER_LEVELS, vbar)[: 2 * n]
    for j in range(LADDER_LEVELS - 1, -1, -1):
        # [Φ | Γ] over 2t: [Φ², ΦΓ + Γ].
        finer = levels[j + 1]
        np.matmul(finer[:, : 2 * n], finer, out=levels[j])
        levels[j, :, 2 * n :] += finer[:, 2 * n :]
    plant._ladders.store((h, vbar), levels, levels.nbytes)
    return levels
