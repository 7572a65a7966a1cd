"""Line capacity (:mod:`trainctl.sim.capacity`) against hand arithmetic and a simulation.

The braking distance and the capacities are worked by hand in the comments.
The relative braking distance is checked against a brute-force run of the two
braking trains: their speeds on a dense time grid, integrated to positions by
trapezoids, and the closest approach read off as the grid's minimum gap; none
of the module's closed forms is used there. Passing times are read off
formations whose heads move at constant speed, where each passing time and
headway is known in closed form.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re

import numpy as np
import pytest

from trainctl.exceptions import ModelError
from trainctl.sim.capacity import (
    LineCapacity,
    absolute_braking_capacity,
    braking_distance,
    headways_at,
    passing_times,
    relative_braking_capacity,
    relative_braking_distance,
    uniform_capacity,
)
from trainctl.units import kg_per_s_to_t_per_h


def test_kg_per_s_to_t_per_h():
    # 1 kg/s for 3600 s is 3600 kg = 3.6 t; 250 kg/s is 900 t/h
    assert kg_per_s_to_t_per_h(1.0) == pytest.approx(3.6, rel=1e-15)
    assert kg_per_s_to_t_per_h(250.0) == pytest.approx(900.0, rel=1e-15)


# --- braking distance -----------------------------------------------------------------------


def test_braking_distance_by_hand():
    # 20 m/s, 0.5 m/s², 2 s reaction, 50 m margin: 20·2 + 20²/(2·0.5) + 50 = 40 + 400 + 50
    d = braking_distance(20.0, 0.5, reaction_time=2.0, margin=50.0)
    assert isinstance(d, float)
    assert d == pytest.approx(490.0, rel=1e-15)
    # no reaction and no margin: 30²/(2·1.5) = 900/3 = 300 m
    assert braking_distance(30.0, 1.5) == pytest.approx(300.0, rel=1e-15)
    # standing still: the margin alone
    assert braking_distance(0.0, 0.7, reaction_time=3.0, margin=12.0) == 12.0


def test_braking_distance_broadcasts():
    # speeds 10, 20, 30 m/s (a row) at 0.5 and 1.0 m/s² (a column), 1 s reaction:
    # at 0.5: 10 + 100, 20 + 400, 30 + 900; at 1.0: 10 + 50, 20 + 200, 30 + 450
    d = braking_distance([10.0, 20.0, 30.0], [[0.5], [1.0]], reaction_time=1.0)
    assert isinstance(d, np.ndarray) and d.shape == (2, 3)
    np.testing.assert_allclose(d, [[110.0, 420.0, 930.0], [60.0, 220.0, 480.0]], rtol=1e-15)
    # an array of margins against a scalar speed: 10²/2 = 50 plus each margin
    np.testing.assert_allclose(braking_distance(10.0, 1.0, margin=np.array([0.0, 5.0])),
                               [50.0, 55.0], rtol=1e-15)


# --- capacities -----------------------------------------------------------------------------


def _assert_capacity(cap: LineCapacity, *, speed, distance_headway, headway, trains_per_hour,
                     mass, throughput, tonnes_per_hour):
    assert cap.speed == pytest.approx(speed, rel=1e-12)
    assert cap.distance_headway == pytest.approx(distance_headway, rel=1e-12)
    assert cap.headway == pytest.approx(headway, rel=1e-12)
    assert cap.trains_per_hour == pytest.approx(trains_per_hour, rel=1e-12)
    assert cap.mass_per_train == pytest.approx(mass, rel=1e-12)
    assert cap.throughput == pytest.approx(throughput, rel=1e-12)
    assert cap.tonnes_per_hour == pytest.approx(tonnes_per_hour, rel=1e-12)


# A 1300 m, 10 000 t train at 20 m/s, 490 m behind the next (the braking distance above):
# 1790 m head to head, 1790 / 20 = 89.5 s, 3600 / 89.5 = 40.2235 trains/h,
# 1e7 kg / 89.5 s = 111 731.8 kg/s, i.e. 40.2235 trains/h · 10 000 t = 402 234.6 t/h.
BY_HAND = dict(speed=20.0, distance_headway=1790.0, headway=89.5,
               trains_per_hour=3600.0 / 89.5, mass=1.0e7, throughput=1.0e7 / 89.5,
               tonnes_per_hour=3600.0 / 89.5 * 10_000.0)


def test_uniform_capacity_by_hand():
    _assert_capacity(uniform_capacity(1300.0, 490.0, 20.0, 1.0e7), **BY_HAND)
    # one combined train of three units, no gap inside: 3900 m at 25 m/s, 3e7 kg, gap 0 →
    # 156 s, 3600 / 156 = 23.077 trains/h, 3e7 / 156 kg/s = 692 307.7 t/h
    _assert_capacity(uniform_capacity(3900.0, 0.0, 25.0, 3.0e7), speed=25.0,
                     distance_headway=3900.0, headway=156.0, trains_per_hour=3600.0 / 156.0,
                     mass=3.0e7, throughput=3.0e7 / 156.0,
                     tonnes_per_hour=3600.0 / 156.0 * 30_000.0)


def test_absolute_braking_capacity_by_hand():
    cap = absolute_braking_capacity(1300.0, 20.0, 0.5, 1.0e7, reaction_time=2.0, margin=50.0)
    _assert_capacity(cap, **BY_HAND)
    # no reaction time or margin: 20²/(2·0.5) = 400 m gap, (1300 + 400) / 20 = 85 s
    assert absolute_braking_capacity(1300.0, 20.0, 0.5, 1.0e7).headway == pytest.approx(85.0)


def test_relative_braking_capacity_by_hand():
    # equal brakes 0.5 m/s², 2 s delay, 50 m margin at 20 m/s: the follower's motion is the
    # leader's 2 s later, never slower, so it gains most at its stop: 20·2 = 40 m;
    # gap 40 + 50 = 90 m, (1300 + 90) / 20 = 69.5 s, 51.80 trains/h, 517 985.6 t/h
    cap = relative_braking_capacity(1300.0, 20.0, follower_deceleration=0.5,
                                    leader_deceleration=0.5, delay=2.0,
                                    mass_per_train=1.0e7, margin=50.0)
    _assert_capacity(cap, speed=20.0, distance_headway=1390.0, headway=69.5,
                     trains_per_hour=3600.0 / 69.5, mass=1.0e7, throughput=1.0e7 / 69.5,
                     tonnes_per_hour=3600.0 / 69.5 * 10_000.0)
    # weaker follower brakes 0.4 against 0.5, 1 s delay, 10 m margin: the follower is never
    # slower, so the closest approach is at its stop: 20·1 + 400/0.8 - 400/1 = 120 m, + 10
    cap = relative_braking_capacity(1300.0, 20.0, follower_deceleration=0.4,
                                    leader_deceleration=0.5, delay=1.0,
                                    mass_per_train=1.0e7, margin=10.0)
    assert cap.distance_headway == pytest.approx(1300.0 + 130.0, rel=1e-12)
    assert cap.headway == pytest.approx(1430.0 / 20.0, rel=1e-12)


def test_line_capacity_is_frozen():
    cap = uniform_capacity(100.0, 0.0, 10.0, 1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        cap.headway = 1.0  # type: ignore[misc]


# --- relative braking distance against a simulation -----------------------------------------


def simulated_gap(vf: float, vl: float, bf: float, bl: float, delay: float,
                  margin: float, points: int = 200_001) -> float:
    """The least initial gap [m] by brute force: both trains' speeds on a dense grid, their
    positions by trapezoids, the follower's largest gain on the leader plus the margin."""
    t_end = 1.05 * max(delay + vf / bf, vl / bl) + 1.0
    t = np.linspace(0.0, t_end, points)
    v_follower = np.clip(vf - bf * np.clip(t - delay, 0.0, None), 0.0, None)
    v_leader = np.clip(vl - bl * t, 0.0, None)
    dt = np.diff(t)

    def position(v: np.ndarray) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum(dt * (v[1:] + v[:-1]) / 2.0)])

    gain = position(v_follower) - position(v_leader)
    return margin + float(gain.max())


