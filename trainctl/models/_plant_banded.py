# Banded exact steps of the plant's linear part, built in O(n) (private to models.plant).
"""Banded propagators of :class:`trainctl.models.Plant` for long trains.

The chain couples only neighbours: a vehicle's acceleration depends on its own
speed and its two couplers, a coupler's elongation rate on two neighbouring
speeds. The exact step [Φ | Γ] = top rows of expm([[A, B], [0, 0]] t) is
then *numerically banded*: its entries decay faster than exponentially with
the distance between the vehicles of row and column (204-vehicle heavy-haul
chain, t = 0.05 s: 1e-2 at 2 vehicles, 1e-7 at 6, 1e-13 at 10, relative to
the largest entry of each block; at t = 0.5 s, 1e-13 at ~26 vehicles). This
module builds that band in O(n) and stores it as a ``scipy.sparse`` CSR
array, so that a substep costs O(n) too.

Construction (:func:`banded_flow`): the chain is cut into overlapping
windows, a *core* of consecutive vehicles plus a margin of M vehicles on
each side; the window's own augmented matrix (the sub-chain of its vehicles,
its couplers to the outside cut) goes through one ``scipy.linalg.expm``, and
the columns of its core vehicles (v_i, delta_i, F_i) are kept. The cut
changes a core column only by the chain's own decay over the margin, so the
kept columns equal the whole chain's to far below the tolerance when M
exceeds the band. An entry is dropped when it is at most :data:`BAND_TOL`
(1e-13) times the largest entry of its block (rows v, delta or s by columns
v, delta or F; the blocks carry different units), which is the criterion the
tests check against the dense ``expm``. The margin is chosen from the
computed decay itself: the reach r (the largest vehicle distance of a kept
entry) must satisfy M >= r + 4 + r // 4 (the decay over those last vehicles
is another 1e-4 or more), otherwise the windows are recomputed with the
larger margin. Windows whose sub-chains are equal (the wagons of a
heavy-haul train) share one ``expm``.

Why windows of dense ``expm`` rather than the alternatives, measured on the
204-vehicle chain at h = 0.05 s, v̄ = 20 m/s (2-core machine shared with
other jobs, single-threaded BLAS; times vary 2–3x with the load, the ratios
less):

- one dense ``expm`` of the 612 x 612 augmented matrix, then truncation:
  the same band, but 0.25–0.35 s per (h, v̄), O(n³) (1.5 s at 404
  vehicles); the windows take 0.04–0.1 s, ~0.1 s at 404 vehicles too;
- ``scipy.sparse.linalg.expm_multiply`` on probe columns (a colouring of the
  band: vehicles 23 apart share a probe): as accurate (7e-16 on the speed
  block), but 0.15 s for the 23 speed probes, ~0.44 s for the three kinds
  of column, against 0.135 s for the windows in the same run;
- a Padé approximant applied every substep with banded LU
  (``scipy.linalg.solve_banded``): not measured; ‖A h‖ ~ 1.5 at the default
  substep, so a diagonal Padé approximant needs scaling and squaring (or
  substeps well below h) to reach 1e-13, and every substep would pay for
  several banded products and a solve instead of one product.

The band is applied with the CSR product ``@`` (scipy's C++ ``csr_matvec``),
~0.8 ns per stored entry: at 204 vehicles 25 000 entries, 23 µs per substep
against 33 µs for the dense (408 x 611) product, measured side by side
(``benchmarks/plant_banded.py``). A hand-vectorised block-tridiagonal product
(groups of 12 vehicles, one batched ``np.matmul``) was no faster (39 against
38 µs, same run), so scipy's is kept.

Rounding: each window's augmented matrix is balanced before its ``expm``
(:func:`_window_expm`); each row's dropped entries are lumped onto its own
vehicle, per block, so that a uniform speed (the rigid-body motion) is
propagated as by the whole matrix. Without the lumping the 204-vehicle chain
drifted 4e-10 m/s from the dense path in 20 s (the dropped ~1e-13 add up on
the common speed); with it 1.5e-11 m/s.

Section crossings (:func:`local_flow`): the banded plant locates a crossing
and adds its jump response on the window of the chain around the crossing
vehicle (the windows above, for (h, v̄)), with a dense ladder of that window
(one ``expm`` over h/1024, then ten squarings), instead of on the whole
chain: the same Newton iteration and response, on ~150 states instead of
612, to below the band tolerance. Measured at 204 vehicles over 600 s with
698 crossing substeps, same run: 0.39 s against 1.38 s for the crossings of
the dense path (0.8 against 2.05 s with the whole chain's banded ladder).
The window's ladder has since given way to Taylor series of A_w over the
whole substep (``local_flow(..., levels=None)``,
:func:`trainctl.models._plant_crossings._local_crossings`): 39 against
107–124 µs per crossing, no ``expm`` of the window.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import scipy.linalg
import scipy.sparse
from numpy.typing import NDArray

from trainctl.models.chain import Chain

if TYPE_CHECKING:
    from trainctl.models.plant import Plant

__all__ = [
    "BAND_TOL", "BANDED_MIN_VEHICLES", "Band", "LocalFlow", "banded_flow", "local_flow",
    "sparse_nbytes",
]

BAND_TOL = 1e-13
"""Entries of [Φ | Γ] at most this times the largest of their block are dropped."""

BANDED_MIN_VEHICLES = 128
"""``propagation="auto"`` uses the banded propagators from this many vehicles on.

