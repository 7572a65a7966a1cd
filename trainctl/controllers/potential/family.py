# The potential family as a registry entry: Zhao & Wang's consensus law with a pair potential.
"""The potential family object (:data:`FAMILY`), see :mod:`trainctl.registry`.

One strategy, ``"consensus"``: Zhao & Wang's (CCDC 2017) four-term law
(:mod:`trainctl.controllers.potential.law`) sampled at the family's
``control_interval``, about the cruise feedforward, clipped to the envelope.
Its linear closed loop is continuous (dt = 0): :meth:`PotentialFamily.closed_loop`
returns it with the inputs ``w[i]`` (specific-force disturbances [m/s²])
and the outputs ``v[i]`` [m/s], ``f[i]`` [kN] and ``d[i]`` [m] (spacing
deviations); generic analyses that need a discrete loop sample it
(:func:`trainctl.analysis.loops.as_discrete`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.hooks import FamilyHooks

if TYPE_CHECKING:
    import control as ct

    from trainctl.analysis.check import Check
    from trainctl.controllers.potential.controller import PotentialController
    from trainctl.controllers.potential.law import PotentialLaw
    from trainctl.design import DesignModel
    from trainctl.report.figures import ReportFigure
    from trainctl.scenario import Scenario
    from trainctl.sim import SimulationResult

__all__ = ["CHECK_NAMES", "FAMILY", "GRAPH_USAGE", "STRATEGIES", "PotentialDesign",
           "PotentialFamily", "design_potential"]

STRATEGIES = ("consensus",)
"""The potential family's one strategy."""

CHECK_NAMES = ("potential_closed_loop", "potential_lyapunov", "potential_spacing_bound",
               "potential_sampling", "potential_position", "potential_linearisation")
"""The potential family's design checks (:mod:`trainctl.controllers.potential.checks`)."""

Array = NDArray[np.float64]

PARTIAL = """\
<p>Zhao &amp; Wang's four-term law (position pinning, speed feedback, velocity consensus over
the communication graph, gradient of the {{ data.potential }} pair potential between coupled
cars) about the cruise feedforward, sampled every {{ data.control_interval }} s{% if not
data.input_bounds %} (no saturation){% endif %}.</p>
<table class="quantities">
  <thead><tr><th scope="col">Quantity</th><th scope="col">Value</th></tr></thead>
  <tbody>
{% for row in data.rows %}
    <tr><td>{{ row.name }}</td><td class="num">{{ row.value }}</td></tr>
{% endfor %}
  </tbody>
</table>
"""

GRAPH_USAGE = ("The law's velocity consensus runs over these links (consensus gain × a_ij); "
               "its position pinning acts on the cars the reference pins (stiffness "
               "position_gain × p_i × the mean coupler stiffness).")
"""The closing sentence of the graph figure's caption: what the law does with the graph."""


@dataclass(frozen=True, kw_only=True, eq=False)
class PotentialDesign:
    """The potential family's design of one scenario.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        The run's design model.
    settings : PotentialSettings
        The family's settings.
    law : PotentialLaw
        The law's SI gains and pair potential.
    control_interval : float
        T_c [s].
    A_open, B_open : ndarray
        Continuous open loop on ξ = [v̂ (n), z (n-1), p] [1/s], inputs û [N].
    A_cl : ndarray
        Continuous linear closed loop [1/s], (2n, 2n).
    initial_errors : ndarray
        ξ(0) of the scenario's ``[simulation]`` (zeros without one).

    Examples
    --------
    The eight cars of ``crh2-potential``: ξ = [v̂ (8), z (7), p]:

    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-potential")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["potential"])
    >>> design.A_cl.shape, design.control_interval, design.pinned  # T_c [s]
    ((16, 16), 0.002, True)
    >>> design.initial_errors[:4].tolist()  # speed errors [m/s]
    [1.0, -1.0, 1.0, -1.0]
    """

    scenario: Scenario
    model: DesignModel
    settings: Any
    law: PotentialLaw
    control_interval: float
    A_open: Array
    B_open: Array
    A_cl: Array
    initial_errors: Array

    @property
    def pinned(self) -> bool:
        """True when some car is pinned to its reference position (position_gain > 0)."""
        return bool(np.any(self.law.pinning > 0))

    def sampled_matrix(self, interval: float | None = None) -> Array:
        """The closed loop with the law held over each interval (exact ZOH of the plant).

        Parameters
        ----------
        interval : float or None
            T [s]; None: :attr:`control_interval`.

        Returns
        -------
        ndarray
            Φ + Γ F, (2n, 2n) [-].
        """
        from trainctl.controllers.continuous.sampled import held_loop

        T = self.control_interval if interval is None else float(interval)
        return held_loop(self.A_open, self.B_open, self.law.feedback(), T)

    @cached_property
    def certificate(self) -> tuple[str, Array] | None:
        """("closed_form", "lmi" or "equation", P) on [v̂, z, p] ([v̂, z] unpinned); None if none."""
        from trainctl.controllers.potential.checks import (
            LMI_MAX_STATES,
            closed_form_certificate,
            lyapunov_equation,
            lyapunov_lmi,
        )

        keep = self.A_cl.shape[0] - (0 if self.pinned else 1)
        P = closed_form_certificate(self)
        if P is not None:
            return "closed_form", P[:keep, :keep]
        if keep > LMI_MAX_STATES:
            P = lyapunov_equation(self.A_cl[:keep, :keep])
            return None if P is None else ("equation", P)
        P = lyapunov_lmi(self.A_cl[:keep, :keep])
        return None if P is None else ("lmi", P)