def standstill(vf, vl, bf, bl, delay, margin):
    """The standstill formula alone (floored at the margin): right only when the closest
    approach is at the follower's stop."""
    return margin + max(0.0, vf * delay + vf**2 / (2 * bf) - vl**2 / (2 * bl))


GRID = list(itertools.product([0.0, 12.0, 25.0], [0.0, 12.0, 25.0], [0.4, 1.0], [0.4, 1.0],
                              [0.0, 3.0]))


@pytest.mark.parametrize(("vf", "vl", "bf", "bl", "delay"), GRID)
def test_relative_braking_distance_matches_simulation(vf, vl, bf, bl, delay):
    expected = simulated_gap(vf, vl, bf, bl, delay, margin=10.0)
    got = relative_braking_distance(vf, vl, follower_deceleration=bf, leader_deceleration=bl,
                                    delay=delay, margin=10.0)
    assert got == pytest.approx(expected, abs=1e-5)
    assert got >= 10.0


# (vf, vl, bf, bl, delay, hand value without margin)
EARLY = [
    # no delay: D' = 5 - 0.5 t = 0 at t = 10 s (before the follower's stop at 20 s):
    # D(10) = (20·10 - 50) - (15·10 - 25) = 25 m; standstill: 200 - 225 = -25 m
    (20.0, 15.0, 1.0, 0.5, 0.0, 25.0),
    # 1 s delay: equal speeds when 20 - (t - 1) = 15 - 0.5 t, t = 12 s:
    # D(12) = (20 + 20·11 - 121/2) - (15·12 - 0.25·144) = 179.5 - 144 = 35.5 m;
    # standstill: 20 + 200 - 225 = -5 m
    (20.0, 15.0, 1.0, 0.5, 1.0, 35.5),
    # 25 behind 20, 1.0 against 0.6 m/s², no delay: t = 5 / 0.4 = 12.5 s,
    # D = 5² / (2·0.4) = 31.25 m; standstill: 312.5 - 333.3 = -20.8 m
    (25.0, 20.0, 1.0, 0.6, 0.0, 31.25),
]


