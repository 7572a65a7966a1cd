# What the H∞ family gives the later stages: its cost, seed 003's claims, its certificate.
"""The H∞ family's optional hooks (:class:`~trainctl.controllers.hooks.FamilyHooks`).

The cost of its semidefinite programs (:mod:`trainctl.controllers.hinf.cost`),
seed 003's published claims and their figure
(:mod:`trainctl.controllers.hinf.claims`,
:mod:`trainctl.controllers.hinf.claims_figures`) and the delay-margin
certificate a sweep tests. :class:`~trainctl.controllers.hinf.family.HinfFamily`
inherits them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from trainctl.controllers.hooks import FamilyHooks

if TYPE_CHECKING:
    from trainctl.analysis.certificates import Certificate
    from trainctl.analysis.claims import Claim
    from trainctl.controllers.hinf.settings import HinfSettings
    from trainctl.controllers.hooks import DesignCost
    from trainctl.report.figures import ReportFigure
    from trainctl.scenario import Scenario

__all__ = ["HinfHooks"]


class HinfHooks(FamilyHooks):
    """The H∞ family's hooks: SDP cost, seed 003's claims, the delay-margin certificate.

    Examples
    --------
    >>> [c.check for c in HinfHooks().certificates()]
    ['hinf_delay_margin']
    """

    claims_source = "Ning et al. 2016, the 1+2+1 heavy-haul train"

    def design_cost(self, scenario: Scenario, settings: HinfSettings,
                    strategies: Sequence[str]) -> DesignCost:
        """The SDPs' cost (:func:`trainctl.controllers.hinf.cost.design_cost`).

        Parameters
        ----------
        scenario : Scenario
            The scenario.
        settings : HinfSettings
            The family's settings.
        strategies : sequence of str
            The family's simulated strategies.

        Returns
        -------
        DesignCost
            Seconds and what dominates.
        """
        from trainctl.controllers.hinf.cost import design_cost

        return design_cost(scenario, settings, strategies)

    def claims(self, run: Any) -> list[Claim]:
        """Seed 003's claims (:func:`trainctl.controllers.hinf.claims.paper_claims`).

        Parameters
        ----------
        run : AnalysisRun
            The analysis run.

        Returns
        -------
        list of Claim
            The claims the run decides.
        """
        from trainctl.controllers.hinf.claims import paper_claims

        return paper_claims(run)

    def claim_figures(self, data: Any,
                      make: Callable[..., ReportFigure]) -> list[ReportFigure]:
        """The H∞ index figure (:mod:`trainctl.controllers.hinf.claims_figures`).

        Parameters
        ----------
        data : ReportData
            The report data.
        make : callable
            Turns a matplotlib figure into a report figure.

        Returns
        -------
        list of ReportFigure
            The figure, when the run decides the H∞ index claim.
        """
        from trainctl.controllers.hinf.claims_figures import performance_figure

        figure = performance_figure(data, make)
        return [] if figure is None else [figure]

    def certificates(self) -> tuple[Certificate, ...]:
        """The H∞ law's delay margin against the simulated loop.

        Returns
        -------
        tuple of Certificate
            ``hinf_delay_margin`` against divergence (else tracking).
        """
        from trainctl.analysis.certificates import NOT_DIVERGED, TRACKING, Certificate

        return (Certificate("hinf_delay_margin", ("distributed", "hinf.distributed"),
                            (NOT_DIVERGED, TRACKING),
                            "the H∞ law keeps stability up to the network's largest delay"),)
