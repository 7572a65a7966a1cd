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

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from trainctl.plots._common import (
    LEGEND_MAX,
    legend_outside,
    limit_lines,
    line_style,
    mark_samples,
    new_axes,
    picked,
    plain_log_labels,
    thin,
    trace,
)

if TYPE_CHECKING:
    from trainctl.models.graphs import CommunicationGraph
    from trainctl.sim.results import SimulationResult

__all__ = [
    "convergence_plot",
    "coupler_force_plot",
    "eigenvalue_plot",
    "graph_plot",
    "input_plot",
    "iterations_plot",
    "speed_error_plot",
    "velocity_plot",
]

def _legend(ax: Axes, count: int) -> None:
    """A legend right of the axes (off the data), for at most ``LEGEND_MAX`` traces."""
    if count <= LEGEND_MAX:
        legend_outside(ax)


def velocity_plot(result: SimulationResult, *, ax: Axes | None = None) -> Axes:
    """Vehicle speeds and the reference speed against time.

    Between-sample (dense) speeds are drawn when the run recorded them, with
    the sample instants marked; otherwise the sampled speeds.

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

    Examples
    --------
    Two vehicles over two 1 s samples; one line per vehicle (each with its
    sample marks) and the dashed reference:

    >>> from trainctl.sim import SimulationResult
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 1.0, 2.0]),
    ...     states=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1],
    ...                      [0.0, 0.001, -0.0005], [0.0, 10.2, 20.5]]),
    ...     velocities=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1]]),
    ...     coupler_forces=np.array([[0.0, 2000.0, -1000.0]]),
    ...     inputs=np.array([[500.0, -300.0], [400.0, -200.0]]),
    ...     reference_speed=np.full(3, 10.0), reference_acceleration=np.zeros(3),
    ...     statuses=("optimal", "max_iterations"), iterations=np.array([3, 10]),
    ...     residuals=((1.0, 0.1), (2.0, 0.5)), solve_times=np.array([1e-3, 2e-3]),
    ...     fallbacks=("", ""), controller_name="demo", seed=0, dt=1.0)
    >>> ax = velocity_plot(result)
    >>> [line.get_label() for line in ax.lines if not line.get_label().startswith("_")]
    ['vehicle 1', 'vehicle 2', 'reference']
    >>> ax.lines[-1].get_ydata().tolist()  # reference [m/s]
    [10.0, 10.0, 10.0]
    """
    ax = new_axes(ax)
    n = result.n_vehicles
    t, speeds, dense = trace(result, "velocities")
    for i in range(n):
        (line,) = ax.plot(*thin(t, speeds[i]), linewidth=1.0, label=f"vehicle {i + 1}")
        if dense:
            mark_samples(ax, result.time, result.velocities[i], line.get_color())
    ax.plot(result.time, result.reference_speed, "k--", linewidth=1.0, label="reference")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("speed [m/s]")
    ax.set_title(f"Speeds — {result.controller_name}")
    _legend(ax, n + 1)
    return ax


