"""Tests of the plant's banded propagators (trainctl.models._plant_banded).

The banded path must equal the dense one (``propagation="dense"``, one expm of
the whole chain) and ``solve_ivp`` on the nonlinear chain ODE for practical
purposes, honour its truncation tolerance entry by entry, and leave the CRH2
half train (dense by default) exactly as it was.
"""

from __future__ import annotations

import numpy as np
import pytest

from trainctl.exceptions import ModelError
from trainctl.models import (
    Plant,
    Track,
    TrackSection,
    Train,
    coupler_forces,
    crh2_half,
    equilibrium,
    heavy_haul_1p2p1,
    virtual_formation,
)
from trainctl.models._plant_banded import (
    BAND_TOL,
    BANDED_MIN_VEHICLES,
    _window_expm,
    banded_flow,
)
from trainctl.models._plant_propagators import augmented_expm, ladder, propagator

HH204 = heavy_haul_1p2p1(detail="full")


def _kinds(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Block kind of each row of [Φ | Γ] (0 v, 1 delta, 2 s) and column (0 v, 1 delta,
    2 F, 3 the s column)."""
    rows = np.r_[np.zeros(n, int), np.ones(n - 1, int), 2]
    cols = np.r_[np.zeros(n, int), np.ones(n - 1, int), 3, np.full(n, 2)]
    return rows, cols


def test_banded_chain_equals_dense_and_solve_ivp_over_60_s_with_grades() -> None:
    """204 vehicles, 60 s, two grade changes crossed by ~100 vehicles each, an input
    changing every 2 s: banded = dense to rounding, both = solve_ivp (rtol 1e-9)."""
    train = HH204
    n = train.n_vehicles
    track = Track(sections=(
        TrackSection(start=0.0),
        TrackSection(start=1200.0, grade_permille=4.0),
        TrackSection(start=2000.0, grade_permille=-3.0),
    ))
    eq = equilibrium(train, 20.0, allocation="own")
    x0 = eq.state(position=1900.0)
    x0[:n] += 0.01 * np.sin(np.arange(n))
    banded = Plant(train=train, track=track)  # "auto": banded at 204 vehicles
    dense = Plant(train=train, track=track, propagation="dense")
    assert banded._banded and not dense._banded
    a = b = r = x0
    for k in range(30):
        u = eq.inputs + train.mass * 0.05 * np.sin(0.3 * k + np.arange(n) / 20.0)
        a = dense.advance(a, u, 2.0)
        b = banded.advance(b, u, 2.0)
        r = dense.advance_reference(r, u, 2.0, rtol=1e-9)
    assert b[-1] > 3000.0  # the head crossed both changes, the tail the first
    f = coupler_forces(train, r)
    # Measured: banded - dense 4.6e-12 m/s, 0.8 µN, 1.1e-10 m; both - solve_ivp
    # 7.8e-9 m/s, 32 mN of a 208 kN force range, 9e-10 m (the splitting error).
    assert np.abs(a[:n] - b[:n]).max() < 5e-11
    assert np.abs(coupler_forces(train, a) - coupler_forces(train, b)).max() < 1e-5
    assert abs(a[-1] - b[-1]) < 1e-9
    assert np.abs(r[:n] - b[:n]).max() < 3e-8
    assert np.abs(f - coupler_forces(train, b)).max() < 0.1
    assert abs(r[-1] - b[-1]) < 1e-8
    assert np.ptp(f) > 1e5


@pytest.mark.parametrize(("t", "vbar"), [(0.05, 20.0), (0.0125, 0.0), (0.5, 14.0)])
def test_band_truncation_honours_the_tolerance(t: float, vbar: float) -> None:
    """Entry by entry against the dense expm of the whole chain: every entry of the
    band within BAND_TOL of its block's largest (plus rounding), dropped entries below
    it; the lumped entries (a row's dropped sum on its own vehicle) within that sum."""
    plant = Plant(train=HH204)
    n = HH204.n_vehicles
    band = banded_flow(plant, t, vbar)
    # The reference: the whole chain as one balanced window, which is today's dense
    # expm (checked first) without its rounding floor (~2e-14 of the (delta, F) block).
    dense = _window_expm(plant, 0, n, t, vbar)
    today = augmented_expm(plant, t, vbar)[: 2 * n]
    assert np.abs(today - dense).max() < 1e-13 * np.abs(dense).max()
    got = band.flow.toarray()
    rkind, ckind = _kinds(n)
    stored = got != 0.0
    assert band.margin >= band.reach + 4 + band.reach // 4
    for r in range(3):
        for c in range(3):
            rows, cols = np.flatnonzero(rkind == r), np.flatnonzero(ckind == c)
            block = np.ix_(rows, cols)
            scale = np.abs(dense[block]).max()
            error = np.abs(got[block] - dense[block])
            kept = stored[block]
            # Dropped entries: the dense ones there are below the tolerance.
            assert np.abs(dense[block][~kept]).max() <= BAND_TOL * scale
            # Kept entries off the lump: rounding only (windows vs whole chain).
            vehicle = np.r_[np.arange(n), np.arange(n - 1), 0][rows]
            anchor = {0: vehicle, 1: np.minimum(vehicle, n - 2), 2: vehicle}[c]
            lump = np.zeros(kept.shape, bool)
            lump[np.arange(rows.size), anchor] = True
            assert error[kept & ~lump].max() <= 1e-14 * scale
            # Lumped entries: within the sum of what their row dropped in the block.
            dropped = np.where(kept, 0.0, np.abs(dense[block])).sum(axis=1)
            assert np.all(error[lump] <= dropped + 1e-14 * scale)
    # The s column is e_s, and a uniform speed is mapped as by the whole matrix.
    assert got[2 * n - 1, 2 * n - 1] == 1.0 and np.count_nonzero(got[:, 2 * n - 1]) == 1
    uniform = np.r_[np.ones(n), np.zeros(2 * n)]
    assert np.abs(got @ uniform - dense @ uniform).max() < 1e-14


def test_band_cost_is_linear_in_the_train_length() -> None:
    """The band stores the same entries per vehicle for 104 and 404 vehicles (±5%), and
    both chains need the same reach: the work per substep is O(n)."""
    short = Plant(train=heavy_haul_1p2p1(detail="full", wagons_per_group=50))
    long = Plant(train=heavy_haul_1p2p1(detail="full", wagons_per_group=200))
    a, b = banded_flow(short, 0.05, 20.0), banded_flow(long, 0.05, 20.0)
    assert a.reach == b.reach <= 14
    per_vehicle = [band.flow.nnz / plant.n_vehicles for band, plant in ((a, short), (b, long))]
    assert per_vehicle[1] == pytest.approx(per_vehicle[0], rel=0.05)
    assert per_vehicle[1] < 150


def test_crh2_is_dense_by_default_and_unchanged() -> None:
    """CRH2 (4 vehicles) stays on the dense path, bit for bit; forced banded, it agrees
    to ~1e-12 relative (the band is the whole chain there)."""
    train = crh2_half()
    track = Track(sections=tuple(
        TrackSection(start=200.0 * i, grade_permille=4.0 * (-1) ** i) for i in range(30)))
    eq = equilibrium(train, 60.0)
    x0 = eq.state(position=150.0)
    x0[:4] += [0.1, -0.05, 0.0, 0.02]
    u = eq.inputs + 2e4 * np.array([1.0, -1.0, 0.5, 0.0])
    auto, dense = Plant(train=train, track=track), Plant(train=train, track=track,
                                                         propagation="dense")
    banded = Plant(train=train, track=track, propagation="banded")
    assert not auto._banded
    a, d, b = (p.advance(x0, u, 20.0) for p in (auto, dense, banded))
    assert np.array_equal(a, d)
    assert np.abs(b[:4] - d[:4]).max() < 1e-12 * 60.0
    forces = coupler_forces(train, d)
    assert np.abs(coupler_forces(train, b) - forces).max() < 1e-12 * np.abs(forces).max() + 1e-6


def test_dense_output_and_virtual_links_on_the_banded_path() -> None:
    """advance_dense (boundaries and inner points, crossings inside substeps) and a
    formation of virtual links give the same states banded as dense."""
    track = Track(sections=(TrackSection(start=0.0), TrackSection(start=1000.0,
                                                                  grade_permille=-6.0)))
    for train in (heavy_haul_1p2p1(detail="full", wagons_per_group=20),
                  virtual_formation(n_trains=3)):
        n = train.n_vehicles
        x0 = np.r_[np.linspace(20.0, 20.5, n), np.zeros(n - 1), 1005.0]
        u = train.mass * np.linspace(0.05, -0.05, n)
        plants = [Plant(train=train, track=track, propagation=m) for m in ("dense", "banded")]
        for every, inner in ((3, 1), (1, 3)):
            (ta, xa), (tb, xb) = (p.advance_dense(x0, u, 1.0, every=every, inner=inner)
                                  for p in plants)
            assert np.array_equal(ta, tb)
            assert np.abs(xa[:n] - xb[:n]).max() < 1e-11
            assert np.abs(xa[n:] - xb[n:]).max() < 1e-11
            assert np.array_equal(xb[:, -1], plants[1].advance(x0, u, 1.0))


def test_banded_ladder_levels_are_the_flows_over_halved_steps() -> None:
    """The ladder on the banded path (inner points of the dense output): level j is the
    flow over h/2^j, and the step is level 0 without its s column."""
    track = Track(sections=(TrackSection(start=0.0), TrackSection(start=50.0)))
    train = heavy_haul_1p2p1(detail="full", wagons_per_group=20)
    plant = Plant(train=train, track=track, propagation="banded")
    n = train.n_vehicles
    levels = ladder(plant, 0.05, 8.0)
    for j, level in enumerate(levels):
        dense = augmented_expm(plant, 0.05 / 2**j, 8.0)[: 2 * n]
        assert np.abs(level.toarray() - dense).max() < 1e-12 * np.abs(dense).max()
    step = propagator(plant, 0.05, 8.0).step.toarray()
    top = np.delete(levels[0].toarray(), 2 * n - 1, axis=1)
    assert np.abs(step - top).max() < 1e-14 * np.abs(top).max()


def test_propagation_is_validated_and_auto_switches_by_length() -> None:
    with pytest.raises(ModelError, match="propagation"):
        Plant(train=crh2_half(), propagation="sparse")
    below, above = (Train(vehicles=HH204.vehicles[:k], couplers=HH204.couplers[: k - 1])
                    for k in (BANDED_MIN_VEHICLES - 1, BANDED_MIN_VEHICLES))
    assert below.n_vehicles < BANDED_MIN_VEHICLES <= above.n_vehicles
    assert not Plant(train=below)._banded and Plant(train=above)._banded
    assert not Plant(train=above, propagation="dense")._banded


@pytest.mark.parametrize("n_vehicles", [1, 2])
def test_banded_path_on_the_shortest_trains(n_vehicles: int) -> None:
    """One and two vehicles, forced banded (one window, no or one coupler), on a grade."""
    base = crh2_half()
    train = Train(vehicles=base.vehicles[:n_vehicles], couplers=base.couplers[: n_vehicles - 1])
    track = Track(sections=(TrackSection(start=0.0), TrackSection(start=30.0,
                                                                  grade_permille=-8.0)))
    x0 = np.r_[np.linspace(20.0, 21.0, n_vehicles), np.zeros(n_vehicles - 1), 0.0]
    u = train.mass * np.linspace(0.05, -0.05, n_vehicles)
    a, b = (Plant(train=train, track=track, propagation=m).advance(x0, u, 5.0)
            for m in ("dense", "banded"))
    assert a[-1] > 100.0
    # Measured: 1.6e-12 m/s and 4e-12 m (one vehicle; the balanced expm rounds
    # differently, and the crossing of the grade change passes that on).
    assert np.abs(a[:n_vehicles] - b[:n_vehicles]).max() < 1e-11
    assert np.abs(a - b).max() < 1e-10


def test_graded_run_equals_the_previous_crossing_code() -> None:
    """204 vehicles, 60 s at T = 1 s on the benchmark's track (a grade change every
    2 km; ~120 vehicle crossings of two boundaries) under the benchmark's kind of speed
    law: the crossing handling made cheap (signed section budgets, scalar Hermite
    seeds, stacked window flows, Newton continued by Taylor steps) gives the result
    of the code before it, recorded below (measured: bit for bit, single-threaded
    BLAS), and equals the dense path."""
    train = HH204
    n = train.n_vehicles
    track = Track(sections=tuple(
        TrackSection(start=2000.0 * i, grade_permille=3.0 * (-1) ** i) for i in range(60)))
    eq = equilibrium(train, 15.0, allocation="own")
    x0 = eq.state(position=4050.0)
    x0[:n] += 0.01 * np.sin(np.arange(n))
    a0, a1, a2 = train.davis
    plants = {mode: Plant(train=train, track=track, propagation=mode)
              for mode in ("banded", "dense")}
    out = {}
    for mode, plant in plants.items():
        x = x0
        for k in range(60):
            v = x[:n]
            u = train.mass * (a0 + a1 * v + a2 * v * v + 0.05 * (15.0 + k / 6.0 - v))
            x = plant.advance(x, u, 1.0)
        out[mode] = x
    b = out["banded"]
    # The previous implementation (commit d0f39e5), banded path.
    speeds = {0: 22.02209079669137, 37: 22.019456515892244, 101: 21.992872331864525,
              150: 22.00084311041917, 203: 22.00194149712087}
    elongations = {0: -0.0002644241641729553, 60: -0.008336349233901613,
                   120: -0.008499624314799269, 202: -0.00018061696392323982}
    for i, v in speeds.items():
        assert abs(b[i] - v) < 1e-10
    for i, d in elongations.items():
        assert abs(b[n + i] - d) < 1e-12
    assert abs(b[-1] - 5124.460442587459) < 1e-9
    # Measured: 3.9e-12 m/s, 9e-11 m from the dense path.
    assert np.abs(out["dense"][:n] - b[:n]).max() < 1e-10
    assert abs(out["dense"][-1] - b[-1]) < 1e-9
