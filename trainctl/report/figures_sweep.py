# The sweep report's figures: a quantity against one or two swept parameters, and certificates.
"""Figures of the sweep report (:mod:`trainctl.report.sweep`), drawn without pyplot.

Every figure shows one quantity of the sweep's table against its swept
parameters, laid out by :class:`Panel` s:

- one parameter: a line per strategy against it (numbers), the median over
  seeds with a min–max band when the sweep has seeds; a row of coloured
  cells for a status or a yes/no outcome;
- two parameters or more: heat maps over the first two parameters, one panel
  per strategy and per combination of the other parameters, at most
  :data:`MAX_PANELS` panels (the caption says which are left out); when the
  points of two numeric parameters fill less than half of their grid (random
  samples), a scatter plot of the points instead.

Palettes are colour-blind safe: Okabe–Ito colours for lines and statuses
(with dashes and markers, and every status cell also written in words when
the cells are few), ``cividis`` for numbers. An axis whose values are all
positive and span more than a decade is logarithmic.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from matplotlib.colors import BoundaryNorm, ListedColormap, LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from trainctl.plots._common import plain_log_labels

__all__ = [
    "CATEGORY_COLOURS", "LINE_COLOURS", "MAX_PANELS", "Panel", "category_figure",
    "certificate_figure", "is_log", "line_figure", "numeric_map_figure",
]

MAX_PANELS = 6
"""At most this many panels (strategies × combinations of further parameters) per figure."""

ANNOTATE_MAX = 48
"""Cells are written in words (values, statuses) when a panel has at most this many."""

LINE_COLOURS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000")
"""Okabe–Ito colours for the strategies' lines (with dashes and markers as well)."""

_DASHES: tuple[Any, ...] = ("-", "--", "-.", ":", (0, (5, 1, 1, 1)))
_MARKERS = ("o", "s", "^", "D", "v", "P", "X")

CATEGORY_COLOURS = {
    "pass": "#0072B2", "yes": "#0072B2",
    "warn": "#F0E442",
    "fail": "#D55E00", "no": "#D55E00",
    "other": "#999999",
}
"""Okabe–Ito fills of a status (good blue, warn yellow, bad vermillion, other grey)."""

MISSING_COLOUR = "#FFFFFF"
"""Cells without a point."""


def is_log(values: Sequence[float]) -> bool:
    """True when every value is > 0 and they span more than a decade.

    Parameters
    ----------
    values : sequence of float
        An axis's values.

    Returns
    -------
    bool
        Whether the axis is drawn on a logarithmic scale.

    Examples
    --------
    >>> is_log([1, 3, 10, 30]), is_log([10.0, 20.0]), is_log([0, 10, 100])
    (True, False, False)
    """
    finite = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    return bool(finite) and min(finite) > 0 and max(finite) / min(finite) > 10.0


@dataclass
class Panel:
    """One heat-map (or scatter) panel: a grid of cells over two parameters.

    Parameters
    ----------
    title : str
        The panel's title (strategy, fixed further parameters), may be empty.
    cells : dict
        ``(x index, y index) -> value``: a float (numbers) or a category
        label (``"pass"``, ``"no"``, ...); cells without a point are absent.
    notes : dict
        ``(x index, y index) -> text`` written in the cell instead of the
        value (e.g. ``"2/3"`` seeds passing).
    marks : dict
        ``(x index, y index) -> True/False/None`` for a certificate map: the
        simulated outcome (ok, not ok, mixed over seeds).

    Examples
    --------
    The N-DMPC check over two weights R (x) and one sample time (y): it
    fails at R = 1 and passes at R = 10:

    >>> panel = Panel("ndmpc", {(0, 0): "fail", (1, 0): "pass"})
    >>> panel.cells[(1, 0)], panel.notes, panel.marks
    ('pass', {}, {})
    """

    title: str
    cells: dict[tuple[int, int], Any] = field(default_factory=dict)
    notes: dict[tuple[int, int], str] = field(default_factory=dict)
    marks: dict[tuple[int, int], bool | None] = field(default_factory=dict)


@dataclass(frozen=True)
class Grid:
    """The two parameters of a heat map: tick labels, axis labels, numeric values."""

    x_label: str
    y_label: str
    x_ticks: tuple[str, ...]
    y_ticks: tuple[str, ...]
    x_values: tuple[float, ...] | None = None
    """Numeric values of the x ticks (None: the parameter is not numeric)."""
    y_values: tuple[float, ...] | None = None


