# Helpers shared by the plot functions: axes, styles, dense traces, limits, legends.
"""Private helpers of :mod:`trainctl.plots.time` and :mod:`trainctl.plots.frequency`.

Limits are drawn the way an engineer reads them: the axes are scaled to the
data, a limit near the data is drawn as a dashed line, and a limit far
outside it (a coupler-force limit of ±500 kN beside forces of a few kN) is
named at the edge of the axes with an arrow instead of squashing the data
into a flat line (:func:`limit_lines`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from matplotlib.artist import Artist

    from trainctl.sim.results import SimulationResult

__all__ = [
    "LEGEND_MAX", "MARK_MAX", "fixed_margins", "legend_outside", "limit_lines", "line_style",
    "mark_samples", "new_axes", "picked", "pin_titles", "plain_log_labels", "series_style",
    "thin", "trace",
]

LEGEND_MAX = 10
"""Show a legend only for at most this many traces."""

MARK_MAX = 250
"""Mark the sample instants with dots when a run has at most this many samples."""

THIN_BUCKETS = 600
"""Dense traces longer than twice this are thinned to the extremes of this many buckets."""

NEAR = 1.0
"""A limit within this many data spans of the data is drawn; farther ones are named."""

_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown",
            "tab:pink", "tab:olive", "tab:cyan", "tab:gray")
_DASHES: tuple[Any, ...] = ("-", "--", "-.", ":", (0, (5, 1, 1, 1)))


def new_axes(ax: Axes | None) -> Axes:
    """``ax``, or the axes of a new 7 × 3.5 in constrained-layout Figure (no pyplot)."""
    if ax is not None:
        return ax
    figure = Figure(figsize=(7.0, 3.5), layout="constrained")
    return figure.add_subplot()


def series_style(k: int) -> dict[str, Any]:
    """Colour and line style of the k-th compared series (strategy), distinct when overlaid."""
    return {"color": _COLOURS[k % len(_COLOURS)], "linestyle": _DASHES[k % len(_DASHES)]}


def line_style(color: Any, label: str | None, default: str,
               extra: dict[str, Any]) -> dict[str, Any]:
    """Line properties of a trace: width 1, ``label`` (else ``default``), colour, extras."""
    style: dict[str, Any] = {"linewidth": 1.0, "label": default if label is None else label}
    if color is not None:
        style["color"] = color
    return {**style, **extra}


def picked(count: int, index: int | None) -> range:
    """All ``count`` signals, or the one at ``index`` (IndexError outside 0..count-1)."""
    if index is None:
        return range(count)
    if not 0 <= index < count:
        raise IndexError(f"index {index} out of range for {count} signals")
    return range(index, index + 1)


def trace(result: SimulationResult, name: str) -> tuple[NDArray[np.float64],
                                                        NDArray[np.float64], bool]:
    """Time and values of a signal: the dense between-sample record when the run has one.

    Parameters
    ----------
    result : SimulationResult
        The run.
    name : {"velocities", "coupler_forces"}
        The signal.

    Returns
    -------
    (ndarray, ndarray, bool)
        Times [s], values (signal, time) and whether they are the dense record
        (``result.dense_time`` with ``result.dense_<name>``).
    """
    dense_time = getattr(result, "dense_time", None)
    dense = getattr(result, f"dense_{name}", None)
    if dense_time is not None and dense is not None and np.size(dense_time):
        return np.asarray(dense_time, dtype=float), np.asarray(dense, dtype=float), True
    return np.asarray(result.time, dtype=float), np.asarray(getattr(result, name)), False


def thin(time: ArrayLike, values: ArrayLike,
         buckets: int = THIN_BUCKETS) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A long trace reduced to what a drawn line shows: each bucket's min and max.

    A 1200 s run on a 16.7 ms dense grid has 72 000 points per signal; a
    figure some 1000 pixels wide cannot show more than a few per pixel
    column, and inline SVG pays for every one (the default report grew from
    0.4 MB to 6 MB drawing them all). The time axis is cut into ``buckets``
    equal runs of points and each keeps the points of its minimum and
    maximum, in time order, plus the first and last points of the trace
    (600 buckets: at least one per pixel column of the report's figures):
    every extreme the data reach is drawn (a maximum coupler force
    in the figure is the maximum in the metrics), and the line drawn through
    the kept points covers, in each bucket, the range the full trace covers.

    Parameters
    ----------
    time : array_like
        Times [s], shape (m,).
    values : array_like
        Values at those times, shape (m,).
    buckets : int
        Buckets; traces of at most ``2 * buckets`` points are returned whole.

    Returns
    -------
    (ndarray, ndarray)
        The kept times and values (the input when it is short).

    Examples
    --------
    >>> t = np.linspace(0.0, 1.0, 10_001)
    >>> y = np.sin(40 * np.pi * t)
    >>> tt, yy = thin(t, y, buckets=100)
    >>> len(tt) <= 202, bool(yy.max() == y.max()), bool(yy.min() == y.min()), float(tt[-1])
    (True, True, True, 1.0)
    """
    t = np.asarray(time, dtype=float)
    y = np.asarray(values, dtype=float)
    m = t.size
    if m <= 2 * buckets:
        return t, y
    edges = np.linspace(0, m, buckets + 1).astype(int)
    starts = edges[:-1]
    # NaN-safe extremes: a non-finite value (a diverged run) stays where it is
    filled_low = np.where(np.isnan(y), np.inf, y)
    filled_high = np.where(np.isnan(y), -np.inf, y)
    spans = list(zip(starts, edges[1:], strict=True))
    lows = starts + np.array([np.argmin(filled_low[a:b]) for a, b in spans])
    highs = starts + np.array([np.argmax(filled_high[a:b]) for a, b in spans])
    keep = np.unique(np.concatenate([[0], lows, highs, [m - 1]]))
    return t[keep], y[keep]


