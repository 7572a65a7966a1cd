# The local process pool of sweeps: warm workers that really run side by side, single-threaded.
"""What makes ``trainctl sweep -j 2`` pay (trainctl issue 27).

- the workers start with the main process's modules (forked on Linux): a
  point in a worker imports nothing of trainctl first;
- two tasks run at the same time in the two workers;
- the workers' BLAS libraries run one thread each, read back through the
  libraries' own getters (the pool sets them through their setters);
- a worker leaves the main process's signal handling (the guard's handlers
  and the watchdog's wakeup descriptor) and the store's lock behind;
- a sweep run serially and on the pool stores the same table, bit for bit.
"""

from __future__ import annotations

import ctypes
import fcntl
import os
import signal
import sys
import time
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from trainctl.run.pool import available_cpus, process_pool, worker_pool

linux = pytest.mark.skipif(not sys.platform.startswith("linux"),
                           reason="workers fork from the main process on Linux only")

_GETTERS = ("openblas_get_num_threads", "openblas_get_num_threads64_",
            "scipy_openblas_get_num_threads", "scipy_openblas_get_num_threads64_")


def blas_threads() -> dict[str, int]:
    """Each loaded OpenBLAS library's thread count, by its getter."""
    counts = {}
    with open("/proc/self/maps", encoding="utf-8") as maps:
        paths = {f[5].strip() for f in (line.split(maxsplit=5) for line in maps)
                 if len(f) == 6 and "openblas" in os.path.basename(f[5])}
    for path in sorted(paths):
        library = ctypes.CDLL(path)
        getter = next((getattr(library, g) for g in _GETTERS if hasattr(library, g)), None)
        if getter is not None:
            counts[os.path.basename(path)] = int(getter())
    return counts


def modules() -> set[str]:
    return set(sys.modules)


def sleeper(seconds: float) -> tuple[int, float, float]:
    start = time.monotonic()
    time.sleep(seconds)
    return os.getpid(), start, time.monotonic()


def openblas_variable() -> str | None:
    return os.environ.get("OPENBLAS_NUM_THREADS")


def signal_state() -> tuple[Any, Any, int]:
    wakeup = signal.set_wakeup_fd(-1)
    return signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT), wakeup


@linux
def test_workers_start_with_the_main_process_modules() -> None:
    """A worker has every module this process had when the pool was made."""
    import trainctl.sweep.runner  # noqa: F401 - imported here, present there

    mine = modules()
    with worker_pool(2) as pool:
        assert pool is not None
        theirs = [pool.submit(modules).result(timeout=60) for _ in range(2)]
    assert all(not mine - t for t in theirs), sorted(mine - theirs[0])[:10]


def test_two_tasks_run_side_by_side() -> None:
    """The two workers run two tasks at the same time (distinct processes, overlapping)."""
    with worker_pool(2) as pool:
        assert pool is not None
        pool.submit(int).result(timeout=60)  # both workers up
        first, second = (pool.submit(sleeper, 1.0) for _ in range(2))
        (pid_a, start_a, end_a), (pid_b, start_b, end_b) = first.result(60), second.result(60)
    assert pid_a != pid_b != os.getpid()
    assert start_b < end_a and start_a < end_b  # the intervals overlap


@linux
def test_workers_blas_single_threaded() -> None:
    """Every OpenBLAS in a worker runs one thread; this process keeps its own count."""
    import scipy.linalg  # noqa: F401 - SciPy's OpenBLAS loaded too

    mine = blas_threads()
    assert mine, "no OpenBLAS library found"
    with process_pool(2) as pool:
        theirs = pool.submit(blas_threads).result(timeout=60)
    assert theirs == dict.fromkeys(mine, 1)
    assert blas_threads() == mine