Measured per substep (``benchmarks/plant_banded.py --sizes 64,124,204``,
interleaved): dense/banded = 0.68 at 64 vehicles, 0.96 at 124, 1.48 at 204,
4.8 at 404; below ~125 vehicles the dense product was faster. Since the banded
substep applies only Φ (Γ F once per value of F,
:class:`~trainctl.models._plant_propagators.Split`): 0.98 at 64 and 2.4–2.5 at
204 vehicles (three runs); the threshold is kept (below it the paths are
about even)."""

_MIN_CORE = 8
"""Fewest core vehicles per window (cores as wide as the margin minimise the cost)."""

Array = NDArray[np.float64]


def sparse_nbytes(matrix: Any) -> int:
    """Bytes held by a CSR array (data, indices, index pointer)."""
    return int(matrix.data.nbytes + matrix.indices.nbytes + matrix.indptr.nbytes)


def _window_matrices(plant: Plant, lo: int, hi: int, vbar: float) -> tuple[Array, Array]:
    """(A_w, B_w) of the sub-chain of vehicles lo..hi-1 on ``[v, delta, s]``.

    s is the position of vehicle lo (the head's only for lo = 0). A_w is
    built as the plant's A (:func:`trainctl.models._plant_propagators.matrix_a`):
    the linear Davis term, then the drag linearised about vbar.
    """
    train = plant.train
    m = hi - lo
    chain = Chain(
        mass=train.mass[lo:hi], stiffness=train.stiffness[lo : hi - 1],
        damping=train.damping[lo : hi - 1], virtual=train.virtual[lo : hi - 1],
        speed_damping=train.davis[1][lo:hi], position=True,
    )
    A, B = chain.matrices()
    if vbar != 0.0:
        A[np.arange(m), np.arange(m)] -= 2.0 * vbar * train.davis[2][lo:hi]
    return A, B


def _window_expm(plant: Plant, lo: int, hi: int, t: float, vbar: float) -> Array:
    """Top 2m rows of expm([[A_w, B_w], [0, 0]] t) of the sub-chain of vehicles lo..hi-1.

    m = hi - lo; the local states are ``[v (m), delta (m-1), s, F (m)]``
    (:func:`_window_matrices`).
    """
    train = plant.train
    m = hi - lo
    A, B = _window_matrices(plant, lo, hi, vbar)
    # Balanced: elongations in units of 1/ω (ω = sqrt(mean k / mean m), the
    # couplers' rate) and forces per unit mass, so that every block is O(1).
    # expm(S M S⁻¹ t) = S expm(M t) S⁻¹ exactly; in rounding, the unbalanced
    # matrix (Φ ~ 1 next to Γ ~ 1e-7 s/kg) left a noise floor of ~5e-14 of
    # the (delta, F) block wherever expm had to square (window at the
    # locomotive, t = 0.0125 s), which the band criterion took for a reach of
    # 86 vehicles; balanced, the entries decay to 1e-35 there as elsewhere.
    k = train.stiffness[~train.virtual]
    omega = float(np.sqrt(k.mean() / train.mass.mean())) if k.size and k.mean() > 0 else 1.0
    scale = np.r_[np.ones(m), np.full(m - 1, omega), 1.0, 1.0 / train.mass[lo:hi]]
    M = np.zeros((3 * m, 3 * m))
    M[: 2 * m, : 2 * m] = A
    M[: 2 * m, 2 * m :] = B
    M *= scale[:, None] * t
    M /= scale[None, :]
    E = np.asarray(scipy.linalg.expm(M))[: 2 * m]
    E /= scale[: 2 * m, None]
    E *= scale[None, :]
    return E


def _window_key(plant: Plant, lo: int, hi: int) -> bytes:
    """Identifies a window's sub-chain (equal keys: equal expm)."""
    train = plant.train
    parts = (
        train.mass[lo:hi], train.stiffness[lo : hi - 1], train.damping[lo : hi - 1],
        train.virtual[lo : hi - 1].astype(float), train.davis[1][lo:hi], train.davis[2][lo:hi],
    )
    return bytes([lo == 0]) + b"".join(np.ascontiguousarray(p).tobytes() for p in parts)


def _layout(n: int, lo: int, hi: int) -> tuple[NDArray[np.intp], NDArray[np.intp], Array,
                                                 Array, NDArray[np.intp], NDArray[np.intp]]:
    """Global indices, vehicle positions and kinds of a window's local rows and columns.

    Rows: global row in [v, delta, s] (2n), vehicle position (delta_i at
    i + 1/2, s at 0) and kind (0 v, 1 delta, 2 s). Columns (the local s column
    left out): global column in [v, delta, s, F] (3n), position, kind (0 v,
    1 delta, 2 F).
    """
    m = hi - lo
    a, c = np.arange(m), np.arange(m - 1)
    rows = np.r_[lo + a, n + lo + c, 2 * n - 1]
    rpos = np.r_[lo + a, lo + c + 0.5, 0.0]
    rkind = np.r_[np.zeros(m, np.intp), np.ones(m - 1, np.intp), 2]
    cols = np.r_[lo + a, n + lo + c, 2 * n + lo + a]
    cpos = np.r_[lo + a, lo + c + 0.5, lo + a].astype(float)
    ckind = np.r_[np.zeros(m, np.intp), np.ones(m - 1, np.intp), np.full(m, 2, np.intp)]
    return rows, cols, rpos, cpos, rkind, ckind


def _entries(
    plant: Plant, t: float, vbar: float, margin: int
) -> tuple[NDArray[np.intp], NDArray[np.intp], Array, Array, NDArray[np.intp]]:
    """All entries of the core columns of every window: rows, columns, values,
    vehicle distances and block ids (3 row kinds x 3 column kinds)."""
    n = plant.train.n_vehicles
    core = max(margin, _MIN_CORE)
    flows: dict[bytes, Array] = {}
    parts: list[tuple[Any, ...]] = []
    for clo in range(0, n, core):
        chi = min(n, clo + core)
        lo, hi = max(0, clo - margin), min(n, chi + margin)
        key = _window_key(plant, lo, hi)
        E = flows.get(key)
        if E is None:
            E = flows[key] = _window_expm(plant, lo, hi, t, vbar)
        m = hi - lo
        E = np.delete(E, 2 * m - 1, axis=1)  # the s column is e_s exactly (added later)
        rows, cols, rpos, cpos, rkind, ckind = _layout(n, lo, hi)
        own = (cpos >= clo) & (cpos < chi)
        keep_rows = np.ones(rows.size, bool)
        keep_rows[-1] = lo == 0  # the local s row is the head's only in the first window
        R, C = np.nonzero(keep_rows[:, None] & own[None, :])
        parts.append((rows[R], cols[C], E[R, C], np.abs(rpos[R] - cpos[C]),
                      3 * rkind[R] + ckind[C]))
    return tuple(np.concatenate(x) for x in zip(*parts, strict=True))  # type: ignore[return-value]


def _first_margin(known: dict[float, int], t: float) -> int:
    """A first margin for duration t [s]: the margin that sufficed for t, else for the
    shortest longer duration (the band only widens with t), else 8 vehicles."""
    longer = [margin for duration, margin in known.items() if duration >= t]
    return min(longer) if longer else 8


class Band(NamedTuple):
    """A banded flow and how it was built."""

    flow: Any
    """[Φ | Γ] as a ``scipy.sparse.csr_array``, shape (2n, 3n)."""
    reach: int
    """Largest vehicle distance between the row and column of a stored entry."""
    margin: int
    """Vehicles on each side of a window's core."""


def banded_flow(plant: Plant, t: float, vbar: float, tol: float = BAND_TOL) -> Band:
    """The banded exact flow [Φ | Γ](t) about vbar, CSR, shape (2n, 3n).

    Parameters
    ----------
    plant : Plant
        The plant (its train gives the chain).
    t : float
        Duration [s], > 0.
    vbar : float
        Speed about which the quadratic drag is linearised [m/s].
    tol : float
        Entries at most ``tol`` times the largest entry of their block are
        dropped (module docstring).

    Returns
    -------
    Band
        ``flow``: rows ``[v, delta, s]``, columns ``[v, delta, s, F]`` as
        :func:`~trainctl.models._plant_propagators.augmented_expm` [SI], the
        s column e_s; with the band's reach and the windows' margin [vehicles].
    """
    n = plant.train.n_vehicles
    margin = _first_margin(plant._margins, t)
    while True:
        rows, cols, vals, dist, block = _entries(plant, t, vbar, margin)
        scale = np.zeros(9)
        np.maximum.at(scale, block, np.abs(vals))
        keep = np.abs(vals) > tol * scale[block]
        reach = int(np.ceil(dist[keep].max())) if keep.any() else 0
        need = reach + 4 + reach // 4
        if margin >= need or margin >= n:  # margin >= n: one window, the whole chain
            break
        margin = max(need, 2 * margin) if reach >= margin - 1 else need
    if len(plant._margins) >= 64:
        plant._margins.clear()
    plant._margins[t] = max(need, 1)
    # Lump each row's dropped entries, per column block, onto the row's own vehicle
    # in that block: the band then maps a uniform v (or delta, or F) exactly as the
    # whole matrix does. Without it the dropped ~1e-13 add up coherently on the
    # common speed (the rigid-body mode): the 204-vehicle chain drifted 4e-10 m/s
    # from the dense path in 20 s; with it 1.5e-11 m/s (level), 4.5e-12 m/s (grades).
    drop = ~keep
    group = 3 * rows[drop] + block[drop] % 3
    lumped = np.bincount(group, weights=vals[drop], minlength=6 * n)
    anchor_rows = np.repeat(np.arange(2 * n), 3)
    vehicle = np.r_[np.arange(n), np.arange(n - 1), 0]
    anchor_cols = np.stack([vehicle, n + np.minimum(vehicle, max(n - 2, 0)), 2 * n + vehicle],
                           axis=1).ravel()
    some = lumped != 0.0
    rows = np.r_[rows[keep], anchor_rows[some], 2 * n - 1]
    cols = np.r_[cols[keep], anchor_cols[some], 2 * n - 1]
    vals = np.r_[vals[keep], lumped[some], 1.0]
    flow = scipy.sparse.csr_array((vals, (rows, cols)), shape=(2 * n, 3 * n))
    flow.sum_duplicates()
    flow.sort_indices()
    return Band(flow, reach, margin)


class LocalFlow(NamedTuple):
    """The exact flow of one window of the chain, for crossings on the banded path."""

    lo: int
    """First vehicle of the window."""
    hi: int
    """One past its last vehicle."""
    levels: Array
    """[Φ_w | Γ_w] over h/2^j, j = 0..L, shape (L+1, 2m, 3m), on ``[v, delta, s]``
    of the window (s: the position of vehicle lo) and its forces."""
    A: Array
    """A_w, shape (2m, 2m), for the Taylor terms below h/2^L."""
    inverse_mass: Array
    """1/m_i of the window's vehicles [1/kg], shape (m, 1)."""
    norm: float = 0.0
    """The larger of ‖S A_w S⁻¹‖₁ and ‖S A_w S⁻¹‖_∞ (S: elongations times ω, as
    :func:`_window_expm` balances), which bounds the growth of the Taylor terms of
    the flow."""
    rows: dict[int, tuple[Array, ...]] | None = None
    """Per vehicle k of the window: the Taylor series' rows e_k A_w^j and columns
    A_w^j B e_k (:func:`trainctl.models._plant_crossings._series`), filled by the
    crossings as they need them."""
    core: tuple[int, int] = (0, 0)
    """The window's core vehicles (those it stands in for), local indices lo..hi-1."""


def local_flow(plant: Plant, h: float, vbar: float, vehicle: int, levels: int | None
               ) -> LocalFlow:
    """The window of the chain around ``vehicle`` whose flow stands in for the chain's there.

    The windows are those of :func:`banded_flow` for (h, vbar): a core of
    consecutive vehicles plus the margin on each side, so that every vehicle
    of the core is at least the margin from a cut. Over t <= h its rows of
    the window's flow then equal the whole chain's to below :data:`BAND_TOL`
    of their block, as the band's columns do. Kept on the plant per (h, vbar)
    (a least-recently-used cache with a byte budget); equal sub-chains share
    one ladder. ``levels`` None: no ladder (``levels`` of the result empty), the
    crossings use Taylor series of A_w over the whole substep instead.
    """
    n = plant.train.n_vehicles
    margin = max(plant._margins.get(h, 8), 8)
    core = max(margin, _MIN_CORE)
    clo = (vehicle // core) * core
    lo, hi = max(0, clo - margin), min(n, clo + core + margin)
    group: dict[Any, LocalFlow] | None = plant._local_flows.fetch((h, vbar, levels))
    if group is None:
        group = {}
        width = min(n, core + 2 * margin)
        # The ladders, or the series' rows and columns (~30 per vehicle of a core).
        per_window = (6 * (levels + 1) * width if levels is not None else 120 * core) * width
        plant._local_flows.store((h, vbar, levels), group, (n // core + 1) * per_window * 8)
    found = group.get((lo, hi))
    if found is not None:
        return found
    m = hi - lo
    shared = _window_key(plant, lo, hi)
    same = group.get(shared)
    if same is None:
        A = _window_matrices(plant, lo, hi, vbar)[0]
        ladder = np.empty((0, 2 * m, 3 * m))
        # One expm for the finest level, the others by squaring [Φ | Γ] -> [Φ², ΦΓ + Γ]
        # as the dense ladder does (five expm of the window cost ~5x more).
        if levels is not None:
            ladder = np.empty((levels + 1, 2 * m, 3 * m))
            ladder[levels] = _window_expm(plant, lo, hi, h / 2.0**levels, vbar)
        for j in range(-1 if levels is None else levels - 1, -1, -1):
            finer = ladder[j + 1]
            np.matmul(finer[:, : 2 * m], finer, out=ladder[j])
            ladder[j, :, 2 * m :] += finer[:, 2 * m :]
        # ‖A_w‖₁ in the balanced units of _window_expm (elongations times ω): ~60 1/s
        # at 204 vehicles where the raw norm (k/m next to 1) is ~500, so that the
        # Taylor series' term bound is not ~10x pessimistic.
        k = plant.train.stiffness[~plant.train.virtual]
        omega = (float(np.sqrt(k.mean() / plant.train.mass.mean()))
                 if k.size and k.mean() > 0 else 1.0)
        scale = np.r_[np.ones(m), np.full(m - 1, omega), 1.0]
        balanced = np.abs(A * scale[:, None] / scale[None, :])
        norm = float(max(balanced.sum(axis=0).max(), balanced.sum(axis=1).max()))
        same = group[shared] = LocalFlow(lo, hi, ladder, A, 1.0 / plant.train.mass[lo:hi, None],
                                         norm, {})
    flow = group[(lo, hi)] = LocalFlow(lo, hi, same.levels, same.A, same.inverse_mass,
                                       same.norm, same.rows,
                                       (clo - lo, min(n, clo + core) - lo))
    return flow
