# The tamper suite: saved runs and sweep stores damaged in every systematic way.
"""Damage saved runs and sweep stores systematically; nothing damaged is ever accepted.

Two saved runs are made once per module (a design review without simulations
of ``heavy-haul-hinf``, and ``crh2-dmpc`` shortened to six samples of one
strategy, with its arrays), and one small simulated sweep store. Each case
copies one of them, damages it, and asserts the exact reason of the refusal:
``trainctl report`` exits 2 with one line naming the file and the key path,
never a traceback, never a page. Damage is generated per declared field
(wrong type, out of its domain, missing, an unknown key), per array (missing,
wrong shape, wrong dtype, non-finite, a lying header, truncated), per relation
between fields, and per file of a store. A damaged point of a store is
recomputed when the sweep is resumed, giving the table of the undamaged run.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from trainctl.cli.main import main
from trainctl.scenario import builtin_scenario_text

REPO = Path(__file__).resolve().parents[1]
MANIFEST = "trainctl-run.json"
SIM = "simulations/decentralised"
RESULT = f"{SIM}/result.json"
ARRAYS = f"{SIM}/arrays.npz"

Tamper = Callable[[Path], object]


def small_scenario() -> str:
    """crh2-dmpc over 120 s (six samples of 20 s), the decentralised law only."""
    text = builtin_scenario_text("crh2-dmpc")
    for pattern, value in [(r"^duration = .*$", "duration = 120.0"),
                           (r"^settle_time = .*$", "settle_time = 60.0"),
                           (r"^strategies = .*$", 'strategies = ["decentralised"]')]:
        text, count = re.subn(pattern, value, text, count=1, flags=re.M)
        assert count == 1, pattern
    return text


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """``plain``: heavy-haul-hinf --no-simulate; ``sim``: the small scenario with its arrays."""
    root = tmp_path_factory.mktemp("runs")
    (root / "small.toml").write_text(small_scenario(), encoding="utf-8")
    assert main(["analyse", "heavy-haul-hinf", "--no-simulate", "--save",
                 str(root / "plain")]) == 0
    assert main(["analyse", str(root / "small.toml"), "--save", str(root / "sim")]) == 0
    return {"plain": root / "plain", "sim": root / "sim"}


# --------------------------------------------------------------------------- helpers


def load(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def dump(path: Path, document: Any) -> None:
    path.write_text(json.dumps(document), encoding="utf-8")


def at(document: Any, loc: tuple[Any, ...]) -> tuple[Any, Any]:
    """The container of ``loc``'s last key, and that key."""
    for key in loc[:-1]:
        document = document[key]
    return document, loc[-1]


def path_text(loc: tuple[Any, ...]) -> str:
    text = ""
    for part in loc:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text


def set_json(name: str, loc: tuple[Any, ...], value: Any) -> Tamper:
    def tamper(run: Path) -> None:
        document = load(run / name)
        parent, key = at(document, loc)
        parent[key] = value
        dump(run / name, document)
    return tamper


def drop_json(name: str, loc: tuple[Any, ...]) -> Tamper:
    def tamper(run: Path) -> None:
        document = load(run / name)
        parent, key = at(document, loc)
        del parent[key]
        dump(run / name, document)
    return tamper


def edit_json(name: str, change: Callable[[Any], object]) -> Tamper:
    def tamper(run: Path) -> None:
        document = load(run / name)
        change(document)
        dump(run / name, document)
    return tamper


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    np.savez(path, **arrays)


def edit_arrays(change: Callable[[dict[str, np.ndarray]], object]) -> Tamper:
    def tamper(run: Path) -> None:
        with np.load(run / ARRAYS) as data:
            arrays = dict(data)
        change(arrays)
        write_npz(run / ARRAYS, arrays)
    return tamper


def lying_header(name: str, shape: tuple[int, ...]) -> Tamper:
    """Member ``name`` declares ``shape`` but holds 8 bytes of data."""
    def tamper(run: Path) -> None:
        with np.load(run / ARRAYS) as data:
            arrays = dict(data)
        arrays.pop(name)
        write_npz(run / ARRAYS, arrays)
        header = io.BytesIO()
        descr = "<i8" if name in ("iterations", "saturation") else "<f8"
        np.lib.format.write_array_header_1_0(
            header, {"descr": descr, "fortran_order": False, "shape": shape})
        with zipfile.ZipFile(run / ARRAYS, "a") as archive:
            archive.writestr(f"{name}.npy", header.getvalue() + b"\0" * 8)
    return tamper


def truncate(name: str, keep: float = 0.5) -> Tamper:
    def tamper(run: Path) -> None:
        data = (run / name).read_bytes()
        (run / name).write_bytes(data[:int(len(data) * keep)])
    return tamper


def scenario_edit(old: str, new: str, checksum: bool = True) -> Tamper:
    """Edit scenario.toml and, like a careful forger, update its checksum in the manifest."""
    def tamper(run: Path) -> None:
        text = (run / "scenario.toml").read_text(encoding="utf-8")
        assert old in text, old
        text = text.replace(old, new, 1)
        (run / "scenario.toml").write_text(text, encoding="utf-8")
        if checksum:
            document = load(run / MANIFEST)
            document["scenario_sha256"] = hashlib.sha256(text.encode()).hexdigest()
            dump(run / MANIFEST, document)
    return tamper


