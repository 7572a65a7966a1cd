# HTML reports: build a context, render it with the package templates, write it.
"""Self-contained HTML reports (no external resources, no JavaScript).

Examples
--------
>>> from trainctl.report import make_environment
>>> make_environment().autoescape
True
"""

from __future__ import annotations

from .render import build_summary_context as build_summary_context
from .render import make_environment as make_environment
from .render import render_summary_report as render_summary_report
from .render import write_report as write_report

__all__ = [
    "build_summary_context",
    "make_environment",
    "render_summary_report",
    "write_report",
]
