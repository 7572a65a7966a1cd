"""Sweep definitions: the points of list, grid and random axes, validation, --set, [sweep], CLI."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from trainctl.cli.main import main
from trainctl.exceptions import ScenarioError
from trainctl.scenario import (
    RESERVED_SECTIONS,
    Scenario,
    builtin_scenario_text,
    load_scenario,
    parse_scenario,
)
from trainctl.sweep import (
    GridAxis,
    ListAxis,
    RandomAxis,
    SweepDefinition,
    parse_set,
    point_key,
)

README = Path(__file__).resolve().parents[1] / "analyses" / "README.md"
R = "controller.r_per_kn2"
DT = "model.sample_time"
MASS = "train.vehicle[0].mass_t"


@pytest.fixture(scope="module")
def book() -> Scenario:
    return load_scenario("crh2-dmpc")


def rows(sweep: SweepDefinition, base_seed: int = 0) -> list[tuple[object, ...]]:
    return [tuple(p.values()) for p in sweep.points(base_seed)]


class TestGridAndList:
    def test_product_first_axis_slowest(self) -> None:
        sweep = SweepDefinition([ListAxis("a.x", [1, 2, 3]), ListAxis("a.y", ["p", "q"])])
        assert rows(sweep) == [(1, "p"), (1, "q"), (2, "p"), (2, "q"), (3, "p"), (3, "q")]
        points = sweep.points()
        assert [p.index for p in points] == list(range(6))
        assert list(points[3]) == ["a.x", "a.y"] and points[3]["a.x"] == 2
        assert sweep.n_points == 6

    def test_linear_grid(self) -> None:
        assert GridAxis("a.x", 0.0, 1.0, 5).grid_values() == (0.0, 0.25, 0.5, 0.75, 1.0)
        assert GridAxis("a.x", 3.0, 1.0, 3).grid_values() == (3.0, 2.0, 1.0)
        assert GridAxis("a.x", 7.5, 9.0, 1).grid_values() == (7.5,)

    def test_integer_grid_gives_ints(self) -> None:
        values = GridAxis("controller.prediction_horizon", 2, 8, 4).grid_values()
        assert values == (2, 4, 6, 8) and all(type(v) is int for v in values)
        assert GridAxis("a.x", 0, 1, 3).grid_values() == (0.0, 0.5, 1.0)

    def test_log_grid(self) -> None:
        values = GridAxis("a.x", 0.1, 10.0, 3, scale="log").grid_values()
        assert values[0] == 0.1 and values[2] == 10.0
        assert values[1] == pytest.approx(1.0, rel=1e-12)
        four = GridAxis("a.x", 1.0, 1000.0, 4, scale="log").grid_values()
        assert four == pytest.approx((1.0, 10.0, 100.0, 1000.0), rel=1e-12)

    def test_grid_and_list_mixed(self) -> None:
        sweep = SweepDefinition([GridAxis("a.x", 1.0, 2.0, 2), ListAxis("a.y", [True])])
        assert rows(sweep) == [(1.0, True), (2.0, True)]

    @pytest.mark.parametrize("make, message", [
        (lambda: GridAxis("a.x", 0.0, 1.0, 0), "num must be an integer >= 1 (got 0)"),
        (lambda: GridAxis("a.x", 0.0, 1.0, 3, scale="log"), "start must be > 0 (got 0.0)"),
        (lambda: GridAxis("a.x", 1.0, 2.0, 3, scale="cubic"), "scale must be 'linear' or 'log'"),
        (lambda: ListAxis("a.x", []), "values must be a non-empty array"),
        (lambda: RandomAxis("a.x", "uniform", low=2.0, high=1.0), "low must be less than high"),
        (lambda: RandomAxis("a.x", "uniform", low=1.0, high=1.0), "the range is empty"),
        (lambda: RandomAxis("a.x", "log-uniform", low=0.0, high=1.0), "low must be > 0"),
        (lambda: RandomAxis("a.x", "normal", mean=0.0, std=0.0), "std must be > 0"),
        (lambda: RandomAxis("a.x", "normal", low=0.0, high=1.0), "low does not apply"),
        (lambda: RandomAxis("a.x", "beta", low=0.0, high=1.0), "distribution must be one of"),
        (lambda: ListAxis("a..x", [1]), "is not a key path"),
        (lambda: SweepDefinition([ListAxis("a.x", [1]), ListAxis("a.x", [2])]), "has 2 axes"),
        (lambda: SweepDefinition([ListAxis("a.x", [1])], samples=2), "needs a random axis"),
        (lambda: SweepDefinition([]), "no axis to vary"),
        (lambda: SweepDefinition([ListAxis("seed", [1])], seeds=2), "also has an axis"),
    ])
    def test_empty_or_malformed(self, make: Callable[[], object], message: str) -> None:
        with pytest.raises(ScenarioError, match=re.escape(message)):
            make()


class TestRandom:
    def axes(self) -> list[RandomAxis]:
        return [RandomAxis(MASS, "uniform", low=40.0, high=50.0),
                RandomAxis(R, "log-uniform", low=0.01, high=100.0)]

    def test_same_seed_same_points(self) -> None:
        one = SweepDefinition(self.axes(), seed=7, samples=20)
        two = SweepDefinition(self.axes(), seed=7, samples=20)
        other = SweepDefinition(self.axes(), seed=8, samples=20)
        assert rows(one) == rows(two)
        assert rows(one) != rows(other)
        assert len(set(rows(one))) == 20

    def test_within_bounds(self) -> None:
        points = SweepDefinition(self.axes(), seed=1, samples=500).points()
        masses = [p[MASS] for p in points]
        weights = [p[R] for p in points]
        assert all(40.0 <= m < 50.0 for m in masses)
        assert all(0.01 <= w < 100.0 for w in weights)

    def test_uniform_spread(self) -> None:
        """Each tenth of [40, 50) holds 10 % of 2000 draws within 5 binomial sigmas."""
        values = np.array([p[MASS] for p in SweepDefinition(
            [RandomAxis(MASS, "uniform", low=40.0, high=50.0)], seed=2, samples=2000).points()])
        counts = np.histogram(values, bins=10, range=(40.0, 50.0))[0]
        sigma = math.sqrt(2000 * 0.1 * 0.9)
        assert np.all(np.abs(counts - 200) < 5 * sigma)

    def test_log_uniform_logs_uniform(self) -> None:
        """log10 of the draws fills each of the 4 decades of [0.01, 100) about equally."""
        values = np.array([p[R] for p in SweepDefinition(
            [RandomAxis(R, "log-uniform", low=0.01, high=100.0)], seed=3, samples=4000).points()])
        counts = np.histogram(np.log10(values), bins=4, range=(-2.0, 2.0))[0]
        sigma = math.sqrt(4000 * 0.25 * 0.75)
        assert counts.sum() == 4000
        assert np.all(np.abs(counts - 1000) < 5 * sigma)  # uniform would give ~1 decade of 4

    def test_normal_mean_and_std(self) -> None:
        n, mean, std = 4000, 48.0, 2.0
        values = np.array([p[MASS] for p in SweepDefinition(
            [RandomAxis(MASS, "normal", mean=mean, std=std)], seed=4, samples=n).points()])
        assert abs(values.mean() - mean) < 5 * std / math.sqrt(n)  # CLT bound
        assert abs(values.std() - std) < 0.1 * std

    def test_stream_per_axis_key(self) -> None:
        """Adding, reordering or removing another axis leaves an axis's draws unchanged."""
        mass = RandomAxis(MASS, "uniform", low=40.0, high=50.0)
        alone = [p[MASS] for p in SweepDefinition([mass], seed=5, samples=10).points()]
        weight = RandomAxis(R, "normal", mean=1.0, std=0.1)
        for axes in ([mass, weight], [weight, mass]):
            joint = SweepDefinition(axes, seed=5, samples=10).points()
            assert [p[MASS] for p in joint] == alone
        expected = np.random.default_rng(np.random.SeedSequence(5, spawn_key=(
            int.from_bytes(__import__("hashlib").sha256(MASS.encode()).digest()[:8], "big"),
        ))).uniform(40.0, 50.0, 10)
        assert alone == pytest.approx(expected.tolist(), rel=0, abs=0)

    def test_random_combined_with_product(self) -> None:
        """Every grid point meets every joint sample; samples vary faster than the grid."""
        sweep = SweepDefinition([ListAxis(DT, [10.0, 20.0]),
                                 RandomAxis(MASS, "uniform", low=40.0, high=50.0)],
                                seed=0, samples=3)
        points = sweep.points()
        assert len(points) == 6 and sweep.n_points == 6
        assert [p[DT] for p in points] == [10.0] * 3 + [20.0] * 3
        draws = [p[MASS] for p in points]
        assert draws[:3] == draws[3:] and len(set(draws[:3])) == 3
        assert list(points[0]) == [DT, MASS]


