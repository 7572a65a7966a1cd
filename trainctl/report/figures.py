# The report's figures: built with the public plot functions, encoded as inline SVG.
"""Figures of a report, as inline SVG.

Each figure is a :class:`matplotlib.figure.Figure` (no pyplot, no global
figure registry) drawn with the same functions notebooks use
(:mod:`trainctl.plots.time`), encoded with :func:`~trainctl.plots.svg.figure_svg`
and then dropped. The encoding (:func:`~trainctl.plots.svg.figure_svg`,
:func:`~trainctl.plots.svg.encode`, :class:`~trainctl.plots.svg.ReportFigure`) lives in
:mod:`trainctl.plots.svg`, below the controller families that draw figures too; its
names are re-exported here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from trainctl.plots import time as plot
from trainctl.plots._common import pin_titles
from trainctl.plots.svg import FIGURES_SECTION as FIGURES_SECTION
from trainctl.plots.svg import SVG_HASH_SALT as SVG_HASH_SALT
from trainctl.plots.svg import ReportFigure as ReportFigure
from trainctl.plots.svg import encode as encode
from trainctl.plots.svg import family_section as family_section
from trainctl.plots.svg import figure_svg as figure_svg

if TYPE_CHECKING:
    from trainctl.report.data import ReportData

__all__ = [
    "FIGURES_SECTION", "OPEN_LOOP_LABEL", "SVG_HASH_SALT", "ReportFigure", "eigenvalue_figure",
    "encode", "family_section", "figure_svg", "report_figures",
]

# --------------------------------------------------------------------------- the figure set


OPEN_LOOP_LABEL = "open loop (design model)"
"""Legend label of the open-loop eigenvalues (``spectra["open loop"]``)."""


def report_figures(data: ReportData) -> list[ReportFigure]:
    """The report's figures, in page order.

    Parameters
    ----------
    data : ReportData
        The report's data.

    Returns
    -------
    list of ReportFigure
        Closed-loop figures when there are simulations
        (:func:`~trainctl.report.figures_time.time_figures`), the eigenvalue
        map, the frequency-domain figures of the linear closed loops
        (:func:`~trainctl.report.figures_frequency.frequency_figures`), then
        each controller family's figures (MPC: the ρ(D0)-against-R curve, in
        the Figures section; potential and flocking: the communication graph,
        in their own sections, :mod:`trainctl.plots.graph_figures`).

    Examples
    --------
    The CRH2 design review without simulations: no closed-loop figures,
    the eigenvalue map first, then the linear closed loops' figures:

    >>> import trainctl
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> from trainctl.report import collect_report_data
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> keys = [f.key for f in report_figures(data)]
    >>> keys[:3]
    ['eigenvalues', 'sigma-speed', 'sigma-force']
    >>> "speed" in keys  # no simulation, no speed-tracking figure
    False
    """
    return list(_figures(data))


def _figures(data: ReportData) -> Iterator[ReportFigure]:
    from trainctl.report.figures_frequency import frequency_figures
    from trainctl.report.figures_time import time_figures

    if data.simulations:
        yield from time_figures(data.scenario, data.simulations, encode)
        from trainctl.controllers.hooks import family_hook
        from trainctl.registry import get_family

        for name in data.families:
            yield from family_hook(get_family(name), "claim_figures")(data, encode)
    if data.spectra:
        yield eigenvalue_figure(data.spectra)
    yield from frequency_figures(data.frequency, encode)
    from trainctl.registry import get_family

    for name, family_data in data.families.items():
        yield from get_family(name).report_figures(family_data)


def eigenvalue_figure(spectra: Mapping[str, NDArray[np.complex128]],
                      make: Callable[..., ReportFigure] = encode) -> ReportFigure:
    """The eigenvalue map of the report (``make`` as for :func:`encode`).

    Parameters
    ----------
    spectra : mapping
        Eigenvalues by label (e.g. open loop, each strategy's closed loop).
    make : callable
        Turns the matplotlib figure into a report figure.

    Returns
    -------
    ReportFigure
        The figure.

    Examples
    --------
    The legend gives the spectral radius ρ: |0.5 ± 0.5j| = 0.707 < 0.9,
    so ρ = 0.9. A ``make`` that returns the drawing shows it:

    >>> spectra = {"open loop": np.array([0.9, 0.5 + 0.5j, 0.5 - 0.5j])}
    >>> fig = eigenvalue_figure(spectra, make=lambda key, title, caption, figure: figure)
    >>> [t.get_text() for t in fig.legends[0].get_texts()]
    ['unit circle', 'open loop (design model) (ρ = 0.9)']
    """
    # A fixed layout: constrained layout misplaces an equal-aspect box beside a legend.
    figure = Figure(figsize=(7.5, 4.4))
    ax = figure.add_axes((0.11, 0.11, 0.47, 0.80))
    labelled = {OPEN_LOOP_LABEL if k == "open loop" else k: v for k, v in spectra.items()}
    plot.eigenvalue_plot(labelled, ax=ax)
    ax.set_aspect("equal", adjustable="box")  # a round circle in a square box
    handles = ax.get_legend_handles_labels()[0]
    legend = ax.get_legend()
    if legend is not None:
        legend.remove()
    figure.legend(handles, [str(h.get_label()) for h in handles], loc="upper left",
                  bbox_to_anchor=(0.61, 0.91), fontsize="small", frameon=False)
    pin_titles(figure)
    return make("eigenvalues", "Eigenvalues against the unit circle",
                  "Discrete-time eigenvalues of the open loop (the design model, without the "
                  "book's dummy state) and of the unconstrained closed loops, legend beside "
                  "the circle; ρ is the spectral radius (the dummy state would add an "
                  "eigenvalue 1 to the open loop: both radii are in the model table).", figure)
