# What MPC costs: the budget's calibration of its analysis and of its QPs per step.
"""The budget's time and memory model of the MPC family (:mod:`trainctl.run.budget`).

The design review grows like vehicles × horizon^1.2 (plus a horizon³ term)
for the global N-DMPC iteration analysis and like the cube of the local
iteration's size (vehicles × (control horizon + 2 × prediction horizon))
when neighbourhood-local N-DMPC is simulated; each controller step costs
the strategy's QPs (centralised: one QP of vehicles × control-horizon moves,
cubic in it; decentralised: one small QP per vehicle with a force to
decide — none for a vehicle whose envelope pins it at 0 kN; N-DMPC and
cooperative: that per iteration, plus the exchange of every vehicle's
predictions). Calibrated on a 2-core machine (OSQP 1.1, DAQP 0.7) and on the
204-vehicle chain (``benchmarks/scenarios/heavy-haul-204-ndmpc.toml``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from trainctl.controllers.hooks import BUILD_SECONDS, STEP_SECONDS, DesignCost

if TYPE_CHECKING:
    from trainctl.controllers.hooks import StrategyRun
    from trainctl.controllers.mpc.settings import ControllerSettings
    from trainctl.scenario import Scenario

__all__ = ["design_cost", "horizons", "strategy_seconds"]

_MPC = 4e-3                 # × n · P^1.2: global N-DMPC iteration analysis (n = 4, P = 40: ~1.3 s;
                            # n = 204, P = 10: ~10 s)
_MPC_LONG = 2.4e-8          # × n · P^3: the same at long horizons
_LOCAL = 5e-10              # × (n · (M + 2P))³: the local iteration's spectra (n = 204: ~55 s)
_EXCHANGE = 5e-6            # per vehicle and iteration: exchanging the local predictions
                            # (204 vehicles, 4 QPs: 2.5 ms per iteration measured)
_QP = 2e-4                  # one small QP (a vehicle's) on OSQP
_QP_DAQP = 4e-5             # the same on DAQP, the step's overhead included (well-sampled CRH2
                            # N-DMPC, 2026-12-02: 172 µs a step of 6.2 coach QPs, quiet machine)
_CENTRAL = 1e-8             # × (n · M)³: the centralised QP's factorisation (n · M = 20: 80 µs;
                            # measured 80 µs a step on DAQP; 3e-7 before, 30 × over)
_DAQP_MAX_DECISIONS = 240   # qp_solver = "auto" gives DAQP QPs up to this size (the controller's
                            # trainctl.controllers.mpc.qp.parametric.DAQP_MAX_DECISIONS, which
                            # imports CVXPY: the budget must not; a test checks they agree)
_BUILD_SIZE = 1e-5          # building a strategy's controller: + _BUILD_SIZE·(n·P)^1.5
_ITERATIONS = 5             # typical distributed iterations per sample (of max_iterations)
_DENSE_MATRICES = 5 * 8     # MPC analysis: about five dense (n·P)² float matrices alive


def horizons(settings: ControllerSettings) -> tuple[int, int]:
    """The prediction and control horizons P and M of the MPC settings [steps].

    Parameters
    ----------
    settings : ControllerSettings
        The MPC family's settings.

    Returns
    -------
    (int, int)
        P and M (1 where unset).

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> horizons(load_scenario("crh2-dmpc").controllers["mpc"])
    (4, 2)
    """
    return (int(getattr(settings, "prediction_horizon", 1) or 1),
            int(getattr(settings, "control_horizon", 1) or 1))


def design_cost(scenario: Scenario, settings: ControllerSettings,
                strategies: Sequence[str]) -> DesignCost:
    """The cost of the MPC analysis: the global iteration, and the local one when simulated.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    settings : ControllerSettings
        The MPC family's settings.
    strategies : sequence of str
        The family's simulated strategies.

    Returns
    -------
    DesignCost
        Seconds [s], peak bytes of the dense matrices, and the words naming
        the keys.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> cost = design_cost(scenario, scenario.controllers["mpc"], ("ndmpc",))
    >>> cost.seconds > 0, cost.dominant.split(" with ")[0]
    (True, 'the MPC analysis of 4 vehicles')
    """
    n = scenario.train.n_vehicles
    horizon, moves = horizons(settings)
    seconds = _MPC * n * horizon**1.2 + _MPC_LONG * n * horizon**3
    memory = _DENSE_MATRICES * float(n * horizon) ** 2
    if "ndmpc-local" in tuple(strategies):
        size = float(n * (moves + 2 * horizon))
        seconds += _LOCAL * size**3
        memory = max(memory, _DENSE_MATRICES * size**2)
    return DesignCost(seconds=seconds, memory_bytes=memory, dominant=(
        f"the MPC analysis of {n} vehicles with [controller].prediction_horizon = {horizon}"))


def strategy_seconds(run: StrategyRun) -> float:
    """Seconds to build an MPC strategy's controller and simulate it.

    Parameters
    ----------
    run : StrategyRun
        The strategy's simulation as the budget sees it.

    Returns
    -------
    float
        Build time plus, per sample, the plant's, the step overhead and the
        strategy's QPs [s].

    Examples
    --------
    >>> from trainctl.controllers.hooks import StrategyRun
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> def run(strategy):
    ...     return StrategyRun(scenario=scenario, settings=scenario.controllers["mpc"],
    ...                        strategy=strategy, samples=60, sample_time=20.0,
    ...                        interval=20.0, substeps=200, plant_seconds=0.02)
    >>> strategy_seconds(run("ndmpc")) > strategy_seconds(run("decentralised"))
    True
    """
    n = run.n_vehicles
    horizon, moves = horizons(run.settings)
    # A vehicle whose envelope pins its force at 0 kN has no QP (u-form with input bounds:
    # trainctl.controllers.mpc.controller.fixed_inputs); counted here from the envelope alone.
    pinned = sum(1 for v in run.scenario.train.vehicles if v.envelope.pins_force)
    solver = str(getattr(run.settings, "qp_solver", "auto"))
    decisions = moves * (n if run.strategy == "centralised" else 1)
    daqp = solver == "daqp" or (solver == "auto" and decisions <= _DAQP_MAX_DECISIONS)
    qp = _QP_DAQP if daqp else _QP
    if run.strategy in ("ndmpc", "cooperative", "ndmpc-local"):
        limit = int(getattr(run.settings, "max_iterations", _ITERATIONS) or _ITERATIONS)
        step = (qp * (n - pinned) + _EXCHANGE * n) * min(limit, _ITERATIONS)
    elif run.strategy == "decentralised":
        step = qp * (n - pinned)
    else:  # centralised
        step = qp + _CENTRAL * float(n * moves) ** 3
    build = BUILD_SECONDS + _BUILD_SIZE * float(n * horizon) ** 1.5
    return float(build + run.samples * (run.plant_seconds + STEP_SECONDS + step))
