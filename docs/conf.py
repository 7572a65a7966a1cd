"""Sphinx configuration of the trainctl documentation (``make docs``)."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import apigen  # noqa: E402

import trainctl  # noqa: E402

project = "trainctl"
author = "the trainctl authors"
copyright = "the trainctl authors"
version = release = trainctl.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "numpydoc",
    "sphinx_gallery.gen_gallery",
]

# The API pages are written afresh at every build from the modules' __all__.
apigen.write()

exclude_patterns = [
    "_build",
    "Thumbs.db",
    ".DS_Store",
    "tutorials/*.rst",  # the gallery header; sphinx-gallery copies it to auto_tutorials
    "assignment/**.toml",
    "assignment/**.py",
    "assignment/**.yml",
    "assignment/**.yaml",
    "assignment/**.md",
    "api/generated/*.inc",
    "auto_tutorials/*.ipynb",
    "auto_tutorials/*.py",
    "auto_tutorials/*.zip",
    "auto_tutorials/*.json",
]

# Maths is written as plain text and Unicode: no MathJax from a CDN, so the
# pages load offline without console errors.
html_theme = "pydata_sphinx_theme"
html_title = f"trainctl {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
}
html_static_path: list[str] = []
# The theme's script logs an error for a page without a stored colour mode
# unless the default mode is one it knows.
html_context = {"default_mode": "auto"}

autosummary_generate = False
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"  # the numpydoc Parameters sections carry the types and units
autodoc_inherit_docstrings = False

numpydoc_show_class_members = False
numpydoc_show_inherited_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
numpydoc_validation_checks: set[str] = set()  # tests/test_docstrings.py validates instead

sphinx_gallery_conf = {
    "examples_dirs": "tutorials",
    "gallery_dirs": "auto_tutorials",
    "filename_pattern": r"/t\d\d_",
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "plot_gallery": "True",
}

# Docstrings write an absolute value or a norm as |x|, which reStructuredText
# reads as a substitution reference. Outside inline literals, literal blocks
# and doctests, such bars are escaped before the docstring is parsed.
_BARS = re.compile(r"(?<![A-Za-z0-9`|\\])\|(?=[^\s|])([^|`\n]*?[^\s|\\])\|(?![A-Za-z0-9`|])")


def _escape_line(line: str) -> str:
    parts = line.split("``")
    for i in range(0, len(parts), 2):  # the even parts are outside ``...``
        parts[i] = _BARS.sub(lambda m: "\\|" + m.group(1) + "\\|", parts[i])
    return "``".join(parts)


def escape_bars(app: object, what: str, name: str, obj: object, options: object,
                lines: list[str]) -> None:
    """Escape ``|x|`` in a docstring's prose (autodoc-process-docstring)."""
    literal_indent: int | None = None
    in_doctest = False
    for k, line in enumerate(lines):
        stripped = line.strip()
        indent = len(line) - len(line.lstrip())
        if in_doctest:
            if not stripped:
                in_doctest = False
            continue
        if literal_indent is not None:
            if not stripped or indent > literal_indent:
                continue
            literal_indent = None
        if stripped.startswith(">>>"):
            in_doctest = True
            continue
        lines[k] = _escape_line(line)
        if stripped.endswith("::"):
            literal_indent = indent


def setup(app: Any) -> None:
    """Connect the docstring hooks."""
    app.connect("autodoc-process-docstring", escape_bars)
