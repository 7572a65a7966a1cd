# The potential-function consensus controller: Zhao & Wang's law sampled at its control interval.
"""The potential controller: u = ū(v_r, a_r) + û(x̂, v̂, z), clipped to the envelope.

The law (:mod:`trainctl.controllers.potential.law`) is continuous in time;
the simulation calls :meth:`PotentialController.step` every ``dt`` (the
family's ``control_interval``) and holds the force until the next call.

The reference position x̄_0(t) starts at the head's measured position at the
first step after :meth:`~PotentialController.reset` and follows the reference
speed (:class:`~trainctl.controllers.reference.ReferencePosition`, with its
accuracy at the reference's breakpoints).

Faults (:mod:`trainctl.controllers.faults`): a state that is not finite, a
law that raises, or a force that is not finite (a spacing deviation left the
potential's domain) gives the status ``"error"`` with the reason in
``info["reason"]`` and the cruise feedforward (fallback ``"feedforward"``),
clipped to the envelope at the measured speeds (at the reference speed when
they are not finite).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.controller import SampledLawController
from trainctl.controllers.potential.law import PotentialLaw

__all__ = ["PotentialController"]

Array = NDArray[np.float64]


class PotentialController(SampledLawController[PotentialLaw]):
    """Zhao & Wang's four-term law about the cruise feedforward (module docstring).

    Parameters
    ----------
    train : Train
        The train (feedforward, envelopes).
    law : PotentialLaw
        Gains and pair potential.
    dt : float
        Control interval [s], > 0.
    input_bounds : bool
        Clip each force to the vehicle's envelope at its measured speed.
    name : str or None
        Label; None: ``"consensus"``.

    Examples
    --------
    >>> from trainctl.controllers.base import Measurement, ReferencePreview
    >>> from trainctl.controllers.continuous.potentials import QuadraticPotential
    >>> from trainctl.models import crh2_half, equilibrium
    >>> train = crh2_half()
    >>> law = PotentialLaw(mass=train.mass, pinning=np.zeros(4), speed_gain=0.5,
    ...                    consensus=np.zeros((4, 4)), potential=QuadraticPotential(0.5))
    >>> ctl = PotentialController(train, law, dt=0.01)
    >>> eq = equilibrium(train, 80.0)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 80.0),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> bool(np.allclose(rec.inputs, eq.inputs)), rec.status
    (True, 'optimal')
    """

    default_name = "consensus"
    vehicles = ("cars", "train")

    def _deviations(self, links: Array, elongations: Array) -> Array:
        """z = δ − δ̄: the elongations less the feedforward's quasi-static ones [m]."""
        z: NDArray[np.float64] = links - elongations
        return z

    def _force_fault(self, z: Array) -> str:
        return ("a spacing deviation left the potential's domain "
                f"(max |z| = {float(np.max(np.abs(z))):.4g} m)")

