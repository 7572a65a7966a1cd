# The flocking family as a registry entry: Olfati-Saber's algorithm for virtually coupled trains.
"""The flocking family object (:data:`FAMILY`), see :mod:`trainctl.registry`.

One strategy, ``"flocking"``: Olfati-Saber's (2006) Algorithm 2 on the gaps
of a virtually coupled formation (:mod:`trainctl.controllers.flocking.law`),
sampled at the family's ``control_interval``, about the cruise feedforward,
clipped to the envelope. Its linear closed loop is continuous (dt = 0):
:meth:`FlockingFamily.closed_loop` returns it with the inputs ``w[i]``
(specific-force disturbances [m/s²]) and the outputs ``v[i]`` [m/s] and
``d[i]`` [m] (gap deviations). Virtual links carry no force, so there are
no ``f[i]`` outputs. Generic analyses sample it
(:func:`trainctl.analysis.loops.as_discrete`).

The desired gap is the ``[train.coupler] gap`` (the plant measures the gap
deviation from it); ``desired_gap_m``, when given, must agree. With
``supervisor = true`` the controller carries the braking supervisor
(:mod:`~trainctl.controllers.flocking.supervisor`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.family import QUANTITIES_TABLE, ContinuousFamily, SampledDesign

if TYPE_CHECKING:
    from trainctl.analysis.check import Check
    from trainctl.controllers.flocking.law import FlockingLaw  # noqa: F401 (a type argument)
    from trainctl.controllers.flocking.settings import FlockingSettings
    from trainctl.design import DesignModel
    from trainctl.scenario import Scenario
    from trainctl.sim import SimulationResult

__all__ = ["CHECK_NAMES", "FAMILY", "GRAPH_USAGE", "STRATEGIES", "FlockingDesign",
           "FlockingFamily", "design_flocking"]

STRATEGIES = ("flocking",)
"""The flocking family's one strategy."""

CHECK_NAMES = ("flocking_parameters", "flocking_closed_loop", "flocking_sampling",
               "flocking_collision", "flocking_connectivity", "flocking_actuators",
               "flocking_braking_distance")
"""The flocking family's design checks (:mod:`trainctl.controllers.flocking.checks`)."""

Array = NDArray[np.float64]

PARTIAL = """\
<p>Olfati-Saber's flocking law on the gaps between the trains (pair potential, velocity
consensus weighted by the communication graph and the bump of the gap, navigation feedback)
about the cruise feedforward, sampled every {{ data.control_interval }} s{% if not
data.input_bounds %} (no saturation){% endif %}.</p>
""" + QUANTITIES_TABLE

GRAPH_USAGE = ("The law's velocity consensus runs over these links (consensus gain × a_ij × the "
               "bump of the gap); its pair potential acts on every consecutive pair and its "
               "navigation feedback on every train, whatever the links and the pinning.")
"""The closing sentence of the graph figure's caption: what the law does with the graph."""


@dataclass(frozen=True, kw_only=True, eq=False)
class FlockingDesign(SampledDesign["FlockingSettings", "FlockingLaw"]):
    """The flocking family's design of one scenario.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        The run's design model.
    settings : FlockingSettings
        The family's settings.
    law : FlockingLaw
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
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> design = FAMILY.design(scenario, build_model(scenario),
    ...                          scenario.controllers["flocking"])
    >>> design.A_cl.shape, design.control_interval  # 4 trains: ξ = [v̂ (4), z (3), p]; T_c [s]
    ((8, 8), 1.0)
    >>> rho = np.max(np.abs(np.linalg.eigvals(design.sampled_matrix())))
    >>> bool(rho < 1.0)  # the law held over 1 s keeps the loop stable
    True
    """

    initial_errors: Array


def design_flocking(scenario: Scenario, model: DesignModel,
                    settings: FlockingSettings) -> FlockingDesign:
    """The law and its linear closed loop.

    Parameters
    ----------
    scenario : Scenario
        The scenario (formation, ``[communication]`` graph, ``[simulation]``).
    model : DesignModel
        Its design model.
    settings : FlockingSettings
        The family's settings.

    Returns
    -------
    FlockingDesign
        The design.

    Raises
    ------
    ScenarioError
        If the simulation's duration is not a whole multiple of the control
        interval, or the formation cannot carry the law
        (:func:`~trainctl.controllers.flocking.law.law_of`).

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> d = design_flocking(scenario, build_model(scenario), scenario.controllers["flocking"])
    >>> d.A_cl.shape, d.law.potential.desired_gap
    ((8, 8), 500.0)
    """
    from trainctl.controllers.continuous.loops import closed_loop_matrices
    from trainctl.controllers.continuous.sampled import control_interval, initial_errors
    from trainctl.controllers.flocking.law import law_of

    T = control_interval(scenario, model, settings, "flocking")
    law = law_of(scenario, settings)
    return FlockingDesign(scenario=scenario, model=model, settings=settings, law=law,
                          control_interval=T,
                          loops=closed_loop_matrices(model, law.feedback(), head_position=True),
                          initial_errors=initial_errors(scenario))


