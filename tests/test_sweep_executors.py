"""A sweep gives the same store and table serially, on a process pool and on a Dask cluster.

The Dask cluster is real: a ``distributed.LocalCluster`` whose scheduler and
two worker processes the module starts on the loopback interface, reached by
``trainctl sweep --scheduler tcp://127.0.0.1:PORT`` (or
``TRAINCTL_DASK_SCHEDULER``) exactly as a remote one would be.
"""

from __future__ import annotations

import math
import os
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from trainctl.cli.main import main
from trainctl.run.pool import WORKER_THREAD_VARIABLES, worker_pool
from trainctl.sweep.runner import SCHEDULER_ENV
from trainctl.sweep.store import SweepStore

pytestmark = pytest.mark.e2e  # a long end-to-end run (make test-e2e): whole pipelines

distributed = pytest.importorskip("distributed")

# two points of the book's CRH2 scenario with its three simulations, shortened
# to 200 s of simulated time (about a second per point)
SWEEP = ["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,10",
         "--set", "simulation.duration=200.0"]

WALL_CLOCK = {"solve_times"}
"""Stored arrays that are measured times (the controllers' solve times), not results."""


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    """A Dask LocalCluster: a scheduler and two single-threaded worker processes on loopback.

    Its web server takes any free port (":0"): with None it takes 8787 and warns (an error
    here) when another test's cluster, e.g. tutorial 7's on the other xdist worker, has it.
    """
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=":0") as local:
        yield local


def point_tasks(address: str) -> int:
    """How many ``run_point_results`` tasks the scheduler at ``address`` has run.

    Counted from the scheduler's log of task transitions (the most recent
    thousands, far more than this module makes), in which every submitted
    task appears under its key, ``run_point_results-<uuid>``.
    """
    with distributed.Client(address, set_as_default=False) as client:
        def count(dask_scheduler: Any) -> int:
            return len({str(entry[0]) for entry in dask_scheduler.transition_log
                        if str(entry[0]).startswith("run_point_results-")
                        and entry[2] == "memory"})

        return int(client.run_on_scheduler(count))


def closed_port() -> int:
    """A loopback TCP port nothing listens on (bound, then released)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def stored_arrays(store: SweepStore, key: str) -> dict[str, dict[str, np.ndarray]]:
    """Strategy → the arrays of a stored point's simulation."""
    out = {}
    for run in sorted((store.points_dir / key / "runs").iterdir()):
        with np.load(run / "arrays.npz") as data:
            out[run.name] = {name: data[name] for name in data.files}
    return out


def thread_variables() -> dict[str, str | None]:
    """The BLAS and OpenMP thread-count variables of the process it runs in."""
    return {name: os.environ.get(name) for name in WORKER_THREAD_VARIABLES}


class TestPoolWorkers:
    def test_libraries_single_threaded(self) -> None:
        """Pool workers see the thread variables at 1 (or as set); this process keeps its own."""
        mine = thread_variables()
        with worker_pool(2) as pool:
            assert pool is not None
            theirs = [pool.submit(thread_variables).result() for _ in range(2)]
        assert thread_variables() == mine
        expected = {name: value or "1" for name, value in mine.items()}
        assert theirs == [expected, expected]


