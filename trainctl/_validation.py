# Shared validation helpers: the one place that owns parameter messages.
"""Validation helpers used by the model constructors.

Messages follow the shape ``where: what must hold (got what). hint.``
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .exceptions import ModelError

__all__ = ["as_vector", "check_finite", "check_nonnegative", "check_positive"]


def check_finite(where: str, name: str, value: float) -> float:
    """Return ``value`` as float, or raise ModelError if it is not finite."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: {name!r} must be a number (got {value!r}).") from None
    if not math.isfinite(x):
        raise ModelError(f"{where}: {name!r} must be finite (got {value!r}).")
    return x


def check_positive(where: str, name: str, value: float) -> float:
    """Return ``value`` as float, or raise ModelError unless finite and > 0."""
    x = check_finite(where, name, value)
    if x <= 0.0:
        raise ModelError(f"{where}: {name!r} must be > 0 (got {value!r}).")
    return x


def check_nonnegative(where: str, name: str, value: float) -> float:
    """Return ``value`` as float, or raise ModelError unless finite and >= 0."""
    x = check_finite(where, name, value)
    if x < 0.0:
        raise ModelError(f"{where}: {name!r} must be >= 0 (got {value!r}).")
    return x


def as_vector(
    where: str, name: str, value: ArrayLike | Sequence[float], length: int | None = None
) -> NDArray[np.float64]:
    """Return a finite 1-D float array, checking its length when given."""
    arr = np.asarray(value, dtype=float)
    if arr.ndim != 1:
        raise ModelError(f"{where}: {name!r} must be a 1-D sequence (got shape {arr.shape}).")
    if length is not None and arr.shape[0] != length:
        raise ModelError(
            f"{where}: {name!r} must have length {length} (got {arr.shape[0]})."
        )
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: {name!r} must be finite (got {arr.tolist()}).")
    return arr