class FlockingFamily(ContinuousFamily[FlockingDesign, "FlockingSettings"]):
    """Olfati-Saber's flocking law for virtually coupled trains (seed 002).

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> design = FAMILY.design(scenario, build_model(scenario),
    ...                          scenario.controllers["flocking"])
    >>> FAMILY.name, len(FAMILY.check_names)
    ('flocking', 7)
    >>> ctl = FAMILY.make(design, "flocking")
    >>> ctl.name, ctl.dt  # sampled every control interval [s]
    ('flocking', 1.0)
    """

    name = "flocking"
    claims_source = "the 2023 virtual-coupling patent, on the formation's line"
    title = "Flocking (virtual coupling)"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    trajectory_check_names = ("flocking_collision", "flocking_connectivity",
                              "flocking_braking_distance")
    """The checks :meth:`trajectory_checks` judges again on a simulation."""
    measures_gaps = True
    """The law measures the gaps (the model's observability check adds them to the outputs)."""
    report_partial = PARTIAL
    settings_path = "trainctl.controllers.flocking.settings:FlockingSettings"
    checks_path = "trainctl.controllers.flocking.checks:flocking_checks"
    controller_path = "trainctl.controllers.flocking.controller:FlockingController"
    head_position = True
    force_outputs = False
    """Virtual links carry no force: the closed loop has no ``f[i]`` outputs."""
    graph_usage = GRAPH_USAGE
    _design = staticmethod(design_flocking)

    def _controller_options(self, design: FlockingDesign) -> dict[str, Any]:
        """The braking supervisor when the settings ask for it (``supervisor = true``)."""
        if not design.settings.supervisor:
            return {}
        from trainctl.controllers.flocking.supervisor import supervisor_of

        return {"supervisor": supervisor_of(design.scenario, design.settings,
                                            design.control_interval)}

    def trajectory_checks(self, design: FlockingDesign, strategy: str,
                          result: SimulationResult) -> list[Check]:
        """``flocking_collision``, ``flocking_connectivity`` and ``flocking_braking_distance``.

        Parameters
        ----------
        design : FlockingDesign
            The family's design.
        strategy : str
            The simulated strategy's name.
        result : SimulationResult
            Its simulation on the nonlinear plant.

        Returns
        -------
        list of Check
            The three checks judged on the simulated gaps and speeds,
            replacing the design review's checks of the same names.
        """
        from trainctl.controllers.flocking.checks import trajectory_checks

        return trajectory_checks(design, strategy, result)

    def claims(self, run: Any) -> list[Any]:
        """Seed 002's claims (:func:`trainctl.controllers.flocking.claims.paper_claims`).

        Parameters
        ----------
        run : AnalysisRun
            The analysis run.

        Returns
        -------
        list of Claim
            The claims the run decides (none without a simulated ``flocking``).
        """
        from trainctl.controllers.flocking.claims import paper_claims

        return paper_claims(run)

    def report_data(self, design: FlockingDesign) -> dict[str, Any]:
        """Potential parameters, the closed-loop spectrum (sampled) and the graph, JSON-safe.

        The ``[communication]`` graph is stored under ``graph``
        (:func:`trainctl.plots.graph_figures.graph_report_data`).

        Parameters
        ----------
        design : FlockingDesign
            The family's design.

        Returns
        -------
        dict
            JSON-safe: ``spectra`` (the closed-loop eigenvalues mapped to z =
            exp(λ T_s) with the model's sample time, as [re, im] pairs),
            ``rows`` (name/value rows of the potential and gains table, with
            the collision barrier), ``control_interval`` [s] (as text),
            ``input_bounds`` and ``graph``.
        """
        from trainctl.controllers.continuous.loops import report_spectrum
        from trainctl.plots.graph_figures import graph_report_data

        points, modes = report_spectrum(design.A_cl, design.model.settings.sample_time)
        p, law = design.law.potential, design.law
        bound = p.collision_energy_bound()
        rows = [("Desired gap d [m]", f"{p.desired_gap:g}"),
                ("Interaction range r [m]", f"{p.r:g}"),
                ("d_α, r_α [-]", f"{p.d_alpha:.4g}, {p.r_alpha:.4g}"),
                ("ρ_h(d_α/r_α) [-]", f"{float(p.adjacency(p.desired_gap)):.3g}"),
                ("k_eff [1/s²]", f"{p.stiffness():.4g}"),
                ("Collision barrier E(0) [m²/s²]", f"{bound.energy:.4g}"),
                ("Barrier as relative speed [m/s]", f"{bound.relative_speed:.4g}"),
                ("Consensus, position, speed gains", f"{law.consensus_gain:g} 1/s, "
                 f"{law.position_gain:g} 1/s², {law.speed_gain:g} 1/s"), modes[0]]
        return {"spectra": {"flocking": points},
                "rows": [{"name": a, "value": b} for a, b in rows],
                "control_interval": f"{design.control_interval:g}",
                "input_bounds": bool(design.settings.input_bounds),
                "graph": graph_report_data(design.scenario.graph())}


FAMILY = FlockingFamily()
"""The registry entry of the flocking family."""
