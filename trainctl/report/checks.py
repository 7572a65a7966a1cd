# The "Design checks" section: badges, values and the review's messages as the page shows them.
"""Context of the report's design checks.

The review's messages name signals in python-control's 0-based index syntax
(``u_prev[3]``); the page numbers vehicles from 1, so they are shown through
:func:`~trainctl._format.one_based`. Forces in N are shown in kN.
"""

from __future__ import annotations

from typing import Any

from trainctl._format import format_value, is_real, one_based
from trainctl.report.data import ReportData

__all__ = ["checks_context"]

_BADGES = {"pass": "pass", "warn": "warn", "fail": "fail"}


def checks_context(data: ReportData) -> dict[str, Any]:
    """Rows of the design checks: badges, values in kN for forces, messages numbered from 1.

    Parameters
    ----------
    data : ReportData
        The report's data (``results["checks"]``, ``expected``, ``unexpected``).

    Returns
    -------
    dict
        ``rows``, ``counts`` by status, ``total`` and ``unexpected``.

    Examples
    --------
    One force check (value 12 000 N against a 500 000 N threshold, shown as
    12 and 500 kN) that warns where the scenario expects a pass; its
    message's 0-based ``f[0]`` is shown as coupler 1 (``f₁``). A stand-in
    carries the three fields read:

    >>> from types import SimpleNamespace
    >>> check = {"name": "coupler_force_conflict", "status": "warn", "value": 12000.0,
    ...          "threshold": 500000.0, "unit": "N", "message": "f[0] near its limit",
    ...          "hint": None}
    >>> data = SimpleNamespace(results={"checks": [check]},
    ...                        expected={"coupler_force_conflict": "pass"},
    ...                        unexpected={"coupler_force_conflict": ["pass", "warn"]})
    >>> context = checks_context(data)
    >>> row = context["rows"][0]
    >>> row["value"], row["threshold"], row["unit"], row["message"], row["unexpected"]
    ('12', '500', 'kN', 'f₁ near its limit', True)
    >>> context["counts"], context["unexpected"][0]["found"]
    ({'pass': 0, 'warn': 1, 'fail': 0}, 'warn')
    """
    rows = []
    counts = {"pass": 0, "warn": 0, "fail": 0}
    for check in data.results.get("checks", []):
        status = str(check["status"])
        counts[status] = counts.get(status, 0) + 1
        expected = data.expected.get(check["name"], "")
        value, threshold, unit = _in_kn(check["value"], check["threshold"], check["unit"] or "-")
        rows.append({
            "name": check["name"], "status": status, "badge": _BADGES.get(status, "other"),
            "value": format_value(value), "threshold": format_value(threshold),
            "unit": unit, "message": one_based(str(check["message"])),
            "hint": one_based(str(check["hint"] or "")),
            "expected": expected,
            "unexpected": bool(expected) and expected != status,
        })
    return {"rows": rows, "counts": counts, "total": len(rows),
            "unexpected": [{"name": k, "expected": v[0], "found": v[1]}
                           for k, v in data.unexpected.items()]}


def _in_kn(value: Any, threshold: Any, unit: str) -> tuple[Any, Any, str]:
    """A check's value and threshold in kN when they are forces in N (as every table shows)."""
    if unit != "N":
        return value, threshold, unit
    return tuple(x / 1e3 if is_real(x) else x for x in (value, threshold)) + ("kN",)
