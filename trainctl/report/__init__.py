# HTML design reports: collect the data, build a context, render with package templates, write.
"""Self-contained HTML design reports (inline CSS and SVG, no JavaScript, no external resources).

The pipeline, each step usable on its own (e.g. in a notebook):

1. :func:`collect_report_data` — from a :class:`~trainctl.run.analysis.AnalysisRun` to
   a :class:`ReportData` (which :meth:`ReportData.save` / :meth:`ReportData.load`
   write and read: ``trainctl analyse --save DIR``).
2. :func:`build_report_context` — the one pure function from data to
   display values and inline-SVG figures.
3. :func:`render_report` — the package template, autoescaped, strict.
4. :func:`write_report` — atomic write (temporary file, then rename).

The report of a sweep store (``trainctl report SWEEP_DIR``) is
:mod:`trainctl.report.sweep`, on the same environment, stylesheet and writes.

Examples
--------
>>> from trainctl.report import make_environment
>>> make_environment().autoescape
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from trainctl import _lazy_exports

if TYPE_CHECKING:
    from trainctl.report.build import ReportJob as ReportJob
    from trainctl.report.build import normalise_timestamp as normalise_timestamp
    from trainctl.report.build import portable_command as portable_command
    from trainctl.report.build import run_report_data as run_report_data
    from trainctl.report.build import write_gallery as write_gallery
    from trainctl.report.build import write_report_file as write_report_file
    from trainctl.report.context import build_index_context as build_index_context
    from trainctl.report.context import build_report_context as build_report_context
    from trainctl.report.context import headline as headline
    from trainctl.report.data import ReportData as ReportData
    from trainctl.report.data import collect_report_data as collect_report_data
    from trainctl.report.data import is_saved_run as is_saved_run
    from trainctl.report.figures import figure_svg as figure_svg
    from trainctl.report.figures import report_figures as report_figures
    from trainctl.report.render import make_environment as make_environment
    from trainctl.report.render import render_index as render_index
    from trainctl.report.render import render_report as render_report
    from trainctl.report.render import write_report as write_report

__all__ = [
    "ReportData",
    "ReportJob",
    "build_index_context",
    "build_report_context",
    "collect_report_data",
    "figure_svg",
    "headline",
    "is_saved_run",
    "make_environment",
    "normalise_timestamp",
    "portable_command",
    "render_index",
    "render_report",
    "report_figures",
    "run_report_data",
    "write_gallery",
    "write_report",
    "write_report_file",
]

_EXPORTS = {
    "ReportJob": "trainctl.report.build",
    "normalise_timestamp": "trainctl.report.build",
    "portable_command": "trainctl.report.build",
    "run_report_data": "trainctl.report.build",
    "write_gallery": "trainctl.report.build",
    "write_report_file": "trainctl.report.build",
    "build_index_context": "trainctl.report.context",
    "build_report_context": "trainctl.report.context",
    "headline": "trainctl.report.context",
    "ReportData": "trainctl.report.data",
    "collect_report_data": "trainctl.report.data",
    "is_saved_run": "trainctl.report.data",
    "figure_svg": "trainctl.report.figures",
    "report_figures": "trainctl.report.figures",
    "make_environment": "trainctl.report.render",
    "render_index": "trainctl.report.render",
    "render_report": "trainctl.report.render",
    "write_report": "trainctl.report.render",
}
"""Re-exported name -> its module, imported on first use (:func:`trainctl._lazy_exports`)."""

__getattr__, __dir__ = _lazy_exports(__name__, _EXPORTS)
