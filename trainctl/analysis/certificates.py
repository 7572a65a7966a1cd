# A design check and the simulated outcome that tests its promise: what sweeps set side by side.
"""Certificates: a design check and the simulation outcome that tests its promise.

A family declares its certificates through its ``certificates()`` hook
(:class:`~trainctl.registry.ControllerFamily`; default none,
:class:`~trainctl.controllers.hooks.FamilyHooks`); the sweep report
(:mod:`trainctl.report.sweep`) sets each check's verdict over the sweep
against what the simulations showed
(:func:`trainctl.report.sweep.declared_certificates` collects them over
every known family).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["CONVERGED", "NOT_DIVERGED", "TRACKING", "Certificate", "Outcome"]


@dataclass(frozen=True)
class Outcome:
    """A simulated outcome: a boolean metric column and the value that means "fine".

    Parameters
    ----------
    metric : str
        The metric's name (column ``metric.<metric>``).
    ok_when : bool
        The value that means the promise held (``converged``: True,
        ``diverged``: False).
    says : str
        What "fine" means, for the page (``"converged"``).
    says_not : str
        What "not fine" means (``"did not converge"``).

    Examples
    --------
    >>> outcome = Outcome("diverged", False, "did not diverge", "diverged")
    >>> outcome.column, outcome.ok_when
    ('metric.diverged', False)
    """

    metric: str
    ok_when: bool
    says: str
    says_not: str

    @property
    def column(self) -> str:
        """``metric.<metric>``."""
        return f"metric.{self.metric}"


@dataclass(frozen=True)
class Certificate:
    """A design check and the simulation outcome that tests its promise.

    Parameters
    ----------
    check : str
        The check's name (columns ``check.<check>.status``/``.value``).
    strategies : tuple of str
        The simulated strategies it speaks for, as ``[simulation]`` names
        them (with or without the family prefix); the first present is used.
    outcomes : tuple of Outcome
        Simulated outcomes in order of preference: the first whose column
        the table has is used (a store made before a metric existed falls
        back to the next).
    promise : str
        What the check promises, for the page.

    Examples
    --------
    A delay-margin certificate of a family's check ``my_margin``: its
    strategy, and the metric columns tried in turn:

    >>> cert = Certificate("my_margin", ("law", "my.law"), (NOT_DIVERGED, TRACKING),
    ...                    "the law keeps stability up to the network's largest delay")
    >>> cert.check, [o.column for o in cert.outcomes]
    ('my_margin', ['metric.diverged', 'metric.tracking_ok'])
    """

    check: str
    strategies: tuple[str, ...]
    outcomes: tuple[Outcome, ...]
    promise: str


CONVERGED = Outcome("converged", True, "converged", "did not converge")
"""The distributed iteration converged at every step (``metric.converged`` true)."""
NOT_DIVERGED = Outcome("diverged", False, "did not diverge", "diverged")
"""The closed loop did not diverge (``metric.diverged`` false)."""
TRACKING = Outcome("tracking_ok", True, "tracked", "did not track")
"""Tracking held (``metric.tracking_ok`` true)."""

