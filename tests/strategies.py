"""Hypothesis strategies for trains."""

from __future__ import annotations

from hypothesis import strategies as st

from trainctl.models import Coupler, TractionEnvelope, Train, Vehicle


@st.composite
def vehicles(draw: st.DrawFn) -> Vehicle:
    """Draws a vehicle of 10–200 t with positive Davis damping and some traction share."""
    return Vehicle(
        mass=draw(st.floats(1e4, 2e5)),
        a0=draw(st.floats(0.0, 0.02)),
        a1=draw(st.floats(1e-5, 1e-3)),
        a2=draw(st.floats(1e-6, 5e-5)),
        traction_share=draw(st.sampled_from([0.0, 1.0, 0.5])),
        envelope=TractionEnvelope(),
    )


@st.composite
def trains(draw: st.DrawFn, min_vehicles: int = 2, max_vehicles: int = 50) -> Train:
    """Draws a physically coupled train of 2–50 vehicles, at least one with traction."""
    n = draw(st.integers(min_vehicles, max_vehicles))
    cars = [draw(vehicles()) for _ in range(n)]
    if all(c.traction_share == 0 for c in cars):
        cars[0] = Vehicle(mass=cars[0].mass, a0=cars[0].a0, a1=cars[0].a1, a2=cars[0].a2)
    couplers = [
        Coupler(stiffness=draw(st.floats(1e6, 5e7)), damping=draw(st.floats(0.0, 1e5)))
        for _ in range(n - 1)
    ]
    return Train(vehicles=tuple(cars), couplers=tuple(couplers))
