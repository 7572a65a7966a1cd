# Tests of the HTML design report: data, context, figures, page, determinism, files.
"""trainctl.report: collected data, context, inline SVG figures, page, save/load, writes."""

from __future__ import annotations

import dataclasses
import math
import os
import re
import stat
from html.parser import HTMLParser
from pathlib import Path

import control as ct
import jinja2
import numpy as np
import pytest
import scipy.linalg

import trainctl
from trainctl.report import (
    ReportData,
    build_report_context,
    collect_report_data,
    figure_svg,
    make_environment,
    normalise_timestamp,
    portable_command,
    render_report,
    write_gallery,
    write_report,
)
from trainctl.report.build import TimestampError
from trainctl.report.data import MANIFEST
from trainctl.report.output import OutputError
from trainctl.run.analysis import run_scenario
from trainctl.scenario import read_scenario_text

FIXED_TIME = "2025-01-01T00:00:00Z"
SECTION_IDS = ("scenario", "model", "checks", "controllers", "figures", "reproducibility")
"""The sections of every page; "claims" is there only for runs with paper claims (seed 003)."""


def _data(name: str) -> ReportData:
    text, _ = read_scenario_text(name)
    from trainctl.scenario import load_scenario

    run = run_scenario(load_scenario(name))
    return collect_report_data(run, scenario_text=text, command=f"trainctl report {name}")


@pytest.fixture(scope="module")
def crh2() -> ReportData:
    """crh2-dmpc, analysed and simulated (three strategies)."""
    return _data("crh2-dmpc")


@pytest.fixture(scope="module")
def hinf() -> ReportData:
    """heavy-haul-hinf: no controller, no simulation, a track."""
    return _data("heavy-haul-hinf")


@pytest.fixture(scope="module")
def context(crh2: ReportData) -> dict[str, object]:
    """Deterministic context of crh2-dmpc with a fixed time."""
    return build_report_context(crh2, generated_at=FIXED_TIME, deterministic=True)


@pytest.fixture(scope="module")
def html(context: dict[str, object]) -> str:
    """The rendered crh2-dmpc page."""
    return render_report(context)


class Page(HTMLParser):
    """Checks nesting and collects tags, attributes, ids, tables and section text."""

    VOID = {"meta", "br", "link", "img", "input", "hr", "col", "wbr"}

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.tags: list[str] = []
        self.attrs: list[tuple[str, str, str]] = []
        self.ids: list[str] = []
        self.tables: list[dict[str, str]] = []
        self.text: dict[str, list[str]] = {}
        self._table: dict[str, str] | None = None
        self._part = ""

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append(tag)
        for name, value in attrs:
            self.attrs.append((tag, name, value or ""))
            if name == "id":
                self.ids.append(value or "")
        if tag == "table":
            self._table = {"head": "", "body": ""}
            self.tables.append(self._table)
        elif tag in ("thead", "caption"):
            self._part = "head"
        elif tag == "tbody":
            self._part = "body"
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag in ("thead", "caption", "tbody"):
            self._part = ""
        if tag == "table":
            self._table = None
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"unexpected </{tag}> with open {self.stack[-3:]}")
        else:
            self.stack.pop()

    def handle_data(self, data: str) -> None:
        for tag in set(self.stack):
            self.text.setdefault(tag, []).append(data)
        if self._table is not None and self._part:
            self._table[self._part] += data + " "

    def text_of(self, tag: str) -> str:
        return "".join(self.text.get(tag, []))


def parse(html: str) -> Page:
    page = Page()
    page.feed(html)
    page.close()
    return page


def _svgs(html: str) -> list[str]:
    return re.findall(r"<svg\b.*?</svg>", html, flags=re.DOTALL)


def _column_keys(context: dict[str, object]) -> list[str]:
    """Column keys of every table of the controllers section."""
    return [c["key"] for table in context["controllers"]["tables"] for c in table["columns"]]