class TestSeeds:
    def test_seeds_repeat_each_point_fastest(self) -> None:
        sweep = SweepDefinition([ListAxis(R, [1.0, 2.0])], seeds=3)
        assert rows(sweep, base_seed=10) == [(1.0, 10), (1.0, 11), (1.0, 12),
                                             (2.0, 10), (2.0, 11), (2.0, 12)]
        assert sweep.keys == (R, "seed")

    def test_seeds_one_leaves_seed_alone(self, book: Scenario) -> None:
        sweep = SweepDefinition([ListAxis(R, [1.0])])
        assert "seed" not in sweep.points()[0]

    def test_seeds_alone_validated(self, book: Scenario) -> None:
        scenarios = SweepDefinition([], seeds=4).validate(book.replace("seed", 5))
        assert [s.seed for s in scenarios] == [5, 6, 7, 8]


class TestValidate:
    def test_values_reach_the_scenario(self, book: Scenario) -> None:
        sweep = SweepDefinition([ListAxis(R, [0.1, 1.0]), ListAxis(DT, [10.0, 20.0])])
        scenarios = sweep.validate(book)
        got = [(s.controller.input_weight, s.model.sample_time) for s in scenarios]
        assert got == [(0.1, 10.0), (0.1, 20.0), (1.0, 10.0), (1.0, 20.0)]
        assert book.controller.input_weight == 10.0  # the base is unchanged

    def test_constraint_names_point_key_value(self, book: Scenario) -> None:
        sweep = SweepDefinition([ListAxis(R, [1.0, 2.0]), ListAxis(DT, [20.0, -1])])
        with pytest.raises(ScenarioError) as info:
            sweep.validate(book)
        message = str(info.value)
        assert message.startswith(f"{book.source}: sweep point 1 (controller.r_per_kn2 = 1.0, "
                                  "model.sample_time = -1): ")
        assert "[model].sample_time must be a number >= " in message and "(got -1)" in message

    def test_unknown_key(self, book: Scenario) -> None:
        with pytest.raises(ScenarioError, match=r"sweep point 0 \(model\.smaple_time = 1\.0\): "
                           r"unknown key \[model\]\.smaple_time.*sample_time"):
            SweepDefinition([ListAxis("model.smaple_time", [1.0])]).validate(book)

    def test_point_key_identifies_the_scenario(self, book: Scenario) -> None:
        scenarios = SweepDefinition([ListAxis(R, [1.0, 2.0, 1.0])]).validate(book)
        keys = [point_key(s) for s in scenarios]
        assert keys[0] == keys[2] != keys[1]
        assert all(re.fullmatch(r"[0-9a-f]{64}", k) for k in keys)
        assert keys[0] == point_key(book.replace(R, 1.0))