def speed_error_plot(
    result: SimulationResult,
    *,
    settle_time: float | None = None,
    vehicle: int | None = None,
    color: Any = None,
    label: str | None = None,
    ax: Axes | None = None,
    **kwargs: Any,
) -> Axes:
    """Speed minus reference speed of every vehicle (or of one) against time.

    Between-sample (dense) errors are drawn when the run recorded them, with
    the sample instants marked; otherwise the sampled errors, marked when
    there are few samples.

    Parameters
    ----------
    result : SimulationResult
        The run.
    settle_time : float or None
        Marked with a dotted vertical line when given [s] (tracking metrics
        start there).
    vehicle : int or None
        Draw only this vehicle (0-based index; labelled from 1); None: all.
    color, label : optional
        Line colour and legend label (for comparing runs in one axes);
        default: matplotlib's cycle and ``"vehicle i"``.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.
    **kwargs
        Further line properties of the traces (e.g. ``linestyle``).

    Returns
    -------
    matplotlib.axes.Axes
        The axes, labelled ``time [s]`` and ``speed error [m/s]``.

    Examples
    --------
    The second vehicle (index 1) runs at 10, 10.4 and 10.1 m/s against a
    10 m/s reference, so its error is 0, 0.4 and 0.1 m/s:

    >>> from trainctl.sim import SimulationResult
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 1.0, 2.0]),
    ...     states=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1],
    ...                      [0.0, 0.001, -0.0005], [0.0, 10.2, 20.5]]),
    ...     velocities=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1]]),
    ...     coupler_forces=np.array([[0.0, 2000.0, -1000.0]]),
    ...     inputs=np.array([[500.0, -300.0], [400.0, -200.0]]),
    ...     reference_speed=np.full(3, 10.0), reference_acceleration=np.zeros(3),
    ...     statuses=("optimal", "max_iterations"), iterations=np.array([3, 10]),
    ...     residuals=((1.0, 0.1), (2.0, 0.5)), solve_times=np.array([1e-3, 2e-3]),
    ...     fallbacks=("", ""), controller_name="demo", seed=0, dt=1.0)
    >>> ax = speed_error_plot(result, vehicle=1, settle_time=1.0)
    >>> ax.lines[0].get_label(), np.round(ax.lines[0].get_ydata(), 3).tolist()  # m/s
    ('vehicle 2', [0.0, 0.4, 0.1])
    >>> ax.lines[-1].get_label()
    'settle time'
    """
    ax = new_axes(ax)
    t, speeds, dense = trace(result, "velocities")
    reference = getattr(result, "dense_reference_speed", None) if dense else None
    if reference is None:
        reference = np.interp(t, result.time, result.reference_speed)
    shown = picked(result.n_vehicles, vehicle)
    for i in shown:
        (line,) = ax.plot(*thin(t, speeds[i] - reference),
                          **line_style(color, label, f"vehicle {i + 1}", kwargs))
        mark_samples(ax, result.time, result.velocities[i] - result.reference_speed,
                     line.get_color())
    ax.axhline(0.0, color="0.6", linewidth=0.6, zorder=0)
    if settle_time is not None:
        ax.axvline(settle_time, color="0.3", linestyle=":", linewidth=1.0, label="settle time")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("speed error [m/s]")
    ax.set_title(f"Speed error — {result.controller_name}")
    if vehicle is None:
        _legend(ax, len(shown) + (settle_time is not None))
    return ax


def coupler_force_plot(
    result: SimulationResult,
    *,
    bounds: tuple[float, float] | None = None,
    coupler: int | None = None,
    color: Any = None,
    label: str | None = None,
    ax: Axes | None = None,
    **kwargs: Any,
) -> Axes:
    """Coupler forces (tension positive) against time, in kN.

    The axes are scaled to the forces; the limits are dashed lines when near
    them and named at the edge of the axes when far outside
    (:func:`trainctl.plots._common.limit_lines`). Between-sample (dense) forces
    are drawn when the run recorded them, with the samples marked.

    Parameters
    ----------
    result : SimulationResult
        The run.
    bounds : (float, float) or None
        Lower and upper coupler-force limits [N].
    coupler : int or None
        Draw only this coupler (0-based; coupler i joins vehicles i + 1 and
        i + 2 as labelled); None: all.
    color, label : optional
        Line colour and legend label (for comparing runs in one axes).
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.
    **kwargs
        Further line properties of the traces (e.g. ``linestyle``).

    Returns
    -------
    matplotlib.axes.Axes
        The axes, labelled ``time [s]`` and ``coupler force [kN]``.

    Examples
    --------
    One coupler at 0, 2000 and −1000 N (tension positive), drawn in kN:

    >>> from trainctl.sim import SimulationResult
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 1.0, 2.0]),
    ...     states=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1],
    ...                      [0.0, 0.001, -0.0005], [0.0, 10.2, 20.5]]),
    ...     velocities=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1]]),
    ...     coupler_forces=np.array([[0.0, 2000.0, -1000.0]]),
    ...     inputs=np.array([[500.0, -300.0], [400.0, -200.0]]),
    ...     reference_speed=np.full(3, 10.0), reference_acceleration=np.zeros(3),
    ...     statuses=("optimal", "max_iterations"), iterations=np.array([3, 10]),
    ...     residuals=((1.0, 0.1), (2.0, 0.5)), solve_times=np.array([1e-3, 2e-3]),
    ...     fallbacks=("", ""), controller_name="demo", seed=0, dt=1.0)
    >>> ax = coupler_force_plot(result)
    >>> ax.lines[0].get_label(), np.round(ax.lines[0].get_ydata(), 3).tolist()  # kN
    ('coupler 1–2', [0.0, 2.0, -1.0])
    """
    ax = new_axes(ax)
    t, forces, dense = trace(result, "coupler_forces")
    count = result.coupler_forces.shape[0]
    shown = picked(count, coupler) if count else range(0)
    for i in shown:
        (line,) = ax.plot(*thin(t, forces[i] / 1e3),
                          **line_style(color, label, f"coupler {i + 1}–{i + 2}", kwargs))
        mark_samples(ax, result.time, result.coupler_forces[i] / 1e3, line.get_color())
    if bounds is not None:
        limit_lines(ax, result.time, bounds[0], bounds[1],
                    labels=("compression limit", "tension limit"))
    ax.set_xlabel("time [s]")
    ax.set_ylabel("coupler force [kN]")
    ax.set_title(f"Coupler forces — {result.controller_name}")
    if count and coupler is None:
        _legend(ax, count)
    return ax


