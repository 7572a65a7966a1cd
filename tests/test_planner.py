"""The reference planned along a line's speed limits (:mod:`trainctl.sim.planner`).

Checked without the planner's own arithmetic: the profile is integrated to
positions here (exact for a piecewise-linear speed), and at thousands of
instants the head's speed is compared with every limit over the train's
extent, read from :meth:`Track.speed_limit`; each lower limit is met when the
head reaches its start; every slope is within the plan's acceleration and
deceleration, and the deceleration within the brakes'. One restriction is
worked by hand (the braking point and the times of the phases).
"""

from __future__ import annotations

import numpy as np
import pytest

from trainctl.exceptions import ModelError
from trainctl.models import builtin_line, crh2_half, heavy_haul_1p2p1
from trainctl.models.track import SpeedLimit, Track, TrackSection
from trainctl.sim.planner import braking_deceleration, limited_profile


def _positions(profile, times: np.ndarray) -> np.ndarray:
    """The head's position [m] at ``times`` from the profile's speed, by exact integration
    of the piecewise-linear speed (trapezoids on the breakpoints, then within)."""
    t = np.asarray(profile.times)
    v = np.asarray(profile.speeds)
    at_breaks = np.concatenate([[0.0], np.cumsum(np.diff(t) * (v[1:] + v[:-1]) / 2)])
    i = np.clip(np.searchsorted(t, times, side="right") - 1, 0, t.size - 1)
    dt = times - t[i]
    speed_now = profile.speed(times)
    return at_breaks[i] + dt * (v[i] + speed_now) / 2


def _check(profile, track: Track, train, *, cruise: float, a: float, b: float,
           end: float) -> None:
    extent = float(np.sum(train.spacing))
    duration = profile.times[-1]
    times = np.linspace(0.0, duration, 20_001)
    s = _positions(profile, times)
    v = profile.speed(times)
    assert v.max() <= cruise * (1 + 1e-12)
    for k in np.linspace(0.0, 1.0, 9):  # head, tail and the points between
        limit = track.speed_limit(s - k * extent)
        assert np.all(v <= limit * (1 + 1e-9) + 1e-9), k
    slopes = np.diff(profile.speeds) / np.diff(profile.times)
    assert slopes.max() <= a * (1 + 1e-9) and slopes.min() >= -b * (1 + 1e-9)
    for limit in track.speed_limits:  # met by the start of every restriction
        if 0.0 < limit.start < _positions(profile, np.array([duration]))[0]:
            t_hit = _time_at(profile, limit.start)
            assert profile.speed(t_hit) <= limit.limit * (1 + 1e-9) + 1e-9
    assert _positions(profile, np.array([duration]))[0] == pytest.approx(end, rel=1e-9)


def _time_at(profile, position: float) -> float:
    lo, hi = 0.0, profile.times[-1]
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if _positions(profile, np.array([mid]))[0] < position:
            lo = mid
        else:
            hi = mid
    return hi


def test_one_restriction_by_hand() -> None:
    train = crh2_half()
    extent = float(np.sum(train.spacing))
    low, cruise, a, b = 12.0, 25.0, 0.3, 0.5
    track = Track(speed_limits=(SpeedLimit(start=3000.0, limit=low),
                                SpeedLimit(start=3500.0, limit=40.0)))
    profile = limited_profile(track, train, cruise=cruise, acceleration=a, deceleration=b,
                              end=10_000.0)
    brake_at = 3000.0 - (cruise**2 - low**2) / (2 * b)
    accel_at = 3500.0 + extent
    t_brake = brake_at / cruise
    t_low = t_brake + (cruise - low) / b
    t_go = t_low + (accel_at - 3000.0) / low
    t_up = t_go + (cruise - low) / a
    expected = [0.0, t_brake, t_low, t_go, t_up]
    np.testing.assert_allclose(profile.times[:5], expected, rtol=1e-12)
    np.testing.assert_allclose(profile.speeds[:5], [cruise, cruise, low, low, cruise],
                               rtol=1e-12)
    _check(profile, track, train, cruise=cruise, a=a, b=b, end=10_000.0)