def both(*tampers: Tamper) -> Tamper:
    def tamper(run: Path) -> None:
        for one in tampers:
            one(run)
    return tamper


# --------------------------------------------------------------------------- saved-run cases

CASES: dict[str, tuple[str, Tamper, str]] = {}
"""Case name -> (which run, the damage, the text the one-line refusal must contain)."""


def case(name: str, run: str, tamper: Tamper, needle: str) -> None:
    assert name not in CASES, name
    CASES[name] = (run, tamper, needle)


# Declared fields of the manifest: (location, kind). The kind says which values are of the
# wrong type and which are out of the field's domain.
MANIFEST_FIELDS: list[tuple[tuple[Any, ...], str]] = [
    (("source",), "str"), (("command",), "str"), (("strategies",), "list"),
    (("results", "scenario"), "str"), (("results", "train"), "str"),
    (("results", "n_vehicles"), "vehicles"), (("results", "n_states"), "count"),
    (("results", "n_inputs"), "count"), (("results", "n_outputs"), "count"),
    (("results", "states"), "list"), (("results", "outputs"), "list"),
    (("results", "speed"), "positive"), (("results", "speed_kmh"), "positive"),
    (("results", "linearisation"), "str"),
    (("results", "checks", 0, "status"), "verdict"), (("results", "checks", 1, "name"), "str"),
    (("results", "checks", 0, "message"), "str"),
    (("results", "modes", 0, "multiplicity"), "count1"),
    (("results", "modes", 0, "kind"), "str"),
    (("results", "equilibrium", "inputs"), "list"),
    (("results", "sampling", "sample_time"), "sample-time"),
    (("results", "failed_checks"), "list"),
    (("results", "expected", "sampling"), "verdict"),
    (("subsystems", 0, "index"), "index"), (("subsystems", 0, "blocks", 0, "from"), "index"),
    (("subsystems", 0, "blocks", 0, "kind"), "matrix-kind"),
    (("expected", "controllability"), "verdict"),
    (("timings",), "dict"),
    (("results", "simulations", "decentralised", "iterations_max"), "count"),
    (("results", "simulations", "decentralised", "status_counts", "optimal"), "count"),
    (("results", "simulations", "decentralised", "rms_error"), "list"),
    (("results", "simulations", "decentralised", "tracking_ok"), "bool"),
    (("results", "simulations", "decentralised", "energy_kwh"), "number"),
]

WRONG_TYPE = {"str": 3, "list": 7, "dict": [1], "bool": "yes", "number": "fast",
              "vehicles": "4", "count": "3", "count1": "1", "index": 1.5, "positive": "fast",
              "sample-time": "fast",
              "verdict": 3, "matrix-kind": 1}
OUT_OF_DOMAIN: dict[str, list[Any]] = {
    "vehicles": [0, -1, 10**400, 0.5, True, 2001], "count": [-1, 10**400, 0.5],
    "count1": [0, 1.5], "index": [-1, 10**6], "positive": [-25.0, 0.0, 1e9],
    "sample-time": [0.0, -20.0, 1e-9, 1e6],
    "verdict": ["bogus", "PASS", ""], "matrix-kind": ["D"],
}

for loc, kind in MANIFEST_FIELDS:
    which = "sim" if "simulations" in loc or "decentralised" in str(loc) else "plain"
    key = path_text(loc)
    case(f"manifest {key}: wrong type", which, set_json(MANIFEST, loc, WRONG_TYPE[kind]),
         f"{MANIFEST}: {key} ")
    for i, value in enumerate(OUT_OF_DOMAIN.get(kind, [])):
        case(f"manifest {key}: out of domain {i}", which, set_json(MANIFEST, loc, value),
             f"{MANIFEST}: {key} must be")
    if isinstance(loc[-1], str) and kind not in ("verdict",) and loc[-2:] != (
            "status_counts", "optimal") and loc != ("timings",):
        case(f"manifest {key}: missing", which, drop_json(MANIFEST, loc),
             f"{MANIFEST}: missing required key '{key}'")

for loc in [(), ("subsystems", 0), ("subsystems", 0, "blocks", 0)]:
    key = path_text((*loc, "bogus_key"))
    case(f"manifest {key}: unknown key", "plain", set_json(MANIFEST, (*loc, "bogus_key"), 1),
         f"unknown key '{key}'")

case("check value of 401 digits", "plain",
     set_json(MANIFEST, ("results", "checks", 0, "value"), 10**400),
     "results.checks[0].value must be a number (integers within ±2**63)")
case("check threshold a list", "plain",
     set_json(MANIFEST, ("results", "checks", 0, "threshold"), [1, 2]),
     "results.checks[0].threshold must be a number")
case("manifest NaN where finite", "plain",
     set_json(MANIFEST, ("results", "speed"), float("nan")),
     "results.speed must be a finite number > 0 (got nan)")