@pytest.mark.parametrize(("vf", "vl", "bf", "bl", "delay", "hand"), EARLY)
def test_early_closest_approach(vf, vl, bf, bl, delay, hand):
    got = relative_braking_distance(vf, vl, follower_deceleration=bf, leader_deceleration=bl,
                                    delay=delay, margin=5.0)
    assert got == pytest.approx(hand + 5.0, rel=1e-12)
    assert got == pytest.approx(simulated_gap(vf, vl, bf, bl, delay, 5.0), abs=1e-5)
    # the standstill formula alone would leave the trains too close
    assert standstill(vf, vl, bf, bl, delay, 5.0) < got - 20.0


def test_relative_braking_distance_special_cases():
    # equal speeds, equal brakes, no delay: the trains brake side by side, the gap stays
    assert relative_braking_distance(20.0, 20.0, follower_deceleration=0.5,
                                     leader_deceleration=0.5, margin=7.5) == 7.5
    assert relative_braking_distance(20.0, 20.0, follower_deceleration=0.5,
                                     leader_deceleration=0.5) == 0.0
    # leader at standstill: the absolute braking distance, 20·2 + 400 + 5 = 445 m
    assert relative_braking_distance(
        20.0, 0.0, follower_deceleration=0.5, leader_deceleration=0.9, delay=2.0, margin=5.0
    ) == pytest.approx(445.0, rel=1e-12)
    # equal speeds and brakes with a 2 s delay: the follower is 0.5·2 = 1 m/s faster from
    # t = 2 s to the leader's stop, then stops 2 s later: its gain is 20·2 = 40 m
    assert relative_braking_distance(
        20.0, 20.0, follower_deceleration=0.5, leader_deceleration=0.5, delay=2.0
    ) == pytest.approx(40.0, rel=1e-12)
    # a slower follower with stronger brakes only falls back: the margin alone
    assert relative_braking_distance(10.0, 20.0, follower_deceleration=1.0,
                                     leader_deceleration=0.5, margin=3.0) == 3.0
    # a follower standing still
    assert relative_braking_distance(0.0, 20.0, follower_deceleration=1.0,
                                     leader_deceleration=0.5, delay=4.0, margin=2.0) == 2.0


# --- passing times and headways -------------------------------------------------------------


def formation(spacing: float, speed: float, order: list[int], times: np.ndarray) -> np.ndarray:
    """Heads at -k·spacing at t = 0 (k from ``order``), all at ``speed``."""
    return np.array([speed * times - k * spacing for k in order])


def test_uniform_formation():
    # heads 500 m apart at 20 m/s pass 1010 m at (1010 + 500 k) / 20 s: 50.5, 75.5, 100.5,
    # 125.5 s, between the 1 s samples; the headway is 500 / 20 = 25 s
    times = np.arange(0.0, 301.0)
    order = [2, 0, 3, 1]
    heads = formation(500.0, 20.0, order, times)
    heads = np.vstack([heads, np.full(times.size, -5000.0)])  # a unit that stands
    passed = passing_times(times, heads, 1010.0)
    np.testing.assert_allclose(passed[:4], [(1010.0 + 500.0 * k) / 20.0 for k in order],
                               rtol=1e-12)
    assert math.isnan(passed[4])
    np.testing.assert_allclose(headways_at(times, heads, 1010.0), [25.0, 25.0, 25.0],
                               rtol=1e-12)


