"""Benchmark: one N-DMPC step, trainctl's fast path against its baselines.

Run:  .venv/bin/python benchmarks/dmpc_step.py [--quick] [--part 1,2,3,4]

Part 1 — CRH2 half train, the well-sampled design (crh2-dmpc-well-sampled:
T = 0.05 s, P = 40, M = 5, u-form, outputs speeds and coupler forces,
envelope, 5 kN/step rate and 50 kN coupler-force limits), N-DMPC with the
scenario's iteration settings, over the same closed-loop sequence of states:

  fast      trainctl, cvxpy-modelled QPs solved through the probed OSQP data
            (qp_solver="osqp")
  fast DAQP the same, solved by the dense active-set path (qp_solver="daqp",
            trainctl.controllers.mpc.qp.dense.FastDAQP)
  cvxpy     trainctl, the same QPs re-solved with Problem.solve(warm_start=True)
  rebuild   a new controller (cvxpy problems rebuilt) at every step
  raw OSQP  the identical (P, q, A, l, u) sequence the fast path produced,
            replayed on OSQP directly (update + solve, warm-started)

The ratio fast / raw OSQP measures trainctl's overhead over the solver on the
same data; the formulation (condensed: inputs are the only decisions, 5 per
coach plus slacks) is reported separately and is the same for all.

Part 1b — the dense path against OSQP on the identical data: the recorded
sequence replayed on raw OSQP, on the OSQP fast path and on the DAQP path
(warm-started, and cold: the empty working set for every QP), interleaved round
by round on the same machine; ratios of the per-round times, and the largest
difference of the solutions [kN] (target: DAQP >= 4x faster than raw OSQP,
solutions within 1e-6 kN).

Part 2 — per-iteration time and iteration counts of the fast path for trains
of 4, 8, 16, 32 and 64 coaches (T-M-M-T units of seed 000's coaches).

Part 3 — per-coach-QP time of the global N-DMPC ("ndmpc") and the
neighbourhood-local one ("ndmpc-local") side by side, each on both QP paths
(qp_solver="osqp" and "daqp"), 4 → 64 (global) and 4 → 256 (local) coaches
(--global-sizes, --local-sizes), P = 10 (where both iterations converge):
build time, per-Jacobi-iteration and per-coach-QP time, as ratios to the
smallest train of the same formulation and path, and OSQP / DAQP at each size.

Part 4 — the plant's 1 h run (benchmarks/plant_banded.py) of 4, 16, 64 and
204 vehicles, dense against banded propagation interleaved, level and graded
track: seconds, banded / dense, largest speed difference.

--part selects parts (e.g. --part 3,4); --quick is a smoke run of every part.
Set OPENBLAS_NUM_THREADS=1 for stable numbers on a shared machine.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import scipy.sparse as sp

from trainctl.controllers.base import Measurement, ReferencePreview
from trainctl.controllers.mpc import MPCConstraints, make_mpc
from trainctl.controllers.mpc.qp.parametric import OSQP_SETTINGS
from trainctl.design import build_design
from trainctl.models import Coupler, Train, equilibrium
from trainctl.scenario import load_scenario

CONSTRAINTS = MPCConstraints(rate_limit=5e3, coupler_force_limit=50e3)


def preview(d, dt, t, v0, accel):
    times = t + dt * np.arange(d.prediction_horizon + 1)
    return ReferencePreview(times=times, speed=v0 + accel * times,
                            acceleration=np.full(times.size, accel))


def closed_loop_states(train, d, dt, steps):
    """States along a closed loop of the fast controller (the shared test sequence)."""
    ctl = make_mpc(train, d, dt=dt, strategy="ndmpc", constraints=CONSTRAINTS,
                   tolerance=1e-4)
    eq = equilibrium(train, 50.0)
    n = train.n_vehicles
    x_dev = np.zeros(d.A.shape[0])
    x_dev[:n] = 1.0  # every coach 1 m/s fast
    states = []
    for k in range(steps):
        state = np.concatenate([50.0 + x_dev[:n], eq.elongations + x_dev[n:], [0.0]])
        states.append(state)
        rec = ctl.step(k * dt, Measurement(state=state), preview(d, dt, 0.0, 50.0, 0.0))
        x_dev = d.A @ x_dev + d.B @ ((rec.inputs - eq.inputs) / 1e3)
    return states


class Recorder:
    """Wraps each block QP's solve_data to record the data vectors it is given."""

    def __init__(self, ctl):
        self.log = []
        for index, block in enumerate(ctl.blocks):
            original = block.qp.solve_data

            def record(data, _orig=original, _i=index):
                self.log.append((_i, data.copy()))
                return _orig(data)

            block.qp.solve_data = record


