# The record of one closed-loop simulation, its files and its views.
"""The result of :func:`trainctl.sim.simulate`.

Arrays are indexed (signal, time) as in python-control. Sample k covers the
interval [t_k, t_{k+1}); signals sampled at the instants (states, speeds,
coupler forces, reference) have N + 1 columns, t_0 .. t_N, and per-step
records (inputs held over the interval, statuses, iterations, solve times)
have N.

Between the samples the plant is recorded on a dense grid, the ``dense_*``
arrays (:attr:`SimulationResult.dense_time` and the states, coupler forces and
reference speed there): the integrator's substeps, or a coarser grid
(:func:`trainctl.sim.simulate`, ``output_interval``), always including every
sample instant, where the dense values equal the sampled ones. The applied
inputs (``inputs``, saturated to the envelopes) sit beside the controller's
requests (``requested_inputs``) and a per-vehicle saturation flag per sample
(``saturation``).

:meth:`SimulationResult.save` writes a directory with ``arrays.npz`` (plain
numpy arrays, loadable with ``allow_pickle=False``) and ``result.json``
(scalars, strings, statuses, residuals and ``meta``);
:meth:`SimulationResult.load` reads it back exactly.
"""

from __future__ import annotations

import json
import platform
import sys
from collections import Counter
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import STATUSES
from trainctl.exceptions import DimensionError
from trainctl.sim._views import PLOT_KINDS, ResultViews

__all__ = ["ARRAY_NAMES", "FORMAT", "OPTIONAL_ARRAY_NAMES", "PLOT_KINDS", "SimulationResult",
           "environment"]

FORMAT = "trainctl.SimulationResult/1"
"""Format tag written to ``result.json``."""

_ARRAYS = (
    "time", "states", "velocities", "coupler_forces", "inputs", "reference_speed",
    "reference_acceleration", "iterations", "solve_times",
)
_EXTRA_ARRAYS = (
    "requested_inputs", "saturation", "dense_time", "dense_states", "dense_coupler_forces",
    "dense_reference_speed", "held_noise_square",
)
"""Arrays added later: a saved run without them loads with their defaults."""
_DENSE_DEFAULTS = {"requested_inputs": "inputs", "dense_time": "time", "dense_states": "states",
                   "dense_coupler_forces": "coupler_forces",
                   "dense_reference_speed": "reference_speed"}