def mark_samples(ax: Axes, time: ArrayLike, values: ArrayLike, color: Any) -> None:
    """Dots at the sample instants (runs of at most :data:`MARK_MAX` samples)."""
    t = np.asarray(time, dtype=float)
    if t.size - 1 <= MARK_MAX:
        ax.plot(t, np.asarray(values, dtype=float), linestyle="none", marker="o",
                markersize=2.2, color=color)


def limit_lines(
    ax: Axes,
    time: ArrayLike,
    lower: ArrayLike | None,
    upper: ArrayLike | None,
    *,
    labels: tuple[str, str] = ("lower limit", "upper limit"),
    scale: float = 1e-3,
    unit: str = "kN",
    color: str = "0.3",
    linestyle: str = "--",
) -> list[Artist]:
    """Draw limits near the data, name those far from it; scale the axes to the data.

    Call after the data are drawn. A limit is a scalar or an array over
    ``time`` (N + 1 values at the instants, or N per sample, held); infinite
    or missing values are not drawn. The y-axis spans the data plus
    :data:`NEAR` data spans at most; a limit inside that window is a dashed
    line (partly clipped when it reaches beyond), one wholly outside it is
    written at the top or bottom edge with an arrow.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Axes holding the data.
    time : array_like
        Sample instants [s].
    lower, upper : array_like or None
        Limits in SI (N); drawn times ``scale``.
    labels : (str, str)
        Names of the lower and the upper limit.
    scale : float
        Factor to the plotted unit (N → kN).
    unit : str
        Plotted unit, for the written values.
    color, linestyle : str
        Style of a drawn limit (default: the dashed grey of actuator and
        controller limits).

    Returns
    -------
    list of Artist
        The drawn lines (for a legend).
    """
    lo, hi = (float(x) for x in ax.dataLim.intervaly) if ax.has_data() else (0.0, 0.0)
    values = [None if v is None else _held(v, time) * scale for v in (lower, upper)]
    finite = [v[np.isfinite(v)] for v in values if v is not None]
    reach = max([abs(lo), abs(hi)] + [float(np.max(np.abs(v))) for v in finite if v.size])
    span = hi - lo
    if span <= 1e-9 * max(abs(lo), abs(hi), 1.0):  # flat data (a trailer's zero traction)
        span = max(0.05 * reach, 1e-12)
    window = (lo - NEAR * span, hi + NEAR * span)
    drawn: list[Artist] = []
    shown_lo, shown_hi = lo, hi
    named = {True: False, False: False}  # a far limit named above / below the data
    for value, label in zip(values, labels, strict=True):
        if value is None or not np.any(np.isfinite(value)):
            continue
        near = value[np.isfinite(value) & (value >= window[0]) & (value <= window[1])]
        if near.size:
            t = np.asarray(time, dtype=float)
            drawn += ax.step(t, np.where(np.isfinite(value), value, np.nan), where="post",
                             color=color, linestyle=linestyle, linewidth=1.0, label=label)
            shown_lo, shown_hi = min(shown_lo, float(near.min())), max(shown_hi, float(near.max()))
        else:
            top = bool(np.nanmin(value) > hi)
            named[top] = True
            _name_far_limit(ax, label, value, top=top, unit=unit)
    pad = 0.08 * (shown_hi - shown_lo) if shown_hi > shown_lo else span
    room = 0.22 * (shown_hi - shown_lo + 2 * pad)  # a strip for a named limit, off the data
    ax.set_ylim(shown_lo - pad - room * named[False], shown_hi + pad + room * named[True])
    return drawn