def input_plot(
    result: SimulationResult,
    *,
    bounds: tuple[ArrayLike, ArrayLike] | None = None,
    vehicle: int | None = None,
    color: Any = None,
    label: str | None = None,
    ax: Axes | None = None,
    **kwargs: Any,
) -> Axes:
    """Traction/braking forces, held over each sample interval, in kN.

    Parameters
    ----------
    result : SimulationResult
        The run.
    bounds : (float or ndarray, float or ndarray) or None
        Lower (braking, negative) and upper (traction) limits [N]: scalars,
        or arrays over the samples (N values, held) or the instants (N + 1
        values), e.g. a vehicle's speed-dependent envelope. Drawn near the
        data, named at the edge when far outside (the axes follow the data).
    vehicle : int or None
        Draw only this vehicle (0-based; labelled from 1); None: all.
    color, label : optional
        Line colour and legend label (for comparing runs in one axes).
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.
    **kwargs
        Further line properties of the traces (e.g. ``linestyle``).

    Returns
    -------
    matplotlib.axes.Axes
        The axes, labelled ``time [s]`` and ``force [kN]``.

    Examples
    --------
    Vehicle 1 pulls 500 N, then brakes with 300 N; the last value is held
    to the end of the run:

    >>> from trainctl.sim import SimulationResult
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 1.0, 2.0]),
    ...     states=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1],
    ...                      [0.0, 0.001, -0.0005], [0.0, 10.2, 20.5]]),
    ...     velocities=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1]]),
    ...     coupler_forces=np.array([[0.0, 2000.0, -1000.0]]),
    ...     inputs=np.array([[500.0, -300.0], [400.0, -200.0]]),
    ...     reference_speed=np.full(3, 10.0), reference_acceleration=np.zeros(3),
    ...     statuses=("optimal", "max_iterations"), iterations=np.array([3, 10]),
    ...     residuals=((1.0, 0.1), (2.0, 0.5)), solve_times=np.array([1e-3, 2e-3]),
    ...     fallbacks=("", ""), controller_name="demo", seed=0, dt=1.0)
    >>> ax = input_plot(result, vehicle=0)
    >>> ax.lines[0].get_label(), np.round(ax.lines[0].get_ydata(), 3).tolist()  # kN
    ('vehicle 1', [0.5, -0.3, -0.3])
    """
    ax = new_axes(ax)
    shown = picked(result.n_vehicles, vehicle)
    if result.n_samples:
        for i in shown:
            held = np.append(result.inputs[i], result.inputs[i, -1]) / 1e3
            ax.step(result.time, held, where="post",
                    **line_style(color, label, f"vehicle {i + 1}", kwargs))
    if bounds is not None:
        limit_lines(ax, result.time, bounds[0], bounds[1],
                    labels=("braking limit", "traction limit"))
    ax.set_xlabel("time [s]")
    ax.set_ylabel("force [kN]")
    ax.set_title(f"Inputs — {result.controller_name}")
    if vehicle is None:
        _legend(ax, len(shown) + (2 if bounds is not None else 0))
    return ax


