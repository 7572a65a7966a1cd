# The default report in a real headless Chromium: no console errors, a real screenshot.
"""Load ``trainctl report``'s default page in Debian's headless Chromium.

Chromium logs every console message (errors, uncaught exceptions, blocked
loads reported by the page) to stderr as ``...:CONSOLE:...`` lines when run
with ``--enable-logging=stderr``; a clean page logs none. The harness itself
is checked on a page that does produce console errors.

Width at 1280 px. The report runs no JavaScript, so the test measures a copy
of it with one measuring script appended (:data:`MEASURE`): Chromium lays the
page out in a 1280 px wide window, the script records the document's scroll
width, every visible element that reaches outside the window and every
element that scrolls horizontally (``overflow-x`` not visible and content
wider than the box, e.g. a table in a scrolling wrapper), and
``--dump-dom`` prints the page with that record. A page fits when the
document is no wider than the window and the record is empty; the harness
is checked on a page built to overflow both ways.

Outside CI a missing browser skips these tests with a visible reason; with
``CI=true`` it is a failure (``.ci/run`` installs ``chromium``).
"""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from tests import chromium
from trainctl.cli.main import main

pytestmark = pytest.mark.slow

E2E = pytest.mark.e2e
"""Reports rendered in full and laid out in Chromium: `make test-e2e` (the harness
self-checks, one small page each, stay in `make test`)."""

WIDTH = 1280
"""Window width [px] the report must fit."""

MEASURE = """
(function () {
  var vw = document.documentElement.clientWidth, found = [];
  var all = document.body.querySelectorAll('*');
  for (var k = 0; k < all.length; k++) {
    var el = all[k], r = el.getBoundingClientRect();
    if (r.width === 0 && r.height === 0) continue;  // not rendered (a closed <details>)
    var name = el.tagName.toLowerCase() + (el.id ? '#' + el.id : '') +
      (typeof el.className === 'string' && el.className ? '.' + el.className : '');
    if (r.right > vw + 0.5 || r.left < -0.5)
      found.push('outside ' + name + ' ' + Math.round(r.left) + '..' + Math.round(r.right));
    if (getComputedStyle(el).overflowX !== 'visible' && el.scrollWidth > el.clientWidth + 1)
      found.push('scrolls ' + name + ' ' + el.scrollWidth + ' > ' + el.clientWidth);
  }
  var out = document.createElement('pre');
  out.id = 'trainctl-measure';
  out.textContent = JSON.stringify({viewport: vw, width: document.documentElement.scrollWidth,
                                    problems: found});
  document.body.appendChild(out);
})();
"""
"""Appended to a copy of the page: records what does not fit the window."""


def _command(page: Path, profile: Path, height: int, *extra: str) -> list[str]:
    return chromium.command(page, profile, WIDTH, height, *extra)


def _load(page: Path, shot: Path, profile: Path, *, height: int = 3000) -> str:
    """Load ``page`` headless, write a screenshot, return Chromium's stderr."""
    command = _command(page, profile, height, f"--screenshot={shot}")
    result = subprocess.run(command, capture_output=True, text=True, timeout=180, check=False)
    assert result.returncode == 0, result.stderr[-2000:]
    return result.stderr


def _measure(page: Path, tmp: Path) -> dict[str, object]:
    """Lay out a copy of ``page`` with :data:`MEASURE` appended in a 1280 px window."""
    return _inspect(page, tmp, MEASURE, "trainctl-measure")


def _inspect(page: Path, tmp: Path, script: str, output: str) -> dict[str, Any]:
    """Lay out a copy of ``page`` with ``script`` appended; return the JSON it writes to a <pre>."""
    html = page.read_text(encoding="utf-8")
    assert "<script" not in html  # the report itself runs no JavaScript
    copy = tmp / f"{output}-{page.name}"
    copy.write_text(html.replace("</body>", f"<script>{script}</script></body>"),
                    encoding="utf-8")
    result = subprocess.run(_command(copy, tmp / f"profile-{output}", 900, "--dump-dom"),
                            capture_output=True, text=True, timeout=180, check=False)
    assert result.returncode == 0, result.stderr[-2000:]
    found = re.search(rf'<pre id="{output}">(.*?)</pre>', result.stdout, re.DOTALL)
    assert found, f"the script writing {output} did not run"
    text = found.group(1).replace("&gt;", ">").replace("&lt;", "<").replace("&amp;", "&")
    return json.loads(text)