class TestEnvironment:
    """make_environment()."""

    def test_settings(self) -> None:
        """Autoescape on, strict undefined, package loader with the report templates."""
        env = make_environment()
        assert env.autoescape is True
        assert env.undefined is jinja2.StrictUndefined
        assert {"report.html.j2", "index.html.j2"} <= set(env.list_templates())

    def test_every_section_has_a_partial(self) -> None:
        """Each section the context lists ships as package data (sections/_<id>.html.j2)."""
        from importlib import resources

        from trainctl.report.context import SECTIONS

        root = resources.files("trainctl.report").joinpath("templates", "sections")
        assert [key for key, _ in SECTIONS if key != "claims"] == list(SECTION_IDS)
        for key, _ in SECTIONS:
            assert root.joinpath(f"_{key}.html.j2").is_file(), key

    def test_undefined_fails(self) -> None:
        """A missing template variable raises instead of rendering empty."""
        with pytest.raises(jinja2.UndefinedError):
            make_environment().from_string("{{ nope }}").render()

    def test_template_typo_fails(self, context: dict[str, object]) -> None:
        """Rendering with a context that lacks a key fails loudly."""
        broken = {k: v for k, v in context.items() if k != "checks"}
        with pytest.raises(jinja2.UndefinedError):
            render_report(broken)


class TestData:
    """collect_report_data(): what the report shows beyond the run."""

    def test_open_loop_spectrum_is_the_zoh_of_the_design_model(self, crh2: ReportData) -> None:
        """Open-loop eigenvalues = eig(expm(A T)) of the continuous model without the dummy."""
        from trainctl.models.linear import linearise

        cfg = crh2.scenario.model
        sys = linearise(crh2.scenario.train, cfg.speed, method=cfg.linearisation)
        T = crh2.scenario.model.sample_time
        expected = np.linalg.eigvals(scipy.linalg.expm(np.asarray(sys.A) * T))
        found = crh2.spectra["open loop"]
        assert found.size == expected.size
        # Compare as multisets: each expected value has a match.
        for z in expected:
            assert np.min(np.abs(found - z)) < 1e-9

    def test_closed_loop_radii_match_the_checks(self, crh2: ReportData) -> None:
        """The eigenvalue sets carry the spectral radii the design review judged."""
        checks = {c["name"]: c for c in crh2.results["checks"]}
        radius = {k: float(np.max(np.abs(v))) for k, v in crh2.spectra.items()}
        assert radius["centralised"] == pytest.approx(
            checks["centralised_closed_loop"]["value"], rel=1e-9)
        assert radius["N-DMPC (Nash)"] == pytest.approx(
            checks["closed_loop_nash"]["value"], rel=1e-9)

    def test_weight_sweep_crosses_one_at_r_star(self, crh2: ReportData) -> None:
        """ρ(D0) falls through 1 at the bisection's R*, and equals the check at the design R."""
        sweep = crh2.families["mpc"]["weight_sweep"]
        r, rho = np.asarray(sweep["weights"]), np.asarray(sweep["radii"])
        above, below = r[rho < 1], r[rho >= 1]
        assert below.max() < sweep["threshold"] < above.min()
        at_design = float(np.interp(np.log(sweep["design_weight"]), np.log(r), rho))
        checks = {c["name"]: c for c in crh2.results["checks"]}
        assert at_design == pytest.approx(checks["ndmpc_convergence"]["value"], rel=0.02)

    def test_coach_matrices_by_hand(self, crh2: ReportData) -> None:
        """A_{0,0}[0,1] = -k/m_0 and A_{1,0}[0,1] = k/m_1 (couplers as springs)."""
        train = crh2.scenario.train
        k = train.couplers[0].stiffness
        coach0, coach1 = crh2.subsystems[0], crh2.subsystems[1]
        a00 = next(b for b in coach0["blocks"] if b["kind"] == "A" and b["from"] == 0)
        a10 = next(b for b in coach1["blocks"] if b["kind"] == "A" and b["from"] == 0)
        b0 = next(b for b in coach0["blocks"] if b["kind"] == "B")
        assert a00["matrix"][0][1] == pytest.approx(-k / train.vehicles[0].mass, rel=1e-12)
        assert a10["matrix"][0][1] == pytest.approx(k / train.vehicles[1].mass, rel=1e-12)
        assert b0["matrix"][0][0] == pytest.approx(1 / train.vehicles[0].mass, rel=1e-12)

    def test_interconnected_blocks_are_the_model(self, crh2: ReportData) -> None:
        """Wiring the reported blocks with control.interconnect gives the model's eigenvalues."""
        from trainctl.models.linear import linearise

        cfg = crh2.scenario.model
        systems = []
        for coach in crh2.subsystems:
            i, states = coach["index"], coach["states"]
            own = next(b for b in coach["blocks"] if b["kind"] == "A" and b["from"] == i)
            others = [b for b in coach["blocks"] if b["kind"] == "A" and b["from"] != i]
            B = next(b for b in coach["blocks"] if b["kind"] == "B")
            Bfull = np.hstack([np.asarray(B["matrix"])] + [np.asarray(b["matrix"]) for b in others])
            inputs = [f"u[{i}]"] + [s for b in others for s in b["columns"]]
            systems.append(ct.ss(np.asarray(own["matrix"]), Bfull, np.eye(len(states)), 0,
                                 inputs=inputs, outputs=states, states=states, name=f"c{i}"))
        n = len(systems)
        whole = ct.interconnect(systems, inplist=[f"u[{i}]" for i in range(n)],
                                outlist=[f"v[{i}]" for i in range(n)])
        full = linearise(crh2.scenario.train, cfg.speed, method=cfg.linearisation,
                         dummy_state=cfg.dummy_state)
        got = np.linalg.eigvals(np.asarray(whole.A))
        want = np.linalg.eigvals(np.asarray(full.A))
        assert got.size == want.size
        for z in want:
            assert np.min(np.abs(got - z)) < 1e-9

    def test_no_controller(self, hinf: ReportData) -> None:
        """Without [controller]: the open loop only, no sweep, no simulations."""
        assert list(hinf.spectra) == ["open loop"]
        assert hinf.families == {}
        assert hinf.simulations == {}


