# Nothing hangs: signals, orphaned workers, --jobs, unreachable schedulers, huge sweeps.
"""Every long operation of the ``trainctl`` command is bounded or interruptible.

- SIGINT, SIGTERM and SIGHUP end ``analyse``, ``report``, ``report --all``
  and ``sweep`` promptly with 130, 143 and 129, no partial output file and
  no process left behind;
- after a ``kill -9`` of ``trainctl sweep -j 2`` its pool workers (and,
  where they start from one, the forkserver and the resource tracker) end
  within seconds;
- ``--jobs`` never starts more workers than the usable CPUs or the tasks;
- a scheduler address that is malformed, of another protocol, refused,
  silent or answering garbage is a clear error (exit 2) within the stated
  timeouts;
- a dry run of the largest sweep answers in seconds.

Every subprocess runs in its own session; each test kills that process
group in a ``finally`` and waits with timeouts.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from trainctl.cli.main import main

REPO = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(REPO))

PROMPT = 5.0
"""Seconds within which a signalled command must have exited. About a second on a quiet
machine (the requirement is 2 s); this allows for a loaded 2-core machine, as in
tests/test_runtime.py, far below the minutes a command that ignored the signal takes."""

GONE = 10.0
"""Seconds within which the processes of a killed command must have vanished."""

# Announce, on stderr, the moment a command starts its real work (a scenario's run in the
# main process; for a sweep on a pool, whose workers run the points, the first point
# stored), so that the signal lands in the middle of the work and not in the start-up.
_HOOK = """
import sys
import trainctl.run.analysis as run
import trainctl.sweep.store as store
def announcing(real):
    def announced(*args, **kwargs):
        sys.stderr.write("WORKING\\n"); sys.stderr.flush()
        return real(*args, **kwargs)
    return announced
run.run_scenario = announcing(run.run_scenario)
store.SweepStore.write_point = announcing(store.SweepStore.write_point)
from trainctl.cli.main import main
sys.exit(main())  # as the installed command calls it (argv from sys.argv)
"""


def _default_signals() -> None:
    """In the child: default handlers (a parent that ignores SIGINT must not pass that on)."""
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_DFL)


@contextlib.contextmanager
def session(argv: list[str], cwd: Path) -> Iterator[subprocess.Popen[str]]:
    """A process in its own session and process group, killed (the group) on the way out."""
    process = subprocess.Popen(argv, cwd=cwd, env=ENV, stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE, text=True, start_new_session=True,
                               preexec_fn=_default_signals)
    try:
        yield process
    finally:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            process.communicate(timeout=10)


def group_members(pgid: int) -> list[int]:
    """Live (not zombie) processes whose process group is ``pgid``."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat", encoding="utf-8") as handle:
                stat = handle.read()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()  # state, ppid, pgrp, ...
        if fields[0] != "Z" and int(fields[2]) == pgid:
            found.append(int(entry))
    return found


def children(pid: int) -> list[int]:
    """Direct children of ``pid`` (all its threads'), from /proc."""
    found: list[int] = []
    with contextlib.suppress(OSError):
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children", encoding="utf-8") as handle:
                found += [int(k) for k in handle.read().split()]
    return found


def descendants(pid: int) -> list[int]:
    """Every process below ``pid``."""
    found, todo = [], [pid]
    while todo:
        for child in children(todo.pop()):
            found.append(child)
            todo.append(child)
    return found


def alive(pids: list[int]) -> list[int]:
    """Those of ``pids`` that still exist and are not zombies."""
    out = []
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat", encoding="utf-8") as handle:
                if handle.read().rsplit(")", 1)[1].split()[0] != "Z":
                    out.append(pid)
        except OSError:
            pass
    return out


