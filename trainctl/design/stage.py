# Design of every controller family of a scenario, on the shared design model.
"""The :class:`Design` of a run and how strategies name their family."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from trainctl.design.model import DesignModel, build_model
from trainctl.exceptions import ScenarioError

if TYPE_CHECKING:
    import control as ct

    from trainctl.scenario import Scenario

__all__ = ["Design", "build_design", "law_interval", "scenario_controllers", "split_strategy",
           "strategy_interval"]


@dataclass(frozen=True, kw_only=True, eq=False)
class Design:
    """Everything designed for one scenario, built once per run.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        The linear models (one linearisation, one discretisation).
    families : mapping of str to object
        Each controller family's design, by family name (primary family
        first); empty without a ``[controller]`` section.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> design = build_design(load_scenario("crh2-potential"))
    >>> list(design.families)  # primary family first
    ['potential', 'mpc', 'lqr']
    >>> type(design.family("mpc")).__name__, design.resolve("mpc.ndmpc")
    ('MPCFamilyDesign', ('mpc', 'ndmpc'))
    >>> design.closed_loop("consensus").dt  # a continuous-time law
    0
    """

    scenario: Scenario
    model: DesignModel
    families: Mapping[str, Any] = field(default_factory=dict)

    def family(self, name: str) -> Any:
        """The design of family ``name``.

        Parameters
        ----------
        name : str
            A family of the scenario.

        Returns
        -------
        object
            The family's design object.

        Raises
        ------
        ScenarioError
            If the scenario has no controller of that family.
        """
        if name not in self.families:
            have = ", ".join(self.families) or "none"
            raise ScenarioError(f"{self.scenario.source}: no [controller] of family {name!r} "
                                f"(the scenario has: {have}).")
        return self.families[name]

    def closed_loop(self, strategy: str) -> ct.StateSpace | None:
        """The linear closed loop of a simulation strategy (None where it is not linear).

        The family's ``closed_loop()``: a ``control.StateSpace``, discrete for
        sampled controllers (MPC, LQR) and continuous for continuous-time
        laws (potential, flocking), from
        the specific-force disturbances ``w[i]`` [m/s²] to the speed
        deviations ``v[i]`` [m/s], the coupler forces ``f[i]`` [kN] and the
        spacing deviations ``d[i]`` [m] (the elongation deviation of coupler
        i, the gap deviation of a virtual link), in that order, which every
        generic analysis (poles, frequency responses, norms, string
        stability) takes.

        Parameters
        ----------
        strategy : str
            A name from ``[simulation] strategies`` (or ``"family.strategy"``).

        Returns
        -------
        control.StateSpace or None
            The closed loop.

        Examples
        --------
        >>> from trainctl.scenario import load_scenario
        >>> loop = build_design(load_scenario("crh2-dmpc")).closed_loop("ndmpc")
        >>> loop.dt, loop.ninputs, loop.noutputs
        (20.0, 4, 10)
        """
        from trainctl.registry import get_family

        family, name = self.resolve(strategy)
        return get_family(family).closed_loop(self.family(family), name)

    def resolve(self, strategy: str) -> tuple[str, str]:
        """The (family, strategy) a simulation strategy name stands for (:func:`split_strategy`).

        Parameters
        ----------
        strategy : str
            A name from ``[simulation] strategies``: a bare strategy of the
            primary family, or ``"family.strategy"``.

        Returns
        -------
        (str, str)
            Family name and the family's strategy name.

        Raises
        ------
        ScenarioError
            If the scenario has no controller, no such family or the family
            no such strategy.
        """
        return split_strategy(self.scenario, strategy)


def scenario_controllers(scenario: Scenario) -> dict[str, Any]:
    """The scenario's controller settings by family name, primary family first.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.

    Returns
    -------
    dict of str to settings
        Empty without a ``[controller]`` section.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> ctl = scenario_controllers(load_scenario("crh2-potential"))
    >>> list(ctl), type(ctl["lqr"]).__name__
    (['potential', 'mpc', 'lqr'], 'LQRSettings')
    >>> scenario_controllers(load_scenario("heavy-haul-hinf"))  # no [controller]
    {}
    """
    return dict(scenario.controllers)


def split_strategy(scenario: Scenario, strategy: str) -> tuple[str, str]:
    """The family and the family's strategy a simulation strategy name stands for.

    A bare name (``"ndmpc"``) is a strategy of the primary family; another
    family's strategy is written ``"family.strategy"`` (``"lqr.centralised"``).

    Parameters
    ----------
    scenario : Scenario
        The scenario (its controllers).
    strategy : str
        A name from ``[simulation] strategies``.

    Returns
    -------
    (str, str)
        Family name and strategy name.

    Raises
    ------
    ScenarioError
        If the scenario has no such family or the family no such strategy.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("crh2-potential")
    >>> split_strategy(sc, "consensus"), split_strategy(sc, "lqr.centralised")
    (('potential', 'consensus'), ('lqr', 'centralised'))
    >>> try:
    ...     split_strategy(sc, "lqr.nash")
    ... except ScenarioError as err:
    ...     print(err)
    builtin:crh2-potential: family 'lqr' has no strategy 'nash' (it has centralised, decentralised).
    """
    from trainctl.registry import get_family

    controllers = scenario_controllers(scenario)
    if not controllers:
        raise ScenarioError(f"{scenario.source}: strategy {strategy!r} needs a [controller].")
    family, sep, name = strategy.partition(".")
    if not sep:
        family, name = next(iter(controllers)), strategy
    if family not in controllers:
        raise ScenarioError(f"{scenario.source}: strategy {strategy!r} names family {family!r}, "
                            f"which the scenario has no [controller] for.")
    if name not in get_family(family).strategies:
        raise ScenarioError(f"{scenario.source}: family {family!r} has no strategy {name!r} "
                            f"(it has {', '.join(get_family(family).strategies)}).")
    return family, name


def build_design(scenario: Scenario, *, model: DesignModel | None = None) -> Design:
    """Build the design model and every family's design for ``scenario``.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.
    model : DesignModel or None
        The design model when already built (:func:`build_model`).

    Returns
    -------
    Design
        The models and the families' designs.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> design = build_design(load_scenario("crh2-dmpc"))
    >>> list(design.families), design.family("mpc").mpc.prediction_horizon
    (['mpc'], 4)
    """
    from trainctl.registry import get_family

    if model is None:
        model = build_model(scenario)
    families = {name: get_family(name).design(scenario, model, settings)
                for name, settings in scenario_controllers(scenario).items()}
    return Design(scenario=scenario, model=model, families=families)


def strategy_interval(scenario: Scenario, strategy: str) -> float:
    """The interval [s] at which a simulation strategy's controller runs (its results' ``dt``).

    A family whose settings have a ``control_interval`` (a continuous-time
    law sampled faster than the model, e.g. the potential and flocking
    families) runs at it when given; every other controller at
    ``[model] sample_time``.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    strategy : str
        A name from ``[simulation] strategies``.

    Returns
    -------
    float
        The interval [s].

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-potential")
    >>> strategy_interval(scenario, "consensus"), strategy_interval(scenario, "mpc.ndmpc")
    (0.002, 0.05)
    """
    family, _ = split_strategy(scenario, strategy)
    return law_interval(scenario.controllers[family], scenario.model.sample_time)


def law_interval(settings: Any, sample_time: float) -> float:
    """The interval [s] a family's law runs at: its ``control_interval``, else the sample time.

    The one rule for every controller: a family whose settings have a
    ``control_interval`` (a continuous-time law sampled faster than the
    model) runs at it when given; every other at ``[model] sample_time``.

    Parameters
    ----------
    settings : object
        The family's settings, with ``control_interval`` [s] or None, or
        without that attribute.
    sample_time : float
        The model's sample time [s].

    Returns
    -------
    float
        The interval [s].

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> law_interval(SimpleNamespace(control_interval=0.1), 0.5)
    0.1
    >>> law_interval(SimpleNamespace(control_interval=None), 0.5), law_interval(object(), 0.5)
    (0.5, 0.5)
    """
    return float(getattr(settings, "control_interval", None) or sample_time)
