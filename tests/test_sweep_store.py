# The sweep store: points stored whole, resumed after Ctrl-C, another sweep refused.
"""A sweep's store (trainctl.sweep.store) and its runner (trainctl.sweep.runner).

The interrupt test drives the real CLI in a child process: a start-up hook
announces every stored point on stderr, so the test can send SIGINT while
the sweep is mid-way; the same command then finishes the sweep, and its
table must equal, byte for byte, the table of a sweep that ran in one go.
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from trainctl.cli.main import main
from trainctl.exceptions import ScenarioError
from trainctl.scenario import load_scenario
from trainctl.sweep import SweepDefinition, SweepPoint, parse_set, point_key
from trainctl.sweep.runner import run_point_results, run_sweep
from trainctl.sweep.store import SweepStore, is_sweep_store, rows_frame

REPO = Path(__file__).resolve().parents[1]
WEIGHTS = "controller.r_per_kn2=1,2,3,5,7,10,15,20"
"""Eight analysis-only points of the book's N-DMPC (about half a second each)."""


def _sweep(weights: str = WEIGHTS) -> tuple[list[SweepPoint], list[object], list[str]]:
    sweep = SweepDefinition([parse_set(weights)])
    points = sweep.points()
    scenarios = sweep.validate(load_scenario("crh2-dmpc"))
    return points, scenarios, [point_key(s) for s in scenarios]


def _open(path: Path, points: list[SweepPoint], keys: list[str], *, simulate: bool = False,
          arrays: str = "sampled") -> SweepStore:
    return SweepStore.open(path, label="builtin:crh2-dmpc", scenario_text="# base\n",
                           points=points, keys=keys, swept=["controller.r_per_kn2"],
                           simulate=simulate, arrays=arrays)


