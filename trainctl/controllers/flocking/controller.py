# The flocking controller: Olfati-Saber's law sampled at its control interval, clipped.
"""The flocking controller: u = ū(v_r, a_r) + m·a(v̂, z, x̂), clipped to the envelope.

The law (:mod:`trainctl.controllers.flocking.law`) is continuous in time; the
simulation calls :meth:`FlockingController.step` every ``dt`` (the family's
``control_interval``) and holds the force until the next call. The virtual
leader's position x̄_0(t) starts at the head's measured position at the
first step after :meth:`~FlockingController.reset` and follows the
reference speed (trapezoid between steps; exact on each linear piece of the
reference). Train i's slot is x̄_0 minus the nominal centre distances
ahead of it, so x̂_i = x̂_0 − Σ_{k<i} z_k.

Faults (:mod:`trainctl.controllers.faults`): a state that is not finite, two
trains that overlap, a law that raises or a force that is not finite gives
the status ``"error"`` with the reason in ``info["reason"]`` and the cruise
feedforward (fallback ``"feedforward"``), clipped to the envelope at the
measured speeds (at the reference speed when they are not finite).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.controller import SampledLawController
from trainctl.controllers.flocking.law import FlockingLaw

__all__ = ["FlockingController"]

Array = NDArray[np.float64]


class FlockingController(SampledLawController[FlockingLaw]):
    """Olfati-Saber's flocking law about the cruise feedforward (module docstring).

    Parameters
    ----------
    train : Train
        The formation: one vehicle per train, virtual links.
    law : FlockingLaw
        Gains and pair potential.
    dt : float
        Control interval [s], > 0.
    input_bounds : bool
        Clip each force to the train's envelope at its measured speed.
    name : str or None
        Label; None: ``"flocking"``.

    Examples
    --------
    >>> from trainctl.controllers.base import Measurement, ReferencePreview
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.law import law_of
    >>> from trainctl.models import equilibrium
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> law = law_of(scenario, scenario.controllers["flocking"])
    >>> ctl = FlockingController(scenario.train, law, dt=1.0)
    >>> eq = equilibrium(scenario.train, 22.0)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 22.0),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> bool(np.allclose(rec.inputs, eq.inputs)), rec.status
    (True, 'optimal')
    """

    default_name = "flocking"
    vehicles = ("trains", "formation")

    def _refuse(self, z: Array) -> tuple[str, dict[str, Any]]:
        """Two trains that overlap; the smallest gap [m] (``info["min_gap"]``)."""
        gaps = self.law.gaps(z)
        if np.any(gaps < 0.0):
            return f"two trains overlap (smallest gap {float(np.min(gaps)):.4g} m)", {}
        return "", {"min_gap": float(np.min(gaps))}
