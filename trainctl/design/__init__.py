# The design stage: the linear models and every controller family's design, built once.
"""The design stage of a run.

:func:`build_design` builds, once per run, the scenario's linear models
(:class:`DesignModel`: one linearisation, one discretisation) and the design
of every controller family the scenario names. The design review, the
controllers and the report read them from the :class:`Design` carried in
:class:`~trainctl.run.analysis.AnalysisRun`; none of them linearises or discretises
again.
"""

from __future__ import annotations

from trainctl.design.model import KN as KN
from trainctl.design.model import DesignModel as DesignModel
from trainctl.design.model import build_model as build_model
from trainctl.design.stage import Design as Design
from trainctl.design.stage import build_design as build_design
from trainctl.design.stage import scenario_controllers as scenario_controllers
from trainctl.design.stage import split_strategy as split_strategy
from trainctl.design.stage import strategy_interval as strategy_interval

__all__ = [
    "KN", "Design", "DesignModel", "build_design", "build_model", "scenario_controllers",
    "split_strategy",
    "strategy_interval",
]
