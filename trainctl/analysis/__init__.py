# Analysis of train models: modes, stability, controllability, sampling, DMPC.
"""Analysis layer: each check is a public function returning a frozen result."""

from .controllability import ControllabilityResult as ControllabilityResult
from .controllability import ObservabilityResult as ObservabilityResult
from .controllability import analyse_controllability as analyse_controllability
from .controllability import analyse_observability as analyse_observability
from .controllability import finite_horizon_gramian as finite_horizon_gramian
from .dmpc import DMPCAnalysis as DMPCAnalysis
from .dmpc import analyse_dmpc as analyse_dmpc
from .feasibility import RouteForces as RouteForces
from .feasibility import feasibility_check as feasibility_check
from .feasibility import route_forces as route_forces
from .frequency import FrequencyResult as FrequencyResult
from .frequency import analyse_frequency as analyse_frequency
from .iteration import convergence_sweep as convergence_sweep
from .loops import ClosedLoopResponse as ClosedLoopResponse
from .loops import analyse_closed_loops as analyse_closed_loops
from .modes import Mode as Mode
from .modes import continuous_modes as continuous_modes
from .modes import nyquist_sample_time as nyquist_sample_time
from .mpc import MPCDesign as MPCDesign
from .mpc import prediction as prediction
from .plausibility import plausibility_check as plausibility_check
from .review import Check as Check
from .review import DesignReview as DesignReview
from .review import model_checks as model_checks
from .review import review_design as review_design
from .review import scenario_checks as scenario_checks
from .sampling import SamplingResult as SamplingResult
from .sampling import analyse_sampling as analyse_sampling
from .sensitivity import bandwidth as bandwidth
from .sensitivity import loop_sensitivity as loop_sensitivity
from .stability import StabilityResult as StabilityResult
from .stability import analyse_stability as analyse_stability
from .steps import StepResult as StepResult
from .steps import analyse_grade_step as analyse_grade_step
from .string_stability import StringStabilityResult as StringStabilityResult
from .string_stability import string_stability as string_stability
from .summary import ModelSummary as ModelSummary
from .summary import model_summary as model_summary

__all__ = [
    "Check", "ClosedLoopResponse", "ControllabilityResult", "DMPCAnalysis", "DesignReview",
    "FrequencyResult", "MPCDesign", "Mode", "ModelSummary", "ObservabilityResult", "RouteForces",
    "SamplingResult", "StabilityResult", "StepResult", "StringStabilityResult",
    "analyse_closed_loops",
    "analyse_controllability", "analyse_dmpc", "analyse_frequency", "analyse_grade_step",
    "analyse_observability", "analyse_sampling", "analyse_stability", "bandwidth",
    "continuous_modes", "convergence_sweep", "feasibility_check", "finite_horizon_gramian",
    "loop_sensitivity", "model_checks", "model_summary", "nyquist_sample_time",
    "plausibility_check", "prediction", "review_design", "route_forces", "scenario_checks",
    "string_stability",
]
