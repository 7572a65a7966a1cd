# The parsed scenario and the vocabulary a scenario file draws on (defined where it lives).
"""The :class:`Scenario` and the names its files may use.

The vocabularies are imported from where the things they name live (the
controller families in :mod:`trainctl.registry`, the model
checks in :mod:`trainctl.design.review`); the functions here combine them
for one scenario: which strategies ``[simulation]`` may list and which checks
``[expected]`` may name, given the controller families present.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

from trainctl.declare.constraints import Violation, suggest
from trainctl.exceptions import ModelError
from trainctl.models.graphs import CommunicationGraph
from trainctl.models.network.schema import NetworkSettings
from trainctl.models.track import Track
from trainctl.models.train import Train
from trainctl.scenario.communication import CommunicationSettings
from trainctl.scenario.cost import CostSettings
from trainctl.scenario.frozen import FrozenMapping as FrozenMapping
from trainctl.scenario.settings import ModelSettings, SimulationSettings

__all__ = [
    "RESERVED_SECTIONS",
    "SCHEMA_VERSION",
    "BuiltinScenario",
    "FrozenMapping",
    "Scenario",
    "check_names",
    "check_statuses",
    "expectation_violation",
    "family_of",
    "model_check_names",
    "strategy_names",
]

SCHEMA_VERSION = 1
"""The only ``schema_version`` this release reads."""

RESERVED_SECTIONS = ("report",)
"""Top-level sections reserved for later releases (rejected today)."""

def model_check_names() -> tuple[str, ...]:
    """The model-level checks, which need no controller.

    Returns
    -------
    tuple of str
        Their names, in the review's order.

    Examples
    --------
    The sampling check is a model check, the N-DMPC convergence check is not
    (it belongs to the MPC family):

    >>> names = model_check_names()
    >>> names[:3]
    ('open_loop_stability', 'controllability', 'observability')
    >>> "sampling" in names, "ndmpc_convergence" in names
    (True, False)
    """
    from trainctl.analysis.check import MODEL_CHECK_NAMES

    return MODEL_CHECK_NAMES


def check_statuses() -> tuple[str, ...]:
    """The statuses a check may have (``[expected]`` values).

    Returns
    -------
    tuple of str
        The statuses, best first.

    Examples
    --------
    >>> check_statuses()
    ('pass', 'warn', 'fail')
    """
    from trainctl.analysis.check import STATUSES

    return STATUSES


def _families(names: Iterable[str] | None = None) -> list[Any]:
    from trainctl.registry import family_names, get_family

    return [get_family(n) for n in (family_names() if names is None else names)]


def check_names(families: Sequence[str] | None = None) -> tuple[str, ...]:
    """Checks ``[expected]`` may name: the model's, then each family's.

    Parameters
    ----------
    families : sequence of str, optional
        Family names; every known family when omitted.

    Returns
    -------
    tuple of str
        Check names, without repeats.

    Examples
    --------
    >>> check_names(["lqr"])
    ('open_loop_stability', 'controllability', 'observability', 'sampling', 'input_collapse', \
'feasibility', 'plausibility', 'lqr_closed_loop', 'lqr_decentralised_closed_loop', \
'string_stability')
    """
    from trainctl.analysis.check import LOOP_CHECK_NAMES

    names = [*model_check_names(), *(c for f in _families(families) for c in f.check_names),
             *LOOP_CHECK_NAMES]
    return tuple(dict.fromkeys(names))


def strategy_names(families: Sequence[str] | None = None) -> tuple[str, ...]:
    """Strategies ``[simulation]`` may list: bare for the first family, else qualified.

    Parameters
    ----------
    families : sequence of str, optional
        The scenario's families, primary first. When omitted, every bare and
        qualified name of every known family (for settings built in Python).

    Returns
    -------
    tuple of str
        ``"ndmpc"`` for the primary family, ``"lqr.centralised"`` for another.

    Examples
    --------
    >>> strategy_names(["mpc", "lqr"])
    ('centralised', 'decentralised', 'ndmpc', 'cooperative', 'ndmpc-local', \
'lqr.centralised', 'lqr.decentralised')
    """
    if families is None:
        known = _families()
        bare = [s for f in known for s in f.strategies]
        return tuple(dict.fromkeys(bare + [f"{f.name}.{s}" for f in known for s in f.strategies]))
    primary, *others = _families(families)
    return (*primary.strategies, *(f"{f.name}.{s}" for f in others for s in f.strategies))


def family_of(settings: object) -> str:
    """The family name of a settings object (its ``family`` or its registry type).

    Parameters
    ----------
    settings : object
        A controller family's settings.

    Returns
    -------
    str
        The family's registered name.

    Raises
    ------
    ModelError
        If no known family has settings of this type.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> family_of(load_scenario("crh2-dmpc").controller)
    'mpc'
    >>> family_of(3.0)
    Traceback (most recent call last):
        ...
    trainctl.exceptions.ModelError: Scenario: 'controller' must be the settings of a \
