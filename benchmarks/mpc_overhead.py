"""Benchmark: the MPC controller step against its raw QP solver on the identical data.

Run:  .venv/bin/python benchmarks/mpc_overhead.py [--scenario NAME] [--duration S]
          [--strategies centralised,decentralised,ndmpc,cooperative] [--solver daqp,osqp]
          [--rounds 5] [--sections] [--clock wall|cpu]

For every strategy of the MPC family the scenario is simulated (shortened to
``--duration`` seconds; default 80 s of crh2-dmpc-well-sampled, 1 600 steps) and the
controller's inputs of every step (time, measurement, preview) are recorded. A fresh
controller then replays them: first once with every coach QP's data logged (the
data each ``ParametricQP.solve_data`` receives), then timed. The raw solver solves
the logged data directly, warm-started, in the same order, one workspace per block
as the controller has:

  DAQP   ``daqp.Model`` set up as the dense path sets it up (same H, A, senses,
         soft weights, settings); per QP ``update(f, bupper, blower)`` + ``solve()``,
         the bounds precomputed (outside the timing) from the logged data.
  OSQP   ``osqp.OSQP`` set up with the fast path's (P, A); per QP
         ``update(q, l, u)`` + ``solve()``, (q, l, u) precomputed.

  floor  (DAQP) the least any Python controller does per QP beyond DAQP's own
         update and solve, given the composed data: the data copied into the dense
         path's buffer, its bounds gather (one take, scale and clamp; every
         constraint has one member here), the cost slice, ``update`` + ``solve`` and
         the decisions taken out, no check and no record. The step's own work
         (composing the data from the state and the other coaches' plans, the
         Jacobi combination, feedforward and envelope) comes on top, so floor / raw
         bounds step / raw from below for any NumPy implementation of this path:
         measured 2.4 x on the well-sampled N-DMPC (3.0 us raw, 7.2 us floor per
         QP), above the 2 x target before any of the step's own work.

Controller pass, raw pass and floor pass alternate round by round; the ratio
controller step time / raw solver time is taken per round (median and range over the
rounds), and ``best/best``: every step (every raw QP) does the same work in every
round, so its fastest round is its time least disturbed by the other processes of
a shared machine; the sums of those minima per step and their ratio. Each timed
interval has the cost of a clock reading (its median over many) subtracted. The
controller time is the sum of ``step`` times (the loop, the plant and ``reset``
outside it). ``--sections`` adds a breakdown of one controller pass
(per-step wall time of its parts, measured by wrapping them: the wrappers add about
0.3 µs per call).

Target (trainctl issue 27): controller step <= 2x the raw solver time (DAQP path,
well-sampled N-DMPC). Set OPENBLAS_NUM_THREADS=1 for stable numbers.
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import time
from typing import Any

import numpy as np

from trainctl.run.simulate import make_controller, simulate_strategy
from trainctl.scenario import load_scenario

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
CLOCK = time.perf_counter
CLOCK_COST = 0.0
"""The clock of every timing: wall time, or with ``--clock cpu`` the process's CPU time
(``time.process_time``: not counting the time other processes hold the cores)."""


def shortened(name: str, duration: float | None) -> Any:
    scenario = load_scenario(name)
    if duration is None:
        return scenario
    settle = scenario.simulation.settle_time
    if settle >= duration:
        scenario = scenario.replace("simulation.settle_time", duration / 2)
    return scenario.replace("simulation.duration", duration)


def record_inputs(scenario: Any, strategy: str) -> list[tuple[float, Any, Any]]:
    """The (t, measurement, preview) of every controller step of the simulated run."""
    import trainctl.run.simulate as run_simulate

    calls: list[tuple[float, Any, Any]] = []
    original = run_simulate.make_controller

    def make(*args: Any, **kwargs: Any) -> Any:
        controller = original(*args, **kwargs)
        step = controller.step

        def recorded(t: float, measurement: Any, reference: Any) -> Any:
            calls.append((t, copy.deepcopy(measurement), copy.deepcopy(reference)))
            return step(t, measurement, reference)

        controller.step = recorded
        return controller

    run_simulate.make_controller = make
    try:
        simulate_strategy(scenario, strategy, warn=False)
    finally:
        run_simulate.make_controller = original
    return calls


def log_data(controller: Any, calls: list[tuple[float, Any, Any]]) -> list[tuple[int, Any]]:
    """Replay once with every block QP's data logged: [(block index, data), ...]."""
    log: list[tuple[int, Any]] = []
    saved = []
    for index, block in enumerate(controller.blocks):
        original = block.qp.solve_data
        saved.append((block.qp, original))

        def logged(data: Any, _orig: Any = original, _i: int = index) -> Any:
            log.append((_i, np.array(data, dtype=float, copy=True)))
            return _orig(data)

        block.qp.solve_data = logged
    controller.reset()
    for t, measurement, reference in calls:
        controller.step(t, measurement, reference)
    for qp, _ in saved:
        del qp.solve_data  # back to the class's method
    return log


