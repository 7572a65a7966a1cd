# The report's figures: built with the public plot functions, encoded as inline SVG.
"""Figures of a report, as inline SVG.

Each figure is a :class:`matplotlib.figure.Figure` (no pyplot, no global
figure registry) drawn with the same functions notebooks use
(:mod:`trainctl.plots.time`), encoded with :func:`figure_svg` and then dropped.

:func:`figure_svg` makes the SVG fit for inlining and for byte-identical
output: a fixed hash salt (clip-path ids), no date or tool metadata, text as
``<text>`` elements rather than glyph paths, the XML prolog, DOCTYPE,
comments and ``<metadata>`` removed, and every id prefixed so that several
SVGs share one HTML page without id clashes.
"""

from __future__ import annotations

import io
import re
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import matplotlib
import numpy as np
from markupsafe import Markup
from matplotlib.figure import Figure
from numpy.typing import NDArray

from trainctl.plots import time as plot
from trainctl.plots._common import pin_titles

if TYPE_CHECKING:
    from trainctl.report.data import ReportData

__all__ = [
    "FIGURES_SECTION", "OPEN_LOOP_LABEL", "ReportFigure", "eigenvalue_figure", "encode",
    "family_section", "figure_svg", "report_figures",
]

SVG_HASH_SALT = "trainctl"
"""``svg.hashsalt``: makes matplotlib's clip-path ids reproducible."""

_SVG_RC: dict[str, Any] = {
    "svg.hashsalt": SVG_HASH_SALT,
    "svg.fonttype": "none",  # <text> elements: smaller, selectable, no glyph defs
    "svg.image_inline": True,
    "font.family": "sans-serif",
}
_STRIP = (
    re.compile(r"<\?xml[^>]*\?>\s*"),
    re.compile(r"<!DOCTYPE[^>]*>\s*", re.IGNORECASE),
    re.compile(r"<!--.*?-->\s*", re.DOTALL),
    re.compile(r"<metadata>.*?</metadata>\s*", re.DOTALL),
)
_ID = re.compile(r'\bid="([^"]+)"')
_REF = re.compile(r'(url\(#|xlink:href="#|href="#)([^)"]+)')
_PATH = re.compile(r'( d=")([^"]*)(")')
_FINE = re.compile(r"-?\d+\.\d{3,}")


def _coarser(match: re.Match[str]) -> str:
    """A path's ``d`` with its coordinates to 0.01 pt (matplotlib writes six decimals).

    A hundredth of a point is 1/7200 inch, far below any screen's pixel; six
    decimals made the traces of the default report's figures about twice as
    large as they need to be.
    """
    d = _FINE.sub(lambda m: f"{float(m.group(0)):.2f}", match.group(2))
    return f"{match.group(1)}{d}{match.group(3)}"


FIGURES_SECTION = "figures"
"""Section id of the page's Figures section (the default :attr:`ReportFigure.section`)."""


def family_section(name: str) -> str:
    """Section id of a controller family's part of the page.

    Parameters
    ----------
    name : str
        The family's name.

    Returns
    -------
    str
        The HTML id of its section.

    Examples
    --------
    >>> family_section("potential")
    'family-potential'
    """
    return f"family-{name}"


@dataclass(frozen=True)
class ReportFigure:
    """One figure of the report.

    Parameters
    ----------
    key : str
        Stable identifier (HTML anchor), e.g. ``"velocity"``.
    title : str
        Caption title.
    caption : str
        What the figure shows, with units.
    svg : markupsafe.Markup
        The inline ``<svg>`` element.
    section : str
        Id of the page section that shows it: :data:`FIGURES_SECTION` (the
        Figures section), or a controller family's section
        (:func:`family_section`), where the figure follows the family's
        partial; a family section that is not on the page (a family without
        a partial) leaves the figure to the Figures section.

    Examples
    --------
    >>> fig = Figure(figsize=(2, 1))
    >>> _ = fig.add_subplot().plot([0, 1], [1, 0])
    >>> f = ReportFigure("demo", "A line", "y = 1 − x [-].", figure_svg(fig, prefix="fig-demo"))
    >>> f.key, f.section, f.svg.startswith("<svg")
    ('demo', 'figures', True)
    """

    key: str
    title: str
    caption: str
    svg: Markup
    section: str = FIGURES_SECTION


def figure_svg(figure: Figure, *, prefix: str) -> Markup:
    """Encode a figure as an inline SVG element and release it.

    Parameters
    ----------
    figure : matplotlib.figure.Figure
        The figure (cleared afterwards).
    prefix : str
        Prefix for every id in the SVG (``[A-Za-z][A-Za-z0-9-]*``), unique
        per page.

    Returns
    -------
    markupsafe.Markup
        ``<svg ...>...</svg>``, safe to place in a template unescaped.

    Examples
    --------
    >>> fig = Figure(figsize=(2, 1))
    >>> _ = fig.add_subplot().plot([0, 1], [1, 0])
    >>> svg = figure_svg(fig, prefix="f1")
    >>> svg.startswith("<svg"), "<?xml" in svg, 'id="f1-' in svg
    (True, False, True)
    """
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9-]*", prefix):
        raise ValueError(f"figure_svg: prefix must match [A-Za-z][A-Za-z0-9-]* (got {prefix!r})")
    buffer = io.StringIO()
    with matplotlib.rc_context(_SVG_RC):  # type: ignore[arg-type]
        figure.savefig(buffer, format="svg", metadata={"Date": None, "Creator": None})
    figure.clear()
    text = buffer.getvalue()
    for pattern in _STRIP:
        text = pattern.sub("", text)
    text = _PATH.sub(_coarser, text)
    text = _ID.sub(lambda m: f'id="{prefix}-{m.group(1)}"', text)
    text = _REF.sub(lambda m: f"{m.group(1)}{prefix}-{m.group(2)}", text)
    start = text.find("<svg")
    if start < 0:
        raise ValueError("figure_svg: matplotlib produced no <svg> element")
    svg = text[start:].strip()
    # Scale with the page: keep the viewBox, let CSS set the width.
    svg = re.sub(r'<svg([^>]*?) width="[^"]*" height="[^"]*"',
                 r'<svg\1 role="img" class="figure"', svg, count=1)
    return Markup(svg)


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


def encode(key: str, title: str, caption: str, figure: Figure, *,
           section: str = FIGURES_SECTION) -> ReportFigure:
    """A :class:`ReportFigure` from a drawn figure (encoded as SVG, then released).

    Parameters
    ----------
    key : str
        Stable identifier, also the SVG id prefix ``fig-<key>``.
    title, caption : str
        Caption title and text.
    figure : matplotlib.figure.Figure
        The drawing.
    section : str
        The page section that shows it (:attr:`ReportFigure.section`).

    Returns
    -------
    ReportFigure
        The figure for the page.

    Examples
    --------
    >>> fig = Figure(figsize=(2, 1))
    >>> _ = fig.add_subplot().plot([0, 1], [1, 0])
    >>> f = encode("demo", "A line", "y = 1 − x [-].", fig)
    >>> f.key, f.section, 'id="fig-demo-' in f.svg
    ('demo', 'figures', True)
    """
    return ReportFigure(key, title, caption, figure_svg(figure, prefix=f"fig-{key}"),
                        section=section)


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
