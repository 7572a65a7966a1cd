# Controller families: the protocol every family follows and the registry that names them.
"""Controller families and their registry.

A *family* is one kind of controller (MPC, LQR, potential-function
consensus, ...) with everything trainctl needs to analyse, simulate and
report it. It lives in ``trainctl/controllers/<family>/`` and is named in
:data:`FAMILY_MODULES` (one line). Each family module exposes a ``FAMILY``
object that follows :class:`ControllerFamily`:

- ``name``, ``strategies`` and ``check_names``: the vocabulary of the
  family, defined once, in the family;
- ``settings``: the schema of its ``[controller]`` table (a pydantic model
  whose validated instance is the family's settings object, SI inside);
- ``design(scenario, model, settings)``: the family's design, built once per
  run from the shared :class:`~trainctl.design.DesignModel`;
- ``make(design, strategy)``: a controller following the
  :class:`~trainctl.controllers.base.Controller` protocol;
- ``checks(design)``: its design checks (:class:`~trainctl.design.review.Check`);
- ``closed_loop(design, strategy)``: the linear closed loop as a
  ``control.StateSpace``, discrete (a sampled controller such as MPC or
  LQR) or continuous (a continuous-time law such as the potential and
  flocking families; analyses that need a discrete loop sample it,
  :func:`trainctl.analysis.loops.as_discrete`), or None where the loop is
  not linear: the input of every generic analysis (poles, frequency
  responses, norms, string stability);
- optionally ``trajectory_checks(design, strategy, result)``: checks that a
  simulation decides (the validity range of a linearisation along the
  trajectory, the connectivity of a formation), each replacing the design
  check of the same name after ``[simulation]`` has run
  (:func:`trainctl.design.review.with_simulations`), with their names in
  ``trajectory_check_names`` (``[expected]`` declares their verdict after
  the simulation, so a run without one does not compare them);
- ``report_data(design)``, ``report_figures(data)`` and ``report_partial``:
  what the HTML report shows for the family (JSON-safe data, figures drawn
  from that data, and the Jinja source of its report section). A figure goes
  to the page's Figures section, or, when its ``section`` is the family's
  (:func:`trainctl.plots.svg.family_section`), into the family's own
  section after the partial (the potential and flocking families' graph,
  :mod:`trainctl.plots.graph_figures`);
- optional hooks for the later stages (the cost estimate, published claims,
  sweep certificates, report labels), with defaults in
  :class:`trainctl.controllers.hooks.FamilyHooks`, which families inherit.

Importing this module, or a family module, imports no solver: families
import cvxpy and python-control inside their methods.

Examples
--------
>>> family_names()[:2]
('mpc', 'lqr')
>>> get_family("mpc").strategies
('centralised', 'decentralised', 'ndmpc', 'cooperative', 'ndmpc-local')
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from importlib import import_module
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, runtime_checkable

from trainctl.exceptions import ScenarioError

if TYPE_CHECKING:
    import control as ct

    from trainctl.analysis.certificates import Certificate
    from trainctl.analysis.check import Check
    from trainctl.analysis.claims import Claim
    from trainctl.controllers.base import Controller
    from trainctl.controllers.hooks import DesignCost, StrategyRun
    from trainctl.design import DesignModel
    from trainctl.plots.svg import ReportFigure
    from trainctl.scenario import Scenario
    from trainctl.sim import SimulationResult

__all__ = [
    "DEFAULT_FAMILY",
    "FAMILY_MODULES",
    "ControllerFamily",
    "ControllerFamilyHooks",
    "DesignT",
    "SettingsT",
    "family_names",
    "get_family",
    "register_family",
    "unregister_family",
]

DEFAULT_FAMILY = "mpc"
"""The family of a ``[controller]`` table without a ``family`` key."""

FAMILY_MODULES: Mapping[str, str] = {
    "mpc": "trainctl.controllers.mpc",
    "lqr": "trainctl.controllers.lqr",
    "potential": "trainctl.controllers.potential",
    "flocking": "trainctl.controllers.flocking",
    "synchronous": "trainctl.controllers.synchronous",
    "hinf": "trainctl.controllers.hinf",
}
"""The built-in families: name -> module exposing ``FAMILY`` (imported on first use)."""

DesignT = TypeVar("DesignT")
"""The type of a family's design (what :meth:`ControllerFamily.design` returns)."""

