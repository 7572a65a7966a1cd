# Reports of the consensus families: comparison rows, the family section, the communication graph.
"""The reports of crh2-potential and heavy-haul-flocking, and the graph figure of their families.

Each scenario is analysed and simulated once per module (crh2-potential takes
about 25 s, heavy-haul-flocking about 6 s); the pages are parsed with
:class:`html.parser.HTMLParser` and compared with the scenario and the
report data, the graph's counts also with closed forms (a bidirectional
chain of n vehicles has 2(n − 1) directed links and λ₂ = 2 − 2 cos(π/n)).
"""

from __future__ import annotations

import json
import math
import re
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure

from trainctl.models.graphs import make_graph
from trainctl.plots.graph_figures import (
    graph_figure,
    graph_figure_key,
    graph_from_data,
    graph_report_data,
)
from trainctl.report import ReportData, build_report_context, collect_report_data, render_report
from trainctl.report.data import MANIFEST
from trainctl.report.figures import FIGURES_SECTION, ReportFigure
from trainctl.run.analysis import run_scenario
from trainctl.scenario import load_scenario, read_scenario_text

pytestmark = pytest.mark.e2e  # a long end-to-end run (make test-e2e): whole pipelines

FIXED_TIME = "2025-01-01T00:00:00Z"


def _data(name: str, *, simulate: bool = True) -> ReportData:
    text, _ = read_scenario_text(name)
    run = run_scenario(load_scenario(name), simulate=simulate)
    return collect_report_data(run, scenario_text=text, command=f"trainctl report {name}")


def _render(data: ReportData) -> str:
    return render_report(build_report_context(data, generated_at=FIXED_TIME, deterministic=True))


@pytest.fixture(scope="module")
def potential() -> dict[str, Any]:
    """crh2-potential (consensus, mpc.ndmpc, lqr.centralised): data and page, once."""
    data = _data("crh2-potential")
    return {"family": "potential", "data": data, "html": _render(data)}


@pytest.fixture(scope="module")
def flocking() -> dict[str, Any]:
    """heavy-haul-flocking (flocking, mpc.decentralised): data and page, once."""
    data = _data("heavy-haul-flocking")
    return {"family": "flocking", "data": data, "html": _render(data)}


@pytest.fixture(params=["potential", "flocking"])
def report(request: pytest.FixtureRequest) -> dict[str, Any]:
    """Each of the two reports in turn."""
    return request.getfixturevalue(request.param)