@pytest.mark.parametrize("name", ["CH_Fribourg_Bern", "SE_Vasteras_Kolback"])
def test_a_real_line_under_every_limit(name: str) -> None:
    line = builtin_line(name)
    train = crh2_half()
    cruise = 140 / 3.6
    profile = limited_profile(line.track, train, cruise=cruise, acceleration=0.4,
                              end=line.length, start_speed=0.0)
    b = 0.9 * float(braking_deceleration(train, np.linspace(0.0, cruise, 65)).min()
                    - max(0.0, -min(s.grade_permille for s in line.track.sections)) * 9.81e-3)
    _check(profile, line.track, train, cruise=cruise, a=0.4, b=b, end=line.length)
    assert profile.speeds[0] == 0.0


def test_a_heavy_train_brakes_earlier_and_waits_for_its_tail() -> None:
    track = Track(speed_limits=(SpeedLimit(start=4000.0, limit=10.0),
                                SpeedLimit(start=4100.0, limit=30.0)))
    heavy, short = heavy_haul_1p2p1(), crh2_half()
    long_plan = limited_profile(track, heavy, cruise=20.0, acceleration=0.1, end=12_000.0)
    short_plan = limited_profile(track, short, cruise=20.0, acceleration=0.1,
                                 deceleration=0.05, end=12_000.0)
    for plan, train in ((long_plan, heavy), (short_plan, short)):
        extent = float(np.sum(train.spacing))
        slopes = np.diff(plan.speeds) / np.diff(plan.times)
        b = -slopes.min()
        _check(plan, track, train, cruise=20.0, a=0.1, b=b, end=12_000.0)
        go = plan.times[int(np.argmax(slopes > 0))]  # the first acceleration
        assert _positions(plan, np.array([go]))[0] == pytest.approx(4100.0 + extent,
                                                                     rel=1e-9)


def test_bad_plans_are_refused() -> None:
    train = crh2_half()
    track = Track(speed_limits=(SpeedLimit(start=0.0, limit=20.0),
                                SpeedLimit(start=500.0, limit=5.0)))
    with pytest.raises(ModelError, match="'start_speed' must be from 0 to the ceiling 20"):
        limited_profile(track, train, cruise=25.0, acceleration=0.3, end=2000.0,
                        start_speed=22.0)
    with pytest.raises(ModelError, match="cannot brake at 0.1 m/s² to the next limit in time"):
        limited_profile(track, train, cruise=25.0, acceleration=0.3, deceleration=0.1,
                        end=2000.0)
    with pytest.raises(ModelError, match="'deceleration' must be at most"):
        limited_profile(track, train, cruise=20.0, acceleration=0.3, deceleration=5.0,
                        end=2000.0)
    steep = Track(sections=(TrackSection(start=0.0, grade_permille=-120.0),),
                  speed_limits=track.speed_limits)
    with pytest.raises(ModelError, match="cannot hold it on the 120 ‰ down-grade"):
        limited_profile(steep, heavy_haul_1p2p1(), cruise=20.0, acceleration=0.1, end=2000.0)
    with pytest.raises(ModelError, match="'end' must be beyond 'start'"):
        limited_profile(track, train, cruise=20.0, acceleration=0.3, end=0.0)


def test_braking_deceleration_is_the_envelopes_over_the_mass() -> None:
    train = heavy_haul_1p2p1()
    v = np.array([5.0, 15.0, 25.0])
    by_hand = np.zeros(3)
    for vehicle in train.vehicles:
        env = vehicle.envelope
        for k, speed in enumerate(v):
            by_hand[k] += min(env.max_braking, env.max_braking_power / speed,
                              env.adhesion * vehicle.mass * 9.81)
    np.testing.assert_allclose(braking_deceleration(train, v), by_hand / train.mass.sum(),
                               rtol=1e-12)


# --- [simulation.plan]: the planned reference of a scenario file -------------------------

def _plan_text(track: str, plan: str, reference: bool = False) -> str:
    """crh2-dmpc with ``track`` and ``plan`` in place of its typed reference."""
    from trainctl.scenario import builtin_scenario_text

    text = builtin_scenario_text("crh2-dmpc")
    head, rest = text.split("[simulation.reference]", 1)
    typed = "[simulation.reference]" + rest.split("\n[", 1)[0] + "\n" if reference else ""
    tail = "\n[" + rest.split("\n[", 1)[1] if "\n[" in rest else ""
    return (head + typed + "[simulation.plan]\n" + plan + "\n" + tail
            + "\n[track]\n" + track + "\n")