def _panel_layout(count: int) -> tuple[int, int]:
    cols = min(3, count)
    return -(-count // cols), cols


def _sparse(grid: Grid, panels: Sequence[Panel]) -> bool:
    """Scatter rather than heat map: both axes numeric and under half of the cells filled."""
    if grid.x_values is None or grid.y_values is None:
        return False
    size = len(grid.x_ticks) * len(grid.y_ticks)
    filled = max((len(p.cells) for p in panels), default=0)
    return size > 4 and filled < 0.5 * size


def _axes_grid(figure: Figure, count: int) -> list[Any]:
    rows, cols = _panel_layout(count)
    axes = figure.subplots(rows, cols, squeeze=False)
    flat = [ax for row in axes for ax in row]
    for ax in flat[count:]:
        ax.set_visible(False)
    return flat[:count]


def _figure(count: int, ny: int, *, extra_height: float = 0.0) -> Figure:
    """A figure for ``count`` panels of ``ny`` rows of cells: rows about 0.4 in high."""
    rows, cols = _panel_layout(count)
    panel = min(1.0 + 0.45 * max(ny, 1), 2.9 if cols > 1 else 3.4)
    return Figure(figsize=(7.5, min(panel * rows + extra_height, 9.0)), layout="constrained")


def _label_grid(ax: Any, grid: Grid, *, first_col: bool, bottom: bool) -> None:
    ax.set_xticks(range(len(grid.x_ticks)), grid.x_ticks, fontsize="small")
    ax.set_yticks(range(len(grid.y_ticks)), grid.y_ticks, fontsize="small")
    ax.set_xlim(-0.5, len(grid.x_ticks) - 0.5)
    ax.set_ylim(-0.5, len(grid.y_ticks) - 0.5)
    if len(grid.x_ticks) > 6:
        for label in ax.get_xticklabels():
            label.set_rotation(45)
            label.set_horizontalalignment("right")
    if bottom:
        ax.set_xlabel(grid.x_label)
    if first_col:
        ax.set_ylabel(grid.y_label)


def _scatter_axes(ax: Any, grid: Grid, *, first_col: bool, bottom: bool) -> None:
    assert grid.x_values is not None and grid.y_values is not None
    for axis, values, setter in ((ax.xaxis, grid.x_values, ax.set_xscale),
                                 (ax.yaxis, grid.y_values, ax.set_yscale)):
        if is_log(values):
            setter("log")
            plain_log_labels(axis)
    if bottom:
        ax.set_xlabel(grid.x_label)
    if first_col:
        ax.set_ylabel(grid.y_label)
    ax.grid(True, linewidth=0.4, alpha=0.5)


def _xy(grid: Grid, cell: tuple[int, int]) -> tuple[float, float]:
    assert grid.x_values is not None and grid.y_values is not None
    return grid.x_values[cell[0]], grid.y_values[cell[1]]


def _positions(grid: Grid, panels: Sequence[Panel], draw: Callable[..., None]) -> Figure:
    """A figure of panels: ``draw(ax, panel, sparse)`` fills each, axes labelled here."""
    sparse = _sparse(grid, panels)
    ny = 6 if sparse else len(grid.y_ticks)
    figure = _figure(len(panels), ny, extra_height=0.5)
    axes = _axes_grid(figure, len(panels))
    rows, cols = _panel_layout(len(panels))
    for k, (ax, panel) in enumerate(zip(axes, panels, strict=True)):
        first_col, bottom = k % cols == 0, k + cols >= len(panels)
        if sparse:
            _scatter_axes(ax, grid, first_col=first_col, bottom=bottom)
        else:
            _label_grid(ax, grid, first_col=first_col, bottom=bottom)
        draw(ax, panel, sparse)
        if panel.title:
            ax.set_title(panel.title, fontsize="small")
    return figure


def numeric_map_figure(grid: Grid, panels: Sequence[Panel], *, label: str) -> Figure:
    """Heat maps (or scatter plots) of a number over two parameters, one colour scale.

    Parameters
    ----------
    grid : Grid
        The two parameters.
    panels : sequence of Panel
        Cells holding floats (NaN: no value).
    label : str
        The colour bar's label, with its unit.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    ρ(D0) over two weights and two sample times: one panel and its colour
    bar, the x axis labelled with the first parameter:

    >>> grid = Grid("R [1/kN²]", "T [s]", ("1", "10"), ("10", "20"), (1.0, 10.0), (10.0, 20.0))
    >>> panel = Panel("ndmpc", {(0, 0): 1.58, (1, 0): 0.31, (0, 1): 1.2, (1, 1): 0.2})
    >>> fig = numeric_map_figure(grid, [panel], label="ρ(D0) [-]")
    >>> len(fig.axes), fig.axes[0].get_xlabel(), fig.axes[0].get_title()
    (2, 'R [1/kN²]', 'ndmpc')
    """
    values = [v for p in panels for v in p.cells.values() if math.isfinite(v)]
    log = is_log(values)
    lo, hi = (min(values), max(values)) if values else (0.0, 1.0)
    if lo == hi:
        lo, hi = lo - 0.5, hi + 0.5
    norm: Normalize = LogNorm(lo, hi) if log else Normalize(lo, hi)
    cmap = _cividis()
    mappable: list[Any] = []

    def draw(ax: Any, panel: Panel, sparse: bool) -> None:
        nx, ny = len(grid.x_ticks), len(grid.y_ticks)
        if sparse:
            cells = [(c, v) for c, v in panel.cells.items() if math.isfinite(v)]
            xs = [_xy(grid, c)[0] for c, _ in cells]
            ys = [_xy(grid, c)[1] for c, _ in cells]
            mappable.append(ax.scatter(xs, ys, c=[v for _, v in cells], cmap=cmap, norm=norm,
                                       s=28, edgecolors="black", linewidths=0.3))
            return
        data = np.full((ny, nx), np.nan)
        for (i, j), v in panel.cells.items():
            data[j, i] = v
        masked = np.ma.masked_invalid(data)
        mappable.append(ax.pcolormesh(np.arange(nx + 1) - 0.5, np.arange(ny + 1) - 0.5, masked,
                                      cmap=cmap, norm=norm, edgecolors="white",
                                      linewidth=0.5))
        if nx * ny <= ANNOTATE_MAX:
            for (i, j), v in panel.cells.items():
                text = panel.notes.get((i, j)) or _short(v)
                shade = cmap(norm(v)) if math.isfinite(v) else (1, 1, 1, 1)
                ax.text(i, j, text, ha="center", va="center", fontsize="x-small",
                        color="black" if _light(shade) else "white")

    figure = _positions(grid, panels, draw)
    if mappable:
        bar = figure.colorbar(mappable[0], ax=figure.axes, shrink=0.9)
        if bar.solids is not None:
            bar.solids.set_rasterized(False)  # vector, not an embedded PNG
            bar.solids.set_edgecolor("face")  # no seams between the colour steps
        bar.set_label(label)
        if log:
            plain_log_labels(bar.ax.yaxis)
    return figure


def category_figure(grid: Grid, panels: Sequence[Panel], *, categories: Sequence[str],
                    legend_title: str, names: Sequence[str] | None = None) -> Figure:
    """Maps of a status or a yes/no outcome over the parameters, one colour per category.

    Parameters
    ----------
    grid : Grid
        The two parameters (one of them a single dummy tick for a
        one-parameter sweep).
    panels : sequence of Panel
        Cells holding category labels.
    categories : sequence of str
        The categories in legend order (keys of :data:`CATEGORY_COLOURS`
        or free labels, drawn grey).
    legend_title : str
        What the colours are.
    names : sequence of str or None
        The legend's words for the categories (default: the categories).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    A check's status in four cells: the legend lists the categories in
    order, and with so few cells each is also written in words:

    >>> grid = Grid("R [1/kN²]", "T [s]", ("1", "10"), ("10", "20"), (1.0, 10.0), (10.0, 20.0))
    >>> panel = Panel("", {(0, 0): "fail", (1, 0): "pass", (0, 1): "warn", (1, 1): "pass"})
    >>> fig = category_figure(grid, [panel], categories=("pass", "warn", "fail"),
    ...                       legend_title="status")
    >>> [t.get_text() for t in fig.legends[0].get_texts()]
    ['pass', 'warn', 'fail']
    >>> sorted(t.get_text() for t in fig.axes[0].texts)
    ['fail', 'pass', 'pass', 'warn']
    """
    colours = [CATEGORY_COLOURS.get(c, CATEGORY_COLOURS["other"]) for c in categories]
    index = {c: k for k, c in enumerate(categories)}
    cmap = ListedColormap(colours)
    norm = BoundaryNorm(np.arange(len(categories) + 1) - 0.5, len(categories))

    def draw(ax: Any, panel: Panel, sparse: bool) -> None:
        _draw_categories(ax, grid, panel, sparse, index, cmap, norm)

    figure = _positions(grid, panels, draw)
    handles = [Patch(facecolor=c, edgecolor="black", linewidth=0.4, label=name)
               for name, c in zip(names or categories, colours, strict=True)]
    figure.legend(handles=handles, loc="outside upper center", ncols=min(len(handles), 6),
                  fontsize="small", frameon=False, title=legend_title,
                  title_fontsize="small")
    return figure


def _draw_categories(ax: Any, grid: Grid, panel: Panel, sparse: bool, index: dict[str, int],
                     cmap: ListedColormap, norm: BoundaryNorm) -> None:
    nx, ny = len(grid.x_ticks), len(grid.y_ticks)
    if sparse:
        for cell, label in panel.cells.items():
            x, y = _xy(grid, cell)
            ax.scatter([x], [y], color=cmap(norm(index[label])), s=36, edgecolors="black",
                       linewidths=0.4)
        return
    data = np.full((ny, nx), np.nan)
    for (i, j), label in panel.cells.items():
        data[j, i] = index[label]
    ax.pcolormesh(np.arange(nx + 1) - 0.5, np.arange(ny + 1) - 0.5, np.ma.masked_invalid(data),
                  cmap=cmap, norm=norm, edgecolors="white", linewidth=0.5)
    if nx * ny <= ANNOTATE_MAX:
        for (i, j), label in panel.cells.items():
            shade = cmap(norm(index[label]))
            ax.text(i, j, panel.notes.get((i, j), label), ha="center", va="center",
                    fontsize="x-small", color="black" if _light(shade) else "white")


def certificate_figure(grid: Grid, panels: Sequence[Panel], *, categories: Sequence[str],
                       outcome: str, outcome_not: str) -> Figure:
    """The certificate's verdict (fill) with the simulated outcome marked in each cell.

    Parameters
    ----------
    grid : Grid
        The two parameters.
    panels : sequence of Panel
        ``cells``: the check's status; ``marks``: True (the simulation
        agrees it is fine: ``outcome``), False (not), None (mixed over
        seeds, with a ``notes`` entry such as ``"2/3"``).
    categories : sequence of str
        Status categories in legend order.
    outcome, outcome_not : str
        What the two marks say, e.g. ``"converged"``, ``"did not converge"``.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    The certificate's status as fill, the simulation's outcome as marks;
    the cell mixed over seeds shows its note:

    >>> grid = Grid("R [1/kN²]", "T [s]", ("1", "10"), ("10", "20"), (1.0, 10.0), (10.0, 20.0))
    >>> panel = Panel("", {(0, 0): "fail", (1, 0): "pass", (0, 1): "warn", (1, 1): "pass"},
    ...               notes={(0, 1): "2/3"},
    ...               marks={(0, 0): False, (1, 0): True, (0, 1): None, (1, 1): True})
    >>> fig = certificate_figure(grid, [panel], categories=("pass", "warn", "fail"),
    ...                          outcome="converged", outcome_not="did not converge")
    >>> [t.get_text() for t in fig.legends[0].get_texts()][-2:]
    ['simulated: converged', 'simulated: did not converge']
    >>> [t.get_text() for t in fig.axes[0].texts]
    ['2/3']
    """
    colours = [CATEGORY_COLOURS.get(c, CATEGORY_COLOURS["other"]) for c in categories]
    index = {c: k for k, c in enumerate(categories)}
    cmap = ListedColormap(colours)
    norm = BoundaryNorm(np.arange(len(categories) + 1) - 0.5, len(categories))

    def draw(ax: Any, panel: Panel, sparse: bool) -> None:
        bare = Panel(panel.title, dict(panel.cells))
        if not sparse:
            _fill_only(ax, grid, bare, index, cmap, norm)
        for cell, ok in panel.marks.items():
            x, y = _xy(grid, cell) if sparse else cell
            if sparse:
                ax.scatter([x], [y], color=cmap(norm(index[panel.cells[cell]])), s=90,
                           edgecolors="black", linewidths=0.4, zorder=2)
            if ok is True:
                ax.plot([x], [y], marker="o", markersize=7, markerfacecolor="white",
                        markeredgecolor="black", linestyle="none", zorder=3)
            elif ok is False:
                ax.plot([x], [y], marker="X", markersize=8, markerfacecolor="black",
                        markeredgecolor="white", linestyle="none", zorder=3)
            else:
                ax.text(x, y, panel.notes.get(cell, "?"), ha="center", va="center",
                        fontsize="x-small", color="black", zorder=3,
                        bbox={"boxstyle": "round,pad=0.15", "facecolor": "white",
                              "edgecolor": "black", "linewidth": 0.4})

    figure = _positions(grid, panels, draw)
    handles: list[Any] = [Patch(facecolor=c, edgecolor="black", linewidth=0.4,
                                label=f"predicted {name}")
                          for name, c in zip(categories, colours, strict=True)]
    handles += [
        Line2D([], [], marker="o", markersize=7, markerfacecolor="white",
               markeredgecolor="black", linestyle="none", label=f"simulated: {outcome}"),
        Line2D([], [], marker="X", markersize=8, markerfacecolor="black",
               markeredgecolor="white", linestyle="none", label=f"simulated: {outcome_not}"),
    ]
    figure.legend(handles=handles, loc="outside upper center", ncols=3, fontsize="small",
                  frameon=False)
    return figure


def _fill_only(ax: Any, grid: Grid, panel: Panel, index: dict[str, int], cmap: ListedColormap,
               norm: BoundaryNorm) -> None:
    nx, ny = len(grid.x_ticks), len(grid.y_ticks)
    data = np.full((ny, nx), np.nan)
    for (i, j), label in panel.cells.items():
        data[j, i] = index[label]
    ax.pcolormesh(np.arange(nx + 1) - 0.5, np.arange(ny + 1) - 0.5, np.ma.masked_invalid(data),
                  cmap=cmap, norm=norm, edgecolors="white", linewidth=0.5)


@dataclass(frozen=True)
class Line:
    """One strategy's line against a numeric parameter: median, and the min–max band."""

    label: str
    x: tuple[float, ...]
    median: tuple[float, ...]
    low: tuple[float, ...]
    high: tuple[float, ...]


def line_figure(lines: Sequence[Line], *, x_label: str, y_label: str,
                x_ticks: Sequence[str] | None = None, band: bool = False) -> Figure:
    """A number against one parameter: one line per strategy (median and min–max band).

    Parameters
    ----------
    lines : sequence of Line
        The series; x are the parameter's values (positions for a
        non-numeric parameter, labelled by ``x_ticks``).
    x_label, y_label : str
        Axis labels with units.
    x_ticks : sequence of str or None
        Tick labels of a non-numeric parameter.
    band : bool
        Shade the min–max band (repeated seeds).

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    R from 1 to 100 spans two decades, so the x axis is logarithmic; the
    band is one shaded area:

    >>> line = Line("ndmpc", (1.0, 10.0, 100.0), (1.58, 0.31, 0.05), (1.5, 0.3, 0.04),
    ...             (1.6, 0.32, 0.06))
    >>> fig = line_figure([line], x_label="R [1/kN²]", y_label="ρ(D0) [-]", band=True)
    >>> ax = fig.axes[0]
    >>> ax.get_xscale(), ax.lines[0].get_label(), ax.lines[0].get_ydata().tolist()
    ('log', 'ndmpc (median)', [1.58, 0.31, 0.05])
    >>> len(ax.collections)
    1
    """
    figure = Figure(figsize=(7.5, 3.4), layout="constrained")
    ax = figure.add_subplot()
    xs = [x for line in lines for x in line.x]
    ys = [y for line in lines for y in (*line.low, *line.high, *line.median)
          if math.isfinite(y)]
    for k, line in enumerate(lines):
        colour = LINE_COLOURS[k % len(LINE_COLOURS)]
        ax.plot(line.x, line.median, color=colour, linestyle=_DASHES[k % len(_DASHES)],
                marker=_MARKERS[k % len(_MARKERS)], markersize=4, linewidth=1.2,
                label=(f"{line.label} (median)" if line.label else "median") if band
                else line.label)
        if band:
            ax.fill_between(line.x, line.low, line.high, color=colour, alpha=0.18,
                            linewidth=0)
    if x_ticks is None and is_log(xs):
        ax.set_xscale("log")
        plain_log_labels(ax.xaxis)
    if x_ticks is not None:
        ax.set_xticks(range(len(x_ticks)), list(x_ticks))
    if is_log(ys):
        ax.set_yscale("log")
        plain_log_labels(ax.yaxis)
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    ax.grid(True, linewidth=0.4, alpha=0.5)
    if len(lines) > 1 or (lines and lines[0].label) or band:
        handles = ax.get_legend_handles_labels()[0]
        if band:
            handles.append(Patch(facecolor="#777777", alpha=0.3, label="min–max over seeds"))
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                  borderaxespad=0.0, fontsize="small", frameon=False)
    return figure


def _cividis() -> Any:
    from matplotlib import colormaps

    return colormaps["cividis"]


def _light(rgba: Sequence[float]) -> bool:
    r, g, b = rgba[:3]
    return 0.299 * r + 0.587 * g + 0.114 * b > 0.5


def _short(value: float) -> str:
    if not math.isfinite(value):
        return ""
    return f"{value:.3g}".replace("-", "−")