def time_controller(ctl, states, d, dt):
    times, iters = [], []
    ctl.reset()
    for k, state in enumerate(states):
        start = time.perf_counter()
        rec = ctl.step(k * dt, Measurement(state=state), preview(d, dt, 0.0, 50.0, 0.0))
        times.append(time.perf_counter() - start)
        iters.append(rec.iterations)
    return times, iters


def time_closed_loop(ctl, train, d, dt, steps):
    """Step the controller in closed loop on its design model; time every step."""
    eq = equilibrium(train, 50.0)
    n = train.n_vehicles
    x_dev = np.zeros(d.A.shape[0])
    x_dev[:n] = 1.0
    times, iters = [], []
    for k in range(steps):
        state = np.concatenate([50.0 + x_dev[:n], eq.elongations + x_dev[n:], [0.0]])
        start = time.perf_counter()
        rec = ctl.step(k * dt, Measurement(state=state), preview(d, dt, 0.0, 50.0, 0.0))
        times.append(time.perf_counter() - start)
        iters.append(rec.iterations)
        x_dev = d.A @ x_dev + d.B @ ((rec.inputs - eq.inputs) / 1e3)
    return times, iters


def replay_raw_osqp(ctl, log, steps):
    """Solve the recorded data with fresh OSQP solvers, warm-started, in the same order."""
    import osqp

    solvers = []
    for block in ctl.blocks:
        fast = block.qp.fast_path
        solver = osqp.OSQP()
        q, lo, up = fast.qlu(fast.offset)
        solver.setup(sp.csc_matrix(sp.triu(fast.P, format="csc")), q, sp.csc_matrix(fast.Amat),
                     lo, up, verbose=False, warm_starting=True, **OSQP_SETTINGS)
        solvers.append((solver, fast))
    prepared = [(i, *solvers[i][1].qlu(data)) for i, data in log]
    start = time.perf_counter()
    for i, q, lo, up in prepared:
        solver = solvers[i][0]
        solver.update(q=q, l=lo, u=up)
        solver.solve(raise_error=False)
    return (time.perf_counter() - start) / steps


def replay_raw_osqp_solutions(ctl, log):
    """Raw OSQP on the recorded data (as :func:`replay_raw_osqp`): each QP's decisions."""
    import osqp

    solvers = []
    for block in ctl.blocks:
        fast = block.qp.fast_path
        solver = osqp.OSQP()
        q, lo, up = fast.qlu(fast.offset)
        solver.setup(sp.csc_matrix(sp.triu(fast.P, format="csc")), q, sp.csc_matrix(fast.Amat),
                     lo, up, verbose=False, warm_starting=True, **OSQP_SETTINGS)
        solvers.append((solver, fast))
    out = []
    for i, data in log:
        solver, fast = solvers[i]
        q, lo, up = fast.qlu(data)
        solver.update(q=q, l=lo, u=up)
        res = solver.solve(raise_error=False)
        out.append((res.x[fast.z_index["z"]], res.info.status_val))
    return out


