# Sweep definitions: axes (lists, grids, random samples), their points, each point validated.
"""What a parameter sweep varies, and the scenarios it makes.

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

**Point order.** The list and grid axes form a Cartesian product in axis
order, the first axis varying slowest (as nested loops, first axis
outermost). The random axes are sampled *jointly* ``samples`` times (sample
``j`` takes the ``j``-th draw of every random axis) and every product point
is combined with every sample, the samples varying faster than the product.
With ``seeds = N`` (> 1) every point is repeated with the scenario seeds
``s, s + 1, ..., s + N - 1`` (``s`` the scenario's own ``seed``; file key
``"seed"``), the seeds varying fastest. Points are numbered from 0 in that
order; a point's keys are the axes' keys in axis order, then ``"seed"``.

**Random draws.** Each random axis draws from its own stream,
``numpy.random.default_rng(SeedSequence(seed, spawn_key=(h,)))`` where
``seed`` is the sweep's seed and ``h`` the first 8 bytes (big-endian) of
the SHA-256 of the axis's key path: the same seed gives the same points,
and adding, removing or reordering other axes (or changing their
distributions) leaves an axis's draws unchanged. The draws are
``rng.uniform(low, high, samples)``, ``rng.normal(mean, std, samples)`` and
``exp(rng.uniform(log(low), log(high), samples))``.

**Validation.** :meth:`SweepDefinition.validate` builds every point's
scenario from the base scenario (its ``[sweep]`` table removed) by chained
:meth:`~trainctl.scenario.Scenario.replace` calls in the point's key order,
so every point obeys every rule a scenario file does; the first bad point
raises :class:`~trainctl.exceptions.ScenarioError` naming the point index,
the key and the value, before anything runs. :func:`point_key` identifies a
validated point's scenario (a SHA-256 of its TOML document), so that a
re-run can skip the points already done.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
import tomllib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from trainctl.exceptions import ScenarioError

if TYPE_CHECKING:
    from trainctl.scenario import Scenario

__all__ = [
    "DISTRIBUTIONS",
    "DRY_RUN_LISTED",
    "MAX_POINTS",
    "MAX_RUN_POINTS",
    "SAMPLED_PER_AXIS",
    "SCALES",
    "Axis",
    "GridAxis",
    "ListAxis",
    "RandomAxis",
    "SweepDefinition",
    "SweepPoint",
    "parse_set",
    "point_key",
]

SCALES = ("linear", "log")
"""Spacings of a :class:`GridAxis`."""

DISTRIBUTIONS = ("uniform", "normal", "log-uniform")
"""Distributions of a :class:`RandomAxis`."""

MAX_POINTS = 1_000_000
"""Most points of one sweep definition (a dry run summarises one this large in seconds)."""

MAX_RUN_POINTS = 10_000
"""Most points :meth:`SweepDefinition.validate` accepts, so most points a sweep runs.

