# Sweep axes (lists, grids, random samples), sweep points, and the --set spelling of an axis.
"""The axes of a parameter sweep (the ``[sweep]`` table of a scenario file) and its points.

A sweep is a set of **axes**, each varying one file key of a scenario (the
key paths of :meth:`~trainctl.scenario.Scenario.replace`:
``"controller.r_per_kn2"``, ``"train.vehicle[1].mass_t"``; values in the
key's file unit):

* :class:`ListAxis` — the values given, in order;
* :class:`GridAxis` — ``num`` values from ``start`` to ``stop`` (both
  included), evenly spaced (``scale = "linear"``) or evenly spaced in
  log10 (``scale = "log"``, start and stop > 0);
* :class:`RandomAxis` — ``samples`` values drawn from ``"uniform"`` (on
  [low, high)), ``"normal"`` (mean, std) or ``"log-uniform"`` (log
  uniform on [low, high), low > 0).

**Random draws.** Each random axis draws from its own stream,
``numpy.random.default_rng(SeedSequence(seed, spawn_key=(h,)))`` where
``seed`` is the sweep's seed and ``h`` the first 8 bytes (big-endian) of
the SHA-256 of the axis's key path: the same seed gives the same points,
and adding, removing or reordering other axes (or changing their
distributions) leaves an axis's draws unchanged. The draws are
``rng.uniform(low, high, samples)``, ``rng.normal(mean, std, samples)`` and
``exp(rng.uniform(log(low), log(high), samples))``.

How the axes combine into numbered points, and how each point is validated,
is :class:`~trainctl.scenario.sweep_definition.SweepDefinition`'s part. The
scenario stage reads ``[sweep]`` (:mod:`trainctl.scenario.parse`); running a
sweep is :mod:`trainctl.sweep`'s.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from trainctl.exceptions import ScenarioError

__all__ = [
    "DISTRIBUTIONS",
    "DRY_RUN_LISTED",
    "MAX_POINTS",
    "MAX_RUN_POINTS",
    "SAMPLED_PER_AXIS",
    "SCALES",
    "SEED_KEY",
    "Axis",
    "GridAxis",
    "ListAxis",
    "RandomAxis",
    "SweepPoint",
    "parse_set",
    "toml_text",
]

SCALES = ("linear", "log")
"""Spacings of a :class:`GridAxis`."""

DISTRIBUTIONS = ("uniform", "normal", "log-uniform")
"""Distributions of a :class:`RandomAxis`."""

MAX_POINTS = 1_000_000
"""Most points of one sweep definition (a dry run summarises one this large in seconds)."""

MAX_RUN_POINTS = 10_000
"""Most points :meth:`~trainctl.scenario.sweep_definition.SweepDefinition.validate` accepts,
so most points a sweep runs.

