# The wall-clock fields of a run's JSON, and the same JSON without them.
"""The fields of a run's JSON that differ between two runs of the same scenario.

:data:`WALL_CLOCK_KEYS` names the solve and stage times; :func:`without_wall_clock`
drops them at any depth (``trainctl analyse --deterministic``, the rows of a
sweep), so that two runs of one scenario compare equal.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

__all__ = ["WALL_CLOCK_KEYS", "without_wall_clock"]

WALL_CLOCK_KEYS = frozenset({
    "solve_time_median", "solve_time_p95", "solve_time_max", "solve_time_total", "wall_time",
    "timings", "solve_time", "search_time",
})
"""Keys of ``analyse --json`` whose values are wall-clock times (left out by --deterministic)."""


def without_wall_clock(value: Any, keys: Iterable[str] = WALL_CLOCK_KEYS) -> Any:
    """``value`` (JSON-like) without the wall-clock keys, at any depth.

    Parameters
    ----------
    value : object
        JSON-like data: dicts, lists and plain values.
    keys : iterable of str
        The keys to drop.

    Returns
    -------
    object
        ``value`` without them (new dicts and lists; the plain values shared).

    Examples
    --------
    >>> without_wall_clock({"a": 1, "s": [{"solve_time_p95": 0.1, "b": 2}]})
    {'a': 1, 's': [{'b': 2}]}
    """
    drop = frozenset(keys)
    if isinstance(value, dict):
        return {k: without_wall_clock(v, drop) for k, v in value.items() if k not in drop}
    if isinstance(value, list):
        return [without_wall_clock(v, drop) for v in value]
    return value
