"""The iteration limit of an iterating controller in the simulation and its metrics."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from trainctl.exceptions import ConvergenceWarning
from trainctl.run.analysis import make_controller, run_scenario, simulate_strategy
from trainctl.scenario import load_scenario
from trainctl.sim import SimulationResult, compute_metrics
from trainctl.sweep import SweepPoint, point_rows


def result(residuals: tuple[tuple[float, ...], ...], meta: dict[str, object]) -> SimulationResult:
    """A one-vehicle run at constant speed with the given per-step residuals [kN]."""
    steps = len(residuals)
    return SimulationResult(
        time=np.arange(steps + 1, dtype=float), states=np.vstack([np.full(steps + 1, 10.0),
                                                                  10.0 * np.arange(steps + 1)]),
        velocities=np.full((1, steps + 1), 10.0), coupler_forces=np.zeros((0, steps + 1)),
        inputs=np.zeros((1, steps)), reference_speed=np.full(steps + 1, 10.0),
        reference_acceleration=np.zeros(steps + 1), statuses=("optimal",) * steps,
        iterations=np.array([len(r) for r in residuals], dtype=np.int64), residuals=residuals,
        solve_times=np.full(steps, 1e-3), fallbacks=("",) * steps, controller_name="hand",
        seed=0, dt=1.0, meta=meta)


class TestMetrics:
    LIMIT = {"iteration_limit": 3, "iteration_tolerance": 0.01}

    def test_counts_the_steps_stopped_at_the_limit(self) -> None:
        """Only a step with 3 iterations whose last change is above 0.01 kN counts; one that
        converged on its 3rd iteration, one under the limit and a held step do not."""
        m = compute_metrics(result(((0.5, 0.1, 0.05), (0.5, 0.005), (1.0, 0.5, 0.01),
                                    (), (0.2, 0.3, 0.4)), self.LIMIT))
        assert (m.iteration_limit, m.iteration_limit_steps) == (3, 2)
        assert m.iterations_converged is False
        d = json.loads(json.dumps(m.to_dict()))
        assert (d["iteration_limit"], d["iteration_limit_steps"],
                d["iterations_converged"]) == (3, 2, False)

    def test_converged(self) -> None:
        m = compute_metrics(result(((0.5, 0.005), (1.0, 0.5, 0.01)), self.LIMIT))
        assert (m.iteration_limit_steps, m.iterations_converged) == (0, True)

    @pytest.mark.parametrize("meta", [{}, {"iteration_limit": None, "iteration_tolerance": None}])
    def test_none_without_a_limit(self, meta: dict[str, object]) -> None:
        """A controller that does not iterate (or a result saved before) has no verdict."""
        m = compute_metrics(result(((0.5, 0.1, 0.05),), meta))
        assert (m.iteration_limit, m.iteration_limit_steps, m.iterations_converged) == (
            None, None, None)

    def test_sweep_columns(self) -> None:
        """metric.converged and metric.iteration_limit_steps come from the run's metrics."""
        m = compute_metrics(result(((0.5, 0.1, 0.05),), self.LIMIT)).to_dict()
        (row,) = point_rows(SweepPoint(0, {}), "k", {"simulations": {"ndmpc": m}})
        assert (row["metric.converged"], row["metric.iteration_limit_steps"]) == (False, 1)
        assert row["metric.deviation_ratio"] is None


class TestController:
    def test_iterating_strategies_declare_their_limit(self) -> None:
        """crh2-dmpc: N-DMPC iterates up to 50 times to 1e-4 kN; the others do not iterate."""
        scenario = load_scenario("crh2-dmpc")
        ndmpc = make_controller(scenario, "ndmpc")
        assert (ndmpc.iteration_limit, ndmpc.iteration_tolerance) == (50, 1e-4)
        for strategy in ("centralised", "decentralised"):
            controller = make_controller(scenario, strategy)
            assert controller.iteration_limit is None and controller.iteration_tolerance is None

    def test_simulation_records_it(self) -> None:
        """The run's meta holds the limit, and its metrics count against it."""
        scenario = load_scenario("crh2-dmpc-convergence-sweep")
        run = simulate_strategy(scenario, "ndmpc")
        assert (run.meta["iteration_limit"], run.meta["iteration_tolerance"]) == (30, 1e-3)
        m = compute_metrics(run)
        assert m.iteration_limit_steps == 0 and m.iterations_converged is True
        assert all(r[-1] <= 1e-3 and len(r) <= 30 for r in run.residuals)
        with pytest.warns(ConvergenceWarning) as caught:
            tight = simulate_strategy(scenario.replace("controller.max_iterations", 2), "ndmpc")
        assert compute_metrics(tight).iteration_limit_steps == tight.n_samples
        (warning,) = caught
        assert str(warning.message).startswith(
            f"simulate: {tight.n_samples} of {tight.n_samples} steps of 'ndmpc' stopped at the "
            "iteration limit 2 with a change above the tolerance 0.001;")
        assert warning.filename == __file__  # stacklevel: the caller's line, not trainctl's

    def test_converged_run_does_not_warn(self) -> None:
        """A run whose every step converged warns nothing (warnings are errors here)."""
        scenario = load_scenario("crh2-dmpc-convergence-sweep")
        run = simulate_strategy(scenario.replace("simulation.duration", 60.0), "ndmpc")
        assert compute_metrics(run).iterations_converged is True

    def test_run_scenario_records_instead_of_warning(self) -> None:
        """run_scenario (the CLI's, the report's and the sweep's path) records the trouble in
        the metrics and does not warn; the warnings filter is left as it was."""
        scenario = (load_scenario("crh2-dmpc-convergence-sweep")
                    .replace("controller.max_iterations", 2)
                    .replace("simulation.duration", 60.0))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            run = run_scenario(scenario)
            with pytest.raises(ConvergenceWarning):  # the filter is back afterwards
                warnings.warn("after", ConvergenceWarning, stacklevel=1)
        m = run.metrics["ndmpc"]
        assert m.iteration_limit_steps == run.simulations["ndmpc"].n_samples > 0

    def test_threads_record_without_warning(self) -> None:
        """Runs in threads side by side (a Dask worker's threads, a thread pool) record and do
        not warn: the switch is an argument, not the process-wide warnings filter."""
        from concurrent.futures import ThreadPoolExecutor

        from trainctl.run.analysis import submit_simulations

        scenario = (load_scenario("crh2-dmpc-convergence-sweep")
                    .replace("controller.max_iterations", 2)
                    .replace("simulation.duration", 60.0))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with ThreadPoolExecutor(max_workers=2) as pool:
                futures = [submit_simulations(scenario, pool) for _ in range(3)]
                results = [f.result() for batch in futures for f in batch.values()]
            quiet = simulate_strategy(scenario, "ndmpc", warn=False)
        assert all(compute_metrics(r).iteration_limit_steps == r.n_samples
                   for r in results if r.controller_name == "ndmpc")
        assert compute_metrics(quiet).iteration_limit_steps == quiet.n_samples
