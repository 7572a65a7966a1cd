# What a report shows, computed once: collected from a run, saved, loaded back.
"""The numbers behind a report, and the saved-results directory.

:func:`collect_report_data` turns an :class:`~trainctl.run.AnalysisRun` into a
:class:`ReportData`: the run's JSON summary plus what only the report shows
(the per-coach matrices, the eigenvalues of the open and closed loops, the
ρ(D0)-against-R curve) and the simulation results. ``trainctl analyse --save
DIR`` writes it with :meth:`ReportData.save`; ``trainctl report DIR`` reads
it back with :meth:`ReportData.load` and renders without re-running anything.

Directory layout (format :data:`FORMAT`, declared and checked on loading by
:mod:`trainctl.report.runfile`)::

    DIR/trainctl-run.json          everything except the time series
    DIR/scenario.toml              the scenario text as read
    DIR/simulations/<strategy>/    one SimulationResult.save directory each
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .._validation import numerical_errors
from ..exceptions import ScenarioError
from .runfile import FORMAT as FORMAT
from .runfile import MANIFEST as MANIFEST
from .runfile import text_digest

if TYPE_CHECKING:
    from ..models.subsystems import CoachSubsystems
    from ..run import AnalysisRun
    from ..scenario import Scenario
    from ..sim.results import SimulationResult

__all__ = [
    "FORMAT", "MANIFEST", "ReportData", "check_save_target", "collect_report_data",
    "is_saved_run",
]


@dataclass(frozen=True, kw_only=True, eq=False)
class ReportData:
    """Everything a report shows, as plain data.

    Parameters
    ----------
    scenario : Scenario
        The scenario, parsed from ``scenario_text``.
    scenario_text : str
        The TOML text as read.
    results : dict
        :meth:`AnalysisRun.to_dict`: summary, checks, failed checks, metrics.
    subsystems : list of dict
        Per coach i: ``index``, ``states`` and ``blocks``, each with ``kind``
        (``"A"``, ``"B"``, ``"C"``), ``from`` (j of A_ij) and ``matrix``
        (nested lists, SI: speeds m/s, elongations m, inputs N); coupling
        blocks also name their ``columns`` (coach j's states).
    spectra : dict of str to ndarray
        Discrete-time eigenvalues (complex) by label: ``"open loop"``, then
        the closed loops each controller family reports (MPC:
        ``"centralised"``, ``"N-DMPC (Nash)"``, ``"N-DMPC (k iterations)"``).
    families : dict of str to dict
        Each controller family's JSON-safe report data (its
        ``report_data()``), by family name; empty without a controller.
    simulations : dict of str to SimulationResult
        Closed-loop runs by strategy.
    frequency : dict of str to dict
        Curves of each strategy's linear closed loop
        (:meth:`trainctl.analysis.ClosedLoopResponse.curves`: singular values
        over frequency and grade-step responses), by strategy; empty without
        linear closed loops.
    expected : dict of str to str
        The scenario's ``[expected]`` table.
    unexpected : dict of str to list of str
        Checks whose status differs from ``expected``: name → [expected, found].
    environment : dict
        Versions (:func:`trainctl.sim.results.environment`).
    command : str
        The command that produced the run, without machine-specific paths.
    timings : dict of str to float
        Wall-clock seconds per stage (``analysis``, ``simulations``, ...).

    Examples
    --------
    The data of the CRH2 scenario's design review (no simulation), saved and
    loaded back:

    >>> import tempfile
    >>> import trainctl
    >>> from trainctl.run import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     loaded = ReportData.load(data.save(tmp + "/run"))
    >>> loaded.scenario.name == data.scenario.name, loaded.simulations
    (True, {})
    >>> list(loaded.spectra)[:2]
    ['open loop', 'centralised']
    """

    scenario: Scenario
    scenario_text: str
    results: dict[str, Any]
    subsystems: list[dict[str, Any]]
    spectra: dict[str, NDArray[np.complex128]]
    families: dict[str, dict[str, Any]] = field(default_factory=dict)
    simulations: dict[str, SimulationResult] = field(default_factory=dict)
    frequency: dict[str, dict[str, Any]] = field(default_factory=dict)
    expected: dict[str, str] = field(default_factory=dict)
    unexpected: dict[str, list[str]] = field(default_factory=dict)
    environment: dict[str, Any] = field(default_factory=dict)
    command: str = ""
    timings: dict[str, float] = field(default_factory=dict)

    # ----------------------------------------------------------------- files
    def save(self, directory: str | os.PathLike[str]) -> Path:
        """Write the data to ``directory``, atomically.

        Everything goes to a temporary sibling directory first, which then
        replaces ``directory``; an interrupted save leaves the previous
        contents (or nothing). An existing ``directory`` must be empty or a
        previous save (it holds :data:`MANIFEST`).

        Parameters
        ----------
        directory : str or os.PathLike
            Target directory (parents are created).

        Returns
        -------
        pathlib.Path
            The directory.

        Raises
        ------
        ScenarioError
            If ``directory`` is a file, or a non-empty directory that is not a
            saved run (nothing is written).
        """
        target = Path(directory)
        check_save_target(target)
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
        try:
            tmp.mkdir()
            (tmp / "scenario.toml").write_text(self.scenario_text, encoding="utf-8")
            for strategy, result in self.simulations.items():
                result.save(tmp / "simulations" / strategy)
            (tmp / MANIFEST).write_text(json.dumps(self._document(), indent=1) + "\n",
                                        encoding="utf-8")
            old = None
            if target.exists():
                old = target.with_name(f".{target.name}.{secrets.token_hex(6)}.old")
                target.rename(old)
            tmp.rename(target)
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise
        return target

    def _document(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "source": self.scenario.source,
            "scenario_sha256": text_digest(self.scenario_text),
            "strategies": list(self.simulations),
            "results": self.results,
            "subsystems": self.subsystems,
            "spectra": {label: [[float(z.real), float(z.imag)] for z in values]
                        for label, values in self.spectra.items()},
            "families": self.families,
            "frequency": self.frequency,
            "expected": self.expected,
            "unexpected": self.unexpected,
            "environment": self.environment,
            "command": self.command,
            "timings": self.timings,
        }

    @classmethod
    def load(cls, directory: str | os.PathLike[str]) -> ReportData:
        """Read a directory written by :meth:`save`.

        Parameters
        ----------
        directory : str or os.PathLike
            A saved-results directory.

        Returns
        -------
        ReportData
            Equal to the saved data (arrays exactly).

        Raises
        ------
        ScenarioError
            If the directory is not a readable saved run of this format, or
            was edited: the message names the file and the key or array at
            fault (:mod:`trainctl.report.runfile`).
        """
        from .runfile import read_saved_run

        run = read_saved_run(Path(directory))
        raw = run["raw"]  # validated by run["document"]; kept as read for an exact round trip
        spectra = {label: np.array([complex(re, im) for re, im in values], dtype=complex)
                   for label, values in raw["spectra"].items()}
        return cls(scenario=run["scenario"], scenario_text=run["text"], results=raw["results"],
                   subsystems=raw["subsystems"], spectra=spectra, families=raw["families"],
                   frequency=raw["frequency"], simulations=run["simulations"],
                   expected=raw["expected"], unexpected=raw["unexpected"],
                   environment=raw["environment"], command=raw["command"],
                   timings=raw["timings"])


def check_save_target(path: str | os.PathLike[str]) -> None:
    """Refuse a directory that :meth:`ReportData.save` must not replace (checked before a run).

    Parameters
    ----------
    path : str or os.PathLike
        The intended saved-results directory.

    Raises
    ------
    ScenarioError
        If ``path`` is a file, or a non-empty directory that is not a saved run.

    Examples
    --------
    A new or empty directory is accepted; one holding other files is not:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     check_save_target(tmp)  # empty: nothing raised
    ...     _ = (Path(tmp) / "notes.txt").write_text("mine")
    ...     try:
    ...         check_save_target(tmp)
    ...     except ScenarioError as error:
    ...         print(type(error).__name__, "non-empty directory" in str(error))
    ScenarioError True
    """
    target = Path(path)
    if target.exists() and not target.is_dir():
        raise ScenarioError(f"{target}: exists and is not a directory; give a directory for "
                            "the saved results.")
    if target.is_dir() and any(target.iterdir()) and not (target / MANIFEST).is_file():
        raise ScenarioError(f"{target}: is a non-empty directory without {MANIFEST}; refusing "
                            "to overwrite it. Give a new or empty directory.")


def is_saved_run(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a directory holding :data:`MANIFEST`.

    Parameters
    ----------
    path : str or os.PathLike
        A path given to ``trainctl report``.

    Returns
    -------
    bool
        Whether it is a saved run.

    Examples
    --------
    >>> import tempfile
    >>> import trainctl
    >>> from trainctl.run import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     saved = data.save(Path(tmp) / "run")
    ...     print(is_saved_run(tmp), is_saved_run(saved))
    False True
    """
    return (Path(path) / MANIFEST).is_file()


