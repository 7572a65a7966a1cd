# The report's closed-loop time-domain figures: small multiples, strategies overlaid.
"""Speed, coupler-force, input, energy and iteration figures of a report.

The strategies are compared where an engineer compares them: one panel per
vehicle (or coupler), every strategy overlaid in its own colour and line
style (:func:`trainctl.plots._common.series_style`), the legend above the
panels, off the data. Axes follow the data; limits are drawn when near and
named when far (:func:`trainctl.plots._common.limit_lines`). Vehicles are
numbered from 1, head first, as in the seeds.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import NDArray

from trainctl.plots import time as plot
from trainctl.plots._common import fixed_margins, legend_outside, limit_lines, series_style, thin
from trainctl.sim.energy import interval_work
from trainctl.units import JOULES_PER_KWH

if TYPE_CHECKING:
    from trainctl.report.figures import ReportFigure
    from trainctl.scenario import Scenario
    from trainctl.sim.results import SimulationResult

__all__ = ["MAX_PANELS", "shown_indices", "time_figures", "vehicle_limits"]

MAX_PANELS = 8
"""Most vehicle (or coupler) panels in one figure; longer trains show a spread."""

PANEL_HEIGHT = 1.45
"""Height of one small-multiple panel [in]."""

ADMISSIBLE_COLOUR = "#b2182b"
"""Colour of a coupler's admissible force in the coupler-force figure."""


def shown_indices(count: int, limit: int = MAX_PANELS) -> list[int]:
    """Indices of the panels shown: all, or ``limit`` spread from the first to the last.

    Parameters
    ----------
    count : int
        Number of panels there are.
    limit : int
        Most panels shown.

    Returns
    -------
    list of int
        The shown panels' indices, increasing.

    Examples
    --------
    >>> shown_indices(4), shown_indices(20, 5)
    ([0, 1, 2, 3], [0, 5, 10, 14, 19])
    """
    if count <= limit:
        return list(range(count))
    return sorted({int(round(x)) for x in np.linspace(0, count - 1, limit)})


