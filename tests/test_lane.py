"""The closed loop's compiled lane (``trainctl.sim._lane``, numba): the Python path's records.

Every run here is simulated twice, with ``TRAINCTL_COMPILED=0`` (the Python loop) and
``=1`` (the compiled lane, whatever the run's length), and every array and record of
the two must be the same, bit for bit: saturation, dense points, a grade, both clips
off, a fault on every sample, a divergence, grid speeds outside the lane's table.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

pytest.importorskip("numba")

from trainctl.controllers.lqr.controller import LQRController  # noqa: E402
from trainctl.models import crh2_half, equilibrium  # noqa: E402
from trainctl.models.plant import Plant  # noqa: E402
from trainctl.models.track import Track, TrackSection  # noqa: E402
from trainctl.sim import _lane, closed_loop, simulate  # noqa: E402
from trainctl.sim.reference import ramp_profile  # noqa: E402

DT = 0.05


def _gain(level: float = 40.0) -> np.ndarray:
    """K [kN per m/s, per m]: speed feedback strong enough to saturate after the ramp's
    start, and some coupler feedback."""
    gain = np.zeros((4, 7))
    gain[np.arange(4), np.arange(4)] = level
    gain[np.arange(3), 4 + np.arange(3)] = 3.0
    gain[1 + np.arange(3), 4 + np.arange(3)] = -3.0
    return gain


def _run(monkeypatch: pytest.MonkeyPatch, compiled: bool, *, train=None, track=None,
         gain=None, input_bounds: bool = True, duration: float = 40.0, **options):
    train = train or crh2_half()
    monkeypatch.setenv("TRAINCTL_COMPILED", "1" if compiled else "0")
    used: list[object] = []
    original = _lane.lane

    def spy(*args):
        found = original(*args)
        used.append(found)
        return found

    monkeypatch.setattr(closed_loop, "_lane", spy)
    controller = LQRController(train, _gain() if gain is None else gain, dt=DT,
                               input_bounds=input_bounds)
    x0 = equilibrium(train, 20.0).state(position=100.0)
    x0[:4] += np.array([0.4, -0.3, 0.2, -0.1])
    result = simulate(Plant(train=train, track=track), controller,
                      ramp_profile(20.0, 30.0, 1.0, 6.0), duration=duration, initial_state=x0,
                      preview_steps=1, warn=False, **options)
    return result, used[0] if used else None


def _same(a, b) -> None:
    for field in dataclasses.fields(a):
        if field.name in ("solve_times", "meta"):
            continue
        value = getattr(a, field.name)
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(value, getattr(b, field.name), err_msg=field.name)
        else:
            assert value == getattr(b, field.name), field.name
    assert a.meta.get("divergence") == b.meta.get("divergence")


def _both(monkeypatch: pytest.MonkeyPatch, **kwargs):
    python, none = _run(monkeypatch, False, **kwargs)
    compiled, lane = _run(monkeypatch, True, **kwargs)
    assert none is None and lane is not None
    _same(python, compiled)
    return compiled


CASES = {
    "saturating": {},
    "dense points": {"output_interval": DT / 3},
    "uniform grade": {"track": Track(sections=(TrackSection(start=0.0,
                                                            grade_permille=6.0),))},
    "clips off": {"input_bounds": False, "saturation": False},
    "no quadratic drag": {"train": dataclasses.replace(crh2_half(), vehicles=tuple(
        dataclasses.replace(v, a2=0.0) for v in crh2_half().vehicles))},
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_lane_records_what_the_python_loop_records(case: str,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    result = _both(monkeypatch, **CASES[case])
    assert len(set(np.round(result.velocities[0], 0))) > 5  # several grid speeds: the table grew
    if case in ("saturating", "dense points"):
        assert np.count_nonzero(result.saturation) > 0
    if case == "dense points":
        assert result.dense_states.shape[1] == 3 * result.inputs.shape[1] + 1


def test_a_fault_goes_the_python_way(monkeypatch: pytest.MonkeyPatch) -> None:
    gain = _gain()
    gain[2, 3] = 1.7e308  # K x̃ [N] overflows: every sample falls back
    result = _both(monkeypatch, gain=gain, duration=5.0)
    assert set(result.statuses) == {"error"} and set(result.fallbacks) == {"feedforward"}


def test_a_divergence_stops_where_the_python_loop_stops(monkeypatch: pytest.MonkeyPatch) -> None:
    result = _both(monkeypatch, gain=_gain(-5.0), divergence_speed_error=2.0)
    assert result.divergence is not None and result.inputs.shape[1] < 800


def test_grid_speeds_outside_the_table_go_the_python_way(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_lane, "_GRID", 12)  # the table holds |v̄| <= 22 m/s
    result = _both(monkeypatch)  # lane, Python above 23 m/s, lane again at each chunk
    assert result.velocities[0].max() > 25.0


def test_when_the_lane_is_taken(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("TRAINCTL_COMPILED", raising=False)
    assert _run(monkeypatch, False, duration=2.0)[1] is None
    monkeypatch.setattr(_lane, "MIN_SAMPLES", 40)  # the default: long runs only
    train = crh2_half()
    sections = Track(sections=(TrackSection(start=0.0), TrackSection(start=900.0,
                                                                     grade_permille=3.0)))
    assert _run(monkeypatch, True, duration=2.0, track=sections)[1] is None  # crossings
    monkeypatch.setattr(_lane, "_kernel", lambda: None)  # numba not installed
    result, lane = _run(monkeypatch, True, duration=2.0, train=train)
    assert lane is None and result.inputs.shape == (4, 40)


def test_a_law_replaced_on_the_instance_or_in_a_subclass_is_run_the_python_way() -> None:
    train = crh2_half()

    class Doubled(LQRController):
        def step(self, t, measurement, reference):
            return super().step(t, measurement, reference)

    plain = LQRController(train, _gain(), dt=DT)
    assert _lane._linear_law(plain) is not None
    assert _lane._linear_law(Doubled(train, _gain(), dt=DT)) is None
    patched = LQRController(train, _gain(), dt=DT)
    patched._feedback = lambda deviation: 0.0 * deviation  # type: ignore[method-assign]
    assert _lane._linear_law(patched) is None