case("manifest spectrum NaN", "plain",
     set_json(MANIFEST, ("spectra", "open loop", 0, 0), float("inf")),
     "spectra.open loop[0][0] must be a finite")

# Relations between the manifest's fields.
RELATIONS: list[tuple[str, str, Tamper, str]] = [
    ("n_vehicles 1000 for 4 vehicles", "sim", set_json(MANIFEST, ("results", "n_vehicles"), 1000),
     "results.vehicles must have 1000 items, one entry per vehicle"),
    ("n_states not the states' count", "plain", set_json(MANIFEST, ("results", "n_states"), 9),
     "results.states must list n_states = 9 names"),
    ("n_inputs not the inputs' count", "plain", set_json(MANIFEST, ("results", "n_inputs"), 3),
     "results.inputs must list n_inputs = 3 names"),
    ("equilibrium.inputs empty", "plain", set_json(MANIFEST, ("results", "equilibrium",
                                                              "inputs"), []),
     "results.equilibrium.inputs must have 4 items"),
    ("coupler forces one too many", "plain",
     edit_json(MANIFEST, lambda d: d["results"]["equilibrium"]["coupler_forces"].append(0.0)),
     "results.equilibrium.coupler_forces must have 3 items"),
    ("rms_error of the wrong length", "sim",
     edit_json(MANIFEST, lambda d: d["results"]["simulations"]["decentralised"]["rms_error"]
               .pop()), "results.simulations.decentralised.rms_error must have 4 items"),
    ("max_error of the wrong length", "sim",
     edit_json(MANIFEST, lambda d: d["results"]["simulations"]["decentralised"]["max_error"]
               .append(0.1)), "results.simulations.decentralised.max_error must have 4 items"),
    ("coupler peaks of the wrong length", "sim",
     edit_json(MANIFEST, lambda d: d["results"]["simulations"]["decentralised"]
               ["coupler_peak_force"].pop()),
     "results.simulations.decentralised.coupler_peak_force must have 3 items"),
    ("a failing check passed", "plain",
     set_json(MANIFEST, ("results", "failed_checks"), []),
     "results.failed_checks must list the checks whose status is 'fail'"),
    ("a check repeated", "plain",
     edit_json(MANIFEST, lambda d: d["results"]["checks"].append(d["results"]["checks"][0])),
     "must not repeat a check's name"),
    ("a check's verdict changed", "plain",
     set_json(MANIFEST, ("results", "checks", 1, "status"), "warn"),
     "unexpected must be the checks whose status differs from expected"),
    ("unexpected invented", "plain",
     set_json(MANIFEST, ("unexpected",), {"controllability": ["pass", "fail"]}),
     "unexpected must be the checks whose status differs from expected"),
    ("expected differs from results.expected", "plain",
     set_json(MANIFEST, ("expected", "controllability"), "fail"),
     "expected must be results.expected"),
    ("coaches out of order", "plain",
     edit_json(MANIFEST, lambda d: d["subsystems"].reverse()), "subsystems[0].index must be 0"),
    ("status counts not the statuses'", "sim",
     set_json(MANIFEST, ("results", "simulations", "decentralised", "status_counts"),
              {"optimal": 5, "error": 1}),
     "results.simulations.decentralised.status_counts must count the saved result's statuses"),
    ("unknown step status counted", "sim",
     set_json(MANIFEST, ("results", "simulations", "decentralised", "status_counts",
                         "bogus"), 1),
     "results.simulations.decentralised.status_counts.bogus key must be one of 'optimal'"),
    ("iterations_max not the arrays'", "sim",
     set_json(MANIFEST, ("results", "simulations", "decentralised", "iterations_max"), 3),
     "iterations_max must be the largest of the saved result's iteration counts (1)"),
    ("strategies not simulated", "sim", set_json(MANIFEST, ("strategies",), []),
     "strategies [] must be the strategies of results.simulations"),
    ("results of another scenario", "plain",
     set_json(MANIFEST, ("results", "scenario"), "another"),
     "results.scenario must be the saved scenario's"),
    ("another train", "plain", set_json(MANIFEST, ("results", "train"), "X-X"),
     "results.train must be the saved scenario's"),
    ("another speed", "plain", set_json(MANIFEST, ("results", "speed"), 30.0),
     "results.speed must be the saved scenario's"),
    ("another sample time", "plain",
     set_json(MANIFEST, ("results", "sampling", "sample_time"), 7.0),
     "results.sampling.sample_time must be the saved scenario's"),
    ("another vehicle mass", "plain",
     set_json(MANIFEST, ("results", "vehicles", 1, "mass"), 1.0),
     "results.vehicles[1].mass must be the saved scenario's"),
    ("both expected tables edited", "plain", both(
        set_json(MANIFEST, ("expected", "controllability"), "warn"),
        set_json(MANIFEST, ("results", "expected", "controllability"), "warn"),
        set_json(MANIFEST, ("unexpected",), {"controllability": ["warn", "pass"]})),
     "expected must be the saved scenario's"),
    ("negative timing", "plain", set_json(MANIFEST, ("timings",), {"analysis": -1.0}),
     "timings.analysis must be"),
]
for name, which, tamper, needle in RELATIONS:
    case(f"relation: {name}", which, tamper, needle)