class TestStore:
    def test_new_store_lists_every_point_missing(self, tmp_path: Path) -> None:
        points, _, keys = _sweep()
        store = _open(tmp_path / "s", points, keys)
        assert is_sweep_store(tmp_path / "s")
        assert store.done() == set() and store.missing() == keys
        manifest = json.loads((tmp_path / "s" / "sweep.json").read_text())
        assert [p["values"]["controller.r_per_kn2"] for p in manifest["points"]] == \
            [1, 2, 3, 5, 7, 10, 15, 20]
        assert (tmp_path / "s" / "scenario.toml").read_text() == "# base\n"

    def test_points_stored_are_done_and_reopen_resumes(self, tmp_path: Path) -> None:
        points, _, keys = _sweep()
        store = _open(tmp_path / "s", points, keys)
        store.write_point(keys[2], {"checks": []})
        store.write_point(keys[0], {"checks": []})
        again = _open(tmp_path / "s", points, keys)
        assert again.done() == {keys[0], keys[2]}
        assert again.missing() == [k for i, k in enumerate(keys) if i not in (0, 2)]

    def test_half_written_point_is_not_done_and_is_cleaned(self, tmp_path: Path) -> None:
        points, _, keys = _sweep()
        store = _open(tmp_path / "s", points, keys)
        partial = store.points_dir / f".{keys[1]}.partial-999"
        partial.mkdir()
        (partial / "summary.json").write_text("{}")
        (store.points_dir / keys[3]).mkdir()  # a directory without its summary
        assert store.done() == set()
        _open(tmp_path / "s", points, keys)
        assert not partial.exists()

    def test_duplicate_scenarios_run_once_and_fill_both_rows(self, tmp_path: Path) -> None:
        points, _, keys = _sweep("controller.r_per_kn2=10,10,20")
        assert keys[0] == keys[1] != keys[2]  # the same value twice: one scenario
        store = _open(tmp_path / "s", points, keys)
        assert store.missing() == [keys[0], keys[2]]
        for key in (keys[0], keys[2]):
            store.write_point(key, {"checks": [{"name": "c", "status": "pass", "value": 1.0}]})
        frame = store.table()
        assert list(frame["point"]) == [0, 1, 2]
        assert list(frame["point_key"]) == keys

    @pytest.mark.parametrize("change, message", [
        ("points", "2 of its 8 points are other scenarios"),
        ("count", "8 points, this sweep has 3"),
        ("simulate", "made with --no-simulate"),
    ])
    def test_another_sweep_is_refused(self, tmp_path: Path, change: str, message: str) -> None:
        points, _, keys = _sweep()
        _open(tmp_path / "s", points, keys).write_point(keys[0], {"checks": []})
        before = sorted(p.name for p in (tmp_path / "s").rglob("*"))
        if change == "points":
            other_points, _, other_keys = _sweep("controller.r_per_kn2=1,2,3,5,7,10,16,21")
            kwargs: dict[str, object] = {}
        elif change == "count":
            other_points, _, other_keys = _sweep("controller.r_per_kn2=1,2,3")
            kwargs = {}
        else:
            other_points, other_keys, kwargs = points, keys, {"simulate": True}
        with pytest.raises(ScenarioError, match="holds the results of another sweep") as err:
            _open(tmp_path / "s", other_points, other_keys, **kwargs)  # type: ignore[arg-type]
        assert message in str(err.value) and "--output" in str(err.value)
        assert sorted(p.name for p in (tmp_path / "s").rglob("*")) == before

    def test_another_version_is_refused(self, tmp_path: Path) -> None:
        points, _, keys = _sweep()
        _open(tmp_path / "s", points, keys)
        manifest_path = tmp_path / "s" / "sweep.json"
        manifest = json.loads(manifest_path.read_text())
        manifest["trainctl"] = "0.0.1"
        manifest_path.write_text(json.dumps(manifest))
        with pytest.raises(ScenarioError, match="made by trainctl 0.0.1"):
            _open(tmp_path / "s", points, keys)

    def test_foreign_directory_and_file_refused(self, tmp_path: Path) -> None:
        points, _, keys = _sweep()
        (tmp_path / "d").mkdir()
        (tmp_path / "d" / "notes.txt").write_text("mine")
        with pytest.raises(ScenarioError, match="not empty and not a sweep store"):
            _open(tmp_path / "d", points, keys)
        assert [p.name for p in (tmp_path / "d").iterdir()] == ["notes.txt"]
        (tmp_path / "f").write_text("x")
        with pytest.raises(ScenarioError, match="must be a directory"):
            _open(tmp_path / "f", points, keys)

    @pytest.mark.parametrize("text", ["{", "[]", '{"format": "trainctl-sweep/1"}'])
    def test_damaged_manifest(self, tmp_path: Path, text: str) -> None:
        (tmp_path / "sweep.json").write_text(text)
        with pytest.raises(ScenarioError, match="edited or damaged"):
            SweepStore.load(tmp_path)

    def test_unfinished_table_is_a_clear_error(self, tmp_path: Path) -> None:
        points, _, keys = _sweep()
        store = _open(tmp_path / "s", points, keys)
        store.write_point(keys[0], {"checks": []})
        with pytest.raises(ScenarioError, match=r"has not finished .*1 of 8 points done"):
            store.read_table()
        with pytest.raises(ScenarioError, match="has not run yet"):
            store.table()

    def test_bad_arrays_choice(self, tmp_path: Path) -> None:
        points, _, keys = _sweep()
        with pytest.raises(ScenarioError, match="must be one of none, sampled, dense"):
            _open(tmp_path / "s", points, keys, arrays="all")
        assert not (tmp_path / "s").exists()