controller family (got float).
    """
    name = getattr(type(settings), "family", None)
    if isinstance(name, str):
        return name
    for family in _families():
        if isinstance(settings, family.settings):
            return str(family.name)
    raise ModelError(
        f"Scenario: 'controller' must be the settings of a controller family (got "
        f"{type(settings).__name__})."
    )


def expectation_violation(check: str, families: Sequence[str]) -> Violation | None:
    """Why ``check`` may not be declared with ``families`` present, or None.

    Parameters
    ----------
    check : str
        A known check name.
    families : sequence of str
        The scenario's controller families.

    Returns
    -------
    Violation or None
        For a controller check whose family is absent.

    Examples
    --------
    A model check may always be expected; an MPC check needs the MPC family:

    >>> expectation_violation("sampling", []) is None
    True
    >>> expectation_violation("ndmpc_convergence", ["mpc"]) is None
    True
    >>> expectation_violation("ndmpc_convergence", ["lqr"]).text
    "needs a controller of family 'mpc'"
    >>> expectation_violation("ndmpc_convergence", []).text
    'needs a [controller] section'
    """
    from trainctl.analysis.check import LOOP_CHECK_NAMES

    owners = [f.name for f in _families() if check in f.check_names]
    if check in LOOP_CHECK_NAMES:
        owners = ["any"]
    if not owners or any(o in families for o in owners) or (owners == ["any"] and families):
        return None
    if not families:
        return Violation(
            text="needs a [controller] section", python_text="needs a controller", got_text="none",
            hint=f" The check {check!r} runs only for a controller design: add [controller] or "
            "remove the expectation.",
        )
    return Violation(
        text=f"needs a controller of family {owners[0]!r}", got_text=", ".join(families),
        hint=f" The check {check!r} runs only for a design of family {owners[0]!r}: add "
        f"[controller.{owners[0]}] or remove the expectation.",
    )


def _fail(message: str) -> NoReturn:
    raise ModelError(f"Scenario: {message}")


@dataclass(frozen=True, kw_only=True)
class Scenario:
    """A parsed scenario: train, track, model and controller settings, all SI.

    Parameters
    ----------
    name : str
        Display name (any text); see :attr:`slug` for a file-name-safe form.
    description : str
        One-line description shown by ``trainctl list``.
    seed : int
        Random seed [-], >= 0.
    train : Train
        The train, head vehicle first.
    track : Track or None
        Track grade and curvature; ``None`` for flat, straight track.
    model : ModelSettings
        Linearisation and sampling settings.
    controller : settings object or None
        The primary controller family's settings (e.g.
        :class:`~trainctl.controllers.mpc.settings.ControllerSettings`);
        ``None`` when the file has no ``[controller]``.
    controllers : Mapping of str to settings object
        Every controller family of the scenario, name to settings, the
        primary first, then the ``[controller.<family>]`` sub-tables in file
        order; read-only. Built from ``controller`` when not given.
    communication : CommunicationSettings or None
        The communication graph of consensus controllers (``[communication]``);
        None: a bidirectional chain with every vehicle hearing the reference
        (:meth:`graph`).
    cost : CostSettings or None
        Prices of energy and train-hours for the runs' operating cost
        (``[cost]``); None: no cost.
    network : NetworkSettings or None
        The radio links over which networked controllers receive their
        neighbours' data (``[network]``: delays, losses, noise, outage
        windows; :class:`trainctl.models.network.Network`); None when the file has
        no ``[network]``.
    simulation : SimulationSettings or None
        The closed-loop simulation run; ``None`` when the file has no
        ``[simulation]``. Needs a ``controller``, its duration must be a
        whole multiple of ``model.sample_time`` and its strategies must
        belong to the scenario's families.
    expected : Mapping of str to str
        Declared outcome of the design checks, check name (a model check or
        a check of one of the scenario's families) to status (``"pass"``,
        ``"warn"`` or ``"fail"``), in file order; read-only, empty when the
        file has no ``[expected]``.
    sweep : SweepDefinition or None
        The parameter sweep of the ``[sweep]`` section
        (:class:`trainctl.sweep.SweepDefinition`); None without one. It
        does not change the scenario itself: its points are validated and
        run by ``trainctl sweep``.
    source : str
        Where the scenario came from: the file path as given, ``"builtin:NAME"``
        or ``"<string>"`` (a scenario made by :meth:`replace` adds the change).
    document : Mapping or None
        The TOML document the scenario was parsed from, read-only (tables as
        mappings, arrays as tuples); None for a scenario built in Python.
        :meth:`replace` edits a copy of it.
    tags : Mapping of str to str
        Where the file's values come from: file key path (``"model.speed_kmh"``,
        ``"train.vehicle[0].mass_t"``) or table path to the source tag of its
        comment (``"reconstructed: CRH cruise speed"``), read-only
        (:func:`~trainctl.scenario.tags.source_tags`); :meth:`replace` drops
        the tag of the key it changes.
    directory : str or None
        The directory a scenario file's relative paths (``[track].file``) are
        read from: the file's own; None (the working directory) for a built-in
        or a string.
    track_digest : str or None
        SHA-256 of the ``[track].file`` the track was read from (None: no file).

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> scenario.slug
    'crh2-half-train-n-dmpc-as-printed-li-zheng-ch-12'
    >>> scenario.simulation.n_steps(scenario.model.sample_time)
    60
    >>> list(scenario.controllers)
    ['mpc']
    """

    name: str
    description: str
    seed: int = 0
    train: Train
    track: Track | None = None
    model: ModelSettings
    controller: Any = None
    controllers: Mapping[str, Any] = field(default_factory=FrozenMapping)
    communication: CommunicationSettings | None = None
    cost: CostSettings | None = None
    network: NetworkSettings | None = None
    simulation: SimulationSettings | None = None
    expected: Mapping[str, str] = field(default_factory=FrozenMapping)
    sweep: Any = None
    source: str = "<string>"
    document: Mapping[str, Any] | None = field(default=None, compare=False, repr=False)
    tags: Mapping[str, str] = field(default_factory=FrozenMapping, compare=False, repr=False)
    directory: str | None = field(default=None, compare=False, repr=False)
    track_digest: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.document is not None:
            from trainctl.scenario.replace import freeze

            object.__setattr__(self, "document", freeze(self.document))
        controllers = self._controllers()
        object.__setattr__(self, "controllers", controllers)
        if controllers:
            object.__setattr__(self, "controller", next(iter(controllers.values())))
        families = tuple(controllers)
        object.__setattr__(self, "expected", self._expected(families))
        n = self.train.n_vehicles
        if self.communication is not None:
            self.communication.check_vehicles(n)
        if self.network is not None:
            self.network.check_vehicles(n)
        for settings in controllers.values():
            for method in ("neighbourhoods", "cooperative_weight_vector"):
                if hasattr(settings, method):
                    getattr(settings, method)(n)
        if self.simulation is not None:
            if self.controller is None:
                _fail("'simulation' needs a controller (got none).")
            self.simulation.n_steps(self.model.sample_time)
            self.simulation.check_vehicles(n, virtual=self.train.virtual.tolist())
            self.simulation.check_strategies(strategy_names(families))

    def graph(self) -> CommunicationGraph:
        """The communication graph on the train's vehicles (``[communication]`` or the default).

        Returns
        -------
        CommunicationGraph
            The graph (:mod:`trainctl.models.graphs`).
        """
        settings = self.communication or CommunicationSettings()
        return settings.graph(self.train.n_vehicles)

    def _controllers(self) -> FrozenMapping[Any]:
        given = dict(self.controllers)
        if self.controller is None:
            return FrozenMapping(given)
        primary = family_of(self.controller)
        rest = {name: s for name, s in given.items() if name != primary}
        return FrozenMapping({primary: self.controller, **rest})

    def _expected(self, families: Sequence[str]) -> FrozenMapping[str]:
        expected = FrozenMapping(self.expected)
        known = check_names()
        statuses = check_statuses()
        for check, status in expected.items():
            if check not in known:
                _fail(f"'expected' names an unknown check {check!r}.{suggest(check, known)} "
                      f"Checks: {', '.join(known)}.")
            if status not in statuses:
                _fail(f"'expected'[{check!r}] must be one of {statuses} (got {status!r}).")
            problem = expectation_violation(check, families)
            if problem is not None:
                _fail(f"'expected'[{check!r}] {problem.python_text or problem.text} "
                      f"(got {problem.got_text}).")
        return expected

    def replace(self, key: str, value: Any) -> Scenario:
        """A new scenario with one file key changed, validated like a file.

        The key is a file key path, as scenario files and error messages
        spell it (``"controller.r_per_kn2"``, ``"model.sample_time"``,
        ``"train.vehicle[1].mass_t"`` with 0-based array indices), and the
        value is in the key's file unit (``r_per_kn2`` per kN², ``mass_t``
        tonnes). The scenario's TOML document is copied, changed and parsed
        again, so every rule a file obeys holds (cross-table ones too).
        Setting one key of a group of alternatives removes the others
        (``r_per_kn2`` replaces ``r_per_n2``); ``None`` removes the key (or
        a whole table, ``"simulation"``). This scenario is left unchanged.
        Each call validates the whole scenario, so keys that constrain each
        other change in an order in which every step is valid (shorten
        ``control_horizon`` before ``prediction_horizon``).

        Parameters
        ----------
        key : str
            File key path.
        value : object
            New value in file units (a TOML value), or None to remove the key.

        Returns
        -------
        Scenario
            The changed scenario; its ``source`` records the change.

        Raises
        ------
        ScenarioError
            If the key path or the value is invalid (the message names the key
            path), or the scenario was built in Python (no document).

        Examples
        --------
        >>> from trainctl.scenario import load_scenario
        >>> book = load_scenario("crh2-dmpc")
        >>> lighter = book.replace("controller.r_per_kn2", 1.0)
        >>> book.controller.input_weight, lighter.controller.input_weight
        (10.0, 1.0)
        >>> lighter.source
        'builtin:crh2-dmpc (controller.r_per_kn2 = 1.0)'
        >>> book.replace("controller.r_per_kn2", -1.0)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
            ...
        trainctl.exceptions.ScenarioError: builtin:crh2-dmpc (controller.r_per_kn2 = -1.0): \