def design_potential(scenario: Scenario, model: DesignModel, settings: Any) -> PotentialDesign:
    """The law's gains and its linear closed loop.

    Parameters
    ----------
    scenario : Scenario
        The scenario (train, ``[communication]`` graph, ``[simulation]``).
    model : DesignModel
        Its design model.
    settings : PotentialSettings
        The family's settings.

    Returns
    -------
    PotentialDesign
        The design.

    Raises
    ------
    ScenarioError
        If the simulation's duration is not a whole multiple of the control
        interval, or the train cannot carry the law
        (:func:`~trainctl.controllers.potential.law.law_of`).

    Examples
    --------
    >>> from trainctl.controllers.potential.settings import PotentialSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc-well-sampled")
    >>> d = design_potential(scenario, build_model(scenario), PotentialSettings())
    >>> d.A_cl.shape, d.control_interval
    ((8, 8), 0.05)
    """
    from trainctl.controllers.continuous.sampled import control_interval, initial_errors
    from trainctl.controllers.potential.law import closed_loop_matrices, law_of

    T = control_interval(scenario, model, settings, "potential")
    law = law_of(scenario, settings)
    A, B, A_cl = closed_loop_matrices(model, law)
    return PotentialDesign(scenario=scenario, model=model, settings=settings, law=law,
                           control_interval=T, A_open=A, B_open=B, A_cl=A_cl,
                           initial_errors=initial_errors(scenario))