def test_workers_leave_the_signal_guard_behind() -> None:
    """Made inside a signal guard (its SIGTERM handler, its watchdog's wakeup fd), the
    workers take SIGTERM's default action, ignore SIGINT and write no wakeup byte."""
    from trainctl.run._signals import signal_guard

    with signal_guard():
        guarded = signal.set_wakeup_fd(-1)
        signal.set_wakeup_fd(guarded, warn_on_full_buffer=False)
        assert guarded != -1 and signal.getsignal(signal.SIGTERM) != signal.SIG_DFL
        with worker_pool(2) as pool:
            assert pool is not None
            term, interrupt, wakeup = pool.submit(signal_state).result(timeout=60)
    assert term == signal.SIG_DFL
    assert interrupt == signal.SIG_IGN
    assert wakeup == -1


def test_sigterm_ends_a_worker_at_once() -> None:
    """SIGTERM to a busy worker made inside a signal guard ends it (it is not unwound)."""
    from trainctl.run._signals import signal_guard

    with signal_guard(), worker_pool(2) as pool:
        assert pool is not None
        pid = pool.submit(os.getpid).result(timeout=60)
        busy = [pool.submit(time.sleep, 30) for _ in range(2)]
        time.sleep(0.3)
        os.kill(pid, signal.SIGTERM)
        with pytest.raises(BrokenProcessPool):  # unwound, it would have raised Interrupted
            busy[0].result(timeout=20)


def lmi_gamma(order: int) -> float:
    """The bounded-real (H∞) level of a stable random system, an SDP Clarabel solves."""
    from trainctl.analysis.hinf import bounded_real_gamma

    rng = np.random.default_rng(order)
    A = rng.standard_normal((order, order))
    A -= (np.max(np.linalg.eigvals(A).real) + 1.0) * np.eye(order)
    B, C = rng.standard_normal((order, 2)), rng.standard_normal((2, order))
    return float(bounded_real_gamma(A, B, C, np.zeros((2, 2))).gamma)


@linux
def test_a_worker_solves_an_lmi_after_the_main_process_did() -> None:
    """Clarabel's thread pool, started here by a solve, is copied into a forked worker
    without its threads: a multi-threaded solve there waited for them forever. trainctl
    solves on one thread (``CLARABEL_THREADS``), so the worker finishes, with the same
    level as this process."""
    mine = lmi_gamma(30)
    with worker_pool(2) as pool:
        assert pool is not None
        theirs = pool.submit(lmi_gamma, 30).result(timeout=60)
    assert theirs == mine


@linux
def test_workers_do_not_hold_the_store_lock(tmp_path: Path) -> None:
    """A store closed while a pool made after its opening lives is free for another writer."""
    from trainctl.sweep.manifest import LOCK, _lock, _unlock

    _lock(tmp_path)
    with worker_pool(2) as pool:
        assert pool is not None
        # Both workers past their start (which closes their copies of the lock): a task done
        # by each. One finished task proves only one worker started; the other, slow under
        # load, still held its inherited copy for a moment. Pairs of overlapping tasks until
        # both have answered (a slow starter may leave both of one pair to the other).
        pids: set[int] = set()
        deadline = time.monotonic() + 60
        while len(pids) < 2 and time.monotonic() < deadline:
            pids |= {f.result(timeout=60)[0] for f in [pool.submit(sleeper, 0.2)
                                                       for _ in range(2)]}
        assert len(pids) == 2
        _unlock(tmp_path)
        fd = os.open(tmp_path / LOCK, os.O_RDWR)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # OSError if a worker held it
            except OSError:
                pytest.fail(f"the store's lock is held: {lock_holders(tmp_path / LOCK)}")
        finally:
            os.close(fd)