def iterations_plot(result: SimulationResult, *, ax: Axes | None = None) -> Axes:
    """Iterations and the final iteration residual per sample.

    Iterations are a step line on the left axis; samples whose status is not
    optimal are marked with red crosses. When the controller iterates (the
    run recorded residuals), the last residual of each sample [kN] is drawn
    on a logarithmic right axis.

    Parameters
    ----------
    result : SimulationResult
        The run.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The iterations axes, labelled ``time [s]`` and ``iterations [-]``
        (the residual axes is its twin).

    Examples
    --------
    Two samples of 3 and 10 iterations; the second did not end optimal, so
    it is crossed, and the last residual of each sample goes on the twin axis:

    >>> from trainctl.sim import SimulationResult
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 1.0, 2.0]),
    ...     states=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1],
    ...                      [0.0, 0.001, -0.0005], [0.0, 10.2, 20.5]]),
    ...     velocities=np.array([[10.0, 10.5, 10.2], [10.0, 10.4, 10.1]]),
    ...     coupler_forces=np.array([[0.0, 2000.0, -1000.0]]),
    ...     inputs=np.array([[500.0, -300.0], [400.0, -200.0]]),
    ...     reference_speed=np.full(3, 10.0), reference_acceleration=np.zeros(3),
    ...     statuses=("optimal", "max_iterations"), iterations=np.array([3, 10]),
    ...     residuals=((1.0, 0.1), (2.0, 0.5)), solve_times=np.array([1e-3, 2e-3]),
    ...     fallbacks=("", ""), controller_name="demo", seed=0, dt=1.0)
    >>> ax = iterations_plot(result)
    >>> [(line.get_label(), line.get_ydata().tolist()) for line in ax.lines]
    [('iterations', [3, 10]), ('not optimal', [10])]
    >>> twin = ax.figure.axes[1]
    >>> twin.get_ylabel(), twin.lines[0].get_ydata().tolist()  # kN
    ('residual [kN]', [0.1, 0.5])
    """
    ax = new_axes(ax)
    t = result.time[:-1]
    handles = ax.step(t, result.iterations, where="post", linewidth=1.0, label="iterations")
    flagged = np.array([s != "optimal" for s in result.statuses], dtype=bool)
    if np.any(flagged):
        handles += ax.plot(t[flagged], result.iterations[flagged], "rx", label="not optimal")
    final = np.array([r[-1] if r else np.nan for r in result.residuals], dtype=float)
    shown = np.where(final > 0, final, np.nan)
    if np.any(np.isfinite(shown)):
        twin = ax.twinx()
        handles += twin.step(t, shown, where="post", color="tab:orange", linewidth=0.8,
                             label="final residual")
        twin.set_yscale("log")
        plain_log_labels(twin.yaxis)
        twin.set_ylabel("residual [kN]")
    ax.set_ylim(bottom=0)
    if len(handles) > 1:
        ax.legend(handles=handles, loc="best", fontsize="small")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("iterations [-]")
    ax.set_title(f"Iterations — {result.controller_name}")
    return ax


def eigenvalue_plot(
    eigenvalues: Mapping[str, ArrayLike], *, ax: Axes | None = None
) -> Axes:
    """Discrete-time eigenvalues against the unit circle.

    Parameters
    ----------
    eigenvalues : mapping of str to array_like of complex
        Label (e.g. ``"open loop"``, ``"centralised"``) to eigenvalues.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        Equal-aspect axes labelled ``Re(λ) [-]`` and ``Im(λ) [-]``, the
        legend to the right of them.

    Examples
    --------
    >>> ax = eigenvalue_plot({"open loop": [1.0, 0.5 + 0.5j, 0.5 - 0.5j]})
    >>> ax.get_xlabel(), [line.get_label() for line in ax.lines][:2]
    ('Re(λ) [-]', ['unit circle', 'open loop (ρ = 1)'])
    """
    ax = new_axes(ax)
    theta = np.linspace(0.0, 2.0 * np.pi, 361)
    ax.plot(np.cos(theta), np.sin(theta), color="0.5", linewidth=0.8, label="unit circle")
    markers = ("o", "x", "+", "s", "^", "D")
    for k, (label, values) in enumerate(eigenvalues.items()):
        z = np.asarray(values, dtype=complex).ravel()
        filled = markers[k % len(markers)] in ("o", "s", "^", "D")
        ax.plot(z.real, z.imag, linestyle="none", marker=markers[k % len(markers)],
                markersize=6 if filled else 7, fillstyle="none" if filled else "full",
                label=f"{label} (ρ = {np.max(np.abs(z)) if z.size else 0.0:.4g})")
    ax.axhline(0.0, color="0.85", linewidth=0.6, zorder=0)
    ax.axvline(0.0, color="0.85", linewidth=0.6, zorder=0)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("Re(λ) [-]")
    ax.set_ylabel("Im(λ) [-]")
    ax.set_title("Eigenvalues and the unit circle")
    legend_outside(ax)  # beside the circle, never over it
    return ax