# The scenario text, edited with its checksum updated: it must still be the run's scenario.
case("scenario renamed", "plain", scenario_edit('name = "', 'name = "Forged '),
     "results.scenario must be the saved scenario's")
case("scenario mass edited", "sim", scenario_edit("mass_t = 48.0", "mass_t = 58.0"),
     "results.vehicles[1].mass must be the saved scenario's")
case("scenario vehicle renamed", "sim", scenario_edit('name = "M"', 'name = "Q"'),
     "results.train must be the saved scenario's ('T-Q-M-T'")
case("scenario sample time edited", "sim",
     scenario_edit("sample_time = 20.0", "sample_time = 10.0"),
     "results.sampling.sample_time must be the saved scenario's")
case("scenario speed edited", "sim", scenario_edit("speed_kmh = 300.0", "speed_kmh = 250.0"),
     "results.speed must be the saved scenario's")
case("scenario strategy edited", "sim",
     scenario_edit('strategies = ["decentralised"]', 'strategies = ["centralised"]'),
     "strategies must be among the saved scenario's [simulation] strategies")
case("scenario expected edited", "sim",
     scenario_edit('open_loop_stability = "pass"', 'open_loop_stability = "fail"'),
     "expected must be the saved scenario's")
case("scenario not TOML", "plain", scenario_edit('name = "', 'name = = "'),
     "scenario.toml: not a valid scenario")
case("scenario out of its domain", "sim", scenario_edit("mass_t = 48.0", "mass_t = -48.0"),
     "scenario.toml: not a valid scenario")
case("scenario edited, checksum not", "plain",
     scenario_edit("[expected]", "# edited\n[expected]", checksum=False),
     "scenario.toml: was edited")
case("scenario too large", "plain",
     lambda run: (run / "scenario.toml").write_bytes(b"#" * (5 * 2**20)),
     "scenario.toml: is too large for a scenario file")
case("checksum not hexadecimal", "plain", set_json(MANIFEST, ("scenario_sha256",), "x" * 64),
     "scenario_sha256 must match pattern '^[0-9a-f]{64}$'")

# result.json: its declared fields.
RESULT_FIELDS: list[tuple[str, list[Any], str]] = [
    ("controller_name", [3], "controller_name must be"),
    ("seed", ["zero", 0.5], "seed must be"),
    ("dt", ["fast", 0.0, -20.0], "dt must be"),
    ("statuses", [7, ["bogus"] * 6, [3] * 6], "statuses"),
    ("fallbacks", [7, [1] * 6], "fallbacks"),
    ("residuals", [7, [["x"]] * 6], "residuals"),
    ("meta", [[], 1], "meta must be"),
    ("format", ["trainctl.SimulationResult/0"], "must be a 'trainctl.SimulationResult/1'"),
]
for field, values, needle in RESULT_FIELDS:
    for i, value in enumerate(values):
        case(f"result.json {field}: bad value {i}", "sim", set_json(RESULT, (field,), value),
             f"{RESULT}: {needle}")
    if field != "format":
        case(f"result.json {field}: missing", "sim", drop_json(RESULT, (field,)),
             f"{RESULT}: missing required key '{field}'")
case("result.json unknown key", "sim", set_json(RESULT, ("bogus_key",), 1),
     "unknown key 'bogus_key'")
case("unknown step status", "sim", set_json(RESULT, ("statuses", 2), "bogus"),
     f"{RESULT}: statuses[2] must be one of 'optimal'")
case("statuses one short", "sim", edit_json(RESULT, lambda d: d["statuses"].pop()),
     "'statuses' must hold one entry per sample (6) (got 5)")
case("meta.n_vehicles 1000", "sim", set_json(RESULT, ("meta", "n_vehicles"), 1000),
     "meta.n_vehicles must be the arrays' vehicle count 4 (got 1000)")
case("dt not the scenario's", "sim", both(
    set_json(RESULT, ("dt",), 10.0),
    edit_arrays(lambda a: a.update(time=a["time"] / 2, dense_time=a["dense_time"] / 2))),
    "dt must be the interval 20.0 s at which the scenario runs")
case("result of another strategy", "sim", set_json(RESULT, ("controller_name",), "ndmpc"),
     "controller_name must be 'decentralised' (got 'ndmpc')")

# arrays.npz: per array.
REQUIRED = ["time", "states", "velocities", "coupler_forces", "inputs", "reference_speed",
            "reference_acceleration", "iterations", "solve_times"]
OPTIONAL = ["requested_inputs", "saturation", "dense_time", "dense_states",
            "dense_coupler_forces", "dense_reference_speed", "held_noise_square"]
FLOATS = [n for n in REQUIRED + OPTIONAL if n not in ("iterations", "saturation")]


def _grow(a: dict[str, np.ndarray], name: str) -> None:
    value = a[name]
    a[name] = np.concatenate([value, value[..., -1:]], axis=-1)