def wait_until(condition: Any, seconds: float, step: float = 0.1) -> bool:
    """Poll ``condition()`` until it is true or ``seconds`` have passed (bounded)."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(step)
    return bool(condition())


def wait_for_line(process: subprocess.Popen[str], word: str, seconds: float = 180.0) -> None:
    """Read the child's stderr until a line ``word`` (the child's hook announces its work)."""
    assert process.stderr is not None
    box: list[bool] = []

    def read() -> None:
        assert process.stderr is not None
        for line in process.stderr:
            if line.strip() == word:
                box.append(True)
                return

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(seconds)
    if not box:
        pytest.fail(f"the command never announced {word!r} (exit {process.poll()})")


# --- signals ------------------------------------------------------------------------------

SIGNALS = {"INT": (signal.SIGINT, 130), "TERM": (signal.SIGTERM, 143),
           "HUP": (signal.SIGHUP, 129)}

COMMANDS = {
    "analyse": ["analyse", "crh2-dmpc-well-sampled", "--jobs", "2"],
    "report": ["report", "crh2-dmpc-well-sampled", "--jobs", "2", "-o", "out.html"],
    "report-all": ["report", "--all", "-o", "gallery"],
    "sweep": ["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,2,3,4,5,6", "-j", "2",
              "-o", "store"],
}


FAST_CASES = {("analyse", "INT"), ("report", "TERM"), ("report-all", "HUP"), ("sweep", "INT")}
"""The pairs `make test` runs: every command and every signal once (the sweep, whose pool
workers must end too, with Ctrl-C); the other eight pairs of the matrix are e2e."""


@pytest.mark.slow
@pytest.mark.parametrize(("command", "name"), [
    pytest.param(command, name, id=f"{command}-{name}",
                 marks=() if (command, name) in FAST_CASES else pytest.mark.e2e)
    for command in COMMANDS for name in SIGNALS])
def test_signal_ends_the_command(command: str, name: str, tmp_path: Path) -> None:
    """Mid-work, each stop signal ends the command promptly with 128 + the signal:
    one clear line, no traceback, no output file, no process of its group left."""
    signum, status = SIGNALS[name]
    argv = [sys.executable, "-c", _HOOK, *COMMANDS[command]]
    with session(argv, tmp_path) as process:
        wait_for_line(process, "WORKING")
        time.sleep(0.5)  # well inside the work (simulations, the pool's workers running)
        start = time.monotonic()
        process.send_signal(signum)
        _, err = process.communicate(timeout=60)
        seconds = time.monotonic() - start
        assert process.returncode == status, err
        assert seconds < PROMPT, seconds
        assert "interrupted" in err and "Traceback" not in err, err
        # nothing of the group survives it (pool workers, forkserver, resource tracker)
        assert wait_until(lambda: not group_members(process.pid), GONE), \
            group_members(process.pid)
    assert not (tmp_path / "out.html").exists()
    assert not (tmp_path / "gallery").exists() or not any(
        p.suffix == ".html" for p in (tmp_path / "gallery").iterdir())
    leftovers = [p.name for p in tmp_path.rglob("*") if p.name.endswith((".tmp", ".partial"))
                 or ".partial-" in p.name]
    assert leftovers == []


def test_hangup_unwinds_like_ctrl_c() -> None:
    """In process: SIGHUP (and SIGTERM) raise Interrupted inside the guard, a
    KeyboardInterrupt carrying the signal; the handlers are restored after."""
    from trainctl.run._signals import Interrupted, exit_status, signal_guard

    before = signal.getsignal(signal.SIGHUP)
    for signum, status in ((signal.SIGHUP, 129), (signal.SIGTERM, 143)):
        with pytest.raises(KeyboardInterrupt) as caught, signal_guard():
            os.kill(os.getpid(), signum)
            time.sleep(5)  # the handler interrupts this at once
        assert isinstance(caught.value, Interrupted) and caught.value.signum == signum
        assert exit_status(caught.value) == status
    assert signal.getsignal(signal.SIGHUP) == before


def test_report_all_closes_its_pool_when_rendering_is_interrupted(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C while a report renders (outside the simulations' generator) closes the
    generator, and its worker pool, at once (explicitly: ``contextlib.closing``)."""
    import trainctl.report.batch as batch
    from trainctl.report import ReportJob
    from trainctl.scenario import parse_scenario, read_scenario_text

    closed: list[str] = []

    def results(jobs: Any, **kwargs: Any) -> Iterator[Any]:
        try:
            for _ in jobs:
                yield object()
        except GeneratorExit:
            closed.append("closed")
            raise

    def render(*args: Any, **kwargs: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(batch, "run_report_data", results)
    monkeypatch.setattr(batch, "write_report_file", render)
    text, label = read_scenario_text("crh2-dmpc")
    job = ReportJob(parse_scenario(text, source=label), text, "trainctl report crh2-dmpc")
    with pytest.raises(KeyboardInterrupt):  # (its traceback keeps the frames alive)
        batch.report_all([job, job], tmp_path / "out")
    assert closed == ["closed"]


# --- workers die with their parent -----------------------------------------------------------

@pytest.mark.slow
def test_kill_9_of_a_sweep_leaves_no_process(tmp_path: Path) -> None:
    """``kill -9`` of ``trainctl sweep -j 2``: its workers, the forkserver and the resource
    tracker end within seconds (they lived on for 13 minutes, holding stdout)."""
    argv = [sys.executable, "-m", "trainctl", "sweep", "crh2-dmpc", "--set",
            "controller.r_per_kn2=1,2,3,4,5,6", "-j", "2", "-o", "store"]
    with session(argv, tmp_path) as process:
        # both workers run: forked from the command itself (Linux), or from its forkserver
        def two_workers() -> bool:
            kids = alive(children(process.pid))
            forkservers = [pid for pid in kids if b"forkserver" in
                           Path(f"/proc/{pid}/cmdline").read_bytes()]
            return (len(kids) >= 2 and not forkservers) or any(
                len(alive(children(pid))) >= 2 for pid in forkservers)

        assert wait_until(two_workers, 180.0, step=0.2), (process.poll(),
                                                          descendants(process.pid))
        below = descendants(process.pid)
        assert len(below) >= 2  # the two workers (and a forkserver, a resource tracker)
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=10)
        assert wait_until(lambda: not alive(below), GONE), alive(below)
        assert not group_members(process.pid)


