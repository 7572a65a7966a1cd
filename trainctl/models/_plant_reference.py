# The plant's reference integrator: solve_ivp on the nonlinear model (private to models.plant).
"""Reference integration of the plant with ``scipy.integrate.solve_ivp``.

:meth:`trainctl.models.Plant.advance_reference` integrates
:func:`~trainctl.models.train_rhs` with the inputs held, restarting at every
section crossing (located as a terminal event) so that the right-hand side is
smooth on each piece. Slow; for tests and cross-checks of the splitting.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from trainctl.exceptions import SolverError
from trainctl.models.dynamics import train_rhs, vehicle_positions
from trainctl.models.train import Train

if TYPE_CHECKING:
    from trainctl.models._plant_propagators import TrackArrays
    from trainctl.models.plant import Plant

__all__ = ["advance_reference"]


def advance_reference(
    plant: Plant,
    x: NDArray[np.float64],
    u: NDArray[np.float64],
    dt: float,
    rtol: float,
    atol: float | ArrayLike | None,
    method: str,
) -> NDArray[np.float64]:
    """The state after ``dt`` [s] from the checked ``x`` and ``u`` (see the Plant method)."""
    train = plant.train
    n = train.n_vehicles
    if atol is None:
        scale = np.r_[np.ones(n), np.full(n - 1, 1e-5), 1.0]
        atol = rtol * scale
    track = plant._track_arrays
    t = 0.0
    for _ in range(10 * n * (1 if track is None else track[0].size) + 10):
        if track is None:
            frozen = np.zeros(n)
            events = None
        else:
            lo, hi, frozen = _section_bounds(train, x, track)
            events = _leave_event(train, lo, hi)
        sol = solve_ivp(
            _frozen_rhs(train, u, frozen), (t, dt), x, method=method, rtol=rtol,
            atol=atol, events=events,
        )
        if sol.status == -1:
            raise SolverError(
                f"Plant.advance_reference: solve_ivp failed at t={sol.t[-1]!r} s "
                f"({sol.message}). Loosen rtol/atol or try method='Radau'."
            )
        if sol.status == 1:
            t = float(sol.t_events[0][-1])
            x = np.asarray(sol.y_events[0][-1], dtype=float)
            continue
        return np.asarray(sol.y[:, -1], dtype=float)
    raise SolverError(
        "Plant.advance_reference: too many section crossings within one interval "
        f"(dt={dt!r} s). Check the track sections."
    )


def _frozen_rhs(
    train: Train, u: NDArray[np.float64], frozen: NDArray[np.float64]
) -> Callable[[float, NDArray[np.float64]], NDArray[np.float64]]:
    n = train.n_vehicles

    def rhs(t: float, x: NDArray[np.float64]) -> NDArray[np.float64]:
        dx = train_rhs(train, x, u)
        dx[:n] -= frozen
        return dx

    return rhs


def _section_bounds(
    train: Train, x: NDArray[np.float64], track: TrackArrays
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per vehicle: the bounds to watch in its current section, and its resistance per mass.

    A vehicle within 1e-6 m of a boundary is put on the side it is moving to,
    and that boundary is not watched (-inf/inf), so that an integration
    restarted at a located crossing moves on.
    """
    starts, per_mass = track[0], track[1]
    n = train.n_vehicles
    p = vehicle_positions(train, x)
    v = x[:n]
    sec = np.clip(np.searchsorted(starts, p, side="right") - 1, 0, starts.size - 1)
    near = np.clip(np.searchsorted(starts, p), 0, starts.size - 1)
    for i in range(n):
        for j in (near[i] - 1, near[i]):
            if 1 <= j < starts.size and abs(p[i] - starts[j]) <= 1e-6:
                sec[i] = j if v[i] > 0 else j - 1
    bounds = np.r_[-math.inf, starts[1:], math.inf]
    lo, hi = bounds[sec], bounds[sec + 1]
    # A vehicle just past a bound and moving away from it cannot be watched for it:
    # the event function would start at zero and the root finder stick there.
    lo = np.where((p - lo <= 1e-6) & (v > 0), -math.inf, lo)
    hi = np.where((hi - p <= 1e-6) & (v < 0), math.inf, hi)
    return lo, hi, per_mass[sec]


def _leave_event(
    train: Train, lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> Callable[[float, NDArray[np.float64]], float]:
    finite_lo, finite_hi = np.isfinite(lo), np.isfinite(hi)

    def event(t: float, x: NDArray[np.float64]) -> float:
        p = vehicle_positions(train, x)
        gaps = np.r_[(p - lo)[finite_lo], (hi - p)[finite_hi]]
        return float(gaps.min()) if gaps.size else 1.0

    event.terminal = True  # type: ignore[attr-defined]
    event.direction = -1  # type: ignore[attr-defined]
    return event