def _nan(a: dict[str, np.ndarray], name: str, bad: float) -> None:
    value = a[name].astype(float)
    value.flat[min(1, value.size - 1)] = bad
    a[name] = value


for name in REQUIRED:
    case(f"array {name}: missing", "sim", edit_arrays(lambda a, n=name: a.pop(n)),
         f"{ARRAYS}: missing array '{name}'")
for name in REQUIRED + OPTIONAL:
    case(f"array {name}: wrong shape", "sim", edit_arrays(lambda a, n=name: _grow(a, n)),
         "must have shape" if name not in ("time", "dense_time") else "must")
    case(f"array {name}: complex dtype", "sim",
         edit_arrays(lambda a, n=name: a.update({n: a[n] + 0j})),
         f"{ARRAYS}: array '{name}' must hold")
    case(f"array {name}: text dtype", "sim",
         edit_arrays(lambda a, n=name: a.update({n: a[n].astype(str)})),
         f"{ARRAYS}: array '{name}' must hold")
    case(f"array {name}: header declares (10**12,)", "sim", lying_header(name, (10**12,)),
         f"{ARRAYS}: array '{name}' declares shape (1000000000000,)")
for name in FLOATS:
    for label, bad in (("NaN", np.nan), ("inf", np.inf)):
        case(f"array {name}: {label}", "sim", edit_arrays(lambda a, n=name, b=bad: _nan(a, n, b)),
             f"{ARRAYS}: array '{name}' must be finite")
case("iterations of 0.5", "sim",
     edit_arrays(lambda a: a.update(iterations=a["iterations"] - 0.5)),
     f"{ARRAYS}: array 'iterations' must hold integers (got dtype float64)")
case("iterations negative", "sim",
     edit_arrays(lambda a: a.update(iterations=-a["iterations"])),
     f"{ARRAYS}: array 'iterations' must be >= 0")
case("solve times negative", "sim",
     edit_arrays(lambda a: a.update(solve_times=-1.0 - a["solve_times"])),
     f"{ARRAYS}: array 'solve_times' must be >= 0")
case("saturation flag 2", "sim",
     edit_arrays(lambda a: a.update(saturation=a["saturation"] + 2)),
     "'saturation' must hold -1, 0 or +1")
case("time not increasing", "sim",
     edit_arrays(lambda a: a.update(time=a["time"][[0, 2, 1, 3, 4, 5, 6]])),
     f"{ARRAYS}: array 'time' must increase strictly")
case("time constant", "sim", edit_arrays(lambda a: a.update(time=a["time"] * 0.0)),
     f"{ARRAYS}: array 'time' must increase strictly")
case("time not in steps of dt", "sim",
     edit_arrays(lambda a: a.update(time=a["time"] ** 1.01)),
     f"{ARRAYS}: array 'time' must advance by dt = 20.0 s")
case("dense time not increasing", "sim",
     edit_arrays(lambda a: a.update(dense_time=a["dense_time"][::-1])),
     "'dense_time' must increase strictly")
case("unknown array", "sim", edit_arrays(lambda a: a.update(bogus=np.zeros(2))),
     f"{ARRAYS}: unknown array 'bogus'")
case("arrays truncated", "sim", truncate(ARRAYS), f"{ARRAYS}: not a NumPy .npz archive")
case("arrays not a zip", "sim", lambda run: (run / ARRAYS).write_text("no"),
     f"{ARRAYS}: not a NumPy .npz archive")
case("arrays deleted", "sim", lambda run: (run / ARRAYS).unlink(), f"{ARRAYS}: file not found")

# Whole files.
case("manifest truncated", "plain", truncate(MANIFEST), f"{MANIFEST}: not valid JSON")
case("manifest not UTF-8", "plain", lambda run: (run / MANIFEST).write_bytes(b"\xff\xfe{}"),
     f"{MANIFEST}: not UTF-8")
case("manifest a list", "plain", lambda run: (run / MANIFEST).write_text("[]"),
     "must be a 'trainctl.ReportData/3' file (got format None)")
case("manifest 3 GiB sparse", "plain",
     lambda run: os.truncate(run / MANIFEST, 3 * 2**30),
     f"{MANIFEST}: is 3221225472 bytes, more than the 268435456 bytes")
case("result.json 3 GiB sparse", "sim", lambda run: os.truncate(run / RESULT, 3 * 2**30),
     f"{RESULT}: is 3221225472 bytes, more than")
case("result.json truncated", "sim", truncate(RESULT), f"{RESULT}: not valid JSON")


