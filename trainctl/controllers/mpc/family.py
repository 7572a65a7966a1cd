# The MPC family as a registry entry: vocabulary, schema, design, controllers, checks, report.
"""The MPC family object (:data:`FAMILY`), see :mod:`trainctl.registry`.

The family's design (:class:`MPCFamilyDesign`) holds the unconstrained design
on the run's discrete model (:class:`~trainctl.controllers.mpc.theory.mpc.MPCDesign`) and,
computed on first use, its closed-form analysis
(:func:`~trainctl.controllers.mpc.theory.dmpc.analyse_dmpc`), which the checks, the linear
closed loops and the report share.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np

from trainctl.controllers.family import FamilyBase
from trainctl.controllers.mpc.report import PARTIAL
from trainctl.controllers.mpc.settings import STRATEGIES, ControllerSettings

if TYPE_CHECKING:
    import control as ct

    from trainctl.analysis.certificates import Certificate
    from trainctl.controllers.hooks import DesignCost, StrategyRun
    from trainctl.controllers.mpc.controller import MPCController
    from trainctl.controllers.mpc.theory.dmpc import DMPCAnalysis, LocalDMPCAnalysis
    from trainctl.controllers.mpc.theory.local_iteration.model import LocalModel
    from trainctl.controllers.mpc.theory.mpc import MPCDesign
    from trainctl.design import DesignModel
    from trainctl.plots.svg import ReportFigure
    from trainctl.scenario import Scenario

__all__ = ["CHECK_NAMES", "FAMILY", "MPCFamily", "MPCFamilyDesign"]

CHECK_NAMES = (
    "ndmpc_convergence",
    "relaxation",
    "closed_loop_nash",
    "closed_loop_iterations",
    "nash_gap",
    "cooperative_convergence",
    "centralised_closed_loop",
    "prediction_horizon",
    "qp_conditioning",
    "rate_limit_conflict",
    "coupler_force_conflict",
)
"""The MPC family's design checks."""


@dataclass(frozen=True, kw_only=True, eq=False)
class MPCFamilyDesign:
    """The MPC family's design of one scenario.

    Parameters
    ----------
    scenario : Scenario
        The scenario (train, sample time, simulation noise for the observer).
    model : DesignModel
        The run's design model.
    settings : ControllerSettings
        The family's ``[controller]`` settings.
    mpc : MPCDesign
        The unconstrained design in design units (inputs kN).

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> design.mpc.prediction_horizon, design.mpc.control_horizon, design.mpc.form
    (4, 2, 'du')
    >>> design.mpc.neighbourhoods  # N-DMPC: each coach and the coaches next to it
    ((0, 1), (0, 1, 2), (1, 2, 3), (2, 3))
    >>> design.closed_loop_labels()[-4:]  # Δu-form: the previous inputs join the state
    ['u_prev[0]', 'u_prev[1]', 'u_prev[2]', 'u_prev[3]']
    """

    scenario: Scenario
    model: DesignModel
    settings: ControllerSettings
    mpc: MPCDesign

    @cached_property
    def analysis(self) -> DMPCAnalysis:
        """The closed-form N-DMPC / cooperative analysis (computed once)."""
        from trainctl.controllers.mpc.theory.dmpc import analyse_dmpc

        return analyse_dmpc(self.mpc, iterations=self.settings.iterations,
                            cooperative_weights=self.cooperative_weights())

    @cached_property
    def local(self) -> LocalModel:
        """The continuous design model partitioned by coach, for ``"ndmpc-local"``.

        The coach owns its speed and the elongation of the coupler behind it;
        hold, substeps and boundary are the ``local_*`` settings
        (:func:`~trainctl.controllers.mpc.theory.local_iteration.local_model`). Needs the
        zero-order-hold design model (``discretisation = "zoh"``).
        """
        from trainctl.controllers.mpc.theory.local_iteration.model import (
            local_model,
            train_state_owner,
        )

        sys, ctl = self.model.design, self.settings
        return local_model(self.mpc, np.asarray(sys.A, dtype=float),
                           np.asarray(sys.B, dtype=float), self.scenario.model.sample_time,
                           train_state_owner(self.mpc.n_inputs), hold=ctl.local_hold,
                           substeps=ctl.local_substeps, boundary=ctl.local_boundary)

    @property
    def simulates_local(self) -> bool:
        """True when the scenario simulates ``"ndmpc-local"`` (its checks then report it)."""
        sim = getattr(self.scenario, "simulation", None)
        return sim is not None and "ndmpc-local" in tuple(sim.strategies)

    @cached_property
    def local_analysis(self) -> LocalDMPCAnalysis:
        """The closed-form analysis of neighbourhood-local N-DMPC (computed once)."""
        from trainctl.controllers.mpc.theory.dmpc import analyse_local_dmpc

        return analyse_local_dmpc(self.mpc, self.local, iterations=self.settings.iterations)

    def cooperative_weights(self) -> np.ndarray | None:
        """Convex weights of cooperative DMPC (None: uniform).

        Returns
        -------
        ndarray or None
            The settings' ``cooperative_weights`` as an array [-], or None
            when they are ``"uniform"``.
        """
        weights = self.settings.cooperative_weights
        return None if weights == "uniform" else np.asarray(weights, dtype=float)

    def closed_loop_labels(self) -> list[str]:
        """State names of the closed loops: the design states, then u_prev in the Δu-form.

        Returns
        -------
        list of str
            The train's state labels, followed by ``u_prev[i]`` per input
            when the design's form is ``"du"``.
        """
        labels = self.scenario.train.state_labels()
        if self.mpc.form == "du":
            labels += [f"u_prev[{i}]" for i in range(self.mpc.n_inputs)]
        return labels


