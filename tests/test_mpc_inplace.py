# The MPC step's in-place routes against the constructions they replace.
"""Preallocated routes of the MPC step (issue 27) equal the allocating ones, bit for bit.

- DAQP's bounds from the one-pass gather (:class:`~trainctl.controllers.mpc.qp.dense._Rows`)
  against a member-by-member reference written here;
- all blocks' parameters in one gather against :func:`block_parameters`;
- a block's data composed in place against ``prep.data + Jo @ U``;
- the solution of data in the solver's own buffer against the same data in a new array,
  and the slacks read later against the eager formula;
- the reused feedforward and bounds against a fresh computation;
- the one-test fault check against the reasons it gives.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from trainctl.controllers.base import Measurement, ReferencePreview
from trainctl.controllers.mpc.condensed import ParameterGather, block_parameters
from trainctl.controllers.mpc.qp.dense import _DAQP_INF, _HUGE, FastDAQP, _Rows
from trainctl.run.simulate import make_controller
from trainctl.scenario import load_scenario


@functools.cache
def controller(name: str = "crh2-dmpc-well-sampled", strategy: str = "ndmpc"):
    return make_controller(load_scenario(name), strategy)


def reference_bounds(n, n_data, rows, groups, factors, n_eq, d):
    """Member by member: upper = min of d/f over f > 0 (and equality rows), lower = max of
    d/f over f < 0 (and equality rows); a datum beyond 1e19 |f| is infinite; no member: inf."""
    upper, lower = np.full(n, _DAQP_INF), np.full(n, -_DAQP_INF)
    seen_up, seen_lo = np.zeros(n, bool), np.zeros(n, bool)
    for r, g, f in zip(rows, groups, factors, strict=True):
        scale = 1.0 / f
        value = d[r] * scale
        if f > 0 or r < n_eq:
            v = _DAQP_INF if value >= _HUGE * abs(scale) else value
            upper[g] = v if not seen_up[g] else min(upper[g], v)
            seen_up[g] = True
        if f < 0 or r < n_eq:
            v = -_DAQP_INF if value <= -_HUGE * abs(scale) else value
            lower[g] = v if not seen_lo[g] else max(lower[g], v)
            seen_lo[g] = True
    return lower, upper


@pytest.mark.parametrize("seed", range(8))
def test_rows_gather_equals_member_by_member_bounds(seed):
    rng = np.random.default_rng(seed)
    n, n_data, n_eq = 7, 20, 3
    rows = list(rng.permutation(n_data)[:16])
    groups = [int(g) for g in rng.integers(0, n, len(rows))]
    factors = [float(f) for f in rng.choice([-1.0, 1.0], len(rows)) * rng.uniform(0.1, 3.0,
                                                                                   len(rows))]
    rows_obj = _Rows(n, n_data, rows, groups, factors, n_eq, base=5)
    for _ in range(20):
        d = rng.normal(0.0, 100.0, n_data)
        d[rng.random(n_data) < 0.2] = 1e20    # clipped infinite bounds
        d[rng.random(n_data) < 0.1] = -1e20
        d[rng.random(n_data) < 0.05] = 0.0
        lower, upper = rows_obj.bounds(d)
        ref_lower, ref_upper = reference_bounds(n, n_data, rows, groups, factors, n_eq, d)
        np.testing.assert_array_equal(lower, ref_lower)
        np.testing.assert_array_equal(upper, ref_upper)
        # the view route from [base entries; data; sentinel] gives the same numbers
        ext = np.concatenate([rng.normal(size=5), d, [_DAQP_INF]])
        view_lower, view_upper = rows_obj.gather(ext)
        np.testing.assert_array_equal(view_lower, ref_lower)
        np.testing.assert_array_equal(view_upper, ref_upper)


def test_parameter_gather_equals_block_parameters():
    ctl = controller()
    blocks = ctl.problem.blocks
    gather = ParameterGather(blocks, fast=True)
    assert gather.stacked
    rng = np.random.default_rng(1)
    size = ctl.problem._src.size
    for _ in range(10):
        src = rng.normal(0.0, 50.0, size)
        src[rng.random(size) < 0.1] = np.inf
        src[rng.random(size) < 0.1] = -np.inf
        ours = [p.data.copy() for p in gather(src.copy())]
        ref = [p.data for p in block_parameters(blocks, src.copy(), True)]
        for a, b in zip(ours, ref, strict=True):
            np.testing.assert_array_equal(a, b)


def test_block_data_composed_in_place_equal_the_sum():
    ctl = controller()
    rng = np.random.default_rng(2)
    src = rng.normal(0.0, 20.0, ctl.problem._src.size)
    params = block_parameters(ctl.problem.blocks, src, True)
    for block, prep in zip(ctl.problem.blocks, params, strict=True):
        seen = []
        original = block.qp.solve_data

        def record(data, _o=original, _s=seen):
            _s.append(data.copy())
            return _o(data)

        block.qp.solve_data = record
        try:
            for _ in range(3):
                U = rng.normal(0.0, 5.0, ctl.M * ctl.n)
                block.solve(prep, U, "fast")
                np.testing.assert_array_equal(seen[-1], prep.data + block.Jo @ U)
        finally:
            del block.qp.solve_data


def test_solution_from_the_solver_buffer_equals_a_new_array():
    """A twin solver on copies of the data: the same decisions, statuses, iterations and
    slacks; the slacks read after later solves equal max(0, hl - F z, F z - hu)."""
    ctl = controller()
    block = ctl.problem.blocks[1]
    ours, twin = FastDAQP(block.qp.fast_path), FastDAQP(block.qp.fast_path)
    assert ours.soft
    rng = np.random.default_rng(3)
    ctl.reset()
    state = np.concatenate([50.0 + rng.normal(0.0, 1.0, 4), np.zeros(3), [0.0]])
    ctx = ctl._context(state, preview(50.0, 0.0, ctl.P, ctl.dt))
    src = ctl.problem.sources(ctx).copy()
    base = block_parameters(ctl.problem.blocks, src, True)[1].data
    sols, datas = [], []
    for _ in range(12):
        data = base + block.Jo @ rng.normal(0.0, 10.0, ctl.M * ctl.n)
        ours.data_buffer[...] = data
        a = ours.solve_vector(ours.data_buffer)
        b = twin.solve_vector(data.copy())
        np.testing.assert_array_equal(a.z, b.z)
        assert (a.status, a.iterations) == (b.status, b.iterations)
        assert a.status == "optimal"
        sols.append(a)
        datas.append(data)
    for sol, data in zip(sols, datas, strict=True):  # read after the buffers were rewritten
        lower, upper, _ = twin._bounds(data)
        part = twin._soft_part
        x = np.zeros(twin.n_vars)
        x[twin._z_pos] = sol.z
        Fz = twin._A_soft @ x
        expected = np.maximum(0.0, np.maximum(lower[part] - Fz, Fz - upper[part]))
        np.testing.assert_array_equal(sol.slack, expected)
        assert sol.slack.shape == (block.qp.ns,)


def preview(v: float, a: float, P: int, dt: float) -> ReferencePreview:
    times = dt * np.arange(P + 1)
    return ReferencePreview(times=times, speed=v + a * times, acceleration=np.full(P + 1, a))


def test_reused_feedforward_equals_a_fresh_one():
    ctl = controller()
    ctl.reset()
    state = np.concatenate([np.full(4, 50.0), np.zeros(3), [0.0]])
    ref = preview(50.0, 0.0, ctl.P, ctl.dt)
    first = ctl._context(state, ref)
    again = ctl._context(state + 0.01, ref)  # same preview: reused
    assert again.u_ff is first.u_ff and again.bounds is first.bounds
    u_ff, f_ff, elong0 = ctl._feedforward(ref.speed[:ctl.P + 1], ref.acceleration[:ctl.P + 1])
    np.testing.assert_array_equal(again.u_ff, u_ff[:ctl.M])
    np.testing.assert_array_equal(again.f_ff, f_ff[1:].ravel())
    np.testing.assert_array_equal(again.bounds, ctl._bound_pair(ref.speed[:ctl.M])
                                  - u_ff[:ctl.M].ravel())
    assert not again.bounds.flags.writeable and not again.u_ff.flags.writeable
    ramp = ctl._context(state, preview(50.0, 0.1, ctl.P, ctl.dt))  # a new preview
    assert ramp.u_ff is not first.u_ff
    assert not np.array_equal(ramp.u_ff, first.u_ff)


@pytest.mark.parametrize(("where", "value", "reason"), [
    ("state", np.nan, "non-finite measurement: state[2]"),
    ("state", np.inf, "non-finite measurement: state[2]"),
    ("speed", np.nan, "non-finite reference speed"),
    ("acceleration", -np.inf, "non-finite reference acceleration"),
    ("state", 1e300, ""),  # finite, however large
])
def test_fault_check(where, value, reason):
    ctl = controller()
    state = np.full(8, 50.0)
    ref = preview(50.0, 0.0, ctl.P, ctl.dt)
    if where == "state":
        state[2] = value
    else:
        getattr(ref, where)[5] = value
    got = ctl._fault(Measurement(state=state), ref)
    assert got.startswith(reason) and (reason or got == "")

