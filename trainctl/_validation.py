# Shared validation helpers: the one place that owns parameter messages.
"""Validation helpers used by the model constructors.

Messages follow the shape ``where: what must hold (got what). hint.``
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import ModelError

__all__ = ["as_vector", "check_finite", "check_finite_arrays", "check_nonnegative",
           "check_positive", "numerical_errors"]

_DEGENERATE_HINT = (
    "The model's numbers are too far apart for floating point (e.g. a very light vehicle on "
    "a very stiff or strongly damped coupler); bring the masses, couplers, Davis terms and "
    "sample time closer to a train's (trainctl.declare.limits gives the hard bounds).")


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


def check_finite_arrays(where: str, hint: str = "", **arrays: ArrayLike) -> None:
    """Raise ModelError naming the first array with a non-finite entry (and where).

    Parameters
    ----------
    where : str
        The message's first words, e.g. ``"discretise"``.
    hint : str
        Sentences appended to the message (how to avoid it).
    **arrays : array_like
        The arrays by the name the message uses.

    Raises
    ------
    ModelError
        ``"where: A must be finite (got inf at [0, 1]).hint"``.

    Examples
    --------
    >>> check_finite_arrays("demo", A=[[1.0, 2.0]])
    >>> check_finite_arrays("demo", " Shorten T.", A=[[1.0, float("inf")]])
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: demo: A must be finite (got inf at [0, 1]). Shorten T.
    """
    for name, value in arrays.items():
        arr = np.asarray(value)
        if arr.dtype.kind not in "fc" or np.all(np.isfinite(arr)):
            continue
        index = [int(i) for i in np.argwhere(~np.isfinite(arr))[0]]
        at = f" at {index}" if index else ""
        raise ModelError(f"{where}: {name} must be finite (got {arr[tuple(index)]}{at}).{hint}")


@contextlib.contextmanager
def numerical_errors(where: str) -> Iterator[None]:
    """Turn a numerical breakdown inside the block into a :class:`ModelError`.

    NumPy's ``LinAlgError`` (eigenvalues or an SVD that do not converge,
    infs or NaNs in a factorisation) and float overflow are not bugs of the
    code but of a model whose numbers floating point cannot hold; they
    become a ModelError naming ``where``.

    Parameters
    ----------
    where : str
        The message's first words, e.g. the scenario's file.

    Yields
    ------
    None

    Raises
    ------
    ModelError
        From ``numpy.linalg.LinAlgError``, ``OverflowError`` or
        ``FloatingPointError`` raised in the block.

    Examples
    --------
    >>> try:
    ...     with numerical_errors("demo"):
    ...         np.linalg.eigvals(np.array([[np.inf]]))
    ... except ModelError as exc:
    ...     print(str(exc).split(" (")[0])
    demo: the model's linear algebra failed
    """
    try:
        yield
    except np.linalg.LinAlgError as exc:
        raise ModelError(f"{where}: the model's linear algebra failed ({exc}). "
                         f"{_DEGENERATE_HINT}") from exc
    except (OverflowError, FloatingPointError) as exc:
        raise ModelError(f"{where}: a computation overflowed ({exc}). {_DEGENERATE_HINT}") from exc
