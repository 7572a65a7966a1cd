# What a continuous-time law's simulation costs: the budget's calibration of an explicit law.
"""The budget's time model of an explicit law (:func:`law_seconds`).

A continuous-time law (potential, flocking, synchronous, hinf) solves no
optimisation: each step evaluates the law and its network messages, at the
law's own control interval, with the plant's substeps scaled to it.
Calibrated on ``heavy-haul-hinf-delay`` (4 vehicles, 4 substeps per 0.2 s
step): 0.43 ms per hinf step and 0.27 ms per synchronous step in all, 35 µs
per plant substep. The default of
:meth:`~trainctl.controllers.hooks.FamilyHooks.strategy_seconds`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from trainctl.controllers.hooks import BUILD_SECONDS

if TYPE_CHECKING:
    from trainctl.controllers.hooks import StrategyRun

__all__ = ["LAW_STEP_SECONDS", "LAW_SUBSTEP_SECONDS", "law_seconds"]

LAW_STEP_SECONDS = 2e-4
"""An explicit law's step with its network messages [s], × (1 + n / 32)."""

LAW_SUBSTEP_SECONDS = 4e-5
"""A plant substep under an explicit law [s], × (1 + n / 32)."""


def law_seconds(run: StrategyRun) -> float:
    """Seconds to build an explicit law and simulate it for ``run.samples`` samples.

    Parameters
    ----------
    run : StrategyRun
        The strategy's simulation as the budget sees it.

    Returns
    -------
    float
        ``BUILD_SECONDS + steps · (1 + n/32) · (LAW_STEP_SECONDS + LAW_SUBSTEP_SECONDS ·
        substeps per step)`` [s], steps counted at the control interval.

    Examples
    --------
    Ten 0.05 s samples of 8 vehicles, one plant substep each:

    >>> from trainctl.controllers.hooks import StrategyRun
    >>> from trainctl.scenario import load_scenario
    >>> run = StrategyRun(scenario=load_scenario("crh2-potential"), settings=None,
    ...                   strategy="consensus", samples=10, sample_time=0.05,
    ...                   interval=0.05, substeps=1, plant_seconds=1e-4)
    >>> round(law_seconds(run), 6)  # 0.5 + 10 · 1.25 · (2e-4 + 4e-5)
    0.503
    """
    n = run.n_vehicles
    steps = run.samples * run.sample_time / run.interval
    under = run.substeps * run.interval / run.sample_time
    return BUILD_SECONDS + steps * (1 + n / 32) * (LAW_STEP_SECONDS + LAW_SUBSTEP_SECONDS * under)