def test_passing_time_interpolation():
    times = [0.0, 1.0, 2.0, 3.0]
    heads = [
        [0.0, 10.0, 30.0, 40.0],  # 20 m is 10/20 of the way from 1 s to 2 s: 1.5 s
        [0.0, 30.0, 10.0, 40.0],  # first crossing 0 → 30 m: 20/30 s; the return is ignored
        [0.0, 20.0, 40.0, 60.0],  # on a sample: 1 s
        [50.0, 60.0, 70.0, 80.0],  # already past at the first sample: 0 s
        [0.0, 5.0, 19.9, 19.9],  # never reaches it
    ]
    passed = passing_times(times, heads, 20.0)
    np.testing.assert_allclose(passed[:4], [1.5, 2.0 / 3.0, 1.0, 0.0], rtol=1e-12)
    assert math.isnan(passed[4])
    # the sorted finite times 0, 2/3, 1, 1.5
    np.testing.assert_allclose(headways_at(times, heads, 20.0), [2.0 / 3.0, 1.0 / 3.0, 0.5],
                               rtol=1e-12)


def test_headways_with_fewer_than_two_units():
    times = [0.0, 1.0]
    assert headways_at(times, [[0.0, 10.0]], 5.0).size == 0
    assert headways_at(times, [[0.0, 1.0], [0.0, 2.0]], 5.0).size == 0


# --- errors ---------------------------------------------------------------------------------

T2 = [0.0, 1.0]
H2 = [[0.0, 1.0]]


def rbd(**changes):
    kwargs = dict(follower_deceleration=1.0, leader_deceleration=0.5, delay=0.0, margin=0.0)
    kwargs.update(changes)
    speeds = (kwargs.pop("follower_speed", 20.0), kwargs.pop("leader_speed", 15.0))
    return lambda: relative_braking_distance(*speeds, **kwargs)


def rbc(**changes):
    kwargs = dict(train_length=1300.0, speed=20.0, follower_deceleration=0.5,
                  leader_deceleration=0.5, delay=1.0, mass_per_train=1.0e7, margin=0.0)
    kwargs.update(changes)
    return lambda: relative_braking_capacity(kwargs.pop("train_length"), kwargs.pop("speed"),
                                             **kwargs)


