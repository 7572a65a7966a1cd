# The delay margin of a networked continuous law against the [network] worst-case delay.
"""A loop's delay margin judged against the ``[network]`` worst case (synchronous, hinf).

:func:`worst_delay` reads the worst case off a ``[network]`` section,
:func:`delay_margin_check` judges a
:class:`~trainctl.analysis.delay.DelayMargin` against it (each family gives
its own name, wording and hints) and :func:`seconds` writes a delay for a
report table.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

from trainctl.analysis.check import Check

if TYPE_CHECKING:
    from trainctl.analysis.delay import DelayMargin
    from trainctl.models.network import NetworkSettings

__all__ = ["delay_margin_check", "seconds", "worst_delay"]


def worst_delay(network: NetworkSettings | None) -> float | None:
    """The ``[network]`` worst-case delay [s] (upper end of the range); None without one.

    Parameters
    ----------
    network : NetworkSettings or None
        The scenario's ``[network]`` section.

    Returns
    -------
    float or None
        The upper end of ``delay_range_s``, or ``delay_s`` [s]; None without a network.

    Examples
    --------
    >>> from trainctl.models.network import NetworkSettings
    >>> worst_delay(None), worst_delay(NetworkSettings(delay_range_s=(0.0, 2.0)))
    (None, 2.0)
    """
    return None if network is None else float(network.delay_bounds()[1])


def seconds(x: float | None, missing: str = "no [network]") -> str:
    """A delay [s] for a report table: four digits, ``"∞"``, or ``missing`` for None.

    Parameters
    ----------
    x : float or None
        The delay [s].
    missing : str
        The text for None.

    Returns
    -------
    str
        The value as text.

    Examples
    --------
    >>> seconds(0.56789), seconds(math.inf), seconds(None), seconds(None, "directed graph")
    ('0.5679', '∞', 'no [network]', 'directed graph')
    """
    if x is None:
        return missing
    return f"{x:.4g}" if math.isfinite(x) else "∞"


def delay_margin_check(name: str, res: DelayMargin, worst: float | None, *,
                       details: Mapping[str, object], closed_loop: str, subject: str = "",
                       unconnected_subject: str | None = None, unconnected: str,
                       destabilises: str, note: str = "", unconnected_hint: str,
                       fail_hint: str) -> Check:
    """A delay margin against the ``[network]`` worst-case delay.

    Fail when the loop is unstable without delay (margin 0); warn without
    ``[network]`` (``worst`` None), with the margin; fail when the worst
    case reaches the margin; pass otherwise, or warn when the two Padé
    orders disagree.

    Parameters
    ----------
    name : str
        The check's name.
    res : DelayMargin
        The loop's delay margin (:func:`trainctl.analysis.delay.delay_margin`).
    worst : float or None
        The worst-case delay [s] (:func:`worst_delay`); None without ``[network]``.
    details : mapping
        Further details, after the margin's and ``worst_delay``.
    closed_loop : str
        The name of the delay-free stability check (the hint of margin 0).
    subject : str
        What the margin is of, after "delay margin" (e.g. ``" of the full coupled loop"``).
    unconnected_subject : str or None
        The same without ``[network]``; None: ``subject``.
    unconnected : str
        Why there is nothing to compare without ``[network]``.
    destabilises : str
        What a worst case at or above the margin does.
    note : str
        Appended to the main clause of each message but the margin-0 one.
    unconnected_hint, fail_hint : str
        The hints without ``[network]`` and on a failure.

    Returns
    -------
    Check
        The named check of the delay margin [s] against the worst case [s].

    Examples
    --------
    >>> from trainctl.analysis.delay import delay_margin
    >>> import numpy as np
    >>> res = delay_margin(np.zeros((1, 1)), np.ones((1, 1)), -np.ones((1, 1)), tau_max=5.0)
    >>> words = dict(details={}, closed_loop="x_closed_loop", unconnected="nothing to compare",
    ...              destabilises="it can diverge", unconnected_hint="add a [network]",
    ...              fail_hint="lower the gain")
    >>> check = delay_margin_check("x_delay_margin", res, 2.0, **words)
    >>> check.status, round(check.value, 2), check.message[:51]
    ('fail', 1.57, 'delay margin 1.571 s, crossing at 1 rad/s ≤ the [ne')
    >>> delay_margin_check("x_delay_margin", res, None, **words).status
    'warn'
    """
    margin = res.margin
    all_details: dict[str, object] = {**res.to_dict(), "worst_delay": worst, **details}
    shown = (f"{margin:.4g} s" if math.isfinite(margin)
             else f"above {res.tau_max:g} s (stable up to the end of the search)")
    crossing = ("" if math.isnan(res.crossing_frequency)
                else f", crossing at {res.crossing_frequency:.3g} rad/s")
    orders = ("" if res.agree else
              f"; the Padé orders {res.orders[0]} and {res.orders[1]} disagree "
              f"({res.margins[0]:.4g} s against {res.margins[1]:.4g} s)")
    if margin == 0.0:
        return Check(name=name, status="fail", value=0.0, threshold=worst, unit="s",
                     message="the loop is unstable without delay: no delay margin",
                     hint=f"see {closed_loop}", details=all_details)
    if worst is None:
        alone = subject if unconnected_subject is None else unconnected_subject
        return Check(name=name, status="warn", value=margin, threshold=None, unit="s",
                     message=f"delay margin{alone} {shown}{crossing}{note}; no [network]: "
                     f"{unconnected}" + orders,
                     hint=unconnected_hint, details=all_details)
    if worst >= margin:
        return Check(name=name, status="fail", value=margin, threshold=worst, unit="s",
                     message=f"delay margin{subject} {shown}{crossing} ≤ the [network] "
                     f"worst-case delay {worst:g} s: {destabilises}{note}" + orders,
                     hint=fail_hint, details=all_details)
    status = "pass" if res.agree else "warn"
    return Check(name=name, status=status, value=margin, threshold=worst, unit="s",
                 message=f"delay margin{subject} {shown}{crossing} > the [network] worst-case "
                 f"delay {worst:g} s{note}" + orders,
                 hint="" if res.agree else "raise the Padé orders to settle the margin",
                 details=all_details)