@pytest.mark.parametrize("name", list(CASES))
def test_damaged_run_is_refused(name: str, runs: dict[str, Path], tmp_path: Path,
                                capsys: pytest.CaptureFixture[str]) -> None:
    """Each damage: exit 2, one line naming the run's file and the reason, no page written."""
    which, tamper, needle = CASES[name]
    run = tmp_path / "run"
    shutil.copytree(runs[which], run)
    tamper(run)
    out = tmp_path / "r.html"
    capsys.readouterr()
    assert main(["report", str(run), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"trainctl: error: {run}"), err
    assert needle in err, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_enough_kinds_of_damage() -> None:
    assert len(CASES) + len(STORE_CASES) >= 100


def test_check_statuses_are_the_analysis_vocabulary() -> None:
    from trainctl.analysis.check import STATUSES
    from trainctl.report.runfile import CHECK_STATUSES

    assert CHECK_STATUSES == STATUSES


def test_array_cap_refuses_before_reading(runs: dict[str, Path], tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """An archive declaring more than the cap is refused from its zip directory alone."""
    from trainctl.exceptions import ModelError
    from trainctl.sim import resultfile

    monkeypatch.setattr(resultfile, "MAX_ARRAY_BYTES", 1000)
    read: list[str] = []
    monkeypatch.setattr(np.lib.format, "read_array",
                        lambda *a, **k: read.append("read") or np.zeros(1))
    with pytest.raises(ModelError, match=r"arrays\.npz: its arrays declare \d+ bytes "
                                         r"uncompressed, more than the 1000 bytes"):
        resultfile.read_result(runs["sim"] / SIM)
    assert read == []


def test_untouched_runs_render(runs: dict[str, Path], tmp_path: Path) -> None:
    """Control: the undamaged runs render (every refusal above is the damage's doing)."""
    from trainctl.report import ReportData

    assert list(ReportData.load(runs["sim"]).simulations) == ["decentralised"]
    assert ReportData.load(runs["plain"]).simulations == {}
    assert main(["report", str(runs["sim"]), "-o", str(tmp_path / "r.html")]) == 0


# --------------------------------------------------------------------------- sweep stores

SWEEP = ["--set", "controller.r_per_kn2=1,10"]
POINTS = "points"


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished two-point sweep of the small scenario, its simulations' arrays kept."""
    root = tmp_path_factory.mktemp("store")
    (root / "small.toml").write_text(small_scenario(), encoding="utf-8")
    assert main(["sweep", str(root / "small.toml"), *SWEEP, "-o", str(root / "s")]) == 0
    return root / "s"


def sweep_argv(root: Path) -> list[str]:
    return ["sweep", str(root.parent / "small.toml"), *SWEEP, "-o", str(root)]


def point(root: Path, i: int) -> Path:
    return root / POINTS / load(root / "sweep.json")["points"][i]["key"]


def in_point(i: int, name: str, tamper: Callable[[Path], object]) -> Tamper:
    return lambda root: tamper(point(root, i) / name)


def _edit_summary(path: Path) -> None:
    document = load(path)
    document["checks"][0]["value"] = 123.0
    dump(path, document)


def _edit_checksum(path: Path) -> None:
    document = load(path)
    document["summary.json"] = "0" * 64
    dump(path, document)


def _rewrite_table(path: Path) -> None:
    import pandas as pd

    frame = pd.read_parquet(path)
    frame.loc[0, "metric.max_error"] = 0.0
    frame.to_parquet(path, index=False)


def _truncate_file(path: Path) -> None:
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])


