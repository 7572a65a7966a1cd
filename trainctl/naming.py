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

__all__ = ["UNPRINTABLE", "describe_direction", "one_based", "printable"]

_UNPRINTABLE_CLASS = (r"\x00-\x08\x0b-\x1f\x7f-\x9f\u061C\u200E\u200F\u202A-\u202E"
                      r"\u2066-\u2069")
UNPRINTABLE = re.compile(f"[{_UNPRINTABLE_CLASS}]")
"""Characters refused in text and escaped on output (:func:`printable`).

The C0 controls but the tab and the line feed, DEL and the C1 controls, the
Arabic letter mark, the left-to-right and right-to-left marks, embeddings,
overrides and isolates: characters that a terminal obeys as commands or that
reorder the text shown around them.
"""

_INDEXED = re.compile(r"\b([A-Za-z_]\w*)\[(\d+)\]")
_SUBSCRIPTS = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")
_SYMBOLS = {"delta": "δ"}


def printable(text: str) -> str:
    """Text safe to show in a terminal or a page: control characters written as escapes.

    Every character of :data:`UNPRINTABLE` (a NUL, an
    escape that starts a terminal command, a right-to-left override, ...)
    becomes the escape ``\\uXXXX`` that spells it (valid in Python, TOML and
    JSON strings alike); tabs, line feeds and all other text stay. Scenario
    files cannot hold such characters in their text fields; this is for
    everything else a user gives: file names, values quoted in messages,
    names set in Python or read from a saved run.

    Parameters
    ----------
    text : str
        Any text.

    Returns
    -------
    str
        ``text`` with each unprintable character escaped.

    Examples
    --------
    >>> printable("red \\x1b[31m, NUL \\x00, \\u202eabc, tab\\tnewline\\n")
    'red \\\\u001b[31m, NUL \\\\u0000, \\\\u202eabc, tab\\tnewline\\n'
    """
    if UNPRINTABLE.search(text) is None:
        return text
    return UNPRINTABLE.sub(lambda match: f"\\u{ord(match.group()):04x}", text)


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