class Page(HTMLParser):
    """The page's sections, tables (class, rows of cell texts) and figures (key, text, caption)."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.sections: list[str] = []
        self.tables: list[dict[str, Any]] = []
        self.figures: list[dict[str, Any]] = []
        self._open: list[tuple[str, str]] = []  # (tag, id) of the open sections and figures
        self._row: list[str] | None = None
        self._cell: list[str] | None = None
        self._in: dict[str, int] = {"svg": 0, "text": 0, "figcaption": 0}

    def _where(self, tag: str) -> str:
        return next((i for t, i in reversed(self._open) if t == tag), "")

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        if tag == "section":
            self.sections.append(a.get("id", ""))
            self._open.append((tag, a.get("id", "")))
        elif tag == "figure":
            self._open.append((tag, a.get("id", "")))
            self.figures.append({"id": a.get("id", ""), "section": self._where("section"),
                                 "svgs": 0, "texts": [], "caption": ""})
        elif tag == "table":
            self.tables.append({"class": a.get("class", ""), "section": self._where("section"),
                                "rows": []})
        elif tag == "tr":
            self._row = []
        elif tag in ("td", "th") and self._row is not None:
            self._cell = []
        if tag in self._in:
            self._in[tag] += 1
            if tag == "svg" and self.figures and self._where("figure"):
                self.figures[-1]["svgs"] += 1

    def handle_endtag(self, tag: str) -> None:
        if tag in ("section", "figure") and self._open and self._open[-1][0] == tag:
            self._open.pop()
        elif tag in ("td", "th") and self._cell is not None and self._row is not None:
            self._row.append(" ".join("".join(self._cell).split()))
            self._cell = None
        elif tag == "tr" and self._row is not None:
            self.tables[-1]["rows"].append(self._row)
            self._row = None
        if tag in self._in:
            self._in[tag] -= 1

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)
        if self._where("figure"):
            if self._in["text"]:
                self.figures[-1]["texts"].append(data.strip())
            if self._in["figcaption"]:
                self.figures[-1]["caption"] += data


def parse(html: str) -> Page:
    page = Page()
    page.feed(html)
    page.close()
    return page


def _capture(store: dict[str, Any]) -> Any:
    """A ``make`` that keeps the drawn figure and the section instead of encoding them."""
    def make(key: str, title: str, caption: str, figure: Figure, *, section: str) -> str:
        store.update(key=key, title=title, caption=caption, figure=figure, section=section)
        return key
    return make


# --------------------------------------------------------------------------- the helper


class TestGraphFigure:
    """graph_report_data / graph_figure on graphs made here: drawn from the data alone."""

    @pytest.mark.parametrize(("topology", "pinned", "n", "arcs", "pins"), [
        ("predecessor", "head", 5, 4, 1),      # 4 one-way links, drawn one arrow each
        ("bidirectional", "all", 4, 3, 4),     # 3 two-way links, drawn once each
        ("all-to-all", "none", 3, 3, 0),       # 3 two-way links, no pinning
    ])
    def test_drawing_follows_the_data(self, topology: str, pinned: str, n: int, arcs: int,
                                      pins: int) -> None:
        """n vehicles, one arc per link, one dashed arrow per pinned vehicle, the reference box."""
        data = json.loads(json.dumps(graph_report_data(make_graph(topology, n, pinned=pinned))))
        store: dict[str, Any] = {}
        assert graph_figure(data, family="potential", make=_capture(store)) == "graph-potential"
        assert store["section"] == "family-potential"
        ax = store["figure"].axes[0]
        assert len(ax.lines[0].get_xdata()) == n
        assert len(ax.patches) == arcs + pins + 1
        dashed = [p for p in ax.patches if p.get_linestyle() not in ("-", "solid")]
        assert len(dashed) == pins

    def test_caption_states_the_graph(self) -> None:
        """Topology, pinned vehicles, λ₂ and reachability, each following the graph."""
        store: dict[str, Any] = {}
        head = graph_report_data(make_graph("predecessor", 4, pinned="head"))
        graph_figure(head, family="flocking", usage="Closing words.", make=_capture(store))
        text = store["caption"]
        assert "predecessor" in text and "3 one-way links among 4 vehicles" in text
        assert "pins vehicle 1." in text and "reaches every vehicle" in text
        sym = make_graph("predecessor", 4).algebraic_connectivity()
        assert f"λ₂ = {sym:.4g} [-] (of the symmetrised graph)" in text
        assert text.endswith("Closing words.")
        unpinned = graph_report_data(make_graph("predecessor", 4, pinned=[0, 1, 0, 0]))
        graph_figure(unpinned, family="flocking", make=_capture(store))
        assert "pins vehicle 2." in store["caption"]
        assert "does not reach vehicle 1." in store["caption"]
        nothing = graph_report_data(make_graph("bidirectional", 4, pinned="none"))
        graph_figure(nothing, family="flocking", make=_capture(store))
        assert "pins no vehicle" in store["caption"] and "reaches no vehicle" in store["caption"]

    def test_data_round_trip(self) -> None:
        """The stored fields rebuild the same graph, through JSON."""
        graph = make_graph("explicit", 3, pinned=[0.5, 0, 0],
                           adjacency=[[0, 2, 0], [1, 0, 0], [0, 3, 0]])
        again = graph_from_data(json.loads(json.dumps(graph_report_data(graph))))
        assert np.array_equal(again.adjacency, graph.adjacency)
        assert np.array_equal(again.pinning, graph.pinning)
        assert again.summary() == graph.summary()


# --------------------------------------------------------------------------- the two reports


class TestFamilyReports:
    """crh2-potential and heavy-haul-flocking, rendered."""

    def test_comparison_rows_for_every_strategy(self, report: dict[str, Any]) -> None:
        """Each comparison table (metrics, solver, linear loops) has a row per strategy, in order.

        Every strategy of both scenarios has a linear closed loop, so the
        loops table lists them all too.
        """
        data: ReportData = report["data"]
        strategies = list(data.scenario.simulation.strategies)
        assert len(strategies) >= 2
        tables = [t for t in parse(report["html"]).tables if t["section"] == "controllers"]
        assert sorted(t["class"] for t in tables) == [
            "metrics metrics-loops", "metrics metrics-metrics", "metrics metrics-solver"]
        for table in tables:
            names = [row[0] for row in table["rows"][1:]]  # the first row is the header
            assert names == strategies, table["class"]
            assert all(len(row) == len(table["rows"][0]) for row in table["rows"])

    def test_family_section_and_its_table(self, report: dict[str, Any]) -> None:
        """The family's section follows the checks, with its quantity table from the data."""
        name, data = report["family"], report["data"]
        page = parse(report["html"])
        sid = f"family-{name}"
        assert sid in page.sections
        assert page.sections.index("checks") < page.sections.index(sid)
        assert f'href="#{sid}"' in report["html"]
        tables = [t for t in page.tables if t["section"] == sid and t["class"] == "quantities"]
        assert len(tables) == 1
        rows = tables[0]["rows"][1:]
        assert [r[0] for r in rows] == [r["name"] for r in data.families[name]["rows"]]
        assert all(r[1] for r in rows)

    def test_graph_figure_in_the_family_section(self, report: dict[str, Any]) -> None:
        """One graph figure, in the family section, its data the scenario's chain."""
        name, data = report["family"], report["data"]
        n = data.scenario.train.n_vehicles
        stored = data.families[name]["graph"]
        assert data.scenario.graph().topology == stored["topology"] == "bidirectional"
        adjacency = np.asarray(stored["adjacency"])
        assert adjacency.shape == (n, n)
        assert np.count_nonzero(adjacency) == 2 * (n - 1)  # each neighbour pair, both ways
        assert np.array_equal(adjacency, adjacency.T)
        assert np.array_equal(adjacency, data.scenario.graph().adjacency)
        assert np.count_nonzero(stored["pinning"]) == n  # pinned = "all" (the default)
        page = parse(report["html"])
        graphs = [f for f in page.figures if f["id"].startswith("figure-graph-")]
        assert [f["id"] for f in graphs] == [f"figure-{graph_figure_key(name)}"]
        figure = graphs[0]
        assert figure["section"] == f"family-{name}" and figure["svgs"] == 1
        labels = [t for t in figure["texts"] if t]
        assert sorted(int(t) for t in labels if t.isdigit()) == list(range(1, n + 1))
        assert "reference" in labels
        caption = " ".join(figure["caption"].split())
        assert f"{n - 1} two-way links among {n} vehicles" in caption
        assert f"pins every vehicle (1–{n})" in caption
        assert f"λ₂ = {2 - 2 * math.cos(math.pi / n):.4g} [-]" in caption
        assert "reaches every vehicle" in caption

    def test_figures_numbered_in_page_order(self, report: dict[str, Any]) -> None:
        """The graph is Figure 1 (its section comes first); the Figures section goes on from 2."""
        html = report["html"]
        numbers = [int(k) for k in re.findall(r"<strong>Figure (\d+)\. ", html)]
        assert numbers == list(range(1, len(numbers) + 1)) and len(numbers) > 5
        section = html[html.index('<section id="figures">'):]
        assert "figure-graph-" not in section
        assert re.search(r"<strong>Figure 2\. ", section)

    def test_context_places_the_figure(self, report: dict[str, Any]) -> None:
        """The family section lists the graph figure; the Figures section does not."""
        ctx = build_report_context(report["data"], deterministic=True)
        family = next(s for s in ctx["sections"] if s["family"] == report["family"])
        assert [f.key for f in family["figures"]] == [graph_figure_key(report["family"])]
        assert all(f.section == FIGURES_SECTION for f in ctx["figures"])
        assert ctx["figure_numbers"][graph_figure_key(report["family"])] == 1