LIMITED = ("[[track.section]]\nstart = 0.0\ngrade_permille = -3.0\n"
           "[[track.speed_limit]]\nstart = 0.0\nlimit_kmh = 250.0\n"
           "[[track.speed_limit]]\nstart = 8000.0\nlimit_kmh = 120.0\n"
           "[[track.speed_limit]]\nstart = 9000.0\nlimit_kmh = 250.0\n")


def test_a_scenario_plans_its_reference_along_the_track() -> None:
    from trainctl.scenario import parse_scenario

    scenario = parse_scenario(_plan_text(LIMITED, "cruise_kmh = 200.0\nacceleration = 0.3\n"
                                         "end = 20000.0\nstart_speed_kmh = 72.0"))
    sim = scenario.simulation
    profile = limited_profile(scenario.track, scenario.train, cruise=200 / 3.6,
                              acceleration=0.3, end=20_000.0, start_speed=20.0)
    assert sim.reference_times == profile.times and sim.reference_speeds == profile.speeds
    b = 0.9 * float(braking_deceleration(scenario.train, np.linspace(0.0, 200 / 3.6, 65)).min())
    _check(profile, scenario.track, scenario.train, cruise=200 / 3.6, a=0.3, b=b, end=20_000.0)
    assert min(sim.reference_speeds[1:]) == pytest.approx(120 / 3.6)  # the restriction binds
    slower = scenario.replace("simulation.plan.cruise_kmh", 100.0)  # planned anew
    assert max(slower.simulation.reference_speeds) == pytest.approx(100 / 3.6)
    assert slower.simulation.reference_times[-1] > sim.reference_times[-1]


def test_a_plan_on_a_shipped_line_ends_at_its_last_stop() -> None:
    from trainctl.scenario import parse_scenario

    scenario = parse_scenario(_plan_text('line = "CH_Fribourg_Bern"',
                                         "cruise_kmh = 140.0\nacceleration = 0.4"))
    line = builtin_line("CH_Fribourg_Bern")
    times = np.linspace(0.0, scenario.simulation.reference_times[-1], 50_001)
    profile = limited_profile(line.track, scenario.train, cruise=140 / 3.6, acceleration=0.4,
                              end=line.stops[-1])
    assert scenario.simulation.reference_speeds == profile.speeds
    assert _positions(profile, times[-1:])[0] == pytest.approx(line.stops[-1], rel=1e-9)


@pytest.mark.parametrize("track, plan, message", [
    (LIMITED, "cruise_kmh = 200.0\nacceleration = 0.3", "[simulation.plan] needs end"),
    (LIMITED, "cruise_kmh = -1.0\nacceleration = 0.3\nend = 9e3",
     "[simulation.plan].cruise_kmh must be"),
    (LIMITED, "cruise_kmh = 200.0\nacceleration = 0.3\nend = 9e3\ndeceleration = 5.0",
     "[simulation.plan]: limited_breakpoints: 'deceleration' must be at most"),
    (LIMITED, "cruise_kmh = 200.0\nacceleration = 0.3\nend = 9e3\nspeed = 3",
     "[simulation.plan]"),
])
def test_bad_plans_in_a_file_are_refused(track: str, plan: str, message: str,
                                         tmp_path, capsys: pytest.CaptureFixture[str]) -> None:
    from tests.test_cli import assert_refused

    path = tmp_path / "mine.toml"
    path.write_text(_plan_text(track, plan))
    assert_refused(path, message, capsys)


