# The substep loop of the plant's splitting integrator, and its dense output (private).
"""The substeps of :meth:`trainctl.models.Plant.advance` and the states between them.

:func:`integrate` runs the Strang splitting of :mod:`trainctl.models.plant`
over ``steps`` substeps. With a :class:`DenseRecord` it also stores the state
at substep boundaries. Adjacent half steps of the drag flow are merged. Inside
the interval, the state at a boundary is therefore the state after the merged
step with the second half step undone: the exact drag flow backwards over
h/2 about the grid speed it was taken with. That is the splitting's own state
at the boundary, to rounding. The recording works on a copy, so the
integration is the same with and without it, bit for bit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ._plant_propagators import drag_flow, grid_speed, propagator

if TYPE_CHECKING:
    from ._plant_crossings import SectionTracker
    from .plant import Plant

__all__ = ["DenseRecord", "dense_indices", "integrate"]

Array = NDArray[np.float64]


def dense_indices(steps: int, every: int) -> NDArray[np.int64]:
    """Substep boundaries 1..steps recorded with a stride: every ``every``-th and the last.

    Examples
    --------
    >>> dense_indices(10, 4).tolist(), dense_indices(3, 1).tolist(), dense_indices(2, 5).tolist()
    ([4, 8, 10], [1, 2, 3], [2])
    """
    every = max(1, int(every))
    marks = np.arange(every, steps, every, dtype=np.int64)
    return np.append(marks, np.int64(steps))


class DenseRecord:
    """States ``[v, delta, s]`` at chosen substep boundaries of one interval.

    Parameters
    ----------
    n : int
        Number of vehicles.
    steps : int
        Substeps of the interval.
    every : int
        Record every ``every``-th boundary, and always the last (the end of
        the interval).
    """

    def __init__(self, n: int, steps: int, every: int) -> None:
        self.n = n
        self.index = dense_indices(steps, every)
        self.rows: Array = np.empty((self.index.size, 2 * n))
        """One recorded state per row (``rows.T`` is signal x time)."""
        self._wanted = set(self.index.tolist())
        self._column = 0

    def take(self, j: int, z: Array, s: float, undo: Array | None, vbar: float) -> None:
        """Store boundary j from z = [v, delta, F] and s when it is wanted.

        ``undo`` (-h/2·a2 per vehicle) undoes the merged second half of the
        drag flow about ``vbar``; None when z holds the boundary state itself.
        """
        if j not in self._wanted:
            return
        n = self.n
        column = self.rows[self._column]
        column[: 2 * n - 1] = z[: 2 * n - 1]
        if undo is not None:
            drag_flow(column, n, undo, vbar)
        column[2 * n - 1] = s
        self._column += 1


def integrate(
    plant: Plant,
    z: Array,
    s: float,
    base: Array,
    h: float,
    steps: int,
    tracker: SectionTracker | None,
    record: DenseRecord | None = None,
) -> float:
    """``steps`` substeps of length h on z = [v, delta, F] (in place); returns s.

    ``base`` [N] is the held input less the constant Davis term (and a
    uniform grade); ``tracker`` follows the track sections (None: flat);
    ``record`` stores the states at substep boundaries (None: none).
    """
    n = plant.train.n_vehicles
    quadratic = plant._quadratic
    half, full = plant._drag_steps(h)
    undo = -half if quadratic and record is not None else None
    vbar = grid_speed(z[0]) if quadratic else 0.0
    prop = propagator(plant, h, vbar)
    force = base + plant._forces[1] * vbar**2 if quadratic else base
    z[2 * n - 1 :] = force
    if quadratic:
        drag_flow(z, n, half, vbar)
    for j in range(steps + 1):
        if tracker is not None:
            s = tracker.visit(z, s, force, vbar, h, j == steps)
        if record is not None and j:
            record.take(j, z, s, None if j == steps else undo, vbar)
        if j == steps:
            break
        new = prop.step @ z
        s += new[2 * n - 1]
        z[: 2 * n - 1] = new[: 2 * n - 1]
        if not quadratic:
            continue
        if j == steps - 1:
            drag_flow(z, n, half, vbar)
            continue
        nbar = grid_speed(z[0])
        if nbar == vbar:
            drag_flow(z, n, full, vbar)
            continue
        drag_flow(z, n, half, vbar)
        vbar = nbar
        prop = propagator(plant, h, vbar)
        force = base + plant._forces[1] * vbar**2
        z[2 * n - 1 :] = force if tracker is None else force - tracker.resist
        drag_flow(z, n, half, vbar)
    return s