SWEEP_TOML = """
[sweep]
seed = 11
samples = 2
seeds = 2

[[sweep.axis]]
key = "controller.r_per_kn2"
start = 0.1
stop = 10.0
num = 3
scale = "log"

[[sweep.axis]]
key = "model.sample_time"
values = [10.0, 20.0]

[[sweep.axis]]
key = "train.vehicle[0].mass_t"
distribution = "uniform"
low = 40.0
high = 50.0
"""


class TestSweepSection:
    def test_absent_is_none(self, book: Scenario) -> None:
        assert book.sweep is None
        assert "sweep" not in RESERVED_SECTIONS

    def test_section_yields_documented_points(self, tmp_path: Path) -> None:
        path = tmp_path / "sweep.toml"
        path.write_text(builtin_scenario_text("crh2-dmpc") + SWEEP_TOML, encoding="utf-8")
        scenario = load_scenario(path)
        sweep = scenario.sweep
        assert sweep is not None and (sweep.seed, sweep.samples, sweep.seeds) == (11, 2, 2)
        points = sweep.points(scenario.seed)
        assert len(points) == 3 * 2 * 2 * 2
        weights = sorted({p[R] for p in points})
        assert weights == pytest.approx([0.1, 1.0, 10.0])
        assert [p[R] for p in points[:8]] == [0.1] * 8
        assert [p[DT] for p in points[:8]] == [10.0] * 4 + [20.0] * 4
        masses = RandomAxis(MASS, "uniform", low=40.0, high=50.0).draw(seed=11, samples=2)
        assert [p[MASS] for p in points[:4]] == [masses[0]] * 2 + [masses[1]] * 2
        assert [p["seed"] for p in points[:4]] == [scenario.seed, scenario.seed + 1] * 2
        scenarios = sweep.validate(scenario)
        assert len(scenarios) == 24 and all(s.sweep is None for s in scenarios)
        assert scenarios[5].train.vehicles[0].mass == pytest.approx(masses[0] * 1000.0)

    @pytest.mark.parametrize("table, message", [
        ('[[sweep.axis]]\nkey = "a.b"\n', "must be exactly one kind of axis"),
        ('[[sweep.axis]]\nkey = "a.b"\nvalues = []\n', "[sweep.axis][0].values must be"),
        ('[[sweep.axis]]\nkey = "a.b"\nstart = 1.0\nstop = 2.0\nnum = 0\n',
         "[sweep.axis][0].num must be an integer >= 1 (got 0)"),
        ('[[sweep.axis]]\nkey = "a.b"\nstart = 1.0\n', "missing required key [sweep.axis][0].stop"),
        ('[[sweep.axis]]\nkey = "a.b"\ndistribution = "uniform"\nlow = 2.0\nhigh = 1.0\n',
         "[sweep.axis][0]: low must be less than high"),
        ('[[sweep.axis]]\nkey = "a.b"\nvalues = [1]\nnum = 2\n', "(got values and grid)"),
        ("[sweep]\nsamples = 0\n", "[sweep].samples must be an integer >= 1"),
        ("[sweep]\nfoo = 1\n", "unknown key [sweep].foo"),
    ])
    def test_malformed_section(self, table: str, message: str) -> None:
        with pytest.raises(ScenarioError, match=re.escape(message)):
            parse_scenario(builtin_scenario_text("crh2-dmpc") + table, source="x.toml")

    def test_readme_example_parses(self) -> None:
        text = README.read_text(encoding="utf-8")
        example = re.search(r"```toml\n(.*?)```", text, re.DOTALL)
        block = re.search(r"~~~toml\n(\[sweep\].*?)~~~", text, re.DOTALL)
        assert example is not None and block is not None
        scenario = parse_scenario(example.group(1) + block.group(1))
        assert scenario.sweep is not None
        assert len(scenario.sweep.points()) == 3 * 10