ARRAY_NAMES = _ARRAYS
"""The arrays every result has, the required members of its ``arrays.npz``."""
OPTIONAL_ARRAY_NAMES = _EXTRA_ARRAYS
"""Arrays a saved result may lack (saved before they existed); they take their defaults."""
_DEPENDENCIES = ("numpy", "scipy", "control", "slycot", "cvxpy", "osqp", "daqp", "matplotlib",
                 "pandas", "pyarrow")


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
    from trainctl import __version__

    # trainctl's own version is the one imported: the index's "trainctl" is
    # another project, and a source checkout may have no metadata at all.
    versions: dict[str, str | None] = {"trainctl": __version__}
    for package in _DEPENDENCIES:
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
class SimulationResult(ResultViews):
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
        JSON-safe extras: versions, train, plant and run settings; with
        ``"plant_saturation"`` (bool), ``"divergence"`` (None, or where
        the run was stopped: see :attr:`divergence`) and, from
        :func:`~trainctl.sim.simulate`, ``"iteration_limit"`` and
        ``"iteration_tolerance"`` (an iterating controller's limit per step
        and convergence tolerance; None otherwise).
    requested_inputs : ndarray or None
        Forces the controller asked for over [t_k, t_{k+1}) [N], shape
        (n, N) (a non-finite request is recorded as the input held instead);
        None: equal to ``inputs`` (nothing saturated).
    saturation : ndarray of int8 or None
        Per vehicle and sample: +1 when the force was held at the traction
        limit (the request cut to it, or asking for it), -1 at the braking
        limit, 0 elsewhere (:class:`~trainctl.models.ActuatorLimits`), shape
        (n, N); None: zeros. ``requested_inputs != inputs`` shows the cuts.
    dense_time : ndarray or None
        The dense grid [s], strictly increasing, shape (D,), holding every
        sample instant; None: the samples (``time``).
    dense_states : ndarray or None
        Plant states on the dense grid, shape (2n, D); None: ``states``.
    dense_coupler_forces : ndarray or None
        Coupler forces on the dense grid [N], shape (n-1, D); None:
        ``coupler_forces``.
    dense_reference_speed : ndarray or None
        Reference speed on the dense grid [m/s], shape (D,); None:
        ``reference_speed``.
    held_noise_square : ndarray or None
        Per sample: Σ over the network's links of the squared noise of the
        value the controller held during it (its unit squared, (m/s)² for
        speeds; :meth:`trainctl.models.network.MessageLog.held_noise_square`),
        shape (N,); None: zeros (no network).

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
    requested_inputs: NDArray[np.float64] = None  # type: ignore[assignment]
    saturation: NDArray[np.int8] = None  # type: ignore[assignment]
    dense_time: NDArray[np.float64] = None  # type: ignore[assignment]
    dense_states: NDArray[np.float64] = None  # type: ignore[assignment]
    dense_coupler_forces: NDArray[np.float64] = None  # type: ignore[assignment]
    dense_reference_speed: NDArray[np.float64] = None  # type: ignore[assignment]
    held_noise_square: NDArray[np.float64] = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        self._coerce()
        n, steps = self._check_samples()
        self._check_extra(n, steps)

    def _coerce(self) -> None:
        """Arrays as float64 (int64, int8 flags), the defaults filled in, tuples of str."""
        for name in _ARRAYS:
            dtype = np.int64 if name == "iterations" else np.float64
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=dtype))
        for name, source in _DENSE_DEFAULTS.items():
            value = getattr(self, name)
            value = getattr(self, source) if value is None else value
            object.__setattr__(self, name, np.asarray(value, dtype=np.float64))
        flags = (np.zeros(self.inputs.shape, dtype=np.int8) if self.saturation is None
                 else np.asarray(self.saturation))
        if flags.dtype.kind not in "biuf" or not np.isin(flags, (-1, 0, 1)).all():
            raise DimensionError(
                "SimulationResult: 'saturation' must hold -1, 0 or +1 per vehicle and sample "
                f"(got values {np.unique(flags)[:5].tolist()}).")
        object.__setattr__(self, "saturation", flags.astype(np.int8))
        held = (np.zeros(self.inputs.shape[-1]) if self.held_noise_square is None
                else self.held_noise_square)
        object.__setattr__(self, "held_noise_square", np.asarray(held, dtype=np.float64))
        object.__setattr__(self, "statuses", tuple(str(s) for s in self.statuses))
        object.__setattr__(self, "fallbacks", tuple(str(s) for s in self.fallbacks))
        object.__setattr__(
            self, "residuals", tuple(tuple(float(r) for r in rs) for rs in self.residuals)
        )

    def _check_samples(self) -> tuple[int, int]:
        """Shapes of the sampled arrays and records; returns (n, N)."""
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
        return n, steps

    def _check_extra(self, n: int, steps: int) -> None:
        """Shapes of the requested inputs, saturation flags and dense arrays."""
        n_d = self.dense_time.shape[0] if self.dense_time.ndim == 1 else -1
        expected = {
            "requested_inputs": (n, steps),
            "saturation": (n, steps),
            "held_noise_square": (steps,),
            "dense_time": (n_d,),
            "dense_states": (2 * n, n_d),
            "dense_coupler_forces": (max(n - 1, 0), n_d),
            "dense_reference_speed": (n_d,),
        }
        for name, shape in expected.items():
            if getattr(self, name).shape != shape:
                raise DimensionError(
                    f"SimulationResult: {name!r} must have shape {shape} for {n} vehicles, "
                    f"{steps} samples and {n_d} dense points (got {getattr(self, name).shape})."
                )
        where = np.searchsorted(self.dense_time, self.time)
        if n_d < 1 or np.any(np.diff(self.dense_time) <= 0) or np.any(where >= n_d) \
                or not np.array_equal(self.dense_time[np.minimum(where, n_d - 1)], self.time):
            raise DimensionError(
                "SimulationResult: 'dense_time' must increase strictly and hold every sample "
                f"instant of 'time' ({self.time.shape[0]} instants, {n_d} dense points).")

    # ------------------------------------------------------------ shape info
    @property
    def duration(self) -> float:
        """Simulated time t_N - t_0 [s]."""
        return float(self.time[-1] - self.time[0])

    @property
    def positions(self) -> NDArray[np.float64]:
        """Head position s at the instants [m], shape (N+1,)."""
        head: NDArray[np.float64] = self.states[-1]
        return head

    @property
    def dense_velocities(self) -> NDArray[np.float64]:
        """Vehicle speeds on the dense grid [m/s], shape (n, D) (a view of ``dense_states``)."""
        return self.dense_states[: self.n_vehicles]

    @property
    def dense_sample_index(self) -> NDArray[np.int64]:
        """Column of each sample instant in the dense arrays, shape (N+1,)."""
        return np.searchsorted(self.dense_time, self.time).astype(np.int64)

    @property
    def divergence(self) -> dict[str, Any] | None:
        """Where the run was stopped because the plant diverged, or None.

        ``{"sample": k, "time": t [s], "signal": "v[i]" or "state", "value": ...,
        "bound": ..., "message": ...}`` from ``meta["divergence"]``
        (:func:`trainctl.sim.simulate`): the result then ends at the last
        finite state, before ``duration``.
        """
        found = self.meta.get("divergence")
        return dict(found) if isinstance(found, dict) else None

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
    def save(self, directory: str | Path, *, dense: bool = True,
             compressed: bool = False) -> Path:
        """Write ``arrays.npz`` and ``result.json`` into ``directory``.

        Parameters
        ----------
        directory : str or Path
            Directory to write (created with its parents when missing;
            existing files of these names are replaced).
        dense : bool
            Keep the between-sample arrays (``dense_*``); without them the
            loaded result has the sampled ones in their place (about 1 %
            of the size for a 1 s sample time).
        compressed : bool
            Write ``arrays.npz`` zip-compressed (``numpy.savez_compressed``).

        Returns
        -------
        Path
            The directory.
        """
        path = Path(directory)
        path.mkdir(parents=True, exist_ok=True)
        names = [n for n in (*_ARRAYS, *_EXTRA_ARRAYS) if dense or not n.startswith("dense_")]
        writer = np.savez_compressed if compressed else np.savez
        writer(path / "arrays.npz", **{name: getattr(self, name) for name in names})
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
        from trainctl.sim.resultfile import RESULT_HINT, read_result

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
            Controller, sample time, seed, sizes, final speeds, the largest
            coupler force on the dense grid, saturated samples per vehicle,
            whether the run diverged, status counts, iteration and
            solve-time statistics, and ``meta``.
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
                float(np.abs(self.dense_coupler_forces).max())
                if self.dense_coupler_forces.size else 0.0
            ),
            "dense_points": int(self.dense_time.size),
            "saturated_samples": np.count_nonzero(self.saturation, axis=1).tolist(),
            "diverged": self.divergence is not None,
            "status_counts": self.status_counts(),
            "iterations_mean": float(iters.mean()) if iters.size else 0.0,
            "iterations_max": int(iters.max()) if iters.size else 0,
            "solve_time_total": float(self.solve_times.sum()),
            "fallbacks": sum(1 for f in self.fallbacks if f),
            "meta": self.meta,
        }
