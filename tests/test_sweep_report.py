# Tests of the sweep report: `trainctl report SWEEP_DIR` on small real stores.
"""trainctl.report.sweep: sections, figures per column, certificates, self-containedness, errors."""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import pandas as pd
import pytest

from tests.test_report import parse
from trainctl.cli.main import main
from trainctl.report.figures_sweep import is_log
from trainctl.report.sweep import (
    CERTIFICATES,
    REPORT_NAME,
    SweepReportData,
    agreement_counts,
    key_label,
    load_sweep_report_data,
    render_sweep_report,
)
from trainctl.sweep.store import SweepStore

pytestmark = pytest.mark.e2e  # a long end-to-end run (make test-e2e): whole pipelines

FIXED = "2026-01-01T00:00:00Z"


def _sweep(root: Path, *args: str) -> Path:
    assert main(["sweep", "crh2-dmpc", *args, "-o", str(root)]) == 0
    return root


@pytest.fixture(scope="module")
def grid2(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Analysis only, two parameters: 4 × 2 points (ρ(D0) > 1 at R = 1, T = 20 s)."""
    root = tmp_path_factory.mktemp("sweep") / "grid2"
    return _sweep(root, "--set", "controller.r_per_kn2=1,3,10,30",
                  "--set", "model.sample_time=10.0,20.0", "--no-simulate")


@pytest.fixture(scope="module")
def seeded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Analysis only, one parameter and two seeds."""
    root = tmp_path_factory.mktemp("sweep") / "seeded"
    return _sweep(root, "--set", "controller.r_per_kn2=1,10,100", "--seeds", "2",
                  "--set", "model.sample_time=20.0", "--no-simulate")


@pytest.fixture(scope="module")
def three(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Analysis only, three parameters (faceted heat maps)."""
    root = tmp_path_factory.mktemp("sweep") / "three"
    return _sweep(root, "--set", "controller.r_per_kn2=1,10",
                  "--set", "model.sample_time=10.0,20.0",
                  "--set", "controller.prediction_horizon=8,12", "--no-simulate")


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Simulated, two parameters: 2 × 2 points, three strategies each."""
    root = tmp_path_factory.mktemp("sweep") / "simulated"
    return _sweep(root, "--set", "controller.r_per_kn2=1,10", "--set",
                  "model.sample_time=10.0,20.0", "-j", "2")


RANDOM = """

[sweep]
seed = 0
samples = 22
[[sweep.axis]]
key = "controller.r_per_kn2"
distribution = "log-uniform"
low = 0.5
high = 50.0
[[sweep.axis]]
key = "train.vehicle[0].mass_t"
distribution = "normal"
mean = 48.0
std = 2.0
"""


@pytest.fixture(scope="module")
def sampled(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Analysis only, two random axes drawn 22 times (no grid: scatter plots)."""
    from trainctl.scenario import read_scenario_text

    root = tmp_path_factory.mktemp("sweep")
    source = root / "random.toml"
    source.write_text(read_scenario_text("crh2-dmpc")[0] + RANDOM, encoding="utf-8")
    assert main(["sweep", str(source), "-o", str(root / "sampled"), "--no-simulate",
                 "-j", "2"]) == 0
    return root / "sampled"


@pytest.fixture(scope="module")
def seeds_only(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Analysis only, the seed alone swept."""
    return _sweep(tmp_path_factory.mktemp("sweep") / "seeds", "--seeds", "3", "--no-simulate")


def _render(store: Path, out: Path, *extra: str) -> str:
    assert main(["report", str(store), "-o", str(out), "--deterministic", *extra]) == 0
    return out.read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def pages(grid2: Path, seeded: Path, three: Path, simulated: Path,
          tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    out = tmp_path_factory.mktemp("pages")
    return {name: _render(store, out / f"{name}.html", "--timestamp", FIXED)
            for name, store in (("grid2", grid2), ("seeded", seeded), ("three", three),
                                ("simulated", simulated))}


def _figure_ids(html: str) -> list[str]:
    return re.findall(r'<figure id="figure-([\w-]+)">', html)


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def _varies(values: pd.Series) -> bool:
    present = [v for v in values if not pd.isna(v)]
    if not present:
        return False
    if all(isinstance(v, (int, float)) for v in present):
        lo, hi = min(present), max(present)
        return hi - lo > 1e-9 * max(abs(lo), abs(hi)) or len(present) != len(values)
    return len(set(map(str, values))) > 1


# --------------------------------------------------------------------------- page


@pytest.mark.parametrize("name", ["grid2", "seeded", "three", "simulated"])
def test_well_formed_and_self_contained(pages: dict[str, str], name: str) -> None:
    """An HTML5 page nesting properly, with no script, no link, nothing remote."""
    html = pages[name]
    assert html.startswith("<!DOCTYPE html>")
    page = parse(html)
    assert page.errors == [] and page.stack == []
    assert not {"script", "link", "iframe", "object", "embed", "img"} & set(page.tags)
    for tag, attr, value in page.attrs:
        assert not attr.startswith("on"), (tag, attr)
        if attr in {"src", "href", "xlink:href", "srcset", "action", "data"}:
            assert value.startswith("#"), (tag, attr, value)
    assert not re.search(r"url\(\s*['\"]?(?!#)", html)
    assert "@import" not in html
    ids = page.ids
    assert len(ids) == len(set(ids))
    assert "/tmp" not in html and str(Path.home()) not in html  # no machine paths


def test_sections_and_header(pages: dict[str, str], grid2: Path) -> None:
    html = pages["grid2"]
    for key in ("sweep", "points", "checks", "certificates", "reproducibility"):
        assert f'<section id="{key}">' in html and f'href="#{key}"' in html
    assert '<section id="metrics">' not in html  # nothing simulated
    text = parse(html).text_of("section")
    assert "controller.r_per_kn2 [per kN²]" in text and "model.sample_time [s]" in text
    assert "1, 3, 10, 30" in text and "not swept" in text
    assert "no (--no-simulate)" in text
    manifest = json.loads((grid2 / "sweep.json").read_text(encoding="utf-8"))
    assert f"trainctl {manifest['trainctl']}" in text
    assert text.count("894e296a50fd") <= 1  # keys shortened to 12 digits
    assert len(re.findall(r'<table class="sweep-points">.*?</table>', html, re.DOTALL)) == 1
    assert "<details open>" in html  # 8 points: the table is open


@pytest.mark.parametrize("name", ["grid2", "simulated"])
def test_a_figure_per_varying_column(pages: dict[str, str], name: str, request) -> None:
    """Every check and metric that varies has its figure; the constant ones are listed."""
    store = request.getfixturevalue(name)
    table = SweepStore.load(store).read_table()
    html = pages[name]
    figures = set(_figure_ids(html))
    skipped = re.search(r'<table class="sweep-skipped">(.*?)</table>', html, re.DOTALL)
    listed = set(re.findall(r"<code>([^<]+)</code>", skipped.group(1))) if skipped else set()
    for column in table.columns:
        if column.startswith("check."):
            rows = table.drop_duplicates("point")
            key = "check-" + _slug(column[6:])
        elif column.startswith("metric."):
            rows = table[table["strategy"] != ""]
            key = "metric-" + _slug(column[7:])
        else:
            continue
        if _varies(rows[column]):
            assert key in figures, column
        else:
            assert column in listed and key not in figures, column
    assert "check-ndmpc-convergence-value" in figures
    assert "check-ndmpc-convergence-status" in figures
    if name == "simulated":
        for metric in ("rms-error", "max-error", "tracking-ok"):
            assert f"metric-{metric}" in figures
        # one heat-map panel per strategy, named in the SVG
        svg = re.search(r'<figure id="figure-metric-rms-error">(.*?)</figure>', html,
                        re.DOTALL).group(1)
        for strategy in ("centralised", "decentralised", "ndmpc"):
            assert f">{strategy}</text>" in svg


def test_axis_labels_carry_units(pages: dict[str, str]) -> None:
    svg = re.search(r'<figure id="figure-check-ndmpc-convergence-value">(.*?)</figure>',
                    pages["grid2"], re.DOTALL).group(1)
    assert "controller.r_per_kn2 [per kN²]" in svg and "model.sample_time [s]" in svg


def test_seeds_draw_median_and_band(pages: dict[str, str]) -> None:
    """One parameter with seeds: lines with a min–max band, log x over 1 … 100."""
    html = pages["seeded"]
    text = parse(html).text_of("section")
    assert "2 seeds (0, 1)" in text
    figure = re.search(r'<figure id="figure-check-ndmpc-convergence-value">(.*?)</figure>',
                       html, re.DOTALL).group(1)
    assert "min–max over seeds" in figure and "median" in figure
    assert "10⁰" in figure and "10²" in figure  # log scale: 1 … 100 spans two decades
    assert "the band the min–max over seeds" in figure


def test_three_parameters_faceted(pages: dict[str, str]) -> None:
    html = pages["three"]
    figure = re.search(r'<figure id="figure-check-ndmpc-convergence-value">(.*?)</figure>',
                       html, re.DOTALL).group(1)
    assert "one panel per value of controller.prediction_horizon" in figure
    assert "controller.prediction_horizon = 8" in figure
    assert "controller.prediction_horizon = 12" in figure


# --------------------------------------------------------------------------- certificates


def _certificate_table(html: str, check: str) -> dict[str, tuple[int, int]]:
    table = re.search(rf'<table class="certificate" data-check="{check}">(.*?)</table>', html,
                      re.DOTALL)
    assert table, check
    rows = re.findall(r'<tr class="predicted-(\w+)">.*?<td class="num">(\d+)</td>'
                      r'<td class="num">(\d+)</td>', table.group(1), re.DOTALL)
    return {status: (int(ok), int(bad)) for status, ok, bad in rows}


def test_certificate_counts_match_the_table(pages: dict[str, str], simulated: Path) -> None:
    """ndmpc_convergence against the ndmpc simulation, counted here from rows.parquet."""
    table = pd.read_parquet(simulated / "rows.parquet")
    rows = table[table["strategy"] == "ndmpc"]
    if "metric.converged" in table.columns:
        outcome, good = "metric.converged", True
    else:
        outcome, good = "metric.tracking_ok", True
    expected: dict[str, list[int]] = {}
    for status, value in zip(rows["check.ndmpc_convergence.status"], rows[outcome], strict=True):
        cell = expected.setdefault(status, [0, 0])
        cell[0 if bool(value) == good else 1] += 1
    shown = _certificate_table(pages["simulated"], "ndmpc_convergence")
    for status, (ok, bad) in shown.items():
        assert (ok, bad) == tuple(expected.get(status, [0, 0])), status
    assert sum(ok + bad for ok, bad in shown.values()) == len(rows) == 4
    # R = 1 at T = 20 s: ρ(D0) > 1 fails, and the iteration did not settle there
    assert expected["fail"][1] == 1
    html = pages["simulated"]
    assert '<figure id="figure-certificate-ndmpc-convergence">' in html
    assert f"{outcome}</code> of ndmpc" in html
    if outcome != "metric.converged":
        assert "metric.converged is not in this store" in html


def test_tracking_table_counts(pages: dict[str, str], simulated: Path) -> None:
    """Every check against tracking held in every strategy, counted from rows.parquet."""
    table = pd.read_parquet(simulated / "rows.parquet")
    tracked = table.groupby("point")["metric.tracking_ok"].all()
    points = table.drop_duplicates("point")
    html = pages["simulated"]
    body = re.search(r'<table class="tracking">(.*?)</table>', html, re.DOTALL).group(1)
    for check in ("sampling", "ndmpc_convergence", "string_stability"):
        row = re.search(rf"<code>{check}</code></th>(.*?)</tr>", body, re.DOTALL).group(1)
        numbers = [int(n) for n in re.findall(r'<td class="num">(\d+)<', row)]
        statuses = points[f"check.{check}.status"]
        expected = []
        for status in ("pass", "warn", "fail"):
            for ok in (True, False):
                expected.append(sum(1 for p, s in zip(points["point"], statuses, strict=True)
                                    if s == status and bool(tracked[p]) == ok))
        assert numbers == expected, check


def test_no_certificates_without_simulations(pages: dict[str, str]) -> None:
    assert "the points were not simulated" in pages["grid2"]
    assert 'class="certificate"' not in pages["grid2"]


def test_certificates_declared_once() -> None:
    checks = [c.check for c in CERTIFICATES]
    assert len(checks) == len(set(checks))
    assert {"ndmpc_convergence", "hinf_delay_margin", "synchronous_delay_margin"} <= set(checks)
    ndmpc = next(c for c in CERTIFICATES if c.check == "ndmpc_convergence")
    assert ndmpc.outcomes[0].column == "metric.converged"


def test_agreement_counts() -> None:
    pairs = [("pass", True), ("pass", False), ("fail", False), ("fail", True), ("warn", True),
             ("pass", None), ("error", False)]
    c = agreement_counts(pairs)
    assert (c["pass & ok"], c["pass & not ok"], c["fail & not ok"], c["fail & ok"]) == (1, 1, 1, 1)
    assert c["warn & ok"] == 1 and c["no outcome"] == 1 and c["other & not ok"] == 1
    assert c["agree"] == 2 and c["decided"] == 4


def test_units_and_scales() -> None:
    assert key_label("model.sample_time") == "model.sample_time [s]"
    assert key_label("controller.r_per_kn2") == "controller.r_per_kn2 [per kN²]"
    assert key_label("no.such_key_s") == "no.such_key_s [s]"
    assert key_label("train.vehicle[1].mass_t") == "train.vehicle[1].mass_t [t]"
    assert is_log([1, 100]) and not is_log([1, 10]) and not is_log([-1, 100])
    assert not is_log([math.nan])


# --------------------------------------------------------------------------- files


def test_deterministic_twice_identical(grid2: Path, tmp_path: Path) -> None:
    a = _render(grid2, tmp_path / "a.html")
    b = _render(grid2, tmp_path / "b.html")
    assert a.encode() == (tmp_path / "b.html").read_bytes().decode().encode() and a == b
    assert "Generated" not in parse(a).text_of("header")


def test_default_output_inside_the_store(grid2: Path, tmp_path: Path) -> None:
    store = tmp_path / "copy"
    shutil.copytree(grid2, store)
    assert main(["report", str(store), "--deterministic"]) == 0
    assert (store / REPORT_NAME).is_file()
    # the store still opens for reading and resuming
    assert load_sweep_report_data(store).manifest["swept"] == ["controller.r_per_kn2",
                                                                "model.sample_time"]


def _no_table(d: Path) -> None:
    (d / "rows.parquet").unlink()


def _bad_manifest(d: Path) -> None:
    (d / "sweep.json").write_text('{"format": "trainctl-sweep/1", "points": 3', encoding="utf-8")


def _wrong_manifest(d: Path) -> None:
    manifest = json.loads((d / "sweep.json").read_text(encoding="utf-8"))
    manifest["points"] = manifest["points"][:-1]
    (d / "sweep.json").write_text(json.dumps(manifest), encoding="utf-8")


def _bad_table(d: Path) -> None:
    (d / "rows.parquet").write_bytes(b"not parquet")


def _table_without_column(d: Path) -> None:
    table = pd.read_parquet(d / "rows.parquet").drop(columns=["model.sample_time"])
    table.to_parquet(d / "rows.parquet", index=False)


BAD = {
    "unfinished": (_no_table, "the sweep has not finished"),
    "damaged manifest": (_bad_manifest, "sweep.json: not valid JSON"),
    "manifest and table differ": (_wrong_manifest, "fingerprint must be the SHA-256"),
    "damaged table": (_bad_table, "not a readable Parquet table"),
    "column missing": (_table_without_column, "lacks the column(s) model.sample_time"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_store_exits_2(case: str, grid2: Path, tmp_path: Path,
                           capsys: pytest.CaptureFixture[str]) -> None:
    """Each kind of damage: exit 2, one message, no traceback, nothing written."""
    tamper, needle = BAD[case]
    store = tmp_path / "store"
    shutil.copytree(grid2, store)
    tamper(store)
    out = tmp_path / "r.html"
    assert main(["report", str(store), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("trainctl: error: "), err
    assert needle in err, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists() and not (store / REPORT_NAME).exists()
    assert not list(tmp_path.glob(".r.html*"))


def test_random_samples_scatter_and_fold(sampled: Path, tmp_path: Path) -> None:
    """Random axes fill no grid: dots at the drawn values; 22 points fold the points table."""
    html = _render(sampled, tmp_path / "r.html")
    assert "<details open>" not in html and "22 points: swept values" in html
    figure = re.search(r'<figure id="figure-check-ndmpc-convergence-value">(.*?)</figure>',
                       html, re.DOTALL).group(1)
    assert "train.vehicle[0].mass_t [t]" in figure
    assert "10⁰" in figure and "10¹" in figure  # log x: 0.5 … 50
    assert "<image" not in html  # colour bars and maps are vectors
    assert len(re.findall(r"<tr><th scope=\"row\">\d+</th>", html)) == 22


def test_seeds_only_drawn_against_the_seed(seeds_only: Path, tmp_path: Path) -> None:
    html = _render(seeds_only, tmp_path / "s.html")
    text = parse(html).text_of("section")
    assert "3 seeds (0, 1, 2)" in text and "drawn against seed" in text
    assert "No check changes over the sweep." in text or _figure_ids(html)


def _synthetic(rows: list[dict], swept: list[str]) -> SweepReportData:
    from trainctl.sweep.store import rows_frame

    points = sorted({r["point"] for r in rows})
    manifest = {"format": "trainctl-sweep/1", "trainctl": "0", "scenario": "x", "simulate": True,
                "swept": swept, "points": [{"index": p, "key": f"k{p}", "values": {}}
                                           for p in points]}
    return SweepReportData(name="x", manifest=manifest, table=rows_frame(rows, swept),
                           scenario_name="x", check_units={}, check_thresholds={})


def test_delay_margin_certificates_use_the_matching_strategy() -> None:
    """hinf_delay_margin against metric.diverged of the H∞ strategy, not of the others."""
    from trainctl.report.sweep import build_sweep_context

    rows = []
    for point, (delay, status, diverged) in enumerate([(0.5, "pass", False), (1.0, "pass", True),
                                                      (2.0, "fail", True)]):
        for strategy, div in (("distributed", diverged), ("synchronous.synchronous", False)):
            rows.append({"point": point, "point_key": f"k{point}", "network.delay_max_s": delay,
                         "strategy": strategy, "check.hinf_delay_margin.status": status,
                         "check.hinf_delay_margin.value": 1.5,
                         "check.synchronous_delay_margin.status": "fail",
                         "check.synchronous_delay_margin.value": 0.1,
                         "metric.diverged": div, "metric.tracking_ok": not div})
    data = _synthetic(rows, ["network.delay_max_s"])
    context = build_sweep_context(data, deterministic=True)
    found = {c["check"]: c for c in context["certificates"]}
    hinf = found["hinf_delay_margin"]
    assert hinf["strategy"] == "distributed" and hinf["outcome"] == "metric.diverged"
    counts = {r["status"]: (r["ok"], r["not_ok"]) for r in hinf["counts"]}
    assert counts["pass"] == (1, 1) and counts["fail"] == (0, 1)
    assert (hinf["agree"], hinf["decided"]) == (2, 3)
    sync = found["synchronous_delay_margin"]
    assert sync["strategy"] == "synchronous.synchronous"
    assert {r["status"]: (r["ok"], r["not_ok"]) for r in sync["counts"]}["fail"] == (3, 0)
    assert "ndmpc_convergence" not in found  # no such check or strategy here
    assert hinf["figure"] is not None  # one parameter: a row of cells
    html = render_sweep_report(context)
    assert 'data-check="hinf_delay_margin"' in html


def test_sweep_figures_keep_their_labels_inside() -> None:
    """Heat maps, status maps, certificates and lines: nothing drawn outside the canvas."""
    from tests.test_report_figures import _inside
    from trainctl.report.figures_sweep import (
        Grid,
        Line,
        Panel,
        category_figure,
        certificate_figure,
        line_figure,
        numeric_map_figure,
    )

    grid = Grid("controller.r_per_kn2 [per kN²]", "model.sample_time [s]",
                ("0.1", "1", "10", "100"), ("10", "20", "40"))
    cells = {(i, j): 10.0 ** (i - 1) * (j + 1) for i in range(4) for j in range(3)}
    panels = [Panel(name, dict(cells)) for name in ("centralised", "lqr.decentralised",
                                                    "ndmpc", "decentralised")]
    status = [Panel("", {c: ("pass" if v < 5 else "fail") for c, v in cells.items()},
                    marks={c: v < 20 for c, v in cells.items()})]
    figures = [
        numeric_map_figure(grid, panels, label="max_coupler_force [N]"),
        category_figure(grid, status, categories=["pass", "fail"],
                        legend_title="ndmpc_convergence status"),
        certificate_figure(grid, status, categories=["pass", "fail"], outcome="converged",
                           outcome_not="did not converge"),
        line_figure([Line("ndmpc", (0.1, 1.0, 10.0), (1.0, 2.0, 30.0), (0.5, 1.0, 20.0),
                          (2.0, 3.0, 40.0))], x_label="controller.r_per_kn2 [per kN²]",
                    y_label="rms_error [m/s]", band=True),
    ]
    for figure in figures:
        assert _inside(figure)


def test_panels_capped_beyond_two_parameters() -> None:
    """Four parameters: panels over the last two, at most MAX_PANELS, the caption says so."""
    from trainctl.report.figures_sweep import MAX_PANELS
    from trainctl.report.sweep import build_sweep_context

    keys = ["a.x", "a.y", "a.z", "a.w"]
    rows = []
    for point, (x, y, z, w) in enumerate((x, y, z, w) for x in (1, 2) for y in (1, 2)
                                         for z in (1, 2, 3) for w in (1, 2, 3)):
        rows.append({"point": point, "point_key": f"k{point}", "a.x": x, "a.y": y, "a.z": z,
                     "a.w": w, "strategy": "", "check.c.status": "pass" if x < 2 else "fail",
                     "check.c.value": float(x * y + z + w)})
    context = build_sweep_context(_synthetic(rows, keys), deterministic=True)
    figures = {f.key: f for f in context["check_figures"]}
    assert set(figures) == {"check-c-status", "check-c-value"}
    value = figures["check-c-value"]
    assert f"Showing the first {MAX_PANELS} of 9 panels" in value.caption
    assert "a.z = 1, a.w = 1" in value.svg and "a.z = 3, a.w = 3" not in value.svg
