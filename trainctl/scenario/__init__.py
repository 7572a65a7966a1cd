# Scenario files: the one package that reads TOML and turns it into SI objects.
"""Read scenario files (TOML) into frozen objects with SI values inside.

A scenario names a train (a preset or explicit vehicle groups), an optional
track, the model settings (cruise speed, linearisation, sampling),
optionally one or more controller designs (``[controller]``, one family
each), a closed-loop simulation run (``[simulation]``) and the declared
outcome of the design checks (``[expected]``). Keys whose name carries a
unit (``mass_t``, ``speed_kmh``, ``stiffness_kn_per_m``) are converted once,
on reading, with :mod:`trainctl.units`; every other number is already SI.

Every key is declared once — type, unit and converter to SI, constraint,
default, one line of documentation (:mod:`trainctl.declare.keys`) — and from that
declaration come the parsing and validation, the schema tables of
``analyses/README.md`` (:mod:`trainctl.scenario.docs`) and the JSON Schema of
the file format (:func:`json_schema`, ``trainctl schema``). Settings objects
built in Python are checked by the same declarations.

Every malformed input raises :class:`~trainctl.exceptions.ScenarioError`
whose message names the file, the key path (``[train.vehicle][2].mass_t``;
array indices count from 0, head vehicle first), what must hold and what was
given.

Built-in scenarios are the ``*.toml`` files shipped in
``trainctl/builtin_analyses/`` (an installed wheel) or, in a source checkout,
the top-level ``analyses/`` directory. A bare name such as ``crh2-dmpc``
selects one; anything that looks like a path is read as a file.

The scenario stage comes before the controllers: a family's settings class
(MPC's :class:`~trainctl.controllers.mpc.settings.ControllerSettings` and its
vocabularies) is imported from its family's package, not from here.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from trainctl.models.discrete import DISCRETISATIONS as DISCRETISATIONS
from trainctl.models.feedforward import ALLOCATIONS as ALLOCATIONS
from trainctl.models.linear import LINEARISATIONS as LINEARISATIONS
from trainctl.models.network.schema import NetworkSettings as NetworkSettings
from trainctl.scenario.communication import CommunicationSettings as CommunicationSettings
from trainctl.scenario.core import RESERVED_SECTIONS as RESERVED_SECTIONS
from trainctl.scenario.core import SCHEMA_VERSION as SCHEMA_VERSION
from trainctl.scenario.core import BuiltinScenario as BuiltinScenario
from trainctl.scenario.core import Scenario as Scenario
from trainctl.scenario.core import check_names as check_names
from trainctl.scenario.core import strategy_names as strategy_names
from trainctl.scenario.files import builtin_scenario_text as builtin_scenario_text
from trainctl.scenario.files import builtin_scenarios as builtin_scenarios
from trainctl.scenario.files import load_scenario as load_scenario
from trainctl.scenario.files import read_scenario_text as read_scenario_text
from trainctl.scenario.files import slugify as slugify
from trainctl.scenario.parse import parse_scenario as parse_scenario
from trainctl.scenario.schema import json_schema as json_schema
from trainctl.scenario.settings import ModelSettings as ModelSettings
from trainctl.scenario.settings import SimulationSettings as SimulationSettings

__all__ = [
    "ALLOCATIONS",
    "CHECK_NAMES",
    "CHECK_STATUSES",
    "DISCRETISATIONS",
    "LINEARISATIONS",
    "RESERVED_SECTIONS",
    "SCHEMA_VERSION",
    "SIMULATION_STRATEGIES",
    "BuiltinScenario",
    "CommunicationSettings",
    "ModelSettings",
    "NetworkSettings",
    "Scenario",
    "SimulationSettings",
    "builtin_scenario_text",
    "builtin_scenarios",
    "check_names",
    "json_schema",
    "load_scenario",
    "parse_scenario",
    "read_scenario_text",
    "slugify",
    "strategy_names",
]

_COMPUTED = {
    "CHECK_NAMES": "the model checks and the default family's checks ([expected] keys)",
    "CHECK_STATUSES": "the statuses [expected] may declare",
    "SIMULATION_STRATEGIES": "the default family's strategies",
}


def __getattr__(name: str) -> Any:
    """Vocabularies computed from where they live, on first use (PEP 562).

    ``CHECK_NAMES`` are the model checks (:mod:`trainctl.design.review`)
    and the checks of the default controller family; ``SIMULATION_STRATEGIES``
    the default family's strategies (:mod:`trainctl.registry`);
    ``CHECK_STATUSES`` the check statuses.
    """
    if name not in _COMPUTED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from trainctl.registry import DEFAULT_FAMILY, get_family
    from trainctl.scenario.core import check_statuses

    family = get_family(DEFAULT_FAMILY)
    computed: dict[str, Callable[[], tuple[str, ...]]] = {
        "CHECK_NAMES": lambda: check_names([DEFAULT_FAMILY]),
        "CHECK_STATUSES": check_statuses,
        "SIMULATION_STRATEGIES": lambda: family.strategies,
    }
    value = computed[name]()
    globals()[name] = value
    return value
