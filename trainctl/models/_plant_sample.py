# One sample of the plant in one substep, with preallocated buffers (the closed loop's path).
"""The plant over one held-input sample when the sample is one substep (private).

A closed loop at T <= ``max_substep`` (CRH2 at T = 0.05 s: 24 000 samples a
run) advances the plant by one substep per sample, and
:meth:`trainctl.models.Plant.advance_dense` spends most of its time building
what does not change: checks, a :class:`~trainctl.models._plant_dense.DenseRecord`,
a section tracker, cache lookups, copies. :class:`SampleMap` keeps all of it
from sample to sample and writes the states straight into the loop's arrays.
The arithmetic is that of :func:`trainctl.models._plant_integrate.integrate`
with one substep, operation for operation (the same ufuncs on the same
operands, so the same result bit for bit): the half drag flow, the exact
linear step [Φ | Γ] (the precomputed matrix exponential of the sample, per
grid speed v̄), the half drag flow, and the inner dense points as one
product with the stacked flows.

Boundaries: on a track with sections the map takes the sections and their
line resistance at the sample's start, as the tracker does, and checks at the
end, with the tracker's own bound on the motion, whether any vehicle can
have reached a section boundary (a grade or curve change) within the sample.
When it can, the sample is done again from its start by the exact
integrator (which locates the crossing and adds its effect), so the result
is the integrator's in every case. The inputs are held over the sample
(saturation is applied at its start), so no other boundary falls inside.
Not handled here (``Plant.sample_map`` returns None): several substeps per
sample (the grid speed may change between them), and banded propagators.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl.models._plant_crossings import SectionTracker, sections
from trainctl.models._plant_dense import DenseRecord
from trainctl.models._plant_propagators import drag_flow, grid_speed, propagator

if TYPE_CHECKING:
    from trainctl.models.plant import Plant

__all__ = ["SampleMap"]

Array = NDArray[np.float64]


class SampleMap:
    """The plant over samples of ``dt`` [s] = one substep, recorded on the dense grid.

    ``inner`` points per sample (>= 1; the last one is the sample's end).
    :attr:`fallbacks` counts the samples done by the exact integrator.
    """

    def __init__(self, plant: Plant, dt: float, inner: int) -> None:
        n = plant.train.n_vehicles
        self.plant, self.dt, self.n, self.inner = plant, dt, n, int(inner)
        self.quadratic = plant._quadratic
        self.half = plant._drag_steps(dt)[0]
        self.davis0, self.drag2 = plant._forces
        track = plant._track_arrays
        self.grade: Array | None = None
        self.track = track
        if track is not None and track[0].size == 1:  # uniform grade: constant force
            self.grade, self.track = plant.train.mass * track[1][0], None
        self.z = np.empty(3 * n - 1)
        self.new = np.empty(2 * n)
        self.base = np.empty(n)
        self._steps: dict[float, tuple[Array, Array | None, Array]] = {}
        self.fallbacks = 0
        """Samples handed to the exact integrator (a possible section crossing)."""

    def _at(self, vbar: float) -> tuple[Array, Array | None, Array]:
        """[Φ | Γ], the stacked inner flows and m·a2·v̄² for grid speed ``vbar``."""
        cached = self._steps.get(vbar)
        if cached is None:
            plant, dt = self.plant, self.dt
            step = propagator(plant, dt, vbar).step
            flows = None
            if self.inner > 1:  # the same stacked flows DenseRecord.take_inner uses
                record = DenseRecord(self.n, 1, 1, self.inner)
                record.take_inner(plant, np.zeros(3 * self.n - 1), 0.0, dt, vbar)
                flows = plant._inner_flows[(dt, vbar, self.inner)]
            if len(self._steps) >= 16:
                self._steps.clear()
            cached = self._steps[vbar] = (step, flows, self.drag2 * vbar**2)
        return cached

    def advance(self, x: Array, u: Array, block: Array) -> None:
        """Advance ``x`` holding ``u`` over one sample into ``block`` (2n, inner): the
        dense points, the last column the state at the sample's end. ``x`` and ``u``
        must be finite (the loop checks them)."""
        n, z, base = self.n, self.z, self.base
        np.subtract(u, self.davis0, out=base)
        if self.grade is not None:
            np.subtract(base, self.grade, out=base)
        z[: 2 * n - 1] = x[: 2 * n - 1]
        s = float(x[2 * n - 1])
        quadratic = self.quadratic
        vbar = grid_speed(z[0]) if quadratic else 0.0
        step, flows, drag = self._at(vbar)
        if quadratic:
            z[2 * n - 1 :] = base + drag
            drag_flow(z, n, self.half, vbar)
        else:
            z[2 * n - 1 :] = base
        budget = None
        if self.track is not None:
            budget = self._sections(z, s)
        if flows is not None:
            count = self.inner - 1
            points = (flows @ z).reshape(count, 2 * n)
            block[: 2 * n - 1, :count] = points[:, : 2 * n - 1].T
            block[2 * n - 1, :count] = s + points[:, 2 * n - 1]
        new = step @ z
        s += new[2 * n - 1]
        z[: 2 * n - 1] = new[: 2 * n - 1]
        if quadratic:
            drag_flow(z, n, self.half, vbar)
        if budget is not None and self._may_cross(z, s, budget):
            self.fallbacks += 1
            _, states = self.plant.advance_dense(x, u, self.dt, 1, self.inner)
            block[:] = states
            return
        end = block[:, -1]
        end[: 2 * n - 1] = z[: 2 * n - 1]
        end[2 * n - 1] = s

    def _sections(self, z: Array, s: float) -> tuple[float, float, float, Array]:
        """The sections' line resistance into z's forces, as the tracker's first visit
        does; returns its budget (s, ahead, behind, elongations at the start)."""
        n, track = self.n, self.track
        assert track is not None
        p0, now = sections(self.plant.train, z, s, track)
        lo, hi = track[2][now], track[3][now]
        slack = SectionTracker.SLACK
        ahead = max(float((hi - p0).min()) - 0.0 - slack, 0.0)
        behind = max(float((p0 - lo).min()) - 0.0 - slack, 0.0)
        resist = self.plant.train.mass * track[1][now]
        z[2 * n - 1 :] = z[2 * n - 1 :] - resist
        return s, ahead, behind, z[n : 2 * n - 1].copy()

    def _may_cross(self, z: Array, s: float, budget: tuple[float, float, float, Array]) -> bool:
        """The tracker's test at the sample's end: could a vehicle have left its section?"""
        n = self.n
        s_ref, ahead, behind, d_ref = budget
        moved = s - s_ref
        spread = float(np.add.reduce(np.abs(z[n : 2 * n - 1] - d_ref)))
        return moved + spread >= ahead or spread - moved >= behind
