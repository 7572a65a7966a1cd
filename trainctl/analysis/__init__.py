# Analysis of train models: modes, sampling, and (later) design checks.
"""Analysis layer: modal analysis and model summaries."""

from .modes import Mode as Mode
from .modes import continuous_modes as continuous_modes
from .modes import nyquist_sample_time as nyquist_sample_time
from .summary import ModelSummary as ModelSummary
from .summary import model_summary as model_summary

__all__ = ["Mode", "ModelSummary", "continuous_modes", "model_summary", "nyquist_sample_time"]
