"""Repetitions of a scenario's runs and their baselines (trainctl.run.repetitions), seed 003 (c).

Each repetition is checked against a run of the scenario with its seed
changed, each baseline against the scenario file with its delay keys (or its
[network]) removed, the pool against the serial runs, and the delay claims
against the repetitions' arrays.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tests.test_seed003_cases import _claims, _short_delay
from trainctl.cli.main import main
from trainctl.run.analysis import run_scenario, simulate_strategy
from trainctl.run.repetitions import SETTLING_BAND, deviation, planned_runs, run_repetition
from trainctl.scenario import parse_scenario
from trainctl.sim.results import SimulationResult


# -- repetitions and baselines ---------------------------------------------------------------------
@pytest.fixture(scope="module")
def short_run():
    """The short delay case, run serially: 3 repetitions and the delay-free baseline."""
    return run_scenario(parse_scenario(_short_delay()))


def test_planned_runs() -> None:
    sc = parse_scenario(_short_delay())
    assert planned_runs(sc) == [("distributed", 1), ("distributed", 2),
                                ("synchronous.synchronous", 1), ("synchronous.synchronous", 2),
                                ("distributed", -1), ("distributed", -2), ("distributed", -3),
                                ("synchronous.synchronous", -1), ("synchronous.synchronous", -2),
                                ("synchronous.synchronous", -3)]
    alone = parse_scenario(_short_delay(**{"repetitions = 3": "repetitions = 1",
                                           'baseline_network = "delay-free"': ""}))
    assert planned_runs(alone) == []


def test_repetition_r_is_the_run_with_seed_plus_r(short_run) -> None:
    """Run r equals a run of the scenario whose seed is seed + r; the draws differ between runs."""
    sc = short_run.scenario
    reps = short_run.repetitions["distributed"]
    assert [r.seed for r in reps] == [sc.seed, sc.seed + 1, sc.seed + 2]
    again = simulate_strategy(sc.replace("seed", sc.seed + 2), "distributed")
    np.testing.assert_array_equal(deviation(again, 60.0).rms_error,
                                  reps[2].deviation.rms_error)
    assert reps[1].deviation.rms_error[0] != reps[2].deviation.rms_error[0]
    sync = short_run.repetitions["synchronous.synchronous"]
    other = simulate_strategy(sc.replace("seed", sc.seed + 1), "synchronous.synchronous")
    np.testing.assert_array_equal(deviation(other, 60.0).max_error, sync[1].deviation.max_error)
    # run 0 is the run shown
    np.testing.assert_array_equal(
        reps[0].deviation.rms_error, deviation(short_run.simulations["distributed"],
                                               60.0).rms_error)


def test_delay_free_baseline_is_the_file_without_its_delay(short_run) -> None:
    """The baseline equals the scenario with delay_range_s deleted: the same noise, no delay."""
    text = _short_delay().replace("delay_range_s = [0.0, 2.0]", "")
    bases = short_run.baseline["distributed"]
    assert [b.seed for b in bases] == [r.seed for r in short_run.repetitions["distributed"]]
    plain = parse_scenario(text)
    for r in (0, 2):   # each repetition's baseline has that repetition's seed and noise
        again = simulate_strategy(plain.replace("seed", plain.seed + r), "distributed")
        np.testing.assert_array_equal(deviation(again, 60.0).rms_error,
                                      bases[r].deviation.rms_error)
    # the synchronous relay, too, runs over the baseline network (not the design's delays)
    sync = simulate_strategy(plain.replace("seed", plain.seed + 1), "synchronous.synchronous")
    np.testing.assert_array_equal(deviation(sync, 60.0).max_error,
                                  short_run.baseline["synchronous.synchronous"][1]
                                  .deviation.max_error)
    delayed = short_run.repetitions["synchronous.synchronous"][1].deviation.max_error
    assert not np.array_equal(deviation(sync, 60.0).max_error, delayed)


def test_ideal_baseline_is_the_scenario_without_network() -> None:
    text = _short_delay(**{'baseline_network = "delay-free"': 'baseline_network = "ideal"',
                           "repetitions = 3": "repetitions = 1"})
    sc = parse_scenario(text)
    base = run_repetition(sc, "distributed", None, -1)
    head, rest = text.split("\n[network]\n", 1)
    bare = head + "\n" + rest[rest.index("\n[simulation]"):]
    plain = simulate_strategy(parse_scenario(bare), "distributed")
    np.testing.assert_array_equal(deviation(plain, 60.0).max_error, base.deviation.max_error)


@pytest.mark.slow
def test_repetitions_on_the_pool_equal_the_serial_ones(short_run) -> None:
    """The same seeds give the same repetitions serially and on the local process pool."""
    from trainctl.run.pool import worker_pool

    with worker_pool(2) as pool:
        pooled = run_scenario(short_run.scenario, executor=pool)
    from trainctl.cli.support import without_wall_clock

    serial = short_run.to_dict()
    both = pooled.to_dict()
    assert both["repetitions"] == serial["repetitions"]
    assert both["baseline_network"] == serial["baseline_network"]
    assert both["claims"] == serial["claims"]
    # everything but the wall-clock values (what --deterministic prints)
    assert without_wall_clock(both) == without_wall_clock(serial)


def test_deviation_by_hand() -> None:
    """RMS over the samples, peak over the dense grid, settling inf when outside at the end."""
    t = np.linspace(0.0, 10.0, 11)
    v = np.vstack([np.full(11, 20.0), 20.0 + np.linspace(0.0, 0.5, 11)])
    r = SimulationResult(time=t, states=np.vstack([v, np.zeros(11), t]), velocities=v,
                         coupler_forces=np.zeros((1, 11)), inputs=np.zeros((2, 10)),
                         reference_speed=np.full(11, 20.0), reference_acceleration=np.zeros(11),
                         statuses=("optimal",) * 10, iterations=np.zeros(10, dtype=int),
                         residuals=((),) * 10, solve_times=np.zeros(10), fallbacks=("",) * 10,
                         controller_name="c", seed=0, dt=1.0)
    d = deviation(r, since=2.0)
    assert d.rms_error[0] == 0.0
    assert d.rms_error[1] == pytest.approx(math.sqrt(np.mean(np.linspace(0, 0.5, 11) ** 2)))
    assert d.max_error[1] == pytest.approx(0.5)
    assert d.settling_time[0] == 0.0 and math.isinf(d.settling_time[1])
    assert SETTLING_BAND == 0.1


@pytest.mark.parametrize(("line", "match"), [
    ("repetitions = 0", "repetitions"),
    ('baseline_network = "perfect"', "baseline_network"),
])
def test_bad_repetition_keys_exit_2(tmp_path: Path, capsys, line: str, match: str) -> None:
    text = _short_delay(**{"repetitions = 3": line}) if "repetitions" in line else \
        _short_delay(**{'baseline_network = "delay-free"': line})
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["analyse", str(path)]) == 2
    err = capsys.readouterr().err
    assert match in err and "Traceback" not in err


def test_the_budget_counts_every_run() -> None:
    """Repetitions and the baseline are counted: 3 seeds × (run + baseline) = 6 runs of
    each strategy; both families here run batched, so the six cost more than one run and
    less than six alone (the rule: trainctl.run.budget, tests/test_budget.py)."""
    from trainctl.run.budget import estimate_run

    sc = parse_scenario(_short_delay())
    one = parse_scenario(_short_delay(**{"repetitions = 3": "repetitions = 1",
                                         'baseline_network = "delay-free"': ""}))
    many, single = estimate_run(sc), estimate_run(one)
    assert (many.runs, single.runs) == (6, 1)
    assert many.controller_steps == 6 * single.controller_steps
    assert single.simulation_seconds < many.simulation_seconds \
        < 6 * single.simulation_seconds


def test_delay_claims_from_the_runs(short_run) -> None:
    """The deviation ratios pair each seed with its own baseline; the verdicts follow them."""
    claims = _claims(short_run)
    reps, bases = short_run.repetitions["distributed"], short_run.baseline["distributed"]
    # Each ratio recomputed from the arrays of run 0, and from the summaries of the others.
    res = short_run.simulations["distributed"]
    rms0 = math.sqrt(np.mean((res.velocities[0] - res.reference_speed) ** 2))
    plain = parse_scenario(_short_delay().replace("delay_range_s = [0.0, 2.0]", ""))
    base0 = simulate_strategy(plain, "distributed")
    rms_base0 = math.sqrt(np.mean((base0.velocities[0] - base0.reference_speed) ** 2))
    ratios = [rms0 / rms_base0] + [r.deviation.rms_error[0] / b.deviation.rms_error[0]
                                   for r, b in zip(reps[1:], bases[1:], strict=True)]
    median = float(np.median(ratios))
    claim = claims["delay_deviation"]
    assert f"median {median:.3g}×" in claim["trainctl"]
    if 5.0 <= median <= 11.25:
        assert (claim["kind"], claim["verdict"]) == ("depends", "reproduced at this noise level")
    else:
        assert claim["kind"] == "not reproduced"
    assert "noise" in claim["note"]
    settle = claims["settling"]
    assert "without the delays" in settle["trainctl"]
    assert claims["gamma"]["kind"] == "depends"
    # a ramp, not a steady run: no H∞-index claim (its speed errors do not answer w alone)
    assert list(claims) == ["delay_deviation", "settling", "gamma"]


def _result(t, v, ref, *, diverged: bool = False):
    steps = t.size - 1
    n = v.shape[0]
    return SimulationResult(time=t, states=np.vstack([v, np.zeros((n - 1, t.size)), t]),
                            velocities=v, coupler_forces=np.zeros((n - 1, t.size)),
                            inputs=np.zeros((n, steps)), reference_speed=ref,
                            reference_acceleration=np.zeros(t.size),
                            statuses=("optimal",) * steps, iterations=np.zeros(steps, dtype=int),
                            residuals=((),) * steps, solve_times=np.zeros(steps),
                            fallbacks=("",) * steps, controller_name="c", seed=0, dt=1.0,
                            meta={"divergence": {"sample": steps}} if diverged else {})


def test_a_run_that_stopped_early_never_settled() -> None:
    """A diverged run, or one stopped before the last breakpoint, has an infinite settling time
    even when its last samples happen to lie in the band."""
    t = np.arange(0.0, 61.0)
    v = np.vstack([20.0 + 0.01 * np.ones(61), 20.0 + 0.02 * np.ones(61)])
    ref = np.full(61, 20.0)
    assert np.all(deviation(_result(t, v, ref), since=30.0).settling_time == 0.0)
    assert np.all(np.isinf(deviation(_result(t, v, ref, diverged=True),
                                     since=30.0).settling_time))
    assert np.all(np.isinf(deviation(_result(t, v, ref), since=100.0).settling_time))


def test_outage_windows_merged_and_clipped() -> None:
    from types import SimpleNamespace

    from trainctl.controllers.hinf.claims import _windows_union

    w = [SimpleNamespace(start=10.0, end=30.0), SimpleNamespace(start=20.0, end=40.0),
         SimpleNamespace(start=90.0, end=200.0), SimpleNamespace(start=300.0, end=310.0)]
    assert _windows_union(w, 100.0) == [(10.0, 40.0), (90.0, 100.0)]


def test_summaries_are_strict_json_when_a_measure_is_not_finite() -> None:
    """A run that stopped early has nan errors and infinite settling times: its summary is
    still strict JSON (the sweep store writes with allow_nan=False), None in their place."""
    import dataclasses
    import json

    from trainctl.run.repetitions import Deviation
    from trainctl.scenario import load_scenario

    scenario = (load_scenario("crh2-dmpc").replace("simulation.settle_time", 60.0)
                .replace("simulation.duration", 120.0))
    rep = run_repetition(scenario, "decentralised", None, 1)
    nan4 = np.full(4, math.nan)
    bad = dataclasses.replace(
        rep, metrics=dataclasses.replace(rep.metrics, rms_error=nan4, max_error=nan4),
        deviation=Deviation(rms_error=nan4, max_error=np.array([1.0, math.inf, 0.5, 0.2]),
                            settling_time=np.full(4, math.inf), max_coupler_force=math.nan,
                            since=0.0, diverged=True))
    d = json.loads(json.dumps(bad.to_dict(), allow_nan=False))
    assert d["rms_error_settled"] == d["max_error_settled"] == [None] * 4
    assert d["deviation"]["max_error"] == [1.0, None, 0.5, 0.2]
    assert d["deviation"]["settling_time"] == [None] * 4
    assert d["deviation"]["max_coupler_force"] is None and d["deviation"]["diverged"] is True
    good = json.loads(json.dumps(rep.to_dict(), allow_nan=False))
    assert good["rms_error_settled"] == rep.metrics.rms_error.tolist()
