# Display formatting shared by the report context builders.
"""Numbers, complex numbers and JSON-like values as short display strings."""

from __future__ import annotations

import math
import numbers
import re
from collections.abc import Mapping, Sequence
from typing import Any

from trainctl.naming import one_based

__all__ = [
    "docstring_units", "format_complex", "format_number", "format_value", "humanise", "one_based",
]

_LABELS = {
    "n_vehicles": "Number of vehicles",
}
"""Fixed labels of :func:`humanise` (a family's settings' labels are its ``settings_labels``)."""


def humanise(key: str) -> str:
    """``"sample_time"`` → ``"Sample time"`` (with a few fixed labels)."""
    if key in _LABELS:
        return _LABELS[key]
    text = str(key).replace("_", " ").strip()
    return text[:1].upper() + text[1:]


def is_real(value: Any) -> bool:
    """A real number that is not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def format_number(value: Any, digits: int = 6) -> str:
    """A real number in at most ``digits`` significant digits.

    Examples
    --------
    >>> format_number(2.0), format_number(0.30612345), format_number(float("inf"))
    ('2', '0.306123', '∞')
    >>> format_number(-1.5e-7)
    '−1.5e-07'
    """
    x = float(value)
    if math.isnan(x):
        return "—"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x == int(x) and abs(x) < 1e15:
        text = str(int(x))
    else:
        text = f"{x:.{digits}g}"
    return text.replace("-", "−", 1) if text.startswith("-") else text


def format_complex(re_part: Any, im_part: Any, digits: int = 6) -> str:
    """``a ± bj`` (just ``a`` when the imaginary part is zero)."""
    real, imag = float(re_part), float(im_part)
    if imag == 0.0:
        return format_number(real, digits)
    sign = "+" if imag > 0 else "−"
    return f"{format_number(real, digits)} {sign} {format_number(abs(imag), digits)}j"


def format_value(value: Any) -> str:
    """Any JSON-like value as short display text."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, complex):
        return format_complex(value.real, value.imag)
    if is_real(value):
        return format_number(value)
    if isinstance(value, str):
        return value
    if isinstance(value, Mapping):
        return ", ".join(f"{k}: {format_value(v)}" for k, v in value.items())
    if isinstance(value, Sequence) or hasattr(value, "tolist"):
        items = value.tolist() if hasattr(value, "tolist") else list(value)
        if not isinstance(items, list):  # a 0-d array
            return format_value(items)
        return "[" + ", ".join(format_value(v) for v in items) + "]"
    return str(value)


_PARAM = re.compile(r"^    (\w+) : [^\n]*\n((?:        [^\n]*\n?)*)", re.MULTILINE)
_UNIT = re.compile(r"\[([^\]]+)\]")


def docstring_units(cls: type) -> Mapping[str, str]:
    """Units of a class's parameters, read from its numpydoc ``Parameters``.

    The unit of a parameter is the first ``[...]`` in its description, the
    project's convention ("Sample time [s], > 0."); parameters without one
    are left out.

    Examples
    --------
    >>> from trainctl.scenario import ModelSettings
    >>> docstring_units(ModelSettings)["sample_time"]
    's'
    """
    doc = cls.__doc__ or ""
    units = {}
    for match in _PARAM.finditer(doc):
        found = _UNIT.search(match.group(2))
        if found:
            units[match.group(1)] = found.group(1)
    return units