def _figure_texts(html: str) -> dict[str, str]:
    """The text of each figure's inline SVG (legends, labels), by figure key."""
    figures = re.findall(r'<figure id="figure-([\w-]+)">(.*?)</figure>', html, re.DOTALL)
    return {key: " ".join(re.findall(r"<text\b[^>]*>([^<]*)</text>", body))
            for key, body in figures}


_console = chromium.console


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default report (crh2-dmpc), rendered by the CLI."""
    path = tmp_path_factory.mktemp("browser") / "crh2-dmpc.html"
    assert main(["report", "-o", str(path)]) == 0
    return path


@pytest.fixture(scope="module")
def mixed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """crh2-dmpc-well-sampled cut to 20 s: five strategies of two families (MPC, LQR)."""
    from trainctl.scenario import read_scenario_text

    text, _ = read_scenario_text("crh2-dmpc-well-sampled")
    for old, new in (("duration = 1200.0", "duration = 20.0"),
                     ("settle_time = 100.0", "settle_time = 5.0"),
                     ("times = [0.0, 60.0, 460.0, 1020.0, 1200.0]", "times = [0.0, 5.0, 20.0]"),
                     ("speeds_kmh = [72.0, 72.0, 216.0, 288.0, 288.0]",
                      "speeds_kmh = [288.0, 288.0, 295.0]")):
        assert old in text
        text = text.replace(old, new)
    root = tmp_path_factory.mktemp("mixed")
    (root / "mixed.toml").write_text(text, encoding="utf-8")
    path = root / "mixed.html"
    assert main(["report", str(root / "mixed.toml"), "-o", str(path)]) == 0
    return path


FAMILY_SCENARIOS = {"potential": "crh2-potential", "flocking": "heavy-haul-flocking",
                    "hinf": "heavy-haul-hinf-noise"}
"""The scenarios whose primary family exchanges data over a communication graph (the hinf
one with its paper-claims section)."""

GRAPH = """
(function () {
  var figures = document.querySelectorAll('figure[id^="figure-graph-"]');
  var out = {count: figures.length};
  if (figures.length) {
    var fig = figures[0], svg = fig.querySelector('svg'), r = svg.getBoundingClientRect();
    var section = fig.parentElement.closest('section');
    out.id = fig.id;
    out.section = section ? section.id : '';
    out.box = [r.left, r.top, r.width, r.height];
    out.viewport = document.documentElement.clientWidth;
    out.texts = Array.prototype.map.call(svg.querySelectorAll('text'),
                                         function (t) { return t.textContent.trim(); });
    out.caption = fig.querySelector('figcaption').textContent;
  }
  var pre = document.createElement('pre');
  pre.id = 'trainctl-graph';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
})();
"""
"""Appended to a copy of a page: where the graph figure is laid out, and its labels."""


@pytest.fixture(scope="module", params=sorted(FAMILY_SCENARIOS))
def family_report(request: pytest.FixtureRequest,
                  tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """crh2-potential, heavy-haul-flocking and heavy-haul-hinf-noise, each rendered once by
    the CLI (one process)."""
    family = request.param
    name = FAMILY_SCENARIOS[family]
    path = tmp_path_factory.mktemp(f"browser-{family}") / f"{name}.html"
    assert main(["report", name, "-o", str(path), "--jobs", "1"]) == 0
    return family, path


def test_harness_sees_console_errors(tmp_path: Path) -> None:
    """A page that logs an error and throws is caught: the check below can fail."""
    bad = tmp_path / "bad.html"
    bad.write_text("<!DOCTYPE html><html><body><p>x</p><script>console.error('boom');"
                   "throw new Error('bang');</script></body></html>", encoding="utf-8")
    messages = _console(_load(bad, tmp_path / "bad.png", tmp_path / "profile", height=400))
    assert any("boom" in m for m in messages)
    assert any("bang" in m for m in messages)


@E2E
def test_default_report_loads_cleanly(report: Path, tmp_path: Path) -> None:
    """No console message at all, and a screenshot with real content."""
    shot = tmp_path / "report.png"
    stderr = _load(report, shot, tmp_path / "profile")
    assert _console(stderr) == []
    with Image.open(shot) as image:
        assert image.size == (1280, 3000)
        pixels = np.asarray(image.convert("RGB"))
    colours = np.unique(pixels.reshape(-1, 3), axis=0)
    assert len(colours) > 50  # text, badges, tables and figures, not a blank page
    # Not mostly one colour: the background covers well under 99 % of the page.
    background = np.all(pixels == pixels[0, 0], axis=-1).mean()
    assert background < 0.99
    # Ink everywhere down the page, not only in a header.
    ink_rows = np.any(np.any(pixels != pixels[0, 0], axis=-1), axis=1)
    assert ink_rows[:1000].mean() > 0.3 and ink_rows[1000:].mean() > 0.3


def test_harness_sees_overflow(tmp_path: Path) -> None:
    """A page wider than the window, and a table scrolling in its box, are both caught."""
    wide = tmp_path / "wide.html"
    wide.write_text(
        "<!DOCTYPE html><html><body style='margin:0'><div style='width:1500px'>wide</div>"
        "<div style='overflow-x:auto;width:600px'><table><tr><td style='min-width:900px'>"
        "x</td></tr></table></div></body></html>", encoding="utf-8")
    record = _measure(wide, tmp_path)
    assert record["viewport"] == WIDTH and record["width"] > WIDTH
    problems = " ".join(record["problems"])
    assert "outside div" in problems and "scrolls div" in problems


@E2E
def test_default_report_fits_1280(report: Path, tmp_path: Path) -> None:
    """No horizontal overflow at 1280 px: nothing outside the window, nothing scrolling."""
    record = _measure(report, tmp_path)
    assert record["viewport"] == WIDTH
    assert record["width"] <= WIDTH
    assert record["problems"] == []


@E2E
def test_figures_for_every_strategy(report: Path) -> None:
    """Each comparison figure names every strategy; the iterations figure only iterating ones."""
    html = report.read_text(encoding="utf-8")
    texts = _figure_texts(html)
    strategies = ("centralised", "decentralised", "ndmpc")
    for key in ("speed", "coupler-force", "input", "energy", "sigma-speed", "sigma-force",
                "sensitivity", "complementary", "grade-step"):
        assert key in texts, key
        for name in strategies:
            assert re.search(rf"(^|\s){name}(\s|$)", texts[key]), (key, name)
    assert "ndmpc" in texts["iterations"]
    assert not re.search(r"(^|\s)(de)?centralised(\s|$)", texts["iterations"])
    for i in (1, 2, 3, 4):  # one panel per vehicle, numbered from 1
        assert f"vehicle {i}" in texts["speed"] and f"{i} " in texts["input"]


@E2E
def test_mixed_families_report_fits_1280(mixed: Path, tmp_path: Path) -> None:
    """Five strategies with long names (``lqr.decentralised``) still fit, every one drawn."""
    record = _measure(mixed, tmp_path)
    assert record["width"] <= WIDTH and record["problems"] == []
    texts = _figure_texts(mixed.read_text(encoding="utf-8"))
    for name in ("centralised", "decentralised", "ndmpc", "lqr.centralised",
                 "lqr.decentralised"):
        for key in ("speed", "coupler-force", "input", "energy", "sigma-speed",
                    "sensitivity", "grade-step"):
            assert re.search(rf"(^|\s){re.escape(name)}(\s|$)", texts[key]), (key, name)


@E2E
def test_family_report_loads_cleanly(family_report: tuple[str, Path], tmp_path: Path) -> None:
    """The potential, flocking and hinf reports log no console message and fit 1280 px."""
    family, page = family_report
    shot = tmp_path / f"{family}.png"
    assert _console(_load(page, shot, tmp_path / "profile")) == []
    with Image.open(shot) as image:
        pixels = np.asarray(image.convert("RGB"))
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 50  # not a blank page
    record = _measure(page, tmp_path)
    assert record["width"] <= WIDTH and record["problems"] == []


@E2E
def test_family_report_shows_the_graph(family_report: tuple[str, Path], tmp_path: Path) -> None:
    """One graph figure, laid out in the family's section: every vehicle and the reference."""
    from trainctl.scenario import load_scenario

    family, page = family_report
    n = load_scenario(FAMILY_SCENARIOS[family]).train.n_vehicles
    found = _inspect(page, tmp_path, GRAPH, "trainctl-graph")
    assert found["count"] == 1
    assert found["id"] == f"figure-graph-{family}" and found["section"] == f"family-{family}"
    left, top, width, height = found["box"]
    assert 0 <= left and left + width <= found["viewport"]
    assert 300 < width <= 38 * 16 + 1 and 80 < height < width  # small, wider than tall
    numbers = sorted(int(t) for t in found["texts"] if t.isdigit())
    assert numbers == list(range(1, n + 1)) and "reference" in found["texts"]
    assert "reaches every vehicle" in found["caption"]