STORE_CASES: dict[str, tuple[Tamper, str, str]] = {
    # name: (damage, text of `report STORE`'s refusal, what a resume does: "recompute"/"refuse")
    "point value edited in sweep.json": (
        set_json("sweep.json", ("points", 1, "values", "controller.r_per_kn2"), 11),
        "sweep.json: fingerprint must be the SHA-256 of its points", "refuse"),
    "point key edited in sweep.json": (
        set_json("sweep.json", ("points", 0, "key"), "a" * 64),
        "sweep.json: fingerprint must be the SHA-256", "refuse"),
    "simulate flipped in sweep.json": (
        set_json("sweep.json", ("simulate",), False),
        "sweep.json: fingerprint must be the SHA-256", "refuse"),
    "fingerprint edited": (
        set_json("sweep.json", ("fingerprint",), "0" * 64),
        "sweep.json: fingerprint must be the SHA-256", "refuse"),
    "point index edited": (
        set_json("sweep.json", ("points", 1, "index"), 5),
        "sweep.json: points[1].index must be 1", "refuse"),
    "point values of other keys": (
        set_json("sweep.json", ("points", 1, "values"), {"x": 1}),
        "sweep.json: points[1].values must have the swept keys", "refuse"),
    "point key not a digest": (
        set_json("sweep.json", ("points", 0, "key"), "../../etc"),
        "sweep.json: points[0].key must match pattern '^[0-9a-f]{64}$'", "refuse"),
    "no points": (set_json("sweep.json", ("points",), []),
                  "sweep.json: points must have at least 1 item", "refuse"),
    "arrays choice unknown": (
        set_json("sweep.json", ("arrays",), "all"), "sweep.json: arrays must be one of",
        "refuse"),
    "simulate not a boolean": (
        set_json("sweep.json", ("simulate",), 1), "sweep.json: simulate must be", "refuse"),
    "swept not a list": (
        set_json("sweep.json", ("swept",), "x"), "sweep.json: swept must be", "refuse"),
    "unknown manifest key": (
        set_json("sweep.json", ("bogus_key",), 1), "sweep.json: unknown key 'bogus_key'",
        "refuse"),
    "missing manifest key": (
        drop_json("sweep.json", ("scenario",)), "sweep.json: missing required key 'scenario'",
        "refuse"),
    "another version": (
        set_json("sweep.json", ("trainctl",), "0.0.1"),
        "sweep.json: holds the results of another sweep (made by trainctl 0.0.1", "refuse"),
    "another format": (
        set_json("sweep.json", ("format",), "trainctl-sweep/1"),
        "sweep.json: not a 'trainctl-sweep/2' manifest", "refuse"),
    "manifest truncated": (truncate("sweep.json"), "sweep.json: not valid JSON", "refuse"),
    "manifest 3 GiB sparse": (
        lambda root: os.truncate(root / "sweep.json", 3 * 2**30),
        "sweep.json: is 3221225472 bytes, more than", "refuse"),
    "summary value edited": (
        in_point(0, "summary.json", _edit_summary),
        "summary.json: its SHA-256 is not the one in checksums.json", "recompute"),
    "summary deleted": (
        in_point(1, "summary.json", Path.unlink), "summary.json: missing", "recompute"),
    "summary truncated": (
        in_point(0, "summary.json", _truncate_file), "summary.json: its SHA-256", "recompute"),
    "arrays truncated": (
        in_point(1, "runs/decentralised/arrays.npz", _truncate_file),
        "arrays.npz: its SHA-256 is not the one in checksums.json", "recompute"),
    "arrays deleted": (
        in_point(0, "runs/decentralised/arrays.npz", Path.unlink), "arrays.npz: missing",
        "recompute"),
    "result.json edited": (
        in_point(0, "runs/decentralised/result.json",
                 lambda p: p.write_text(p.read_text().replace('"seed": 0', '"seed": 1'))),
        "result.json: its SHA-256", "recompute"),
    "checksums deleted": (
        in_point(1, "checksums.json", Path.unlink), "checksums.json: missing", "recompute"),
    "checksum edited": (
        in_point(0, "checksums.json", _edit_checksum), "summary.json: its SHA-256",
        "recompute"),
    "checksums not JSON": (
        in_point(0, "checksums.json", _truncate_file), "checksums.json: not readable",
        "recompute"),
    "checksums list a file outside": (
        in_point(0, "checksums.json",
                 lambda p: dump(p, {**load(p), "../../sweep.json": "0" * 64})),
        "checksums.json: lists '../../sweep.json', outside the point", "recompute"),
    "point directory emptied": (
        lambda root: [f.unlink() for f in point(root, 1).rglob("*") if f.is_file()],
        "checksums.json: missing", "recompute"),
    "table edited": (
        lambda root: _rewrite_table(root / "rows.parquet"),
        "rows.parquet: is not the table of the store's points", "recompute"),
    "table truncated": (
        lambda root: _truncate_file(root / "rows.parquet"),
        "rows.parquet: not a readable Parquet table", "recompute"),
    "table deleted": (
        lambda root: (root / "rows.parquet").unlink(), "the sweep has not finished",
        "recompute"),
}