def time_controller(controller: Any, calls: list[tuple[float, Any, Any]]) -> float:
    """Sum of the step wall times over the recorded inputs, from a reset controller [s]."""
    return float(step_times(controller, calls).sum())


def step_times(controller: Any, calls: list[tuple[float, Any, Any]]) -> Any:
    """Each step's time over the recorded inputs, from a reset controller [s]."""
    controller.reset()
    step, clock = controller.step, CLOCK
    times = np.empty(len(calls))
    for k, (t, measurement, reference) in enumerate(calls):
        start = clock()
        step(t, measurement, reference)
        times[k] = clock() - start
    return times - CLOCK_COST


class RawDAQP:
    """DAQP called directly on the logged data, one workspace per block (module docstring)."""

    def __init__(self, controller: Any, log: list[tuple[int, Any]]) -> None:
        self.dense = [block.qp.dense_path for block in controller.blocks]
        self.prepared = []
        self.skipped = 0
        for i, data in log:
            dense = self.dense[i]
            lower, upper, violated = dense._bounds(data)
            if violated or (lower > upper).any() or dense._model is None:
                self.skipped += 1  # no plain DAQP solve in the controller either
                continue
            f = np.ascontiguousarray(data[dense._keep_index])
            self.prepared.append((i, f, upper, lower))

    def _models(self) -> list[Any]:
        import daqp

        models = []
        for dense in self.dense:
            model = daqp.Model()
            model.setup(dense.H, dense._f0, dense.A, dense._upper0, dense._lower0,
                        dense._sense0.copy())
            model.settings = dense._settings
            if dense.soft:
                n_all = dense.n_simple + dense.n_rows
                rho, w = np.full(n_all, 1.0), np.zeros(n_all)
                rho[dense._soft_part] = 1.0 / dense._w2[dense._soft_slack]
                w[dense._soft_part] = dense._w1[dense._soft_slack]
                model.soft_weights(rho_l=rho, rho_u=rho, w_l=w, w_u=w)
            models.append(model)
        return models

    def run(self) -> tuple[float, list[Any]]:
        models = self._models()
        out = []
        clock = CLOCK
        times = np.empty(len(self.prepared))
        for k, (i, f, upper, lower) in enumerate(self.prepared):
            model = models[i]
            start = clock()
            model.update(f=f, bupper=upper, blower=lower)
            out.append(model.solve())
            times[k] = clock() - start
        return times - CLOCK_COST, out


class RawOSQP:
    """OSQP called directly on the logged data, one workspace per block."""

    def __init__(self, controller: Any, log: list[tuple[int, Any]]) -> None:
        self.fast = [block.qp.fast_path for block in controller.blocks]
        self.prepared = [(i, *self.fast[i].qlu(data)) for i, data in log]
        self.skipped = 0

    def run(self) -> tuple[float, list[Any]]:
        import osqp
        import scipy.sparse as sp

        from trainctl.controllers.mpc.qp.parametric import OSQP_SETTINGS

        solvers = []
        for fast in self.fast:
            solver = osqp.OSQP()
            q, lo, up = fast.qlu(fast.offset)
            solver.setup(sp.csc_matrix(sp.triu(fast.P, format="csc")), q,
                         sp.csc_matrix(fast.Amat), lo, up, verbose=False, warm_starting=True,
                         **OSQP_SETTINGS)
            solvers.append(solver)
        out = []
        clock = CLOCK
        times = np.empty(len(self.prepared))
        for k, (i, q, lo, up) in enumerate(self.prepared):
            solver = solvers[i]
            start = clock()
            solver.update(q=q, l=lo, u=up)
            out.append(solver.solve(raise_error=False))
            times[k] = clock() - start
        return times - CLOCK_COST, out