Every point is validated (a whole scenario parse, a few milliseconds) and kept before
any runs, then every point runs (seconds to minutes each): 10 000 points take about a
minute to validate and hours to run; a larger sweep is refused at once, before any work
(split it into several sweeps, each into its own store)."""

DRY_RUN_LISTED = 1000
"""Most points a dry run validates and lists one by one; a larger sweep is summarised
(:meth:`~trainctl.scenario.sweep_definition.SweepDefinition.sample_indices`)."""

SAMPLED_PER_AXIS = 25
"""Values per axis a summarised dry run validates (all of a shorter axis)."""

SEED_KEY = "seed"
"""The file key the ``seeds`` option varies (the scenario's top-level ``seed``)."""



def _fail(where: str, message: str) -> ScenarioError:
    return ScenarioError(f"sweep axis {where}: {message}")


def _check_key(key: object) -> str:
    from trainctl.scenario.replace import parse_key_path

    if not isinstance(key, str) or not key:
        raise ScenarioError(f"sweep axis: the key must be a file key path such as "
                            f"'controller.r_per_kn2' (got {key!r}).")
    try:
        parse_key_path(key)
    except ScenarioError as exc:
        raise ScenarioError(f"sweep axis {key!r}: {str(exc).split(': ', 1)[1]}") from None
    return key


def _number(key: str, name: str, value: object, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _fail(repr(key), f"{name} must be a finite number (got {value!r}).")
    if positive and value <= 0:
        raise _fail(repr(key), f"{name} must be > 0 (got {value!r}).")
    return value


def _plain(value: Any) -> Any:
    """numpy scalars and arrays as Python values."""
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


@dataclass(frozen=True)
class ListAxis:
    """An axis over the values given, in order.

    Parameters
    ----------
    key : str
        File key path, e.g. ``"controller.r_per_kn2"``.
    values : sequence
        The values, in the key's file unit (TOML values: numbers, booleans,
        strings, arrays); at least one.

    Examples
    --------
    >>> ListAxis("controller.r_per_kn2", [0.1, 1, 10]).values
    (0.1, 1, 10)
    >>> ListAxis("controller.r_per_kn2", [])
    Traceback (most recent call last):
        ...
    trainctl.exceptions.ScenarioError: sweep axis 'controller.r_per_kn2': values must be a \
non-empty array (got []). Give at least one value.
    """

    key: str
    values: Sequence[Any]

    def __post_init__(self) -> None:
        _check_key(self.key)
        values = self.values
        if isinstance(values, str | bytes | Mapping) or not isinstance(
                values, Sequence | np.ndarray):
            raise _fail(repr(self.key), f"values must be an array of values (got {values!r}).")
        if len(values) == 0:
            raise _fail(repr(self.key), f"values must be a non-empty array (got {list(values)!r})."
                        " Give at least one value.")
        object.__setattr__(self, "values", tuple(_plain(v) for v in values))

    @property
    def random(self) -> bool:
        """False: the axis joins the Cartesian product."""
        return False

    def grid_values(self) -> tuple[Any, ...]:
        """The values, in order.

        Returns
        -------
        tuple
            The axis's values as given (file unit; numpy values as Python
            values).
        """
        return tuple(self.values)


@dataclass(frozen=True)
class GridAxis:
    """An axis of ``num`` evenly spaced values from ``start`` to ``stop``, both included.

    Parameters
    ----------
    key : str
        File key path.
    start, stop : float
        First and last value, in the key's file unit (``stop`` may be below
        ``start``: a descending grid); for ``scale = "log"`` both > 0.
    num : int
        Number of values, >= 1 (1: ``start`` alone).
    scale : {"linear", "log"}
        Even spacing of the values, or of their logarithms.

    Notes
    -----
    A linear grid whose ``start`` and ``stop`` are integers and whose
    values are all whole numbers gives integers (for integer keys such as
    ``controller.prediction_horizon``).

    Examples
    --------
    >>> GridAxis("controller.r_per_kn2", 0.1, 10.0, 3, scale="log").grid_values()
    (0.1, 1.0, 10.0)
    >>> GridAxis("controller.prediction_horizon", 2, 10, 5).grid_values()
    (2, 4, 6, 8, 10)
    """

    key: str
    start: float
    stop: float
    num: int
    scale: str = "linear"

    def __post_init__(self) -> None:
        key = _check_key(self.key)
        log = self.scale == "log"
        if self.scale not in SCALES:
            raise _fail(repr(key), f"scale must be 'linear' or 'log' (got {self.scale!r}).")
        _number(key, "start", self.start, positive=log)
        _number(key, "stop", self.stop, positive=log)
        if isinstance(self.num, bool) or not isinstance(self.num, int) or self.num < 1:
            raise _fail(repr(key), f"num must be an integer >= 1 (got {self.num!r}): an empty "
                        "grid has no points. Give the number of values from start to stop.")
        if self.num > MAX_POINTS:
            raise _fail(repr(key), f"num must be at most {MAX_POINTS} (got {self.num!r}).")

    @property
    def random(self) -> bool:
        """False: the axis joins the Cartesian product."""
        return False

    def grid_values(self) -> tuple[Any, ...]:
        """The ``num`` values (Python floats, or ints for a whole-number linear grid).

        Returns
        -------
        tuple of float or tuple of int
            From ``start`` to ``stop`` (both exactly), evenly spaced or evenly
            spaced in log10, in the key's file unit; ``(start,)`` unchanged for
            ``num = 1``.
        """
        if self.num == 1:
            return (self.start,)
        if self.scale == "log":
            values = np.logspace(math.log10(self.start), math.log10(self.stop), self.num)
            values[0], values[-1] = self.start, self.stop  # exact ends, not 10**log10(x)
            return tuple(float(v) for v in values)
        values = np.linspace(self.start, self.stop, self.num)
        if (isinstance(self.start, int) and isinstance(self.stop, int)
                and all(float(v).is_integer() for v in values)):
            return tuple(int(v) for v in values)
        return tuple(float(v) for v in values)


@dataclass(frozen=True)
class RandomAxis:
    """An axis of random values, ``samples`` draws (the sweep's) from a distribution.

    Parameters
    ----------
    key : str
        File key path.
    distribution : {"uniform", "normal", "log-uniform"}
        ``"uniform"`` on [low, high); ``"normal"`` with ``mean`` and ``std``;
        ``"log-uniform"``: log uniform on [log low, log high), 0 < low.
    low, high : float or None
        Bounds of ``"uniform"`` and ``"log-uniform"`` (file unit), low < high.
    mean, std : float or None
        Mean and standard deviation of ``"normal"`` (file unit), std > 0.

    Examples
    --------
    >>> axis = RandomAxis("train.vehicle[0].mass_t", "uniform", low=40.0, high=50.0)
    >>> values = axis.draw(seed=0, samples=3)
    >>> len(values), all(40.0 <= v < 50.0 for v in values)
    (3, True)
    >>> values == axis.draw(seed=0, samples=3)
    True
    """

    key: str
    distribution: str
    low: float | None = None
    high: float | None = None
    mean: float | None = None
    std: float | None = None

    def __post_init__(self) -> None:
        key = _check_key(self.key)
        where = repr(key)
        if self.distribution not in DISTRIBUTIONS:
            raise _fail(where, f"distribution must be one of {', '.join(DISTRIBUTIONS)} (got "
                        f"{self.distribution!r}).")
        bounded = self.distribution != "normal"
        needed, unused = (("low", "high"), ("mean", "std")) if bounded else (
            ("mean", "std"), ("low", "high"))
        for name in unused:
            if getattr(self, name) is not None:
                raise _fail(where, f"{name} does not apply to distribution "
                            f"{self.distribution!r} (got {getattr(self, name)!r}); it takes "
                            f"{' and '.join(needed)}.")
        for name in needed:
            if getattr(self, name) is None:
                raise _fail(where, f"distribution {self.distribution!r} needs {name}.")
        if bounded:
            low = _number(key, "low", self.low, positive=self.distribution == "log-uniform")
            high = _number(key, "high", self.high)
            if not low < high:
                raise _fail(where, f"low must be less than high (got low = {low!r}, high = "
                            f"{high!r}): the range is empty.")
        else:
            _number(key, "mean", self.mean)
            _number(key, "std", self.std, positive=True)

    @property
    def random(self) -> bool:
        """True: the axis is sampled jointly with the other random axes."""
        return True

    def rng(self, seed: int) -> np.random.Generator:
        """This axis's generator: ``SeedSequence(seed, spawn_key=(h,))``, ``h`` from the key.

        Parameters
        ----------
        seed : int
            The sweep's seed, >= 0.

        Returns
        -------
        numpy.random.Generator
            A new generator, ``h`` being the first 8 bytes (big-endian) of the
            SHA-256 of the key path: the same seed and key give the same stream.
        """
        h = int.from_bytes(hashlib.sha256(self.key.encode("utf-8")).digest()[:8], "big")
        return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(h,)))

    def draw(self, seed: int, samples: int) -> tuple[float, ...]:
        """The ``samples`` values of this axis for the sweep seed ``seed`` (Python floats).

        Parameters
        ----------
        seed : int
            The sweep's seed, >= 0 (see :meth:`rng`).
        samples : int
            Number of values to draw, >= 1.

        Returns
        -------
        tuple of float
            The draws from the distribution, in the key's file unit, in draw
            order.
        """
        rng = self.rng(seed)
        low, high = float(self.low or 0.0), float(self.high or 0.0)
        if self.distribution == "uniform":
            values = rng.uniform(low, high, samples)
        elif self.distribution == "normal":
            values = rng.normal(float(self.mean or 0.0), float(self.std or 0.0), samples)
        else:
            values = np.exp(rng.uniform(math.log(low), math.log(high), samples))
        return tuple(float(v) for v in values)


