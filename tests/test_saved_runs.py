# Saved runs edited by hand: every damage is a clean exit 2 naming the file and the key.
"""Tamper with a saved run of a short scenario; ``trainctl report DIR`` must refuse it cleanly."""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from trainctl.cli.main import main
from trainctl.exceptions import ModelError
from trainctl.report import ReportData
from trainctl.report.runfile import FORMAT, RunFile
from trainctl.scenario import builtin_scenario_text
from trainctl.sim.results import SimulationResult

MANIFEST = "trainctl-run.json"
RESULT = "simulations/centralised/result.json"
ARRAYS = "simulations/centralised/arrays.npz"


def short_scenario() -> str:
    """crh2-dmpc shortened to 10 samples and two strategies."""
    text = builtin_scenario_text("crh2-dmpc")
    for pattern, value in [(r"^duration = .*$", "duration = 200.0"),
                           (r"^settle_time = .*$", "settle_time = 0.0"),
                           (r"^strategies = .*$", 'strategies = ["centralised", "ndmpc"]'),
                           (r"^times = .*$", "times = [0.0, 200.0]"),
                           (r"^speeds_kmh = .*$", "speeds_kmh = [72.0, 72.0]")]:
        text, count = re.subn(pattern, value, text, count=1, flags=re.M)
        assert count == 1, pattern
    return text


