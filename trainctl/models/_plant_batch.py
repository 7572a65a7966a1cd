# The plant advanced for many runs at once: rows of states through the same substeps.
"""R states of one :class:`~trainctl.models.Plant` advanced over one interval at once.

:func:`advance_dense_batch` is :meth:`Plant.advance_dense` on the rows of an
(R, 2n) array, bit for bit: the same substeps (:mod:`trainctl.models._plant_integrate`)
with every elementwise operation applied to all rows (IEEE arithmetic per
element does not depend on the array around it), each row's exact linear step
taken with its own grid speed v̄'s cached propagator (read-only use of the
plant's caches) as one stacked ``np.matmul`` of (R, 2n, 3n-1) by (R, 3n-1, 1):
numpy calls BLAS gemv per row there, the product ``step @ z`` of the serial
path, whereas ``Z @ step.T`` (gemm) sums in another order and differs in the
last bits (measured: about 8 of 11 entries per row differ by an ulp).

Rows the vectorised substeps do not cover go through ``plant.advance_dense``
itself: a row in which some vehicle is in another track section at some
substep boundary than at the start (the serial path's section tracker would
find a crossing there and solve for it; without one its lookups change
nothing), and every row on the banded path or with inner points per substep.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from trainctl.models._plant_dense import dense_indices
from trainctl.models._plant_propagators import SPEED_GRID, propagator
from trainctl.models.plant import Plant

__all__ = ["advance_dense_batch"]

Array = NDArray[np.float64]

def _grid(speed: Array) -> Array:
    """:func:`~trainctl.models._plant_propagators.grid_speed` per element (+0.0: no -0.0,
    as Python's ``round`` gives none)."""
    return SPEED_GRID * np.round(speed / SPEED_GRID) + 0.0


def _drag(z: Array, n: int, ta2: Array, vbar: Array) -> None:
    """:func:`~trainctl.models._plant_propagators.drag_flow` on every row (vbar per row)."""
    w = z[:, :n] - vbar[:, None]
    d = ta2 * w
    d += 1.0
    w /= d
    w += vbar[:, None]
    z[:, :n] = w


def advance_dense_batch(plant: Plant, states: Array, inputs: Array, dt: float, every: int,
                        inner: int) -> Array:
    """``plant.advance_dense(states[r], inputs[r], dt, every, inner)[1]`` for every row r.

    Parameters
    ----------
    plant : Plant
        The plant (its caches are filled as the serial path fills them).
    states : ndarray
        Shape (R, 2n), finite.
    inputs : ndarray
        Shape (R, n) [N], finite.
    dt : float
        Interval [s], > 0.
    every, inner : int
        As in :meth:`Plant.advance_dense`.

    Returns
    -------
    ndarray
        Shape (R, 2n, m): row r's states at the m recorded points, the last the end.
    """
    R = states.shape[0]
    n = plant.train.n_vehicles
    steps = plant._substeps(dt)
    m = steps * inner if inner > 1 else (steps - 1) // every + 1
    out = np.empty((R, 2 * n, m))
    serial = np.zeros(R, dtype=bool)
    if plant._banded or inner > 1:
        serial[:] = True
    rows = np.flatnonzero(~serial)
    if rows.size:
        out[rows], crossed = _integrate(plant, states[rows], inputs[rows], dt, steps, every)
        serial[rows[crossed]] = True
    for r in np.flatnonzero(serial):
        out[r] = plant.advance_dense(states[r], inputs[r], dt, every, inner)[1]
    return out


def _sections(plant: Plant, z: Array, s: Array, starts: Array) -> NDArray[np.intp]:
    """:func:`~trainctl.models._plant_crossings.sections` of every row (the same sums)."""
    n = plant.train.n_vehicles
    behind = np.zeros((z.shape[0], n))
    np.cumsum(plant.train.spacing[None, :] + z[:, n : 2 * n - 1], axis=1, out=behind[:, 1:])
    sections: NDArray[np.intp] = np.searchsorted(starts, s[:, None] - behind, side="right") - 1
    return sections


def _integrate(plant: Plant, x: Array, u: Array, dt: float, steps: int, every: int
               ) -> tuple[Array, NDArray[np.bool_]]:
    """:func:`~trainctl.models._plant_integrate.integrate` with a dense record on every row,
    (R, 2n, m), as if no vehicle crossed a section boundary; and the rows where one did
    (to be done again serially)."""
    R = x.shape[0]
    n = plant.train.n_vehicles
    h = dt / steps
    quadratic = plant._quadratic
    base = u - plant._forces[0]
    track = plant._track_arrays
    resist: Array | None = None
    crossed = np.zeros(R, dtype=bool)
    now: NDArray[np.intp] | None = None
    if track is not None and track[0].size == 1:
        base = base - plant.train.mass * track[1][0]
    elif track is not None:
        now = _sections(plant, x, x[:, 2 * n - 1], track[0])
        resist = plant.train.mass * track[1][now]
    z = np.empty((R, 3 * n - 1))
    z[:, : 2 * n - 1] = x[:, : 2 * n - 1]
    s = x[:, 2 * n - 1].copy()
    half, full = plant._drag_steps(h)
    vbar = _grid(z[:, 0]) if quadratic else np.zeros(R)
    force = base + plant._forces[1] * (vbar**2)[:, None] if quadratic else base
    z[:, 2 * n - 1 :] = force if resist is None else force - resist
    if quadratic:
        _drag(z, n, half, vbar)
    marks = set(dense_indices(steps, every).tolist())
    m = len(marks)
    rec = np.empty((R, m, 2 * n))
    merged_v = np.empty((R, m))
    merged = np.zeros(m, dtype=bool)
    col = 0
    for j in range(steps + 1):
        if j in marks:
            rec[:, col, : 2 * n - 1] = z[:, : 2 * n - 1]
            rec[:, col, 2 * n - 1] = s
            if quadratic and j < steps:
                merged[col] = True
                merged_v[:, col] = vbar
            col += 1
        if j == steps:
            break
        new = _linear_step(plant, h, vbar, z)
        s = s + new[:, 2 * n - 1]
        z[:, : 2 * n - 1] = new[:, : 2 * n - 1]
        if now is not None and track is not None:
            crossed |= (_sections(plant, z, s, track[0]) != now).any(axis=1)
        if not quadratic:
            continue
        if j == steps - 1:
            _drag(z, n, half, vbar)
            continue
        nbar = _grid(z[:, 0])
        moved = nbar != vbar
        if not moved.any():
            _drag(z, n, full, vbar)
            continue
        same = ~moved
        if same.any():
            zs = z[same]
            _drag(zs, n, full, vbar[same])
            z[same] = zs
        zm = z[moved]
        _drag(zm, n, half, vbar[moved])
        vbar = np.where(moved, nbar, vbar)
        vm = vbar[moved]
        fm = base[moved] + plant._forces[1] * (vm**2)[:, None]
        force = force.copy()
        force[moved] = fm
        zm[:, 2 * n - 1 :] = fm if resist is None else fm - resist[moved]
        _drag(zm, n, half, vm)
        z[moved] = zm
    if quadratic and merged.any():
        undo = -half
        cols = np.flatnonzero(merged)
        vb = merged_v[:, cols][:, :, None]
        w = rec[:, cols, :n] - vb
        rec[:, cols, :n] = vb + w / (1.0 + undo * w)
    rec[:, -1, : 2 * n - 1] = z[:, : 2 * n - 1]
    rec[:, -1, 2 * n - 1] = s
    return rec.transpose(0, 2, 1), crossed


def _linear_step(plant: Plant, h: float, vbar: Array, z: Array) -> Array:
    """Each row's ``propagator(plant, h, vbar[r]).step @ z[r]`` (stacked gemv)."""
    first = float(vbar[0])
    if (vbar == first).all():  # one grid speed (the usual case): the step broadcast
        step = propagator(plant, h, first).step
        stacked = np.broadcast_to(step, (z.shape[0], *step.shape))
    else:
        values, index = np.unique(vbar, return_inverse=True)
        steps = np.stack([propagator(plant, h, float(v)).step for v in values.tolist()])
        stacked = steps[index.ravel()]
    out: Array = np.matmul(stacked, z[:, :, None])[:, :, 0]
    return out
