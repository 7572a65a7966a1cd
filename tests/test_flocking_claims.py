"""Seed 002's claims table (:mod:`trainctl.controllers.flocking.claims`).

The quasi-static energy and forces are checked against the textbook by hand
(constant speed on a constant grade; two units on different grades); the
claims of the built-in line study against the capacity formulas worked out
here, and the simulated formation's energy (the plant's exact energy account)
against the quasi-static energy of its units alone, an independent route.
"""

from __future__ import annotations

import numpy as np
import pytest

from trainctl.controllers.flocking.claims import combined_train, reference_energy
from trainctl.models.track import Track, TrackSection
from trainctl.models.train import Train
from trainctl.models.vehicle import Coupler, Vehicle
from trainctl.scenario import SimulationSettings, load_scenario
from trainctl.units import GRAVITY

UNIT = Vehicle(mass=6.0e6, a0=0.01, a1=2e-4, a2=1.5e-5, length=740.0, traction_share=1.0,
               name="unit")


def _sim(speed: float, duration: float, regen: float = 1.0) -> SimulationSettings:
    return SimulationSettings(duration=duration, strategies=("flocking",), reference_times=(0.0,),
                              reference_speeds=(speed,), regen_efficiency=regen)


def test_constant_speed_on_a_constant_grade_is_the_textbook_energy() -> None:
    one = Train(vehicles=(UNIT,), couplers=())
    v, T = 20.0, 100.0
    up = reference_energy(one, Track(sections=(TrackSection(start=0.0, grade_permille=5.0),)),
                          _sim(v, T))
    # W = m (a0 + a1 v + a2 v² + g i) · v T: 6e6 · (0.01 + 0.004 + 0.006 + 0.04905) · 2000 m
    need = UNIT.mass * (0.01 + 2e-4 * v + 1.5e-5 * v * v + GRAVITY * 5e-3)
    assert up["traction"] == pytest.approx(need * v * T, rel=1e-12)
    assert up["braking"] == 0.0
    assert up["per_tonne_km"] == pytest.approx(need * v * T / 3600 / (6000 * 2.0), rel=1e-12)
    down = reference_energy(one, Track(sections=(TrackSection(start=0.0,
                                                              grade_permille=-20.0),)),
                            _sim(v, T, regen=0.5))
    brake = -UNIT.mass * (0.01 + 2e-4 * v + 1.5e-5 * v * v - GRAVITY * 20e-3)
    assert down["traction"] == 0.0 and down["braking"] == pytest.approx(brake * v * T, rel=1e-12)
    assert down["net"] == pytest.approx(-0.5 * brake * v * T, rel=1e-12)


def test_two_coupled_units_on_two_grades_share_the_difference() -> None:
    pair = Train(vehicles=(UNIT, UNIT), couplers=(Coupler(stiffness=0.0, virtual=True,
                                                          spacing=1000.0),))
    one = combined_train(pair)
    assert not one.virtual.any() and one.spacing.tolist() == [740.0]
    track = Track(sections=(TrackSection(start=0.0), TrackSection(start=2000.0,
                                                                  grade_permille=10.0)))
    # head at 2500 m (on 10 ‰), the second unit's centre 740 m behind (on 0 ‰) for 10 s at
    # 20 m/s: each unit gives half the total, so the coupler passes half the difference
    # of their needs, m g (10 ‰) / 2
    found = reference_energy(one, track, _sim(20.0, 10.0), start=2500.0)
    assert found["max_coupler_force"] == pytest.approx(UNIT.mass * GRAVITY * 0.01 / 2,
                                                       rel=1e-12)


@pytest.fixture(scope="module")
def line_run():
    from trainctl.run import run_scenario

    return run_scenario(load_scenario("heavy-haul-flocking-line"))


def test_the_line_study_decides_every_claim(line_run) -> None:
    claims = {c.key: c for c in line_run.claims}
    assert list(claims) == ["spacing", "speed", "efficiency", "energy", "operating_cost",
                            "in_train_forces"]
    assert claims["spacing"].kind == claims["speed"].kind == "reproduced"
    # capacity at 80 km/h: units of 740 m, 6000 t, braking 2400 kN / 6000 t = 0.4 m/s²
    v = 80 / 3.6
    braking = v * v / (2 * 0.4)
    tph = {"b": 6000 * 3600 * v / (740 + 500), "c": 6000 * 3600 * v / (740 + braking),
           "a": 4 * 6000 * 3600 * v / (4 * 740 + braking)}
    text = claims["efficiency"].trainctl
    for key, value in tph.items():
        assert f"({key}) {value:,.0f} t/h" in text
    assert claims["efficiency"].kind == "reproduced"  # 500 m < 617 m of braking
    assert claims["in_train_forces"].kind == "reproduced"


def test_the_simulated_energy_equals_the_units_quasi_static_energy(line_run) -> None:
    """The plant's energy account of the flocking run against each unit following the
    reference alone at its place in the formation: the formation tracks within 0.2 m/s,
    so the two agree to its transients; coupled, the units need less (a braking unit
    pushes a climbing one)."""
    scenario = line_run.scenario
    train, sim = scenario.train, scenario.simulation
    account = line_run.metrics["flocking"].energy_account
    simulated = account.energy_per_tonne_km / 3600.0  # Wh/(t·km)
    offsets = np.concatenate([[0.0], np.cumsum(train.spacing)])
    each = [reference_energy(Train(vehicles=(v,), couplers=()), scenario.track, sim,
                             start=-float(o)) for v, o in zip(train.vehicles, offsets, strict=True)]
    alone = sum(e["net"] for e in each) / 3600.0 / sum(e["tonne_km"] for e in each)
    assert simulated == pytest.approx(alone, rel=5e-3)
    whole = reference_energy(combined_train(train), scenario.track, sim)
    assert whole["per_tonne_km"] < 0.97 * alone


def test_the_simulated_headway_is_the_lattice_s(line_run) -> None:
    """The units of the flocking run pass a point (L + d) / v apart: the formation holds
    its gaps within a few metres at 80 km/h."""
    note = {c.key: c for c in line_run.claims}["efficiency"].note
    simulated = float(note.split(" every ")[1].split(" s ")[0])
    assert simulated == pytest.approx((740 + 500) / (80 / 3.6), rel=2e-3)
