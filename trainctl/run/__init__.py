# The run stage: everything `trainctl analyse` computes, repetitions, budgets, pools.
"""The run stage.

:func:`run_scenario` builds a scenario's design, reviews it and simulates its
strategies (:mod:`~trainctl.run.analysis`); :mod:`~trainctl.run.repetitions` repeats a
run over seeds; :mod:`~trainctl.run.budget` estimates a run's cost before it starts;
:mod:`~trainctl.run.pool` runs independent simulations on worker processes;
:mod:`~trainctl.run.strict` decides ``--strict``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from trainctl import _lazy_exports

if TYPE_CHECKING:
    from trainctl.run.analysis import NETWORK_STREAM as NETWORK_STREAM
    from trainctl.run.analysis import AnalysisRun as AnalysisRun
    from trainctl.run.analysis import make_controller as make_controller
    from trainctl.run.analysis import run_scenario as run_scenario
    from trainctl.run.analysis import simulate_strategy as simulate_strategy
    from trainctl.run.analysis import submit_simulations as submit_simulations

__all__ = [
    'AnalysisRun', 'NETWORK_STREAM', 'make_controller', 'run_scenario', 'simulate_strategy',
    'submit_simulations',
]

_EXPORTS = {
    "NETWORK_STREAM": "trainctl.run.analysis",
    "AnalysisRun": "trainctl.run.analysis",
    "make_controller": "trainctl.run.analysis",
    "run_scenario": "trainctl.run.analysis",
    "simulate_strategy": "trainctl.run.analysis",
    "submit_simulations": "trainctl.run.analysis",
}
"""Re-exported name -> its module, imported on first use (:func:`trainctl._lazy_exports`)."""

__getattr__, __dir__ = _lazy_exports(__name__, _EXPORTS)
