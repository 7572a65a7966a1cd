# Train models: parameters, nonlinear dynamics, linearisation, subsystems.
"""Train models in SI units (python-control systems with named signals)."""

from trainctl.models.actuator import ActuatorLimits as ActuatorLimits
from trainctl.models.chain import Chain as Chain
from trainctl.models.discrete import DISCRETISATIONS as DISCRETISATIONS
from trainctl.models.discrete import discretise as discretise
from trainctl.models.dynamics import Equilibrium as Equilibrium
from trainctl.models.dynamics import coupler_forces as coupler_forces
from trainctl.models.dynamics import equilibrium as equilibrium
from trainctl.models.dynamics import nonlinear_system as nonlinear_system
from trainctl.models.dynamics import train_rhs as train_rhs
from trainctl.models.feedforward import ALLOCATIONS as ALLOCATIONS
from trainctl.models.feedforward import ForceSplit as ForceSplit
from trainctl.models.feedforward import QuasiStaticForces as QuasiStaticForces
from trainctl.models.linear import LINEARISATIONS as LINEARISATIONS
from trainctl.models.linear import linear_matrices as linear_matrices
from trainctl.models.linear import linearise as linearise
from trainctl.models.linear import resistance_damping as resistance_damping
from trainctl.models.plant import Plant as Plant
from trainctl.models.presets import PRESETS as PRESETS
from trainctl.models.presets import crh2_8car as crh2_8car
from trainctl.models.presets import crh2_half as crh2_half
from trainctl.models.presets import heavy_haul_1p2p1 as heavy_haul_1p2p1
from trainctl.models.presets import virtual_formation as virtual_formation
from trainctl.models.subsystems import CoachSubsystems as CoachSubsystems
from trainctl.models.subsystems import Neighbourhood as Neighbourhood
from trainctl.models.subsystems import coach_subsystems as coach_subsystems
from trainctl.models.subsystems import neighbourhood as neighbourhood
from trainctl.models.subsystems import neighbourhoods as neighbourhoods
from trainctl.models.track import Track as Track
from trainctl.models.track import TrackSection as TrackSection
from trainctl.models.train import Train as Train
from trainctl.models.vehicle import Coupler as Coupler
from trainctl.models.vehicle import TractionEnvelope as TractionEnvelope
from trainctl.models.vehicle import Vehicle as Vehicle

__all__ = [
    "ALLOCATIONS", "DISCRETISATIONS", "LINEARISATIONS", "PRESETS",
    "ActuatorLimits", "Chain", "CoachSubsystems", "Coupler", "Equilibrium", "ForceSplit",
    "Neighbourhood", "Plant", "QuasiStaticForces", "Track", "TrackSection", "TractionEnvelope",
    "Train", "Vehicle",
    "coach_subsystems", "coupler_forces", "crh2_8car", "crh2_half", "discretise",
    "equilibrium", "heavy_haul_1p2p1", "linear_matrices", "linearise", "neighbourhood",
    "neighbourhoods", "nonlinear_system", "resistance_damping", "train_rhs",
    "virtual_formation",
]
