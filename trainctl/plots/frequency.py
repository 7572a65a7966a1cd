# Plots of closed-loop frequency and step responses (matplotlib Figure API, never pyplot).
"""Singular-value, grade-step and string-stability plots of the closed loops.

They draw the arrays of :class:`~trainctl.analysis.FrequencyResult` and
:class:`~trainctl.analysis.StepResult` (or their ``curves()``), one
strategy per call, so that several strategies overlay in one axes. Each
draws into ``ax`` or a new ``matplotlib.figure.Figure`` and returns the Axes.

Examples
--------
>>> import numpy as np
>>> w = np.logspace(-2, 0, 5)
>>> ax = sigma_plot(w, [1 / (1 + w), 0.5 / (1 + w)], label="demo")
>>> ax.get_xscale(), ax.get_yscale(), ax.get_xlabel()
('log', 'log', 'frequency ω [rad/s]')
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import ArrayLike

from trainctl.plots._common import new_axes, plain_log_labels

__all__ = ["sigma_plot", "step_response_plot", "string_gain_plot"]


def sigma_plot(
    omega: ArrayLike,
    sigma: ArrayLike,
    *,
    label: str | None = None,
    color: Any = None,
    linestyle: Any = "-",
    ylabel: str = "σ [-]",
    ax: Axes | None = None,
) -> Axes:
    """Singular values of a transfer against frequency, log-log.

    The largest singular value is a solid (or ``linestyle``) line carrying
    ``label``; the others are thin lines of the same colour.

    Parameters
    ----------
    omega : array_like
        Frequencies [rad/s], positive.
    sigma : array_like
        Singular values, shape (k, len(omega)), largest first.
    label : str or None
        Legend label of σ_max.
    color, linestyle : optional
        Style of the lines.
    ylabel : str
        Label of the gain axis, with its unit.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        Log-log axes labelled ``frequency ω [rad/s]`` and ``ylabel``.

    Examples
    --------
    Two singular values at three frequencies: σ_max carries the label, the
    other is a thin line of the same colour:

    >>> ax = sigma_plot([0.1, 1.0, 10.0], [[2.0, 1.0, 0.5], [1.0, 0.5, 0.1]], label="T")
    >>> ax.get_xscale(), ax.get_yscale()
    ('log', 'log')
    >>> [(line.get_label(), line.get_ydata().tolist()) for line in ax.lines][0]
    ('T', [2.0, 1.0, 0.5])
    >>> ax.lines[1].get_color() == ax.lines[0].get_color()
    True
    """
    ax = new_axes(ax)
    w = np.asarray(omega, dtype=float)
    s = np.atleast_2d(np.asarray(sigma, dtype=float))
    positive = w > 0
    shown = np.where(s > 0, s, np.nan)[:, positive]
    (line,) = ax.plot(w[positive], shown[0], linewidth=1.3, linestyle=linestyle, color=color,
                      label=label)
    for row in shown[1:]:
        ax.plot(w[positive], row, linewidth=0.6, alpha=0.45, color=line.get_color())
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_labels(ax.xaxis)
    plain_log_labels(ax.yaxis)
    ax.set_xlabel("frequency ω [rad/s]")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="major", color="0.9", linewidth=0.6)
    return ax


def step_response_plot(
    time: ArrayLike,
    values: ArrayLike,
    *,
    label: str | None = None,
    color: Any = None,
    linestyle: Any = "-",
    ylabel: str = "response",
    ax: Axes | None = None,
) -> Axes:
    """Step responses of several outputs (vehicles or couplers) in one colour.

    Parameters
    ----------
    time : array_like
        Times [s].
    values : array_like
        Responses, shape (outputs, len(time)); the first carries ``label``.
    label : str or None
        Legend label.
    color, linestyle : optional
        Style of the lines.
    ylabel : str
        Label of the value axis, with its unit.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        Axes labelled ``time [s]`` and ``ylabel``.

    Examples
    --------
    >>> ax = step_response_plot([0, 1, 2], [[0, 1, 1], [0, 0.5, 1]], label="demo",
    ...                         ylabel="speed deviation [m/s]")
    >>> len(ax.lines), ax.lines[0].get_label()  # two responses and the zero line
    (3, 'demo')
    """
    ax = new_axes(ax)
    t = np.asarray(time, dtype=float)
    rows = np.atleast_2d(np.asarray(values, dtype=float))
    colour = color
    for k, row in enumerate(rows):
        (line,) = ax.plot(t, row, linewidth=1.0, linestyle=linestyle, color=colour,
                          label=label if k == 0 else None)
        colour = line.get_color()
    ax.axhline(0.0, color="0.6", linewidth=0.6, zorder=0)
    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel)
    return ax


def string_gain_plot(
    omega: ArrayLike,
    gains: ArrayLike,
    *,
    labels: list[str] | None = None,
    ylabel: str = "|G| [-]",
    cmap: str = "viridis",
    ax: Axes | None = None,
) -> Axes:
    """Gain curves of a disturbance to each vehicle's signal along the train, overlaid, log-log.

    One line per channel (spacing or coupler force), head first, coloured
    from the colormap's dark end (head) to its light end (tail); a dot marks
    each curve's largest value. Draws the ``curves()`` of
    :class:`~trainctl.analysis.StringStabilityResult` (``omega`` and
    ``chains[q]["gains"]``) or any |G_i(jω)|.

    Parameters
    ----------
    omega : array_like
        Frequencies [rad/s], positive.
    gains : array_like
        |G_i| per channel, shape (channels, len(omega)), in the unit of ``ylabel``.
    labels : list of str or None
        Legend label per channel (e.g. ``"d[0]"``); None: none.
    ylabel : str
        Label of the gain axis, with its unit.
    cmap : str
        Matplotlib colormap along the train.
    ax : matplotlib.axes.Axes or None
        Axes to draw into; None creates a new Figure.

    Returns
    -------
    matplotlib.axes.Axes
        Log-log axes labelled ``frequency ω [rad/s]`` and ``ylabel``.

    Examples
    --------
    >>> w = np.logspace(-1, 1, 50)
    >>> H = np.abs(1 / (1 - w**2 + 1j * w))
    >>> ax = string_gain_plot(w, [H, H**2, H**3], labels=["d[0]", "d[1]", "d[2]"],
    ...                       ylabel="|G_wd| [m/(m/s²)]")
    >>> len(ax.lines), ax.lines[0].get_label()  # three curves and their peak dots
    (6, 'd[0]')
    """
    from matplotlib import colormaps

    ax = new_axes(ax)
    w = np.asarray(omega, dtype=float)
    rows = np.atleast_2d(np.asarray(gains, dtype=float))
    positive = w > 0
    colours = colormaps[cmap](np.linspace(0.0, 0.85, max(rows.shape[0], 2)))
    for k, row in enumerate(rows):
        shown = np.where(row > 0, row, np.nan)[positive]
        label = labels[k] if labels is not None else None
        ax.plot(w[positive], shown, linewidth=1.1, color=colours[k], label=label)
        if np.any(np.isfinite(shown)):
            top = int(np.nanargmax(shown))
            ax.plot(w[positive][top], shown[top], "o", markersize=3, color=colours[k])
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_labels(ax.xaxis)
    plain_log_labels(ax.yaxis)
    ax.set_xlabel("frequency ω [rad/s]")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="major", color="0.9", linewidth=0.6)
    return ax
