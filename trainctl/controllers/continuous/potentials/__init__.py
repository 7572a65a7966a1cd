# Pair potentials shared by the flocking (seed 002) and potential-gradient (seed 001) controllers.
"""Potential functions of the distributed train controllers.

Two families of controllers use a pairwise potential between neighbouring
trains (or cars):

* seed 002 (virtual coupling of heavy-haul trains) uses the flocking
  primitives of Olfati-Saber, R. (2006), "Flocking for multi-agent dynamic
  systems: algorithms and theory", IEEE Trans. Automatic Control 51(3),
  pp. 401-420: the sigma-norm, the bump function rho_h, the action function
  phi_alpha and the pairwise potential psi_alpha. :class:`FlockingPotential`
  applies them to the *gap* between two trains (tail-to-head distance, not
  the centre distance, so that a zero gap is a collision), with distances
  normalised by a length scale and the action scaled to a physical specific
  force;
* seed 001 (high-speed train cars) uses ``u_4i = -m_i sum_j grad U_ij`` with a
  potential on the spacing deviation: :class:`QuadraticPotential`,
  :class:`BarrierPotential` and :class:`SigmaNormPotential` (the flocking
  potential seen as a function of the deviation from the desired gap).

Sign conventions (spec §5 item 8). For a pair, the *front* train j leads the
*rear* (follower) train i; the gap is ``s = x_j - x_i - L_j`` [m] (L_j the
length of the front train) and the spacing deviation is ``z = s - d`` [m]
(positive: farther apart than desired, an elongation). Every potential here
is per unit mass [m²/s²]: a potential ``U(s)`` gives the rear train the
specific force ``-dU/dx_i = +dU/ds`` [m/s²] and the front train
``-dU/dx_j = -dU/ds``. So a follower that is too far behind is pulled
forward, a follower that is too close is pushed back (and its leader pushed
forward).

The primitives act elementwise on arrays (each entry is a scalar distance on
a line of trains, so ``||z|| = |z|``); a scalar argument gives a float.

The primitives are in :mod:`~trainctl.controllers.continuous.potentials.sigma`, the
flocking potential in :mod:`~trainctl.controllers.continuous.potentials.flocking` and the
spacing-deviation potentials in :mod:`~trainctl.controllers.continuous.potentials.spacing`;
every public name is importable from here.
"""

from __future__ import annotations

from trainctl.controllers.continuous.potentials.flocking import (
    CollisionBound as CollisionBound,
)
from trainctl.controllers.continuous.potentials.flocking import (
    FlockingPotential as FlockingPotential,
)
from trainctl.controllers.continuous.potentials.sigma import Floats as Floats
from trainctl.controllers.continuous.potentials.sigma import bump as bump
from trainctl.controllers.continuous.potentials.sigma import phi as phi
from trainctl.controllers.continuous.potentials.sigma import phi_alpha as phi_alpha
from trainctl.controllers.continuous.potentials.sigma import psi_alpha as psi_alpha
from trainctl.controllers.continuous.potentials.sigma import sigma1 as sigma1
from trainctl.controllers.continuous.potentials.sigma import sigma_grad as sigma_grad
from trainctl.controllers.continuous.potentials.sigma import sigma_norm as sigma_norm
from trainctl.controllers.continuous.potentials.spacing import (
    BarrierPotential as BarrierPotential,
)
from trainctl.controllers.continuous.potentials.spacing import PairPotential as PairPotential
from trainctl.controllers.continuous.potentials.spacing import (
    QuadraticPotential as QuadraticPotential,
)
from trainctl.controllers.continuous.potentials.spacing import (
    SigmaNormPotential as SigmaNormPotential,
)

__all__ = [
    "BarrierPotential",
    "CollisionBound",
    "FlockingPotential",
    "PairPotential",
    "QuadraticPotential",
    "SigmaNormPotential",
    "bump",
    "phi",
    "phi_alpha",
    "psi_alpha",
    "sigma1",
    "sigma_grad",
    "sigma_norm",
]