def replay_fast(ctl, log, steps, solver):
    """The recorded data on a fast-path solver of every block: ``"osqp"`` (FastOSQP, fresh
    workspace), ``"daqp"`` (FastDAQP, warm-started) or ``"daqp-cold"`` (the empty working
    set for every QP, same workspace). Returns the time per step and the solutions."""
    from trainctl.controllers.mpc.qp.dense import FastDAQP

    solvers = []
    for block in ctl.blocks:
        fast = block.qp.fast_path
        if solver == "osqp":
            fast.reset()
            solvers.append(fast)
        else:
            solvers.append(FastDAQP(fast))
    cold = solver == "daqp-cold"
    sols = []
    start = time.perf_counter()
    for i, data in log:
        if cold:
            solvers[i].clear_working_set()
        sols.append(solvers[i].solve_vector(data))
    return (time.perf_counter() - start) / steps, sols


def part1b(fast, log, steps, rounds):
    """Part 1b (module docstring): DAQP vs raw OSQP vs the OSQP fast path, same data."""
    names = ("raw OSQP", "OSQP fast path", "DAQP path (warm)", "DAQP path (cold)")
    times = {name: [] for name in names}
    for _ in range(rounds):  # interleaved: each round times every solver once
        times["raw OSQP"].append(replay_raw_osqp(fast, log, steps))
        for name, key in (("OSQP fast path", "osqp"), ("DAQP path (warm)", "daqp"),
                          ("DAQP path (cold)", "daqp-cold")):
            t, sols = replay_fast(fast, log, steps, key)
            times[name].append(t)
            if key == "daqp":
                dense = sols
            elif key == "osqp":
                fast_sols = sols
    raw = replay_raw_osqp_solutions(fast, log)
    raw_ok = [k for k, (_, status) in enumerate(raw) if status == 1]
    diff_raw = max(np.abs(dense[k].z - raw[k][0]).max() for k in raw_ok)
    diff_fast = max(np.abs(d.z - f.z).max() for d, f in zip(dense, fast_sols, strict=True))
    statuses = {s.status for s in dense}
    blocks = [b.qp for b in fast.blocks]
    from trainctl.controllers.mpc.qp.dense import FastDAQP

    shapes = {(d.n_vars, d.n_simple, d.n_rows, d.soft) for d in
              (FastDAQP(qp.fast_path) for qp in blocks)}
    print(f"\nDense path on the identical data ({len(log)} QPs, {rounds} interleaved rounds; "
          "DAQP problem per coach: variables, simple bounds, rows, soft):", sorted(shapes))
    print(f"{'':24}{'median [ms/step]':>18}{'raw OSQP / this':>18}{'(min..max)':>20}")
    for name in names:
        ratios = [r / t for r, t in zip(times["raw OSQP"], times[name], strict=True)]
        print(f"{name:24}{statistics.median(times[name]) * 1e3:18.3f}"
              f"{statistics.median(ratios):18.2f}{f'{min(ratios):.2f}..{max(ratios):.2f}':>20}")
    print(f"largest |DAQP - raw OSQP| over the {len(raw_ok)} QPs OSQP solved: {diff_raw:.2e} kN; "
          f"|DAQP - OSQP fast path|: {diff_fast:.2e} kN (target <= 1e-6); DAQP statuses "
          f"{sorted(statuses)}; raw OSQP not solved: {len(raw) - len(raw_ok)}")


