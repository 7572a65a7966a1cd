# Figures encoded as inline SVG: byte-identical, id-prefixed, ready for an HTML page.
"""Matplotlib figures encoded as inline SVG, and the figure record of a page.

:func:`figure_svg` makes the SVG fit for inlining and for byte-identical
output: a fixed hash salt (clip-path ids), no date or tool metadata, text as
``<text>`` elements rather than glyph paths, the XML prolog, DOCTYPE,
comments and ``<metadata>`` removed, and every id prefixed so that several
SVGs share one HTML page without id clashes. :func:`encode` wraps a drawn
figure in a :class:`ReportFigure`, the record the report (:mod:`trainctl.report`)
and the controller families' figure hooks hand over.
"""

from __future__ import annotations

import io
import re
from dataclasses import dataclass
from typing import Any

import matplotlib
from markupsafe import Markup
from matplotlib.figure import Figure

__all__ = ["FIGURES_SECTION", "SVG_HASH_SALT", "ReportFigure", "encode", "family_section",
           "figure_svg"]

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