def design_mpc(scenario: Scenario, model: DesignModel,
               settings: ControllerSettings) -> MPCFamilyDesign:
    """The MPC family's design on the run's discrete design model.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        Its design model (outputs as ``settings.outputs``).
    settings : ControllerSettings
        Horizons, form, weights and neighbourhoods.

    Returns
    -------
    MPCFamilyDesign
        The design (its analysis is computed on first use).
    """
    from trainctl.controllers.mpc.theory.mpc import MPCDesign

    train = scenario.train
    n, nc = train.n_vehicles, train.n_couplers
    sysd = model.select(model.discrete, tuple(settings.outputs))
    weight = {"v": (n, settings.q_velocity), "force": (nc, settings.q_force)}
    q = np.concatenate([np.full(*weight[g]) for g in settings.outputs])
    owner = tuple(int(i) for g in settings.outputs for i in range(n if g == "v" else nc))
    mpc = MPCDesign(
        A=np.asarray(sysd.A, dtype=float), B=np.asarray(sysd.B, dtype=float),
        C=np.asarray(sysd.C, dtype=float), prediction_horizon=settings.prediction_horizon,
        control_horizon=settings.control_horizon, form=settings.form, q=q,
        r=np.full(n, settings.input_weight_per_kn2()), output_owner=owner,
        neighbourhoods=settings.neighbourhoods(n))
    return MPCFamilyDesign(scenario=scenario, model=model, settings=settings, mpc=mpc)


def make_mpc_controller(design: MPCFamilyDesign, strategy: str) -> MPCController:
    """The MPC controller of one strategy (QPs built once here).

    Parameters
    ----------
    design : MPCFamilyDesign
        The family's design.
    strategy : str
        One of :data:`~trainctl.controllers.mpc.STRATEGIES`.

    Returns
    -------
    MPCController
        Ready to ``step``.
    """
    from trainctl.controllers.mpc.controller import MPCController
    from trainctl.controllers.mpc.observer import KalmanObserver, ObserverSettings

    scenario, ctl = design.scenario, design.settings
    dt = scenario.model.sample_time
    observer = None
    if ctl.observer == "kalman":
        noise = scenario.simulation.measurement_noise if scenario.simulation else 0.0
        settings = ObserverSettings(measurement_noise=max(noise, 0.01),
                                    disturbance_noise=ctl.observer_disturbance_noise)
        observer = KalmanObserver(scenario.train, dt, scenario.model.speed, settings,
                                  model=design.model.observer_model())
    force_rows = design.model.force_rows() / 1e3  # coupler forces [kN] on the design state
    return MPCController(scenario.train, design.mpc, force_rows, dt=dt, strategy=strategy,
                         constraints=ctl.mpc_constraints(), max_iterations=ctl.max_iterations,
                         tolerance=ctl.iteration_tolerance, relaxation=ctl.relaxation,
                         cooperative_weights=design.cooperative_weights(),
                         path=ctl.solver_path, qp_solver=ctl.qp_solver, name=strategy,
                         observer=observer,
                         local_model=design.local if strategy == "ndmpc-local" else None,
                         track=scenario.track)


