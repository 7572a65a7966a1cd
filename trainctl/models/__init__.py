# Train models: parameters, nonlinear dynamics, linearisation, subsystems.
"""Train models in SI units (python-control systems with named signals)."""

from .actuator import ActuatorLimits as ActuatorLimits
from .chain import Chain as Chain
from .discrete import DISCRETISATIONS as DISCRETISATIONS
from .discrete import discretise as discretise
from .dynamics import Equilibrium as Equilibrium
from .dynamics import coupler_forces as coupler_forces
from .dynamics import equilibrium as equilibrium
from .dynamics import nonlinear_system as nonlinear_system
from .dynamics import train_rhs as train_rhs
from .feedforward import ALLOCATIONS as ALLOCATIONS
from .feedforward import ForceSplit as ForceSplit
from .feedforward import QuasiStaticForces as QuasiStaticForces
from .linear import LINEARISATIONS as LINEARISATIONS
from .linear import linear_matrices as linear_matrices
from .linear import linearise as linearise
from .linear import resistance_damping as resistance_damping
from .plant import Plant as Plant
from .presets import PRESETS as PRESETS
from .presets import crh2_8car as crh2_8car
from .presets import crh2_half as crh2_half
from .presets import heavy_haul_1p2p1 as heavy_haul_1p2p1
from .presets import virtual_formation as virtual_formation
from .subsystems import CoachSubsystems as CoachSubsystems
from .subsystems import Neighbourhood as Neighbourhood
from .subsystems import coach_subsystems as coach_subsystems
from .subsystems import neighbourhood as neighbourhood
from .subsystems import neighbourhoods as neighbourhoods
from .track import Track as Track
from .track import TrackSection as TrackSection
from .train import Train as Train
from .vehicle import Coupler as Coupler
from .vehicle import TractionEnvelope as TractionEnvelope
from .vehicle import Vehicle as Vehicle

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