# --------------------------------------------------------------------------- collection


def collect_report_data(
    run: AnalysisRun,
    *,
    scenario_text: str,
    command: str = "",
    timings: Mapping[str, float] | None = None,
) -> ReportData:
    """Compute what the report shows beyond the run itself.

    Everything comes from the run's design (:attr:`AnalysisRun.design`):
    nothing is linearised or discretised again.

    Parameters
    ----------
    run : AnalysisRun
        From :func:`trainctl.run.run_scenario`.
    scenario_text : str
        The scenario's TOML text (echoed in the report and saved).
    command : str
        The producing command, machine-specific paths removed.
    timings : mapping or None
        Wall-clock seconds per stage.

    Returns
    -------
    ReportData
        Plain data for :func:`trainctl.report.build_report_context`.

    Examples
    --------
    The CRH2 design review without simulations. Its seven open-loop
    eigenvalues (sample time T = 20 s) are the rigid mode e^(−aT) and three
    undamped coupler modes, each pair damped by the running resistance
    alone at e^(−aT/2), with a = 2.685e-3 1/s: e^(−0.02685) = 0.97351:

    >>> import trainctl
    >>> from trainctl.run import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> z = data.spectra["open loop"]
    >>> len(z), round(float(np.max(np.abs(z))), 5)
    (7, 0.97351)
    >>> list(data.families), data.simulations
    (['mpc'], {})
    """
    from ..controllers.registry import get_family
    from ..sim.results import environment

    design = run.design
    with numerical_errors(run.scenario.source):
        families = {name: get_family(name).report_data(family_design)
                    for name, family_design in design.families.items()}
        spectra = {"open loop": _eig(np.asarray(design.model.discrete.A, dtype=float))}
    for data in families.values():
        for label, values in data.get("spectra", {}).items():
            spectra[label] = np.array([complex(re, im) for re, im in values], dtype=complex)
    return ReportData(
        scenario=run.scenario,
        scenario_text=scenario_text,
        results=run.to_dict(),
        subsystems=_subsystems(design.model.subsystems),
        spectra=spectra,
        families=families,
        simulations=dict(run.simulations),
        frequency={name: response.curves() for name, response in run.frequency.items()},
        expected=dict(run.scenario.expected),
        unexpected={name: list(pair) for name, pair in run.unexpected_checks().items()},
        environment=environment(),
        command=command,
        timings=dict(timings or {}),
    )


def _subsystems(sub: CoachSubsystems) -> list[dict[str, Any]]:
    coaches = []
    for i in range(sub.n_coaches):
        blocks: list[dict[str, Any]] = [{"kind": "A", "from": i, "matrix": sub.A[i, i].tolist()}]
        for j in (i - 1, i + 1):
            if (i, j) in sub.A:
                blocks.append({"kind": "A", "from": j, "matrix": sub.A[i, j].tolist(),
                               "columns": list(sub.state_labels[j])})
        blocks.append({"kind": "B", "from": i, "matrix": sub.B[i].tolist()})
        blocks.append({"kind": "C", "from": i, "matrix": sub.C[i].tolist()})
        coaches.append({"index": i, "states": list(sub.state_labels[i]), "blocks": blocks})
    return coaches


def _eig(matrix: NDArray[np.float64]) -> NDArray[np.complex128]:
    values = np.linalg.eigvals(matrix).astype(complex)
    # A fixed order (by angle, then modulus) keeps saved files and figures stable.
    order = np.lexsort((np.round(np.abs(values), 12), np.round(np.angle(values), 12)))
    return values[order]
