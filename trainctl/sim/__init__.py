# Closed-loop simulation: plant integrator, references, loop, results, metrics.
"""Closed-loop simulation of trainctl controllers on the nonlinear train.

:class:`Plant` integrates the nonlinear train between samples (exponential
splitting, exact for the stiff couplers); :class:`SpeedProfile` gives the
reference; :func:`simulate` runs any :class:`~trainctl.controllers.base.Controller`
in closed loop and returns a :class:`SimulationResult` (save/load, pandas,
python-control and matplotlib views); :func:`compute_metrics` summarises it
and :func:`energy_account` balances its energy; :func:`limited_profile` plans a
reference under a line's speed limits; :mod:`trainctl.sim.capacity` gives a
line's braking distances, headways and throughput.
The loop saturates every controller's forces to the vehicles' envelopes and
records the plant between the samples on a dense grid (:func:`dense_grid`
gives its rule).
Importing this package loads neither pandas nor :mod:`trainctl.plots.time`; they are
imported when a view needs them.
"""

from trainctl.models.plant import Plant as Plant
from trainctl.sim._log import DENSE_PHASE_STEP as DENSE_PHASE_STEP
from trainctl.sim._log import MAX_DENSE_POINTS as MAX_DENSE_POINTS
from trainctl.sim._log import MAX_DENSE_VALUES as MAX_DENSE_VALUES
from trainctl.sim._log import dense_grid as dense_grid
from trainctl.sim.closed_loop import DIVERGENCE_SPEED_ERROR as DIVERGENCE_SPEED_ERROR
from trainctl.sim.closed_loop import HOLD_FALLBACK as HOLD_FALLBACK
from trainctl.sim.closed_loop import simulate as simulate
from trainctl.sim.energy import EnergyAccount as EnergyAccount
from trainctl.sim.energy import energy_account as energy_account
from trainctl.sim.metrics import Metrics as Metrics
from trainctl.sim.metrics import compute_metrics as compute_metrics
from trainctl.sim.planner import braking_deceleration as braking_deceleration
from trainctl.sim.planner import limited_profile as limited_profile
from trainctl.sim.reference import Reference as Reference
from trainctl.sim.reference import SpeedProfile as SpeedProfile
from trainctl.sim.reference import ramp_profile as ramp_profile
from trainctl.sim.results import SimulationResult as SimulationResult
from trainctl.sim.results import environment as environment

__all__ = [
    "DENSE_PHASE_STEP", "DIVERGENCE_SPEED_ERROR", "HOLD_FALLBACK", "MAX_DENSE_POINTS",
    "MAX_DENSE_VALUES", "EnergyAccount", "Metrics", "Plant", "Reference", "SimulationResult",
    "SpeedProfile", "braking_deceleration", "compute_metrics", "dense_grid", "energy_account",
    "environment", "limited_profile", "ramp_profile", "simulate",
]
