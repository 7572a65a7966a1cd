# The record of one closed-loop simulation, its files and its views.
"""The result of :func:`trainctl.sim.simulate`.

Arrays are indexed (signal, time) as in python-control. Sample k covers the
interval [t_k, t_{k+1}); signals sampled at the instants (states, speeds,
coupler forces, reference) have N + 1 columns, t_0 .. t_N, and per-step
records (inputs held over the interval, statuses, iterations, solve times)
have N.

:meth:`SimulationResult.save` writes a directory with ``arrays.npz`` (plain
numpy arrays, loadable with ``allow_pickle=False``) and ``result.json``
(scalars, strings, statuses, residuals and ``meta``);
:meth:`SimulationResult.load` reads it back exactly.
"""

from __future__ import annotations

import importlib
import json
import platform
import sys
from collections import Counter
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..controllers.base import STATUSES
from ..exceptions import DimensionError, MissingDependencyError, ModelError

if TYPE_CHECKING:
    import control as ct
    from matplotlib.axes import Axes

__all__ = ["ARRAY_NAMES", "FORMAT", "PLOT_KINDS", "SimulationResult", "environment"]

FORMAT = "trainctl.SimulationResult/1"
"""Format tag written to ``result.json``."""

PLOT_KINDS = ("velocity", "coupler_force", "input", "iterations")
"""Kinds accepted by :meth:`SimulationResult.plot`."""

_ARRAYS = (
    "time", "states", "velocities", "coupler_forces", "inputs", "reference_speed",
    "reference_acceleration", "iterations", "solve_times",
)
ARRAY_NAMES = _ARRAYS
"""The arrays of a result, the members of its ``arrays.npz``."""
_DEPENDENCIES = ("numpy", "scipy", "control", "cvxpy", "matplotlib", "pandas")


def environment() -> dict[str, object]:
    """Versions of trainctl, its dependencies and Python (JSON-safe).

    Returns
    -------
    dict
        ``{"versions": {package: version or None}, "python": ..., "platform": ...}``.

    Examples
    --------
    >>> env = environment()
    >>> sorted(env), "trainctl" in env["versions"]
    (['platform', 'python', 'versions'], True)
    """
    versions: dict[str, str | None] = {}
    for package in ("trainctl", *_DEPENDENCIES):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = None
    return {
        "versions": versions,
        "python": sys.version.split()[0],
        "platform": platform.platform(),
    }


