# Process pools for independent simulations (strategies, scenarios, later Monte-Carlo sweeps).
"""Run independent simulations on several processes.

Simulations of different strategies (and scenarios) share nothing, so they can
run side by side. Every function here takes any :class:`concurrent.futures.Executor`:
:func:`process_pool` makes a local one; a Dask cluster's
``distributed.Client.get_executor()`` fits the same slot, since the submitted
callables (:func:`trainctl.run.analysis.simulate_strategy`) and their arguments (frozen
scenario dataclasses) pickle.

On Linux the workers are forked from this process when the pool is made
(:func:`process_pool`), with everything it has imported: a pool of two
starts in tens of milliseconds. Elsewhere they fork from a ``forkserver`` that
imports trainctl first (about 2.5 s of CPU, python-control and SciPy's
signal and stats modules most of it) and each worker then imports what its
first task needs (CVXPY: another 0.5 s each); on a 2-core machine that
start-up alone cost as much as a sweep of four one-second points, whence
``-j 2`` ran 1.06 times as fast as ``-j 1`` (``benchmarks/sweep.py``).
Workers run their BLAS and OpenMP libraries on one thread, ignore SIGINT so
that Ctrl-C reaches only the main process, which cancels the pool, and die
with it.

Examples
--------
>>> from trainctl.scenario import load_scenario
>>> estimated_steps(load_scenario("crh2-dmpc"))
180
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import warnings
from collections.abc import Iterable, Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from multiprocessing.connection import Connection
from multiprocessing.context import BaseContext
from typing import TYPE_CHECKING

from trainctl.run._signals import at_forced_stop

if TYPE_CHECKING:
    from trainctl.scenario import Scenario

__all__ = [
    "FORKSERVER_MIN_SECONDS", "PARALLEL_MIN_SECONDS", "available_cpus", "estimated_seconds",
    "estimated_steps", "pool_size", "process_pool",
    "single_threaded_blas", "terminate_workers", "want_pool", "worker_pool",
]

_LIVE: set[Executor] = set()
"""Pools of :func:`worker_pool` that are running (for :func:`terminate_workers`)."""

PARALLEL_MIN_SECONDS = 1.0
"""Estimated seconds of simulation (summed over a run's simulations) from which a pool of
forked workers (Linux) pays off [s].

The estimate is the budget's (:func:`estimated_seconds`), at each strategy's control
interval. A pool of two forked workers starts in tens of milliseconds and each worker's
first task costs nothing extra, so a run of a second or more finishes sooner on two
cores."""

FORKSERVER_MIN_SECONDS = 10.0
""":data:`PARALLEL_MIN_SECONDS` where workers start from a forkserver (not Linux) [s]: the
forkserver's import of trainctl and each worker's first imports cost about 3 s of CPU."""


def available_cpus() -> int:
    """CPUs this process may run on (``os.sched_getaffinity`` where available).

    Returns
    -------
    int
        The number of usable CPUs, at least 1.

    Examples
    --------
    The count depends on the machine, but it is at least one and never more
    than the CPUs the operating system reports:

    >>> import os
    >>> n = available_cpus()
    >>> 1 <= n <= (os.cpu_count() or 1)
    True
    """
    counter = getattr(os, "process_cpu_count", None)  # Python >= 3.13: affinity-aware
    if counter is not None:
        return max(1, counter() or 1)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def pool_size(jobs: int, tasks: int) -> int:
    """Worker processes for ``tasks`` independent tasks when ``jobs`` are asked for.

    At most ``jobs``, the number of tasks and the usable CPUs
    (:func:`available_cpus`): more workers than cores only compete for them,
    and each costs a process and its memory. A single worker is no better
    than the main process, so 1 becomes 0.

    Parameters
    ----------
    jobs : int
        Requested workers (``--jobs``).
    tasks : int
        Independent tasks to run.

    Returns
    -------
    int
        0 to run in the main process, else the pool size (>= 2).

    Examples
    --------
    >>> cpus = available_cpus()
    >>> pool_size(10_000, 3) == (min(3, cpus) if cpus > 1 else 0)
    True
    >>> pool_size(1, 100), pool_size(8, 1)
    (0, 0)
    >>> pool_size(10_000, 10_000) <= cpus
    True
    """
    workers = min(int(jobs), int(tasks), available_cpus())
    return workers if workers > 1 else 0


def estimated_steps(scenario: Scenario) -> int:
    """Controller steps of all of a scenario's simulations (0 without ``[simulation]``).

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario.

    Returns
    -------
    int
        ``n_steps × number of runs`` (:func:`simulation_runs`): the budget's
        count (:attr:`trainctl.run.budget.RunEstimate.controller_steps`).

    Examples
    --------
    ``crh2-dmpc`` simulates 1200 s at a 20 s sample time, 60 steps, for each
    of its 3 strategies: 60 × 3 = 180 steps.

    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> scenario.simulation.duration, scenario.model.sample_time, scenario.simulation.strategies
    (1200.0, 20.0, ('centralised', 'decentralised', 'ndmpc'))
    >>> estimated_steps(scenario)
    180
    >>> estimated_steps(scenario.replace("simulation.duration", 600.0))  # 30 steps × 3
    90
    """
    from trainctl.run.budget import estimate_run

    return estimate_run(scenario).controller_steps


def estimated_seconds(scenario: Scenario) -> float:
    """Estimated seconds of a scenario's simulations, one after the other.

    The budget's :attr:`~trainctl.run.budget.RunEstimate.simulation_seconds`, each
    strategy priced at its control interval.

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Returns
    -------
    float
        Seconds [s]; 0 without ``[simulation]``.

    Examples
    --------
    ``crh2-dmpc``'s 180 controller steps are MPC steps (QPs over a horizon of 4 samples),
    estimated at seconds:

    >>> from trainctl.scenario import load_scenario
    >>> estimated_seconds(load_scenario("crh2-dmpc")) > PARALLEL_MIN_SECONDS
    True
    >>> estimated_seconds(load_scenario("crh2-dmpc").replace("simulation", None))
    0.0
    """
    from trainctl.run.budget import estimate_run

    return estimate_run(scenario).simulation_seconds


def simulation_runs(scenario: Scenario) -> int:
    """Closed-loop runs of a scenario: its strategies, each ``repetitions`` times, plus
    the baseline-network runs (:mod:`trainctl.run.repetitions`); 0 without ``[simulation]``."""
    from trainctl.run.repetitions import planned_runs

    sim = scenario.simulation
    if sim is None:
        return 0
    return len(sim.strategies) + len(planned_runs(scenario))


def want_pool(scenarios: Iterable[Scenario], jobs: int | None) -> int:
    """How many worker processes to use for these scenarios' simulations.

    Parameters
    ----------
    scenarios : iterable of Scenario
        The scenarios to simulate.
    jobs : int or None
        Requested workers; None chooses: the available CPUs when the
        simulations are estimated at :data:`PARALLEL_MIN_SECONDS` or more
        (:func:`estimated_seconds`; :data:`FORKSERVER_MIN_SECONDS` where the
        workers start from a forkserver), else 0.

    Returns
    -------
    int
        0 to simulate in the main process, else the pool size (never more
        than the number of simulations nor the usable CPUs, :func:`pool_size`).

    Examples
    --------
    ``crh2-dmpc`` has 3 simulations estimated at seconds, so by default they
    run on every available CPU (at most 3); the convergence sweep's single
    N-DMPC run (one task, estimated under a second) runs in the main
    process; an explicit request is capped at the number of simulations and
    of CPUs:

    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> want_pool([scenario], None) == pool_size(available_cpus(), 3)
    True
    >>> short = load_scenario("crh2-dmpc-convergence-sweep")
    >>> estimated_seconds(short) < PARALLEL_MIN_SECONDS, want_pool([short], None)
    (True, 0)
    >>> want_pool([scenario], 1)
    0
    >>> want_pool([scenario], 4) == pool_size(4, 3)
    True
    >>> want_pool([scenario, scenario], 10_000) == pool_size(10_000, 6)  # 2 × 3 simulations
    True
    """
    scenarios = list(scenarios)
    tasks = sum(simulation_runs(s) for s in scenarios)
    if tasks <= 1 or jobs == 1 or jobs == 0:
        return 0
    if jobs is None:
        least = PARALLEL_MIN_SECONDS if _fork_context() is not None else FORKSERVER_MIN_SECONDS
        if sum(estimated_seconds(s) for s in scenarios) < least:
            return 0
        jobs = available_cpus()
    return pool_size(jobs, tasks)


def _init_worker(lifeline: Connection | None = None, forked: bool = False,
                 parent_is_thread: bool = False) -> None:
    """Workers ignore SIGINT (the main process cancels the pool), print nothing to stdout,
    run their BLAS single-threaded and die with the main process (:func:`_die_with_parent`).

    A ``forked`` worker (a copy of the main process) first drops what it inherited of the
    main process's signal handling: the handlers of :func:`trainctl.run._signals.signal_guard`
    (SIGTERM must end a worker, not unwind it) and its wakeup file descriptor (a signal to
    the worker would otherwise be heard by the main process's watchdog).
    """
    from trainctl.run._signals import silence_c_stdout

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if forked:
        for signum in (signal.SIGTERM, getattr(signal, "SIGHUP", None), signal.SIGALRM):
            if signum is not None:
                signal.signal(signum, signal.SIG_DFL)
        with contextlib.suppress(ValueError):  # only possible in the main thread
            signal.set_wakeup_fd(-1)
        _LIVE.clear()  # the main process's pools: not this worker's to terminate
        for name in WORKER_THREAD_VARIABLES:  # for libraries loaded from now on
            os.environ.setdefault(name, "1")
        single_threaded_blas()
    silence_c_stdout()
    _die_with_parent(lifeline, prctl=not parent_is_thread)


_PR_SET_PDEATHSIG = 1
"""``prctl`` option: the signal a process gets when its parent dies (Linux)."""


def _die_with_parent(lifeline: Connection | None, prctl: bool = True) -> None:
    """End this worker when the process that made its pool dies, however it dies.

    A worker's parent is the forkserver, not the main process, and it blocks
    reading a task queue whose write end the workers hold too: after a
    ``kill -9`` of the main process it waited forever, and kept the
    forkserver (whose "alive" pipe every worker holds) and the resource
    tracker alive with it, all holding the terminal's stdout. Two guards:

    - the **lifeline**, the read end of a pipe whose write end only the main
      process holds (:func:`process_pool`): a daemon thread reads it, and
      end of file (the main process gone, by any signal, or its pool shut
      down) ends the worker at once (``os._exit``), whatever its main thread
      is doing (a long C call included). Any POSIX system.
    - on Linux, ``prctl(PR_SET_PDEATHSIG, SIGKILL)``: the worker is killed
      when its own parent (the main process, or the forkserver) dies. Not
      when ``prctl`` is False: a worker forked from a thread other than the
      main thread would be killed when that *thread* ends (the kernel's
      "parent" of a forked process is the thread that forked it).

    With the workers gone, a forkserver sees the end of its "alive" pipe
    and exits, and the resource tracker with it.
    """
    if prctl and sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError, TypeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if lifeline is None:
        return

    def watch() -> None:
        with contextlib.suppress(EOFError, OSError):
            while True:
                lifeline.recv_bytes()  # the parent never writes: only EOF comes
        os._exit(1)

    threading.Thread(target=watch, name="trainctl-lifeline", daemon=True).start()


WORKER_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Thread-count variables of the BLAS and OpenMP libraries, set to 1 for pool workers
(unless set already): the workers are as many as the cores, so threads inside each would
only compete for them (Dask's workers do the same)."""


@contextlib.contextmanager
def _single_threaded_libraries() -> Iterator[None]:
    """Set :data:`WORKER_THREAD_VARIABLES` to 1 where unset, for processes started inside."""
    unset = [name for name in WORKER_THREAD_VARIABLES if name not in os.environ]
    for name in unset:
        os.environ[name] = "1"
    try:
        yield
    finally:
        for name in unset:
            os.environ.pop(name, None)


_LIFELINES: set[Connection] = set()
"""Write ends of the lifelines of this process's pools: a forked worker closes its copies
(:func:`_forget_lifelines`), or a pool's workers would outlive the main process for as
long as the workers of a later pool (which inherit them) live."""


def _forget_lifelines() -> None:
    """In a forked child: close the inherited write ends of every pool's lifeline."""
    for writer in list(_LIFELINES):
        with contextlib.suppress(OSError):
            writer.close()
    _LIFELINES.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_lifelines)


_BLAS_THREAD_SETTERS = (
    "openblas_set_num_threads", "openblas_set_num_threads64_",
    "scipy_openblas_set_num_threads", "scipy_openblas_set_num_threads64_",
    "MKL_Set_Num_Threads", "omp_set_num_threads",
)
"""Functions that set a loaded BLAS or OpenMP runtime's thread count (OpenBLAS, including the
``scipy_openblas`` builds that NumPy, SciPy and Slycot each bundle, MKL, OpenMP)."""

_BLAS_LIBRARY_NAMES = ("openblas", "mkl_rt", "libgomp", "libomp", "libiomp")


def single_threaded_blas() -> list[str]:
    """Set every BLAS and OpenMP library loaded in this process to one thread.

    The thread-count variables (:data:`WORKER_THREAD_VARIABLES`) are read
    once, when a library loads: a worker forked from the main process
    inherits its libraries configured for every core (two threads each of
    NumPy's, SciPy's and Slycot's OpenBLAS on 2 cores), so their own
    setters are called. This is what ``threadpoolctl.threadpool_limits(1)``
    does, in a few lines: threadpoolctl is not a dependency of trainctl.

    Returns
    -------
    list of str
        The files of the libraries set (Linux: from ``/proc/self/maps``; empty
        elsewhere, where workers start from a forkserver with the variables set).

    Examples
    --------
    >>> paths = single_threaded_blas()
    >>> all(isinstance(path, str) for path in paths)
    True
    """
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as maps:
            paths = sorted({fields[5].strip() for fields in (line.split(maxsplit=5)
                                                            for line in maps)
                            if len(fields) == 6 and any(
                                part in os.path.basename(fields[5])
                                for part in _BLAS_LIBRARY_NAMES)})
    except OSError:
        return []
    done = []
    for path in paths:
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        setters = [getattr(library, name, None) for name in _BLAS_THREAD_SETTERS]
        for setter in setters:
            if setter is not None:
                setter(1)
        if any(setter is not None for setter in setters):
            done.append(path)
    return done


def _fork_context() -> BaseContext | None:
    """``fork`` on Linux (workers copy the main process, its imports included), else None."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return multiprocessing.get_context("fork")
    except ValueError:  # pragma: no cover - a Linux without fork
        return None


def process_pool(workers: int) -> Executor:
    """A local process pool whose workers have trainctl imported.

    On Linux the workers are forked from this process at once, before this
    returns (so before any thread the caller starts next, and before the
    pool's own threads): they start with every module this process has
    imported, in tens of milliseconds. Elsewhere they fork from a forkserver that
    imports :mod:`trainctl.run.analysis` first.

    The workers' BLAS and OpenMP libraries run single-threaded (one thread
    per worker, :data:`WORKER_THREAD_VARIABLES`, unless those variables are
    set; :func:`single_threaded_blas`), so that ``workers`` processes on as
    many cores do not oversubscribe them.

    Parameters
    ----------
    workers : int
        Number of worker processes, >= 1.

    Returns
    -------
    concurrent.futures.ProcessPoolExecutor
        Use it as a context manager.

    Examples
    --------
    >>> from trainctl.run.pool import process_pool
    >>> with process_pool(2) as pool:
    ...     print(list(pool.map(abs, [-3, 4, -5])))
    [3, 4, 5]
    """
    context: BaseContext | None = _fork_context()
    forked = context is not None
    if context is None:
        try:
            forkserver = multiprocessing.get_context("forkserver")
            forkserver.set_forkserver_preload(["trainctl.run.analysis"])
            from multiprocessing import forkserver as _server

            with _single_threaded_libraries():
                _server.ensure_running()  # the workers fork from it, with its environment
            context = forkserver
        except ValueError:  # pragma: no cover - platforms without forkserver
            context = multiprocessing.get_context("spawn")
    # The lifeline: the workers get its read end, only this process holds the write end
    # (non-inheritable, never passed to a child, closed in forked ones: _forget_lifelines);
    # it closes when the pool is shut down, or when this process dies in any way, and the
    # workers then end (_die_with_parent).
    reader, writer = context.Pipe(duplex=False)
    _LIFELINES.add(writer)
    in_thread = threading.current_thread() is not threading.main_thread()
    pool = _LifelinePool(max_workers=workers, mp_context=context, initializer=_init_worker,
                         initargs=(reader, forked, forked and in_thread))
    pool._trainctl_lifeline = writer
    pool._trainctl_lifeline_reader = reader
    if forked:
        # The first submission forks every worker (ProcessPoolExecutor does so with "fork",
        # before its manager thread starts). Python >= 3.12 warns about any fork of a process
        # with threads; here the others are BLAS threads (which OpenBLAS stops around a fork)
        # and, in the command, the signal watchdog blocked in a read: no lock is held.
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", category=DeprecationWarning,
                                    message=r".*multi-threaded.*fork")
            pool.submit(int)
    return pool


class _LifelinePool(ProcessPoolExecutor):
    """A process pool that holds the write end of its workers' lifeline (see
    :func:`_die_with_parent`) and closes it once the workers are done."""

    _trainctl_lifeline: Connection | None = None
    _trainctl_lifeline_reader: Connection | None = None

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        super().shutdown(wait=wait, cancel_futures=cancel_futures)
        reader, self._trainctl_lifeline_reader = self._trainctl_lifeline_reader, None
        if reader is not None:
            reader.close()  # this process's copy of the read end (the workers have theirs)
        if wait and self._trainctl_lifeline is not None:
            _LIFELINES.discard(self._trainctl_lifeline)
            self._trainctl_lifeline.close()  # the workers have exited: nothing to end
            self._trainctl_lifeline = None


@contextlib.contextmanager
def worker_pool(workers: int) -> Iterator[Executor | None]:
    """A :func:`process_pool` of ``workers`` (None for 0) that is torn down at once on error.

    On an exception (Ctrl-C included) queued simulations are cancelled and
    running workers terminated instead of waited for.

    Parameters
    ----------
    workers : int
        Pool size; 0 yields None (run in this process).

    Yields
    ------
    concurrent.futures.Executor or None
        The pool.

    Examples
    --------
    Zero workers starts no process and yields None, the caller's cue to
    simulate in the main process:

    >>> with worker_pool(0) as pool:
    ...     print(pool)
    None
    """
    if workers <= 0:
        yield None
        return
    pool = process_pool(workers)
    _LIVE.add(pool)
    try:
        yield pool
    except BaseException as exc:
        _terminate(pool, ending=isinstance(exc, KeyboardInterrupt))
        raise
    else:
        pool.shutdown(wait=True)
    finally:
        _LIVE.discard(pool)


def _terminate(pool: Executor, *, ending: bool = False) -> None:
    """Cancel queued work and terminate the workers at once (SIGTERM, then SIGKILL).

    ``ending`` (an interrupt: the process is about to end) also ends the forkserver,
    which may still be starting (importing trainctl) with workers to fork: they would
    start after this process freed their queues (a FileNotFoundError traceback each)
    and its exit would wait for them. The next pool starts a new forkserver.
    """
    # ProcessPoolExecutor keeps its workers in _processes (no public handle).
    procs = list((getattr(pool, "_processes", None) or {}).values())
    # Workers first: a worker still starting (unpickling its queues) when shutdown frees
    # the queues' semaphores prints a FileNotFoundError traceback; SIGTERM ends it silently
    # (seen when Ctrl-C came during a slow pool start on a loaded machine).
    for process in procs:
        process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)
    if ending:
        _end_forkserver()
    for process in procs:
        process.join(timeout=0.3)
        if process.is_alive():
            process.kill()


def _end_forkserver() -> None:
    """Kill this process's forkserver, if it runs (``multiprocessing`` keeps its PID)."""
    from multiprocessing import forkserver

    server = getattr(forkserver, "_forkserver", None)
    pid = getattr(server, "_forkserver_pid", None)
    if pid:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def terminate_workers() -> None:
    """Terminate the workers of every running :func:`worker_pool` (a process about to end).

    Examples
    --------
    With no pool running (``worker_pool(0)`` starts none) there is nothing
    to terminate, and the call returns at once:

    >>> with worker_pool(0) as pool:
    ...     terminate_workers()
    >>> pool is None
    True
    """
    for pool in list(_LIVE):
        _terminate(pool, ending=True)


at_forced_stop(terminate_workers)  # the watchdog of trainctl.run._signals ends the workers