class TestSaveLoad:
    """ReportData.save / load."""

    def test_round_trip_renders_identically(self, crh2: ReportData, tmp_path: Path) -> None:
        """A loaded copy renders to the same bytes as the original."""
        crh2.save(tmp_path / "run")
        loaded = ReportData.load(tmp_path / "run")
        assert loaded.scenario == crh2.scenario
        for name, result in crh2.simulations.items():
            assert np.array_equal(loaded.simulations[name].states, result.states)
        kwargs = {"generated_at": FIXED_TIME, "deterministic": True}
        assert render_report(build_report_context(loaded, **kwargs)) == render_report(
            build_report_context(crh2, **kwargs))

    def test_replaces_a_previous_save_only(self, hinf: ReportData, tmp_path: Path) -> None:
        """A previous save is replaced; a foreign non-empty directory is refused untouched."""
        target = tmp_path / "run"
        hinf.save(target)
        hinf.save(target)
        assert (target / MANIFEST).is_file()
        assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
        foreign = tmp_path / "mine"
        foreign.mkdir()
        (foreign / "notes.txt").write_text("keep", encoding="utf-8")
        with pytest.raises(trainctl.TrainctlError, match="refusing to overwrite"):
            hinf.save(foreign)
        assert [p.name for p in foreign.iterdir()] == ["notes.txt"]

    def test_load_rejects_other_directories(self, tmp_path: Path) -> None:
        """A directory without the manifest, or of another format, is a clear error."""
        with pytest.raises(trainctl.TrainctlError, match="not a complete saved run"):
            ReportData.load(tmp_path)
        (tmp_path / MANIFEST).write_text('{"format": "other/1"}', encoding="utf-8")
        (tmp_path / "scenario.toml").write_text("", encoding="utf-8")
        with pytest.raises(trainctl.TrainctlError, match="format 'other/1'"):
            ReportData.load(tmp_path)