class TestFrame:
    def test_dtypes_follow_the_values(self) -> None:
        rows = [
            {"point": 0, "point_key": "a", "x": 1, "strategy": "s", "m.int": 3,
             "m.float": 1.5, "m.bool": True, "m.text": "pass", "m.list": [1, 2],
             "m.mixed": 1.0},
            {"point": 1, "point_key": "b", "x": 2, "strategy": "s", "m.int": None,
             "m.float": None, "m.bool": None, "m.text": None, "m.list": None,
             "m.mixed": "n/a", "m.late": 7.0},
        ]
        frame = rows_frame(rows, ["x"])
        assert list(frame.columns) == ["point", "point_key", "x", "strategy", "m.int",
                                       "m.float", "m.bool", "m.text", "m.list", "m.mixed",
                                       "m.late"]
        assert str(frame["m.int"].dtype) == "Int64" and frame["m.int"].isna().tolist() == \
            [False, True]
        assert frame["m.float"].dtype == np.float64 and math.isnan(frame["m.float"][1])
        assert str(frame["m.bool"].dtype) == "boolean"
        assert frame["m.list"].tolist()[0] == "[1, 2]"
        assert frame["m.mixed"].tolist() == ["1.0", '"n/a"']
        assert math.isnan(frame["m.late"][0]) and frame["m.late"][1] == 7.0

    def test_parquet_round_trip_keeps_values_and_types(self, tmp_path: Path) -> None:
        rows = [{"point": i, "point_key": str(i), "x": 0.1 * i, "strategy": "",
                 "ok": i % 2 == 0, "v": None if i == 1 else 1 / 3 + i} for i in range(3)]
        frame = rows_frame(rows, ["x"])
        frame.to_parquet(tmp_path / "t.parquet", index=False)
        back = pd.read_parquet(tmp_path / "t.parquet")
        pd.testing.assert_frame_equal(back, frame)
        assert back["x"].tolist() == [0.0, 0.1, 0.2]


