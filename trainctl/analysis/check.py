# The result types of the design review: one named check, and the review of a scenario.
"""A named design check (:class:`Check`) and the checks of one scenario (:class:`DesignReview`).

The checks themselves are computed in :mod:`trainctl.design.review` (the
model and scenario checks) and by each controller family.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from trainctl.declare.violations import suggest
from trainctl.exceptions import UnknownNameError
from trainctl.naming import describe_direction

__all__ = [
    "LOOP_CHECK_NAMES", "MODEL_CHECK_NAMES", "SAMPLING_FAIL", "SAMPLING_PASS", "STATUSES",
    "Check", "DesignReview", "radius_check",
]

MODEL_CHECK_NAMES = (
    "open_loop_stability", "controllability", "observability", "sampling", "input_collapse",
    "feasibility", "plausibility",
)

LOOP_CHECK_NAMES = ("string_stability",)
"""Checks of the primary family's linear closed loop, whatever the family (after its own)."""
"""Names of the checks that need no controller: the linear model's (:func:`model_checks`),
then the scenario's (:func:`scenario_checks`); controller families add their own."""

SAMPLING_PASS = math.pi / 2
"""ω_max·T [rad] below which the sampling resolves the fastest coupler mode (pass): at
least four samples per period of the fastest mode. The sampling hint asks for
T < SAMPLING_PASS / ω_max."""

SAMPLING_FAIL = math.pi
"""ω_max·T [rad] at and above which the fastest coupler mode is aliased (Nyquist, fail)."""

_UNIT_TOL = 1e-9
"""Closed-loop eigenvalues within this of the unit circle count as marginal."""


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


def radius_check(name: str, A_cl: NDArray[np.float64], labels: list[str], what: str, *,
                 marginal_hint: str, unstable_hint: str) -> Check:
    """Judge a discrete closed loop by its spectral radius (fail > 1, warn on the circle).

    Parameters
    ----------
    name : str
        Check name.
    A_cl : ndarray
        Closed-loop state matrix (discrete).
    labels : list of str
        State names (eigenvector directions are described with them).
    what : str
        What the closed loop is, for the message.
    marginal_hint, unstable_hint : str
        Hints when eigenvalues sit on the unit circle / outside it.

    Returns
    -------
    Check
        Value ρ, threshold 1; details with the eigenvalues on the circle.

    Examples
    --------
    >>> import numpy as np
    >>> def judge(A):
    ...     return radius_check("demo", A, ["v[0]", "v[1]"], "toy loop",
    ...                         marginal_hint="on the circle", unstable_hint="outside")
    >>> judge(np.diag([0.5, 0.9])).status, judge(np.diag([0.5, 0.9])).value
    ('pass', 0.9)
    >>> c = judge(np.diag([0.5, 1.0]))  # v[1] never decays
    >>> c.status, c.details["unit_circle"][0]["direction"]
    ('warn', {'v[1]': 1.0})
    >>> judge(np.diag([0.5, 1.1])).message
    'toy loop: closed loop unstable, ρ = 1.1'
    """
    from trainctl.analysis.stability import mode_direction  # stability imports this module

    lam, vec = np.linalg.eig(A_cl)
    rho = float(np.max(np.abs(lam)))
    on_circle = np.flatnonzero(np.abs(np.abs(lam) - 1) <= _UNIT_TOL)
    directions = [mode_direction(vec[:, k], labels) for k in on_circle]
    circle = [{"eigenvalue": [float(lam[k].real), float(lam[k].imag)], "direction": d}
              for k, d in zip(on_circle, directions, strict=True)]
    details = {"spectral_radius": rho, "unit_circle": circle}
    if rho > 1 + _UNIT_TOL:
        return Check(name=name, status="fail", value=rho, threshold=1.0, unit="",
                     message=f"{what}: closed loop unstable, ρ = {rho:.6g}",
                     hint=unstable_hint, details=details)
    if circle:
        return Check(name=name, status="warn", value=rho, threshold=1.0, unit="",
                     message=f"{what}: {len(circle)} eigenvalue(s) on the unit circle, e.g. "
                     f"direction {describe_direction(directions[0])}",
                     hint=marginal_hint, details=details)
    return Check(name=name, status="pass", value=rho, threshold=1.0, unit="",
                 message=f"{what}: ρ = {rho:.6g} < 1", details=details)
