# The report's figures: built with the public plot functions, encoded as inline SVG.
"""Figures of a report, as inline SVG.

Each figure is a :class:`matplotlib.figure.Figure` (no pyplot, no global
figure registry) drawn with the same functions notebooks use
(:mod:`trainctl.plot`), encoded with :func:`figure_svg` and then dropped.

:func:`figure_svg` makes the SVG fit for inlining and for byte-identical
output: a fixed hash salt (clip-path ids), no date or tool metadata, text as
``<text>`` elements rather than glyph paths, the XML prolog, DOCTYPE,
comments and ``<metadata>`` removed, and every id prefixed so that several
SVGs share one HTML page without id clashes.
"""

from __future__ import annotations

import io
import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import matplotlib
import numpy as np
from markupsafe import Markup
from matplotlib.figure import Figure
from numpy.typing import NDArray

from .. import plot

if TYPE_CHECKING:
    from ..scenario import Scenario
    from ..sim.results import SimulationResult
    from .data import ReportData

__all__ = ["ReportFigure", "figure_svg", "report_figures"]

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
    """

    key: str
    title: str
    caption: str
    svg: Markup


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


def report_figures(data: ReportData) -> list[ReportFigure]:
    """The report's figures, in page order.

    Parameters
    ----------
    data : ReportData
        The report's data.

    Returns
    -------
    list of ReportFigure
        Closed-loop figures (one panel per strategy) when there are
        simulations, then the eigenvalue map, then each controller family's
        figures (MPC: the ρ(D0)-against-R curve).
    """
    return list(_figures(data))


def _figures(data: ReportData) -> Iterator[ReportFigure]:
    sims = data.simulations
    scenario = data.scenario
    if sims:
        limit = getattr(scenario.controller, "coupler_force_limit", np.inf)
        force_bounds = (-limit, limit) if np.isfinite(limit) else None
        settle = scenario.simulation.settle_time if scenario.simulation else None
        yield _panels("velocity", "Speed tracking", sims,
                      lambda r, ax: plot.velocity_plot(r, ax=ax),
                      "Speed of every vehicle [m/s] against the reference (dashed), nonlinear "
                      "plant, per strategy.")
        yield _panels("speed-error", "Speed tracking error", sims,
                      lambda r, ax: plot.speed_error_plot(r, settle_time=settle, ax=ax),
                      "Speed minus reference speed of every vehicle [m/s]; the dotted line "
                      "marks the settle time after which the metrics judge tracking.")
        yield _panels("coupler-force", "Coupler forces", sims,
                      lambda r, ax: plot.coupler_force_plot(r, bounds=force_bounds, ax=ax),
                      "Coupler forces [kN], tension positive; dashed: the coupler-force limit "
                      "(soft constraint) when the controller has one.")
        yield _panels("input", "Traction and braking forces", sims,
                      lambda r, ax: plot.input_plot(r, bounds=input_envelope(scenario, r), ax=ax),
                      "Applied force per vehicle [kN], held over each sample; dashed: the "
                      "traction and braking envelope at the measured speed (widest vehicle).")
        yield _panels("iterations", "Iterations and residuals", sims,
                      lambda r, ax: plot.iterations_plot(r, ax=ax),
                      "Iterations per sample (left) and the last iteration's plan change [kN] "
                      "(right, log scale) for iterating controllers; red crosses mark samples "
                      "that were not solved to optimality.")
    if data.spectra:
        figure = _figure(width=5.6, height=5.0)
        plot.eigenvalue_plot(data.spectra, ax=figure.add_subplot())
        yield ReportFigure("eigenvalues", "Eigenvalues against the unit circle",
                           "Discrete-time eigenvalues of the design model (open loop) and of "
                           "the unconstrained closed loops; ρ in the legend is the spectral "
                           "radius.", figure_svg(figure, prefix="fig-eigenvalues"))
    from ..controllers.registry import get_family

    for name, family_data in data.families.items():
        yield from get_family(name).report_figures(family_data)


def _figure(*, width: float, height: float) -> Figure:
    return Figure(figsize=(width, height), layout="constrained")


def _panels(key: str, title: str, sims: dict[str, SimulationResult], draw: object,
            caption: str) -> ReportFigure:
    figure = _figure(width=7.5, height=2.6 * len(sims) + 0.4)
    axes = figure.subplots(len(sims), 1, sharex=True, squeeze=False)[:, 0]
    for ax, (name, result) in zip(axes, sims.items(), strict=True):
        draw(result, ax)  # type: ignore[operator]
        ax.set_title("")  # the panel is named by its strategy, the figure by its title
        ax.set_title(name, loc="left", fontsize="medium")
        if ax is not axes[-1]:
            ax.set_xlabel("")
    figure.suptitle(title)
    return ReportFigure(key, title, caption, figure_svg(figure, prefix=f"fig-{key}"))


def input_envelope(
    scenario: Scenario, result: SimulationResult
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """Widest braking and traction limits over the vehicles at the measured speeds [N].

    Parameters
    ----------
    scenario : Scenario
        The scenario (its train's traction envelopes).
    result : SimulationResult
        The run (speeds at each sample instant).

    Returns
    -------
    (ndarray, ndarray) or None
        Lower (negative) and upper limits per sample, shape (N,); None
        when the controller does not bound its inputs.
    """
    if scenario.controller is None or not getattr(scenario.controller, "input_bounds", True):
        return None
    speeds = result.velocities[:, :-1]
    up = np.max([veh.envelope.traction_limit(speeds[i], mass=veh.mass)
                 for i, veh in enumerate(scenario.train.vehicles)], axis=0)
    down = np.max([veh.envelope.braking_limit(speeds[i], mass=veh.mass)
                   for i, veh in enumerate(scenario.train.vehicles)], axis=0)
    return -np.asarray(down, dtype=float), np.asarray(up, dtype=float)