def lock_holders(path: Path) -> list[str]:
    """The processes /proc/locks names as holding a lock on ``path``, with their command
    lines and parents."""
    inode = os.stat(path).st_ino
    found = []
    with open("/proc/locks", encoding="ascii") as locks:
        for line in locks:
            fields = line.split()
            pid, where = fields[4], fields[5]
            if where.rsplit(":", 1)[-1] == str(inode):
                try:
                    cmd = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
                    status = Path(f"/proc/{pid}/status").read_text()
                    ppid = next(x.split()[1] for x in status.splitlines()
                                if x.startswith("PPid"))
                except OSError:
                    cmd, ppid = b"?", "?"
                found.append(f"PID {pid} (parent {ppid}, this {os.getpid()}): "
                             f"{cmd.decode(errors='replace')[:200]}")
    return found


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_serial_and_pool_sweeps_identical(tmp_path: Path) -> None:
    """Two points run here and on two workers: the same table bytes and the same arrays."""
    from trainctl.sweep import sweep_scenario
    from trainctl.sweep.store import SweepStore

    axes = ["controller.r_per_kn2=5,10", "simulation.duration=200.0"]
    sweep_scenario("crh2-dmpc", tmp_path / "serial", axes=axes)
    with worker_pool(2) as pool:
        sweep_scenario("crh2-dmpc", tmp_path / "pool", axes=axes, executor=pool)
    serial, pooled = (SweepStore.load(tmp_path / name) for name in ("serial", "pool"))
    table = "rows.parquet"
    assert (serial.path / table).read_bytes() == (pooled.path / table).read_bytes()
    assert serial.keys == pooled.keys and len(serial.keys) == 2
    for key in serial.keys:
        runs = sorted(p.name for p in (serial.points_dir / key / "runs").iterdir())
        assert runs == sorted(p.name for p in (pooled.points_dir / key / "runs").iterdir())
        for run in runs:
            with np.load(serial.points_dir / key / "runs" / run / "arrays.npz") as a, \
                    np.load(pooled.points_dir / key / "runs" / run / "arrays.npz") as b:
                assert a.files == b.files
                for name in a.files:
                    if "solve_time" in name:  # wall-clock
                        continue
                    np.testing.assert_array_equal(a[name], b[name], err_msg=f"{run}/{name}")


# --- when the pool is used by default (analyse, report: --jobs not given) ---------------------

two_cpus = pytest.mark.skipif(available_cpus() < 2, reason="a pool needs two usable CPUs")


@two_cpus
def test_a_second_long_run_goes_to_the_pool() -> None:
    """crh2-dmpc over 200 s (10 samples of 3 MPC strategies, about a second of CPU) is
    simulated on the pool, though it counts only 30 controller steps."""
    from trainctl.run.pool import estimated_steps, pool_size, want_pool
    from trainctl.scenario import load_scenario

    scenario = load_scenario("crh2-dmpc").replace("simulation.duration", 200.0)
    assert estimated_steps(scenario) == 30
    assert want_pool([scenario], None) == pool_size(available_cpus(), 3) >= 2


@two_cpus
def test_the_control_interval_counts() -> None:
    """heavy-haul-flocking steps one strategy every second at a 2 s sample time (1800
    sample steps): estimated at seconds, it goes to the pool."""
    from trainctl.design.stage import strategy_interval
    from trainctl.run.pool import PARALLEL_MIN_SECONDS, estimated_seconds, want_pool
    from trainctl.scenario import load_scenario

    scenario = load_scenario("heavy-haul-flocking")
    assert scenario.simulation is not None
    assert min(strategy_interval(scenario, s) for s in scenario.simulation.strategies) \
        < scenario.model.sample_time
    assert estimated_seconds(scenario) > PARALLEL_MIN_SECONDS
    assert want_pool([scenario], None) >= 2


@pytest.mark.slow
def test_forkserver_pool_still_works(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without fork (as on macOS) the workers start from a forkserver, with the thread
    variables at 1, and the default threshold is the forkserver's."""
    import trainctl.run.pool as pool_module
    from trainctl.scenario import load_scenario

    monkeypatch.setattr(pool_module, "_fork_context", lambda: None)
    with pool_module.worker_pool(2) as pool:
        assert pool is not None
        assert list(pool.map(abs, [-3, 4])) == [3, 4]
        env = pool.submit(openblas_variable).result(timeout=120)
    assert env == os.environ.get("OPENBLAS_NUM_THREADS", "1")
    scenario = load_scenario("crh2-dmpc").replace("simulation.duration", 200.0)
    assert pool_module.estimated_seconds(scenario) < pool_module.FORKSERVER_MIN_SECONDS
    assert pool_module.want_pool([scenario], None) == 0
