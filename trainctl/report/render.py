# HTML report rendering: Jinja environment, package templates, atomic writes.
"""Render report pages with the package templates and write them (atomically to files).

The templates (``templates/*.html.j2``) and the stylesheet
(``static/report.css``) are package data, loaded by package name; the
stylesheet is inlined, so a page loads no external resource and runs no
JavaScript. Autoescape is on and undefined names are errors: every string from
a scenario file is escaped, and a template typo fails the render instead of
printing nothing. Contexts come from :mod:`trainctl.report.context`.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import jinja2
from markupsafe import Markup

from trainctl.naming import printable
from trainctl.report.output import OutputTarget, write_output
from trainctl.report.output import write_text_atomic as write_text_atomic

__all__ = [
    "make_environment",
    "render_index",
    "render_report",
    "write_report",
    "write_text_atomic",
]

REPORT_TEMPLATE = "report.html.j2"
INDEX_TEMPLATE = "index.html.j2"
_CSS_RESOURCE = ("static", "report.css")
FAMILY_TEMPLATES = "families/"
"""Template names ``families/<family>.html.j2`` load the family's ``report_partial``."""


# --------------------------------------------------------------------------- environment


def make_environment() -> jinja2.Environment:
    """Create the Jinja environment for the report templates.

    Returns
    -------
    jinja2.Environment
        Loads from the package's ``templates`` directory (and the report
        sections of controller families as ``families/<name>.html.j2``),
        escapes every substituted value (HTML's special characters as
        entities, control characters as ``\\uXXXX``: no NUL, terminal escape
        or bidirectional override reaches a page) and fails on undefined names.

    Examples
    --------
    >>> env = make_environment()
    >>> env.from_string("{{ x }}").render(x="<b>")
    '&lt;b&gt;'
    >>> env.from_string("{{ x }}").render(x="\\x1b[31m\\u202e")
    '\\\\u001b[31m\\\\u202e'
    """
    return jinja2.Environment(
        loader=jinja2.ChoiceLoader([jinja2.PackageLoader("trainctl.report", "templates"),
                                    _FamilyLoader()]),
        autoescape=True,
        finalize=_printable,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


def _printable(value: Any) -> Any:
    """Every substituted string, markup too, with its control characters escaped."""
    if value is None or isinstance(value, (bool, int, float)):
        return value
    if hasattr(value, "__html__"):
        return Markup(printable(value.__html__()))
    return printable(str(value))


class _FamilyLoader(jinja2.BaseLoader):
    """``families/<family>.html.j2``: the report section (``report_partial``) of a family."""

    def get_source(
        self, environment: jinja2.Environment, template: str
    ) -> tuple[str, str | None, Any]:
        from trainctl.exceptions import ScenarioError
        from trainctl.registry import get_family

        name = template.removeprefix(FAMILY_TEMPLATES).removesuffix(".html.j2")
        if f"{FAMILY_TEMPLATES}{name}.html.j2" != template:
            raise jinja2.TemplateNotFound(template)
        try:
            source = get_family(name).report_partial
        except ScenarioError:
            raise jinja2.TemplateNotFound(template) from None
        return source, None, lambda: False  # never cached across families' changes

    def list_templates(self) -> list[str]:
        from trainctl.registry import family_names

        return [f"{FAMILY_TEMPLATES}{name}.html.j2" for name in family_names()]


@lru_cache(maxsize=1)
def _stylesheet() -> str:
    css = resources.files("trainctl.report").joinpath(*_CSS_RESOURCE).read_text(encoding="utf-8")
    if "</" in css:
        raise ValueError("report.css must not contain '</' (it is inlined in a <style> block)")
    return css


# --------------------------------------------------------------------------- render / write


def render_report(context: Mapping[str, Any]) -> str:
    """Render a scenario's report page.

    Parameters
    ----------
    context : Mapping
        From :func:`trainctl.report.build_report_context`.

    Returns
    -------
    str
        A complete, self-contained HTML5 document.

    Examples
    --------
    The CRH2 design review (no simulation), rendered; the page loads
    nothing from elsewhere:

    >>> import trainctl
    >>> from trainctl.report import build_report_context, collect_report_data
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> context = build_report_context(collect_report_data(run, scenario_text=text),
    ...                                deterministic=True)
    >>> html = render_report(context)
    >>> html.startswith("<!DOCTYPE html>"), "<script" in html, 'src="http' in html
    (True, False, False)
    """
    template = make_environment().get_template(REPORT_TEMPLATE)
    return template.render(**context, css=Markup(_stylesheet()))


def render_index(context: Mapping[str, Any]) -> str:
    """Render the gallery page of several reports.

    Parameters
    ----------
    context : Mapping
        From :func:`trainctl.report.build_index_context`.

    Returns
    -------
    str
        A complete, self-contained HTML5 document.

    Examples
    --------
    >>> from trainctl.report import build_index_context
    >>> entry = {"name": "CRH2", "href": "crh2-dmpc.html", "description": "half train",
    ...          "headline": "19 checks", "source": "builtin:crh2-dmpc"}
    >>> html = render_index(build_index_context([entry], deterministic=True))
    >>> html.startswith("<!DOCTYPE html>"), 'href="crh2-dmpc.html"' in html
    (True, True)
    """
    template = make_environment().get_template(INDEX_TEMPLATE)
    return template.render(**context, css=Markup(_stylesheet()))


def write_report(html: str, path: str | os.PathLike[str] | OutputTarget) -> Path:
    """Write a rendered report: a file atomically, a device or pipe through.

    Parameters
    ----------
    html : str
        The page from :func:`render_report` or :func:`render_index`.
    path : str, os.PathLike or OutputTarget
        Destination, e.g. ``reports/crh2-dmpc.html``, ``/dev/null`` or an
        :class:`~trainctl.report.output.OutputTarget` (``-`` for standard
        output); see :func:`~trainctl.report.output.write_output`.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    OutputError
        For a target that is neither a regular file, a new path, a character
        device, a pipe nor standard output.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_report("<!DOCTYPE html><title>t</title>", Path(tmp) / "r.html")
    ...     text = path.read_text(encoding="utf-8")
    >>> path.name, text
    ('r.html', '<!DOCTYPE html><title>t</title>')
    """
    return write_output(html, path)