class TestRunner:
    def test_serial_run_stores_summaries_arrays_and_table(self, tmp_path: Path) -> None:
        """A simulated point: summary as a direct run's, arrays as its result's, sampled."""
        from trainctl.sim.results import SimulationResult

        scenario = load_scenario("heavy-haul-hinf-noise").replace(
            "simulation.settle_time", 10.0).replace("simulation.duration", 20.0)
        sweep = SweepDefinition([parse_set("controller.kappa_p_per_s=0.05")])
        points, scenarios = sweep.points(), sweep.validate(scenario)
        keys = [point_key(s) for s in scenarios]
        store = SweepStore.open(tmp_path / "s", label="x", scenario_text="", points=points,
                                keys=keys, swept=sweep.keys, simulate=True)
        frame = run_sweep(store, dict(zip(keys, scenarios, strict=True)))
        summary, sims = run_point_results(scenarios[0])
        assert store.summary(keys[0]) == json.loads(json.dumps(summary))
        assert list(frame["strategy"]) == list(sims)
        for strategy, result in sims.items():
            loaded = SimulationResult.load(store.points_dir / keys[0] / "runs" / strategy)
            np.testing.assert_array_equal(loaded.states, result.states)
            np.testing.assert_array_equal(loaded.inputs, result.inputs)
            # sampled store: the between-sample arrays are the sampled ones
            np.testing.assert_array_equal(loaded.dense_states, result.states)
            with np.load(store.points_dir / keys[0] / "runs" / strategy / "arrays.npz") as z:
                assert not [n for n in z.files if n.startswith("dense_")]
        row = frame.iloc[0]
        assert row["metric.max_coupler_force"] == pytest.approx(
            summary["simulations"][row["strategy"]]["max_coupler_force"])

    def test_run_again_runs_nothing(self, tmp_path: Path) -> None:
        points, scenarios, keys = _sweep("controller.r_per_kn2=1,10")
        store = _open(tmp_path / "s", points, keys)
        by_key = dict(zip(keys, scenarios, strict=True))
        seen: list[str] = []
        first = run_sweep(store, by_key, simulate=False, on_point=seen.append)
        assert sorted(seen) == sorted(keys)
        seen.clear()
        second = run_sweep(_open(tmp_path / "s", points, keys), by_key, simulate=False,
                           on_point=seen.append)
        assert seen == []
        pd.testing.assert_frame_equal(first, second)


    @pytest.mark.parametrize("in_flight", [1, 2, 64])
    def test_bounded_submission_gives_the_serial_table(self, tmp_path: Path,
                                                       in_flight: int) -> None:
        from concurrent.futures import ThreadPoolExecutor

        points, scenarios, keys = _sweep("controller.r_per_kn2=1,3,10")
        by_key = dict(zip(keys, scenarios, strict=True))
        serial = run_sweep(_open(tmp_path / "a", points, keys), by_key, simulate=False)
        seen: list[str] = []
        with ThreadPoolExecutor(2) as pool:
            threaded = run_sweep(_open(tmp_path / "b", points, keys), by_key, simulate=False,
                                 executor=pool, in_flight=in_flight, on_point=seen.append)
        assert sorted(seen) == sorted(keys)
        pd.testing.assert_frame_equal(serial, threaded)
        assert (tmp_path / "a" / "rows.parquet").read_bytes() == \
            (tmp_path / "b" / "rows.parquet").read_bytes()


    def test_rows_carry_the_energy_account(self, tmp_path: Path) -> None:
        """net_energy_kwh and energy_per_tonne_km are the account's of the same run, per η.

        The CRH2 train slows from 72 to 40 km/h, so it brakes and η matters.
        """
        from trainctl.run.simulate import simulate_strategy
        from trainctl.sim.energy import energy_account

        base = (load_scenario("crh2-dmpc").replace("simulation.settle_time", 60.0)
                .replace("simulation.duration", 120.0)
                .replace("simulation.strategies", ["decentralised"])
                .replace("simulation.reference.times", [0.0, 40.0, 100.0, 110.0, 120.0])
                .replace("simulation.reference.speeds_kmh", [72.0, 72.0, 40.0, 40.0, 40.0]))
        sweep = SweepDefinition([parse_set("simulation.regen_efficiency=0.5,1")])
        points, scenarios = sweep.points(), sweep.validate(base)
        keys = [point_key(s) for s in scenarios]
        store = SweepStore.open(tmp_path / "s", label="x", scenario_text="", points=points,
                                keys=keys, swept=sweep.keys, simulate=True)
        frame = run_sweep(store, dict(zip(keys, scenarios, strict=True)))
        assert list(frame["strategy"]) == ["decentralised"] * 2
        assert str(frame["metric.net_energy_kwh"].dtype) == "float64"
        for (_, row), scenario in zip(frame.iterrows(), scenarios, strict=True):
            eta = scenario.simulation.regen_efficiency
            assert row["simulation.regen_efficiency"] == eta
            result = simulate_strategy(scenario, "decentralised", warn=False)
            account = energy_account(result, scenario.train, scenario.track,
                                     regen_efficiency=eta)
            assert account.total("braking_work") > account.total("traction_work") > 0
            assert row["metric.net_energy_kwh"] == pytest.approx(
                account.total("net_energy") / 3.6e6, rel=1e-12)
            assert row["metric.energy_per_tonne_km"] == pytest.approx(
                account.energy_per_tonne_km, rel=1e-12)
        assert frame["metric.net_energy_kwh"].nunique() == 2


    def test_energy_columns_empty_without_an_account(self) -> None:
        """A summary whose metrics hold no energy account: both columns None."""
        from trainctl.sweep import point_rows

        summary = {"simulations": {"c": {"energy_kwh": 1.0, "energy_account": None}}}
        (row,) = point_rows(SweepPoint(0, {}), "k", summary)
        assert row["metric.energy_kwh"] == 1.0
        assert row["metric.net_energy_kwh"] is None and row["metric.energy_per_tonne_km"] is None