SettingsT = TypeVar("SettingsT")
"""The type of a family's settings (an instance of :attr:`ControllerFamily.settings`)."""

_REGISTERED: dict[str, ControllerFamily[Any, Any]] = {}
_LOADED: dict[str, ControllerFamily[Any, Any]] = {}


@runtime_checkable
class ControllerFamily(Protocol[DesignT, SettingsT]):
    """What a controller family provides (module docstring).

    The protocol is generic in the family's design type ``DesignT`` and its
    settings type ``SettingsT``: ``ControllerFamily[LQRDesign, LQRSettings]``
    is the LQR family, whose :meth:`design` takes ``LQRSettings`` and whose
    other methods take the ``LQRDesign`` it returns. The registry holds
    families of every type (``ControllerFamily[Any, Any]``). The attributes
    are read-only members: a family defines each as a class attribute, an
    instance attribute or a property.
    :func:`trainctl.controllers.check_family` checks a family against this
    protocol, at run time.

    Attributes
    ----------
    name : str
        Registry name, the value of ``[controller] family``.
    title : str
        Display name, e.g. ``"Model predictive control"``.
    strategies : tuple of str
        Its strategy names, the values of ``[simulation] strategies``.
    check_names : tuple of str
        Names of the checks :meth:`checks` returns (what ``[expected]`` may
        declare for the family).
    settings : type of SettingsT
        Pydantic model of the family's ``[controller]`` table (a
        ``pydantic.BaseModel`` or a pydantic dataclass such as
        :func:`trainctl.declare.keys.settings` makes); its instances are the
        settings :meth:`design` takes.
    report_partial : str
        Jinja source of the family's report section (rendered with ``data``,
        the family's :meth:`report_data`, and ``design`` as context), or ""
        for none.

    Examples
    --------
    Every built-in family satisfies the protocol, which is checked at run time:

    >>> [isinstance(get_family(name), ControllerFamily) for name in ("mpc", "hinf")]
    [True, True]
    >>> isinstance(object(), ControllerFamily)
    False
    """

    # Read-only members: a class attribute, an instance attribute or a property follows them
    # (and a family's tuple[str, str] is a tuple[str, ...]).
    @property
    def name(self) -> str:
        """Registry name (see the class docstring)."""
        ...

    @property
    def title(self) -> str:
        """Display name (see the class docstring)."""
        ...

    @property
    def strategies(self) -> tuple[str, ...]:
        """Strategy names (see the class docstring)."""
        ...

    @property
    def check_names(self) -> tuple[str, ...]:
        """Names of the design checks (see the class docstring)."""
        ...

    @property
    def settings(self) -> type[SettingsT]:
        """The schema of the family's ``[controller]`` table (see the class docstring)."""
        ...

    @property
    def report_partial(self) -> str:
        """Jinja source of the report section (see the class docstring)."""
        ...

    def design(self, scenario: Scenario, model: DesignModel, settings: SettingsT) -> DesignT:
        """The family's design (built once per run).

        Parameters
        ----------
        scenario : Scenario
            The validated scenario of the run.
        model : DesignModel
            The shared design model (linearised platoon, sample time, bounds).
        settings : SettingsT
            The family's validated ``[controller]`` settings (an instance of
            :attr:`settings`, SI units).

        Returns
        -------
        DesignT
            The family's design, passed to :meth:`make`, :meth:`checks`,
            :meth:`closed_loop` and :meth:`report_data`.
        """
        ...

    def make(self, design: DesignT, strategy: str) -> Controller:
        """A controller for one strategy, ready to ``step``.

        Parameters
        ----------
        design : DesignT
            The family's design, from :meth:`design`.
        strategy : str
            One of :attr:`strategies`.

        Returns
        -------
        Controller
            A fresh controller following the
            :class:`~trainctl.controllers.base.Controller` protocol.
        """
        ...

    def checks(self, design: DesignT) -> list[Check]:
        """The family's design checks.

        Parameters
        ----------
        design : DesignT
            The family's design, from :meth:`design`.

        Returns
        -------
        list of Check
            One check per name in :attr:`check_names`.
        """
        ...

    def closed_loop(self, design: DesignT, strategy: str) -> ct.StateSpace | None:
        """The linear closed loop of a strategy (discrete or continuous), or None.

        Parameters
        ----------
        design : DesignT
            The family's design, from :meth:`design`.
        strategy : str
            One of :attr:`strategies`.

        Returns
        -------
        control.StateSpace or None
            The linear closed loop of the strategy (inputs and outputs as the
            family labels them, e.g. disturbances ``w[i]`` to speed, coupler-force
            and spacing deviations), discrete (``dt`` the sample time [s]) or
            continuous; None where the loop is not linear.
        """
        ...

    def report_data(self, design: DesignT) -> dict[str, Any]:
        """JSON-safe data for the family's report section and figures.

        Parameters
        ----------
        design : DesignT
            The family's design, from :meth:`design`.

        Returns
        -------
        dict of str to object
            JSON-safe data, the ``data`` context of :attr:`report_partial` and
            the input of :meth:`report_figures`.
        """
        ...

    def report_figures(self, data: Mapping[str, Any]) -> Sequence[ReportFigure]:
        """The family's figures, drawn from ``data`` (placed by their ``section``).

        Parameters
        ----------
        data : mapping of str to object
            The family's :meth:`report_data` (possibly read back from JSON).

        Returns
        -------
        sequence of ReportFigure
            The figures, each placed by its ``section``; may be empty.
        """
        ...


