# Sweep definitions, re-exported: the [sweep] table is the scenario stage's (scenario/sweep_*.py).
"""What a parameter sweep varies, and the scenarios it makes.

The definition of a sweep — its axes (:mod:`trainctl.scenario.sweep_axes`) and
how they combine into validated points (:mod:`trainctl.scenario.sweep_definition`)
— belongs to the scenario stage, which reads a file's ``[sweep]`` table; its
names are re-exported here, where :mod:`trainctl.sweep` runs them.
"""

from __future__ import annotations

from trainctl.scenario.sweep_axes import DISTRIBUTIONS as DISTRIBUTIONS
from trainctl.scenario.sweep_axes import DRY_RUN_LISTED as DRY_RUN_LISTED
from trainctl.scenario.sweep_axes import MAX_POINTS as MAX_POINTS
from trainctl.scenario.sweep_axes import MAX_RUN_POINTS as MAX_RUN_POINTS
from trainctl.scenario.sweep_axes import SAMPLED_PER_AXIS as SAMPLED_PER_AXIS
from trainctl.scenario.sweep_axes import SCALES as SCALES
from trainctl.scenario.sweep_axes import SEED_KEY as SEED_KEY
from trainctl.scenario.sweep_axes import Axis as Axis
from trainctl.scenario.sweep_axes import GridAxis as GridAxis
from trainctl.scenario.sweep_axes import ListAxis as ListAxis
from trainctl.scenario.sweep_axes import RandomAxis as RandomAxis
from trainctl.scenario.sweep_axes import SweepPoint as SweepPoint
from trainctl.scenario.sweep_axes import parse_set as parse_set
from trainctl.scenario.sweep_axes import toml_text as toml_text
from trainctl.scenario.sweep_definition import SweepDefinition as SweepDefinition
from trainctl.scenario.sweep_definition import point_key as point_key

__all__ = [
    "DISTRIBUTIONS",
    "DRY_RUN_LISTED",
    "MAX_POINTS",
    "MAX_RUN_POINTS",
    "SAMPLED_PER_AXIS",
    "SCALES",
    "Axis",
    "GridAxis",
    "ListAxis",
    "RandomAxis",
    "SweepDefinition",
    "SweepPoint",
    "parse_set",
    "point_key",
]