class FloorDAQP(RawDAQP):
    """The floor pass (module docstring): the minimal Python path around DAQP per QP."""

    def __init__(self, controller: Any, log: list[tuple[int, Any]]) -> None:
        super().__init__(controller, log)
        self.log = [(i, data) for i, data in log]

    def run(self) -> tuple[float, list[Any]]:
        models = self._models()
        dense, clock = self.dense, CLOCK
        out = []
        times = np.empty(len(self.log))
        for k, (i, data) in enumerate(self.log):
            d, model = dense[i], models[i]
            start = clock()
            ext = d._ext
            ext[:-1] = data
            lower, upper = d._rows.gather(ext)
            model.update(f=data[d._keep_index], bupper=upper, blower=lower)
            x = model.solve()[0]
            out.append(x[d._z_pos])
            times[k] = clock() - start
        return times - CLOCK_COST, out


def _floor_columns(ctl_runs: list[Any], raw_runs: list[Any], floor_runs: list[Any]) -> str:
    """floor / raw and step / floor, medians of the rounds' ratios ("" without a floor)."""
    if not floor_runs:
        return ""
    over_raw = statistics.median(f.sum() / r.sum() for f, r in zip(floor_runs, raw_runs,
                                                                   strict=True))
    step_over = statistics.median(c.sum() / f.sum() for c, f in zip(ctl_runs, floor_runs,
                                                                    strict=True))
    return f"{over_raw:>11.2f}{step_over:>12.2f}"


def clock_cost() -> float:
    """The time one reading of the clock adds to a timed interval (median of many) [s]."""
    clock = CLOCK
    pairs = []
    for _ in range(20000):
        start = clock()
        pairs.append(clock() - start)
    return float(np.median(pairs))


