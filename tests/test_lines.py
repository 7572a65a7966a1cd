"""Railway lines from TTOBench files: every file loads, profiles as in the file, clear refusals.

The TTOBench track library (``tests/data/ttobench``, BSD 2-Clause, source in
``SOURCE``) is read by :func:`trainctl.models.lines.read_line`. Its grade,
curvature and speed-limit profiles are checked against the JSON itself, read
here with :mod:`json` alone: at every breakpoint, and just before the next one.
A clothoid's equivalent radius is checked against the mean |curvature| by
numerical quadrature. Malformed files are refused by ``trainctl analyse`` with
exit status 2, the message naming the file and the key.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.test_cli import assert_refused
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.models.lines import LINES, builtin_line, line_from_document, read_line
from trainctl.models.track import SpeedLimit, Track
from trainctl.scenario import builtin_scenario_text, load_scenario, parse_scenario

DATA = Path(__file__).parent / "data" / "ttobench"
FILES = sorted(DATA.glob("*.json"))
KMH = 3.6


def _section_at(track: Track, position: float):
    """The TrackSection holding ``position`` (by the sections' starts, read here)."""
    starts = [s.start for s in track.sections]
    i = max(j for j, start in enumerate(starts) if start <= position)
    return track.sections[i]


def test_the_library_is_here() -> None:
    assert len(FILES) == 15
    assert (DATA / "LICENSE").read_text().startswith("BSD 2-Clause License")


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_every_file_loads_with_its_profiles_at_every_breakpoint(path: Path) -> None:
    doc = json.loads(path.read_text())
    line = read_line(path)
    assert line.name == doc["metadata"]["id"] == path.stem
    assert line.stops == tuple(float(s) for s in doc["stops"]["values"])
    length = line.length
    track = line.track
    limits = doc["speed limits"]["values"]
    assert doc["speed limits"]["units"] == {"position": "m", "velocity": "km/h"}
    for i, (start, limit) in enumerate(limits):
        end = limits[i + 1][0] if i + 1 < len(limits) else length
        for p in (start, 0.5 * (start + end), math.nextafter(end, -math.inf)):
            assert track.speed_limit(p) == pytest.approx(limit / KMH, rel=1e-15)
    grades = doc.get("gradients", {"values": [[0.0, 0.0]]})["values"]
    for i, (start, grade) in enumerate(grades):
        end = grades[i + 1][0] if i + 1 < len(grades) else length
        for p in (start, math.nextafter(end, -math.inf)):
            assert _section_at(track, p).grade_permille == grade
    curves = doc.get("curvatures", {"values": [[0.0, "infinity", "infinity"]]})["values"]
    for i, (start, r1, r2) in enumerate(curves):
        end = curves[i + 1][0] if i + 1 < len(curves) else length
        k1, k2 = (0.0 if r == "infinity" else 1.0 / r for r in (r1, r2))
        s = np.linspace(0.0, 1.0, 200_001)  # |κ| along the section, mean by the trapezoid
        kappa = np.abs(k1 + (k2 - k1) * s)
        mean = float(np.sum(kappa[1:] + kappa[:-1]) / (2 * (s.size - 1)))
        radius = _section_at(track, start).curve_radius
        assert _section_at(track, math.nextafter(end, -math.inf)).curve_radius == radius
        if mean == 0.0:
            assert radius == math.inf
        else:
            assert 1.0 / radius == pytest.approx(mean, rel=1e-8)
    boundaries = {float(row[0]) for key in ("gradients", "curvatures") for row in
                  doc.get(key, {"values": [[0.0]]})["values"]}
    assert [s.start for s in track.sections] == sorted(boundaries)


def test_shipped_lines_are_the_library_files() -> None:
    for name in LINES:
        shipped = builtin_line(name)
        assert shipped.source == f"trainctl:{name}"
        assert shipped.track == read_line(DATA / f"{name}.json").track


def test_speed_limit_holds_from_its_start_to_the_next() -> None:
    track = Track(speed_limits=(SpeedLimit(start=100.0, limit=20.0),
                                SpeedLimit(start=300.0, limit=10.0)))
    assert track.speed_limit([0.0, 99.99, 100.0, 299.99, 300.0, 1e9]).tolist() == [
        math.inf, math.inf, 20.0, 20.0, 10.0, 10.0]
    with pytest.raises(ModelError, match="speed-limit starts must increase strictly"):
        Track(speed_limits=(SpeedLimit(start=100.0, limit=20.0),
                            SpeedLimit(start=100.0, limit=10.0)))
    with pytest.raises(ModelError, match="'limit' must be"):
        SpeedLimit(start=0.0, limit=0.0)


def _broken(edit) -> dict:
    doc = json.loads((DATA / "CH_StGallen_Wil.json").read_text())
    edit(doc)
    return doc


def _set(path: tuple, value):
    def edit(doc):
        node = doc
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    return edit


MALFORMED = {
    "missing metadata": (lambda doc: doc.pop("metadata"), "missing required key 'metadata'"),
    "missing id": (lambda doc: doc["metadata"].pop("id"), "missing required key 'metadata.id'"),
    "unsorted gradients": (_set(("gradients", "values", 3, 0), 100.0),
                           "gradients.values[3][0] must be greater than the previous position"),
    "unsorted stops": (_set(("stops", "values"), [0.0, 500.0, 400.0, 29556.1]),
                       "stops.values[2] must be greater than the previous position 500.0"),
    "unknown velocity unit": (_set(("speed limits", "units", "velocity"), "mph"),
                              "speed limits.units.velocity must be 'km/h' or 'm/s' (got 'mph'"),
    "unknown slope unit": (_set(("gradients", "units", "slope"), "%"),
                           "gradients.units.slope must be"),
    "speed limit zero": (_set(("speed limits", "values", 2, 1), 0),
                         "speed limits.values[2][1] must be a speed > 0 (got 0)"),
    "speed limit negative": (_set(("speed limits", "values", 0, 1), -40),
                             "speed limits.values[0][1] must be a speed > 0 (got -40)"),
    "radius not a number": (_set(("curvatures", "values", 1, 2), "straight"),
                            'curvatures.values[1][2] must be a number, or "infinity"'),
    "misspelt key": (lambda doc: doc.update({"gradient": doc.pop("gradients")}),
                     "unknown key 'gradient'"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_a_malformed_file_is_refused_naming_file_and_key(case: str) -> None:
    edit, message = MALFORMED[case]
    with pytest.raises(ScenarioError) as exc:
        line_from_document(_broken(edit), source="bad/line.json")
    assert str(exc.value).startswith("bad/line.json: ")
    assert message in str(exc.value)


def _scenario_text(track: str) -> str:
    return builtin_scenario_text("crh2-dmpc") + "\n[track]\n" + track + "\n"


def test_a_scenario_reads_a_file_relative_to_itself_and_a_shipped_line(tmp_path: Path) -> None:
    (tmp_path / "lines").mkdir()
    (tmp_path / "lines" / "wil.json").write_text((DATA / "CH_StGallen_Wil.json").read_text())
    path = tmp_path / "mine.toml"
    path.write_text(_scenario_text('file = "lines/wil.json"'))
    scenario = load_scenario(path)
    assert scenario.track == read_line(DATA / "CH_StGallen_Wil.json").track
    again = scenario.replace("model.speed_kmh", 250.0)  # the file found again
    assert again.track == scenario.track
    shipped = parse_scenario(_scenario_text('line = "SE_Vasteras_Kolback"\n'
                                            '[[track.speed_limit]]\nstart = 0.0\n'
                                            'limit_kmh = 72.0'))
    assert shipped.track.sections == builtin_line("SE_Vasteras_Kolback").track.sections
    assert shipped.track.speed_limits == (SpeedLimit(start=0.0, limit=20.0),)


@pytest.mark.parametrize("track, message", [
    ('line = "CH_Fribourg_Bern"\nfile = "x.json"', "[track].file cannot be given with 'line'"),
    ('line = "CH_Bern"', "[track].line must be"),
    ("formula = \"tbt\"", "[track.section] must be given, or 'line' or 'file' instead"),
    ('file = "missing.json"', "missing.json"),
])
def test_track_table_refusals(track: str, message: str, tmp_path: Path,
                              capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(_scenario_text(track))
    assert_refused(path, message, capsys)


@pytest.mark.parametrize("case", ["missing metadata", "unsorted gradients",
                                  "unknown velocity unit", "speed limit zero"])
def test_analyse_exits_2_on_a_malformed_file(case: str, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    edit, message = MALFORMED[case]
    (tmp_path / "line.json").write_text(json.dumps(_broken(edit)))
    path = tmp_path / "mine.toml"
    path.write_text(_scenario_text('file = "line.json"'))
    assert_refused(path, "[track].file = 'line.json' (relative to the scenario file's "
                   "directory): ", capsys)
    assert_refused(path, f"line.json: {message}", capsys)


def test_a_saved_run_reads_its_track_file_from_the_scenario_directory(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    from trainctl.cli.main import main

    work = tmp_path / "work"
    (work / "lines").mkdir(parents=True)
    (work / "lines" / "wil.json").write_text((DATA / "CH_StGallen_Wil.json").read_text())
    (work / "mine.toml").write_text(_scenario_text('file = "lines/wil.json"'))
    monkeypatch.chdir(work)
    assert main(["analyse", "mine.toml", "--no-simulate", "--save", "saved"]) == 0
    monkeypatch.chdir(tmp_path)  # elsewhere: the file is found where the scenario was
    assert main(["report", str(work / "saved"), "-o", str(tmp_path / "r.html")]) == 0
    original = (work / "lines" / "wil.json").read_text()
    changed = json.loads(original)
    changed["gradients"]["values"][1][1] += 1.0  # another track under the same name
    (work / "lines" / "wil.json").write_text(json.dumps(changed))
    capsys.readouterr()
    assert main(["report", str(work / "saved"), "-o", str(tmp_path / "r1.html")]) == 2
    assert "the track file of [track].file changed since the run was saved" in (
        capsys.readouterr().err)
    (work / "lines" / "wil.json").unlink()
    capsys.readouterr()
    assert main(["report", str(work / "saved"), "-o", str(tmp_path / "r2.html")]) == 2
    err = capsys.readouterr().err
    assert "lines/wil.json: file not found" in err and "put it back" in err
    assert not (tmp_path / "r2.html").exists()