SettingsInT = TypeVar("SettingsInT", contravariant=True)
"""The settings type the hooks take (contravariant: hooks only read settings)."""


@runtime_checkable
class ControllerFamilyHooks(Protocol[SettingsInT]):
    """The optional hooks of a family, beyond :class:`ControllerFamily`.

    What the run, the budget, the pool, the report and sweeps ask of a family. A family
    may leave out any of them: the stages call them through
    :func:`trainctl.controllers.hooks.family_hook`, which falls back to the default of
    :class:`trainctl.controllers.hooks.FamilyHooks` (the mixin every built-in family
    inherits, through :class:`trainctl.controllers.family.FamilyBase`).

    Examples
    --------
    >>> isinstance(get_family("mpc"), ControllerFamilyHooks)
    True
    """

    claims_source: str
    """The publication the family's :meth:`claims` come from (``""``: none)."""
    settings_labels: Mapping[str, str]
    """Display labels of some of the settings' fields, for the report."""
    headline_checks: Mapping[str, str]
    """Check name → symbol of its value, for the checks the report's headline quotes."""
    trajectory_check_names: tuple[str, ...]
    """The checks :meth:`trajectory_checks` judges again on a simulation."""
    measures_gaps: bool
    """Whether the family's controllers measure the gaps (observability counts them)."""

    def trajectory_checks(self, design: Any, strategy: str,
                          result: SimulationResult) -> list[Check]:
        """Checks a simulation decides, each replacing the design check of its name.

        Parameters
        ----------
        design : object
            The family's design.
        strategy : str
            The simulated strategy.
        result : SimulationResult
            Its simulation.

        Returns
        -------
        list of Check
            Named from :attr:`trajectory_check_names`.
        """
        ...

    def cost_horizons(self, settings: SettingsInT) -> tuple[int, int]:
        """The prediction and control horizons of what each step solves ((1, 1): none).

        Parameters
        ----------
        settings : object
            The family's settings.

        Returns
        -------
        (int, int)
            P and M [steps] (the budget's ``work`` is steps × vehicles × P).
        """
        ...

    def design_cost(self, scenario: Scenario, settings: SettingsInT,
                    strategies: Sequence[str]) -> DesignCost | None:
        """The estimated cost of the family's design and review, or None when negligible.

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        settings : object
            The family's settings.
        strategies : sequence of str
            The family's simulated strategies.

        Returns
        -------
        DesignCost or None
            Seconds, peak bytes and what dominates (:mod:`trainctl.run.budget` sums them).
        """
        ...

    def strategy_seconds(self, run: StrategyRun) -> float:
        """Seconds to build a strategy's controller and simulate it (the plant's included).

        Parameters
        ----------
        run : StrategyRun
            The strategy's simulation as the budget sees it (samples, control
            interval, the plant's cost per sample).

        Returns
        -------
        float
            Time [s].
        """
        ...

    def claims(self, run: Any) -> Sequence[Claim]:
        """The published claims a run decides, with trainctl's numbers and verdicts.

        Parameters
        ----------
        run : AnalysisRun
            The analysis run.

        Returns
        -------
        sequence of Claim
            Possibly empty.
        """
        ...

    def claim_figures(self, data: Any,
                      make: Callable[..., ReportFigure]) -> Sequence[ReportFigure]:
        """Report figures that illustrate the family's claims (after the time series).

        Parameters
        ----------
        data : ReportData
            The report data.
        make : callable
            Turns a matplotlib figure into a report figure.

        Returns
        -------
        sequence of ReportFigure
            Possibly empty.
        """
        ...

    def certificates(self) -> Sequence[Certificate]:
        """Design checks that a sweep sets against simulated outcomes.

        Returns
        -------
        sequence of Certificate
            Possibly empty.
        """
        ...