@dataclass(frozen=True, kw_only=True, eq=False)
class SimulationResult:
    """Everything one closed-loop simulation produced.

    Parameters
    ----------
    time : ndarray
        Sample instants t_0 .. t_N [s], shape (N+1,).
    states : ndarray
        Plant states ``[v, delta, s]`` at the instants, shape (2n, N+1).
    velocities : ndarray
        Vehicle speeds [m/s], shape (n, N+1).
    coupler_forces : ndarray
        Coupler forces [N] (tension positive), shape (n-1, N+1).
    inputs : ndarray
        Forces applied over [t_k, t_{k+1}) [N], shape (n, N).
    reference_speed : ndarray
        Reference speed at the instants [m/s], shape (N+1,).
    reference_acceleration : ndarray
        Reference acceleration at the instants [m/s²], shape (N+1,).
    statuses : tuple of str
        Step status per sample (:data:`trainctl.controllers.base.STATUSES`), N.
    iterations : ndarray
        Iterations per sample, int, shape (N,).
    residuals : tuple of tuple of float
        Iteration residuals per sample [kN], N.
    solve_times : ndarray
        Wall time of each controller step [s], shape (N,).
    fallbacks : tuple of str
        Fallback applied per sample ("" when none), N.
    controller_name : str
        The controller's name.
    seed : int
        Seed of the measurement-noise generator.
    dt : float
        Sample time [s].
    meta : dict
        JSON-safe extras: versions, train, plant and run settings.

    Examples
    --------
    >>> import numpy as np
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 1.0]), states=np.array([[10.0, 10.0], [0.0, 10.0]]),
    ...     velocities=np.array([[10.0, 10.0]]), coupler_forces=np.zeros((0, 2)),
    ...     inputs=np.array([[0.0]]), reference_speed=np.array([10.0, 10.0]),
    ...     reference_acceleration=np.zeros(2), statuses=("optimal",),
    ...     iterations=np.array([1]), residuals=((),), solve_times=np.array([1e-3]),
    ...     fallbacks=("",), controller_name="demo", seed=0, dt=1.0)
    >>> result.n_vehicles, result.n_samples, result.duration
    (1, 1, 1.0)
    """

    time: NDArray[np.float64]
    states: NDArray[np.float64]
    velocities: NDArray[np.float64]
    coupler_forces: NDArray[np.float64]
    inputs: NDArray[np.float64]
    reference_speed: NDArray[np.float64]
    reference_acceleration: NDArray[np.float64]
    statuses: tuple[str, ...]
    iterations: NDArray[np.int64]
    residuals: tuple[tuple[float, ...], ...]
    solve_times: NDArray[np.float64]
    fallbacks: tuple[str, ...]
    controller_name: str
    seed: int
    dt: float
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in _ARRAYS:
            dtype = np.int64 if name == "iterations" else np.float64
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=dtype))
        object.__setattr__(self, "statuses", tuple(str(s) for s in self.statuses))
        object.__setattr__(self, "fallbacks", tuple(str(s) for s in self.fallbacks))
        object.__setattr__(
            self, "residuals", tuple(tuple(float(r) for r in rs) for rs in self.residuals)
        )
        n_t = self.time.shape[0] if self.time.ndim == 1 else -1
        n = self.velocities.shape[0] if self.velocities.ndim == 2 else -1
        steps = n_t - 1
        expected = {
            "time": (n_t,),
            "states": (2 * n, n_t),
            "velocities": (n, n_t),
            "coupler_forces": (max(n - 1, 0), n_t),
            "inputs": (n, steps),
            "reference_speed": (n_t,),
            "reference_acceleration": (n_t,),
            "iterations": (steps,),
            "solve_times": (steps,),
        }
        if n_t < 1 or n < 1:
            raise DimensionError(
                "SimulationResult: 'time' must be 1-D and 'velocities' (n, N+1) with n >= 1 "
                f"(got {self.time.shape} and {self.velocities.shape})."
            )
        for name, shape in expected.items():
            if getattr(self, name).shape != shape:
                raise DimensionError(
                    f"SimulationResult: {name!r} must have shape {shape} for {n} vehicles and "
                    f"{steps} samples (got {getattr(self, name).shape})."
                )
        for name in ("statuses", "residuals", "fallbacks"):
            if len(getattr(self, name)) != steps:
                raise DimensionError(
                    f"SimulationResult: {name!r} must hold one entry per sample ({steps}) "
                    f"(got {len(getattr(self, name))})."
                )

    # ------------------------------------------------------------ shape info
    @property
    def n_vehicles(self) -> int:
        """Number of vehicles n."""
        return int(self.velocities.shape[0])

    @property
    def n_samples(self) -> int:
        """Number of controller samples N."""
        return int(self.inputs.shape[1])

    @property
    def duration(self) -> float:
        """Simulated time t_N - t_0 [s]."""
        return float(self.time[-1] - self.time[0])

    @property
    def positions(self) -> NDArray[np.float64]:
        """Head position s at the instants [m], shape (N+1,)."""
        return self.states[-1]

    def status_counts(self) -> dict[str, int]:
        """Number of samples per status, every known status listed (0 when absent).

        Returns
        -------
        dict
            ``{status: count}`` with the :data:`STATUSES` first, then any other.
        """
        counts = Counter(self.statuses)
        out = {status: int(counts.get(status, 0)) for status in STATUSES}
        out.update({s: int(c) for s, c in counts.items() if s not in out})
        return out

    # ----------------------------------------------------------------- files
    def save(self, directory: str | Path) -> Path:
        """Write ``arrays.npz`` and ``result.json`` into ``directory``.

        Parameters
        ----------
        directory : str or Path
            Directory to write (created with its parents when missing;
            existing files of these names are replaced).

        Returns
        -------
        Path
            The directory.
        """
        path = Path(directory)
        path.mkdir(parents=True, exist_ok=True)
        np.savez(path / "arrays.npz", **{name: getattr(self, name) for name in _ARRAYS})
        document = {
            "format": FORMAT,
            "controller_name": self.controller_name,
            "seed": self.seed,
            "dt": self.dt,
            "statuses": list(self.statuses),
            "fallbacks": list(self.fallbacks),
            "residuals": [list(r) for r in self.residuals],
            "meta": self.meta,
        }
        (path / "result.json").write_text(json.dumps(document, indent=1) + "\n", encoding="utf-8")
        return path

    @classmethod
    def load(cls, directory: str | Path) -> SimulationResult:
        """Read a result written by :meth:`save`.

        Parameters
        ----------
        directory : str or Path
            Directory holding ``arrays.npz`` and ``result.json``.

        Returns
        -------
        SimulationResult
            Equal, array by array and field by field, to the saved one.

        Raises
        ------
        ModelError
            When ``result.json`` is not a trainctl simulation result of this
            format (a key missing, unknown or wrong), or ``arrays.npz`` lacks
            an array or holds a non-finite or non-numeric one; the message
            names the file and the key or array.
        DimensionError
            When the arrays' shapes do not fit together.
        """
        from .resultfile import RESULT_HINT, read_result

        path = Path(directory)
        fields = read_result(path)
        try:
            return cls(**fields)
        except DimensionError as exc:
            raise DimensionError(f"{path}: {exc}{RESULT_HINT}") from None

    # ----------------------------------------------------------------- views
    def to_dict(self) -> dict[str, object]:
        """JSON-safe summary (no time series).

        Returns
        -------
        dict
            Controller, sample time, seed, sizes, final speeds, status counts,
            iteration and solve-time statistics, and ``meta``.
        """
        iters = self.iterations
        return {
            "controller_name": self.controller_name,
            "dt": self.dt,
            "seed": self.seed,
            "n_vehicles": self.n_vehicles,
            "n_samples": self.n_samples,
            "duration": self.duration,
            "final_speeds": self.velocities[:, -1].tolist(),
            "final_reference_speed": float(self.reference_speed[-1]),
            "max_abs_coupler_force": (
                float(np.abs(self.coupler_forces).max()) if self.coupler_forces.size else 0.0
            ),
            "status_counts": self.status_counts(),
            "iterations_mean": float(iters.mean()) if iters.size else 0.0,
            "iterations_max": int(iters.max()) if iters.size else 0,
            "solve_time_total": float(self.solve_times.sum()),
            "fallbacks": sum(1 for f in self.fallbacks if f),
            "meta": self.meta,
        }

    def labels(self) -> dict[str, list[str]]:
        """Signal names in python-control's indexed syntax.

        Returns
        -------
        dict
            ``{"v": ["v[0]", ...], "delta": [...], "f": [...], "u": [...]}``.
        """
        n = self.n_vehicles
        return {
            "v": [f"v[{i}]" for i in range(n)],
            "delta": [f"delta[{i}]" for i in range(n - 1)],
            "f": [f"f[{i}]" for i in range(n - 1)],
            "u": [f"u[{i}]" for i in range(n)],
        }

    def to_pandas(self) -> Any:
        """The time series as a ``pandas.DataFrame`` indexed by time [s].

        Columns ``v[i]`` [m/s], ``delta[i]`` [m], ``s`` [m], ``f[i]`` [N],
        ``u[i]`` [N], ``v_ref`` [m/s], ``a_ref`` [m/s²], ``status``,
        ``iterations``, ``solve_time`` [s], ``fallback``. Per-step columns
        hold the value of the interval starting at that time; the last row
        (t_N) has NaN / None there.

        Returns
        -------
        pandas.DataFrame
            N + 1 rows.

        Raises
        ------
        MissingDependencyError
            When pandas is not installed.
        """
        try:
            pd = importlib.import_module("pandas")  # optional: trainctl[pandas]
        except ImportError:
            raise MissingDependencyError(
                "SimulationResult.to_pandas: pandas must be installed (got ImportError). "
                "pip install 'trainctl[pandas]'"
            ) from None
        labels = self.labels()
        n = self.n_vehicles
        columns: dict[str, Any] = {}
        for i, name in enumerate(labels["v"] + labels["delta"]):
            columns[name] = self.states[i]
        columns["s"] = self.states[2 * n - 1]
        for i, name in enumerate(labels["f"]):
            columns[name] = self.coupler_forces[i]
        for i, name in enumerate(labels["u"]):
            columns[name] = np.append(self.inputs[i], np.nan)
        columns["v_ref"] = self.reference_speed
        columns["a_ref"] = self.reference_acceleration
        columns["status"] = [*self.statuses, None]
        columns["iterations"] = pd.array([*self.iterations.tolist(), None], dtype="Int64")
        columns["solve_time"] = np.append(self.solve_times, np.nan)
        columns["fallback"] = [*self.fallbacks, None]
        return pd.DataFrame(columns, index=pd.Index(self.time, name="time"))

    def to_time_response(self) -> ct.TimeResponseData:
        """The run as a python-control ``TimeResponseData`` (outputs = speeds).

        Inputs get one more column than :attr:`inputs` (the last input is
        held to t_N), as python-control expects one input per time point.

        Returns
        -------
        control.TimeResponseData
            Outputs ``v[i]`` [m/s], states ``v[i]``, ``delta[i]``, ``s``,
            inputs ``u[i]`` [N].
        """
        import control as ct

        labels = self.labels()
        held = np.hstack([self.inputs, self.inputs[:, -1:]]) if self.n_samples else self.inputs
        return ct.TimeResponseData(
            self.time,
            self.velocities,
            states=self.states,
            inputs=held,
            output_labels=labels["v"],
            state_labels=labels["v"] + labels["delta"] + ["s"],
            input_labels=labels["u"],
            title=f"trainctl simulation: {self.controller_name}",
            sysname=self.controller_name,
        )

    def plot(self, kind: str = "velocity", ax: Axes | None = None) -> Axes:
        """Plot one view of the run with :mod:`trainctl.plot`.

        Parameters
        ----------
        kind : {"velocity", "coupler_force", "input", "iterations"}
            What to plot.
        ax : matplotlib.axes.Axes or None
            Axes to draw into; None creates a new figure.

        Returns
        -------
        matplotlib.axes.Axes
            The axes drawn into.
        """
        from .. import plot

        functions = {
            "velocity": plot.velocity_plot,
            "coupler_force": plot.coupler_force_plot,
            "input": plot.input_plot,
            "iterations": plot.iterations_plot,
        }
        if kind not in functions:
            raise ModelError(
                f"SimulationResult.plot: 'kind' must be one of {PLOT_KINDS} (got {kind!r})."
            )
        return functions[kind](self, ax=ax)
