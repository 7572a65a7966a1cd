# The report's frequency-domain figures of the linear closed loops, strategies overlaid.
"""Singular-value, sensitivity and grade-step figures of a report.

Drawn from :attr:`ReportData.frequency` (the curves of
:meth:`trainctl.analysis.ClosedLoopResponse.curves`), one figure per
quantity with every strategy overlaid in the colours and line styles of the
time-domain figures. The definitions (S and T at the plant input, in
specific-force units; the bandwidth of the common-mode T) are those of
:mod:`trainctl.analysis.sensitivity`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from trainctl.plots import frequency as freqplot
from trainctl.plots._common import fixed_margins, legend_outside, series_style

if TYPE_CHECKING:
    from trainctl.report.figures import ReportFigure

__all__ = ["frequency_figures"]

_SIGMA = (
    ("speed", "sigma-speed", "Grade disturbance to speed error",
     "σ(G_wv) [(m/s)/(m/s²)]",
     "Singular values of the linear closed loop from a specific-force disturbance on each "
     "vehicle w [m/s²] to the speed errors [m/s]: thick the largest (the worst direction), thin "
     "the others. A 1 ‰ grade is w = g·10⁻³ ≈ 0.0098 m/s², so a gain of 100 means about "
     "1 m/s of speed error per ‰ of grade varying at that frequency. The curves end at the "
     "Nyquist frequency π/T."),
    ("force", "sigma-force", "Grade disturbance to coupler force",
     "σ(G_wf) [kN/(m/s²)]",
     "Singular values from the disturbance w [m/s²] to the coupler forces [kN]; thick the "
     "largest. Multiply by g·10⁻³ for kN per ‰ of grade."),
    ("sensitivity", "sensitivity", "Input sensitivity S",
     "σ(S) [-]",
     "Singular values of the input sensitivity S = (I + L)⁻¹, the loop broken at the plant "
     "input in specific-force units: from a disturbance w to the total specific force the "
     "vehicles feel (w plus the controller's answer). Below 1 the controller attenuates the "
     "disturbance, above 1 it amplifies it; the peak ‖S‖∞ is the inverse of the smallest "
     "distance of the loop to instability (dashed: 1)."),
    ("complementary", "complementary", "Complementary sensitivity T",
     "σ(T) [-]",
     "Singular values of T = L(I + L)⁻¹ = I − S: the controller's counter-force per unit of "
     "disturbance. Short thick ticks at the bottom: the bandwidth, where the common-mode T "
     "(a uniform grade on every vehicle) has fallen 3 dB below its DC gain (python-control's "
     "definition, on the unit circle); none where a closed-loop pole at z = 1 makes the DC "
     "gain infinite."),
)


def frequency_figures(curves: Mapping[str, Mapping[str, Any]],
                      make: Callable[..., ReportFigure]) -> Iterator[ReportFigure]:
    """The frequency-domain figures of the report's linear closed loops.

    Parameters
    ----------
    curves : mapping of str to mapping
        By strategy, :meth:`ClosedLoopResponse.curves` (``frequency`` and
        ``steps``); empty: no figures.
    make : callable
        ``make(key, title, caption, figure)`` encodes a figure.

    Yields
    ------
    ReportFigure
        Disturbance → speed error and → coupler force, S and T (when the
        loops have them), the grade-step responses, then the string-stability
        gains (when the loops have spacing or coupler-force outputs).

    Examples
    --------
    The curves of the CRH2 scenario's linear closed loops; a ``make`` that
    keeps only the keys lists the figures:

    >>> import trainctl
    >>> from trainctl.run.analysis import run_scenario
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> curves = {name: loop.curves() for name, loop in run.frequency.items()}
    >>> def key_only(key, title, caption, figure, **kwargs):  # keep the key, drop the drawing
    ...     return key
    >>> list(frequency_figures(curves, key_only))[:2]
    ['sigma-speed', 'sigma-force']
    >>> list(frequency_figures({}, key_only))  # no loops, no figures
    []
    """
    if not curves:
        return
    for quantity, key, title, ylabel, caption in _SIGMA:
        present = {k: c["frequency"] for k, c in curves.items()
                   if _positive(c["frequency"].get(quantity))}
        if present:
            yield make(key, title, caption,
                       _sigma_figure(present, quantity, ylabel, order=list(curves)))
    yield _steps(curves, make)
    strings = {k: c["string"] for k, c in curves.items() if c.get("string")}
    if strings:
        yield make("string-stability", "String stability: head disturbance along the train",
                   _STRING_CAPTION, _string_figure(strings))


def _positive(rows: Any) -> bool:
    """True for gain curves with a positive value (a loop without coupler forces has none)."""
    return rows is not None and any(max(row, default=0.0) > 0 for row in rows)


def _sigma_figure(curves: Mapping[str, Mapping[str, Any]], quantity: str, ylabel: str, *,
                  order: list[str]) -> Figure:
    figure = Figure(figsize=(7.5, 3.9))
    ax = figure.add_subplot()
    for name, c in curves.items():
        style = series_style(order.index(name))
        freqplot.sigma_plot(c["omega"], c[quantity], label=name, ylabel=ylabel, ax=ax, **style)
        if quantity == "complementary" and c.get("bandwidth"):
            ax.axvline(c["bandwidth"], ymax=0.1, color=style["color"], linewidth=2.0)
    if quantity in ("sensitivity", "complementary"):
        ax.axhline(1.0, color="0.3", linestyle="--", linewidth=0.9)
    top = max(max(max(row) for row in c[quantity]) for c in curves.values())
    if top > 0:  # four decades below the largest gain: directions that matter
        ax.set_ylim(bottom=max(ax.get_ylim()[0], top * 1e-4))
    _nyquist(ax, curves)
    legend_outside(figure)
    return fixed_margins(figure)


def _nyquist(ax: Axes, curves: Mapping[str, Mapping[str, Any]]) -> None:
    rates = {round(float(c["nyquist"]), 12) for c in curves.values()}
    for w in rates:
        ax.axvline(w, color="0.5", linestyle=":", linewidth=0.9)
        ax.annotate("π/T", xy=(w, 1.0), xycoords=("data", "axes fraction"), ha="right",
                    va="top", fontsize="x-small", color="0.35")


def _steps(curves: Mapping[str, Mapping[str, Any]],
           make: Callable[..., ReportFigure]) -> ReportFigure:
    figure = Figure(figsize=(7.5, 5.6))
    axes = figure.subplots(2, 2, sharex=True)
    panels = (("speeds", "speed deviation [m/s]", axes[0, 0]),
              ("forces", "coupler force [kN]", axes[0, 1]),
              ("head_speeds", "speed deviation [m/s]", axes[1, 0]),
              ("head_forces", "coupler force [kN]", axes[1, 1]))
    for k, (name, c) in enumerate(curves.items()):
        steps = c["steps"]
        for field, ylabel, ax in panels:
            if steps[field]:
                freqplot.step_response_plot(steps["time"], steps[field], label=name,
                                            ylabel=ylabel, ax=ax, **series_style(k))
    axes[0, 0].set_title("1 ‰ grade on every vehicle", loc="left", fontsize="small")
    axes[0, 1].set_title("… its coupler forces", loc="left", fontsize="small")
    axes[1, 0].set_title("1 ‰ grade on vehicle 1 (head) only", loc="left", fontsize="small")
    axes[1, 1].set_title("… its coupler forces", loc="left", fontsize="small")
    for ax in axes.ravel():
        ax.tick_params(labelsize="small")
    for ax in axes[0]:
        ax.set_xlabel("")
    handles = [Line2D([], [], linewidth=1.3, label=name, **series_style(k))
               for k, name in enumerate(curves)]
    legend_outside(figure, handles)
    fixed_margins(figure, top=0.3, hspace=0.45, wspace=0.85)
    caption = ("Responses of the linear closed loops (unconstrained, at the linearisation "
               "speed) to a 1 ‰ down-grade step, w = g·10⁻³ m/s², starting at t = 0: on every "
               "vehicle (top) and on the head vehicle only (bottom). One line per vehicle or "
               "coupler, in the strategy's colour. control.step_response on each loop.")
    return make("grade-step", "Grade-step responses", caption, figure)


_STRING_CAPTION = (
    "Gain from a specific-force disturbance on the head vehicle, w[0] [m/s²], to each spacing "
    "deviation d[i] [m] (left) and each coupler force f[i] [kN] (right), one line per coupler, "
    "dark at the head, light at the tail; a dot marks each peak. The train is string stable "
    "when the peaks do not grow towards the tail (trainctl.analysis.string_stability; the "
    "review's check judges the primary family's first strategy). One row per strategy; "
    "coupler forces are absent for virtual links.")

_STRING_PANELS = (("d", "|G_wd| [m/(m/s²)]"), ("f", "|G_wf| [kN/(m/s²)]"))


def _string_figure(strings: Mapping[str, Mapping[str, Any]]) -> Figure:
    figure = Figure(figsize=(7.5, 0.6 + 2.1 * len(strings)))
    axes = figure.subplots(len(strings), 2, sharex=True, squeeze=False)
    for row, (name, c) in zip(axes, strings.items(), strict=True):
        for ax, (quantity, ylabel) in zip(row, _STRING_PANELS, strict=True):
            chain = c["chains"].get(quantity)
            if chain is None:
                ax.set_axis_off()
                continue
            freqplot.string_gain_plot(c["omega"], chain["gains"], labels=chain["labels"],
                                      ylabel=ylabel, ax=ax)
            ax.set_title(name, loc="left", fontsize="small")
            ax.tick_params(labelsize="small")
            if c.get("nyquist"):
                ax.axvline(c["nyquist"], color="0.5", linestyle=":", linewidth=0.9)
        row[0].legend(fontsize="x-small", ncols=2, loc="lower left")
    for row in axes[:-1]:  # the shared frequency axis is labelled once, at the bottom
        for ax in row:
            ax.set_xlabel("")
    return fixed_margins(figure, top=0.3, hspace=0.45, wspace=0.85)
