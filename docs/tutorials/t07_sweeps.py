"""
Sweeps on the local cores and on a Dask cluster
===============================================

A sweep runs one scenario at many points of its file keys: lists, grids or
random samples, and optionally several seeds. ``trainctl sweep`` does this
from the command line; this tutorial does it from Python with
``trainctl.sweep``, first on a pool of local processes and then on a Dask
cluster, and checks that both give the same table.

The scenario is the built-in ``crh2-dmpc-convergence-sweep``: the
well-sampled CRH2 N-DMPC without constraints, 1 s per point, whose
``[sweep]`` sets the input weight R against the sample time T. The question
it answers: does the N-DMPC iteration converge at every step exactly where
the closed-form ρ(D0) says it should?
"""

# %%
# The sweep in one call
# ---------------------
#
# ``sweep_scenario`` does what ``trainctl sweep`` does: it takes the
# scenario's ``[sweep]`` (or axes given as ``"KEY=V1,V2,..."``, the command
# line's ``--set``), validates every point's scenario with the schema before
# anything runs, opens a resumable store in a directory (each finished point
# is written at once; the same sweep into the same directory again runs only
# the points it lacks) and runs the points on any
# ``concurrent.futures.Executor``. ``worker_pool(2)`` is a pool of two local
# processes (each with a single BLAS thread); without an executor the points
# run one after the other in this process. The result is a pandas table with
# one row per point and strategy: every check's status and value and every
# metric.
#
# The built-in's own sweep has 8 points (4 weights × 2 sample times:
# ``points in the file's sweep: 8``); the short mode of these tutorials runs
# two of them, R = 0.05 and 1 per kN² at T = 0.05 s.
#
# The code runs under ``if __name__ == "__main__":``. A process pool starts
# fresh Python processes that import this script to find what it defines;
# the guard keeps them from running the sweep again themselves. Any script
# that uses ``worker_pool`` or ``trainctl.run.pool`` needs it.

import os
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import trainctl
from trainctl.run.pool import worker_pool
from trainctl.sweep import SweepDefinition, dask_executor, sweep_scenario

SHORT = os.environ.get("TRAINCTL_TUTORIAL_SHORT") == "1"
NAME = "crh2-dmpc-convergence-sweep"
AXES = ["controller.r_per_kn2=0.05,1", "model.sample_time=0.05"] if SHORT else []

if __name__ == "__main__":
    base = trainctl.load_scenario(NAME)
    print("the file's sweep:", [(axis.key, axis.values) for axis in base.sweep.axes])
    print("points in the file's sweep:", SweepDefinition.of(base).n_points)
    workdir = Path(tempfile.mkdtemp(prefix="trainctl-sweep-"))
    with worker_pool(2) as pool:
        local = sweep_scenario(NAME, workdir / "local", axes=AXES, executor=pool)
    columns = ["controller.r_per_kn2", "model.sample_time", "check.ndmpc_convergence.value",
               "metric.converged", "metric.iteration_limit_steps"]
    print(local[columns].to_string(index=False))

# %%
# What the table says
# -------------------
#
# At T = 0.05 s, R = 0.05 per kN² is below the threshold:
# ``rho(D0) at R = 0.05, T = 0.05 s: 1.0395`` and the simulated iteration
# stops at its limit (``converged: False``), while R = 1 per kN² gives
# ``rho(D0) at R = 1, T = 0.05 s: 0.2201`` and every step converges
# (``converged: True``). The closed-form test and the simulation agree on
# every point: ``certificate agrees with the simulation at every point: True``.


def row(frame, r, t):
    """The table row of the point (R, T)."""
    hit = frame[(frame["controller.r_per_kn2"] == r) & (frame["model.sample_time"] == t)]
    return hit.iloc[0]


if __name__ == "__main__":
    for r in (0.05, 1.0):
        point = row(local, r, 0.05)
        print(f"rho(D0) at R = {r:g}, T = 0.05 s: {point['check.ndmpc_convergence.value']:.4f}")
        print(f"  converged: {bool(point['metric.converged'])}")
    agree = all((v < 1) == bool(c) for v, c in zip(local["check.ndmpc_convergence.value"],
                                                  local["metric.converged"], strict=True))
    print(f"certificate agrees with the simulation at every point: {agree}")

# %%
# On a Dask cluster
# -----------------
#
# ``dask_executor(address)`` connects to a running Dask scheduler, here a
# ``distributed.LocalCluster`` of two workers started by the script (on a
# real cluster, the address of its scheduler, e.g. ``tcp://10.0.0.5:8786``;
# the command line takes ``--scheduler``). The same points give the same
# table: ``Dask table equals local table: True``.

if __name__ == "__main__":
    import distributed  # optional dependency: pip install 'trainctl-toolbox[dask]'

    # ":0": the scheduler's web server on any free port (None would take 8787, and warn
    # when another cluster on this machine has it)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as cluster:
        with dask_executor(cluster.scheduler_address) as executor:
            remote = sweep_scenario(NAME, workdir / "dask", axes=AXES, executor=executor)
    same = remote[columns].reset_index(drop=True).equals(local[columns].reset_index(drop=True))
    print(f"Dask table equals local table: {same}")

    fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
    for t, group in local.groupby("model.sample_time"):
        ax.semilogx(group["controller.r_per_kn2"], group["check.ndmpc_convergence.value"], "o-",
                    label=f"T = {t:g} s")
    ax.axhline(1.0, color="k", lw=0.8)
    ax.set_xlabel("input weight R [per kN²]")
    ax.set_ylabel("ρ(D0) [-]")
    ax.legend()
    plt.show()
    shutil.rmtree(workdir)  # the two stores: rows.parquet and each point's arrays