_HOOK = """
import sys, time
from trainctl.sweep import store as _store
_real = _store.SweepStore.write_point
_count = [0]
def _announced(self, key, summary, simulations=None):
    path = _real(self, key, summary, simulations)
    sys.stderr.write("STORED\\n"); sys.stderr.flush()
    _count[0] += 1
    # after the third point, wait for the test's SIGINT (however loaded the machine is)
    time.sleep(60 if _count[0] == 3 else 0.2)
    return path
_store.SweepStore.write_point = _announced
from trainctl.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


def _sweep_cli(out: Path, *extra: str, hook: bool = False) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    plain = "import sys; from trainctl.cli.main import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.Popen(
        [sys.executable, "-c", _HOOK if hook else plain, "sweep", "crh2-dmpc", "--set",
         WEIGHTS, "--no-simulate", "-o", str(out), *extra],
        cwd=out.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
@pytest.mark.slow
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_interrupted_sweep_resumes_to_the_full_table(tmp_path: Path, jobs: str) -> None:
    """SIGINT after three points; the same command again gives the one-go table exactly."""
    whole = _sweep_cli(tmp_path / "whole", "-j", jobs)
    out = tmp_path / "cut"
    process = _sweep_cli(out, "-j", jobs, hook=True)
    assert process.stderr is not None
    stored, deadline = 0, time.monotonic() + 120
    while stored < 3 and time.monotonic() < deadline:
        line = process.stderr.readline()
        if not line and process.poll() is not None:
            break
        stored += line.strip() == "STORED"
    assert stored == 3, "the sweep never stored three points"
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert "Traceback" not in err and "run the same command again" in err
    done = [p for p in (out / "points").iterdir()]
    assert 3 <= len(done) < 8 and all((p / "summary.json").is_file() for p in done)
    assert not (out / "rows.parquet").exists()

    again = _sweep_cli(out, "-j", jobs)
    out_text, err = again.communicate(timeout=300)
    assert again.returncode == 0, err
    assert "resuming" in err and "8 sweep points, 8 rows" in out_text
    _, whole_err = whole.communicate(timeout=300)
    assert whole.returncode == 0, whole_err
    table = pd.read_parquet(out / "rows.parquet")
    assert table["point"].tolist() == list(range(8))
    assert (out / "rows.parquet").read_bytes() == (tmp_path / "whole" / "rows.parquet").read_bytes()
    assert sorted(p.name for p in (out / "points").iterdir()) == \
        sorted(p.name for p in (tmp_path / "whole" / "points").iterdir())


def test_cli_writes_the_store_and_resumes_without_running(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    out = tmp_path / "s"
    argv = ["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,10", "--no-simulate",
            "-o", str(out), "--csv"]
    assert main(argv) == 0
    first = (out / "rows.parquet").read_bytes()
    csv = pd.read_csv(out / "rows.csv")
    assert csv["controller.r_per_kn2"].tolist() == [1, 10]
    assert csv["check.ndmpc_convergence.status"].tolist()[0] == "fail"
    capsys.readouterr()
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "resuming" not in captured.err  # nothing left to run
    assert (out / "rows.parquet").read_bytes() == first


def test_cli_refuses_another_sweep_in_the_store(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "s"
    assert main(["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,10", "--no-simulate",
                 "-o", str(out)]) == 0
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    capsys.readouterr()
    code = main(["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,20", "--no-simulate",
                 "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "holds the results of another sweep" in err
    assert "Traceback" not in err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before


def test_sweep_scenario_in_one_call(tmp_path):
    """sweep_scenario: each point's check equals a review of the scenario with that key set;
    a second call into the same directory runs nothing; nothing to sweep is refused."""
    from trainctl.analysis import review_design
    from trainctl.sweep import sweep_scenario

    axes = ["controller.r_per_kn2=0.5,2", "model.sample_time=10,20"]
    table = sweep_scenario("crh2-dmpc", tmp_path / "s", axes=axes, simulate=False)
    assert len(table) == 4
    base = load_scenario("crh2-dmpc")
    for _, row in table.iterrows():
        point = (base.replace("controller.r_per_kn2", float(row["controller.r_per_kn2"]))
                 .replace("model.sample_time", float(row["model.sample_time"])))
        check = review_design(point).check("ndmpc_convergence")
        assert row["check.ndmpc_convergence.value"] == pytest.approx(check.value, rel=1e-12)
        assert row["check.ndmpc_convergence.status"] == check.status
    def stored():
        return {p: p.stat().st_mtime_ns for p in (tmp_path / "s" / "points").rglob("*.json")}

    before = stored()
    assert len(before) >= 4
    again = sweep_scenario("crh2-dmpc", tmp_path / "s", axes=axes, simulate=False)
    pd.testing.assert_frame_equal(again, table)
    assert stored() == before   # every point was stored: none ran again
    with pytest.raises(ScenarioError, match="no sweep to run"):
        sweep_scenario("crh2-dmpc", tmp_path / "t")
    assert not (tmp_path / "t").exists()
