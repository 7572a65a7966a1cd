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

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.family import QUANTITIES_TABLE, ContinuousFamily, SampledDesign

if TYPE_CHECKING:
    from trainctl.analysis.check import Check
    from trainctl.controllers.potential.law import PotentialLaw  # noqa: F401 (a type argument)
    from trainctl.controllers.potential.settings import PotentialSettings
    from trainctl.design import DesignModel
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
""" + QUANTITIES_TABLE

GRAPH_USAGE = ("The law's velocity consensus runs over these links (consensus gain × a_ij); "
               "its position pinning acts on the cars the reference pins (stiffness "
               "position_gain × p_i × the mean coupler stiffness).")
"""The closing sentence of the graph figure's caption: what the law does with the graph."""


@dataclass(frozen=True, kw_only=True, eq=False)
class PotentialDesign(SampledDesign["PotentialSettings", "PotentialLaw"]):
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
    loops : LoopMatrices
        The continuous loops on ξ = [v̂ (n), z (n-1), p] [1/s], inputs û [N]:
        ``A_open``, ``B_open`` and the closed loop ``A_cl``, (2n, 2n).
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

    initial_errors: Array

    @property
    def pinned(self) -> bool:
        """True when some car is pinned to its reference position (position_gain > 0)."""
        return bool(np.any(self.law.pinning > 0))

    @cached_property
    def certificate(self) -> tuple[str, Array] | None:
        """("closed_form", "lmi" or "equation", P) on [v̂, z, p] ([v̂, z] unpinned); None if none."""
        from trainctl.controllers.potential.lyapunov import (
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


def design_potential(scenario: Scenario, model: DesignModel,
                     settings: PotentialSettings) -> PotentialDesign:
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
    from trainctl.controllers.continuous.loops import closed_loop_matrices
    from trainctl.controllers.continuous.sampled import control_interval, initial_errors
    from trainctl.controllers.potential.law import law_of

    T = control_interval(scenario, model, settings, "potential")
    law = law_of(scenario, settings)
    return PotentialDesign(scenario=scenario, model=model, settings=settings, law=law,
                           control_interval=T,
                           loops=closed_loop_matrices(model, law.feedback(), head_position=True),
                           initial_errors=initial_errors(scenario))


class PotentialFamily(ContinuousFamily[PotentialDesign, "PotentialSettings"]):
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
    claims_source = "Zhao & Wang 2017, the potential-function law"
    title = "Potential-function consensus"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    trajectory_check_names = ("potential_linearisation",)
    """The checks :meth:`trajectory_checks` judges again on a simulation."""
    report_partial = PARTIAL
    settings_path = "trainctl.controllers.potential.settings:PotentialSettings"
    checks_path = "trainctl.controllers.potential.checks:potential_checks"
    controller_path = "trainctl.controllers.potential.controller:PotentialController"
    head_position = True
    graph_usage = GRAPH_USAGE
    _design = staticmethod(design_potential)


    def claims(self, run: Any) -> list[Any]:
        """Seed 001's claims (:func:`~trainctl.controllers.potential.claims.potential_claims`).

        None when another family is primary.

        Parameters
        ----------
        run : AnalysisRun
            The analysis run.

        Returns
        -------
        list of Claim
            The claims the run decides; none when another family is primary.
        """
        from trainctl.controllers.potential.claims import potential_claims

        if next(iter(run.design.families), None) != self.name:
            return []
        return potential_claims(run)
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
        from trainctl.controllers.continuous.loops import report_spectrum
        from trainctl.plots.graph_figures import graph_report_data

        points, modes = report_spectrum(design.A_cl, design.model.settings.sample_time)
        s, law = design.settings, design.law
        rows = [("Pair potential", s.potential), ("κ [1/s²]", f"{s.kappa:g}"),
                ("Pinning stiffness, largest [kN/m]", f"{float(np.max(law.pinning)) / 1e3:.4g}"),
                ("Speed gain [1/s]", f"{s.speed_gain:g}"),
                ("Consensus gain [1/s]", f"{s.consensus_gain:g}"), *modes]
        return {"spectra": {"potential consensus": points},
                "rows": [{"name": a, "value": b} for a, b in rows],
                "potential": s.potential, "control_interval": f"{design.control_interval:g}",
                "input_bounds": bool(s.input_bounds),
                "graph": graph_report_data(design.scenario.graph())}


FAMILY = PotentialFamily()
"""The registry entry of the potential family."""
