# Signal names as people read them: vehicles and couplers numbered from 1.
"""Signal names for messages and pages, numbered from 1 as the seed papers number vehicles.

trainctl's signal names follow python-control's indexed syntax and count
from 0 (``v[0]``, ``delta[2]``, ``u_prev[3]``); they stay that way in JSON
and in the systems, where they name a signal of a ``StateSpace``. Text meant
for a person — check messages, ``analyse`` output, the report — numbers
vehicles and couplers from 1, head first, as the papers do.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

__all__ = ["describe_direction", "one_based"]

_INDEXED = re.compile(r"\b([A-Za-z_]\w*)\[(\d+)\]")
_SUBSCRIPTS = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")
_SYMBOLS = {"delta": "δ"}


def one_based(text: str) -> str:
    """Signal names in 0-based index syntax written as people number them.

    Every ``name[i]`` in ``text`` becomes ``name`` with the subscript i + 1
    (``delta`` as ``δ``); nothing else changes.

    Parameters
    ----------
    text : str
        Any text.

    Returns
    -------
    str
        The text with its indexed names renumbered.

    Examples
    --------
    >>> one_based("v[0], delta[2]; {'u_prev[3]': 0.5} in [controller].outputs")
    "v₁, δ₃; {'u_prev₄': 0.5} in [controller].outputs"
    """
    def repl(match: re.Match[str]) -> str:
        name = _SYMBOLS.get(match.group(1), match.group(1))
        return name + str(int(match.group(2)) + 1).translate(_SUBSCRIPTS)

    return _INDEXED.sub(repl, text)


def describe_direction(direction: Mapping[str, float]) -> str:
    """A mode's direction (state name → weight) as a short phrase, numbered from 1.

    Parameters
    ----------
    direction : mapping of str to float
        State names (0-based index syntax) and their weights in the mode, as
        :func:`trainctl.analysis.stability.mode_direction` gives them.

    Returns
    -------
    str
        ``"name weight, ..."`` in the given order, weights to 3 digits.

    Examples
    --------
    >>> describe_direction({"u_prev[3]": 0.59183, "u_prev[0]": 0.566457})
    'u_prev₄ 0.592, u_prev₁ 0.566'
    >>> describe_direction({})
    '(none)'
    """
    if not direction:
        return "(none)"
    return ", ".join(f"{one_based(name)} {weight:.3g}" for name, weight in direction.items())
