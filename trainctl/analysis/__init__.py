# Analysis of train models: modes, stability, controllability, sampling, DMPC.
"""Analysis layer: each check is a public function returning a frozen result."""

from trainctl.analysis.controllability import ControllabilityResult as ControllabilityResult
from trainctl.analysis.controllability import ObservabilityResult as ObservabilityResult
from trainctl.analysis.controllability import analyse_controllability as analyse_controllability
from trainctl.analysis.controllability import analyse_observability as analyse_observability
from trainctl.analysis.controllability import finite_horizon_gramian as finite_horizon_gramian
from trainctl.analysis.dmpc import DMPCAnalysis as DMPCAnalysis
from trainctl.analysis.dmpc import analyse_dmpc as analyse_dmpc
from trainctl.analysis.feasibility import RouteForces as RouteForces
from trainctl.analysis.feasibility import feasibility_check as feasibility_check
from trainctl.analysis.feasibility import route_forces as route_forces
from trainctl.analysis.frequency import FrequencyResult as FrequencyResult
from trainctl.analysis.frequency import analyse_frequency as analyse_frequency
from trainctl.analysis.iteration import convergence_sweep as convergence_sweep
from trainctl.analysis.loops import ClosedLoopResponse as ClosedLoopResponse
from trainctl.analysis.loops import analyse_closed_loops as analyse_closed_loops
from trainctl.analysis.modes import Mode as Mode
from trainctl.analysis.modes import continuous_modes as continuous_modes
from trainctl.analysis.modes import nyquist_sample_time as nyquist_sample_time
from trainctl.analysis.mpc import MPCDesign as MPCDesign
from trainctl.analysis.mpc import prediction as prediction
from trainctl.analysis.plausibility import plausibility_check as plausibility_check
from trainctl.analysis.review import Check as Check
from trainctl.analysis.review import DesignReview as DesignReview
from trainctl.analysis.review import model_checks as model_checks
from trainctl.analysis.review import review_design as review_design
from trainctl.analysis.review import scenario_checks as scenario_checks
from trainctl.analysis.sampling import SamplingResult as SamplingResult
from trainctl.analysis.sampling import analyse_sampling as analyse_sampling
from trainctl.analysis.sensitivity import bandwidth as bandwidth
from trainctl.analysis.sensitivity import loop_sensitivity as loop_sensitivity
from trainctl.analysis.stability import StabilityResult as StabilityResult
from trainctl.analysis.stability import analyse_stability as analyse_stability
from trainctl.analysis.steps import StepResult as StepResult
from trainctl.analysis.steps import analyse_grade_step as analyse_grade_step
from trainctl.analysis.string_stability import StringStabilityResult as StringStabilityResult
from trainctl.analysis.string_stability import string_stability as string_stability
from trainctl.analysis.summary import ModelSummary as ModelSummary
from trainctl.analysis.summary import model_summary as model_summary

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