[controller].r_per_kn2 must be a number > 0 (got -1.0). ...
        """
        from trainctl.exceptions import ScenarioError
        from trainctl.scenario.parse import parse_document
        from trainctl.scenario.replace import replaced_document

        if self.document is None:
            raise ScenarioError(
                f"Scenario.replace: {self.name!r} was built in Python, not read from a file, so "
                "there is no file key to replace; use dataclasses.replace on its settings.")
        label = f"{self.source} ({key} = {value!r})"
        tags = {k: v for k, v in self.tags.items()
                if k != key and not k.startswith((key + ".", key + "["))}
        return parse_document(replaced_document(self.document, key, value), source=label,
                              tags=tags, directory=self.directory)

    @property
    def slug(self) -> str:
        """File-name-safe form of :attr:`name` (see :func:`~trainctl.scenario.slugify`)."""
        from trainctl.scenario.files import slugify

        return slugify(self.name)


@dataclass(frozen=True, kw_only=True)
class BuiltinScenario:
    """A scenario file shipped with trainctl.

    Parameters
    ----------
    name : str
        Built-in name (the file stem), e.g. ``"crh2-dmpc"``.
    description : str
        The file's one-line ``description``.
    path : pathlib.Path
        Location of the file.

    Examples
    --------
    >>> from trainctl.scenario import builtin_scenarios
    >>> builtin_scenarios()[0].name
    'crh2-dmpc'
    """

    name: str
    description: str
    path: Path
