# The glue every controller family shares: its vocabulary, lazy schema and checks, report defaults.
"""A base for controller families (:class:`FamilyBase`), see :mod:`trainctl.registry`.

A family states its vocabulary as class attributes (``name``, ``title``,
``strategies``, ``check_names``, ``report_partial``), names its settings
schema and its checks function by dotted path (imported on first use, so
that importing a family imports no solver), and writes its design (the
private ``_design``), its controller (:meth:`FamilyBase.make`) and its
closed loop (:meth:`FamilyBase.closed_loop`). The report defaults are an
empty section with no figures. The two type parameters are the family's
design and settings classes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from importlib import import_module
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

from trainctl.controllers.hooks import FamilyHooks

if TYPE_CHECKING:
    import control as ct

    from trainctl.analysis.check import Check
    from trainctl.controllers.base import Controller
    from trainctl.design import DesignModel
    from trainctl.report.figures import ReportFigure
    from trainctl.scenario import Scenario

__all__ = ["DesignT", "FamilyBase", "SettingsT", "import_path"]

DesignT = TypeVar("DesignT")
"""The family's design class."""

SettingsT = TypeVar("SettingsT")
"""The family's settings class (the schema of its ``[controller]`` table)."""


def import_path(path: str) -> Any:
    """The object a ``"package.module:name"`` path names, imported on first use.

    Parameters
    ----------
    path : str
        ``"<module>:<attribute>"``.

    Returns
    -------
    object
        The module's attribute.

    Examples
    --------
    >>> import_path("trainctl.controllers.lqr.settings:LQRSettings").__name__
    'LQRSettings'
    """
    module, _, attribute = path.partition(":")
    return getattr(import_module(module), attribute)


class FamilyBase(FamilyHooks, Generic[DesignT, SettingsT]):
    """The shared part of a controller family (:class:`~trainctl.registry.ControllerFamily`).

    A subclass sets the class attributes below and writes ``_design``,
    :meth:`make` and :meth:`closed_loop` (and, for a report section,
    :meth:`report_data` and :meth:`report_figures`); the optional hooks
    (cost, claims, certificates) and their defaults come from
    :class:`~trainctl.controllers.hooks.FamilyHooks`.

    Attributes
    ----------
    name : str
        Registry name, the value of ``[controller] family``.
    title : str
        Display name.
    strategies : tuple of str
        Its strategy names.
    check_names : tuple of str
        Names of the checks :meth:`checks` returns, in order.
    report_partial : str
        Jinja source of the family's report section ("" for none).
    settings_path : str
        ``"module:Class"`` of the settings schema (:attr:`settings`).
    checks_path : str
        ``"module:function"`` of the checks, ``function(design) -> list[Check]``.

    Examples
    --------
    >>> from trainctl.registry import ControllerFamily, get_family
    >>> family = get_family("potential")
    >>> isinstance(family, FamilyBase), isinstance(family, ControllerFamily)
    (True, True)
    >>> family.settings.__name__
    'PotentialSettings'
    """

    name: ClassVar[str]
    title: ClassVar[str]
    strategies: ClassVar[tuple[str, ...]]
    check_names: ClassVar[tuple[str, ...]]
    report_partial: ClassVar[str] = ""
    settings_path: ClassVar[str]
    checks_path: ClassVar[str]

    @property
    def settings(self) -> type[SettingsT]:
        """The schema of the family's ``[controller]`` table (imported on first use)."""
        schema: type[SettingsT] = import_path(self.settings_path)
        return schema

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
        return self._design(scenario, model, settings)

    def _design(self, scenario: Scenario, model: DesignModel, settings: SettingsT) -> DesignT:
        raise NotImplementedError(f"{type(self).__name__} does not build a design")

    def make(self, design: DesignT, strategy: str) -> Controller:
        """A controller for one strategy, ready to ``step``.

        Parameters
        ----------
        design : DesignT
            The family's design, from :meth:`design`.
        strategy : str
            One of :attr:`strategies`; it names the controller.

        Returns
        -------
        Controller
            A fresh controller following the
            :class:`~trainctl.controllers.base.Controller` protocol.
        """
        raise NotImplementedError(f"{type(self).__name__} makes no controller")

    def checks(self, design: DesignT) -> list[Check]:
        """The family's design checks (:attr:`checks_path`).

        Parameters
        ----------
        design : DesignT
            The family's design, from :meth:`design`.

        Returns
        -------
        list of Check
            One check per name in :attr:`check_names`, in that order.
        """
        checks: list[Check] = import_path(self.checks_path)(design)
        return checks

    def closed_loop(self, design: DesignT, strategy: str) -> ct.StateSpace | None:
        """The linear closed loop of a strategy (discrete or continuous), or None.

        Parameters
        ----------
        design : DesignT
            The family's design, from :meth:`design`.
        strategy : str
            One of :attr:`strategies`; it names the system.

        Returns
        -------
        control.StateSpace or None
            The linear closed loop from the disturbances ``w[i]`` [m/s²] to
            the family's outputs; None where the loop is not linear.
        """
        return None

    def report_data(self, design: DesignT) -> dict[str, Any]:
        """JSON-safe data for the family's report section and figures (none by default).

        Parameters
        ----------
        design : DesignT
            The family's design, from :meth:`design`.

        Returns
        -------
        dict of str to object
            The ``data`` context of :attr:`report_partial` and the input of
            :meth:`report_figures`.
        """
        return {}

    def report_figures(self, data: Mapping[str, Any]) -> Sequence[ReportFigure]:
        """The family's figures, drawn from ``data`` (none by default).

        Parameters
        ----------
        data : mapping of str to object
            The family's :meth:`report_data` (possibly read back from JSON).

        Returns
        -------
        sequence of ReportFigure
            The figures, each placed by its ``section``; may be empty.
        """
        return []
