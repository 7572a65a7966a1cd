# Running a scenario: everything `trainctl analyse` computes, in one result.
"""Run a scenario's analyses and collect them in one :class:`AnalysisRun`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from .analysis.review import DesignReview, review_design
from .analysis.summary import ModelSummary, model_summary

if TYPE_CHECKING:
    from .scenario import Scenario

__all__ = ["AnalysisRun", "run_scenario"]


@dataclass(frozen=True, kw_only=True)
class AnalysisRun:
    """The results of running one scenario.

    Parameters
    ----------
    scenario : Scenario
        The scenario that was run.
    summary : ModelSummary
        Model summary (vehicles, equilibrium, modes, sampling).
    review : DesignReview
        The named design checks.
    """

    scenario: Scenario
    summary: ModelSummary
    review: DesignReview

    @property
    def failed_checks(self) -> tuple[str, ...]:
        """Names of failed design checks (``--strict`` exits 1 when non-empty)."""
        return self.review.failed_checks

    def unexpected_checks(self) -> dict[str, tuple[str, str]]:
        """Checks whose status differs from the scenario's ``[expected]`` table.

        Returns
        -------
        dict
            Check name → (expected, found).
        """
        found = {c.name: c.status for c in self.review.checks}
        return {name: (want, found.get(name, "missing"))
                for name, want in self.scenario.expected.items() if found.get(name) != want}

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict: the summary plus the review."""
        out = self.summary.to_dict()
        out["checks"] = self.review.to_dict()["checks"]
        out["failed_checks"] = list(self.failed_checks)
        return out

    def format_text(self) -> str:
        """The text ``trainctl analyse`` prints."""
        return self.summary.format_text() + "\n\n" + self.review.format_text()


def run_scenario(scenario: Scenario) -> AnalysisRun:
    """Run the model summary and the design review of ``scenario``.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.

    Returns
    -------
    AnalysisRun
        Summary and review.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> run = run_scenario(load_scenario("crh2-dmpc"))
    >>> "sampling" in run.failed_checks, run.unexpected_checks()
    (True, {})
    """
    return AnalysisRun(scenario=scenario, summary=model_summary(scenario),
                       review=review_design(scenario))