def vehicle_limits(scenario: Scenario, result: SimulationResult,
                   vehicle: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A vehicle's own braking (negative) and traction limits at the reference speed [N].

    Parameters
    ----------
    scenario : Scenario
        The scenario (the vehicle's traction envelope and mass).
    result : SimulationResult
        A run (its reference speed at the sample instants).
    vehicle : int
        0-based index.

    Returns
    -------
    (ndarray, ndarray)
        Lower and upper limit at each instant, shape (N + 1,); a trailer's
        traction limit is 0.

    Examples
    --------
    CRH2's motor car (index 1) has 80 kN traction, 40 kN braking and
    1.2 MW either way: at 20 m/s the power allows 60 kN, so traction is
    60 kN and braking 40 kN; at 60 m/s both are 1.2 MW / 60 m/s = 20 kN.
    The trailer (index 0) brakes with 40 kN and has no traction. Only the
    reference speed of the run is read (a stand-in here):

    >>> from types import SimpleNamespace
    >>> import trainctl
    >>> scenario = trainctl.load_scenario("crh2-dmpc")
    >>> run = SimpleNamespace(reference_speed=np.array([20.0, 60.0]))  # m/s
    >>> [x.tolist() for x in vehicle_limits(scenario, run, 1)]  # N
    [[-40000.0, -20000.0], [60000.0, 20000.0]]
    >>> [x.tolist() for x in vehicle_limits(scenario, run, 0)]  # N
    [[-40000.0, -40000.0], [0.0, 0.0]]
    """
    veh = scenario.train.vehicles[vehicle]
    speed = np.asarray(result.reference_speed, dtype=float)
    up = np.asarray(veh.envelope.traction_limit(speed, mass=veh.mass), dtype=float)
    down = np.asarray(veh.envelope.braking_limit(speed, mass=veh.mass), dtype=float)
    return -down, up


def time_figures(scenario: Scenario, sims: Mapping[str, SimulationResult],
                 make: Callable[..., ReportFigure]) -> Iterator[ReportFigure]:
    """The closed-loop figures of a report, in page order.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    sims : mapping of str to SimulationResult
        Runs by strategy (non-empty).
    make : callable
        ``make(key, title, caption, figure)`` encodes a figure
        (:func:`trainctl.plots.svg.encode`).

    Yields
    ------
    ReportFigure
        Speed tracking, coupler forces (with couplers), inputs, traction
        power and cumulative energy, and the iterations of the iterating
        strategies (when any iterated).

    Examples
    --------
    Two strategies over 120 s of the CRH2 scenario; the N-DMPC iterates,
    so the iterations figure is there. A ``make`` that keeps only the keys:

    >>> import trainctl
    >>> from trainctl.run.analysis import simulate_strategy
    >>> scenario = (trainctl.load_scenario("crh2-dmpc")
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0))
    >>> sims = {name: simulate_strategy(scenario, name) for name in ("decentralised", "ndmpc")}
    >>> def key_only(key, title, caption, figure):  # keep the key, drop the drawing
    ...     return key
    >>> list(time_figures(scenario, sims, key_only))
    ['speed', 'coupler-force', 'input', 'energy', 'iterations']
    """
    yield _speed(scenario, sims, make)
    first = next(iter(sims.values()))
    if first.coupler_forces.shape[0]:
        yield _couplers(scenario, sims, make)
    yield _inputs(scenario, sims, make)
    yield _energy(scenario, sims, make)
    iterating = {k: r for k, r in sims.items() if r.n_samples and np.any(r.iterations > 1)}
    if iterating:
        yield _iterations(iterating, make)


def _panels(count: int, *, top: float = 0.0) -> tuple[Figure, list[Axes]]:
    """A figure of ``count`` stacked panels sharing the time axis (and a taller first one)."""
    ratios = ([top / PANEL_HEIGHT] if top else []) + [1.0] * count
    figure = Figure(figsize=(7.5, 0.9 + top + PANEL_HEIGHT * count))
    axes = figure.subplots(len(ratios), 1, sharex=True, squeeze=False,
                           gridspec_kw={"height_ratios": ratios})[:, 0]
    for ax in axes[:-1]:
        ax.tick_params(labelbottom=False)
    return figure, list(axes)


def _tidy(axes: list[Axes]) -> None:
    for ax in axes:
        ax.set_title("")
        ax.set_xlabel("")
        ax.tick_params(labelsize="small")
    axes[-1].set_xlabel("time [s]")


def _strategy_handles(sims: Mapping[str, Any]) -> list[Line2D]:
    return [Line2D([], [], linewidth=1.3, label=name, **series_style(k))
            for k, name in enumerate(sims)]


def _which(count: int, noun: str) -> str:
    shown = shown_indices(count)
    if len(shown) == count:
        return ""
    return f" Of {count} {noun}s, {', '.join(str(i + 1) for i in shown)} are shown."


def _speed(scenario: Scenario, sims: Mapping[str, SimulationResult],
           make: Callable[..., ReportFigure]) -> ReportFigure:
    n = next(iter(sims.values())).n_vehicles
    vehicles = shown_indices(n)
    figure, axes = _panels(len(vehicles), top=2.0)
    settle = scenario.simulation.settle_time if scenario.simulation else None
    first = next(iter(sims.values()))
    axes[0].plot(first.time, first.reference_speed, color="black", linewidth=2.2, alpha=0.35)
    for k, (name, result) in enumerate(sims.items()):
        style = series_style(k)
        for i in vehicles:
            axes[0].plot(result.time, result.velocities[i], linewidth=0.8, **style)
            plot.speed_error_plot(result, vehicle=i, settle_time=settle if k == 0 else None,
                                  color=style["color"], label=name,
                                  linestyle=style["linestyle"], ax=axes[1 + vehicles.index(i)])
    axes[0].set_ylabel("speed [m/s]")
    for ax, i in zip(axes[1:], vehicles, strict=True):
        ax.set_ylabel(f"vehicle {i + 1}\nerror [m/s]", fontsize="small")
    _tidy(axes)
    handles = _strategy_handles(sims) + [
        Line2D([], [], color="black", linewidth=2.2, alpha=0.35, label="reference")]
    if settle is not None:
        handles.append(Line2D([], [], color="0.3", linestyle=":", label="settle time"))
    legend_outside(figure, handles)
    fixed_margins(figure)
    caption = ("Top: every vehicle's speed [m/s] against the reference (wide grey line); at "
               "this scale the traces mostly coincide. Below, one panel per vehicle (1 = head): "
               "speed minus reference [m/s], every strategy overlaid; dots mark the sample "
               "instants, lines between them the between-sample speeds when the run "
               "recorded them; the dotted line is the settle time after which the metrics "
               "judge tracking." + _which(n, "vehicle"))
    return make("speed", "Speed tracking", caption, figure)


def _couplers(scenario: Scenario, sims: Mapping[str, SimulationResult],
              make: Callable[..., ReportFigure]) -> ReportFigure:
    first = next(iter(sims.values()))
    count = first.coupler_forces.shape[0]
    couplers = shown_indices(count)
    figure, axes = _panels(len(couplers))
    limit = getattr(scenario.controller, "coupler_force_limit", np.inf)
    for k, (name, result) in enumerate(sims.items()):
        style = series_style(k)
        for ax, c in zip(axes, couplers, strict=True):
            plot.coupler_force_plot(result, coupler=c, color=style["color"], label=name,
                                    linestyle=style["linestyle"], ax=ax)
    admissible = np.asarray(scenario.train.max_coupler_force, dtype=float)
    drawn = strength = False
    for ax, c in zip(axes, couplers, strict=True):
        if np.isfinite(limit):
            drawn = bool(limit_lines(ax, first.time, -limit, limit,
                                     labels=("limit", "limit"))) or drawn
        if c < admissible.size and np.isfinite(admissible[c]):
            strength = bool(limit_lines(ax, first.time, -admissible[c], admissible[c],
                                        labels=("admissible", "admissible"),
                                        color=ADMISSIBLE_COLOUR, linestyle="-.")) or strength
        ax.set_ylabel(f"{c + 1}–{c + 2}\nforce [kN]", fontsize="small")
    _tidy(axes)
    handles = _strategy_handles(sims)
    if drawn:
        handles.append(Line2D([], [], color="0.3", linestyle="--", label="coupler-force limit"))
    if strength:
        handles.append(Line2D([], [], color=ADMISSIBLE_COLOUR, linestyle="-.",
                              label="coupler admissible force"))
    legend_outside(figure, handles)
    fixed_margins(figure)
    bound = (f"the controller's coupler-force limit ±{limit / 1e3:.4g} kN (a soft constraint) "
             "is dashed when near the forces and named at the panel's edge when far outside "
             "them" if np.isfinite(limit) else "the controller sets no coupler-force limit")
    if np.any(np.isfinite(admissible)):
        bound += ("; the couplers' admissible force ([train.coupler] max_force_kn) is "
                  "dash-dotted when near and named at the edge when far")
    caption = (f"One panel per coupler (1–2 joins vehicles 1 and 2): force [kN], tension "
               f"positive, every strategy overlaid, axes scaled to the forces; {bound}. Dots "
               "mark the sample instants." + _which(count, "coupler"))
    return make("coupler-force", "Coupler forces", caption, figure)


def _inputs(scenario: Scenario, sims: Mapping[str, SimulationResult],
            make: Callable[..., ReportFigure]) -> ReportFigure:
    first = next(iter(sims.values()))
    vehicles = shown_indices(first.n_vehicles)
    figure, axes = _panels(len(vehicles))
    for k, (name, result) in enumerate(sims.items()):
        style = series_style(k)
        for ax, i in zip(axes, vehicles, strict=True):
            plot.input_plot(result, vehicle=i, color=style["color"], label=name,
                            linestyle=style["linestyle"], ax=ax)
    for ax, i in zip(axes, vehicles, strict=True):
        lower, upper = vehicle_limits(scenario, first, i)
        limit_lines(ax, first.time, lower, upper, labels=("braking limit", "traction limit"))
        veh = scenario.train.vehicles[i]
        ax.set_ylabel(f"{i + 1} {veh.name}\nforce [kN]", fontsize="small")
    _tidy(axes)
    handles = _strategy_handles(sims) + [Line2D([], [], color="0.3", linestyle="--",
                                                label="vehicle's own limits")]
    legend_outside(figure, handles)
    fixed_margins(figure)
    caption = ("One panel per vehicle (number and name): applied traction (+) or braking (−) "
               "force [kN], held over each sample, every strategy overlaid. Dashed: that "
               "vehicle's own traction and braking limits at the reference speed (a trailer "
               "cannot pull: its traction limit is 0); a limit far outside the forces is "
               "named at the panel's edge." + _which(first.n_vehicles, "vehicle"))
    return make("input", "Traction and braking forces", caption, figure)


def _power(result: SimulationResult) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Times [s] and the train's traction power Σ u_i v_i [W] on the dense grid.

    Each sample interval contributes its dense points, both ends included, with
    its held input, so a sample instant appears twice: the jump of the inputs.
    """
    index = result.dense_sample_index
    counts = np.diff(index) + 1
    interval = np.repeat(np.arange(counts.size), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    columns = np.repeat(index[:-1], counts) + np.arange(int(counts.sum())) - first
    power = np.sum(result.inputs[:, interval] * result.dense_velocities[:, columns], axis=0)
    return result.dense_time[columns], np.asarray(power, dtype=float)


def _net_energy(scenario: Scenario, result: SimulationResult,
                eta: float) -> NDArray[np.float64]:
    """Cumulative net energy drawn at the sample instants [J], shape (N + 1,).

    Interval by interval, traction - ``eta`` × braking work
    (:func:`~trainctl.sim.energy.interval_work`, as the energy account sums it).
    """
    traction, braking = interval_work(result, scenario.train)
    net = np.sum(traction - eta * braking, axis=0)
    return np.concatenate([[0.0], np.cumsum(net)])


def _energy(scenario: Scenario, sims: Mapping[str, SimulationResult],
            make: Callable[..., ReportFigure]) -> ReportFigure:
    eta = scenario.simulation.regen_efficiency if scenario.simulation else 1.0
    figure, axes = _panels(2)
    ends = []
    for k, (name, result) in enumerate(sims.items()):
        style = series_style(k)
        t, power = _power(result)
        axes[0].plot(*thin(t, power / 1e6), linewidth=0.9, **style)
        energy = _net_energy(scenario, result, eta) / JOULES_PER_KWH
        axes[1].plot(*thin(result.time, energy), linewidth=1.2, **style)
        ends.append(f"{name} {energy[-1]:.4g} kWh")
    for ax in axes:
        ax.axhline(0.0, color="0.6", linewidth=0.6, zorder=0)
    axes[0].set_ylabel("traction power\n[MW]", fontsize="small")
    axes[1].set_ylabel("net energy\n[kWh]", fontsize="small")
    _tidy(axes)
    legend_outside(figure, _strategy_handles(sims))
    fixed_margins(figure)
    caption = ("Top: the train's traction power Σ u·v over its vehicles [MW], motoring "
               "positive, braking negative: each vehicle's input, held over the sample, "
               "times its speed on the dense grid between the samples (at the sample "
               "instants when the run recorded none). Bottom: the cumulative net energy drawn "
               f"[kWh], traction − {eta:g} × braking work (regen_efficiency = {eta:g}, "
               "[simulation] regen_efficiency), at the sample instants; each interval's work "
               "is the held input times the distance the vehicle moved, as in the exact "
               "energy account, so each curve ends at the run's net energy: "
               + "; ".join(ends) + ".")
    return make("energy", "Traction power and energy", caption, figure)

def _iterations(sims: Mapping[str, SimulationResult],
                make: Callable[..., ReportFigure]) -> ReportFigure:
    figure, axes = _panels(len(sims))
    figure.set_figheight(0.9 + 2.2 * len(sims))
    for ax, (name, result) in zip(axes, sims.items(), strict=True):
        plot.iterations_plot(result, ax=ax)
        ax.set_title("")
        ax.set_title(name, loc="left", fontsize="medium")
        ax.set_xlabel("")
        legend = ax.get_legend()
        if legend is not None:
            legend.remove()
    axes[-1].set_xlabel("time [s]")
    handles = [Line2D([], [], color="tab:blue", label="iterations"),
               Line2D([], [], color="tab:orange", label="final residual [kN]"),
               Line2D([], [], color="red", marker="x", linestyle="none", label="not optimal")]
    legend_outside(figure, handles)
    fixed_margins(figure, right=0.85, top=0.3, hspace=0.35)
    caption = ("Strategies that iterate (more than one iteration at some sample): iterations "
               "per sample (left axis) and the last iteration's plan change [kN] (right, log "
               "scale); red crosses mark samples that were not solved to optimality.")
    return make("iterations", "Iterations and residuals", caption, figure)
