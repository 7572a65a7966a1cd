# The optional hooks of a controller family, with their defaults: cost, claims, certificates.
"""Defaults of the optional family hooks (:class:`~trainctl.registry.ControllerFamilyHooks`).

Everything a stage after the design asks of a family, beside the required
members, goes through these hooks, so that no stage names a family, a
strategy or a check:

- the run's cost estimate (:mod:`trainctl.run.budget`, which only sums):
  :meth:`FamilyHooks.cost_horizons` (the size of what each step solves),
  :meth:`FamilyHooks.design_cost` (the family's design and review) and
  :meth:`FamilyHooks.strategy_seconds` (building and running one strategy,
  given a :class:`StrategyRun`);
- the published claims a run of the family decides
  (:meth:`FamilyHooks.claims`, :attr:`FamilyHooks.claims_source`, and their
  figures, :meth:`FamilyHooks.claim_figures`; vocabulary
  :class:`~trainctl.analysis.claims.Claim`);
- the certificates a sweep sets against simulation
  (:meth:`FamilyHooks.certificates`; vocabulary
  :class:`~trainctl.analysis.certificates.Certificate`);
- what the report says of the family beside its own section: the labels of
  its settings (:attr:`FamilyHooks.settings_labels`) and the checks whose
  value the page's headline quotes (:attr:`FamilyHooks.headline_checks`).

A family class inherits :class:`FamilyHooks` and overrides what it has;
:func:`family_hook` gives the stages a family's hook, or the default for a
family that does not inherit the mixin (a plug-in written against the
protocol alone).

Examples
--------
>>> class Toy(FamilyHooks):
...     name = "toy"
>>> Toy().cost_horizons(None), Toy().claims(None), Toy().certificates()
((1, 1), (), ())
>>> family_hook(object(), "certificates")()
()
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import partial
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from trainctl.analysis.certificates import Certificate
    from trainctl.analysis.check import Check
    from trainctl.analysis.claims import Claim
    from trainctl.plots.svg import ReportFigure
    from trainctl.scenario import Scenario
    from trainctl.sim import SimulationResult

__all__ = ["BUILD_SECONDS", "STEP_SECONDS", "DesignCost", "FamilyHooks", "StrategyRun",
           "family_hook"]

BUILD_SECONDS = 0.5
"""Building a strategy's controller [s] (cvxpy problems, network; the budget's calibration)."""

STEP_SECONDS = 1e-4
"""A sampled controller's overhead per step [s] (the budget's calibration: with a plant
substep's 0.1 ms, 0.2 ms a sample against the 72 µs measured of the whole LQR loop of the
4-coach train; 5e-4 before)."""


@dataclass(frozen=True, kw_only=True)
class DesignCost:
    """The estimated cost of a family's design and review.

    Parameters
    ----------
    seconds : float
        Time [s] beyond the shared model and review.
    memory_bytes : float
        Peak memory of its largest matrices [bytes] (0 when negligible).
    dominant : str
        What the time goes to, in words naming the keys that drive it (shown
        when it dominates the run).

    Examples
    --------
    >>> DesignCost(seconds=1.5, memory_bytes=0.0, dominant="the toy's synthesis").seconds
    1.5
    """

    seconds: float
    memory_bytes: float
    dominant: str


@dataclass(frozen=True, kw_only=True)
class StrategyRun:
    """What the budget knows of one strategy's simulation, for its family to price.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    settings : object
        The family's ``[controller]`` settings.
    strategy : str
        The family's strategy name (without the family prefix).
    samples : int
        Recorded samples at ``[model] sample_time``.
    sample_time : float
        ``[model] sample_time`` [s].
    interval : float
        The strategy's control interval [s]
        (:func:`trainctl.design.stage.strategy_interval`).
    substeps : int
        The plant's integration substeps per sample.
    plant_seconds : float
        Seconds of the plant's substeps and their recording per sample [s].

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> run = StrategyRun(scenario=load_scenario("crh2-dmpc"), settings=None,
    ...                   strategy="ndmpc", samples=60, sample_time=20.0, interval=20.0,
    ...                   substeps=200, plant_seconds=0.02)
    >>> run.n_vehicles
    4
    """

    scenario: Scenario
    settings: Any
    strategy: str
    samples: int
    sample_time: float
    interval: float
    substeps: int
    plant_seconds: float

    @property
    def n_vehicles(self) -> int:
        """Vehicles of the train."""
        return int(self.scenario.train.n_vehicles)


class FamilyHooks:
    """The optional hooks of a controller family, with their defaults (module docstring).

    The defaults describe a family with no costly design, whose strategies
    are explicit laws (no optimisation per step,
    :func:`trainctl.controllers.continuous.cost.law_seconds`), with no
    published claims and no certificates.

    Attributes
    ----------
    claims_source : str
        The publication the family's claims come from, for the page and the
        text summary (``""`` when it has none).
    settings_labels : mapping of str to str
        Display labels of some of its settings' fields (e.g.
        ``"prediction_horizon"`` → ``"Prediction horizon P"``); the others
        are humanised from their names.
    headline_checks : mapping of str to str
        Check name → the symbol of its value, for the checks whose value the
        report's headline quotes (e.g. MPC's spectral radius ρ(D0)).
    trajectory_check_names : tuple of str
        The checks :meth:`trajectory_checks` judges again on a simulation
        (what ``[expected]`` declares after the simulation).
    measures_gaps : bool
        Whether the family's controllers measure the gaps between vehicles
        (the observability check then counts them as outputs, e.g. flocking).
    batches_repetitions : bool
        Whether the family's controllers have a batched law, so that the
        repetitions of a strategy run as one batch
        (:func:`trainctl.run.repetitions.run_repetitions`); the budget then
        prices every run after the first at a fraction of it.

    Examples
    --------
    >>> from trainctl.registry import get_family
    >>> isinstance(get_family("lqr"), FamilyHooks)
    True
    """

    claims_source: str = ""
    settings_labels: Mapping[str, str] = MappingProxyType({})
    headline_checks: Mapping[str, str] = MappingProxyType({})
    trajectory_check_names: tuple[str, ...] = ()
    measures_gaps: bool = False
    batches_repetitions: bool = False

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
            Named from :attr:`trajectory_check_names`; empty by default.

        Examples
        --------
        >>> FamilyHooks().trajectory_checks(None, "any", None)
        []
        """
        return []

    def cost_horizons(self, settings: Any) -> tuple[int, int]:
        """The prediction and control horizons of what each step solves (1, 1 for none).

        Parameters
        ----------
        settings : object
            The family's ``[controller]`` settings.

        Returns
        -------
        (int, int)
            Prediction horizon P and control horizon M [steps]; the budget's
            ``work`` is steps × vehicles × P.

        Examples
        --------
        >>> FamilyHooks().cost_horizons(None)
        (1, 1)
        """
        return 1, 1

    def design_cost(self, scenario: Scenario, settings: Any,
                    strategies: Sequence[str]) -> DesignCost | None:
        """The cost of the family's design and review beyond the shared model's, or None.

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        settings : object
            The family's ``[controller]`` settings.
        strategies : sequence of str
            The family's strategies ``[simulation]`` names (without prefix).

        Returns
        -------
        DesignCost or None
            None when negligible (the default).

        Examples
        --------
        >>> FamilyHooks().design_cost(None, None, ()) is None
        True
        """
        return None

    def strategy_seconds(self, run: StrategyRun) -> float:
        """Seconds to build one strategy's controller and simulate ``run.samples`` samples.

        Parameters
        ----------
        run : StrategyRun
            The strategy's simulation as the budget sees it.

        Returns
        -------
        float
            Time [s], the plant's included. The default prices an explicit
            law stepped at its control interval
            (:func:`~trainctl.controllers.continuous.cost.law_seconds`).

        Examples
        --------
        >>> from trainctl.scenario import load_scenario
        >>> run = StrategyRun(scenario=load_scenario("crh2-potential"), settings=None,
        ...                   strategy="consensus", samples=10, sample_time=0.05,
        ...                   interval=0.05, substeps=1, plant_seconds=1e-4)
        >>> FamilyHooks().strategy_seconds(run) > 0.5
        True
        """
        from trainctl.controllers.continuous.cost import law_seconds

        return law_seconds(run)

    def claims(self, run: Any) -> Sequence[Claim]:
        """The published claims this run decides, with trainctl's numbers and verdicts.

        Parameters
        ----------
        run : AnalysisRun
            The analysis run (:class:`trainctl.run.AnalysisRun`): design,
            simulations, repetitions.

        Returns
        -------
        sequence of Claim
            Empty by default.

        Examples
        --------
        >>> FamilyHooks().claims(None)
        ()
        """
        return ()

    def claim_figures(self, data: Any,
                      make: Callable[..., ReportFigure]) -> Sequence[ReportFigure]:
        """Figures of the report that illustrate the family's claims (after the time series).

        Parameters
        ----------
        data : ReportData
            The report data (:class:`trainctl.report.ReportData`), its claims
            in ``data.results["claims"]``.
        make : callable
            Turns a matplotlib figure into a report figure
            (:func:`trainctl.report.figures.encode`).

        Returns
        -------
        sequence of ReportFigure
            Empty by default.

        Examples
        --------
        >>> FamilyHooks().claim_figures(None, print)
        ()
        """
        return ()

    def certificates(self) -> Sequence[Certificate]:
        """Design checks of the family that a sweep sets against simulated outcomes.

        Returns
        -------
        sequence of Certificate
            Empty by default.

        Examples
        --------
        >>> FamilyHooks().certificates()
        ()
        """
        return ()


def family_hook(family: Any, name: str) -> Any:
    """``family``'s hook ``name``, or the default one for a family without it.

    Parameters
    ----------
    family : ControllerFamily
        A family (:func:`trainctl.registry.get_family`).
    name : str
        A hook of :class:`FamilyHooks`: a method or an attribute.

    Returns
    -------
    object
        The bound method, or the attribute's value.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> toy = SimpleNamespace(name="toy", claims_source="A paper")
    >>> family_hook(toy, "cost_horizons")(None), family_hook(toy, "claims_source")
    ((1, 1), 'A paper')
    >>> dict(family_hook(toy, "headline_checks"))
    {}
    """
    default = getattr(FamilyHooks, name)
    value = getattr(family, name, None)
    if callable(default):
        return value if callable(value) else partial(default, family)
    return default if value is None else value