def _held(value: ArrayLike, time: ArrayLike) -> NDArray[np.float64]:
    """A limit as N + 1 values: a scalar repeated, N per-sample values held over the last."""
    arr = np.asarray(value, dtype=float)
    n = np.asarray(time).shape[0]
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape[0] == n - 1:
        return np.append(arr, arr[-1])
    return arr


def _name_far_limit(ax: Axes, label: str, value: NDArray[np.float64], *, top: bool,
                    unit: str) -> None:
    finite = value[np.isfinite(value)]
    lo, hi = float(finite.min()), float(finite.max())
    amount = f"{_fmt(lo)} {unit}" if np.isclose(lo, hi) else f"{_fmt(lo)} … {_fmt(hi)} {unit}"
    ax.annotate(f"{'↑' if top else '↓'} {label} {amount} (off scale)",
                xy=(0.99, 0.96 if top else 0.04), xycoords="axes fraction",
                ha="right", va="top" if top else "bottom", fontsize="x-small", color="0.25")


def _fmt(x: float) -> str:
    return f"{x:.3g}".replace("-", "−")


def legend_outside(target: Figure | Axes, handles: Sequence[Artist] | None = None, *,
                   ncols: int | None = None) -> None:
    """A legend off the data: above the panels of a figure, or right of a single axes.

    Parameters
    ----------
    target : Figure or Axes
        A constrained-layout figure (legend above its axes) or an axes
        (legend to its right).
    handles : sequence of Artist or None
        Legend entries, labelled by their labels; None takes the labelled
        artists of ``target`` (of its first axes for a figure).
    ncols : int or None
        Columns of a figure legend (default: one row of up to 6 entries, else
        two rows); entries read row by row.
    """
    source = target.axes[0] if isinstance(target, Figure) else target
    if handles is None:
        handles = source.get_legend_handles_labels()[0]
    if not handles:
        return
    labels = [str(h.get_label()) for h in handles]
    if isinstance(target, Figure):
        count = len(handles)
        cols = ncols or (count if count <= 6 else -(-count // 2))
        order = _row_major(count, cols)  # matplotlib fills columns first; read rows first
        target.legend([handles[k] for k in order], [labels[k] for k in order],
                      loc="outside upper center", fontsize="small", ncols=cols, frameon=False)
    else:
        target.legend(list(handles), labels, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                      borderaxespad=0.0, fontsize="small", frameon=False)


LEGEND_ROW = 0.19
"""Height of one row of a ``fontsize="small"`` figure legend [in] (with its spacing)."""


def fixed_margins(figure: Figure, *, left: float = 0.85, right: float = 0.2,
                  bottom: float = 0.5, top: float = 0.12, hspace: float = 0.12,
                  wspace: float = 0.8) -> Figure:
    """Place a figure's subplot grid by fixed margins [in], computed once: no layout engine.

    Constrained layout measures every tick label and text of every axes
    (two passes per draw, and ``savefig`` draws twice), about half the time
    of a report's figures. The report's figures have known contents — tick
    labels at ``labelsize="small"``, one- or two-line y-labels, a figure
    legend of :func:`legend_outside` above the panels — so margins in inches
    keep them readable at a fraction of the cost; the report's tests check
    that nothing leaves the canvas.

    Parameters
    ----------
    figure : matplotlib.figure.Figure
        A figure whose axes come from one ``subplots`` grid (or a single
        ``add_subplot``); call after its figure legend is placed.
    left, right, bottom, top : float
        Margins [in]; ``top`` is below the figure legend's rows
        (:data:`LEGEND_ROW` each), which are added.
    hspace, wspace : float
        Gaps between rows and between columns of panels [in].

    Returns
    -------
    matplotlib.figure.Figure
        ``figure``, without a layout engine.
    """
    width, height = (float(x) for x in figure.get_size_inches())
    rows = 0
    if figure.legends:
        legend = figure.legends[0]
        entries = len(legend.get_texts())
        cols = max(int(getattr(legend, "_ncols", 1)), 1)
        rows = -(-entries // cols)
    top += rows * LEGEND_ROW + (0.08 if rows else 0.0)
    nrows, ncols = 1, 1
    for ax in figure.axes:
        spec = ax.get_subplotspec()
        if spec is not None:
            nrows, ncols = spec.get_gridspec().get_geometry()
            break
    span_h = height - top - bottom
    span_w = width - left - right
    axes_h = (span_h - hspace * (nrows - 1)) / nrows
    axes_w = (span_w - wspace * (ncols - 1)) / ncols
    figure.set_layout_engine("none")
    pin_titles(figure)
    figure.subplots_adjust(left=left / width, right=1.0 - right / width,
                           bottom=bottom / height, top=1.0 - top / height,
                           hspace=hspace / axes_h, wspace=wspace / axes_w)
    return figure


def pin_titles(figure: Figure) -> None:
    """Fix every axes title at the top of its axes (y = 1), as placed when nothing is above.

    Left to itself, matplotlib measures the tick labels of every titled axes
    (and its twins) again at each draw to lift the title over labels at the
    top; the report's figures have none there, and the measuring was a fifth
    of their drawing time. Text, size and weight are kept.
    """
    for ax in figure.axes:
        for loc in ("left", "center", "right"):
            text = ax.get_title(loc=loc)
            if text:
                title = ax.title if loc == "center" else getattr(ax, f"_{loc}_title")
                ax.set_title(text, loc=loc, y=1.0, fontsize=title.get_fontsize(),
                             fontweight=title.get_fontweight(), color=title.get_color())


def _row_major(count: int, cols: int) -> list[int]:
    """The order that makes a column-filled legend of ``cols`` columns read row by row.

    Examples
    --------
    >>> _row_major(7, 4)
    [0, 4, 1, 5, 2, 6, 3]
    """
    rows = -(-count // cols)
    return [r * cols + c for c in range(cols) for r in range(rows) if r * cols + c < count]


_SUPERSCRIPTS = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _power_of_ten(x: float, _pos: int | None = None) -> str:
    """``10⁻⁶`` for a power of ten, else the number (plain text, no mathtext)."""
    if x <= 0:
        return ""
    exponent = float(np.log10(x))
    if abs(exponent - round(exponent)) < 1e-9:
        return "10" + str(int(round(exponent))).translate(_SUPERSCRIPTS)
    return f"{x:g}"


def plain_log_labels(axis: Axis) -> None:
    """Label a logarithmic axis as ``10ⁿ`` in plain text (minor ticks 2 and 5 on short spans).

    matplotlib's default labels are mathtext, whose parsing costs about a
    second per figure; plain Unicode superscripts look the same in an SVG.
    """
    def minor(x: float, _pos: int | None = None) -> str:
        lo, hi = sorted(abs(v) for v in axis.get_view_interval())
        if x <= 0 or lo <= 0 or hi / lo > 100:  # two decades or more: majors suffice
            return ""
        lead = x / 10 ** np.floor(np.log10(x))
        return f"{x:g}" if round(lead) in (2, 5) else ""

    axis.set_major_formatter(FuncFormatter(_power_of_ten))
    axis.set_minor_formatter(FuncFormatter(minor))
    axis.set_minor_locator(_LogMinor())


_EVERY = (2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0)


class _LogMinor(LogLocator):
    """Minor ticks of a log axis: 2, …, 9 on spans up to two decades, 2 and 5 on longer ones.

    Every tick is a handful of artists, each drawn into the SVG: with all
    eight minor ticks per decade the string-stability figure of the CRH2
    report (eight log-log panels, five to seven decades each) spent 0.5 s of
    its 0.7 s on minor ticks; 2 and 5 mark a long decade as well.
    """

    def __init__(self) -> None:
        super().__init__(base=10.0, subs=_EVERY)

    def tick_values(self, vmin: float, vmax: float) -> Any:
        lo, hi = sorted((abs(vmin), abs(vmax)))
        long = lo > 0 and hi / lo > 100.0
        self.set_params(subs=(2.0, 5.0) if long else _EVERY)
        return super().tick_values(vmin, vmax)
