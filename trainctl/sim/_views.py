# The views of a simulation result: signal names, pandas, python-control, matplotlib.
"""Views of a :class:`~trainctl.sim.SimulationResult` (a mixin of its methods).

The result keeps its arrays; these methods present them to pandas,
python-control and :mod:`trainctl.plots.time`, importing each only when called.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import NDArray

from trainctl.exceptions import MissingDependencyError, ModelError

if TYPE_CHECKING:
    import control as ct
    from matplotlib.axes import Axes

    from trainctl.sim.results import SimulationResult

__all__ = ["PLOT_KINDS", "ResultViews"]

PLOT_KINDS = ("velocity", "coupler_force", "input", "iterations")
"""Kinds accepted by :meth:`SimulationResult.plot`."""


class ResultViews:
    """The views of :class:`~trainctl.sim.SimulationResult` (its fields are declared there)."""

    time: NDArray[np.float64]
    states: NDArray[np.float64]
    velocities: NDArray[np.float64]
    coupler_forces: NDArray[np.float64]
    inputs: NDArray[np.float64]
    reference_speed: NDArray[np.float64]
    reference_acceleration: NDArray[np.float64]
    statuses: tuple[str, ...]
    iterations: NDArray[np.int64]
    solve_times: NDArray[np.float64]
    fallbacks: tuple[str, ...]
    controller_name: str

    @property
    def n_vehicles(self) -> int:
        """Number of vehicles n."""
        return int(self.velocities.shape[0])

    @property
    def n_samples(self) -> int:
        """Number of controller samples N."""
        return int(self.inputs.shape[1])

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
            pd = importlib.import_module("pandas")  # optional: trainctl-toolbox[pandas]
        except ImportError:
            raise MissingDependencyError(
                "SimulationResult.to_pandas: pandas must be installed (got ImportError). "
                "pip install 'trainctl-toolbox[pandas]'"
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
        """Plot one view of the run with :mod:`trainctl.plots.time`.

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
        from trainctl.plots import time as plot
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
        return functions[kind](cast("SimulationResult", self), ax=ax)