@E2E
def test_seed003_repetitions_and_claims_fit_1280(tmp_path: Path) -> None:
    """Case (c) shortened: the spread table, the coupler column and the claims fit, cleanly."""
    from tests.test_seed003_cases import _short_delay

    source = tmp_path / "c.toml"
    source.write_text(_short_delay(), encoding="utf-8")
    page = tmp_path / "c.html"
    assert main(["report", str(source), "-o", str(page), "--jobs", "1"]) == 0
    html = page.read_text(encoding="utf-8")
    assert "metrics-repetitions" in html and '<section id="claims">' in html
    assert _console(_load(page, tmp_path / "c.png", tmp_path / "profile")) == []
    record = _measure(page, tmp_path)
    assert record["width"] <= WIDTH and record["problems"] == []


@pytest.fixture(scope="module")
def sweep_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The report of a small simulated sweep (2 × 2 points, three strategies)."""
    root = tmp_path_factory.mktemp("browser-sweep")
    store = root / "store"
    assert main(["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,10", "--set",
                 "model.sample_time=10.0,20.0", "-o", str(store), "-j", "2"]) == 0
    assert main(["report", str(store), "--deterministic"]) == 0
    return store / "report.html"


@E2E
def test_sweep_report_loads_cleanly_and_fits_1280(sweep_report: Path, tmp_path: Path) -> None:
    """The sweep report: no console message, real content, nothing wider than 1280 px."""
    shot = tmp_path / "sweep.png"
    assert _console(_load(sweep_report, shot, tmp_path / "profile")) == []
    with Image.open(shot) as image:
        pixels = np.asarray(image.convert("RGB"))
    assert len(np.unique(pixels.reshape(-1, 3), axis=0)) > 50  # not a blank page
    ink_rows = np.any(np.any(pixels != pixels[0, 0], axis=-1), axis=1)
    assert ink_rows[:1000].mean() > 0.3 and ink_rows[1000:].mean() > 0.3
    record = _measure(sweep_report, tmp_path)
    assert record["viewport"] == WIDTH
    assert record["width"] <= WIDTH and record["problems"] == []
    texts = _figure_texts(sweep_report.read_text(encoding="utf-8"))
    for name in ("centralised", "decentralised", "ndmpc"):  # a panel per strategy
        assert re.search(rf"(^|\s){name}(\s|$)", texts["metric-rms-error"]), name
    assert "predicted pass" in texts["certificate-ndmpc-convergence"]
