# Train models: parameters, nonlinear dynamics, linearisation, subsystems.
"""Train models in SI units (python-control systems with named signals)."""

from typing import TYPE_CHECKING

from trainctl import _lazy_exports

if TYPE_CHECKING:
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
    from trainctl.models.lines import LINES as LINES
    from trainctl.models.lines import Line as Line
    from trainctl.models.lines import builtin_line as builtin_line
    from trainctl.models.lines import read_line as read_line
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
    from trainctl.models.track import SpeedLimit as SpeedLimit
    from trainctl.models.track import Track as Track
    from trainctl.models.track import TrackSection as TrackSection
    from trainctl.models.train import Train as Train
    from trainctl.models.vehicle import Coupler as Coupler
    from trainctl.models.vehicle import TractionEnvelope as TractionEnvelope
    from trainctl.models.vehicle import Vehicle as Vehicle

__all__ = [
    "ALLOCATIONS", "DISCRETISATIONS", "LINEARISATIONS", "LINES", "PRESETS",
    "ActuatorLimits", "Chain", "CoachSubsystems", "Coupler", "Equilibrium", "ForceSplit", "Line",
    "Neighbourhood", "Plant", "QuasiStaticForces", "SpeedLimit", "Track", "TrackSection",
    "TractionEnvelope", "Train", "Vehicle",
    "builtin_line", "coach_subsystems", "coupler_forces", "crh2_8car", "crh2_half", "discretise",
    "equilibrium", "heavy_haul_1p2p1", "linear_matrices", "linearise", "neighbourhood",
    "neighbourhoods", "nonlinear_system", "read_line", "resistance_damping", "train_rhs",
    "virtual_formation",
]

_EXPORTS = {
    "ActuatorLimits": "trainctl.models.actuator",
    "Chain": "trainctl.models.chain",
    "DISCRETISATIONS": "trainctl.models.discrete",
    "discretise": "trainctl.models.discrete",
    "Equilibrium": "trainctl.models.dynamics",
    "coupler_forces": "trainctl.models.dynamics",
    "equilibrium": "trainctl.models.dynamics",
    "nonlinear_system": "trainctl.models.dynamics",
    "train_rhs": "trainctl.models.dynamics",
    "ALLOCATIONS": "trainctl.models.feedforward",
    "ForceSplit": "trainctl.models.feedforward",
    "QuasiStaticForces": "trainctl.models.feedforward",
    "LINEARISATIONS": "trainctl.models.linear",
    "linear_matrices": "trainctl.models.linear",
    "linearise": "trainctl.models.linear",
    "resistance_damping": "trainctl.models.linear",
    "Plant": "trainctl.models.plant",
    "PRESETS": "trainctl.models.presets",
    "crh2_8car": "trainctl.models.presets",
    "crh2_half": "trainctl.models.presets",
    "heavy_haul_1p2p1": "trainctl.models.presets",
    "virtual_formation": "trainctl.models.presets",
    "CoachSubsystems": "trainctl.models.subsystems",
    "Neighbourhood": "trainctl.models.subsystems",
    "coach_subsystems": "trainctl.models.subsystems",
    "neighbourhood": "trainctl.models.subsystems",
    "neighbourhoods": "trainctl.models.subsystems",
    "LINES": "trainctl.models.lines",
    "Line": "trainctl.models.lines",
    "builtin_line": "trainctl.models.lines",
    "read_line": "trainctl.models.lines",
    "SpeedLimit": "trainctl.models.track",
    "Track": "trainctl.models.track",
    "TrackSection": "trainctl.models.track",
    "Train": "trainctl.models.train",
    "Coupler": "trainctl.models.vehicle",
    "TractionEnvelope": "trainctl.models.vehicle",
    "Vehicle": "trainctl.models.vehicle",
}
"""Re-exported name -> its module, imported on first use (:func:`trainctl._lazy_exports`)."""

__getattr__, __dir__ = _lazy_exports(__name__, _EXPORTS)