def sections(controller: Any, calls: list[tuple[float, Any, Any]]) -> dict[str, float]:
    """Wall time per step of the controller's parts over one pass [s] (wrapped calls)."""
    import trainctl.controllers.mpc.strategies.base as base

    spent: dict[str, float] = {}
    undo = []

    def wrap(owner: Any, name: str, label: str) -> None:
        original = getattr(owner, name)

        def timed(*args: Any, **kwargs: Any) -> Any:
            start = CLOCK()
            try:
                return original(*args, **kwargs)
            finally:
                spent[label] = spent.get(label, 0.0) + CLOCK() - start

        object.__setattr__(owner, name, timed)
        undo.append((owner, name, original))

    wrap(controller, "_context", "context (feedforward, bounds)")
    wrap(controller.problem, "parameters", "parameters (sources, data)")
    wrap(controller._strategy, "plan", "plan (strategy)")
    for block in controller.blocks:
        if block.qp.dense_path is not None:
            wrap(block.qp.dense_path, "solve_vector", "  solve_vector")
        elif block.qp.fast_path is not None:
            wrap(block.qp.fast_path, "solve_vector", "  solve_vector")
    wrap(base, "solve_block", "  solve_block")
    try:
        total = time_controller(controller, calls)
    finally:
        base.solve_block = undo[-1][2]  # the module's function (the rest belong to controller)
    steps = len(calls)
    out = {"step (total)": total / steps}
    out.update({k: v / steps for k, v in spent.items()})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="crh2-dmpc-well-sampled")
    parser.add_argument("--duration", type=float, default=80.0,
                        help="simulated time [s] (default 80; 0: the scenario's own)")
    parser.add_argument("--strategies", default="centralised,decentralised,ndmpc,cooperative")
    parser.add_argument("--solver", default="daqp,osqp")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--sections", action="store_true")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                        help="wall time (perf_counter) or process CPU time (process_time)")
    args = parser.parse_args()
    global CLOCK, CLOCK_COST
    CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter
    CLOCK_COST = clock_cost()
    duration = args.duration or None
    print(f"{args.scenario}, {duration or 'full'} s, {args.clock} clock; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'strategy':>14}{'solver':>7}{'steps':>7}{'QPs':>7}{'step [us]':>11}"
          f"{'raw [us/step]':>15}{'step/raw':>10}{'(min..max)':>14}{'best [us]':>11}"
          f"{'raw best':>10}{'best/best':>11}"
          f"{'max|dz|':>10}{'floor/raw':>11}{'step/floor':>12}")
    for solver in args.solver.split(","):
        scenario = shortened(args.scenario, duration).replace("controller.qp_solver", solver)
        for strategy in args.strategies.split(","):
            calls = record_inputs(scenario, strategy)
            controller = make_controller(scenario, strategy)
            used = {b.qp.solver for b in controller.blocks}
            if used != {solver}:
                print(f"{strategy:>14}{solver:>7}  blocks use {sorted(used)}: skipped")
                continue
            log = log_data(controller, calls)
            raw = RawDAQP(controller, log) if solver == "daqp" else RawOSQP(controller, log)
            floor = FloorDAQP(controller, log) if solver == "daqp" and not raw.skipped else None
            ctl_runs, raw_runs, floor_runs = [], [], []
            for _ in range(args.rounds):
                ctl_runs.append(step_times(controller, calls))
                raw_runs.append(raw.run()[0])
                if floor is not None:
                    floor_runs.append(floor.run()[0])
            ctl_times = [float(run.sum()) for run in ctl_runs]
            raw_times = [float(run.sum()) for run in raw_runs]
            ratios = [c / r for c, r in zip(ctl_times, raw_times, strict=True)]
            # every step (QP) does the same work in every round: its fastest round is its
            # time undisturbed by the other processes of a shared machine
            ctl_best = float(np.min(ctl_runs, axis=0).sum())
            raw_best = float(np.min(raw_runs, axis=0).sum())
            steps = len(calls)
            # the logged decisions against the raw solver's (same data: the same solution)
            dz = float("nan")
            if solver == "daqp" and not raw.skipped:
                _, sols = raw.run()
                dz = 0.0
                pos = [b.qp.dense_path._z_pos for b in controller.blocks]
                fresh = make_controller(scenario, strategy)
                floors = floor.run()[1] if floor is not None else [None] * len(log)
                for (i, data), sol, low in zip(log, sols, floors, strict=True):
                    ours = fresh.blocks[i].qp.solve_data(data).z
                    theirs = np.asarray(sol[0])[pos[i]]
                    dz = max(dz, float(np.abs(ours - theirs).max()))
                    if low is not None:  # the floor pass solves the same QPs
                        dz = max(dz, float(np.abs(low - theirs).max()))
            print(f"{strategy:>14}{solver:>7}{steps:>7}{len(log):>7}"
                  f"{statistics.median(ctl_times) / steps * 1e6:>11.1f}"
                  f"{statistics.median(raw_times) / steps * 1e6:>15.1f}"
                  f"{statistics.median(ratios):>10.2f}"
                  f"{f'{min(ratios):.2f}..{max(ratios):.2f}':>14}"
                  f"{ctl_best / steps * 1e6:>11.1f}{raw_best / steps * 1e6:>10.1f}"
                  f"{ctl_best / raw_best:>11.2f}{dz:>10.1e}"
                  + _floor_columns(ctl_runs, raw_runs, floor_runs)
                  + (f"  ({raw.skipped} QPs not replayed)" if raw.skipped else ""), flush=True)
            if args.sections:
                for label, value in sections(make_controller(scenario, strategy),
                                             calls).items():
                    print(f"{'':>21}{label:<34}{value * 1e6:10.1f} us/step")


if __name__ == "__main__":
    main()