class TestContext:
    """build_report_context()."""

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_pure_and_deterministic(self, crh2: ReportData) -> None:
        """The same data and time give the same context and the same bytes."""
        a = build_report_context(crh2, generated_at=FIXED_TIME, deterministic=True)
        b = build_report_context(crh2, generated_at=FIXED_TIME, deterministic=True)
        assert a == b
        assert render_report(a) == render_report(b)

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_deterministic_leaves_out_wall_clock(self, crh2: ReportData) -> None:
        """--deterministic drops solve times, stage timings and, unless given, the time."""
        ctx = build_report_context(crh2, deterministic=True)
        assert ctx["generated_at"] == ""
        assert ctx["footer"]["timings"] == []
        assert "solve_time" not in _column_keys(ctx)
        live = build_report_context(crh2)
        assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", live["generated_at"])
        assert "solve_time" in _column_keys(live)

    def test_checks_and_headline(self, crh2: ReportData, context: dict[str, object]) -> None:
        """Counts and badges follow the review; the headline names them."""
        statuses = [c["status"] for c in crh2.results["checks"]]
        checks = context["checks"]
        assert checks["counts"] == {s: statuses.count(s) for s in ("pass", "warn", "fail")}
        assert [row["badge"] for row in checks["rows"]] == statuses
        assert context["headline"].startswith(
            f"{len(statuses)} checks: {statuses.count('pass')} pass, "
            f"{statuses.count('warn')} warn, {statuses.count('fail')} fail")

    def test_settings_carry_units(self, context: dict[str, object]) -> None:
        """Numeric settings show the unit from their docstring."""
        rows = {row["key"]: row for group in context["scenario"]["settings"]
                for row in group["rows"]}
        assert rows["sample_time"]["unit"] == "s"
        assert rows["speed"]["unit"] == "m/s"
        assert rows["speed_kmh"]["value"] == "300"
        assert rows["input_weight"]["unit"] == "per kN²"
        assert rows["duration"]["unit"] == "s"
        assert rows["reference_speeds"]["unit"] == "m/s"
        assert rows["coupler_force_limit"]["unit"] == "kN"  # forces in kN everywhere
        assert rows["coupler_force_limit"]["value"] == "500"
        assert rows["form"]["unit"] == ""

    def test_metrics_rows(self, crh2: ReportData, context: dict[str, object]) -> None:
        """One metrics row per simulated strategy, in order, with the worst speed error."""
        table = context["controllers"]["tables"][0]
        assert [row["cells"][0] for row in table["rows"]] == list(crh2.simulations)
        keys = [c["key"] for c in table["columns"]]
        for row, result in zip(table["rows"], crh2.simulations.values(), strict=True):
            settle = crh2.scenario.simulation.settle_time
            mask = result.dense_time >= settle  # maxima are taken between the samples too
            worst = np.max(np.abs(result.dense_velocities[:, mask]
                                  - result.dense_reference_speed[mask]))
            shown = float(row["cells"][keys.index("max_error")])
            assert shown == pytest.approx(worst, rel=1e-3)


class TestFigures:
    """figure_svg() and the report's figures."""

    def test_svg_fit_for_inlining(self) -> None:
        """No prolog, DOCTYPE, comments or metadata; ids prefixed; references resolve."""
        from matplotlib.figure import Figure

        fig = Figure(figsize=(3, 2))
        ax = fig.add_subplot()
        ax.plot([0, 1, 2], [0, 1, 0], label="x")
        ax.legend()
        svg = str(figure_svg(fig, prefix="demo"))
        assert svg.startswith("<svg") and svg.endswith("</svg>")
        for bad in ("<?xml", "<!DOCTYPE", "<!--", "<metadata", "dc:date", "Matplotlib v"):
            assert bad not in svg
        ids = re.findall(r'\bid="([^"]+)"', svg)
        assert ids and all(i.startswith("demo-") for i in ids)
        refs = re.findall(r'url\(#([^)]+)\)|href="#([^"]+)"', svg)
        assert {a or b for a, b in refs} <= set(ids)
        assert fig.axes == []  # released after encoding

    def test_svg_deterministic(self) -> None:
        """Encoding the same drawing twice gives identical text (fixed hash salt, no date)."""
        from matplotlib.figure import Figure

        def draw() -> Figure:
            fig = Figure(figsize=(3, 2))
            fig.add_subplot().plot(np.arange(50.0), np.sin(np.arange(50.0)))
            return fig

        assert figure_svg(draw(), prefix="a") == figure_svg(draw(), prefix="a")

    def test_bad_prefix(self) -> None:
        """A prefix that is not an id-safe token is refused."""
        from matplotlib.figure import Figure

        with pytest.raises(ValueError, match="prefix"):
            figure_svg(Figure(), prefix="1 bad")

    def test_every_figure_non_empty(self, context: dict[str, object]) -> None:
        """Each figure is an <svg> with a positive viewBox and drawn paths."""
        keys = [f.key for f in context["figures"]]
        assert keys == ["speed", "coupler-force", "input", "energy", "iterations", "eigenvalues",
                        "sigma-speed", "sigma-force", "sensitivity", "complementary",
                        "grade-step", "string-stability", "convergence"]
        for figure in context["figures"]:
            svg = str(figure.svg)
            width, height = map(float, re.search(
                r'viewBox="0 0 ([\d.]+) ([\d.]+)"', svg).groups())
            assert width > 100 and height > 100
            assert svg.count("<path") > 10, figure.key

    def test_no_duplicate_ids_on_the_page(self, html: str) -> None:
        """Inline SVGs do not clash: every id on the page is unique."""
        ids = parse(html).ids
        assert len(ids) == len(set(ids))