def test_worker_ends_when_its_lifeline_closes() -> None:
    """In process: a pool worker whose lifeline is closed (as when the parent dies) exits at
    once, even in the middle of a task."""
    from trainctl.run.pool import worker_pool

    with worker_pool(2) as pool:
        assert pool is not None
        pids = {pool.submit(os.getpid).result(timeout=60) for _ in range(4)}
        busy = pool.submit(time.sleep, 30)
        time.sleep(0.2)
        pool._trainctl_lifeline.close()  # type: ignore[union-attr]
        assert wait_until(lambda: not alive(sorted(pids)), GONE), alive(sorted(pids))
        with pytest.raises(Exception):  # noqa: B017, PT011 - the pool is broken now
            busy.result(timeout=30)


# --- --jobs ----------------------------------------------------------------------------------

def test_jobs_capped_at_cpus_and_tasks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    """``--jobs 10000`` asks for no more workers than the usable CPUs and the points."""
    import trainctl.run.pool as parallel

    cpus = parallel.available_cpus()
    asked: list[int] = []

    @contextlib.contextmanager
    def recording(workers: int) -> Iterator[None]:
        asked.append(workers)
        yield None  # run the points here

    monkeypatch.setattr(parallel, "worker_pool", recording)
    argv = ["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,2,3", "--no-simulate",
            "-j", "10000", "-o", str(tmp_path / "store")]
    assert main(argv) == 0
    capsys.readouterr()
    assert len(asked) == 1
    assert asked[0] <= min(cpus, 3)
    assert asked[0] == (min(cpus, 3) if min(cpus, 3) > 1 else 0)
    assert parallel.pool_size(10_000, 10_000) <= cpus
    from trainctl.scenario import load_scenario

    scenario = load_scenario("crh2-dmpc")
    assert parallel.want_pool([scenario] * 40, 10_000) <= cpus