def _same(a: Any, b: Any) -> bool:
    """Equal, floats to 1e-9 relative. The workers' BLAS runs single-threaded, the serial
    run's multi-threaded: on a loaded machine the check details' Gramian eigenvalues were
    seen to differ at 1e-12 relative (the table and the arrays stay bit-identical)."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b or math.isclose(a, b, rel_tol=1e-9, abs_tol=0.0)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return type(a) is type(b) and a == b


@pytest.mark.slow
class TestSameTable:
    def test_serial_pool_and_dask_identical(self, cluster: Any, tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:
        """Serial, ``-j 2`` and ``--scheduler`` write the same table, summaries and arrays.

        The arrays are compared but for the solve times, which are wall-clock.
        """
        monkeypatch.delenv(SCHEDULER_ENV, raising=False)
        before = point_tasks(cluster.scheduler_address)
        runs = {"serial": [], "pool": ["-j", "2"],
                "dask": ["--scheduler", cluster.scheduler_address]}
        for name, extra in runs.items():
            assert main([*SWEEP, *extra, "-o", str(tmp_path / name)]) == 0, name
        capsys.readouterr()
        # the Dask run really ran its two points on the cluster
        assert point_tasks(cluster.scheduler_address) == before + 2

        tables = {name: (tmp_path / name / "rows.parquet").read_bytes() for name in runs}
        assert tables["pool"] == tables["serial"]
        assert tables["dask"] == tables["serial"]
        frames = {name: pd.read_parquet(tmp_path / name / "rows.parquet") for name in runs}
        assert len(frames["serial"]) == 2 * 3  # two points, three strategies
        for name in ("pool", "dask"):
            pd.testing.assert_frame_equal(frames[name], frames["serial"], check_exact=True)

        stores = {name: SweepStore.load(tmp_path / name) for name in runs}
        keys = stores["serial"].keys
        assert len(set(keys)) == 2
        for name in ("pool", "dask"):
            assert stores[name].manifest == stores["serial"].manifest
            assert sorted(stores[name].done()) == sorted(keys)
        for key in keys:
            summary = stores["serial"].summary(key)
            assert summary["simulations"], "the points ran their simulations"
            arrays = stored_arrays(stores["serial"], key)
            for name in ("pool", "dask"):
                assert _same(stores[name].summary(key), summary), (name, key)
                other = stored_arrays(stores[name], key)
                assert other.keys() == arrays.keys()
                for strategy, data in arrays.items():
                    assert other[strategy].keys() == data.keys()
                    for field, values in data.items():
                        if field not in WALL_CLOCK:
                            np.testing.assert_array_equal(other[strategy][field], values)

    def test_environment_variable_names_the_scheduler(
            self, cluster: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
            capsys: pytest.CaptureFixture[str]) -> None:
        """Without ``--scheduler``, TRAINCTL_DASK_SCHEDULER sends the points to the cluster."""
        before = point_tasks(cluster.scheduler_address)
        monkeypatch.setenv(SCHEDULER_ENV, cluster.scheduler_address)
        assert main([*SWEEP, "--no-simulate", "-o", str(tmp_path / "env")]) == 0
        capsys.readouterr()
        assert point_tasks(cluster.scheduler_address) == before + 2
        assert (tmp_path / "env" / "rows.parquet").is_file()


@pytest.mark.slow
class TestUnreachableScheduler:
    @pytest.mark.parametrize("how", ["option", "environment"])
    def test_exits_2_and_writes_nothing(self, how: str, tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch,
                                        capsys: pytest.CaptureFixture[str]) -> None:
        """No scheduler at the address: exit status 2, one clear message, no store."""
        address = f"tcp://127.0.0.1:{closed_port()}"
        output = tmp_path / "store"
        if how == "option":
            monkeypatch.delenv(SCHEDULER_ENV, raising=False)
            argv = [*SWEEP, "--scheduler", address, "-o", str(output)]
        else:
            monkeypatch.setenv(SCHEDULER_ENV, address)
            argv = [*SWEEP, "-o", str(output)]
        code = main(argv)
        captured = capsys.readouterr()
        assert code == 2
        named = "--scheduler" if how == "option" else SCHEDULER_ENV  # where it came from
        assert captured.err.startswith(f"trainctl: error: {named} ")
        assert address in captured.err and "no Dask scheduler answered" in captured.err
        # refused at once by the TCP probe, not after the client's 10 s of retries
        assert "Connection refused" in captured.err
        assert "Traceback" not in captured.err and captured.out == ""
        assert not output.exists()
        assert list(tmp_path.iterdir()) == []
