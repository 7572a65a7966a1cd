# Running a sweep into its store: the points still missing, on any executor, with progress.
"""Run a sweep's missing points into its store and write its table.

:func:`run_sweep` asks the store which points are missing
(:meth:`~trainctl.sweep.store.SweepStore.missing`), runs each of them once
(:func:`run_point_results`: the analysis and, unless ``simulate=False``, the
simulations, summarised like ``trainctl analyse --json`` without wall-clock
values), stores each point as soon as it finishes, and when all are done
writes the table from the store. Where the points run is an
:class:`concurrent.futures.Executor`:

- None: here, one after the other;
- a local process pool (:func:`trainctl.run.pool.worker_pool`);
- a Dask cluster: :func:`dask_executor` (``distributed.Client.get_executor``).

Every point is independent and stored under its own key, and the table is
read back from the store in point order, so the table is the same whichever
executor ran the points. Ctrl-C (or any error) cancels what is queued; the
points already stored stay, and the same call again runs only the rest.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import re
import socket
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from typing import TYPE_CHECKING, Any

from trainctl.exceptions import ScenarioError

if TYPE_CHECKING:
    from trainctl.scenario import Scenario
    from trainctl.sim.results import SimulationResult
    from trainctl.sweep.definition import Axis
    from trainctl.sweep.store import SweepStore

__all__ = ["CONNECT_TIMEOUT", "HANDSHAKE_TIMEOUT", "SCHEDULER_ENV", "check_scheduler_address",
           "dask_executor", "run_point_results", "run_sweep", "sweep_scenario",
           "scheduler_address"]

SCHEDULER_ENV = "TRAINCTL_DASK_SCHEDULER"
"""Environment variable naming the Dask scheduler when ``--scheduler`` is not given."""


def run_point_results(scenario: Scenario, simulate: bool = True, arrays: bool | str = True,
                      ) -> tuple[dict[str, Any], dict[str, SimulationResult]]:
    """One point's run: its summary and the simulation results a store keeps of it.

    Parameters
    ----------
    scenario : Scenario
        The point's validated scenario.
    simulate : bool
        Run its ``[simulation]`` strategies.
    arrays : {"dense", "sampled", "none"} or bool
        What to return of the simulations' time series (the store's
        ``arrays``, :data:`~trainctl.sweep.store.ARRAYS`): the results
        whole (``"dense"`` or True), without their between-sample arrays
        (``"sampled"``: the ``dense_*`` arrays are the sampled ones, so a
        result travels back from a worker at a small fraction of its size),
        or an empty mapping (``"none"`` or False).

    Returns
    -------
    summary : dict
        ``AnalysisRun.to_dict()`` without wall-clock values, JSON-safe.
    simulations : dict of str to SimulationResult
        Strategy → result (run 0 of each strategy).

    Examples
    --------
    The decentralised law over 120 s of the CRH2 scenario (sample time
    20 s); with ``arrays="sampled"`` the dense arrays are the sampled ones:

    >>> import trainctl
    >>> scenario = (trainctl.load_scenario("crh2-dmpc")
    ...             .replace("simulation.settle_time", 60.0)
    ...             .replace("simulation.duration", 120.0)
    ...             .replace("simulation.strategies", ["decentralised"]))
    >>> summary, sims = run_point_results(scenario, arrays="sampled")
    >>> result = sims["decentralised"]
    >>> result.time.tolist()  # s
    [0.0, 20.0, 40.0, 60.0, 80.0, 100.0, 120.0]
    >>> result.dense_time is result.time, summary["simulations"]["decentralised"]["tracking_ok"]
    (True, True)
    >>> run_point_results(scenario, simulate=False)[1]  # no simulations
    {}
    """
    import dataclasses

    from trainctl.run.analysis import run_scenario
    from trainctl.run.wall_clock import without_wall_clock

    if isinstance(arrays, bool):
        arrays = "dense" if arrays else "none"
    run = run_scenario(scenario, simulate=simulate)
    summary: dict[str, Any] = without_wall_clock(run.to_dict())
    if arrays == "none":
        return summary, {}
    if arrays == "dense":
        return summary, dict(run.simulations)
    # the between-sample arrays become the sampled ones (what a result without them loads as)
    return summary, {name: dataclasses.replace(
        result, dense_time=result.time, dense_states=result.states,
        dense_coupler_forces=result.coupler_forces, dense_reference_speed=result.reference_speed)
        for name, result in run.simulations.items()}


def sweep_scenario(scenario: str | os.PathLike[str], directory: str | os.PathLike[str], *,
                   axes: Sequence[str | Axis] = (), seeds: int | None = None,
                   executor: Executor | None = None, simulate: bool = True,
                   arrays: str = "sampled", csv: bool = False) -> Any:
    """Run a scenario's sweep into a store and return its table, in one call.

    What ``trainctl sweep SCENARIO [--set ...] [--seeds N] -o DIRECTORY``
    does, for a script or a notebook: the sweep
    (:meth:`SweepDefinition.of`), every point validated before anything
    runs, the store opened (or reopened: running the same sweep into the same
    directory again runs only the points it lacks) and the points run
    (:func:`run_sweep`).

    Parameters
    ----------
    scenario : str or path-like
        A built-in scenario's name or a scenario file.
    directory : str or path-like
        The store's directory: missing or empty, or a store of this same sweep.
    axes : sequence of str or Axis
        Axes replacing the scenario's ``[sweep]``: :class:`Axis` objects or
        ``"KEY=V1,V2,..."`` strings (:func:`parse_set`).
    seeds : int or None
        Seeds per point (None: the ``[sweep]`` section's, else 1).
    executor : concurrent.futures.Executor or None
        Where the points run (:func:`trainctl.run.pool.worker_pool`,
        :func:`dask_executor`); None: here, one after the other.
    simulate : bool
        Run each point's simulations (False: the design review only).
    arrays : {"sampled", "dense", "none"}
        What the store keeps of each simulation's time series.
    csv : bool
        Also write the table as CSV.

    Returns
    -------
    pandas.DataFrame
        One row per point and strategy (:meth:`SweepStore.table`).

    Raises
    ------
    ScenarioError
        If the scenario, an axis or a point is invalid, or there is nothing
        to sweep; nothing runs then.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     table = sweep_scenario("crh2-dmpc", tmp, axes=["controller.r_per_kn2=1,10"],
    ...                            simulate=False)
    >>> [round(v, 4) for v in table["check.ndmpc_convergence.value"]]
    [1.5849, 0.3057]
    """
    from trainctl.scenario import parse_scenario, read_scenario_text
    from trainctl.sweep.definition import SweepDefinition, parse_set, point_key
    from trainctl.sweep.store import SweepStore

    text, label = read_scenario_text(scenario)
    base = parse_scenario(text, source=label)
    sweep = SweepDefinition.of(base, [parse_set(a) if isinstance(a, str) else a for a in axes],
                               seeds=seeds)
    scenarios = sweep.validate(base)  # first: refuses a sweep too large at once
    points = sweep.points(base_seed=base.seed)
    keys = [point_key(s) for s in scenarios]
    store = SweepStore.open(directory, label=label, scenario_text=text, points=points,
                            keys=keys, swept=sweep.keys, simulate=simulate, arrays=arrays)
    try:
        return run_sweep(store, dict(zip(keys, scenarios, strict=True)), simulate=simulate,
                         executor=executor, csv=csv)
    finally:
        store.close()


def run_sweep(store: SweepStore, scenarios: Mapping[str, Scenario], *, simulate: bool = True,
              executor: Executor | None = None,
              on_point: Callable[[str], None] | None = None,
              csv: bool = False, in_flight: int = 64) -> Any:
    """Run the store's missing points, store each, then write and return the table.

    Parameters
    ----------
    store : SweepStore
        The sweep's store (:meth:`~trainctl.sweep.store.SweepStore.open`).
    scenarios : mapping of str to Scenario
        Point key → its validated scenario (every key of the store).
    simulate : bool
        Run each point's simulations.
    executor : concurrent.futures.Executor or None
        Where the points run; None here, one after the other.
    on_point : callable or None
        Called with the key of every point stored (progress).
    csv : bool
        Also write the table as CSV.
    in_flight : int
        Points submitted to ``executor`` and not yet stored, at most (keep it
        above the number of workers so that none waits).

    Returns
    -------
    pandas.DataFrame
        The table of every point, as written (:meth:`SweepStore.table`).

    Raises
    ------
    ScenarioError
        A key of the store has no scenario.

    Examples
    --------
    Both points run the first time; the second call finds them stored and
    runs none, returning the same table:

    >>> import tempfile
    >>> from trainctl.sweep.store import SweepStore
    >>> from trainctl.scenario import parse_scenario, read_scenario_text
    >>> from trainctl.sweep import SweepDefinition, parse_set, point_key
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> base = parse_scenario(text, source=label)
    >>> sweep = SweepDefinition.of(base, [parse_set("controller.r_per_kn2=1,10")])
    >>> points, scenarios = sweep.points(base_seed=base.seed), sweep.validate(base)
    >>> keys = [point_key(s) for s in scenarios]
    >>> ran = []
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     store = SweepStore.open(tmp, label=label, scenario_text=text, points=points,
    ...                             keys=keys, swept=sweep.keys, simulate=False,
    ...                             arrays="none")
    ...     table = run_sweep(store, dict(zip(keys, scenarios)), simulate=False,
    ...                       on_point=ran.append)
    ...     again = run_sweep(store, dict(zip(keys, scenarios)), simulate=False,
    ...                       on_point=ran.append)
    >>> len(ran), table["controller.r_per_kn2"].tolist(), table.equals(again)
    (2, [1, 10], True)
    """
    todo = store.missing()
    lost = [k for k in todo if k not in scenarios]
    if lost:
        raise ScenarioError(f"{store.path}: {len(lost)} points of the store have no scenario "
                            f"(first {lost[0][:12]}).")
    arrays = str(store.manifest.get("arrays", "sampled"))
    if executor is None:
        for key in todo:
            summary, sims = run_point_results(scenarios[key], simulate, arrays)
            store.write_point(key, summary, sims)
            if on_point is not None:
                on_point(key)
    else:
        # At most `in_flight` points are submitted and not yet stored: a 10 000-point sweep
        # neither pickles every scenario up front nor holds every result in memory.
        queue = iter(todo)
        futures: dict[Future[Any], str] = {}
        try:
            for key in itertools.islice(queue, max(1, int(in_flight))):
                futures[executor.submit(run_point_results, scenarios[key], simulate,
                                        arrays)] = key
            _import_table_writer()
            while futures:
                finished, _ = wait(futures, return_when=FIRST_COMPLETED)
                for future in finished:
                    key = futures.pop(future)
                    summary, sims = future.result()
                    store.write_point(key, summary, sims)
                    if on_point is not None:
                        on_point(key)
                    for nxt in itertools.islice(queue, 1):
                        futures[executor.submit(run_point_results, scenarios[nxt], simulate,
                                                arrays)] = nxt
        except BaseException:
            for future in futures:
                future.cancel()
            raise
    store.write_table(csv=csv)
    return store.read_table()


def _import_table_writer() -> None:
    """Import what writing the table takes (pandas, pyarrow's Parquet: about 0.5 s of CPU
    the first time in a process) while the first points run elsewhere, rather than after
    the last point: the table of a sweep of four one-second points on two workers was
    written half a second after its last point."""
    import pandas  # noqa: F401
    import pyarrow.parquet  # noqa: F401


def scheduler_address(given: str | None) -> str | None:
    """The Dask scheduler to use: ``given``, else :data:`SCHEDULER_ENV`, else None (local).

    Parameters
    ----------
    given : str or None
        ``--scheduler``.

    Returns
    -------
    str or None

    Examples
    --------
    >>> import os
    >>> from unittest import mock
    >>> scheduler_address("tcp://10.0.0.5:8786")
    'tcp://10.0.0.5:8786'
    >>> with mock.patch.dict(os.environ, {SCHEDULER_ENV: "tcp://10.0.0.6:8786"}):
    ...     scheduler_address(None)
    'tcp://10.0.0.6:8786'
    >>> with mock.patch.dict(os.environ, {SCHEDULER_ENV: ""}):
    ...     print(scheduler_address(None))  # local
    None
    """
    if given:
        return given
    return os.environ.get(SCHEDULER_ENV) or None


CONNECT_TIMEOUT = 5.0
"""Seconds a scheduler's port gets to accept the connection [s]."""

HANDSHAKE_TIMEOUT = 5.0
"""Seconds a scheduler gets to answer Dask's handshake once connected [s]: a port that
accepts and says nothing, or answers something else, is refused after at most this long."""

_ADDRESS = re.compile(r"(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?"
                      r"(?P<host>\[[^\]/]*\]|[^\[\]/:]*)(?::(?P<port>[^/]*))?")
_HOSTNAME = re.compile(r"[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
                       r"(?:\.[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?)*\.?")
_OTHER_SCHEMES = {
    "tls": "TLS needs a certificate and key, which trainctl sweep cannot pass; reach the "
           "scheduler over tcp:// (e.g. through an SSH tunnel), or give a "
           "distributed.Client's executor to trainctl.sweep.sweep_scenario",
    "inproc": "an in-process address is reachable only inside the process that started "
              "the cluster",
    "ucx": "UCX is not supported",
    "ws": "a websocket address is not supported",
    "wss": "a websocket address is not supported",
    "http": "that is a web address (the dashboard's?), not the scheduler's",
    "https": "that is a web address (the dashboard's?), not the scheduler's",
}


def check_scheduler_address(address: str, option: str = "--scheduler") -> tuple[str, int]:
    """Check a scheduler address's form: ``tcp://HOST:PORT`` (or ``HOST:PORT``).

    Parameters
    ----------
    address : str
        The address given.
    option : str
        Where it came from, named in the error (``--scheduler`` or
        :data:`SCHEDULER_ENV`).

    Returns
    -------
    (str, int)
        Host (without an IPv6 address's brackets) and port.

    Raises
    ------
    ScenarioError
        The address is not of that form (another protocol, no port, a port
        outside 1–65535, a malformed host), with what is accepted.

    Examples
    --------
    >>> check_scheduler_address("tcp://10.0.0.5:8786"), check_scheduler_address("[::1]:8786")
    (('10.0.0.5', 8786), ('::1', 8786))
    >>> try:
    ...     check_scheduler_address("inproc://x", SCHEDULER_ENV)
    ... except ScenarioError as error:
    ...     print(str(error).split(": ")[0:2])
    ["TRAINCTL_DASK_SCHEDULER 'inproc://x'", 'not a usable Dask scheduler address']
    """
    import ipaddress

    def refuse(reason: str) -> ScenarioError:
        return ScenarioError(
            f"{option} {address!r}: not a usable Dask scheduler address: {reason}. Give "
            "tcp://HOST:PORT, HOST a host name, an IPv4 address or an [IPv6] address in "
            "brackets, PORT the scheduler's port (1-65535; 8786 unless it was started with "
            "another), e.g. tcp://10.0.0.5:8786.")

    match = _ADDRESS.fullmatch(address.strip())
    if match is None:
        raise refuse("it is not of the form tcp://HOST:PORT")
    scheme = (match.group("scheme") or "tcp").lower()
    if scheme != "tcp":
        raise refuse(_OTHER_SCHEMES.get(scheme, f"the protocol {scheme!r} is not supported "
                                                "(only tcp)"))
    host, port = match.group("host"), match.group("port")
    if host.startswith("["):
        try:
            host = str(ipaddress.IPv6Address(host[1:-1]))
        except ValueError:
            raise refuse(f"{host} is not an IPv6 address") from None
    elif not host or not _HOSTNAME.fullmatch(host):
        raise refuse("no host" if not host else f"{host!r} is not a host name or an IP address")
    if port is None or port == "":
        raise refuse("no port")
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise refuse(f"the port {port!r} is not a whole number from 1 to 65535")
    return host, int(port)


def _probe(address: str, host: str, port: int, option: str) -> None:
    """Reach the scheduler within :data:`CONNECT_TIMEOUT` and :data:`HANDSHAKE_TIMEOUT`.

    A TCP connection first, so that a refused port fails at once (where
    ``distributed.Client`` retries until its timeout), then Dask's own
    handshake (``distributed.comm.connect``) under a deadline: a port that
    accepts and never answers, or answers something that is not Dask, is
    refused after :data:`HANDSHAKE_TIMEOUT` seconds, where the client waited
    (and then printed tracebacks while closing).
    """
    import asyncio

    from distributed.comm import connect

    hint = (f"Start one (dask scheduler; dask worker ADDRESS on each machine) or check the "
            f"address (or {SCHEDULER_ENV}).")
    try:
        with socket.create_connection((host, port), timeout=CONNECT_TIMEOUT):
            pass
    except OSError as exc:
        reason = f"timed out after {CONNECT_TIMEOUT:g} s" if isinstance(
            exc, TimeoutError) else str(exc)
        raise ScenarioError(f"{option} {address}: no Dask scheduler answered ({reason}). "
                            f"{hint}") from None

    async def handshake() -> None:
        comm = await asyncio.wait_for(connect(f"tcp://{_bracketed(host)}:{port}",
                                              timeout=HANDSHAKE_TIMEOUT), HANDSHAKE_TIMEOUT)
        await comm.close()

    try:
        asyncio.run(handshake())
    except Exception as exc:  # any failure of the handshake: not a Dask scheduler
        reason = (f"no answer within {HANDSHAKE_TIMEOUT:g} s"
                  if isinstance(exc, TimeoutError) else "its answer is not Dask's")
        raise ScenarioError(f"{option} {address}: the port accepts connections but no Dask "
                            f"scheduler answered there ({reason}). {hint}") from None


def _bracketed(host: str) -> str:
    return f"[{host}]" if ":" in host else host


@contextlib.contextmanager
def dask_executor(address: str, timeout: float = 10.0, *,
                  option: str = "--scheduler") -> Iterator[Executor]:
    """An executor on a running Dask cluster (``distributed.Client(address).get_executor``).

    The address is checked first (:func:`check_scheduler_address`), then
    the scheduler reached within :data:`CONNECT_TIMEOUT` and its handshake
    answered within :data:`HANDSHAKE_TIMEOUT`: nothing waits longer. From
    Python, the ``inproc://`` address of a cluster this process started
    (``LocalCluster(processes=False)``) is taken as it is; the command line
    refuses it, since no other process can reach it.

    Parameters
    ----------
    address : str
        The scheduler's address, e.g. ``"tcp://10.0.0.5:8786"``.
    timeout : float
        Seconds the client gets to connect, after the checks [s].
    option : str
        Where the address came from, named in errors (``--scheduler`` or
        :data:`SCHEDULER_ENV`).

    Yields
    ------
    concurrent.futures.Executor
        Tasks are submitted as impure (each runs, none is deduplicated).

    Raises
    ------
    ScenarioError
        The address is malformed, ``distributed`` is not installed, or the
        scheduler does not answer.

    Examples
    --------
    Nothing listens on port 1, so the connection is refused at once:

    >>> try:
    ...     with dask_executor("tcp://127.0.0.1:1", timeout=0.5) as executor:
    ...         pass
    ... except ScenarioError as error:
    ...     print(str(error).split(" (")[0])
    --scheduler tcp://127.0.0.1:1: no Dask scheduler answered
    """
    try:
        from distributed import Client
    except ImportError:
        raise ScenarioError("--scheduler needs Dask's distributed package, which is not "
                            "installed: pip install 'trainctl-toolbox[dask]' (the workers need it "
                            "and trainctl too).") from None
    if address.startswith("inproc://"):
        target = address  # this process's own cluster: nothing to probe on a network
    else:
        host, port = check_scheduler_address(address, option)
        _probe(address, host, port, option)
        target = f"tcp://{_bracketed(host)}:{port}"
    try:
        client = Client(target, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise ScenarioError(f"{option} {address}: no Dask scheduler answered ({exc}). "
                            "Start one (dask scheduler; dask worker ADDRESS on each machine) "
                            f"or check the address (or {SCHEDULER_ENV}).") from None
    try:
        yield client.get_executor(pure=False)
    finally:
        client.close()