def part1(steps, rounds=5):
    scenario = load_scenario("crh2-dmpc-well-sampled")
    train, dt = scenario.train, scenario.model.sample_time
    d = build_design(scenario).family("mpc").mpc
    states = closed_loop_states(train, d, dt, steps)
    fast = make_mpc(train, d, dt=dt, strategy="ndmpc", constraints=CONSTRAINTS, tolerance=1e-4,
                    qp_solver="osqp")
    dense = make_mpc(train, d, dt=dt, strategy="ndmpc", constraints=CONSTRAINTS,
                     tolerance=1e-4, qp_solver="daqp")
    recorder = Recorder(fast)
    t_fast, iters = time_controller(fast, states, d, dt)
    t_dense, _ = time_controller(dense, states, d, dt)
    raw = replay_raw_osqp(fast, recorder.log, steps)
    plain = make_mpc(train, d, dt=dt, strategy="ndmpc", constraints=CONSTRAINTS, tolerance=1e-4,
                     path="cvxpy")
    t_cvxpy, _ = time_controller(plain, states, d, dt)
    t_rebuild = []
    for k, state in enumerate(states[: max(3, steps // 10)]):
        start = time.perf_counter()
        ctl = make_mpc(train, d, dt=dt, strategy="ndmpc", constraints=CONSTRAINTS,
                       tolerance=1e-4, path="cvxpy")
        ctl.step(k * dt, Measurement(state=state), preview(d, dt, 0.0, 50.0, 0.0))
        t_rebuild.append(time.perf_counter() - start)
    block = fast.blocks[0].qp
    print(f"CRH2 half train, T = {dt} s, P = {d.prediction_horizon}, M = {d.control_horizon}, "
          f"{d.form}-form, N-DMPC; {steps} closed-loop steps, median "
          f"{statistics.median(iters)} Jacobi iterations x 4 coach QPs per step")
    print(f"formulation: condensed; each coach QP has {block.nz} decisions, {block.nh} hard "
          f"rows, {block.ns} soft rows (+{block.ns} slacks)")
    mean_fast = sum(t_fast) / steps
    rows = [("trainctl fast path", statistics.median(t_fast), mean_fast),
            ("trainctl fast path, DAQP", statistics.median(t_dense), sum(t_dense) / steps),
            ("trainctl plain cvxpy re-solve", statistics.median(t_cvxpy), sum(t_cvxpy) / steps),
            ("cvxpy rebuilt every step", statistics.median(t_rebuild),
             sum(t_rebuild) / len(t_rebuild)),
            ("raw OSQP on the same data", raw, raw)]
    print("(the controller rows run one after the other; part 1b interleaves the solvers)")
    print(f"{'':32}{'median [ms]':>12}{'mean [ms]':>12}{'mean / raw':>12}")
    for name, med, mean in rows:
        print(f"{name:32}{med * 1e3:12.2f}{mean * 1e3:12.2f}{mean / raw:12.2f}")
    print(f"overhead ratio (fast / raw OSQP, same iterations and data): {mean_fast / raw:.2f} "
          "(target <= 1.5)")
    part1b(fast, recorder.log, steps, rounds)


def chain(n):
    base = load_scenario("crh2-dmpc").train
    cars = [base.vehicles[i % 4] for i in range(n)]
    coupler = Coupler(stiffness=1.0488e7, spacing=25.0)
    return Train(vehicles=tuple(cars), couplers=(coupler,) * (n - 1))


# R = max(0.2, 2 R*) per kN² for each train size, R* from analysis.mpc.threshold_weight
# (to 5 %) on this design; recompute with --compute-r (slow: R* at 64 coaches takes minutes).
SCALING_R = {4: 0.2, 8: 0.505, 16: 0.757, 32: 2.05, 64: 2.76}


def part2(sizes, steps, compute_r=False):
    from trainctl.controllers.mpc.theory.iteration import threshold_weight
    from trainctl.controllers.mpc.theory.mpc import MPCDesign
    from trainctl.models import discretise, linearise

    print("\nScaling (fast path with OSQP and with DAQP, N-DMPC, adjacent neighbourhoods, "
          f"T = 0.05 s, P = 40, M = 5, {steps} steps):")
    print("R = max(0.2, 2 R*) per kN² (R* to 5 %): the Jacobi iteration converges")
    print("(times are for closed-loop steps from a 1 m/s error on every coach)")
    print(f"{'coaches':>8}{'solver':>8}{'R':>8}{'build [s]':>11}{'iterations':>12}"
          f"{'per iteration [ms]':>20}{'per coach-QP [ms]':>19}")
    for n in sizes:
        train = chain(n)
        sys_c = linearise(train, 50.0, outputs=("v", "force"))
        scale = np.concatenate([np.ones(n), np.full(n - 1, 1e-3)])
        sysd = discretise(sys_c, 0.05)
        d = MPCDesign(A=sysd.A, B=sysd.B * 1e3, C=scale[:, None] * sysd.C,
                      prediction_horizon=40, control_horizon=5, form="u",
                      q=np.concatenate([np.full(n, 10.0), np.full(n - 1, 0.01)]),
                      r=np.full(n, 0.2), output_owner=tuple(range(n)) + tuple(range(n - 1)),
                      neighbourhoods=tuple(tuple(j for j in (i - 1, i, i + 1) if 0 <= j < n)
                                           for i in range(n)))
        if compute_r or n not in SCALING_R:
            r = max(0.2, 2.0 * threshold_weight(d, rtol=0.05))
        else:
            r = SCALING_R[n]
        d = d.with_r(r)
        for solver in ("osqp", "daqp"):
            start = time.perf_counter()
            ctl = make_mpc(train, d, dt=0.05, strategy="ndmpc", constraints=CONSTRAINTS,
                           tolerance=1e-4, qp_solver=solver)
            build = time.perf_counter() - start
            times, iters = time_closed_loop(ctl, train, d, 0.05, steps)
            per_iter = sum(times) / max(sum(iters), 1)
            print(f"{n:>8}{solver:>8}{r:>8.3g}{build:>11.2f}{statistics.median(iters):>12.1f}"
                  f"{per_iter * 1e3:>20.2f}"
                  f"{per_iter / n * 1e3:>19.3f}")


def chain_design(n, r, P=40):
    """The part-2 design of an n-coach chain and its continuous model partitioned by coach."""
    from trainctl.controllers.mpc.theory.local_iteration import local_model, train_state_owner
    from trainctl.controllers.mpc.theory.mpc import MPCDesign
    from trainctl.models import discretise, linearise

    train = chain(n)
    sys_c = linearise(train, 50.0, outputs=("v", "force"))
    scale = np.concatenate([np.ones(n), np.full(n - 1, 1e-3)])
    sysd = discretise(sys_c, 0.05)
    d = MPCDesign(A=sysd.A, B=sysd.B * 1e3, C=scale[:, None] * sysd.C,
                  prediction_horizon=P, control_horizon=5, form="u",
                  q=np.concatenate([np.full(n, 10.0), np.full(n - 1, 0.01)]),
                  r=np.full(n, r), output_owner=tuple(range(n)) + tuple(range(n - 1)),
                  neighbourhoods=tuple(tuple(j for j in (i - 1, i, i + 1) if 0 <= j < n)
                                       for i in range(n)))
    model = local_model(d, sys_c.A, sys_c.B * 1e3, 0.05, train_state_owner(n))
    return train, d, model


def part3(global_sizes, local_sizes, steps, P=10, r=2.0, repeats=3,
          solvers=("osqp", "daqp")):
    """Per-coach-QP time of the global and the local N-DMPC formulations on both QP paths.

    P = 10, R = 2 per kN²: both Jacobi iterations converge for every size (ρ(D0_local)
    0.32 at 4 coaches, 0.46 at 16; at P = 40, R = 0.2 the local one diverges, ρ 1.41).
    For every (size, formulation) one controller per QP path is built, then the same
    closed loop (``steps`` steps) is run ``repeats`` times, the paths interleaved
    (reset before each run); times are medians over the repeats. Ratios: to the
    smallest size of the same (formulation, path), and OSQP / DAQP at the same size.
    """
    print(f"\nGlobal vs local N-DMPC, QP paths {' and '.join(solvers)} (T = 0.05 s, P = {P}, "
          f"M = 5, R = {r:g} per kN², iterations to 1e-4 kN, {steps} steps from a 1 m/s "
          f"error, median of {repeats} interleaved runs):")
    print("global: every coach QP from the global model (data depend on every plan); "
          "local ('ndmpc-local'): neighbourhood model, plans and own-state trajectories "
          "exchanged")
    print("per coach-QP: all of a sweep's work divided by n; 'solver' the QP solver's share, "
          "'rest' the data composition and exchange; 'per iter.': one Jacobi sweep of all n")
    print(f"{'coaches':>8}{'form':>8}{'path':>6}{'build [s]':>11}{'distinct':>10}{'rows':>6}"
          f"{'Jacobi':>8}{'QP iters':>10}{'per iter. [ms]':>16}{'per coach-QP [ms]':>19}"
          f"{'solver [ms]':>13}{'rest [ms]':>11}")
    results = {}
    for n in sorted(set(global_sizes) | set(local_sizes)):
        train, d, model = chain_design(n, r, P)
        for form, strategy, sizes in (("global", "ndmpc", global_sizes),
                                      ("local", "ndmpc-local", local_sizes)):
            if n not in sizes:
                continue
            ctls, builds, logs = {}, {}, {}
            for solver in solvers:
                start = time.perf_counter()
                ctl = make_mpc(train, d, dt=0.05, strategy=strategy, constraints=CONSTRAINTS,
                               tolerance=1e-4, qp_solver=solver,
                               local_model=model if form == "local" else None)
                builds[solver] = time.perf_counter() - start
                used = {b.qp.solver for b in ctl.blocks}
                if used != {solver}:
                    raise RuntimeError(f"{form} {n}: asked for {solver}, blocks use {used}")
                log = logs[solver] = []
                for block in ctl.blocks:
                    def record(data, _orig=block.qp.solve_data, _log=log):
                        sol = _orig(data)
                        _log.append((sol.iterations, sol.solve_time))
                        return sol
                    block.qp.solve_data = record
                ctls[solver] = ctl
            runs = {solver: [] for solver in solvers}
            for _ in range(repeats):
                for solver, ctl in ctls.items():
                    ctl.reset()
                    logs[solver].clear()
                    times, iters = time_closed_loop(ctl, train, d, 0.05, steps)
                    qps = max(sum(iters), 1) * n
                    runs[solver].append((sum(times) / max(sum(iters), 1), sum(times) / qps,
                                         sum(t for _, t in logs[solver]) / qps,
                                         statistics.mean(iters),
                                         statistics.mean(i for i, _ in logs[solver])))
            for solver, ctl in ctls.items():
                per_iter, per_qp, solve, jacobi, qp_iters = (
                    statistics.median(col) for col in zip(*runs[solver], strict=True))
                distinct = getattr(ctl.problem, "distinct", n)
                rows = max(b.qp.nh + b.qp.ns for b in ctl.blocks)
                results[n, form, solver] = dict(build=builds[solver], per_iter=per_iter,
                                                per_qp=per_qp, solve=solve, jacobi=jacobi,
                                                runs=[run[1] for run in runs[solver]])
                print(f"{n:>8}{form:>8}{solver:>6}{builds[solver]:>11.2f}{distinct:>10}"
                      f"{rows:>6}{jacobi:>8.1f}{qp_iters:>10.1f}{per_iter * 1e3:>16.3f}"
                      f"{per_qp * 1e3:>19.4f}{solve * 1e3:>13.4f}{(per_qp - solve) * 1e3:>11.4f}",
                      flush=True)
    part3_ratios(results, global_sizes, local_sizes, solvers)
    return results


def part3_ratios(results, global_sizes, local_sizes, solvers):
    """Part 3's ratios: to the smallest size of the same (formulation, path), OSQP / DAQP."""
    print("\nRatios to the smallest train of the same formulation and path "
          "(per coach-QP: target flat within 1.5x for the local formulation), "
          "and OSQP / DAQP per coach-QP at the same size (per-run ratios, median):")
    print(f"{'coaches':>8}{'form':>8}{'path':>6}{'per coach-QP':>14}{'per iter.':>11}"
          f"{'build':>8}{'OSQP/DAQP':>11}")
    for form, sizes in (("global", global_sizes), ("local", local_sizes)):
        sizes = sorted(sizes)
        for solver in solvers:
            base = results.get((sizes[0], form, solver)) if sizes else None
            if base is None:
                continue
            for n in sizes:
                row = results[n, form, solver]
                pair = ""
                if solver == "osqp" and (n, form, "daqp") in results:
                    ratio = statistics.median(
                        o / q for o, q in zip(row["runs"], results[n, form, "daqp"]["runs"],
                                              strict=True))
                    pair = f"{ratio:.1f}"
                print(f"{n:>8}{form:>8}{solver:>6}{row['per_qp'] / base['per_qp']:>14.2f}"
                      f"{row['per_iter'] / base['per_iter']:>11.2f}"
                      f"{row['build'] / base['build']:>8.2f}{pair:>11}")
            ratios = [results[n, form, solver]["per_qp"] / base["per_qp"] for n in sizes]
            print(f"{form} {solver}: per coach-QP {sizes[0]} -> {sizes[-1]} coaches within "
                  f"{min(ratios):.2f}..{max(ratios):.2f}x of {sizes[0]} coaches "
                  f"({'flat' if max(ratios) <= 1.5 else 'not flat'} within 1.5x)")


def part4(sizes, duration, grades=(False, True)):
    """The plant's 1 h run, dense against banded propagation (benchmarks/plant_banded.py)."""
    from plant_banded import hour

    print(f"\nPlant, {duration:g} s at T = 1 s ({int(duration) * 20} substeps), speed law "
          "15 -> 25 -> 18 m/s, dense and banded propagation interleaved sample by sample, "
          "cold caches:")
    print(f"{'vehicles':>8}{'track':>8}{'km':>7}{'dense [s]':>11}{'banded [s]':>12}"
          f"{'banded/dense':>14}{'max |dv| [m/s]':>16}")
    out = {}
    for n in sizes:
        for graded in grades:
            tag = "grades" if graded else "level"
            res = hour(duration, grades=graded, vehicles=n, verbose=False)
            dense, banded = res[f"hour {tag} dense s"], res[f"hour {tag} banded s"]
            out[n, tag] = res
            print(f"{n:>8}{tag:>8}{res[f'hour {tag} km']:>7.1f}{dense:>11.2f}{banded:>12.2f}"
                  f"{banded / dense:>14.3f}{res[f'hour {tag} max dv']:>16.1e}", flush=True)
    return out


def sizes_arg(text):
    return [int(s) for s in text.split(",") if s]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps and sizes (smoke run)")
    parser.add_argument("--part", default="1,2,3,4",
                        help="parts to run, comma-separated, of 1 (with 1b), 2, 3, 4 "
                             "(default all)")
    parser.add_argument("--compute-r", action="store_true",
                        help="recompute R* for every train size (slow)")
    parser.add_argument("--global-sizes", type=sizes_arg, default=None,
                        help="part 3: coaches of the global formulation (default 4,8,16,32,64; "
                             "its build grows faster than linearly)")
    parser.add_argument("--local-sizes", type=sizes_arg, default=None,
                        help="part 3: coaches of the local formulation "
                             "(default 4,8,16,32,64,128,256)")
    parser.add_argument("--repeats", type=int, default=None,
                        help="part 3: interleaved runs per controller (default 3)")
    parser.add_argument("--plant-sizes", type=sizes_arg, default=None,
                        help="part 4: vehicles per chain (default 4,16,64,204)")
    parser.add_argument("--seconds", type=float, default=None,
                        help="part 4: simulated time [s] (default 3600)")
    args = parser.parse_args()
    parts = {p.strip() for p in args.part.split(",")}
    unknown = parts - {"1", "2", "3", "4"}
    if unknown:
        parser.error(f"--part: unknown part(s) {sorted(unknown)}")
    quick = args.quick
    if "1" in parts:
        part1(steps=10 if quick else 60, rounds=2 if quick else 5)
    if "2" in parts:
        part2([4, 8] if quick else [4, 8, 16, 32, 64], steps=3 if quick else 6,
              compute_r=args.compute_r)
    if "3" in parts:
        part3(args.global_sizes or ([4, 8] if quick else [4, 8, 16, 32, 64]),
              args.local_sizes or ([4, 8] if quick else [4, 8, 16, 32, 64, 128, 256]),
              steps=2 if quick else 4,
              repeats=args.repeats or (1 if quick else 3))
    if "4" in parts:
        part4(args.plant_sizes or ([4, 16] if quick else [4, 16, 64, 204]),
              args.seconds or (60.0 if quick else 3600.0))


if __name__ == "__main__":
    main()
