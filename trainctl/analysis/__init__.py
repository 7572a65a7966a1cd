# Analysis of linear models and loops: modes, stability, controllability, sampling, norms.
"""Analysis layer: each check is a public function returning a frozen result.

The generic analyses of linear models and closed loops live here. Names that
moved to their stage or family stay importable from this package (the README's
``from trainctl.analysis import review_design``) and are documented at their home:
the design review in :mod:`trainctl.design.review`, the MPC theory in
:mod:`trainctl.controllers.mpc.theory`.
"""

from typing import TYPE_CHECKING

from trainctl import _lazy_exports

if TYPE_CHECKING:
    from trainctl.analysis.check import Check as Check
    from trainctl.analysis.check import DesignReview as DesignReview
    from trainctl.analysis.controllability import ControllabilityResult as ControllabilityResult
    from trainctl.analysis.controllability import ObservabilityResult as ObservabilityResult
    from trainctl.analysis.controllability import analyse_controllability as analyse_controllability
    from trainctl.analysis.controllability import analyse_observability as analyse_observability
    from trainctl.analysis.controllability import finite_horizon_gramian as finite_horizon_gramian
    from trainctl.analysis.feasibility import RouteForces as RouteForces
    from trainctl.analysis.feasibility import feasibility_check as feasibility_check
    from trainctl.analysis.feasibility import route_forces as route_forces
    from trainctl.analysis.frequency import FrequencyResult as FrequencyResult
    from trainctl.analysis.frequency import analyse_frequency as analyse_frequency
    from trainctl.analysis.loops import ClosedLoopResponse as ClosedLoopResponse
    from trainctl.analysis.loops import analyse_closed_loops as analyse_closed_loops
    from trainctl.analysis.modes import Mode as Mode
    from trainctl.analysis.modes import continuous_modes as continuous_modes
    from trainctl.analysis.modes import nyquist_sample_time as nyquist_sample_time
    from trainctl.analysis.plausibility import plausibility_check as plausibility_check
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
    "Check", "ClosedLoopResponse", "ControllabilityResult", "DesignReview",
    "FrequencyResult", "Mode", "ModelSummary", "ObservabilityResult", "RouteForces",
    "SamplingResult", "StabilityResult", "StepResult", "StringStabilityResult",
    "analyse_closed_loops",
    "analyse_controllability", "analyse_frequency", "analyse_grade_step",
    "analyse_observability", "analyse_sampling", "analyse_stability", "bandwidth",
    "continuous_modes", "feasibility_check", "finite_horizon_gramian",
    "loop_sensitivity", "model_summary", "nyquist_sample_time",
    "plausibility_check", "route_forces",
    "string_stability",
]

_FROM_DESIGN = ("model_checks", "review_design", "scenario_checks")
"""Names that moved to :mod:`trainctl.design.review` (the design review)."""
_FROM_MPC = ("DMPCAnalysis", "MPCDesign", "analyse_dmpc", "convergence_sweep", "prediction")
"""Names that moved to :mod:`trainctl.controllers.mpc.theory` (the MPC family's theory)."""


_EXPORTS = {
    "Check": "trainctl.analysis.check",
    "DesignReview": "trainctl.analysis.check",
    "ControllabilityResult": "trainctl.analysis.controllability",
    "ObservabilityResult": "trainctl.analysis.controllability",
    "analyse_controllability": "trainctl.analysis.controllability",
    "analyse_observability": "trainctl.analysis.controllability",
    "finite_horizon_gramian": "trainctl.analysis.controllability",
    "RouteForces": "trainctl.analysis.feasibility",
    "feasibility_check": "trainctl.analysis.feasibility",
    "route_forces": "trainctl.analysis.feasibility",
    "FrequencyResult": "trainctl.analysis.frequency",
    "analyse_frequency": "trainctl.analysis.frequency",
    "ClosedLoopResponse": "trainctl.analysis.loops",
    "analyse_closed_loops": "trainctl.analysis.loops",
    "Mode": "trainctl.analysis.modes",
    "continuous_modes": "trainctl.analysis.modes",
    "nyquist_sample_time": "trainctl.analysis.modes",
    "plausibility_check": "trainctl.analysis.plausibility",
    "SamplingResult": "trainctl.analysis.sampling",
    "analyse_sampling": "trainctl.analysis.sampling",
    "bandwidth": "trainctl.analysis.sensitivity",
    "loop_sensitivity": "trainctl.analysis.sensitivity",
    "StabilityResult": "trainctl.analysis.stability",
    "analyse_stability": "trainctl.analysis.stability",
    "StepResult": "trainctl.analysis.steps",
    "analyse_grade_step": "trainctl.analysis.steps",
    "StringStabilityResult": "trainctl.analysis.string_stability",
    "string_stability": "trainctl.analysis.string_stability",
    "ModelSummary": "trainctl.analysis.summary",
    "model_summary": "trainctl.analysis.summary",
}
"""Re-exported name -> its module, imported on first use (:func:`trainctl._lazy_exports`)."""

_lazy_getattr, _lazy_dir = _lazy_exports(__name__, _EXPORTS)


def __getattr__(name: str) -> object:
    # Imported on first use only: this stage comes before the design stage and the
    # controllers (the contract in pyproject.toml names these two imports).
    if name in _FROM_DESIGN:
        from trainctl.design import review

        value = getattr(review, name)
    elif name in _FROM_MPC:
        from trainctl.controllers.mpc import theory

        value = getattr(theory, name)
    else:
        return _lazy_getattr(name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(_lazy_dir()) | set(_FROM_DESIGN) | set(_FROM_MPC))
