# Sweep definitions: how the axes combine into points, each point validated as a scenario.
"""What a parameter sweep varies, and the scenarios it makes.

A :class:`SweepDefinition` is a set of axes (:mod:`trainctl.scenario.sweep_axes`:
:class:`~trainctl.scenario.sweep_axes.ListAxis`,
:class:`~trainctl.scenario.sweep_axes.GridAxis`,
:class:`~trainctl.scenario.sweep_axes.RandomAxis`) and how they combine.

**Point order.** The list and grid axes form a Cartesian product in axis
order, the first axis varying slowest (as nested loops, first axis
outermost). The random axes are sampled *jointly* ``samples`` times (sample
``j`` takes the ``j``-th draw of every random axis) and every product point
is combined with every sample, the samples varying faster than the product.
With ``seeds = N`` (> 1) every point is repeated with the scenario seeds
``s, s + 1, ..., s + N - 1`` (``s`` the scenario's own ``seed``; file key
``"seed"``), the seeds varying fastest. Points are numbered from 0 in that
order; a point's keys are the axes' keys in axis order, then ``"seed"``.

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
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from trainctl.exceptions import ScenarioError
from trainctl.scenario.sweep_axes import (
    MAX_POINTS,
    MAX_RUN_POINTS,
    SAMPLED_PER_AXIS,
    SEED_KEY,
    Axis,
    GridAxis,
    ListAxis,
    RandomAxis,
    SweepPoint,
    toml_text,
)

if TYPE_CHECKING:
    from trainctl.scenario import Scenario

__all__ = ["SweepDefinition", "point_key"]


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
        >>> from trainctl.scenario.sweep_axes import parse_set
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
    return parse_document(document, source=scenario.source, tags=scenario.tags,
                          directory=scenario.directory)


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