class PotentialFamily(FamilyHooks):
    """Zhao & Wang's potential-function consensus law (seed 001).

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-potential")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["potential"])
    >>> FAMILY.name, FAMILY.check_names[0]
    ('potential', 'potential_closed_loop')
    >>> ctl = FAMILY.make(design, FAMILY.strategies[0])
    >>> ctl.dt  # the law runs every control interval [s]
    0.002
    """

    name = "potential"
    title = "Potential-function consensus"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    trajectory_check_names = ("potential_linearisation",)
    """The checks :meth:`trajectory_checks` judges again on a simulation."""
    report_partial = PARTIAL

    @property
    def settings(self) -> type[Any]:
        """The schema of the family's ``[controller]`` table."""
        from trainctl.controllers.potential.settings import PotentialSettings

        return PotentialSettings

    def design(self, scenario: Scenario, model: DesignModel, settings: Any) -> PotentialDesign:
        """See :func:`design_potential`.

        Parameters
        ----------
        scenario : Scenario
            The scenario (train, ``[communication]`` graph, ``[simulation]``).
        model : DesignModel
            Its design model.
        settings : PotentialSettings
            The family's settings.

        Returns
        -------
        PotentialDesign
            The law's SI gains, pair potential, control interval and linear
            closed loop.
        """
        return design_potential(scenario, model, settings)

    def make(self, design: PotentialDesign, strategy: str) -> PotentialController:
        """The controller: the law sampled every ``control_interval``.

        Parameters
        ----------
        design : PotentialDesign
            The family's design.
        strategy : str
            The strategy, ``"consensus"``; it names the controller.

        Returns
        -------
        PotentialController
            The law about the cruise feedforward, dt = ``control_interval``
            [s], clipped to the envelope if the settings' ``input_bounds``.
        """
        from trainctl.controllers.potential.controller import PotentialController

        return PotentialController(design.scenario.train, design.law,
                                   dt=design.control_interval,
                                   input_bounds=design.settings.input_bounds, name=strategy)

    def checks(self, design: PotentialDesign) -> list[Check]:
        """The six checks of :mod:`trainctl.controllers.potential.checks`.

        Parameters
        ----------
        design : PotentialDesign
            The family's design.

        Returns
        -------
        list of Check
            In :data:`CHECK_NAMES` order.
        """
        from trainctl.controllers.potential.checks import potential_checks

        return potential_checks(design)

    def trajectory_checks(self, design: PotentialDesign, strategy: str,
                          result: SimulationResult) -> list[Check]:
        """``potential_linearisation`` judged on the simulated trajectory.

        Parameters
        ----------
        design : PotentialDesign
            The family's design.
        strategy : str
            The simulated strategy's name.
        result : SimulationResult
            Its simulation on the nonlinear plant.

        Returns
        -------
        list of Check
            The ``potential_linearisation`` check, replacing the design
            review's check of that name.
        """
        from trainctl.controllers.potential.checks import trajectory_checks

        return trajectory_checks(design, strategy, result)

    def closed_loop(self, design: PotentialDesign, strategy: str) -> ct.StateSpace:
        """ξ̇ = A_cl ξ + B_w w (continuous); outputs v [m/s], f [kN], d [m].

        Parameters
        ----------
        design : PotentialDesign
            The family's design.
        strategy : str
            The strategy, ``"consensus"``; it names the system.

        Returns
        -------
        control.StateSpace
            The continuous linear closed loop on ξ = [v̂, z, p], inputs the
            specific-force disturbances ``w[i]`` [m/s²], outputs ``v[i]``
            [m/s], ``f[i]`` [kN] and ``d[i]`` [m].
        """
        import control as ct

        n = design.law.n
        rows, outputs = design.model.loop_outputs()
        C = np.hstack([rows, np.zeros((rows.shape[0], 1))])  # p, the head's position error
        return ct.ss(design.A_cl, design.B_open * design.law.mass[None, :], C, 0,
                     states=design.scenario.train.state_labels() + ["p"],
                     inputs=[f"w[{i}]" for i in range(n)], outputs=outputs,
                     name=f"potential_{strategy}")

    def report_data(self, design: PotentialDesign) -> dict[str, Any]:
        """Gains, the closed-loop spectrum sampled at the model's sample time and the graph.

        The ``[communication]`` graph is stored under ``graph``
        (:func:`trainctl.plots.graph_figures.graph_report_data`), JSON-safe.

        Parameters
        ----------
        design : PotentialDesign
            The family's design.

        Returns
        -------
        dict
            JSON-safe: ``spectra`` (the closed-loop eigenvalues mapped to z =
            exp(λ T_s) with the model's sample time, as [re, im] pairs),
            ``rows`` (name/value rows of the gains table), ``potential``,
            ``control_interval`` [s] (as text), ``input_bounds`` and ``graph``.
        """
        from trainctl.plots.graph_figures import graph_report_data

        lam = np.linalg.eigvals(design.A_cl).astype(complex)
        z = np.exp(lam * design.model.settings.sample_time)
        s, law = design.settings, design.law
        rows = [("Pair potential", s.potential), ("κ [1/s²]", f"{s.kappa:g}"),
                ("Pinning stiffness, largest [kN/m]", f"{float(np.max(law.pinning)) / 1e3:.4g}"),
                ("Speed gain [1/s]", f"{s.speed_gain:g}"),
                ("Consensus gain [1/s]", f"{s.consensus_gain:g}"),
                ("Slowest mode, max Re λ [1/s]", f"{float(np.max(lam.real)):.4g}"),
                ("Fastest mode, max |λ| [rad/s]", f"{float(np.max(np.abs(lam))):.4g}")]
        return {"spectra": {"potential consensus": [[float(x.real), float(x.imag)] for x in z]},
                "rows": [{"name": a, "value": b} for a, b in rows],
                "potential": s.potential, "control_interval": f"{design.control_interval:g}",
                "input_bounds": bool(s.input_bounds),
                "graph": graph_report_data(design.scenario.graph())}

    def report_figures(self, data: Mapping[str, Any]) -> Sequence[ReportFigure]:
        """The communication graph, in the family's section (its spectrum joins the eigenvalue map).

        Drawn from ``data["graph"]``
        (:func:`trainctl.plots.graph_figures.graph_figure`).

        Parameters
        ----------
        data : mapping
            The family's :meth:`report_data`.

        Returns
        -------
        list of ReportFigure
            One figure, the communication graph.
        """
        from trainctl.plots.graph_figures import graph_figure

        return [graph_figure(data["graph"], family=self.name, usage=GRAPH_USAGE)]


FAMILY = PotentialFamily()
"""The registry entry of the potential family."""