Axis = ListAxis | GridAxis | RandomAxis
"""One axis of a sweep."""


@dataclass(frozen=True)
class SweepPoint(Mapping[str, Any]):
    """One point of a sweep: key path to value, in the point's key order, and its index.

    Parameters
    ----------
    index : int
        Position in :meth:`~trainctl.scenario.sweep_definition.SweepDefinition.points` (from 0).
    changes : mapping of str to object
        File key path to value (file unit), axis order, then ``"seed"``
        (the point is also this mapping: ``point["seed"]``, ``dict(point)``).

    Examples
    --------
    >>> point = SweepPoint(2, {"controller.r_per_kn2": 10.0})
    >>> point.index, dict(point), point.label()
    (2, {'controller.r_per_kn2': 10.0}, 'controller.r_per_kn2 = 10.0')
    """

    index: int
    changes: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from trainctl.scenario.frozen import FrozenMapping

        object.__setattr__(self, "changes", FrozenMapping(self.changes))

    def __getitem__(self, key: str) -> Any:
        return self.changes[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.changes)

    def __len__(self) -> int:
        return len(self.changes)

    def label(self) -> str:
        """``"key = value, ..."`` (TOML spelling of the values).

        Returns
        -------
        str
            Each key path with its value as a TOML file writes it, in the
            point's key order, joined by commas.
        """
        return ", ".join(f"{k} = {toml_text(v)}" for k, v in self.changes.items())


