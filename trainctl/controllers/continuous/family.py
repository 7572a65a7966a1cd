# The base of the continuous-time law families: their design's common part and their glue.
"""A base for the families of a continuous-time law sampled at a control interval.

:class:`SampledDesign` holds what every such design has (the scenario, the
design model, the settings, the law, the control interval and the law's
continuous loops, :class:`~trainctl.controllers.continuous.loops.LoopMatrices`)
and the loop held over an interval; :class:`ContinuousFamily` makes the
controller, closes the linear loop and draws the ``[communication]`` graph
for every such family. A family then writes its law, its design function,
its checks and its settings (``tests/test_continuous_base.py`` has a
minimal one); its report partial may end with :data:`QUANTITIES_TABLE`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.family import FamilyBase, SettingsT, import_path

if TYPE_CHECKING:
    import control as ct

    from trainctl.controllers.base import Controller
    from trainctl.controllers.continuous.loops import LoopMatrices
    from trainctl.design import DesignModel
    from trainctl.report.figures import ReportFigure
    from trainctl.scenario import Scenario

__all__ = ["QUANTITIES_TABLE", "ContinuousFamily", "SampledDesign"]

Array = NDArray[np.float64]

LawT = TypeVar("LawT")

QUANTITIES_TABLE = """\
<table class="quantities">
  <thead><tr><th scope="col">Quantity</th><th scope="col">Value</th></tr></thead>
  <tbody>
{% for row in data.rows %}
    <tr><td>{{ row.name }}</td><td class="num">{{ row.value }}</td></tr>
{% endfor %}
  </tbody>
</table>
"""
"""The end of a family's ``report_partial``: its ``data.rows`` (name, value) as a table."""


@dataclass(frozen=True, kw_only=True, eq=False)
class SampledDesign(Generic[SettingsT, LawT]):
    """What the design of a sampled continuous-time law holds.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        The run's design model.
    settings : SettingsT
        The family's settings (with ``input_bounds``).
    law : LawT
        The law's SI gains, with ``feedback()``, its linear gain F (û = F x).
    control_interval : float
        T_c [s].
    loops : LoopMatrices
        The law's continuous loops.

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.potential.family import FAMILY
    >>> scenario = load_scenario("crh2-potential")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["potential"])
    >>> isinstance(design, SampledDesign), design.A_cl is design.loops.A_cl
    (True, True)
    """

    scenario: Scenario
    model: DesignModel
    settings: SettingsT
    law: LawT
    control_interval: float
    loops: LoopMatrices

    @property
    def A_open(self) -> Array:
        """The continuous open loop [1/s] (:attr:`loops`)."""
        return self.loops.A_open

    @property
    def B_open(self) -> Array:
        """Its input matrix, inputs û [N] (:attr:`loops`)."""
        return self.loops.B_open

    @property
    def A_cl(self) -> Array:
        """The continuous delay-free linear closed loop [1/s] (:attr:`loops`)."""
        return self.loops.A_cl

    def _feedback(self) -> Array:
        """The law's linear gain F [N per unit of state] on the design state."""
        gain: NDArray[np.float64] = self.law.feedback()  # type: ignore[attr-defined]
        return gain

    def sampled_matrix(self, interval: float | None = None) -> Array:
        """The delay-free loop with the law held over each interval (exact ZOH of the plant).

        Parameters
        ----------
        interval : float or None
            T [s]; None: :attr:`control_interval`.

        Returns
        -------
        ndarray
            Φ + Γ F, (N, N) [-]
            (:func:`~trainctl.controllers.continuous.sampled.held_loop`).
        """
        from trainctl.controllers.continuous.sampled import held_loop

        T = self.control_interval if interval is None else float(interval)
        return held_loop(self.loops.A_open, self.loops.B_open, self._feedback(), T)


DesignT = TypeVar("DesignT", bound=SampledDesign[Any, Any])


