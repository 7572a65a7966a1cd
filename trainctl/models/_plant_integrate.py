# The substep loop of the plant's splitting integrator, and its dense output (private).
"""The substeps of :meth:`trainctl.models.Plant.advance`.

:func:`integrate` runs the Strang splitting of :mod:`trainctl.models.plant`
over ``steps`` substeps; with a :class:`~trainctl.models._plant_dense.DenseRecord`
it also stores the states between the start and the end
(:mod:`trainctl.models._plant_dense`), on copies, so that the integration is
the same with and without recording, bit for bit.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl.models._plant_propagators import drag_flow, grid_speed, propagator

if TYPE_CHECKING:
    from trainctl.models._plant_crossings import SectionTracker
    from trainctl.models._plant_dense import DenseRecord
    from trainctl.models.plant import Plant

__all__ = ["integrate"]

Array = NDArray[np.float64]


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
    # Banded path: Γ F once per value of F (prop.split), recomputed when v̄ changes
    # (g = None) or the tracker writes new forces (its count of writes moved on).
    g: Array | None = None
    forced = 0
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
        split = prop.split
        if split is None:
            new = prop.apply(z)
        else:
            writes = 0 if tracker is None else tracker.writes
            if g is None or writes != forced:
                g, forced = split.forcing(z[2 * n - 1 :]), writes
            new = g.copy()
            split.state(z, new)
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
        g = None
        force = base + plant._forces[1] * vbar**2
        z[2 * n - 1 :] = force if tracker is None else force - tracker.resist
        drag_flow(z, n, half, vbar)
    if record is not None:
        record.finish(undo)
    return s