ERRORS = [
    (lambda: braking_distance(-1.0, 0.5), "braking_distance: 'speed' must be >= 0 (got -1.0)"),
    (lambda: braking_distance([10.0, -1.0], 0.5),
     "braking_distance: 'speed' must be finite and >= 0 (got -1.0 at [1])"),
    (lambda: braking_distance("fast", 0.5),
     "braking_distance: 'speed' must be a number (got 'fast')"),
    (lambda: braking_distance(["fast"], 0.5),
     "braking_distance: 'speed' must be numbers (got ['fast'])"),
    (lambda: braking_distance(10.0, 0.0),
     "braking_distance: 'deceleration' must be > 0 (got 0.0)"),
    (lambda: braking_distance(10.0, [0.5, math.nan]),
     "braking_distance: 'deceleration' must be finite and > 0 (got nan at [1])"),
    (lambda: braking_distance(10.0, math.inf),
     "braking_distance: 'deceleration' must be finite (got inf)"),
    (lambda: braking_distance(10.0, 0.5, reaction_time=-2.0),
     "braking_distance: 'reaction_time' must be >= 0 (got -2.0)"),
    (lambda: braking_distance(10.0, 0.5, margin=-1.0),
     "braking_distance: 'margin' must be >= 0 (got -1.0)"),
    (lambda: braking_distance([1.0, 2.0], [1.0, 2.0, 3.0]),
     "braking_distance: 'speed', 'deceleration', 'reaction_time' and 'margin' must broadcast "
     "together (got shapes (2,), (3,), (), ())"),
    (rbd(follower_speed=-1.0), "relative_braking_distance: 'follower_speed' must be >= 0"),
    (rbd(leader_speed=math.nan), "relative_braking_distance: 'leader_speed' must be finite"),
    (rbd(follower_deceleration=0.0),
     "relative_braking_distance: 'follower_deceleration' must be > 0 (got 0.0)"),
    (rbd(leader_deceleration=-0.5),
     "relative_braking_distance: 'leader_deceleration' must be > 0 (got -0.5)"),
    (rbd(delay=-1.0), "relative_braking_distance: 'delay' must be >= 0 (got -1.0)"),
    (rbd(margin=-3.0), "relative_braking_distance: 'margin' must be >= 0 (got -3.0)"),
    (lambda: uniform_capacity(0.0, 10.0, 20.0, 1e7),
     "uniform_capacity: 'train_length' must be > 0 (got 0.0)"),
    (lambda: uniform_capacity(100.0, -1.0, 20.0, 1e7),
     "uniform_capacity: 'gap' must be >= 0 (got -1.0)"),
    (lambda: uniform_capacity(100.0, 10.0, 0.0, 1e7),
     "uniform_capacity: 'speed' must be > 0 (got 0.0)"),
    (lambda: uniform_capacity(100.0, 10.0, 20.0, 0.0),
     "uniform_capacity: 'mass_per_train' must be > 0 (got 0.0)"),
    (lambda: absolute_braking_capacity(-1.0, 20.0, 0.5, 1e7),
     "absolute_braking_capacity: 'train_length' must be > 0 (got -1.0)"),
    (lambda: absolute_braking_capacity(100.0, 0.0, 0.5, 1e7),
     "absolute_braking_capacity: 'speed' must be > 0 (got 0.0)"),
    (lambda: absolute_braking_capacity(100.0, 20.0, 0.0, 1e7),
     "absolute_braking_capacity: 'deceleration' must be > 0 (got 0.0)"),
    (lambda: absolute_braking_capacity(100.0, 20.0, 0.5, -1.0),
     "absolute_braking_capacity: 'mass_per_train' must be > 0 (got -1.0)"),
    (lambda: absolute_braking_capacity(100.0, 20.0, 0.5, 1e7, reaction_time=-1.0),
     "absolute_braking_capacity: 'reaction_time' must be >= 0 (got -1.0)"),
    (lambda: absolute_braking_capacity(100.0, 20.0, 0.5, 1e7, margin=-1.0),
     "absolute_braking_capacity: 'margin' must be >= 0 (got -1.0)"),
    (rbc(train_length=0.0), "relative_braking_capacity: 'train_length' must be > 0 (got 0.0)"),
    (rbc(speed=0.0), "relative_braking_capacity: 'speed' must be > 0 (got 0.0)"),
    (rbc(follower_deceleration=0.0),
     "relative_braking_capacity: 'follower_deceleration' must be > 0 (got 0.0)"),
    (rbc(leader_deceleration=-1.0),
     "relative_braking_capacity: 'leader_deceleration' must be > 0 (got -1.0)"),
    (rbc(delay=-1.0), "relative_braking_capacity: 'delay' must be >= 0 (got -1.0)"),
    (rbc(mass_per_train=0.0),
     "relative_braking_capacity: 'mass_per_train' must be > 0 (got 0.0)"),
    (rbc(margin=-1.0), "relative_braking_capacity: 'margin' must be >= 0 (got -1.0)"),
    (lambda: passing_times([0.0, 2.0, 1.0], [[0.0, 1.0, 2.0]], 0.5),
     "passing_times: 'times' must be finite and strictly increasing (got 1.0 at [2])"),
    (lambda: passing_times([0.0, 1.0, 1.0], [[0.0, 1.0, 2.0]], 0.5),
     "passing_times: 'times' must be finite and strictly increasing (got 1.0 at [2])"),
    (lambda: passing_times([0.0, math.nan], H2, 0.5),
     "passing_times: 'times' must be finite and strictly increasing (got nan at [1])"),
    (lambda: passing_times([[0.0, 1.0]], H2, 0.5),
     "passing_times: 'times' must be a non-empty 1-D sequence (got shape (1, 2))"),
    (lambda: passing_times(T2, [0.0, 1.0], 0.5),
     "passing_times: 'head_positions' must have shape (units, 2), one row per unit over "
     "'times' (got (2,))"),
    (lambda: passing_times(T2, [[0.0, 1.0, 2.0]], 0.5),
     "passing_times: 'head_positions' must have shape (units, 2)"),
    (lambda: passing_times(T2, [[0.0, 1.0], [0.0, math.inf]], 0.5),
     "passing_times: 'head_positions' must be finite (got inf at [1, 1])"),
    (lambda: passing_times(T2, [["a", "b"]], 0.5),
     "passing_times: 'times' and 'head_positions' must be numbers"),
    (lambda: passing_times(T2, H2, math.nan), "passing_times: 'point' must be finite (got nan)"),
    (lambda: headways_at([1.0, 0.0], H2, 0.5),
     "headways_at: 'times' must be finite and strictly increasing (got 0.0 at [1])"),
    (lambda: headways_at(T2, [[0.0, 1.0, 2.0]], 0.5),
     "headways_at: 'head_positions' must have shape (units, 2)"),
]


@pytest.mark.parametrize(("call", "message"), ERRORS,
                         ids=[f"{i:02d}-{m.split(':')[0]}" for i, (_, m) in enumerate(ERRORS)])
def test_errors(call, message):
    with pytest.raises(ModelError, match=re.escape(message)):
        call()