def test_saved_run_redraws_the_graph_from_its_data(tmp_path: Path) -> None:
    """A saved run renders the same page; its graph data, edited, changes figure and caption."""
    data = _data("heavy-haul-flocking", simulate=False)
    data.save(tmp_path / "run")
    html = _render(data)
    assert 'id="figure-graph-flocking"' in html
    assert _render(ReportData.load(tmp_path / "run")) == html
    manifest = tmp_path / "run" / MANIFEST
    document = json.loads(manifest.read_text(encoding="utf-8"))
    graph = document["families"]["flocking"]["graph"]
    assert graph["adjacency"] == data.scenario.graph().adjacency.tolist()
    graph.update(topology="predecessor", pinning=[1.0, 0.0, 0.0, 0.0],
                 adjacency=make_graph("predecessor", 4).adjacency.tolist())
    manifest.write_text(json.dumps(document), encoding="utf-8")
    page = parse(_render(ReportData.load(tmp_path / "run")))
    figure = next(f for f in page.figures if f["id"] == "figure-graph-flocking")
    caption = " ".join(figure["caption"].split())
    assert "Topology predecessor: 3 one-way links among 4 vehicles" in caption
    assert "pins vehicle 1." in caption


@pytest.fixture(scope="module")
def unsimulated() -> dict[str, ReportData]:
    """crh2-dmpc (MPC) and crh2-dmpc-well-sampled (MPC and LQR), analysed without simulations."""
    return {name: _data(name, simulate=False) for name in ("crh2-dmpc", "crh2-dmpc-well-sampled")}