def test_jobs_help_says_it_is_capped(capsys: pytest.CaptureFixture[str]) -> None:
    for command in ("analyse", "report", "sweep"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        assert "at most the usable CPUs" in " ".join(capsys.readouterr().out.split()), command


# --- schedulers ------------------------------------------------------------------------------

SWEEP = ["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,2", "--no-simulate"]

MALFORMED = {
    "garbage": "no port",
    "http://127.0.0.1:8787": "web address",
    "tcp://[::1": "not of the form",
    "tls://127.0.0.1:8786": "TLS",
    "inproc://x": "in-process",
    "ucx://127.0.0.1:8786": "UCX",
    "tcp://127.0.0.1:99999": "1 to 65535",
    "tcp://127.0.0.1": "no port",
    "tcp://[zz::1]:8786": "not an IPv6 address",
    "tcp://exa mple:8786": "not a host name",
}


@pytest.mark.parametrize("how", ["option", "environment"])
@pytest.mark.parametrize("address", list(MALFORMED))
def test_malformed_scheduler_is_a_clear_error(address: str, how: str, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """Exit 2 at once, naming the option (or variable), the value and what is accepted."""
    pytest.importorskip("distributed")
    from trainctl.sweep.runner import SCHEDULER_ENV

    if how == "option":
        monkeypatch.delenv(SCHEDULER_ENV, raising=False)
        argv = [*SWEEP, "--scheduler", address, "-o", str(tmp_path / "store")]
        named = "--scheduler"
    else:
        monkeypatch.setenv(SCHEDULER_ENV, address)
        argv = [*SWEEP, "-o", str(tmp_path / "store")]
        named = SCHEDULER_ENV
    start = time.monotonic()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert time.monotonic() - start < 5.0
    assert err.startswith(f"trainctl: error: {named} {address!r}: ")
    assert MALFORMED[address] in err and "tcp://HOST:PORT" in err
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@contextlib.contextmanager
def listening(answer: bytes | None) -> Iterator[int]:
    """A loopback port that accepts connections and says nothing (None) or ``answer``."""
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    server.settimeout(0.2)
    stop = threading.Event()
    held: list[socket.socket] = []

    def serve() -> None:
        while not stop.is_set():  # bounded: the test sets stop
            try:
                conn, _ = server.accept()
            except OSError:
                continue
            held.append(conn)
            if answer is not None:
                with contextlib.suppress(OSError):
                    conn.sendall(answer)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield int(server.getsockname()[1])
    finally:
        stop.set()
        thread.join(timeout=5)
        for conn in held:
            conn.close()
        server.close()


@pytest.mark.parametrize("answer", [None, b"HTTP/1.1 200 OK\r\n\r\n\x00\xff garbage" * 20,
                                    b"\x01\x00\x00\x00\x00\x00\x00\x00\x05\x00\x00\x00" * 4],
                         ids=["silent", "garbage", "short-frame"])
def test_port_that_is_not_a_scheduler(answer: bytes | None, tmp_path: Path,
                                      monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    """A port that accepts and never answers, or answers garbage: exit 2 within the
    handshake timeout (here shortened to 1 s), no traceback, nothing written."""
    pytest.importorskip("distributed")
    import trainctl.sweep.runner as runner

    monkeypatch.delenv(runner.SCHEDULER_ENV, raising=False)
    monkeypatch.setattr(runner, "HANDSHAKE_TIMEOUT", 1.0)
    with listening(answer) as port:
        address = f"tcp://127.0.0.1:{port}"
        start = time.monotonic()
        code = main([*SWEEP, "--scheduler", address, "-o", str(tmp_path / "store")])
        seconds = time.monotonic() - start
    err = capsys.readouterr().err
    assert code == 2, err
    assert seconds < 1.0 + 15.0  # the handshake's 1 s, plus validating two points
    assert err.startswith(f"trainctl: error: --scheduler {address}: the port accepts")
    assert "no Dask scheduler answered" in err and "Traceback" not in err
    if answer is None:
        assert "no answer within 1 s" in err
    assert list(tmp_path.iterdir()) == []


def test_timeouts_are_stated() -> None:
    """The connection and handshake timeouts are a few seconds."""
    from trainctl.sweep.runner import CONNECT_TIMEOUT, HANDSHAKE_TIMEOUT

    assert 1.0 <= CONNECT_TIMEOUT <= 10.0 and 1.0 <= HANDSHAKE_TIMEOUT <= 10.0


# --- huge sweeps -----------------------------------------------------------------------------

def _grid_file(tmp_path: Path, first: int, second: int) -> Path:
    """crh2-dmpc with a [sweep] of two grid axes of ``first`` × ``second`` values."""
    from trainctl.scenario import builtin_scenario_text

    text = builtin_scenario_text("crh2-dmpc").split("\n[expected]")[0]
    text += (f'\n[sweep]\n\n[[sweep.axis]]\nkey = "controller.r_per_kn2"\nstart = 1.0\n'
             f'stop = {float(first)}\nnum = {first}\n\n[[sweep.axis]]\n'
             f'key = "controller.q_velocity"\nstart = 1.0\nstop = {float(second)}\n'
             f'num = {second}\n')
    path = tmp_path / "s.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("output", [False, True], ids=["plain", "with-o"])
def test_dry_run_of_the_largest_grid_answers_in_seconds(
        output: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A 1000 × 999 grid (just under MAX_POINTS): the dry run summarises it in seconds
    (it ran for hours: every point was parsed), writes nothing, and says a run is refused."""
    from trainctl.sweep.definition import MAX_POINTS, MAX_RUN_POINTS, SAMPLED_PER_AXIS

    path = _grid_file(tmp_path, 1000, 999)
    assert 1000 * 999 <= MAX_POINTS
    argv = ["sweep", str(path), "--dry-run"] + (["-o", str(tmp_path / "store")] if output
                                               else [])
    start = time.monotonic()
    assert main(argv) == 0
    seconds = time.monotonic() - start
    captured = capsys.readouterr()
    assert seconds < 20.0, seconds  # about 1 s on a quiet machine
    lines = captured.out.splitlines()
    assert lines[0].startswith(f"{path}: 999000 sweep points (1000 × 999)")
    assert "controller.r_per_kn2: 1000 values, 1.0 ... 1000.0" in captured.out
    rows = [line.split() for line in lines if line.split() and line.split()[0].isdigit()]
    assert 2 <= len(rows) <= 2 + 2 * SAMPLED_PER_AXIS
    assert rows[0][:3] == ["0", "1.0", "1.0"]
    assert rows[-1][:3] == ["998999", "1000.0", "999.0"]  # the last point, validated
    assert f"refused: more than {MAX_RUN_POINTS} points" in captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_run_of_a_huge_grid_is_refused_at_once(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """The real run refuses it before any work (it validated every point first, for hours)."""
    path = _grid_file(tmp_path, 1000, 999)
    start = time.monotonic()
    assert main(["sweep", str(path), "-o", str(tmp_path / "store")]) == 2
    seconds = time.monotonic() - start
    err = capsys.readouterr().err
    assert seconds < 20.0, seconds
    assert err.startswith(f"trainctl: error: {path}: sweep: 999000 points (1000 × 999), more "
                          "than the")
    assert "Split the sweep" in err and "Traceback" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_summarised_dry_run_finds_a_bad_value(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """The sample validates the ends of every axis: an axis whose last value alone is bad
    (999 values from 999 down to -1) is still an error, naming that point."""
    path = _grid_file(tmp_path, 1000, 999)
    text = path.read_text(encoding="utf-8")
    assert text.count("start = 1.0\nstop = 999.0") == 1
    path.write_text(text.replace("start = 1.0\nstop = 999.0", "start = 999.0\nstop = -1.0"),
                    encoding="utf-8")
    assert main(["sweep", str(path), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"trainctl: error: {path}: sweep point 998 (")
    assert "controller.q_velocity = -1.0" in err and ">= 0" in err
    assert "Traceback" not in err


def test_point_by_index_matches_the_list() -> None:
    """SweepDefinition.point(i) is points()[i], for lists, grids, random axes and seeds."""
    from trainctl.sweep.definition import GridAxis, ListAxis, RandomAxis, SweepDefinition

    sweep = SweepDefinition([ListAxis("controller.r_per_kn2", [0.1, 1.0, 10.0]),
                             RandomAxis("train.vehicle[0].mass_t", "uniform", low=40.0,
                                        high=50.0),
                             GridAxis("model.sample_time", 10.0, 30.0, 3)],
                            seed=7, samples=4, seeds=2)
    points = sweep.points(base_seed=5)
    assert len(points) == sweep.n_points == 3 * 3 * 4 * 2
    assert [sweep.point(i, base_seed=5) for i in range(len(points))] == points
    assert set(sweep.sample_indices(per_axis=2)) <= set(range(len(points)))
    with pytest.raises(IndexError):
        sweep.point(len(points))