Every point is validated (a whole scenario parse, a few milliseconds) and kept before
any runs, then every point runs (seconds to minutes each): 10 000 points take about a
minute to validate and hours to run; a larger sweep is refused at once, before any work
(split it into several sweeps, each into its own store)."""

DRY_RUN_LISTED = 1000
"""Most points a dry run validates and lists one by one; a larger sweep is summarised
(:meth:`SweepDefinition.sample_indices`)."""

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
        Position in :meth:`SweepDefinition.points` (from 0).
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


@dataclass(frozen=True)
class SweepDefinition:
    """The axes of a sweep and how they combine (see the module documentation).

    Parameters
    ----------
    axes : sequence of ListAxis, GridAxis or RandomAxis
        The axes, in order (at least one, or ``seeds`` > 1); each key once.
    seed : int
        Seed of the random axes' draws, >= 0.
    samples : int
        Joint draws of the random axes, >= 1; > 1 needs a random axis.
    seeds : int
        Repeat every point with the scenario seeds ``s, ..., s + seeds - 1``
        (``s`` the scenario's ``seed``), >= 1; 1: the scenario's seed only
        (no ``"seed"`` key in the points).

    Examples
    --------
    A 3 × 2 grid, the first axis varying slowest:

    >>> sweep = SweepDefinition([ListAxis("controller.r_per_kn2", [0.1, 1.0, 10.0]),
    ...                          ListAxis("model.sample_time", [10.0, 20.0])])
    >>> [tuple(p.values()) for p in sweep.points()]  # doctest: +NORMALIZE_WHITESPACE
    [(0.1, 10.0), (0.1, 20.0), (1.0, 10.0), (1.0, 20.0), (10.0, 10.0), (10.0, 20.0)]
    >>> from trainctl.scenario import load_scenario
    >>> scenarios = sweep.validate(load_scenario("crh2-dmpc"))
    >>> [s.controller.input_weight for s in scenarios[::2]]
    [0.1, 1.0, 10.0]
    """

    axes: tuple[Axis, ...]
    seed: int = 0
    samples: int = 1
    seeds: int = 1

    def __post_init__(self) -> None:
        axes = tuple(self.axes)
        object.__setattr__(self, "axes", axes)
        for name, value in (("seed", self.seed), ("samples", self.samples),
                            ("seeds", self.seeds)):
            low = 0 if name == "seed" else 1
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ScenarioError(f"sweep: {name} must be an integer >= {low} (got {value!r}).")
        for axis in axes:
            if not isinstance(axis, ListAxis | GridAxis | RandomAxis):
                raise ScenarioError(f"sweep: each axis must be a ListAxis, GridAxis or "
                                    f"RandomAxis (got {axis!r}).")
        if not axes and self.seeds == 1:
            raise ScenarioError("sweep: no axis to vary. Give at least one axis ([[sweep.axis]] "
                                "or --set KEY=V1,V2,...) or seeds > 1.")
        keys = [a.key for a in axes]
        for key in keys:
            if keys.count(key) > 1:
                raise ScenarioError(f"sweep: the key {key!r} has {keys.count(key)} axes; give "
                                    "each key one axis (list all its values in one).")
        if self.seeds > 1 and SEED_KEY in keys:
            raise ScenarioError(f"sweep: seeds = {self.seeds} varies the key 'seed', which also "
                                "has an axis; use one or the other.")
        if self.samples > 1 and not any(a.random for a in axes):
            raise ScenarioError(f"sweep: samples = {self.samples} needs a random axis (one with "
                                "a distribution); list and grid axes take every value once.")
        if self.n_points > MAX_POINTS:
            raise ScenarioError(f"sweep: {self.n_points} points, more than {MAX_POINTS}. Split "
                                "the sweep or use fewer values.")

    @classmethod
    def of(cls, scenario: Scenario, axes: Sequence[Axis] = (), *,
           seeds: int | None = None) -> SweepDefinition:
        """The sweep ``trainctl sweep SCENARIO [--set ...] [--seeds N]`` runs.

        Parameters
        ----------
        scenario : Scenario
            The base scenario; its ``[sweep]`` section (if any) gives the
            axes when ``axes`` is empty, and its seed options.
        axes : sequence of Axis
            Axes that replace the section's (e.g. from :func:`parse_set`).
        seeds : int or None
            Seeds per point (None: the section's, else 1).

        Returns
        -------
        SweepDefinition

        Raises
        ------
        ScenarioError
            If there is nothing to sweep: no axes, no ``[sweep]`` section and
            no seeds.

        Examples
        --------
        >>> from trainctl.scenario import load_scenario
        >>> base = load_scenario("crh2-dmpc-convergence-sweep")
        >>> SweepDefinition.of(base).n_points
        8
        >>> SweepDefinition.of(base, [parse_set("controller.r_per_kn2=1,2")], seeds=3).keys
        ('controller.r_per_kn2', 'seed')
        """
        given = scenario.sweep
        axes = tuple(axes)
        if not axes and given is None and seeds is None:
            raise ScenarioError(f"{scenario.source}: no sweep to run: the scenario has no [sweep] "
                                "section. Give axes (--set KEY=V1,V2,..., e.g. --set "
                                "controller.r_per_kn2=0.1,1,10) or seeds (--seeds N), or add a "
                                "[sweep] section.")
        if axes or given is None:
            return cls(axes, seed=given.seed if given else 0,
                       seeds=seeds or (given.seeds if given else 1))
        return cls(given.axes, seed=given.seed, samples=given.samples,
                   seeds=seeds or given.seeds)

    @property
    def n_points(self) -> int:
        """Number of points: product of the grid sizes × samples (if random) × seeds."""
        n = math.prod([len(a.grid_values()) for a in self.axes if not isinstance(a, RandomAxis)])
        return n * (self.samples if any(a.random for a in self.axes) else 1) * self.seeds

    @property
    def keys(self) -> tuple[str, ...]:
        """The key paths of every point, in order (axis keys, then ``"seed"`` if seeds > 1)."""
        return tuple(a.key for a in self.axes) + ((SEED_KEY,) if self.seeds > 1 else ())

    def sizes(self) -> tuple[int, ...]:
        """How many values each varying part of the sweep has, slowest first.

        Returns
        -------
        tuple of int
            Each list or grid axis's values, then the random samples (when
            there is a random axis), then the seeds (when more than 1); their
            product is :attr:`n_points`.

        Examples
        --------
        >>> SweepDefinition([ListAxis("controller.r_per_kn2", [0.1, 1.0, 10.0]),
        ...                  ListAxis("model.sample_time", [10.0, 20.0])], seeds=4).sizes()
        (3, 2, 4)
        """
        sizes = [len(a.grid_values()) for a in self.axes if not isinstance(a, RandomAxis)]
        if any(a.random for a in self.axes):
            sizes.append(self.samples)
        if self.seeds > 1:
            sizes.append(self.seeds)
        return tuple(sizes)

    def point(self, index: int, base_seed: int = 0) -> SweepPoint:
        """Point ``index`` of :meth:`points`, without making the others.

        Parameters
        ----------
        index : int
            0 <= index < :attr:`n_points`.
        base_seed : int
            The scenario's seed, first of the ``seeds`` option's seeds.

        Returns
        -------
        SweepPoint

        Examples
        --------
        >>> sweep = SweepDefinition([ListAxis("controller.r_per_kn2", [0.1, 1.0, 10.0]),
        ...                          ListAxis("model.sample_time", [10.0, 20.0])])
        >>> all(sweep.point(i) == p for i, p in enumerate(sweep.points()))
        True
        >>> dict(SweepDefinition([GridAxis("controller.r_per_kn2", 1, 1000, 1000),
        ...                       GridAxis("controller.q_velocity", 1, 999, 999)]
        ...                      ).point(998_999))
        {'controller.r_per_kn2': 1000, 'controller.q_velocity': 999}
        """
        if not 0 <= index < self.n_points:
            raise IndexError(f"sweep point {index} of {self.n_points}")
        digits = []
        rest = index
        for size in reversed(self.sizes()):
            rest, digit = divmod(rest, size)
            digits.append(digit)
        digits.reverse()
        grids = [a.grid_values() for a in self.axes if not isinstance(a, RandomAxis)]
        position = iter(digits)
        combo = [grid[next(position)] for grid in grids]
        values: dict[str, Any] = {}
        if any(a.random for a in self.axes):
            sample = next(position)
            randoms = iter(a.draw(self.seed, self.samples)[sample]
                           for a in self.axes if isinstance(a, RandomAxis))
        grid_it = iter(combo)
        for axis in self.axes:
            values[axis.key] = next(randoms) if axis.random else next(grid_it)
        if self.seeds > 1:
            values[SEED_KEY] = base_seed + next(position)
        return SweepPoint(index, values)

    def sample_indices(self, per_axis: int = SAMPLED_PER_AXIS) -> list[int]:
        """Indices of the points a summarised dry run validates, in order.

        The first and the last point, and for each varying part (axis,
        samples, seeds) up to ``per_axis`` of its values evenly spread (its
        first and last among them; all of them when it has fewer), the
        other parts at their first value.

        Parameters
        ----------
        per_axis : int
            Values per part, >= 2.

        Returns
        -------
        list of int
            Sorted, distinct; at most ``2 + per_axis × parts``.

        Examples
        --------
        >>> sweep = SweepDefinition([GridAxis("controller.r_per_kn2", 1, 1000, 1000),
        ...                          GridAxis("controller.q_velocity", 1, 999, 999)])
        >>> indices = sweep.sample_indices(per_axis=3)
        >>> indices  # the first axis moves in steps of 999 points
        [0, 499, 998, 499500, 998001, 998999]
        """
        sizes = self.sizes()
        strides = [math.prod(sizes[k + 1:]) for k in range(len(sizes))]
        chosen = {0, self.n_points - 1}
        for size, stride in zip(sizes, strides, strict=True):
            count = min(size, max(2, int(per_axis)))
            chosen.update(round(j * (size - 1) / (count - 1)) * stride if count > 1 else 0
                          for j in range(count))
        return sorted(chosen)

    def points(self, base_seed: int = 0) -> list[SweepPoint]:
        """Every point, in the documented order.

        Parameters
        ----------
        base_seed : int
            The scenario's seed, first of the ``seeds`` option's seeds.

        Returns
        -------
        list of SweepPoint
            Numbered from 0.
        """
        grids = [a.grid_values() for a in self.axes if not isinstance(a, RandomAxis)]
        randoms = [a for a in self.axes if isinstance(a, RandomAxis)]
        draws = [a.draw(self.seed, self.samples) for a in randoms]
        samples = list(zip(*draws, strict=True)) if randoms else [()]
        seeds = [base_seed + k for k in range(self.seeds)] if self.seeds > 1 else [None]
        points: list[SweepPoint] = []
        for combo in itertools.product(*grids):
            for sample in samples:
                for seed in seeds:
                    grid_it, random_it = iter(combo), iter(sample)
                    values = {a.key: next(random_it) if a.random else next(grid_it)
                              for a in self.axes}
                    if seed is not None:
                        values[SEED_KEY] = seed
                    points.append(SweepPoint(len(points), values))
        return points

    def validate(self, scenario: Scenario) -> list[Scenario]:
        """Every point's scenario, validated like a file, before anything runs.

        The base is ``scenario`` without its ``[sweep]`` table; each point
        applies its keys with chained :meth:`Scenario.replace
        <trainctl.scenario.Scenario.replace>` calls in its key order (points
        sharing leading values share those steps).

        Parameters
        ----------
        scenario : Scenario
            The base scenario (read from a file: it needs its document).

        Returns
        -------
        list of Scenario
            One per point of :meth:`points`, in order.

        Raises
        ------
        ScenarioError
            At the first point a value of which breaks a rule: ``SOURCE: sweep
            point I (key = value, ...): <what must hold>`` (``SOURCE`` the
            scenario file's path or built-in name); at once, before any
            point is made, when the sweep has more than
            :data:`MAX_RUN_POINTS` points.
        """
        if self.n_points > MAX_RUN_POINTS:
            raise ScenarioError(
                f"{scenario.source}: sweep: {self.n_points} points "
                f"({' × '.join(map(str, self.sizes()))}), more than the {MAX_RUN_POINTS} a "
                "sweep runs: every point is validated before any runs (a few ms each) and "
                "then runs (seconds or more each). Split the sweep into several with fewer "
                "values (each into its own store); --dry-run summarises this one.")
        return list(_validated(_without_sweep(scenario), self.points(base_seed=scenario.seed),
                                scenario.source))

    def validate_sample(self, scenario: Scenario, per_axis: int = SAMPLED_PER_AXIS,
                        ) -> list[tuple[SweepPoint, Scenario]]:
        """The points of :meth:`sample_indices`, each validated like :meth:`validate`.

        What a dry run of a sweep too large to list checks, in time
        independent of the number of points.

        Parameters
        ----------
        scenario : Scenario
            The base scenario.
        per_axis : int
            Values per varying part (:meth:`sample_indices`).

        Returns
        -------
        list of (SweepPoint, Scenario)
            In point order.

        Raises
        ------
        ScenarioError
            As :meth:`validate`, at the first sampled point that breaks a rule.

        Examples
        --------
        >>> from trainctl.scenario import load_scenario
        >>> sweep = SweepDefinition([GridAxis("controller.r_per_kn2", 1, 1000, 1000),
        ...                          GridAxis("controller.q_velocity", 1, 999, 999)])
        >>> found = sweep.validate_sample(load_scenario("crh2-dmpc"), per_axis=2)
        >>> [p.index for p, _ in found], found[-1][1].controller.input_weight
        ([0, 998, 998001, 998999], 1000.0)
        """
        points = [self.point(i, base_seed=scenario.seed)
                  for i in self.sample_indices(per_axis)]
        return list(zip(points, _validated(_without_sweep(scenario), points, scenario.source),
                        strict=True))


def _validated(base: Scenario, points: Sequence[SweepPoint], source: str) -> Iterator[Scenario]:
    """Each point's scenario: ``base`` with the point's keys replaced, in the point's key order
    (points sharing leading values share those steps)."""
    cache: dict[tuple[tuple[str, str], ...], Scenario] = {}
    for point in points:
        current: Scenario = base
        prefix: tuple[tuple[str, str], ...] = ()
        for key, value in point.items():
            prefix = (*prefix, (key, toml_text(value)))
            if prefix not in cache:
                try:
                    cache[prefix] = current.replace(key, value)
                except ScenarioError as exc:
                    raise _point_error(source, point, key, value, exc) from None
            current = cache[prefix]
        yield current
        cache = {k: v for k, v in cache.items() if len(k) < len(point)}


def _point_error(source: str, point: SweepPoint, key: str, value: Any,
                 exc: ScenarioError) -> ScenarioError:
    message = str(exc)
    marker = f"({key} = {value!r}): "
    detail = message.split(marker, 1)[1] if marker in message else message
    return ScenarioError(f"{source}: sweep point {point.index} ({point.label()}): {detail}")


def _without_sweep(scenario: Scenario) -> Scenario:
    """``scenario`` without its ``[sweep]`` table (the same one if it has none)."""
    if scenario.document is None or "sweep" not in scenario.document:
        return scenario
    from trainctl.scenario.parse import parse_document
    from trainctl.scenario.replace import thaw

    document = {k: thaw(v) for k, v in scenario.document.items() if k != "sweep"}
    return parse_document(document, source=scenario.source, tags=scenario.tags)


def point_key(scenario: Scenario) -> str:
    """The stable key of a validated point: SHA-256 (hex) of its TOML document as JSON.

    The document (the scenario file's values with the point's changes, no
    ``[sweep]`` table) is written as JSON with sorted keys and no spaces;
    equal keys mean the same validated scenario, so a re-run of a sweep can
    skip the points whose key it has already stored, and a changed scenario
    never matches an old point.

    Parameters
    ----------
    scenario : Scenario
        A scenario read from a file (it has a document).

    Returns
    -------
    str
        64 hexadecimal digits.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> book = load_scenario("crh2-dmpc")
    >>> point_key(book) == point_key(load_scenario("crh2-dmpc"))
    True
    >>> point_key(book) == point_key(book.replace("controller.r_per_kn2", 1.0))
    False
    """
    from trainctl.scenario.replace import thaw

    if scenario.document is None:
        raise ScenarioError(f"point_key: {scenario.name!r} was built in Python and has no "
                            "document to identify it by.")
    document = {k: v for k, v in thaw(scenario.document).items() if k != "sweep"}
    text = json.dumps(document, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


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