class TestPage:
    """render_report() on crh2-dmpc."""

    def test_well_formed(self, html: str) -> None:
        """An HTML5 document whose elements nest properly."""
        assert html.startswith("<!DOCTYPE html>")
        page = parse(html)
        assert page.errors == []
        assert page.stack == []

    def test_sections_present(self, html: str) -> None:
        """Every section is there, in order, with a heading and a table-of-contents link."""
        page = parse(html)
        positions = [html.index(f'<section id="{key}">') for key in SECTION_IDS]
        assert positions == sorted(positions)
        for key in SECTION_IDS:
            assert f'href="#{key}"' in html
        assert page.text_of("h2").count("Design checks") == 1

    def test_figures_are_inline_svg(self, html: str) -> None:
        """Thirteen figures, each an inline SVG inside a <figure> with a caption."""
        svgs = _svgs(html)
        assert len(svgs) == 13
        assert html.count("<figcaption>") == 13
        assert "<img" not in html

    def test_tables_carry_units(self, html: str) -> None:
        """Every table names units in its header or caption (a [unit] or a Unit column)."""
        page = parse(html)
        assert len(page.tables) > 10
        for table in page.tables:
            head = table["head"]
            ok = re.search(r"\[[^\]]+\]|\bUnit\b|\bSI\b|Version|Stage", head)
            assert ok, head

    def test_self_contained(self, html: str) -> None:
        """No script, no external stylesheet, nothing remote in src/href/url()."""
        page = parse(html)
        assert not {"script", "link", "iframe", "object", "embed", "img"} & set(page.tags)
        for tag, name, value in page.attrs:
            assert not name.startswith("on"), (tag, name)
            if name in {"src", "href", "xlink:href", "srcset", "action", "data"}:
                assert value.startswith("#"), (tag, name, value)
        assert not re.search(r"url\(\s*['\"]?(?!#)", html)
        assert "@import" not in html

    def test_matrix_values_shown(self, html: str, crh2: ReportData) -> None:
        """A_{0,0} of the first coach shows -k/m_0 (formatted)."""
        train = crh2.scenario.train
        value = train.couplers[0].stiffness / train.vehicles[0].mass
        assert f"−{value:.6g}" in html

    def test_footer(self, html: str) -> None:
        """Versions, seed and the command, without machine paths."""
        page = parse(html)
        text = page.text_of("section")
        assert f"trainctl{trainctl.__version__}" in text.replace("\n", "").replace(" ", "")
        for package in ("numpy", "scipy", "control", "cvxpy", "matplotlib"):
            assert package in text
        assert "trainctl report crh2-dmpc" in html
        assert str(Path.home()) not in html and os.getcwd() not in html


class TestGallery:
    """write_gallery()."""

    def test_links_and_headlines(self, crh2: ReportData, hinf: ReportData,
                                 tmp_path: Path) -> None:
        """One entry per report, linked relatively, with its one-line key results."""
        paths = [tmp_path / "a.html", tmp_path / "sub" / "b.html"]
        index = write_gallery(list(zip((crh2, hinf), paths, strict=True)), tmp_path / "index.html",
                              generated_at=FIXED_TIME)
        html = index.read_text(encoding="utf-8")
        page = parse(html)
        assert page.errors == []
        hrefs = [v for t, n, v in page.attrs if t == "a" and n == "href"]
        assert hrefs == ["a.html", "sub/b.html"]
        assert "best tracking" in html and "no closed-loop simulation" in html
        assert FIXED_TIME in html


