# Plots of simulation results (matplotlib Figure API, never pyplot).
"""Plots of a :class:`trainctl.sim.SimulationResult`.

Each function draws into ``ax`` or, when ``ax`` is None, into a new
``matplotlib.figure.Figure`` (not pyplot: nothing is registered with a GUI
backend and nothing is shown), and returns the Axes. Forces are shown in kN,
speeds in m/s, time in s.

Examples
--------
>>> import numpy as np
>>> from trainctl.sim import SimulationResult
>>> result = SimulationResult(
...     time=np.array([0.0, 1.0]), states=np.array([[10.0, 10.5], [0.0, 10.2]]),
...     velocities=np.array([[10.0, 10.5]]), coupler_forces=np.zeros((0, 2)),
...     inputs=np.array([[500.0]]), reference_speed=np.array([10.0, 10.0]),
...     reference_acceleration=np.zeros(2), statuses=("optimal",),
...     iterations=np.array([3]), residuals=((1.0, 0.1, 0.01),),
...     solve_times=np.array([1e-3]), fallbacks=("",), controller_name="demo",
...     seed=0, dt=1.0)
>>> velocity_plot(result).get_ylabel()
'speed [m/s]'
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from .sim.results import SimulationResult

__all__ = ["coupler_force_plot", "input_plot", "iterations_plot", "velocity_plot"]

_LEGEND_MAX = 10
"""Show a legend only for at most this many traces."""


def _axes(ax: Axes | None) -> Axes:
    if ax is not None:
        return ax
    figure = Figure(figsize=(7.0, 3.5), layout="constrained")
    return figure.add_subplot()


def _legend(ax: Axes, count: int) -> None:
    if count <= _LEGEND_MAX:
        ax.legend(loc="best", fontsize="small")


def _bounds(ax: Axes, bounds: tuple[float, float] | None) -> None:
    """Dashed horizontal lines at the bounds given in N (drawn in kN)."""
    if bounds is None:
        return
    for value in bounds:
        if value is not None and np.isfinite(value):
            ax.axhline(value / 1e3, color="0.3", linestyle="--", linewidth=1.0)


def velocity_plot(result: SimulationResult, *, ax: Axes | None = None) -> Axes:
    """Vehicle speeds and the reference speed against time.

    Parameters
    ----------
    result : SimulationResult
        The run.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes, labelled ``time [s]`` and ``speed [m/s]``.
    """
    ax = _axes(ax)
    n = result.n_vehicles
    for i in range(n):
        ax.plot(result.time, result.velocities[i], linewidth=1.0, label=f"vehicle {i + 1}")
    ax.plot(result.time, result.reference_speed, "k--", linewidth=1.0, label="reference")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("speed [m/s]")
    ax.set_title(f"Speeds — {result.controller_name}")
    _legend(ax, n + 1)
    return ax


def coupler_force_plot(
    result: SimulationResult,
    *,
    bounds: tuple[float, float] | None = None,
    ax: Axes | None = None,
) -> Axes:
    """Coupler forces (tension positive) against time, in kN.

    Parameters
    ----------
    result : SimulationResult
        The run.
    bounds : (float, float) or None
        Lower and upper coupler-force limits [N], drawn as dashed lines.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes, labelled ``time [s]`` and ``coupler force [kN]``.
    """
    ax = _axes(ax)
    count = result.coupler_forces.shape[0]
    for i in range(count):
        ax.plot(result.time, result.coupler_forces[i] / 1e3, linewidth=1.0,
                label=f"coupler {i + 1}–{i + 2}")
    _bounds(ax, bounds)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("coupler force [kN]")
    ax.set_title(f"Coupler forces — {result.controller_name}")
    if count:
        _legend(ax, count)
    return ax


def input_plot(
    result: SimulationResult,
    *,
    bounds: tuple[float, float] | None = None,
    ax: Axes | None = None,
) -> Axes:
    """Traction/braking forces, held over each sample interval, in kN.

    Parameters
    ----------
    result : SimulationResult
        The run.
    bounds : (float, float) or None
        Lower (braking) and upper (traction) limits [N], drawn as dashed lines.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes, labelled ``time [s]`` and ``force [kN]``.
    """
    ax = _axes(ax)
    n = result.n_vehicles
    if result.n_samples:
        for i in range(n):
            held = np.append(result.inputs[i], result.inputs[i, -1]) / 1e3
            ax.step(result.time, held, where="post", linewidth=1.0, label=f"vehicle {i + 1}")
    _bounds(ax, bounds)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("force [kN]")
    ax.set_title(f"Inputs — {result.controller_name}")
    _legend(ax, n)
    return ax


def iterations_plot(result: SimulationResult, *, ax: Axes | None = None) -> Axes:
    """Iterations per sample; samples whose status is not optimal are marked.

    Parameters
    ----------
    result : SimulationResult
        The run.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes, labelled ``time [s]`` and ``iterations [-]``.
    """
    ax = _axes(ax)
    t = result.time[:-1]
    ax.step(t, result.iterations, where="post", linewidth=1.0, label="iterations")
    flagged = np.array([s != "optimal" for s in result.statuses], dtype=bool)
    if np.any(flagged):
        ax.plot(t[flagged], result.iterations[flagged], "rx", label="not optimal")
        ax.legend(loc="best", fontsize="small")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("iterations [-]")
    ax.set_title(f"Iterations — {result.controller_name}")
    return ax
