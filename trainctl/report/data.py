# What a report shows, computed once: collected from a run, saved, loaded back.
"""The numbers behind a report, and the saved-results directory.

:func:`collect_report_data` turns an :class:`~trainctl.run.analysis.AnalysisRun` into a
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

A save never deletes what it did not write (:func:`check_save_target`,
:mod:`trainctl.report.savedir`): DIR is new, empty, or an earlier save
holding nothing else; a re-save stages its files in a hidden
``DIR/.trainctl-save-<hex>.tmp`` and renames them over the earlier save's,
the manifest last.
"""

from __future__ import annotations

import json
import os
import secrets
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl._validation import numerical_errors
from trainctl.report.output import OutputError
from trainctl.report.runfile import FORMAT as FORMAT
from trainctl.report.runfile import MANIFEST as MANIFEST
from trainctl.report.runfile import text_digest

if TYPE_CHECKING:
    from trainctl.models.subsystems import CoachSubsystems
    from trainctl.run.analysis import AnalysisRun
    from trainctl.scenario import Scenario
    from trainctl.sim.results import SimulationResult

from trainctl.report.savedir import (
    _STAGING_PREFIX,
    _clean_up,
    _is_regular,
    _make_directories,
    _move_into_place,
    _refuse_foreign,
    _save_directory,
    _signals_deferred,
    _where,
    check_save_target,
    is_saved_run,
)

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
    >>> from trainctl.run.analysis import run_scenario
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
        """Write the data to ``directory``, replacing only what an earlier save wrote.

        ``directory`` must be new, empty, or hold a previous save and nothing
        else (:func:`check_save_target`). The files are written to a hidden
        staging directory inside it first and then moved into place, the
        manifest last; only the files of the previous save are replaced, and
        the directory itself (its owner, permissions, a symbolic link
        pointing to it) stays. An error or an interrupt before the move
        leaves the previous save as it was; SIGINT, SIGTERM and SIGHUP
        arriving during the move (a few renames) take effect once it is
        done. No staging entry survives; one left by a killed process
        (``.trainctl-save-*``) is removed by the next save.

        Parameters
        ----------
        directory : str or os.PathLike
            Target directory (it and its parents are created). A symbolic
            link to a directory is followed.

        Returns
        -------
        pathlib.Path
            The directory, as given.

        Raises
        ------
        ScenarioError
            If ``directory`` is a file or a broken link, or holds anything
            a save does not write (nothing is written or removed).
        OutputError
            If writing fails (a full disk, no permission): the message names
            the directory; the earlier save, if any, is unchanged.
        """
        given = Path(directory)
        target = _save_directory(given)
        created = _make_directories(target)
        staging = target / f"{_STAGING_PREFIX}{secrets.token_hex(6)}.tmp"
        try:
            staging.mkdir()
            (staging / "scenario.toml").write_text(self.scenario_text, encoding="utf-8")
            for strategy, result in self.simulations.items():
                result.save(staging / "simulations" / strategy)
            (staging / MANIFEST).write_text(json.dumps(self._document(), indent=1) + "\n",
                                            encoding="utf-8")
            _refuse_foreign(given, target)  # checked again: it may have changed meanwhile
            with _signals_deferred():
                _move_into_place(staging, target)
        except OSError as exc:  # a full disk, a permission: name the directory
            _clean_up(staging, created)
            kept = ("the earlier save is unchanged" if _is_regular(target / MANIFEST)
                    else "nothing was written")
            raise OutputError(f"{given}: cannot write the saved results ({exc.strerror or exc}"
                              f"{_where(exc)}); {kept}.") from None
        except BaseException:
            _clean_up(staging, created)
            raise
        return given

    def _document(self) -> dict[str, Any]:
        return {
            "format": FORMAT,
            "source": self.scenario.source,
            "scenario_sha256": text_digest(self.scenario_text),
            "directory": self.scenario.directory,
            "track_sha256": self.scenario.track_digest,
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
        from trainctl.report.runfile import read_saved_run

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
        From :func:`trainctl.run.analysis.run_scenario`.
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
    >>> from trainctl.run.analysis import run_scenario
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
    from trainctl.registry import get_family
    from trainctl.sim.results import environment

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