def test_a_plan_needs_a_track_and_no_typed_reference(tmp_path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from tests.test_cli import assert_refused

    plan = "cruise_kmh = 200.0\nacceleration = 0.3\nend = 9e3"
    path = tmp_path / "both.toml"
    path.write_text(_plan_text(LIMITED, plan, reference=True))
    assert_refused(path, "[simulation.plan] cannot be given with [simulation.reference]", capsys)
    path = tmp_path / "trackless.toml"
    path.write_text(_plan_text(LIMITED, plan).split("\n[track]\n")[0].replace(
        LIMITED, ""))
    assert_refused(path, "[simulation.plan] needs a [track] to plan along", capsys)


def test_the_schema_takes_a_plan_or_a_reference_not_both() -> None:
    import tomllib

    import jsonschema

    from trainctl.scenario.schema import json_schema

    validator = jsonschema.Draft202012Validator(json_schema())
    plan = "cruise_kmh = 200.0\nacceleration = 0.3\nend = 9e3"
    assert not list(validator.iter_errors(tomllib.loads(_plan_text(LIMITED, plan))))
    both = tomllib.loads(_plan_text(LIMITED, plan, reference=True))
    assert list(validator.iter_errors(both))
    neither = tomllib.loads(_plan_text(LIMITED, plan))
    del neither["simulation"]["plan"]
    assert list(validator.iter_errors(neither))


def _typed(times: list[float], speeds_kmh: list[float]) -> str:
    """crh2-dmpc on LIMITED with a typed reference."""
    from trainctl.scenario import builtin_scenario_text

    text = builtin_scenario_text("crh2-dmpc")
    head, rest = text.split("[simulation.reference]", 1)
    tail = "\n[" + rest.split("\n[", 1)[1] if "\n[" in rest else ""
    return (head + f"[simulation.reference]\ntimes = {times}\nspeeds_kmh = {speeds_kmh}\n"
            + tail + "\n[track]\n" + LIMITED + "\n")


def test_the_review_fails_a_reference_over_a_speed_limit() -> None:
    from trainctl.analysis.feasibility import feasibility_check
    from trainctl.scenario import parse_scenario

    scenario = parse_scenario(_typed([0.0], [250.0]))  # 250 km/h through the 120 km/h zone
    check = feasibility_check(scenario)
    assert check.status == "fail"
    found = check.details["speed_limit"]
    assert found["excess"] == pytest.approx(130 / 3.6, rel=1e-12)
    assert found["time"] == pytest.approx(8000.0 / (250 / 3.6), rel=1e-9)  # head at 8 km
    assert "exceeds the speed limit of 120 km/h (from 8000 m) by 130 km/h" in check.message


def test_the_tail_must_leave_a_restriction_before_the_reference_speeds_up() -> None:
    from trainctl.analysis.feasibility import feasibility_check
    from trainctl.scenario import parse_scenario

    v = 119.5 / 3.6  # just under 120 km/h; then 100 s at 0.1 m/s²
    length = float(np.sum(parse_scenario(_typed([0.0], [100.0])).train.spacing))
    head_out = 9000.0 / v  # the head leaves the 120 km/h zone; the tail is still in it
    tail_out = (9000.0 + length) / v
    top = 3.6 * (v + 10.0)
    early = parse_scenario(_typed([0.0, head_out, head_out + 100.0], [119.5, 119.5, top]))
    late = parse_scenario(_typed([0.0, tail_out, tail_out + 100.0], [119.5, 119.5, top]))
    check = feasibility_check(early)
    assert check.status == "fail" and "120 km/h (from 8000 m)" in check.message
    # from head_out the speed grows at 0.1 m/s² while the head runs `length` more: the tail
    # leaves at v_out² = v² + 2 · 0.1 · length
    assert check.details["speed_limit"]["excess"] == pytest.approx(
        np.sqrt(v * v + 0.2 * length) - 120 / 3.6, rel=1e-9)
    assert "speed limit" not in feasibility_check(late).message
    assert feasibility_check(late).details["speed_limit"]["excess"] <= 1e-9


def test_a_planned_reference_passes_the_speed_limit_review() -> None:
    from trainctl.analysis.feasibility import feasibility_check
    from trainctl.scenario import parse_scenario

    scenario = parse_scenario(_plan_text(LIMITED, "cruise_kmh = 200.0\nacceleration = 0.3\n"
                                         "end = 20000.0"))
    excess = feasibility_check(scenario).details["speed_limit"]["excess"]
    assert abs(excess) <= 1e-9  # the plan runs at the limit, never over it