def toml_text(value: Any) -> str:
    """A TOML value as written in a file: ``true``, ``"zoh"``, ``[1.0, 2.0]``, ``0.1``.

    Parameters
    ----------
    value : object
        A TOML value: a bool, str, number, array or table.

    Returns
    -------
    str
        Its TOML spelling.

    Examples
    --------
    >>> toml_text(True), toml_text("zoh"), toml_text([1, 2.5])
    ('true', '"zoh"', '[1, 2.5]')
    """
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_text(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k} = {toml_text(v)}" for k, v in value.items()) + "}"
    return repr(value)


_SET = re.compile(r"^\s*([^=\s]+)\s*=(.*)$", re.DOTALL)
_BARE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]*$")


def parse_set(text: str) -> ListAxis:
    """A list axis from ``--set KEY=V1,V2,...``.

    The values are split on commas outside brackets and quotes; each is a
    TOML value (``0.1``, ``1e-3``, ``10``, ``true``, ``"zoh"``, an array
    ``[1.0, 2.0]`` for an array-valued key). A bare word that is not a TOML
    value (``zoh``, ``tustin``) is taken as a string.

    Parameters
    ----------
    text : str
        ``KEY=V1,V2,...``.

    Returns
    -------
    ListAxis
        The axis over the values, in order.

    Raises
    ------
    ScenarioError
        If there is no ``=``, the key path is malformed, a value is empty or
        not a TOML value.

    Examples
    --------
    >>> parse_set("controller.r_per_kn2=0.1,1,10").values
    (0.1, 1, 10)
    >>> parse_set('simulation.reference.speeds_kmh=[72.0, 288.0],[0, 100]').values
    ([72.0, 288.0], [0, 100])
    >>> parse_set("model.discretisation=zoh,\\"tustin\\"").values
    ('zoh', 'tustin')
    >>> parse_set("model.sample_time")
    Traceback (most recent call last):
        ...
    trainctl.exceptions.ScenarioError: --set 'model.sample_time': must be KEY=V1,V2,... \
(e.g. controller.r_per_kn2=0.1,1,10).
    """
    match = _SET.match(text)
    if match is None:
        raise ScenarioError(f"--set {text!r}: must be KEY=V1,V2,... (e.g. "
                            "controller.r_per_kn2=0.1,1,10).")
    key, rest = match.group(1), match.group(2)
    values = [_set_value(text, piece.strip()) for piece in _split(text, rest)]
    try:
        return ListAxis(key, values)
    except ScenarioError as exc:
        raise ScenarioError(f"--set {text!r}: {str(exc).split(': ', 1)[1]}") from None


def _split(text: str, rest: str) -> list[str]:
    """``rest`` split on the commas outside brackets, braces and quotes."""
    pieces, depth, quote, start = [], 0, "", 0
    for i, c in enumerate(rest):
        if quote:
            if c == quote and rest[i - 1] != "\\":
                quote = ""
        elif c in "\"'":
            quote = c
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
            if depth < 0:
                raise ScenarioError(f"--set {text!r}: unbalanced {c!r} in the values.")
        elif c == "," and depth == 0:
            pieces.append(rest[start:i])
            start = i + 1
    if quote or depth:
        raise ScenarioError(f"--set {text!r}: unclosed {quote or '['} in the values.")
    pieces.append(rest[start:])
    if rest.strip() == "":
        raise ScenarioError(f"--set {text!r}: no values after '='. Give at least one value, "
                            "e.g. KEY=0.1,1,10.")
    return pieces


def _set_value(text: str, piece: str) -> Any:
    if not piece:
        raise ScenarioError(f"--set {text!r}: an empty value (two commas in a row, or one at "
                            "an end). Give KEY=V1,V2,... with a value between every two commas.")
    try:
        return tomllib.loads(f"v = {piece}")["v"]
    except tomllib.TOMLDecodeError:
        if _BARE.match(piece):
            return piece
        raise ScenarioError(f"--set {text!r}: {piece!r} is not a TOML value (a number, true "
                            "or false, a quoted string or an [array]).") from None