class ContinuousFamily(FamilyBase[DesignT, SettingsT]):
    """A family of a continuous-time law sampled at its control interval.

    On top of :class:`~trainctl.controllers.family.FamilyBase` a subclass
    names its controller (``controller_path``, a class called as
    ``cls(train, law, dt=, input_bounds=, name=)``) and says whether its
    loop carries the head's position error (``head_position``), whether its
    links are virtual (``force_outputs = False``: no coupler forces) and what
    its law does with the ``[communication]`` graph (``graph_usage``; "" for
    no graph figure).

    Attributes
    ----------
    controller_path : str
        ``"module:Class"`` of the controller.
    head_position : bool
        The closed loop's state ends with p, the head's position error.
    force_outputs : bool
        The closed loop has the coupler-force outputs ``f[i]`` [kN].
    graph_usage : str
        The closing sentence of the graph figure's caption ("" for none).

    Examples
    --------
    >>> from trainctl.registry import get_family
    >>> [isinstance(get_family(f), ContinuousFamily) for f in ("flocking", "hinf", "mpc")]
    [True, True, False]
    """

    controller_path: ClassVar[str]
    head_position: ClassVar[bool] = False
    force_outputs: ClassVar[bool] = True
    graph_usage: ClassVar[str] = ""

    def _controller_options(self, design: DesignT) -> dict[str, Any]:
        """Further keyword arguments of the controller (none by default)."""
        return {}

    def make(self, design: DesignT, strategy: str) -> Controller:
        """The controller: the law sampled every ``control_interval``.

        Parameters
        ----------
        design : DesignT
            The family's design.
        strategy : str
            One of :attr:`strategies`; it names the controller.

        Returns
        -------
        Controller
            The law about its feedforward, dt = ``control_interval`` [s],
            clipped to the envelope if the settings' ``input_bounds``.
        """
        controller = import_path(self.controller_path)
        made: Controller = controller(design.scenario.train, design.law,
                                      dt=design.control_interval,
                                      input_bounds=design.settings.input_bounds, name=strategy,
                                      **self._controller_options(design))
        return made

    def closed_loop(self, design: DesignT, strategy: str) -> ct.StateSpace:
        """ẋ = A_cl x + B_w w (continuous, dt = 0); outputs v [m/s], f [kN], d [m].

        Parameters
        ----------
        design : DesignT
            The family's design.
        strategy : str
            One of :attr:`strategies`; it names the system ``<family>_<strategy>``.

        Returns
        -------
        control.StateSpace
            The continuous linear closed loop on the design state (with p,
            the head's position error, last when ``head_position``), inputs
            the specific-force disturbances ``w[i]`` [m/s²], outputs ``v[i]``
            [m/s], ``f[i]`` [kN] (unless the links are virtual) and ``d[i]``
            [m].
        """
        import control as ct

        n = design.law.n
        rows, outputs = design.model.loop_outputs()
        if not self.force_outputs:
            keep = [k for k, label in enumerate(outputs) if not label.startswith("f[")]
            rows, outputs = rows[keep], [outputs[k] for k in keep]
        states = design.scenario.train.state_labels()
        C = rows
        if self.head_position:
            C = np.hstack([rows, np.zeros((rows.shape[0], 1))])  # p, the head's position error
            states = states + ["p"]
        return ct.ss(design.A_cl, design.B_open * design.law.mass[None, :], C, 0,
                     states=states, inputs=[f"w[{i}]" for i in range(n)], outputs=outputs,
                     name=f"{self.name}_{strategy}")

    def report_figures(self, data: Mapping[str, Any]) -> Sequence[ReportFigure]:
        """The communication graph, in the family's section (its spectrum joins the eigenvalue map).

        Drawn from ``data["graph"]``
        (:func:`trainctl.plots.graph_figures.graph_figure`) when the family
        has a ``graph_usage``; no figure otherwise.

        Parameters
        ----------
        data : mapping
            The family's :meth:`report_data`.

        Returns
        -------
        list of ReportFigure
            The communication graph, or nothing.
        """
        if not self.graph_usage:
            return []
        from trainctl.plots.graph_figures import graph_figure

        return [graph_figure(data["graph"], family=self.name, usage=self.graph_usage)]

