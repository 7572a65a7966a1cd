# Tests of the HTML report renderer (context, template, stylesheet, atomic write).
"""trainctl.report: context building, rendering and atomic writing."""

from __future__ import annotations

import os
import stat
from html.parser import HTMLParser
from pathlib import Path

import jinja2
import pytest

import trainctl
from trainctl.analysis.summary import model_summary
from trainctl.report import (
    build_summary_context,
    make_environment,
    render_summary_report,
    write_report,
)
from trainctl.scenario import load_scenario

FIXED_TIME = "2025-01-01T00:00:00Z"


@pytest.fixture(scope="module")
def crh2() -> tuple[object, object]:
    """The crh2-dmpc scenario and its model summary."""
    scenario = load_scenario("crh2-dmpc")
    return scenario, model_summary(scenario)


@pytest.fixture(scope="module")
def context(crh2: tuple[object, object]) -> dict[str, object]:
    """The report context of crh2-dmpc with a fixed timestamp."""
    scenario, summary = crh2
    return build_summary_context(scenario, summary, generated_at=FIXED_TIME)


@pytest.fixture(scope="module")
def html(context: dict[str, object]) -> str:
    """The rendered crh2-dmpc page."""
    return render_summary_report(context)


class _Checker(HTMLParser):
    """Checks that every non-void element is closed in order."""

    VOID = {"meta", "br", "link", "img", "input", "hr", "col", "wbr"}

    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.errors: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unexpected </{tag}> with open {self.stack[-3:]}")
        else:
            self.stack.pop()


class TestEnvironment:
    """make_environment()."""

    def test_settings(self) -> None:
        """Autoescape on, strict undefined, package loader with the summary template."""
        env = make_environment()
        assert env.autoescape is True
        assert env.undefined is jinja2.StrictUndefined
        assert "summary.html.j2" in env.list_templates()

    def test_undefined_fails(self) -> None:
        """A missing template variable raises instead of rendering empty."""
        with pytest.raises(jinja2.UndefinedError):
            make_environment().from_string("{{ nope }}").render()


class TestContext:
    """build_summary_context()."""

    def test_pure_and_deterministic(self, crh2: tuple[object, object]) -> None:
        """The same inputs and timestamp give the same context and page."""
        scenario, summary = crh2
        a = build_summary_context(scenario, summary, generated_at=FIXED_TIME)
        b = build_summary_context(scenario, summary, generated_at=FIXED_TIME)
        assert a == b
        assert render_summary_report(a) == render_summary_report(b)

    def test_default_timestamp(self, crh2: tuple[object, object]) -> None:
        """Without generated_at, an ISO-8601 UTC time is used."""
        scenario, summary = crh2
        stamp = build_summary_context(scenario, summary)["generated_at"]
        assert isinstance(stamp, str)
        assert stamp.endswith("Z") and "T" in stamp

    def test_versions(self, context: dict[str, object]) -> None:
        """The footer versions cover trainctl and the numerical stack."""
        versions = {row["name"]: row["version"] for row in context["versions"]}  # type: ignore[attr-defined]
        assert versions["trainctl"] == trainctl.__version__
        assert {"numpy", "scipy", "control", "cvxpy"} <= set(versions)

    def test_vehicles_in_tonnes(self, context: dict[str, object]) -> None:
        """Vehicle masses are shown in tonnes, head first."""
        masses = [row["mass_t"] for row in context["train"]["vehicles"]]  # type: ignore[index]
        assert masses == ["42.8", "48", "46.5", "42"]

    def test_accepts_plain_mapping(self, crh2: tuple[object, object]) -> None:
        """A summary given as a dict is rendered generically, section by section."""
        scenario, _ = crh2
        summary = {
            "n_states": 3,
            "flag": True,
            "modes": [{"kind": "coupler", "eigenvalue": [-0.5, 2.0], "natural_frequency": 2.06}],
            "sampling": {"sample_time": 0.1, "note": None},
        }
        context = build_summary_context(scenario, summary, generated_at=FIXED_TIME)
        titles = [section["title"] for section in context["sections"]]
        assert titles == ["Overview", "Modes", "Sampling"]
        modes = context["sections"][1]
        assert modes["columns"] == ["Kind", "Eigenvalue [1/s]", "Natural frequency [rad/s]"]
        assert modes["rows"] == [["coupler", "-0.5 + 2j", "2.06"]]
        page = render_summary_report(context)
        assert "-0.5 + 2j" in page


class TestPage:
    """render_summary_report() on crh2-dmpc."""

    def test_well_formed(self, html: str) -> None:
        """The page is an HTML5 document whose elements nest properly."""
        assert html.startswith("<!DOCTYPE html>")
        checker = _Checker()
        checker.feed(html)
        checker.close()
        assert checker.errors == []
        assert checker.stack == []

    def test_css_inlined(self, html: str) -> None:
        """The package stylesheet is inlined in a <style> block."""
        assert "<style>" in html
        assert "border-collapse: collapse" in html
        assert "<link" not in html
        assert "<script" not in html

    def test_content(self, html: str) -> None:
        """Name, description, source, vehicles, settings with units and modes are shown."""
        scenario = load_scenario("crh2-dmpc")
        escaped = scenario.name.replace("&", "&amp;")
        assert f"<h1>{escaped}</h1>" in html
        assert scenario.description.replace("&", "&amp;") in html
        assert "builtin:crh2-dmpc" in html
        for text in ("Mass [t]", "Traction share", "a<sub>0</sub> [m/s²]", "rad/s", "km/h"):
            assert text in html
        assert "<h3>Modes</h3>" in html
        assert "<h3>Sampling</h3>" in html
        assert FIXED_TIME in html


class TestWriteReport:
    """write_report()."""

    def test_creates_parent_and_returns_path(self, tmp_path: Path) -> None:
        """Missing directories are created; the path is returned."""
        target = tmp_path / "a" / "b" / "r.html"
        assert write_report("<p>hi</p>", target) == target
        assert target.read_text(encoding="utf-8") == "<p>hi</p>"
        assert sorted(p.name for p in target.parent.iterdir()) == ["r.html"]

    def test_replaces_existing(self, tmp_path: Path) -> None:
        """An existing report is replaced whole; no temporary file is left."""
        target = tmp_path / "r.html"
        target.write_text("old", encoding="utf-8")
        write_report("new ✓", str(target))
        assert target.read_text(encoding="utf-8") == "new ✓"
        assert [p.name for p in tmp_path.iterdir()] == ["r.html"]

    def test_permissions_follow_umask(self, tmp_path: Path) -> None:
        """The file gets ordinary permissions (not the 0600 of a temp file)."""
        old = os.umask(0o022)
        try:
            target = write_report("x", tmp_path / "r.html")
        finally:
            os.umask(old)
        assert stat.S_IMODE(target.stat().st_mode) == 0o644

    def test_failure_leaves_nothing(self, tmp_path: Path) -> None:
        """If the rename fails, the destination and the temp file are absent."""
        (tmp_path / "r.html").mkdir()
        with pytest.raises(OSError):
            write_report("x", tmp_path / "r.html")
        assert [p.name for p in tmp_path.iterdir()] == ["r.html"]
        assert list((tmp_path / "r.html").iterdir()) == []