@pytest.mark.parametrize("name", ["crh2-dmpc", "crh2-dmpc-well-sampled"])
def test_mpc_and_lqr_reports_have_no_graph(name: str, unsimulated: dict[str, ReportData]) -> None:
    """MPC (and MPC with LQR) scenarios: no graph figure; MPC's own figure stays in Figures."""
    data = unsimulated[name]
    assert set(data.families) <= {"mpc", "lqr"} and "mpc" in data.families
    assert not any("graph" in family for family in data.families.values())
    ctx = build_report_context(data, deterministic=True)
    keys = [f.key for f in ctx["figures"]]
    assert "convergence" in keys and not any(k.startswith("graph-") for k in keys)
    assert all(not s["figures"] for s in ctx["sections"] if s["family"])
    html = render_report(ctx)
    assert "figure-graph-" not in html
    page = parse(html)
    assert {f["section"] for f in page.figures} == {"figures"}
    numbers = [int(k) for k in re.findall(r"<strong>Figure (\d+)\. ", html)]
    assert numbers == list(range(1, len(keys) + 1))


def test_figure_of_an_absent_section_goes_to_figures(unsimulated: dict[str, ReportData],
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """A figure placed in a section that is not on the page is shown among the Figures."""
    from markupsafe import Markup

    import trainctl.report.context as context

    data = unsimulated["crh2-dmpc"]
    figures = context.report_figures(data)
    stray = ReportFigure("stray", "Stray", "A figure for a family without a section.",
                         Markup("<svg></svg>"), section="family-absent")
    placed = ReportFigure("placed", "Placed", "A figure for the MPC section.",
                          Markup("<svg></svg>"), section="family-mpc")
    monkeypatch.setattr(context, "report_figures", lambda _: [placed, *figures, stray])
    ctx = build_report_context(data, deterministic=True)
    assert [f.key for f in ctx["figures"]] == [f.key for f in figures] + ["stray"]
    mpc = next(s for s in ctx["sections"] if s["family"] == "mpc")
    assert [f.key for f in mpc["figures"]] == ["placed"]
    assert ctx["figure_numbers"]["placed"] == 1 and ctx["figure_numbers"]["stray"] == len(
        figures) + 2
    page = parse(render_report(ctx))
    where = {f["id"]: f["section"] for f in page.figures}
    assert where["figure-placed"] == "family-mpc" and where["figure-stray"] == "figures"


@pytest.mark.parametrize(("name", "strategy", "dt"), [
    ("heavy-haul-flocking-collision", "flocking", 1.0),
    ("crh2-potential-unpinned", "consensus", 0.002),
])
def test_saved_runs_with_sampled_laws_render(tmp_path: Path, name: str, strategy: str,
                                             dt: float) -> None:
    """analyse --save, then report DIR: a law's results keep its control interval as dt."""
    from trainctl.cli.main import main
    from trainctl.sim.results import SimulationResult

    run = tmp_path / "run"
    assert main(["analyse", name, "--save", str(run), "--jobs", "1"]) in (0, 1)
    saved = SimulationResult.load(run / "simulations" / strategy)
    assert saved.dt == dt
    out = tmp_path / "page.html"
    assert main(["report", str(run), "-o", str(out), "--deterministic"]) == 0
    html = out.read_text(encoding="utf-8")
    family = "flocking" if strategy == "flocking" else "potential"
    assert f'id="figure-graph-{family}"' in html
    tables = [t for t in parse(html).tables if t["section"] == "controllers"]
    assert tables
    for table in tables:
        assert [row[0] for row in table["rows"][1:]] == [strategy]