def mpc_closed_loop(design: MPCFamilyDesign, strategy: str) -> ct.StateSpace:
    """The unconstrained closed loop of a strategy as a discrete ``StateSpace``.

    Inputs are specific-force disturbances ``w[i]`` [m/s²] per vehicle (a
    grade), entering the plant only; outputs the speed deviations ``v[i]``
    [m/s], the coupler-force deviations ``f[i]`` [kN] and the spacing
    deviations ``d[i]`` [m] (:meth:`DesignModel.loop_outputs`). The state matrix is the
    one the checks judge: centralised and cooperative (whose fixed point is
    the centralised optimum) the centralised loop, ``ndmpc`` the converged
    Nash loop, ``ndmpc-local`` the converged Nash loop of the local
    formulation, ``decentralised`` each coach optimising its own outputs with
    the others at their feedforward.

    Parameters
    ----------
    design : MPCFamilyDesign
        The family's design.
    strategy : str
        A strategy of the family.

    Returns
    -------
    control.StateSpace
        Discrete, ``dt`` the sample time.
    """
    import control as ct

    res = design.analysis
    if strategy in ("centralised", "cooperative"):
        A_cl = res.closed_loop_centralised
    elif strategy == "ndmpc":
        A_cl = res.closed_loop_nash
    elif strategy == "ndmpc-local":
        A_cl = design.local_analysis.closed_loop_nash
    else:
        A_cl = _decentralised_closed_loop(design.mpc)
    model = design.model
    n, nx = model.n_vehicles, model.n_states
    extra = A_cl.shape[0] - nx
    B = np.vstack([model.disturbance_matrix(), np.zeros((extra, n))])
    C, outputs = model.loop_outputs()
    C = np.hstack([C, np.zeros((C.shape[0], extra))])
    return ct.ss(A_cl, B, C, 0, dt=model.settings.sample_time,
                 states=design.closed_loop_labels(), inputs=[f"w[{i}]" for i in range(n)],
                 outputs=outputs, name=f"mpc_{strategy}")


def _decentralised_closed_loop(mpc: MPCDesign) -> np.ndarray:
    from trainctl.controllers.mpc.theory.iteration import closed_loop_matrix, iteration_matrices
    from trainctl.controllers.mpc.theory.mpc import prediction

    own = mpc.with_neighbourhoods([(i,) for i in range(mpc.n_inputs)])
    pred = prediction(own)
    _, D1 = iteration_matrices(own, pred)
    return closed_loop_matrix(own, D1, pred)  # one sweep from the feedforward: U = D1 e


