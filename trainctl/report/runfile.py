# The saved-run manifest (trainctl-run.json), declared: what `report DIR` may rely on.
"""The declaration of ``trainctl-run.json`` and the checks of a saved run as a whole.

:class:`RunFile` declares the manifest (format :data:`FORMAT`): its top level
closed (an unknown key is an error), and in ``results`` every key the report
reads, typed (further keys allowed, so that a run carries more than the page
shows). :func:`read_saved_run` validates it and then the run as a whole: the
scenario text matches the checksum recorded when it was saved (another
scenario's TOML, or an edited one, is named as such), the strategies listed
are the ones simulated and saved, and every simulation result
(:mod:`trainctl.sim.resultfile`) belongs to its strategy and to the scenario's
train and sample time.

Nothing of the file is trusted: counts are integers within
:mod:`trainctl.declare.limits`, statuses and verdicts come from their vocabularies,
per-vehicle lists have one entry per vehicle, ``failed_checks`` and
``unexpected`` follow from the checks, and the scenario text (re-validated)
must be the one the results describe: its name, train, speed, sample time,
``[expected]`` table and strategies. Each simulation's status counts and
largest iteration count must be those of its saved arrays.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    StrictBool,
    StrictFloat,
    StrictStr,
    model_validator,
)

from trainctl._files import read_regular
from trainctl.controllers.base import STATUSES as STEP_STATUSES
from trainctl.declare.constraints import Choice, Integer, Violation, raise_at
from trainctl.declare.jsonfile import FiniteFloat, read_json, validate_json
from trainctl.declare.limits import MAX_SAMPLES, MAX_VEHICLES, SAMPLE_TIME, SPEED, in_unit
from trainctl.exceptions import DimensionError, ModelError, ScenarioError
from trainctl.units import KMH_PER_MS

__all__ = ["FORMAT", "MANIFEST", "RUN_HINT", "RunFile", "read_saved_run", "text_digest"]

FORMAT = "trainctl.ReportData/3"
"""Format tag of ``trainctl-run.json`` (3: the scenario text's checksum is recorded)."""

MANIFEST = "trainctl-run.json"
"""File that marks a saved-results directory."""

RUN_HINT = (" The saved run was edited or damaged; re-create it with 'trainctl analyse SCENARIO "
            "--save DIR'.")
"""The sentence every message about a saved run ends with."""



def _scalar(value: Any) -> Any:
    if value is None or isinstance(value, bool | float | str):
        return value
    if isinstance(value, int) and -2**63 <= value < 2**63:  # an integer as numpy holds it
        return value
    raise ValueError("must be a number (integers within ±2**63), a string, a boolean or null")


Scalar = Annotated[Any, AfterValidator(_scalar)]  # a check's value or threshold
Number = StrictFloat | None  # a number (the page shows inf and nan as such), or null

CHECK_STATUSES = ("pass", "warn", "fail")
"""A check's verdicts (:data:`trainctl.analysis.check.STATUSES`, not imported: the analysis
package is slow to import and reading a run needs none of it)."""

Verdict = Annotated[str, Choice(CHECK_STATUSES)]
Found = Annotated[str, Choice((*CHECK_STATUSES, "missing"))]  # a check's status, or none
StepStatus = Annotated[str, Choice(STEP_STATUSES)]
Vehicles = Annotated[int, Integer(ge=1, le=MAX_VEHICLES)]
Count = Annotated[int, Integer(ge=0, le=4 * MAX_VEHICLES)]  # states, inputs, outputs
Steps = Annotated[int, Integer(ge=0, le=MAX_SAMPLES)]  # samples of one run


class _Open(BaseModel):
    model_config = ConfigDict(extra="allow", frozen=True)


class _Closed(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


class Check(_Open):
    """One design check of ``results.checks``."""

    name: StrictStr
    status: Verdict
    value: Scalar = None
    threshold: Scalar = None
    unit: StrictStr | None = None
    message: StrictStr
    hint: StrictStr


class Equilibrium(_Open):
    """``results.equilibrium``: the cruise inputs and static coupler forces [N, m]."""

    feasible: StrictBool | None = None
    inputs: list[Number]
    traction_limit: list[Number]
    coupler_forces: list[Number]
    elongations: list[Number]
    braking_limit: list[Number] | None = None


class Sampling(_Open):
    """``results.sampling``."""

    sample_time: Annotated[float, SAMPLE_TIME]
    nyquist_sample_time: Number
    omega_max_times_T: Number
    discrete_spectral_radius: Number


class Mode(_Open):
    """One mode of ``results.modes``."""

    kind: StrictStr
    eigenvalue: tuple[FiniteFloat, FiniteFloat]
    natural_frequency: Number
    damping_ratio: Number
    period: Number
    multiplicity: Annotated[int, Integer(ge=1, le=4 * MAX_VEHICLES)]


class Metrics(_Open):
    """One strategy's closed-loop metrics, ``results.simulations.<strategy>``."""

    rms_error: list[Number] = Field(min_length=1)
    max_error: list[Number] = Field(min_length=1)
    max_coupler_force: Number
    energy_kwh: Number
    max_jerk: Number
    iterations_mean: Number
    iterations_max: Annotated[int, Integer(ge=0, le=2**31 - 1)]  # a solver's or a scheme's
    solve_time_median: Number
    solve_time_p95: Number
    status_counts: dict[StepStatus, Steps]
    tracking_ok: StrictBool
    saturation_time: list[Number] | None = None
    braking_saturation_time: list[Number] | None = None
    coupler_peak_force: list[Number] | None = None
    coupler_peak_time: list[Number] | None = None
    coupler_over_time: list[Number] | None = None


class Results(_Open):
    """``results``: the run's summary (``AnalysisRun.to_dict()``), as far as the report reads it."""

    scenario: StrictStr
    train: StrictStr
    n_vehicles: Vehicles
    vehicles: list[dict[str, Any]]
    n_states: Count
    n_inputs: Count
    n_outputs: Count
    states: list[StrictStr]
    inputs: list[StrictStr]
    outputs: list[StrictStr]
    speed: Annotated[float, SPEED]
    speed_kmh: Annotated[float, in_unit(SPEED, lambda kmh: kmh / KMH_PER_MS)]
    linearisation: StrictStr
    sampling: Sampling
    equilibrium: Equilibrium
    modes: list[Mode]
    checks: list[Check]
    failed_checks: list[StrictStr]
    expected: dict[str, Verdict] = Field(default_factory=dict)
    unexpected_checks: dict[str, Any] = Field(default_factory=dict)
    unsimulated_checks: list[StrictStr] = Field(default_factory=list)
    simulations: dict[str, Metrics] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _relations(self) -> Results:
        n = self.n_vehicles
        for name, count in (("states", self.n_states), ("inputs", self.n_inputs),
                            ("outputs", self.n_outputs)):
            if len(getattr(self, name)) != count:
                _relation((name,), f"must list n_{name} = {count} names", getattr(self, name))
        _length(("vehicles",), self.vehicles, n, "one entry per vehicle")
        for key in ("inputs", "traction_limit", "braking_limit"):
            _length(("equilibrium", key), getattr(self.equilibrium, key), self.n_inputs,
                    "one entry per input (n_inputs)")
        for key in ("coupler_forces", "elongations"):
            _length(("equilibrium", key), getattr(self.equilibrium, key), n - 1,
                    "one entry per coupler (n_vehicles - 1)")
        names = [c.name for c in self.checks]
        for i, name in enumerate(names):
            if name in names[:i]:
                _relation(("checks", i, "name"), "must not repeat a check's name", name)
        failed = [c.name for c in self.checks if c.status == "fail"]
        if self.failed_checks != failed:
            _relation(("failed_checks",), f"must list the checks whose status is 'fail' "
                      f"({failed})", self.failed_checks)
        for strategy, metrics in self.simulations.items():
            for key in ("rms_error", "max_error", "saturation_time", "braking_saturation_time"):
                _length(("simulations", strategy, key), getattr(metrics, key), n,
                        "one entry per vehicle (n_vehicles)")
            for key in ("coupler_peak_force", "coupler_peak_time", "coupler_over_time"):
                _length(("simulations", strategy, key), getattr(metrics, key), n - 1,
                        "one entry per coupler (n_vehicles - 1)")
        return self


def _relation(loc: tuple[str | int, ...], text: str, value: Any) -> None:
    raise_at(loc, Violation(text, got=value), value)


def _length(loc: tuple[str | int, ...], values: list[Any] | None, count: int, what: str) -> None:
    if values is not None and len(values) != count:
        _relation(loc, f"must have {count} items, {what}", values)


class Block(_Closed):
    """One matrix of a coach's subsystem."""

    kind: Literal["A", "B", "C"]
    source: Annotated[int, Integer(ge=0, le=MAX_VEHICLES)] = Field(alias="from")
    matrix: list[list[FiniteFloat]]
    columns: list[StrictStr] | None = None


class Coach(_Closed):
    """One coach's subsystem matrices (``subsystems[i]``)."""

    index: Annotated[int, Integer(ge=0, le=MAX_VEHICLES)]
    states: list[StrictStr]
    blocks: list[Block]


class RunFile(_Closed):
    """``trainctl-run.json``: everything of a saved run except the time series.

    Parameters
    ----------
    format : str
        The file format's name and version.
    source : str
        The scenario's text as it was run.
    scenario_sha256 : str
        SHA-256 of that text (:func:`text_digest`).
    directory : str or None
        Where the scenario's relative paths were read from
        (:attr:`~trainctl.scenario.Scenario.directory`): the run's track file
        (``[track].file``) is read from there again.
    track_sha256 : str or None
        SHA-256 of that track file when the run was saved: a file changed
        since is refused.
    strategies : list of str
        The simulated strategies, in order.
    results : Results
        The model summary, the checks and each strategy's metrics.
    subsystems : list of Coach
        Per coach: its local model's summary.
    spectra : dict
        Eigenvalues by label, as (real, imaginary) pairs [1/s].
    families : dict
        Per controller family: its design summary and checks.
    frequency : dict
        The frequency-domain data of the report's figures.
    expected : dict
        The scenario's ``[expected]`` statuses, check name to status.
    unexpected : dict
        Checks whose status differs from ``[expected]``: name to (expected, got).
    environment : dict
        Versions of Python, trainctl and its dependencies.
    command : str
        The command that saved the run.
    timings : dict
        Wall times of the run's parts [s].

    Examples
    --------
    The validated manifest of a saved run (:func:`read_saved_run`):

    >>> import tempfile
    >>> import trainctl
    >>> from trainctl.report import collect_report_data
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     saved = collect_report_data(run, scenario_text=text).save(tmp + "/run")
    ...     doc = read_saved_run(saved)["document"]
    >>> isinstance(doc, RunFile), doc.strategies, doc.scenario_sha256 == text_digest(text)
    (True, [], True)
    """

    format: StrictStr
    source: StrictStr
    scenario_sha256: str = Field(pattern=r"^[0-9a-f]{64}$")
    directory: StrictStr | None = None
    track_sha256: str | None = Field(default=None, pattern=r"^[0-9a-f]{64}$")
    strategies: list[StrictStr]
    results: Results
    subsystems: list[Coach]
    spectra: dict[str, list[tuple[FiniteFloat, FiniteFloat]]]
    families: dict[str, dict[str, Any]]
    frequency: dict[str, dict[str, Any]]
    expected: dict[str, Verdict]
    unexpected: dict[str, tuple[Verdict, Found]]
    environment: dict[str, Any]
    command: StrictStr
    timings: dict[str, Annotated[FiniteFloat, Field(ge=0)]]

    @model_validator(mode="after")
    def _relations(self) -> RunFile:
        if self.expected != self.results.expected:
            _relation(("expected",), "must be results.expected", self.expected)
        for i, coach in enumerate(self.subsystems):
            if coach.index != i:
                _relation(("subsystems", i, "index"), f"must be {i} (coaches in order)",
                          coach.index)
        status = {c.name: c.status for c in self.results.checks}
        skip = set(self.results.unsimulated_checks)
        differ = {name: (want, status.get(name, "missing"))
                  for name, want in self.expected.items()
                  if name not in skip and status.get(name) != want}
        if self.unexpected != differ:
            _relation(("unexpected",), "must be the checks whose status differs from "
                      f"expected, as (expected, got) ({differ})", self.unexpected)
        return self


def text_digest(text: str) -> str:
    """SHA-256 (hex) of a scenario's text as saved (UTF-8).

    Parameters
    ----------
    text : str
        The scenario file's text.

    Returns
    -------
    str
        The digest, 64 hexadecimal digits.

    Examples
    --------
    >>> text_digest("")[:12]
    'e3b0c44298fc'
    """
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def read_saved_run(directory: str | Path) -> dict[str, Any]:
    """Validate a saved run and return its parts.

    Parameters
    ----------
    directory : str or pathlib.Path
        A directory written by :meth:`~trainctl.report.ReportData.save`.

    Returns
    -------
    dict
        ``document`` (the validated :class:`RunFile`), ``raw`` (the JSON
        as read, which it describes), ``text`` (the scenario TOML),
        ``scenario`` and ``simulations`` (strategy →
        :class:`~trainctl.sim.SimulationResult`).

    Raises
    ------
    ScenarioError
        Naming the file and key at fault: not a saved run, another format, a
        key missing, unknown or of the wrong type, a scenario text that is
        not the one saved, strategies that do not match the results, or a
        simulation result that is damaged or belongs elsewhere.

    Examples
    --------
    A run saved without simulations, read back; a directory without the
    manifest is refused:

    >>> import tempfile
    >>> import trainctl
    >>> from trainctl.report import collect_report_data
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     parts = read_saved_run(collect_report_data(run, scenario_text=text).save(tmp + "/run"))
    ...     try:
    ...         read_saved_run(tmp)
    ...     except ScenarioError as error:
    ...         refused = "not a complete saved run" in str(error)
    >>> sorted(parts), parts["text"] == text, parts["simulations"], refused
    (['document', 'raw', 'scenario', 'simulations', 'text'], True, {}, True)
    """
    from trainctl.scenario import parse_scenario

    path = Path(directory)
    manifest = path / MANIFEST
    if not manifest.is_file():
        raise ScenarioError(f"{path}: not a complete saved run ({MANIFEST} is missing). Write "
                            "one with 'trainctl analyse SCENARIO --save DIR'.")
    raw = read_json(manifest, hint=RUN_HINT, finite=False)  # free-form sections may hold NaN
    _check_format(manifest, raw)
    doc = validate_json(raw, RunFile, manifest, hint=RUN_HINT)
    text = _scenario_text(path, doc)
    try:
        scenario = parse_scenario(text, source=doc.source, directory=doc.directory)
    except ScenarioError as exc:
        hint = RUN_HINT
        if "[track].file" in str(exc):
            hint = (" The run read its track from that file: put it back (or save the run "
                    "again with 'trainctl analyse SCENARIO --save DIR').")
        raise ScenarioError(f"{path / 'scenario.toml'}: not a valid scenario: {exc}"
                            f"{hint}") from None
    if doc.track_sha256 is not None and scenario.track_digest != doc.track_sha256:
        raise ScenarioError(
            f"{path / 'scenario.toml'}: the track file of [track].file changed since the run "
            f"was saved (SHA-256 {doc.track_sha256[:12]}… then, "
            f"{(scenario.track_digest or 'none')[:12]}… now): the saved results are not "
            "this track's. Put the original file back, or save the run again with "
            "'trainctl analyse SCENARIO --save DIR'.")
    _check_strategies(manifest, doc)
    _check_scenario(manifest, doc, scenario)
    sims = {name: _simulation(path, name, scenario, doc.results.simulations[name])
            for name in doc.strategies}
    return {"document": doc, "raw": raw, "text": text, "scenario": scenario,
            "simulations": sims}


def _check_format(manifest: Path, raw: Any) -> None:
    found = raw.get("format") if isinstance(raw, dict) else None
    if found != FORMAT:
        older = isinstance(found, str) and found.startswith("trainctl.ReportData/")
        raise ScenarioError(
            f"{manifest}: must be a {FORMAT!r} file (got format {found!r}). "
            + ("It was saved by an earlier trainctl; re-create" if older else "Re-create")
            + " it with 'trainctl analyse SCENARIO --save DIR'.")


def _scenario_text(path: Path, doc: RunFile) -> str:
    from trainctl.scenario.parse import MAX_TEXT_BYTES, check_size

    toml = path / "scenario.toml"
    try:
        # as written (CRLF kept: the checksum is of that); bounded: a scenario is kilobytes
        raw = read_regular(toml, MAX_TEXT_BYTES)
        check_size(len(raw), str(toml))
        text = raw.decode("utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{path}: not a complete saved run (scenario.toml is missing)."
                            f"{RUN_HINT}") from None
    except (OSError, UnicodeDecodeError) as exc:
        why = getattr(exc, "strerror", None) or exc
        raise ScenarioError(f"{toml}: cannot read the scenario ({why}).{RUN_HINT}") from None
    if text_digest(text) != doc.scenario_sha256:
        name = _name_in(text)
        what = (f"holds another scenario ({name!r}, not {doc.results.scenario!r})"
                if name is not None and name != doc.results.scenario else "was edited")
        raise ScenarioError(f"{toml}: {what}: it is not the text the run was saved with (its "
                            f"SHA-256 differs from {MANIFEST}'s scenario_sha256).{RUN_HINT}")
    return text


def _name_in(text: str) -> str | None:
    import tomllib

    try:
        name = tomllib.loads(text).get("name")
    except (tomllib.TOMLDecodeError, RecursionError):
        return None
    return name if isinstance(name, str) else None


def _check_strategies(manifest: Path, doc: RunFile) -> None:
    listed, simulated = doc.strategies, list(doc.results.simulations)
    if len(set(listed)) != len(listed):
        raise ScenarioError(f"{manifest}: strategies must not repeat a name (got {listed}).")
    if sorted(listed) != sorted(simulated):
        raise ScenarioError(f"{manifest}: strategies {listed} must be the strategies of "
                            f"results.simulations {simulated}.{RUN_HINT}")


def _check_scenario(manifest: Path, doc: RunFile, scenario: Any) -> None:
    """The results must describe the saved scenario (its text may be edited, checksum and all)."""
    results, train = doc.results, scenario.train
    simulated = tuple(scenario.simulation.strategies) if scenario.simulation else ()
    wanted: list[tuple[str, Any, Any]] = [
        ("results.scenario", scenario.name, results.scenario),
        ("results.train", train.name, results.train),
        ("results.n_vehicles", train.n_vehicles, results.n_vehicles),
        ("results.speed", scenario.model.speed, results.speed),
        ("results.sampling.sample_time", scenario.model.sample_time,
         results.sampling.sample_time),
        ("expected", dict(scenario.expected), doc.expected),
    ]
    if results.n_vehicles == train.n_vehicles:
        for i, (vehicle, saved) in enumerate(zip(train.vehicles, results.vehicles, strict=True)):
            for key in ("name", "mass", "length", "traction_share"):
                wanted.append((f"results.vehicles[{i}].{key}", getattr(vehicle, key),
                               saved.get(key)))
    for key, want, got in wanted:
        same = (math.isclose(want, got, rel_tol=1e-12)
                if isinstance(want, float) and isinstance(got, float) else want == got)
        if not same:
            shown = "a different table" if isinstance(want, dict) else repr(want)
            raise ScenarioError(f"{manifest}: {key} must be the saved scenario's ({shown}, from "
                                f"scenario.toml) (got {_short(got)}): the results are not "
                                f"those of that scenario.{RUN_HINT}")
    extra = [name for name in doc.strategies if name not in simulated]
    if extra:
        raise ScenarioError(f"{manifest}: strategies must be among the saved scenario's "
                            f"[simulation] strategies {list(simulated)} (got {extra[0]!r})."
                            f"{RUN_HINT}")


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _simulation(path: Path, strategy: str, scenario: Any, metrics: Metrics) -> Any:
    from trainctl.design import strategy_interval
    from trainctl.sim.results import SimulationResult

    where = path / "simulations" / strategy
    if not where.is_dir():
        raise ScenarioError(f"{where}: missing: the run lists strategy {strategy!r} but has no "
                            f"saved result for it.{RUN_HINT}")
    try:
        result = SimulationResult.load(where)
    except (ModelError, DimensionError) as exc:
        raise ScenarioError(str(exc)) from None
    problem = None
    if result.controller_name != strategy:
        problem = f"controller_name must be {strategy!r} (got {result.controller_name!r})"
    elif not math.isclose(result.dt, interval := strategy_interval(scenario, strategy),
                          rel_tol=1e-12):
        problem = (f"dt must be the interval {interval!r} s at which the scenario runs "
                   f"{strategy!r} (got {result.dt!r})")
    elif result.n_vehicles != scenario.train.n_vehicles:
        problem = (f"the arrays must be for the scenario's {scenario.train.n_vehicles} vehicles "
                   f"(got {result.n_vehicles})")
    if problem is not None:
        raise ScenarioError(f"{where / 'result.json'}: {problem}.{RUN_HINT}")
    counts = result.status_counts()
    top = int(result.iterations.max()) if result.iterations.size else 0
    key = f"results.simulations.{strategy}"
    if {k: v for k, v in metrics.status_counts.items() if v} != {k: v for k, v in counts.items()
                                                                 if v}:
        problem = (f"{key}.status_counts must count the saved result's statuses ({counts}) "
                   f"(got {metrics.status_counts})")
    elif metrics.iterations_max != top:
        problem = (f"{key}.iterations_max must be the largest of the saved result's iteration "
                   f"counts ({top}) (got {metrics.iterations_max})")
    if problem is not None:
        raise ScenarioError(f"{path / MANIFEST}: {problem}.{RUN_HINT}")
    return result