@pytest.fixture(scope="module")
def saved_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A saved run of the short scenario (made once)."""
    root = tmp_path_factory.mktemp("saved")
    source = root / "short.toml"
    source.write_text(short_scenario(), encoding="utf-8")
    assert main(["analyse", str(source), "--save", str(root / "run")]) == 0
    return root / "run"


def edit_json(path: Path, change: Callable[[dict], object]) -> None:
    document = json.loads(path.read_text(encoding="utf-8"))
    change(document)
    path.write_text(json.dumps(document), encoding="utf-8")


def edit_arrays(path: Path, change: Callable[[dict], object]) -> None:
    with np.load(path) as data:
        arrays = dict(data)
    change(arrays)
    np.savez(path, **arrays)


def replace_text(path: Path, old: str, new: str) -> None:
    text = path.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new, 1), encoding="utf-8")


def _nan_entry(a: dict) -> None:
    a["velocities"][0, 3] = np.nan


TAMPERS: dict[str, tuple[Callable[[Path], object], str]] = {
    "missing manifest key": (
        lambda d: edit_json(d / MANIFEST, lambda x: x.pop("spectra")),
        f"{MANIFEST}: missing required key 'spectra'"),
    "missing nested manifest key": (
        lambda d: edit_json(d / MANIFEST, lambda x: x["results"]["equilibrium"].pop("inputs")),
        "missing required key 'results.equilibrium.inputs'"),
    "wrong manifest type": (
        lambda d: edit_json(d / MANIFEST, lambda x: x["results"]["checks"][0].update(status=3)),
        "results.checks[0].status must be one of 'pass', 'warn', 'fail' (got 3)"),
    "unknown manifest key": (
        lambda d: edit_json(d / MANIFEST, lambda x: x.update(extra=1)),
        "unknown key 'extra'"),
    "family data": (
        lambda d: edit_json(d / MANIFEST, lambda x: x["families"]["mpc"].pop("weight_sweep")),
        "the saved run's data does not fit the report (key 'weight_sweep' is missing)"),
    "strategies": (
        lambda d: edit_json(d / MANIFEST, lambda x: x["strategies"].pop()),
        "must be the strategies of results.simulations"),
    "non-finite manifest number": (
        lambda d: replace_text(d / MANIFEST, '"speed": ', '"speed": NaN, "was": '),
        "results.speed must be a finite number > 0 (got nan)"),
    "missing result.json key": (
        lambda d: edit_json(d / RESULT, lambda x: x.pop("dt")),
        f"{RESULT}: missing required key 'dt'"),
    "result of another strategy": (
        lambda d: edit_json(d / RESULT, lambda x: x.update(controller_name="ndmpc")),
        "controller_name must be 'centralised' (got 'ndmpc')"),
    "statuses one short": (
        lambda d: edit_json(d / RESULT, lambda x: x["statuses"].pop()),
        "'statuses' must hold one entry per sample (10) (got 9)"),
    "wrong array shape": (
        lambda d: edit_arrays(d / ARRAYS, lambda a: a.update(states=a["states"][:, :-1])),
        "'states' must have shape (8, 11)"),
    "missing NPZ member": (
        lambda d: edit_arrays(d / ARRAYS, lambda a: a.pop("inputs")),
        f"{ARRAYS}: missing array 'inputs'"),
    "NaN array": (
        lambda d: edit_arrays(d / ARRAYS, _nan_entry),
        "array 'velocities' must be finite (got nan at [0, 3])"),
    "text array": (
        lambda d: edit_arrays(d / ARRAYS, lambda a: a.update(time=np.array(["x"] * 11))),
        "array 'time' must hold numbers"),
    "not a zip": (
        lambda d: (d / ARRAYS).write_text("no", encoding="utf-8"),
        "not a NumPy .npz archive"),
    "non-JSON manifest": (
        lambda d: (d / MANIFEST).write_text("{not json", encoding="utf-8"),
        f"{MANIFEST}: not valid JSON"),
    "non-JSON result": (
        lambda d: (d / RESULT).write_text("", encoding="utf-8"),
        f"{RESULT}: not valid JSON"),
    "manifest not an object": (
        lambda d: (d / MANIFEST).write_text("[1, 2]", encoding="utf-8"),
        f"must be a {FORMAT!r} file (got format None)"),
    "older format": (
        lambda d: edit_json(d / MANIFEST, lambda x: x.update(format="trainctl.ReportData/2")),
        "saved by an earlier trainctl"),
    "another scenario's TOML": (
        lambda d: (d / "scenario.toml").write_text(
            builtin_scenario_text("crh2-dmpc-well-sampled"), encoding="utf-8"),
        "scenario.toml: holds another scenario ('CRH2 half train — N-DMPC, well sampled"),
    "edited TOML": (
        lambda d: replace_text(d / "scenario.toml", "mass_t = 42.8", "mass_t = 52.8"),
        "scenario.toml: was edited"),
    "missing TOML": (
        lambda d: (d / "scenario.toml").unlink(),
        "scenario.toml is missing"),
    "missing simulation": (
        lambda d: shutil.rmtree(d / "simulations" / "ndmpc"),
        "the run lists strategy 'ndmpc' but has no saved result"),
}


@pytest.mark.parametrize("case", list(TAMPERS))
def test_tampered_run_exits_2(case: str, saved_run: Path, tmp_path: Path,
                              capsys: pytest.CaptureFixture[str]) -> None:
    """Each kind of damage: exit 2, one message naming the file and what is wrong, no page."""
    tamper, needle = TAMPERS[case]
    run = tmp_path / "run"
    shutil.copytree(saved_run, run)
    tamper(run)
    out = tmp_path / "r.html"
    assert main(["report", str(run), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"trainctl: error: {run}"), err
    assert needle in err, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_untouched_run_renders(saved_run: Path, tmp_path: Path) -> None:
    """Control: the same saved run, untouched, loads and renders."""
    data = ReportData.load(saved_run)
    assert list(data.simulations) == ["centralised", "ndmpc"]
    assert main(["report", str(saved_run), "-o", str(tmp_path / "r.html")]) == 0


def test_declaration_matches_what_is_saved(saved_run: Path) -> None:
    """The manifest a save writes is exactly what RunFile declares (no key left out)."""
    document = json.loads((saved_run / MANIFEST).read_text(encoding="utf-8"))
    assert set(document) == set(RunFile.model_fields)
    RunFile.model_validate(document)


def test_simulation_result_load_names_the_file(saved_run: Path, tmp_path: Path) -> None:
    """SimulationResult.load on its own: a ModelError naming result.json and the key."""
    run = tmp_path / "sim"
    shutil.copytree(saved_run / "simulations" / "centralised", run)
    edit_json(run / "result.json", lambda x: x.update(seed="zero"))
    with pytest.raises(ModelError, match=r"result\.json: seed must be a valid integer"):
        SimulationResult.load(run)