@pytest.mark.parametrize("name", list(STORE_CASES))
def test_damaged_store_report_refused(name: str, store: Path, tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    """``report STORE``: exit 2, one line naming the damaged file and why, no page."""
    tamper, needle, _ = STORE_CASES[name]
    root = tmp_path / "s"
    shutil.copytree(store, root)
    tamper(root)
    out = tmp_path / "r.html"
    capsys.readouterr()
    assert main(["report", str(root), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"trainctl: error: {root}"), err
    assert needle in err, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file() and p.name != "rows.csv"}


@pytest.mark.parametrize("name", [n for n, c in STORE_CASES.items() if c[2] == "recompute"])
def test_damaged_point_recomputed_on_resume(name: str, store: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """Resuming a damaged store recomputes what is damaged (said on stderr): the undamaged
    store's files again, byte for byte where they do not hold wall-clock times."""
    tamper, needle, _ = STORE_CASES[name]
    (tmp_path / "small.toml").write_text(small_scenario(), encoding="utf-8")
    root = tmp_path / "s"
    shutil.copytree(store, root)
    tamper(root)
    capsys.readouterr()
    assert main(sweep_argv(root)) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if "rows.parquet" not in needle and "not finished" not in needle:
        assert "is damaged; recomputing it" in err and needle.split(":")[0] in err, err
    from trainctl.report.sweep import load_sweep_report_data

    load_sweep_report_data(root)  # what `report STORE` checks: every point whole again
    before, after = _files(store), _files(root)
    assert sorted(after) == sorted(before)  # no point twice, nothing left over
    assert after["rows.parquet"] == before["rows.parquet"]
    assert after["sweep.json"] == before["sweep.json"]
    for key in after:
        if key.endswith("summary.json"):
            assert load(root / key) == load(store / key)


@pytest.mark.parametrize("name", [n for n, c in STORE_CASES.items() if c[2] == "refuse"])
def test_damaged_manifest_refused_on_resume(name: str, store: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    """A damaged manifest cannot be recomputed: the sweep refuses it as report does."""
    tamper, needle, _ = STORE_CASES[name]
    (tmp_path / "small.toml").write_text(small_scenario(), encoding="utf-8")
    root = tmp_path / "s"
    shutil.copytree(store, root)
    tamper(root)
    before = _files(root) if name != "manifest 3 GiB sparse" else None
    capsys.readouterr()
    assert main(sweep_argv(root)) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err, err
    if before is not None:
        assert _files(root) == before


# --------------------------------------------------------------------------- concurrent writers

_SLOW = """
import sys, time
from trainctl.sweep import store as _store
_real = _store.SweepStore.write_point
def _announced(self, key, summary, simulations=None):
    path = _real(self, key, summary, simulations)
    sys.stderr.write("STORED\\n"); sys.stderr.flush()
    time.sleep(3.0)
    return path
_store.SweepStore.write_point = _announced
from trainctl.cli.main import main
sys.exit(main(sys.argv[1:]))
"""
WEIGHTS = ["--set", "controller.r_per_kn2=1,2,3,5", "--no-simulate"]


def _cli(out: Path, slow: bool) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    plain = "import sys; from trainctl.cli.main import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.Popen([sys.executable, "-c", _SLOW if slow else plain, "sweep",
                             "crh2-dmpc", *WEIGHTS, "-o", str(out)], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def _wait_stored(process: subprocess.Popen[str], count: int) -> None:
    assert process.stderr is not None
    stored, deadline = 0, time.monotonic() + 180
    while stored < count and time.monotonic() < deadline:
        line = process.stderr.readline()
        if not line and process.poll() is not None:
            break
        stored += line.strip() == "STORED"
    assert stored == count, "the sweep never stored its points"


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("serial") / "s"
    assert main(["sweep", "crh2-dmpc", *WEIGHTS, "-o", str(root)]) == 0
    return root


def _same_store(root: Path, reference: Path) -> None:
    assert (root / "rows.parquet").read_bytes() == (reference / "rows.parquet").read_bytes()
    names = sorted(p.name for p in (root / POINTS).iterdir())
    assert names == sorted(p.name for p in (reference / POINTS).iterdir())  # none twice
    assert not [n for n in names if "partial" in n]


@pytest.mark.slow
@pytest.mark.e2e  # two real CLI sweeps on one store (test_lock_names_the_holder: make test)
def test_second_writer_refused_while_the_first_runs(serial: Path, tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    """Two writers on one store: the second exits 2 naming the first's PID; the first's
    table is the serial run's, every point once."""
    out = tmp_path / "s"
    first = _cli(out, slow=True)
    try:
        _wait_stored(first, 1)
        capsys.readouterr()
        assert main(["sweep", "crh2-dmpc", *WEIGHTS, "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert f"store in use by PID {first.pid}" in err and "Traceback" not in err, err
        second = _cli(out, slow=False)
        _, second_err = second.communicate(timeout=120)
        assert second.returncode == 2 and f"store in use by PID {first.pid}" in second_err
        _, first_err = first.communicate(timeout=300)
        assert first.returncode == 0, first_err
    finally:
        if first.poll() is None:
            first.kill()
            first.communicate()
    _same_store(out, serial)
    assert main(["report", str(out), "-o", str(tmp_path / "r.html")]) == 0


@pytest.mark.slow
@pytest.mark.e2e  # a real CLI sweep killed, then resumed (test_lock_names_the_holder: make test)
def test_kill_9_mid_sweep_then_resume(serial: Path, tmp_path: Path) -> None:
    """SIGKILL after the first point: the lock dies with the process; the resume runs the
    rest once and gives the serial run's table."""
    out = tmp_path / "s"
    first = _cli(out, slow=True)
    try:
        _wait_stored(first, 1)
        os.kill(first.pid, signal.SIGKILL)
        first.wait(timeout=30)
    finally:
        first.kill()
        first.communicate()
    assert first.returncode == -signal.SIGKILL
    assert not (out / "rows.parquet").exists()
    again = _cli(out, slow=False)
    _, err = again.communicate(timeout=300)
    assert again.returncode == 0, err
    assert "resuming" in err and "1 points stored, 3 to run" in err, err
    _same_store(out, serial)


def test_lock_names_the_holder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A store held by another process (here a child holding the lock) is refused at once."""
    out = tmp_path / "s"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, os, sys, time; os.makedirs(sys.argv[1]); "
         "f = open(sys.argv[1] + '/.trainctl-sweep.lock', 'w'); "
         "fcntl.flock(f, fcntl.LOCK_EX); f.write(str(os.getpid())); f.flush(); "
         "print('held', flush=True); time.sleep(120)", str(out)],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        capsys.readouterr()
        assert main(["sweep", "crh2-dmpc", *WEIGHTS, "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert f"{out}: store in use by PID {holder.pid}" in err, err
        assert sorted(p.name for p in out.iterdir()) == [".trainctl-sweep.lock"]
    finally:
        holder.kill()
        holder.communicate()
    assert main(["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1", "--no-simulate",
                 "-o", str(out)]) == 0  # released with its holder