class TestParseSet:
    def test_scalars(self) -> None:
        assert parse_set("controller.r_per_kn2=0.1,1,10") == ListAxis(R, [0.1, 1, 10])
        axis = parse_set('a.b = true, "x,y", zoh, -2e-3')
        assert axis.key == "a.b" and axis.values == (True, "x,y", "zoh", -0.002)

    def test_arrays(self) -> None:
        axis = parse_set("simulation.reference.speeds_kmh=[0, 100],[0.0, 200.0]")
        assert axis.values == ([0, 100], [0.0, 200.0])

    @pytest.mark.parametrize("text, message", [
        ("a.b", "must be KEY=V1,V2,..."),
        ("a.b=", "no values after '='"),
        ("a.b=1,,2", "an empty value"),
        ("a.b=[1,2", "unclosed"),
        ("a.b=1 2", "is not a TOML value"),
        ("a..b=1", "is not a key path"),
    ])
    def test_malformed(self, text: str, message: str) -> None:
        with pytest.raises(ScenarioError, match=re.escape(message)):
            parse_set(text)


class TestCli:
    def test_dry_run_lists_points(self, capsys: pytest.CaptureFixture[str]) -> None:
        code = main(["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=0.1,1,10",
                     "--dry-run"])
        out = capsys.readouterr().out
        assert code == 0
        lines = out.splitlines()
        assert "3 valid sweep points" in lines[0]
        table = [line.split() for line in lines[2:]]
        assert [row[:2] for row in table] == [["0", "0.1"], ["1", "1"], ["2", "10"]]
        assert all(re.fullmatch(r"[0-9a-f]{12}", row[2]) for row in table)
        assert len({row[2] for row in table}) == 3

    def test_product_and_seeds(self, capsys: pytest.CaptureFixture[str]) -> None:
        code = main(["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,10", "--set",
                     "model.sample_time=10.0,20.0", "--seeds", "2", "--dry-run"])
        lines = capsys.readouterr().out.splitlines()
        assert code == 0 and len(lines) == 2 + 8
        assert lines[1].split() == ["point", R, DT, "seed", "key"]
        assert lines[3].split()[:4] == ["1", "1", "10.0", "1"]

    @pytest.mark.parametrize("argv, message", [
        (["--set", "model.sample_time=20.0,-1"],
         "builtin:crh2-dmpc: sweep point 1 (model.sample_time = -1)"),
        (["--set", "model.smaple_time=1.0"], "unknown key [model].smaple_time"),
        (["--set", "controller.r_per_kn2="], "no values after '='"),
        ([], "no sweep to run"),
    ])
    @pytest.mark.parametrize("dry", [["--dry-run"], []], ids=["dry-run", "run"])
    def test_malformed_exits_2(self, argv: list[str], message: str, dry: list[str],
                               tmp_path: Path,
                               monkeypatch: pytest.MonkeyPatch,
                               capsys: pytest.CaptureFixture[str]) -> None:
        monkeypatch.chdir(tmp_path)
        code = main(["sweep", "crh2-dmpc", *argv, *dry])
        captured = capsys.readouterr()
        assert code == 2
        assert captured.err.startswith("trainctl: error: ") and message in captured.err
        assert "Traceback" not in captured.err and captured.out == ""
        assert list(tmp_path.iterdir()) == []

    def test_runs_the_points_like_analyse(self, capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
        """Each point's rows hold the checks a direct run of the edited scenario finds."""
        import json

        monkeypatch.chdir(tmp_path)

        from trainctl.run.analysis import run_scenario
        from trainctl.scenario import load_scenario

        code = main(["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,10",
                     "--no-simulate", "--json"])
        rows = json.loads(capsys.readouterr().out)
        assert code == 0 and [r["point"] for r in rows] == [0, 1]
        assert [r["controller.r_per_kn2"] for r in rows] == [1, 10]
        for row, weight in zip(rows, (1.0, 10.0), strict=True):
            direct = run_scenario(load_scenario("crh2-dmpc").replace(
                "controller.r_per_kn2", weight), simulate=False)
            for check in direct.review.checks:
                assert row[f"check.{check.name}.status"] == check.status, check.name
        # R = 1 is below the threshold weight of the book's N-DMPC iteration, R = 10 above
        assert rows[0]["check.ndmpc_convergence.status"] == "fail"
        assert rows[1]["check.ndmpc_convergence.status"] != "fail"

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    @pytest.mark.slow
    def test_pool_and_serial_rows_identical(self) -> None:
        """Two worker processes give exactly the rows of a serial run (simulations included)."""
        from trainctl.run.pool import worker_pool
        from trainctl.scenario import load_scenario
        from trainctl.sweep import sweep_rows

        scenario = load_scenario("heavy-haul-hinf-noise").replace(
            "simulation.settle_time", 30.0).replace("simulation.duration", 60.0)
        sweep = SweepDefinition([parse_set("controller.kappa_p_per_s=0.05,0.1")])
        points, scenarios = sweep.points(), sweep.validate(scenario)
        serial = sweep_rows(points, scenarios)
        with worker_pool(2) as pool:
            pooled = sweep_rows(points, scenarios, executor=pool)
        assert pooled == serial and len(serial) == 2
        assert serial[0]["strategy"] == "distributed"
        assert serial[0]["metric.rms_error"] != serial[1]["metric.rms_error"]