class TestHelpers:
    """portable_command() and normalise_timestamp()."""

    def test_portable_command(self) -> None:
        """Absolute paths lose their directories; relative ones and options stay."""
        assert portable_command(["analyse", "/srv/x/a.toml", "--save=/tmp/r/out"]) == (
            "trainctl analyse a.toml --save=out")
        assert portable_command(["report", "analyses/b.toml"]) == "trainctl report analyses/b.toml"

    def test_timestamps(self) -> None:
        """ISO times with zones, dates and Unix seconds normalise to UTC."""
        assert normalise_timestamp("2026-11-22T10:00:00Z") == "2026-11-22T10:00:00Z"
        assert normalise_timestamp("2026-11-22") == "2026-11-22T00:00:00Z"
        assert normalise_timestamp("86400") == "1970-01-02T00:00:00Z"
        with pytest.raises(TimestampError, match="ISO 8601"):
            normalise_timestamp("yesterday")


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

    def test_failure_leaves_nothing(self, tmp_path: Path,
                                    monkeypatch: pytest.MonkeyPatch) -> None:
        """If the rename fails, the destination and the temp file are absent."""
        (tmp_path / "r.html").mkdir()
        with pytest.raises(OutputError, match="is a directory"):
            write_report("x", tmp_path / "r.html")
        assert [p.name for p in tmp_path.iterdir()] == ["r.html"]
        assert list((tmp_path / "r.html").iterdir()) == []

        def fail(src: object, dst: object) -> None:
            raise OSError("rename failed")

        monkeypatch.setattr("os.replace", fail)
        with pytest.raises(OutputError, match=r"new\.html: cannot write the file \(rename "
                           r"failed\); nothing was written"):
            write_report("x", tmp_path / "new.html")
        assert [p.name for p in tmp_path.iterdir()] == ["r.html"]


def test_sequential_and_pool_runs_agree() -> None:
    """Simulations on a process pool give exactly the sequential results."""
    from trainctl.run.pool import process_pool
    from trainctl.scenario import load_scenario

    scenario = load_scenario("crh2-dmpc")
    sim = dataclasses.replace(scenario.simulation, duration=200.0,
                              strategies=("centralised", "ndmpc"))
    scenario = dataclasses.replace(scenario, simulation=sim)
    here = run_scenario(scenario)
    with process_pool(2) as pool:
        there = run_scenario(scenario, executor=pool)
    for name in sim.strategies:
        a, b = here.simulations[name], there.simulations[name]
        assert np.array_equal(a.states, b.states) and np.array_equal(a.inputs, b.inputs)
        assert a.statuses == b.statuses
    assert math.isclose(here.metrics["ndmpc"].energy, there.metrics["ndmpc"].energy)


class TestProgress:
    """The terminal progress bar."""

    class _Terminal:
        def __init__(self) -> None:
            self.chunks: list[str] = []

        def write(self, text: str) -> int:
            self.chunks.append(text)
            return len(text)

        def flush(self) -> None:
            pass

        def isatty(self) -> bool:
            return True

    def test_draws_on_a_terminal_and_clears(self) -> None:
        """On a terminal: counted bar with the label, then the line is cleared."""
        from trainctl.run._progress import Progress

        term = self._Terminal()
        with Progress(4, stream=term) as bar:  # type: ignore[arg-type]
            bar.advance("simulated ndmpc")
            bar.advance("analysed", steps=2)
        text = "".join(term.chunks)
        assert "[######------------------] 1/4 simulated ndmpc" in text
        assert "3/4 analysed" in text
        assert text.endswith("\r") and not text.rsplit("\r", 2)[-2].strip()  # line cleared

    def test_silent_off_a_terminal(self) -> None:
        """Not a terminal (pipe, log, CI): nothing is written."""
        import io

        from trainctl.run._progress import Progress

        stream = io.StringIO()
        with Progress(2, stream=stream) as bar:
            bar.advance("x")
        assert stream.getvalue() == ""
