# The result types of the design review: one named check, and the review of a scenario.
"""A named design check (:class:`Check`) and the checks of one scenario (:class:`DesignReview`).

The checks themselves are computed in :mod:`trainctl.analysis.review` (the
model and scenario checks) and by each controller family.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from trainctl.exceptions import UnknownNameError
from trainctl.violations import suggest

__all__ = ["STATUSES", "Check", "DesignReview"]

STATUSES = ("pass", "warn", "fail")
"""Check statuses, from best to worst."""


@dataclass(frozen=True, kw_only=True)
class Check:
    """One named design check.

    Parameters
    ----------
    name : str
        Check name (see :data:`trainctl.scenario.CHECK_NAMES`).
    status : {"pass", "warn", "fail"}
        Outcome.
    value : float or None
        The measured number.
    threshold : float or None
        The number it is compared with.
    unit : str
        Unit of value and threshold ("" when dimensionless).
    message : str
        One line: what was found.
    hint : str
        One line: what to change ("" when nothing needs changing).
    details : dict
        JSON-safe supporting numbers (eigenvalues, directions, ...).

    Examples
    --------
    >>> Check(name="sampling", status="pass", value=1.39, threshold=math.pi, unit="rad",
    ...       message="resolved").to_dict()["threshold"]
    3.141592653589793
    """

    name: str
    status: str
    value: float | None
    threshold: float | None
    unit: str
    message: str
    hint: str = ""
    details: Mapping[str, object] = field(default_factory=dict)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict (non-finite numbers as None).

        Returns
        -------
        dict
            The fields by name: ``name``, ``status``, ``value`` and
            ``threshold`` (None when missing or not finite), ``unit``,
            ``message``, ``hint`` and ``details`` (a copy).
        """
        return {"name": self.name, "status": self.status, "value": finite_or_none(self.value),
                "threshold": finite_or_none(self.threshold), "unit": self.unit,
                "message": self.message, "hint": self.hint, "details": dict(self.details)}


@dataclass(frozen=True, kw_only=True)
class DesignReview:
    """The checks of one scenario, in a fixed order.

    Parameters
    ----------
    scenario_name : str
        Display name of the scenario.
    checks : tuple of Check
        The checks.

    Examples
    --------
    >>> review = DesignReview(scenario_name="toy", checks=(
    ...     Check(name="sampling", status="fail", value=None, threshold=None, unit="",
    ...           message="aliased"),))
    >>> review.failed_checks, review.check("sampling").message
    (('sampling',), 'aliased')
    >>> review.check("sampling_rate")
    Traceback (most recent call last):
        ...
    trainctl.exceptions.UnknownNameError: the review of 'toy' has no check 'sampling_rate'. \
Did you mean 'sampling'? Checks: sampling.
    """

    scenario_name: str
    checks: tuple[Check, ...]

    @property
    def failed_checks(self) -> tuple[str, ...]:
        """Names of the checks whose status is ``"fail"``."""
        return tuple(c.name for c in self.checks if c.status == "fail")

    @property
    def names(self) -> tuple[str, ...]:
        """The names of the checks, in order."""
        return tuple(c.name for c in self.checks)

    def check(self, name: str) -> Check:
        """The check called ``name``.

        Parameters
        ----------
        name : str
            A name from :attr:`names`.

        Returns
        -------
        Check
            The check.

        Raises
        ------
        UnknownNameError
            If the review has no such check (also a ``KeyError``); the
            message lists the checks and suggests a near miss.
        """
        for c in self.checks:
            if c.name == name:
                return c
        raise UnknownNameError(
            f"the review of {self.scenario_name!r} has no check {name!r}."
            f"{suggest(name, self.names)} Checks: {', '.join(self.names) or '(none)'}.")

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``scenario`` (the display name), ``checks`` (each check's
            :meth:`Check.to_dict`, in order) and ``failed_checks`` (the names
            of the failed checks).
        """
        return {"scenario": self.scenario_name, "checks": [c.to_dict() for c in self.checks],
                "failed_checks": list(self.failed_checks)}

    def format_text(self) -> str:
        """The review as a plain-text table with hints.

        Returns
        -------
        str
            A "Design checks:" header, then one row per check (name, status,
            value, threshold, unit) followed by its message and, when it has
            one, its hint; lines joined by newlines.
        """
        w = max([24] + [len(c.name) + 2 for c in self.checks])
        lines = ["Design checks:",
                 f"  {'check':<{w}}{'status':<8}{'value':>12}{'threshold':>12}  unit"]
        for c in self.checks:
            lines.append(f"  {c.name:<{w}}{c.status.upper():<8}{format_number(c.value):>12}"
                         f"{format_number(c.threshold):>12}  {c.unit}")
            lines.append(f"      {c.message}")
            if c.hint:
                lines.append(f"      hint: {c.hint}")
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        from html import escape
        rows = "".join(
            f"<tr><td>{escape(c.name)}</td><td>{c.status}</td><td>{format_number(c.value)}</td>"
            f"<td>{format_number(c.threshold)}</td><td>{escape(c.unit)}</td>"
            f"<td>{escape(c.message)}</td></tr>"
            for c in self.checks)
        return ("<table><tr><th>check</th><th>status</th><th>value</th><th>threshold</th>"
                f"<th>unit</th><th>finding</th></tr>{rows}</table>")


def finite_or_none(x: float | None) -> float | None:
    """``x`` as a float, or None when it is None or not finite (JSON-safe).

    Parameters
    ----------
    x : float or None
        A number.

    Returns
    -------
    float or None
        ``float(x)``, or None.

    Examples
    --------
    >>> finite_or_none(2), finite_or_none(math.inf)
    (2.0, None)
    """
    return None if x is None or not math.isfinite(x) else float(x)


def format_number(x: float | None) -> str:
    """A check value for the text table: 4 significant digits, "-" for none.

    Parameters
    ----------
    x : float or None
        A check's value or threshold.

    Returns
    -------
    str
        The text.

    Examples
    --------
    >>> format_number(555.39799), format_number(None), format_number(math.inf)
    ('555.4', '-', 'inf')
    """
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if math.isinf(x):
        return "inf"
    return f"{x:.4g}"
