# The documentation site: built with warnings as errors, links resolve, pages load cleanly.
"""Build the Sphinx site once and check what a reader meets.

The site is built from ``docs/`` into a temporary directory by
``sphinx-build -W`` in a subprocess (Sphinx's own warnings would otherwise
meet pytest's ``filterwarnings = error``), with ``TRAINCTL_TUTORIAL_SHORT=1``
so that the tutorials run their shortened simulations. Then every internal
link of every page must reach a file (and its ``#anchor`` an element id on
that page), and the front page, an API page and a tutorial page must load in
headless Chromium without a console message.

Without Sphinx (the ``docs`` extra) these tests are skipped with the reason;
with ``CI=true`` that is a failure.
"""

from __future__ import annotations

import html.parser
import importlib.util
import os
import re
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

from tests import chromium

pytestmark = pytest.mark.slow

E2E = pytest.mark.e2e
"""The site-building tests (the Sphinx build of the whole site): `make test-e2e`."""

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
MISSING = [name for name in ("sphinx", "pydata_sphinx_theme", "numpydoc", "sphinx_gallery")
           if importlib.util.find_spec(name) is None]


THEME_LOG = re.compile(r'"\[PST\]: (Changed to \w+ mode using the \w+ theme\.'
                       r'|Scrolled sidebar using (last active link|stored browser position)'
                       r'\.\.\.)"')
"""The theme script's informational messages (console.log of the colour mode and the
sidebar's scroll position), the only console lines a clean page shows."""


def _need_sphinx() -> None:
    if not MISSING:
        return
    reason = (f"the docs extra is not installed (missing {', '.join(MISSING)}); "
              "`pip install -e '.[docs]'` or `make docs` installs it")
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(reason + " — required in CI (CI=true)")
    pytest.skip(reason)


SITE_ENV = "TRAINCTL_DOCS_SITE"
"""An HTML site built by ``make docs`` (warnings are errors there too) to check instead of
building one: CI builds the site anyway, and the check need not build it twice."""


@pytest.fixture(scope="session")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The HTML site, built once with warnings as errors and short tutorials; or the site
    :data:`SITE_ENV` names, already built so (``.ci/run``: ``make docs``, the full build)."""
    given = os.environ.get(SITE_ENV, "")
    if given:
        built = Path(given).resolve()
        assert (built / "index.html").is_file(), f"{SITE_ENV}={given}: no index.html there"
        return built
    _need_sphinx()
    out = tmp_path_factory.mktemp("docs-site") / "html"
    env = {**os.environ, "TRAINCTL_TUTORIAL_SHORT": "1", "PYTHONWARNINGS": "default"}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    start = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         "-d", str(out.parent / "doctrees"), str(DOCS), str(out)],
        capture_output=True, text=True, env=env, cwd=ROOT, timeout=900, check=False)
    seconds = time.perf_counter() - start
    assert result.returncode == 0, (f"sphinx-build failed after {seconds:.0f} s:\n"
                                    + result.stderr[-6000:])
    assert (out / "index.html").is_file()
    return out


class _Links(html.parser.HTMLParser):
    """The href/src values and the element ids of one page."""

    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        for name, value in attrs:
            if value is None:
                continue
            if name in ("href", "src"):
                self.links.append(value)
            elif name in ("id", "name"):
                self.ids.add(value)


def _parse(page: Path) -> _Links:
    parser = _Links()
    parser.feed(page.read_text(encoding="utf-8"))
    return parser


def broken_links(root: Path) -> list[str]:
    """Every internal link under ``root`` that reaches no file, or no id on its page."""
    pages = {page: _parse(page) for page in sorted(root.rglob("*.html"))
             if "_static" not in page.relative_to(root).parts}  # theme templates, not pages
    broken = []
    for page, parsed in pages.items():
        for link in parsed.links:
            parts = urlsplit(link)
            if parts.scheme or parts.netloc or link.startswith(("//", "mailto:", "data:")):
                continue  # external: not checked (the build has no network)
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if target.is_dir():
                target = target / "index.html"
            where = f"{page.relative_to(root)}: {link}"
            if not target.is_file():
                broken.append(f"{where} (no file)")
            elif parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{where} (no id {parts.fragment!r})")
    return broken


def test_link_check_sees_broken_links(tmp_path: Path) -> None:
    """A missing file and a missing anchor are both reported: the check can fail."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "a.html").write_text(
        '<html><body><p id="here">x</p><a href="sub/b.html#there">b</a>'
        '<a href="missing.html">m</a><a href="#here">self</a><a href="#gone">gone</a>'
        '<a href="https://example.org/x">external</a><img src="sub/pic.png"></body></html>',
        encoding="utf-8")
    (tmp_path / "sub" / "b.html").write_text('<html><body id="top"></body></html>',
                                             encoding="utf-8")
    found = broken_links(tmp_path)
    assert len(found) == 4, found
    assert any("missing.html (no file)" in f for f in found)
    assert any("sub/pic.png (no file)" in f for f in found)
    assert any("no id 'there'" in f for f in found) and any("no id 'gone'" in f for f in found)


@E2E
def test_site_has_its_pages(site: Path) -> None:
    """The front page, the usage page, the tutorials, the assignment and the API reference."""
    for page in ("index.html", "usage.html", "auto_tutorials/index.html",
                 "assignment/index.html", "api/index.html",
                 "api/generated/trainctl.scenario.files.html"):
        assert (site / page).is_file(), page
    front = re.sub(r"<[^>]+>", "", (site / "index.html").read_text(encoding="utf-8"))
    for text in ("make report", "make test", "make docs"):
        assert text in front, text
    api = (site / "api" / "generated" / "trainctl.scenario.files.html").read_text(encoding="utf-8")
    assert 'id="trainctl.scenario.files.load_scenario"' in api
    tutorials = sorted((site / "auto_tutorials").glob("t[0-9][0-9]_*.html"))
    assert tutorials, "no tutorial page was built"


@E2E
def test_internal_links_resolve(site: Path) -> None:
    """Every href/src without a scheme reaches a file, and its #anchor an id there."""
    found = broken_links(site)
    assert not found, f"{len(found)} broken internal links:\n" + "\n".join(found[:50])


@E2E
def test_pages_load_without_console_messages(site: Path, tmp_path: Path) -> None:
    """The front page, an API page and a tutorial log nothing to the console offline.

    Beyond the theme's informational :data:`THEME_LOG` lines: an error or an
    uncaught exception would show here (a missing file is the link check's job).
    """
    tutorial = sorted((site / "auto_tutorials").glob("t[0-9][0-9]_*.html"))[0]
    for page in (site / "index.html", site / "api" / "generated" / "trainctl.scenario.files.html",
                 tutorial):
        messages = [m for m in chromium.console_of(page, tmp_path / f"profile-{page.stem}")
                    if not THEME_LOG.search(m)]
        assert messages == [], f"{page.relative_to(site)}:\n" + "\n".join(messages)


def test_console_check_sees_errors(tmp_path: Path) -> None:
    """A page that logs an error and throws is caught by the same helper."""
    bad = tmp_path / "bad.html"
    bad.write_text("<!DOCTYPE html><html><body><script>"
                   "console.log('[PST]: Changed to auto mode using the light theme.');"
                   "console.error('boom');throw new Error('bang');</script></body></html>",
                   encoding="utf-8")
    messages = chromium.console_of(bad, tmp_path / "profile")
    assert any("boom" in m for m in messages) and any("bang" in m for m in messages)
    assert sum(bool(THEME_LOG.search(m)) for m in messages) == 1
