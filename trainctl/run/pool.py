# Process pools for independent simulations (strategies, scenarios, later Monte-Carlo sweeps).
"""Run independent simulations on several processes.

Simulations of different strategies (and scenarios) share nothing, so they can
run side by side. Every function here takes any :class:`concurrent.futures.Executor`:
:func:`process_pool` makes a local one; a Dask cluster's
``distributed.Client.get_executor()`` fits the same slot, since the submitted
callables (:func:`trainctl.run.analysis.simulate_strategy`) and their arguments (frozen
scenario dataclasses) pickle.

Workers start from a ``forkserver`` that has imported trainctl once, so a
worker costs a fork rather than a fresh interpreter; workers ignore SIGINT so
that Ctrl-C reaches only the main process, which cancels the pool.

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
from collections.abc import Iterable, Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from multiprocessing.connection import Connection
from multiprocessing.context import BaseContext
from typing import TYPE_CHECKING

from trainctl.run._signals import at_forced_stop

if TYPE_CHECKING:
    from trainctl.scenario import Scenario

__all__ = [
    "PARALLEL_MIN_STEPS", "available_cpus", "estimated_steps", "pool_size", "process_pool",
    "terminate_workers", "want_pool", "worker_pool",
]

_LIVE: set[Executor] = set()
"""Pools of :func:`worker_pool` that are running (for :func:`terminate_workers`)."""

PARALLEL_MIN_STEPS = 5000
"""Simulated controller steps (summed over strategies) from which a pool pays off.

Starting the pool costs about a second; a controller step costs 0.2–2 ms, so
below a few thousand steps the simulations finish sooner in the main process.
"""


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
        simulations total at least :data:`PARALLEL_MIN_STEPS` steps, else 0.

    Returns
    -------
    int
        0 to simulate in the main process, else the pool size (never more
        than the number of simulations nor the usable CPUs, :func:`pool_size`).

    Examples
    --------
    ``crh2-dmpc`` has 3 simulations of 60 steps each (180 steps, far below
    :data:`PARALLEL_MIN_STEPS`), so by default it runs in the main process;
    an explicit request is capped at the number of simulations and of CPUs:

    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> want_pool([scenario], None), want_pool([scenario], 1)
    (0, 0)
    >>> want_pool([scenario], 4) == pool_size(4, 3)
    True
    >>> want_pool([scenario, scenario], 10_000) == pool_size(10_000, 6)  # 2 × 3 simulations
    True

    Thirty copies total 30 × 180 = 5400 >= 5000 steps, so the default uses
    every available CPU (at most the 90 simulations):

    >>> want_pool([scenario] * 30, None) == pool_size(available_cpus(), 90)
    True
    """
    scenarios = list(scenarios)
    tasks = sum(simulation_runs(s) for s in scenarios)
    if tasks <= 1 or jobs == 1 or jobs == 0:
        return 0
    if jobs is None:
        if sum(estimated_steps(s) for s in scenarios) < PARALLEL_MIN_STEPS:
            return 0
        jobs = available_cpus()
    return pool_size(jobs, tasks)


def _init_worker(lifeline: Connection | None = None) -> None:
    """Workers ignore SIGINT (the main process cancels the pool), print nothing to stdout
    and die with the main process (:func:`_die_with_parent`)."""
    from trainctl.run._signals import silence_c_stdout

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    silence_c_stdout()
    _die_with_parent(lifeline)


_PR_SET_PDEATHSIG = 1
"""``prctl`` option: the signal a process gets when its parent dies (Linux)."""


def _die_with_parent(lifeline: Connection | None) -> None:
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
      when its own parent (the forkserver) dies.

    With the workers gone, the forkserver sees the end of its "alive" pipe
    and exits, and the resource tracker with it.
    """
    if sys.platform.startswith("linux"):
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


def process_pool(workers: int) -> Executor:
    """A local process pool whose workers have trainctl imported.

    The workers' BLAS and OpenMP libraries run single-threaded (one thread
    per worker, :data:`WORKER_THREAD_VARIABLES`, unless those variables are
    set), so that ``workers`` processes on as many cores do not oversubscribe
    them.

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
    context: BaseContext
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
    # (non-inheritable, never passed to a child); it closes when the pool is shut down,
    # or when this process dies in any way, and the workers then end (_die_with_parent).
    reader, writer = context.Pipe(duplex=False)
    pool = _LifelinePool(max_workers=workers, mp_context=context, initializer=_init_worker,
                         initargs=(reader,))
    pool._trainctl_lifeline = writer
    pool._trainctl_lifeline_reader = reader
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