class MPCFamily(FamilyBase[MPCFamilyDesign, ControllerSettings]):
    """Centralised, decentralised, N-DMPC and cooperative DMPC of the train.

    Its design is :func:`design_mpc`, its checks
    :func:`trainctl.controllers.mpc.checks.mpc_checks`.

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> FAMILY.name, "ndmpc" in FAMILY.strategies
    ('mpc', True)
    >>> ctl = FAMILY.make(design, "ndmpc")
    >>> type(ctl).__name__, ctl.name, ctl.dt  # the scenario's sample time [s]
    ('MPCController', 'ndmpc', 20.0)
    """

    name = "mpc"
    title = "Model predictive control"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    report_partial = PARTIAL
    settings_path = "trainctl.controllers.mpc.settings:ControllerSettings"
    checks_path = "trainctl.controllers.mpc.checks:mpc_checks"
    _design = staticmethod(design_mpc)


    def claims(self, run: Any) -> list[Any]:
        """Seed 000's claims (:func:`~trainctl.controllers.mpc.claims.mpc_claims`), when primary.

        Parameters
        ----------
        run : AnalysisRun
            The analysis run.

        Returns
        -------
        list of Claim
            The claims the run decides; none when another family is primary.
        """
        from trainctl.controllers.mpc.claims import mpc_claims

        if next(iter(run.design.families), None) != self.name:
            return []
        return mpc_claims(run)
    def make(self, design: MPCFamilyDesign, strategy: str) -> MPCController:
        """See :func:`make_mpc_controller`.

        Parameters
        ----------
        design : MPCFamilyDesign
            The family's design.
        strategy : str
            One of :data:`~trainctl.controllers.mpc.STRATEGIES`.

        Returns
        -------
        MPCController
            The strategy's controller, its QPs built, ready to ``step``.
        """
        return make_mpc_controller(design, strategy)

    def closed_loop(self, design: MPCFamilyDesign, strategy: str) -> ct.StateSpace:
        """See :func:`mpc_closed_loop`.

        Parameters
        ----------
        design : MPCFamilyDesign
            The family's design.
        strategy : str
            One of :data:`~trainctl.controllers.mpc.STRATEGIES`.

        Returns
        -------
        control.StateSpace
            The unconstrained closed loop, discrete (``dt`` the sample time
            [s]), from the disturbances ``w[i]`` [m/s²] to the speed [m/s],
            coupler-force [kN] and spacing [m] deviations.
        """
        return mpc_closed_loop(design, strategy)

    def report_data(self, design: MPCFamilyDesign) -> dict[str, Any]:
        """See :func:`trainctl.controllers.mpc.report.mpc_report_data`.

        Parameters
        ----------
        design : MPCFamilyDesign
            The family's design.

        Returns
        -------
        dict of str to object
            JSON-safe: closed-loop ``spectra``, the ``weight_sweep`` of ρ(D0)
            against R, and display values for the section.
        """
        from trainctl.controllers.mpc.report import mpc_report_data

        return mpc_report_data(design)

    def report_figures(self, data: Mapping[str, Any]) -> Sequence[ReportFigure]:
        """See :func:`trainctl.controllers.mpc.report.mpc_report_figures`.

        Parameters
        ----------
        data : mapping of str to object
            The family's :meth:`report_data`.

        Returns
        -------
        sequence of ReportFigure
            The convergence figure (ρ(D0) against R, R* marked).
        """
        from trainctl.controllers.mpc.report import mpc_report_figures

        return mpc_report_figures(data)

    # -- optional hooks (trainctl.controllers.hooks.FamilyHooks) ------------------------------

    settings_labels = MappingProxyType({
        "q_velocity": "Velocity weight Q_v", "q_force": "Coupler-force weight Q_f",
        "input_weight": "Input weight R", "prediction_horizon": "Prediction horizon P",
        "control_horizon": "Control horizon M"})
    headline_checks = MappingProxyType({"ndmpc_convergence": "ρ(D0)"})

    def cost_horizons(self, settings: ControllerSettings) -> tuple[int, int]:
        """The prediction and control horizons (:func:`trainctl.controllers.mpc.cost.horizons`).

        Parameters
        ----------
        settings : ControllerSettings
            The family's settings.

        Returns
        -------
        (int, int)
            P and M [steps].
        """
        from trainctl.controllers.mpc.cost import horizons

        return horizons(settings)

    def design_cost(self, scenario: Scenario, settings: ControllerSettings,
                    strategies: Sequence[str]) -> DesignCost:
        """The MPC analysis' cost (:func:`trainctl.controllers.mpc.cost.design_cost`).

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        settings : ControllerSettings
            The family's settings.
        strategies : sequence of str
            The family's simulated strategies.

        Returns
        -------
        DesignCost
            Seconds, peak bytes and what dominates.
        """
        from trainctl.controllers.mpc.cost import design_cost

        return design_cost(scenario, settings, strategies)

    def strategy_seconds(self, run: StrategyRun) -> float:
        """A strategy's build and QPs (:func:`trainctl.controllers.mpc.cost.strategy_seconds`).

        Parameters
        ----------
        run : StrategyRun
            The strategy's simulation as the budget sees it.

        Returns
        -------
        float
            Seconds [s].
        """
        from trainctl.controllers.mpc.cost import strategy_seconds

        return strategy_seconds(run)

    def certificates(self) -> tuple[Certificate, ...]:
        """The N-DMPC convergence check against the simulated iteration.

        Returns
        -------
        tuple of Certificate
            ``ndmpc_convergence`` against ``metric.converged`` (else tracking,
            else divergence).
        """
        from trainctl.analysis.certificates import CONVERGED, NOT_DIVERGED, TRACKING, Certificate

        return (Certificate("ndmpc_convergence", ("ndmpc", "mpc.ndmpc"),
                            (CONVERGED, TRACKING, NOT_DIVERGED),
                            "ρ(D0) < 1: the N-DMPC iteration converges at every step"),)


FAMILY = MPCFamily()
"""The registry entry of the MPC family."""