def convergence_plot(
    weights: ArrayLike,
    radii: ArrayLike,
    *,
    threshold: float | None = None,
    design_weight: float | None = None,
    unit: str = "per kN²",
    ax: Axes | None = None,
) -> Axes:
    """ρ(D0) of the N-DMPC iteration against the input weight R, with R* marked.

    Parameters
    ----------
    weights : array_like
        Input weights R > 0 [``unit``].
    radii : array_like
        ρ(D0) at each weight (see :func:`trainctl.analysis.convergence_sweep`).
    threshold : float or None
        R*, the smallest weight with ρ(D0) < 1 [``unit``]; marked when finite.
    design_weight : float or None
        The design's own R [``unit``]; marked when given.
    unit : str
        Unit of the weights, for the axis label.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        Axes with a logarithmic R axis labelled ``R [unit]`` and ``ρ(D0) [-]``.

    Examples
    --------
    >>> ax = convergence_plot([1.0, 5.0, 25.0], [1.667, 1.0, 0.333], threshold=5.0)
    >>> ax.get_xscale(), ax.get_ylabel()
    ('log', 'ρ(D0) [-]')
    """
    ax = new_axes(ax)
    r = np.asarray(weights, dtype=float)
    rho = np.asarray(radii, dtype=float)
    ax.plot(r, rho, linewidth=1.2, label="ρ(D0)")
    ax.axhline(1.0, color="0.3", linestyle="--", linewidth=1.0, label="ρ = 1")
    if threshold is not None and np.isfinite(threshold):
        ax.axvline(threshold, color="tab:red", linestyle=":", linewidth=1.2,
                   label=f"R* = {threshold:.4g}")
    if design_weight is not None and np.isfinite(design_weight):
        at = float(np.interp(np.log(design_weight), np.log(r), rho)) if r.size else np.nan
        ax.plot([design_weight], [at], "o", color="tab:green",
                label=f"design R = {design_weight:.4g}")
    ax.set_xscale("log")
    plain_log_labels(ax.xaxis)
    ax.set_ylim(bottom=0)
    ax.set_xlabel(f"R [{unit}]")
    ax.set_ylabel("ρ(D0) [-]")
    ax.set_title("N-DMPC iteration: ρ(D0) against the input weight")
    legend_outside(ax)
    return ax


def graph_plot(graph: CommunicationGraph, *, ax: Axes | None = None) -> Axes:
    """A communication graph: vehicles in a row (head left), links as arcs, reference above.

    Links heard both ways are one arc with arrowheads at both ends; a link
    heard one way points from sender to receiver; the reference (a square
    above the train) points to the vehicles it pins. Arcs between
    neighbours are straight; longer ones bend upwards, more the longer.

    Parameters
    ----------
    graph : CommunicationGraph
        The graph (:func:`trainctl.models.graphs.make_graph`).
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        The axes (no ticks; vehicles labelled from 1).

    Examples
    --------
    >>> from trainctl.models.graphs import make_graph
    >>> ax = graph_plot(make_graph("predecessor", 4, pinned="head"))
    >>> len(ax.patches)  # 3 links, 1 reference link, the reference square
    5
    """
    from matplotlib.patches import FancyArrowPatch, Rectangle

    ax = new_axes(ax)
    n = graph.n
    a = graph.adjacency
    top = 1.0 + 0.15 * max(n - 1, 1) ** 0.5
    centre = (n - 1) / 2.0
    ax.plot(np.arange(n), np.zeros(n), "o", markersize=9 if n <= 30 else 4,
            color="tab:blue", zorder=3)
    if n <= 30:
        for i in range(n):
            ax.annotate(str(i + 1), (i, 0), xytext=(0, -13), textcoords="offset points",
                        ha="center", fontsize=8)
    for i, j in zip(*np.nonzero(a), strict=True):
        both = a[j, i] > 0
        if both and j > i:
            continue  # drawn once, from the lower index
        span = abs(int(i) - int(j))
        style = "<|-|>" if both else "-|>"
        ax.add_patch(FancyArrowPatch(
            (float(j), 0.0), (float(i), 0.0), arrowstyle=style, mutation_scale=8,
            connectionstyle=f"arc3,rad={0.0 if span == 1 else -0.35 * np.sign(i - j)}",
            shrinkA=5, shrinkB=5, linewidth=0.8, color="0.35"))
    for pinned in np.flatnonzero(graph.pinning):
        ax.add_patch(FancyArrowPatch((centre, top), (float(pinned), 0.0), arrowstyle="-|>",
                                     mutation_scale=8, shrinkA=6, shrinkB=5, linewidth=0.8,
                                     linestyle="--", color="tab:red"))
    ax.add_patch(Rectangle((centre - 0.18, top - 0.09), 0.36, 0.18, color="tab:red", zorder=3))
    ax.annotate("reference", (centre, top), xytext=(0, 9), textcoords="offset points",
                ha="center", fontsize=8, color="tab:red")
    ax.set_xlim(-0.7, n - 0.3)
    ax.set_ylim(-0.6 - 0.1 * n ** 0.5, top + 0.45)
    ax.set_xticks([])
    ax.set_yticks([])
    for spine in ax.spines.values():
        spine.set_visible(False)
    ax.set_title(f"Communication graph — {graph.topology}, head on the left")
    return ax