def family_names() -> tuple[str, ...]:
    """Names of every known family: the built-ins, then the registered ones.

    Returns
    -------
    tuple of str
        Family names.

    Examples
    --------
    >>> "mpc" in family_names()
    True
    """
    return tuple(FAMILY_MODULES) + tuple(n for n in _REGISTERED if n not in FAMILY_MODULES)


def get_family(name: str) -> ControllerFamily[Any, Any]:
    """The family called ``name``.

    Parameters
    ----------
    name : str
        A name from :func:`family_names`.

    Returns
    -------
    ControllerFamily
        The family object.

    Raises
    ------
    ScenarioError
        If no family has that name (the message lists them).

    Examples
    --------
    >>> get_family("lqr").name
    'lqr'
    """
    if name in _REGISTERED:
        return _REGISTERED[name]
    if name in _LOADED:
        return _LOADED[name]
    if name not in FAMILY_MODULES:
        from difflib import get_close_matches

        close = get_close_matches(str(name), list(family_names()), n=1)
        hint = f" Did you mean {close[0]!r}?" if close else ""
        raise ScenarioError(
            f"controller family {name!r} is not known.{hint} Families: "
            f"{', '.join(family_names())}."
        )
    family: ControllerFamily[Any, Any] = import_module(FAMILY_MODULES[name]).FAMILY
    _LOADED[name] = family
    return family


def register_family(family: ControllerFamily[Any, Any]) -> None:
    """Make ``family`` available under ``family.name`` (a plug-in, or a test's toy family).

    Parameters
    ----------
    family : ControllerFamily
        The family; a built-in name cannot be replaced.

    Raises
    ------
    ValueError
        If ``family.name`` is a built-in family or not an identifier.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> toy = SimpleNamespace(name="toy", strategies=("hold",))
    >>> register_family(toy)
    >>> family_names()[-1], get_family("toy") is toy
    ('toy', True)
    >>> unregister_family("toy")
    >>> register_family(SimpleNamespace(name="mpc"))
    Traceback (most recent call last):
    ...
    ValueError: register_family: 'mpc' is a built-in family and cannot be replaced.
    """
    name = getattr(family, "name", None)
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"register_family: 'name' must be an identifier (got {name!r}).")
    if name in FAMILY_MODULES:
        raise ValueError(f"register_family: {name!r} is a built-in family and cannot be replaced.")
    _REGISTERED[name] = family


def unregister_family(name: str) -> None:
    """Remove a family added with :func:`register_family` (no error if absent).

    Parameters
    ----------
    name : str
        The family's name.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> register_family(SimpleNamespace(name="toy"))
    >>> "toy" in family_names()
    True
    >>> unregister_family("toy")
    >>> "toy" in family_names()
    False
    >>> unregister_family("toy")  # absent: nothing happens
    """
    _REGISTERED.pop(name, None)


def strategy_names(families: Iterable[str]) -> tuple[str, ...]:
    """Every strategy of the given families, in order (helper for messages)."""
    return tuple(s for f in families for s in get_family(f).strategies)
