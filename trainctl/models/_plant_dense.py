# The plant's dense output: states between the samples (a mixin of Plant's methods).
"""States of :class:`trainctl.models.Plant` between the start and the end of an interval.

:class:`DenseOutput` holds the methods :class:`~trainctl.models.Plant` offers
for the between-sample truth of a simulation (:meth:`~DenseOutput.advance_dense`,
:meth:`~DenseOutput.dense_offsets`, :attr:`~DenseOutput.fastest_rate`);
:class:`DenseRecord` collects the states while
:func:`trainctl.models._plant_integrate.integrate` runs the substeps:

- at substep boundaries (every ``every``-th): adjacent half steps of the drag
  flow are merged, so the state at a boundary inside the interval is the
  state after the merged step with its second half undone (the exact drag
  flow backwards over h/2 about the grid speed it was taken with) — the
  splitting's own state there, to rounding;
- inside each substep (``inner`` > 1 points per substep): the exact linear
  flow of the substep over h/inner, 2h/inner, ... from the substep's start,
  with the weak drag remainder applied at the start only; a section crossing
  inside the substep adds its exact effect Γ(t - τ) e_i ΔF to the points
  after it, as :mod:`trainctl.models._plant_crossings` does at the substep's
  end. For CRH2 these points agree with ``solve_ivp`` to about 1e-7 m/s and
  0.01 N.

The recording works on copies: the integration is the same with and without
it, bit for bit.
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_positive
from trainctl.exceptions import ModelError
from trainctl.models._plant_crossings import linear_flow
from trainctl.models._plant_propagators import propagator

if TYPE_CHECKING:
    from trainctl.models.plant import Plant
    from trainctl.models.train import Train

__all__ = ["DenseOutput", "DenseRecord", "dense_indices"]

Array = NDArray[np.float64]


class DenseOutput:
    """:class:`~trainctl.models.Plant`'s methods for the states between the samples."""

    if TYPE_CHECKING:
        train: Train
        _offsets: dict[tuple[float, int, int], Array]

        @property
        def _linear(self) -> tuple[Array, Array]: ...

        def _check(self, where: str, state: ArrayLike, inputs: ArrayLike,
                   dt: float) -> tuple[Array, Array, float]: ...

        def _substeps(self, dt: float) -> int: ...

        def _advance(self, x: Array, u: Array, dt: float,
                     record: DenseRecord | None) -> Array: ...

    @cached_property
    def fastest_rate(self) -> float:
        """Largest |eigenvalue| of the linear part at rest [rad/s]: the fastest coupler mode.

        Examples
        --------
        >>> from trainctl.models import Plant, crh2_half
        >>> round(Plant(train=crh2_half()).fastest_rate, 2)
        27.77
        """
        eigenvalues = np.linalg.eigvals(self._linear[0])
        return float(np.abs(eigenvalues).max()) if eigenvalues.size else 0.0

    def advance_dense(
        self, state: ArrayLike, inputs: ArrayLike, dt: float, every: int = 1, inner: int = 1
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`advance`, returning the states between the start and the end as well.

        Parameters
        ----------
        state : array_like
            ``[v (n) [m/s], delta (n-1) [m], s [m]]``.
        inputs : array_like
            Force per vehicle [N], held over ``dt``.
        dt : float
            Interval [s], > 0.
        every : int
            Keep every ``every``-th substep boundary (>= 1) and always the
            last one, the end of the interval.
        inner : int
            Points per substep (>= 1); > 1 (with ``every`` = 1) also keeps
            the points that split each substep evenly, on its exact linear
            flow (:mod:`trainctl.models._plant_dense`).

        Returns
        -------
        offsets : ndarray
            Times of the kept points after the start [s], shape (m,); the
            last is ``dt``.
        states : ndarray
            The states there, shape (2n, m). The last column is exactly what
            :meth:`advance` returns; the integration is the same bit for bit.

        Examples
        --------
        >>> import numpy as np
        >>> from trainctl.models import Plant, crh2_half
        >>> plant = Plant(train=crh2_half())
        >>> x0 = np.r_[np.full(4, 50.0), 1e-4, 0.0, 0.0, 0.0]
        >>> offsets, states = plant.advance_dense(x0, np.zeros(4), 1.0, every=5)
        >>> offsets.tolist(), states.shape
        ([0.25, 0.5, 0.75, 1.0], (8, 4))
        >>> bool(np.array_equal(states[:, -1], plant.advance(x0, np.zeros(4), 1.0)))
        True
        """
        x, u, dt = self._check("Plant.advance_dense", state, inputs, dt)
        for name, value in (("every", every), ("inner", inner)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ModelError(
                    f"Plant.advance_dense: {name!r} must be an int >= 1 (got {value!r}).")
        if inner > 1 and every != 1:
            raise ModelError(f"Plant.advance_dense: 'every' must be 1 with inner = {inner} > 1 "
                             f"(got every={every!r}).")
        steps = self._substeps(dt)
        record = DenseRecord(self.train.n_vehicles, steps, int(every), int(inner))
        end = self._advance(x, u, dt, record)
        record.rows[-1] = end
        return self.dense_offsets(dt, every, inner), record.rows.T.copy()

    def dense_offsets(self, dt: float, every: int = 1, inner: int = 1) -> NDArray[np.float64]:
        """Times after the start [s] of the states :meth:`advance_dense` returns.

        Parameters
        ----------
        dt : float
            Interval [s], > 0.
        every, inner : int
            As in :meth:`advance_dense`.

        Returns
        -------
        ndarray
            Increasing offsets in (0, dt], the last exactly ``dt``.

        Examples
        --------
        >>> from trainctl.models import Plant, crh2_half
        >>> Plant(train=crh2_half()).dense_offsets(0.1, inner=2).tolist()
        [0.025, 0.05, 0.07500000000000001, 0.1]
        """
        key = (dt, every, inner)
        offsets = self._offsets.get(key)
        if offsets is None:
            steps = self._substeps(check_positive("Plant.dense_offsets", "dt", dt))
            offsets = DenseRecord(self.train.n_vehicles, steps, every, inner).offsets
            offsets *= dt / steps
            offsets[-1] = dt
            if len(self._offsets) >= 8:
                self._offsets.clear()
            self._offsets[key] = offsets
        return offsets.copy()


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
        self.n, self.steps = n, steps
        self.every, self.inner = max(1, int(every)), max(1, int(inner))
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
            step = propagator(plant, h / self.inner, vbar).step
            if not isinstance(step, np.ndarray):  # banded: the powers fill in anyway
                step = step.toarray()
            flows = plant._inner_flows[key] = _powers(step, n, count)
        points = (flows @ z).reshape(count, 2 * n)
        rows = self.rows[self._column : self._column + count]
        rows[:, : 2 * n - 1] = points[:, : 2 * n - 1]
        rows[:, 2 * n - 1] = s + points[:, 2 * n - 1]
        self._column += count


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
