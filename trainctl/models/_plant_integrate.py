# The substep loop of the plant's splitting integrator, and its dense output (private).
"""The substeps of :meth:`trainctl.models.Plant.advance` and the states between them.

:func:`integrate` runs the Strang splitting of :mod:`trainctl.models.plant`
over ``steps`` substeps. With a :class:`DenseRecord` it also stores states
between the samples, on a copy, so that the integration is the same with and
without recording, bit for bit:

- at substep boundaries (every ``every``-th): adjacent half steps of the drag
  flow are merged, so the state at a boundary inside the interval is the
  state after the merged step with its second half undone (the exact drag
  flow backwards over h/2 about the grid speed it was taken with) — the
  splitting's own state there, to rounding;
- inside each substep (``inner`` > 1 points per substep): the exact linear
  flow of the substep over h/inner, 2h/inner, ... (a cached propagator)
  from the substep's start, with the weak drag remainder applied at the
  start only; a section crossing inside the substep adds its exact effect
  Γ(t - τ) e_i ΔF to the points after it (as :mod:`._plant_crossings` does
  at the substep's end). For CRH2 these points agree with ``solve_ivp`` to
  about 1e-7 m/s and 0.01 N.
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ._plant_crossings import linear_flow
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
    """States ``[v, delta, s]`` at chosen points of one interval of ``steps`` substeps.

    Parameters
    ----------
    n : int
        Number of vehicles.
    steps : int
        Substeps of the interval.
    every : int
        Record every ``every``-th substep boundary, and always the last (the
        end of the interval).
    inner : int
        Points per substep (>= 1): with ``inner`` > 1 (then ``every`` = 1)
        also the inner - 1 points that split each substep evenly.

    """

    def __init__(self, n: int, steps: int, every: int = 1, inner: int = 1) -> None:
        self.n, self.steps, self.every, self.inner = n, steps, max(1, int(every)), max(1, int(inner))
        self._column = 0
        self._merged: list[tuple[int, float]] = []

    @cached_property
    def rows(self) -> Array:
        """One recorded state per row (``rows.T`` is signal x time)."""
        # dense_indices(steps, every) has (steps - 1) // every + 1 entries
        size = self.steps * self.inner if self.inner > 1 else (self.steps - 1) // self.every + 1
        return np.empty((size, 2 * self.n))

    @property
    def offsets(self) -> Array:
        """The recorded points, in substeps from the start (boundary j is j)."""
        if self.inner > 1:
            return np.arange(1, self.steps * self.inner + 1) / self.inner
        return dense_indices(self.steps, self.every).astype(np.float64)

    def take(self, j: int, z: Array, s: float, merged: bool, vbar: float) -> None:
        """Store boundary j from z = [v, delta, F] and s when it is wanted.

        ``merged``: z holds the merged second half of the drag flow about
        ``vbar``, which :meth:`finish` undoes.
        """
        if j != self.steps and self.inner == 1 and j % self.every:
            return
        n = self.n
        column = self.rows[self._column]
        column[: 2 * n - 1] = z[: 2 * n - 1]
        column[2 * n - 1] = s
        if merged:
            self._merged.append((self._column, vbar))
        self._column += 1

    def cross_inner(self, plant: Plant, h: float, crossed: tuple[Array, Array, float]) -> None:
        """Add the section crossings of the last substep to its inner points.

        ``crossed`` = (τ, e_i ΔF columns, v̄) from the section tracker: a
        point at t > τ gets Γ(t - τ) e_i ΔF, as the substep's end got.
        """
        tau, jumps, vbar = crossed
        n, count = self.n, self.inner - 1
        first = self._column - count
        t = np.arange(1, count + 1) * (h / self.inner)
        late = np.maximum(t[:, None] - tau[None, :], 0.0).ravel()  # point x crossing
        forcing = np.tile(jumps, count)
        response = linear_flow(plant, h, vbar, np.zeros((2 * n, late.size)), forcing, late)
        self.rows[first : self._column] += response.reshape(2 * n, count, -1).sum(axis=2).T

    def finish(self, undo: Array | None) -> None:
        """Undo the merged half drag steps (``undo`` = -h/2·a2 per vehicle), all at once."""
        if undo is None or not self._merged:
            return
        n = self.n
        index, vbar = (np.array(x) for x in zip(*self._merged, strict=True))
        w = self.rows[index, :n] - vbar[:, None]
        self.rows[index, :n] = vbar[:, None] + w / (1.0 + undo * w)

    def take_inner(self, plant: Plant, z: Array, s: float, h: float, vbar: float) -> None:
        """Store the inner - 1 points inside the substep that starts from z and s."""
        n, count = self.n, self.inner - 1
        key = (h, vbar, self.inner)
        flows = plant._inner_flows.get(key)
        if flows is None:
            if len(plant._inner_flows) >= 8:
                plant._inner_flows.clear()
            flows = plant._inner_flows[key] = _powers(
                propagator(plant, h / self.inner, vbar).step, n, count)
        points = (flows @ z).reshape(count, 2 * n)
        rows = self.rows[self._column : self._column + count]
        rows[:, : 2 * n - 1] = points[:, : 2 * n - 1]
        rows[:, 2 * n - 1] = s + points[:, 2 * n - 1]
        self._column += count


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
            if record is not None and record.inner > 1 and tracker.crossed is not None:
                record.cross_inner(plant, h, tracker.crossed)
        if record is not None and j:
            record.take(j, z, s, quadratic and j < steps, vbar)
        if j == steps:
            break
        if record is not None and record.inner > 1:
            record.take_inner(plant, z, s, h, vbar)
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
    if record is not None:
        record.finish(undo)
    return s


def _powers(step: Array, n: int, count: int) -> Array:
    """The flows over 1..count steps stacked, from one step's [Φ | Γ] on [v, delta, F].

    ``step`` maps y = [v, delta, F] to [v', delta', Δs] (F held); the flow
    over i steps is M^i on y, M = [[step without its Δs row], [0, I]], and
    its Δs row is Σ_{m<i} (Δs row) M^m.
    """
    size = 3 * n - 1
    M = np.zeros((size, size))
    M[: 2 * n - 1] = step[: 2 * n - 1]
    M[2 * n - 1 :, 2 * n - 1 :] = np.eye(n)
    power, ds = np.eye(size), np.zeros(size)
    blocks = []
    for _ in range(count):
        ds = ds + step[2 * n - 1] @ power
        power = M @ power
        blocks.append(np.vstack([power[: 2 * n - 1], ds]))
    return np.vstack(blocks)
