# Nothing lost: a save, an output or an input never deletes, re-owns or waits on what is not its.
"""Issue 25, writes and reads: ``--save``, output targets, non-regular inputs.

Every case checks the exit status (or the exception), the message (naming the
path), that no traceback is printed, that the user's files are byte-identical
(a hash of every entry before and after), that no temporary entry is left and
that nothing is written outside the requested target. Command-line cases run
the real CLI (``python -m trainctl``) in a subprocess with a timeout, so a
blocking open fails the test instead of hanging it.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import signal
import socket
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from trainctl.exceptions import TrainctlError
from trainctl.report import ReportData, collect_report_data
from trainctl.report.data import MANIFEST, check_save_target
from trainctl.report.output import OutputError, write_output, write_text_atomic
from trainctl.run.analysis import run_scenario
from trainctl.scenario import builtin_scenario_text, load_scenario, read_scenario_text

REPO = Path(__file__).resolve().parents[1]
OTHER_UID = 1234
"""The "other user" of the ownership cases (the tests run as root in CI containers)."""


_PAUSE_IN_SAVE = """
import sys, time
import trainctl.report.data as data
_document = data.ReportData._document
def _announced(self):
    sys.stderr.write("STAGING\\n"); sys.stderr.flush()
    time.sleep(60)
    return _document(self)
data.ReportData._document = _announced
from trainctl.cli.main import main
sys.exit(main(sys.argv[1:]))
"""
"""The CLI, pausing inside ReportData.save once its staging directory holds scenario.toml."""


# --------------------------------------------------------------------------- helpers


def snapshot(root: Path) -> dict[str, tuple[str, str]]:
    """Every entry under ``root`` (not followed): its kind and content hash or link target."""
    found: dict[str, tuple[str, str]] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            path = Path(dirpath) / name
            rel = path.relative_to(root).as_posix()
            st = os.lstat(path)
            if stat.S_ISLNK(st.st_mode):
                found[rel] = ("link", os.readlink(path))
            elif stat.S_ISREG(st.st_mode):
                found[rel] = ("file", hashlib.sha256(path.read_bytes()).hexdigest())
            elif stat.S_ISDIR(st.st_mode):
                found[rel] = ("dir", "")
            else:
                found[rel] = ("special", oct(stat.S_IFMT(st.st_mode)))
    return found


def temporary_entries(root: Path) -> list[str]:
    """Entries that look like a writer's temporary or staging files."""
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*")
                  if p.name.endswith((".tmp", ".old")) or ".trainctl-save-" in p.name
                  or ".partial-" in p.name)


def cli(*args: str, cwd: Path, timeout: float = 240,
        code: str | None = None) -> subprocess.CompletedProcess[str]:
    """``python -m trainctl ARGS`` (or ``python -c CODE ARGS``) in ``cwd``, bounded in time."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    command = [sys.executable, "-c", code] if code else [sys.executable, "-m", "trainctl"]
    return subprocess.run([*command, *args], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=timeout, check=False)


def assert_refused(result: subprocess.CompletedProcess[str], *words: str) -> None:
    """Exit 2, a trainctl error message holding ``words``, no traceback."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr, result.stderr
    assert result.stderr.startswith("trainctl: error: "), result.stderr
    for word in words:
        assert word in result.stderr, (word, result.stderr)


def assert_ran(result: subprocess.CompletedProcess[str]) -> None:
    """Exit 0 and no traceback."""
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr


def assert_valid_save(directory: Path) -> ReportData:
    """The directory holds exactly a save's files, and it loads."""
    names = {p.name for p in directory.iterdir()}
    assert {MANIFEST, "scenario.toml"} <= names <= {MANIFEST, "scenario.toml", "simulations"}
    return ReportData.load(directory)


@pytest.fixture(scope="module")
def hinf() -> ReportData:
    """heavy-haul-hinf's design review: no simulation (the cheapest save)."""
    text, _ = read_scenario_text("heavy-haul-hinf")
    run = run_scenario(load_scenario("heavy-haul-hinf"), simulate=False)
    return collect_report_data(run, scenario_text=text)


@pytest.fixture(scope="module")
def simulated() -> ReportData:
    """crh2-dmpc, shortened to one strategy over 120 s: a save with ``simulations/``."""
    text, _ = read_scenario_text("crh2-dmpc")
    scenario = (load_scenario("crh2-dmpc").replace("simulation.settle_time", 60.0)
                .replace("simulation.duration", 120.0)
                .replace("simulation.strategies", ["decentralised"]))
    return collect_report_data(run_scenario(scenario), scenario_text=text)


@pytest.fixture
def earlier_save(tmp_path: Path, hinf: ReportData) -> Path:
    """``tmp_path/runs``: an earlier save of heavy-haul-hinf."""
    return hinf.save(tmp_path / "runs")


# --------------------------------------------------------------------------- --save, CLI


@pytest.mark.slow
class TestSaveCommand:
    """``trainctl analyse ... --save DIR`` refuses what is not a save, before running."""

    def test_user_file_beside_an_earlier_save_is_kept(self, tmp_path: Path,
                                                      earlier_save: Path) -> None:
        """The issue's case: runs/ holds an earlier save and my-notes.txt."""
        (earlier_save / "my-notes.txt").write_bytes(b"my notes\n\x00 bytes too")
        before = snapshot(tmp_path)
        result = cli("analyse", "heavy-haul-hinf", "--no-simulate", "--save", "runs",
                     cwd=tmp_path)
        assert_refused(result, "runs", "my-notes.txt", "nothing was changed")
        assert snapshot(tmp_path) == before

    def test_fake_manifest_among_user_files(self, tmp_path: Path) -> None:
        """An empty trainctl-run.json does not make a directory a save."""
        mine = tmp_path / "mine"
        mine.mkdir()
        (mine / MANIFEST).write_bytes(b"")
        (mine / "thesis.tex").write_text("\\section{Intro}", encoding="utf-8")
        (mine / "data").mkdir()
        (mine / "data" / "x.csv").write_text("1,2\n", encoding="utf-8")
        before = snapshot(tmp_path)
        result = cli("analyse", "heavy-haul-hinf", "--no-simulate", "--save", "mine",
                     cwd=tmp_path)
        assert_refused(result, "mine", "thesis.tex", "data/", MANIFEST)
        assert snapshot(tmp_path) == before

    def test_fake_manifest_alone(self, tmp_path: Path) -> None:
        """A trainctl-run.json that trainctl did not write is itself not replaced."""
        mine = tmp_path / "mine"
        mine.mkdir()
        (mine / MANIFEST).write_text('{"format": "my-own/1", "keep": true}', encoding="utf-8")
        before = snapshot(tmp_path)
        result = cli("analyse", "heavy-haul-hinf", "--no-simulate", "--save", "mine",
                     cwd=tmp_path)
        assert_refused(result, "mine", f"{MANIFEST} (not a manifest trainctl wrote")
        assert snapshot(tmp_path) == before

    def test_save_dot_inside_an_earlier_save(self, earlier_save: Path) -> None:
        """``--save .`` from inside a save replaces it in place: no traceback, no staging."""
        inode = os.stat(earlier_save).st_ino
        result = cli("analyse", "crh2-dmpc", "--no-simulate", "--save", ".", cwd=earlier_save)
        assert_ran(result)
        assert os.stat(earlier_save).st_ino == inode
        assert assert_valid_save(earlier_save).scenario.source == "builtin:crh2-dmpc"
        assert temporary_entries(earlier_save.parent) == []

    def test_symlink_to_an_earlier_save_is_followed(self, tmp_path: Path,
                                                    earlier_save: Path) -> None:
        """``--save LINK``: the link stays a link, its directory gets the new save."""
        (tmp_path / "link").symlink_to("runs")
        result = cli("analyse", "crh2-dmpc", "--no-simulate", "--save", "link", cwd=tmp_path)
        assert_ran(result)
        assert (tmp_path / "link").is_symlink() and os.readlink(tmp_path / "link") == "runs"
        assert assert_valid_save(earlier_save).scenario.source == "builtin:crh2-dmpc"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "runs"]
        assert temporary_entries(tmp_path) == []

    def test_symlink_to_a_foreign_directory_is_refused(self, tmp_path: Path) -> None:
        """The link's target is judged by the same rule; the link is not touched."""
        (tmp_path / "mine").mkdir()
        (tmp_path / "mine" / "notes.txt").write_text("keep", encoding="utf-8")
        (tmp_path / "link").symlink_to("mine")
        before = snapshot(tmp_path)
        result = cli("analyse", "heavy-haul-hinf", "--no-simulate", "--save", "link",
                     cwd=tmp_path)
        assert_refused(result, "link", "notes.txt")
        assert snapshot(tmp_path) == before

    @pytest.mark.parametrize("kind", ["broken link", "file", "fifo"])
    def test_not_a_directory(self, tmp_path: Path, kind: str) -> None:
        """A broken link, a file or a pipe where the directory should be: refused, kept."""
        path = tmp_path / "out"
        if kind == "broken link":
            path.symlink_to("missing")
        elif kind == "file":
            path.write_text("mine", encoding="utf-8")
        else:
            os.mkfifo(path)
        before = snapshot(tmp_path)
        result = cli("analyse", "heavy-haul-hinf", "--no-simulate", "--save", "out",
                     cwd=tmp_path, timeout=120)
        assert_refused(result, "out:")
        assert snapshot(tmp_path) == before


    @pytest.mark.parametrize("signum", [
        # SIGINT unwinds as SIGTERM does (tests/test_no_hang.py: both, in process): e2e
        pytest.param(signal.SIGINT, id="SIGINT", marks=pytest.mark.e2e),
        pytest.param(signal.SIGTERM, id="SIGTERM"),
        pytest.param(signal.SIGKILL, id="SIGKILL")])
    def test_signal_while_staging(self, tmp_path: Path, earlier_save: Path, hinf: ReportData,
                                  signum: int) -> None:
        """Signalled mid-save: the earlier save is whole; only SIGKILL leaves its staging,
        which the next save removes."""
        before = snapshot(tmp_path)
        env = dict(os.environ, PYTHONPATH=str(REPO))
        process = subprocess.Popen(
            [sys.executable, "-c", _PAUSE_IN_SAVE, "analyse", "crh2-dmpc", "--no-simulate",
             "--save", "runs"], cwd=tmp_path, env=env, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True)
        try:
            assert process.stderr is not None
            for line in process.stderr:
                if line.strip() == "STAGING":
                    break
            else:
                pytest.fail("the save never started")
            assert [p.name for p in earlier_save.iterdir() if p.name.startswith(".")]
            process.send_signal(signum)
            _, err = process.communicate(timeout=60)
        finally:
            process.kill()
        after = snapshot(tmp_path)
        if signum == signal.SIGKILL:
            assert process.returncode == -signal.SIGKILL
            staged = {k for k in after if k.startswith("runs/.trainctl-save-")}
            assert staged and {k: v for k, v in after.items() if k not in staged} == before
            hinf.save(earlier_save)
            assert temporary_entries(tmp_path) == []
        else:
            assert process.returncode in (130, 143), err
            assert "interrupted" in err and "Traceback" not in err
            assert after == before


# --------------------------------------------------------------------------- --save, API


class TestSaveDirectory:
    """ReportData.save and check_save_target: what counts as an earlier save."""

    def test_new_directory_holds_only_the_save(self, tmp_path: Path,
                                               simulated: ReportData) -> None:
        """Parents are created; nothing but the save's files, nothing beside the directory."""
        target = tmp_path / "a" / "b" / "run"
        simulated.save(target)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]
        assert {p.name for p in target.iterdir()} == {MANIFEST, "scenario.toml", "simulations"}
        assert sorted(p.name for p in (target / "simulations" / "decentralised").iterdir()) == [
            "arrays.npz", "result.json"]
        assert list(assert_valid_save(target).simulations) == ["decentralised"]

    def test_resave_replaces_only_its_own_files(self, tmp_path: Path, simulated: ReportData,
                                                hinf: ReportData) -> None:
        """A save with simulations replaced by one without: its simulations/ goes, DIR stays."""
        target = simulated.save(tmp_path / "run")
        os.chmod(target, 0o750)
        os.chown(target, OTHER_UID, OTHER_UID)
        inode = os.stat(target).st_ino
        hinf.save(target)
        st = os.stat(target)
        assert (st.st_ino, st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode)) == (
            inode, OTHER_UID, OTHER_UID, 0o750)
        assert sorted(p.name for p in target.iterdir()) == sorted([MANIFEST, "scenario.toml"])
        assert assert_valid_save(target).scenario.source == "builtin:heavy-haul-hinf"

    @pytest.mark.parametrize("damage", [
        "notes in a strategy", "unlisted strategy", "linked scenario", "file as simulations",
        "hidden file", "other-format manifest", "manifest as a directory",
    ])
    def test_foreign_entries_are_named(self, tmp_path: Path, simulated: ReportData,
                                       damage: str) -> None:
        """Anything a save does not write, wherever it is, is named and nothing changes."""
        target = simulated.save(tmp_path / "run")
        outside = tmp_path / "outside.toml"
        outside.write_text("mine = true\n", encoding="utf-8")
        if damage == "notes in a strategy":
            (target / "simulations" / "decentralised" / "notes.txt").write_text("x")
            named = "simulations/decentralised/notes.txt"
        elif damage == "unlisted strategy":
            (target / "simulations" / "mine").mkdir()
            named = "simulations/mine"
        elif damage == "linked scenario":
            (target / "scenario.toml").unlink()
            (target / "scenario.toml").symlink_to(outside)
            named = "scenario.toml (a symbolic link)"
        elif damage == "file as simulations":
            for path in sorted((target / "simulations").rglob("*"), reverse=True):
                path.unlink() if path.is_file() else path.rmdir()
            (target / "simulations").rmdir()
            (target / "simulations").write_text("mine")
            named = "simulations"
        elif damage == "hidden file":
            (target / ".trainctl-save-mine").write_text("mine")
            named = ".trainctl-save-mine"
        elif damage == "other-format manifest":
            document = json.loads((target / MANIFEST).read_text(encoding="utf-8"))
            document["format"] = "someone-else/1"
            (target / MANIFEST).write_text(json.dumps(document), encoding="utf-8")
            named = f"{MANIFEST} (not a manifest trainctl wrote"
        else:
            (target / MANIFEST).unlink()
            (target / MANIFEST).mkdir()
            named = f"{MANIFEST} (a directory, not a file trainctl wrote)"
        before = snapshot(tmp_path)
        with pytest.raises(TrainctlError, match="refusing to overwrite") as info:
            check_save_target(target)
        assert named in str(info.value) and str(target) in str(info.value)
        with pytest.raises(TrainctlError, match="refusing to overwrite"):
            simulated.save(target)
        assert snapshot(tmp_path) == before

    def test_many_foreign_entries_are_counted(self, tmp_path: Path) -> None:
        """The first few are named, the rest counted."""
        for i in range(9):
            (tmp_path / f"f{i}.txt").write_text("x")
        with pytest.raises(TrainctlError, match=r"f0\.txt, .*f4\.txt and 4 more"):
            check_save_target(tmp_path)

    def test_staging_left_by_a_killed_save_is_removed(self, tmp_path: Path,
                                                      hinf: ReportData) -> None:
        """A ``.trainctl-save-<hex>.tmp`` directory (SIGKILL mid-save) is the save's own."""
        target = hinf.save(tmp_path / "run")
        leftover = target / ".trainctl-save-0123456789ab.tmp"
        (leftover / "simulations").mkdir(parents=True)
        (leftover / MANIFEST).write_text("{}")
        hinf.save(target)
        assert temporary_entries(tmp_path) == []
        assert_valid_save(target)

    def test_error_while_staging_keeps_the_earlier_save(
            self, tmp_path: Path, earlier_save: Path, simulated: ReportData,
            monkeypatch: pytest.MonkeyPatch) -> None:
        """A full disk (or Ctrl-C) while the new files are written: the old save is intact."""
        from trainctl.sim.results import SimulationResult

        before = snapshot(tmp_path)
        for failure in (OSError(errno.ENOSPC, "No space left on device"), KeyboardInterrupt()):
            def fail(*args: object, _failure: BaseException = failure,
                     **kwargs: object) -> None:
                raise _failure

            monkeypatch.setattr(SimulationResult, "save", fail)
            expected = KeyboardInterrupt if isinstance(failure, KeyboardInterrupt) else OutputError
            with pytest.raises(expected) as info:
                simulated.save(earlier_save)
            if expected is OutputError:
                assert str(earlier_save) in str(info.value)
                assert "No space left on device" in str(info.value)
                assert "the earlier save is unchanged" in str(info.value)
            assert snapshot(tmp_path) == before

    def test_first_save_interrupted_leaves_nothing(self, tmp_path: Path, simulated: ReportData,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
        """The directories a failed first save created are removed again."""
        from trainctl.sim.results import SimulationResult

        def interrupt(*args: object, **kwargs: object) -> None:
            raise KeyboardInterrupt

        monkeypatch.setattr(SimulationResult, "save", interrupt)
        with pytest.raises(KeyboardInterrupt):
            simulated.save(tmp_path / "new" / "run")
        assert list(tmp_path.iterdir()) == []

    def test_failed_rename_is_undone(self, tmp_path: Path, simulated: ReportData,
                                     hinf: ReportData, monkeypatch: pytest.MonkeyPatch) -> None:
        """A rename failing in the middle of the swap puts the earlier save back."""
        target = simulated.save(tmp_path / "run")
        before = snapshot(tmp_path)
        real_rename = os.rename
        calls: list[tuple[str, str]] = []

        def flaky(source: str, destination: str) -> None:
            calls.append((str(source), str(destination)))
            if len(calls) == 4:  # old entries moved aside, the first new one moving in
                raise OSError(errno.EIO, "Input/output error")
            real_rename(source, destination)

        monkeypatch.setattr(os, "rename", flaky)
        with pytest.raises(OutputError, match="Input/output error.*the earlier save is unchanged"):
            hinf.save(target)
        monkeypatch.setattr(os, "rename", real_rename)
        assert len(calls) > 4  # the undo renamed entries back
        assert snapshot(tmp_path) == before
        assert list(assert_valid_save(target).simulations) == ["decentralised"]

    def test_signal_during_the_swap_waits_for_it(self, tmp_path: Path, simulated: ReportData,
                                                 hinf: ReportData,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
        """SIGINT arriving mid-swap takes effect after it: a whole new save, no staging."""
        target = simulated.save(tmp_path / "run")
        real_rename = os.rename
        sent: list[bool] = []

        def signalling(source: str, destination: str) -> None:
            if not sent:
                sent.append(True)
                signal.raise_signal(signal.SIGINT)
            real_rename(source, destination)

        monkeypatch.setattr(os, "rename", signalling)
        with pytest.raises(KeyboardInterrupt):
            hinf.save(target)
        monkeypatch.setattr(os, "rename", real_rename)
        assert sent and signal.getsignal(signal.SIGINT) is signal.default_int_handler
        assert sorted(p.name for p in target.iterdir()) == sorted([MANIFEST, "scenario.toml"])
        assert assert_valid_save(target).scenario.source == "builtin:heavy-haul-hinf"
        assert temporary_entries(tmp_path) == []


# --------------------------------------------------------------------------- output targets


class TestOutputTargets:
    """-o: owners and modes kept through links; special files refused without blocking."""

    def _foreign_file(self, tmp_path: Path) -> tuple[Path, Path]:
        """``elsewhere/theirs.html`` (uid 1234, 0640) and ``out/link.html`` pointing at it."""
        elsewhere, out = tmp_path / "elsewhere", tmp_path / "out"
        elsewhere.mkdir()
        out.mkdir()
        theirs = elsewhere / "theirs.html"
        theirs.write_text("their page", encoding="utf-8")
        os.chown(theirs, OTHER_UID, OTHER_UID)
        os.chmod(theirs, 0o640)
        (out / "link.html").symlink_to(theirs)
        return theirs, out / "link.html"

    def _assert_owned_by_them(self, theirs: Path) -> None:
        st = os.stat(theirs)
        assert (st.st_uid, st.st_gid, stat.S_IMODE(st.st_mode)) == (OTHER_UID, OTHER_UID, 0o640)

    @pytest.mark.slow
    def test_export_through_a_link_keeps_owner_and_mode(self, tmp_path: Path) -> None:
        """export -o LINK --force replaces the file it points to; owner, group, mode stay."""
        theirs, link = self._foreign_file(tmp_path)
        result = cli("export", "crh2-dmpc", "-o", str(link), "--force", cwd=tmp_path)
        assert_ran(result)
        assert link.is_symlink() and os.readlink(link) == str(theirs)
        assert theirs.read_text(encoding="utf-8") == builtin_scenario_text("crh2-dmpc")
        self._assert_owned_by_them(theirs)
        assert temporary_entries(tmp_path) == []
        assert sorted(p.name for p in theirs.parent.iterdir()) == ["theirs.html"]

    @pytest.mark.slow
    def test_report_through_a_link_keeps_owner_and_mode(self, tmp_path: Path) -> None:
        """The issue's case: report -o out.html, a link to another user's file elsewhere."""
        theirs, link = self._foreign_file(tmp_path)
        result = cli("report", "heavy-haul-hinf", "-o", str(link), cwd=tmp_path)
        assert_ran(result)
        assert theirs.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
        self._assert_owned_by_them(theirs)
        assert temporary_entries(tmp_path) == []

    def test_other_users_file_refused_when_not_root(self, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
        """Without root the owner could not be kept: refused, the file untouched."""
        theirs, link = self._foreign_file(tmp_path)
        monkeypatch.setattr(os, "geteuid", lambda: 1000)
        before = snapshot(tmp_path)
        with pytest.raises(OutputError, match="belongs to another user \\(uid 1234\\)") as info:
            write_output("mine", link)
        assert str(link) in str(info.value)
        assert snapshot(tmp_path) == before

    def test_setgid_bit_kept(self, tmp_path: Path) -> None:
        """chown clears set-id bits; they are restored with the mode."""
        path = tmp_path / "page.html"
        path.write_text("old", encoding="utf-8")
        os.chown(path, OTHER_UID, OTHER_UID)
        os.chmod(path, 0o2664)
        write_text_atomic("new", path)
        st = os.stat(path)
        assert (st.st_uid, stat.S_IMODE(st.st_mode)) == (OTHER_UID, 0o2664)

    @pytest.mark.slow
    def test_fifo_without_reader_refused(self, tmp_path: Path) -> None:
        """-o FIFO with nobody reading: exit 2 at once, the pipe stays a pipe."""
        fifo = tmp_path / "pipe"
        os.mkfifo(fifo)
        result = cli("export", "crh2-dmpc", "-o", str(fifo), cwd=tmp_path, timeout=60)
        assert_refused(result, str(fifo), "no process is reading")
        assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe"]

    @pytest.mark.slow
    def test_dev_full_refused(self, tmp_path: Path) -> None:
        """/dev/full is a character device other than /dev/null: refused before any work."""
        if not Path("/dev/full").exists():
            pytest.skip("no /dev/full")
        result = cli("export", "crh2-dmpc", "-o", "/dev/full", cwd=tmp_path, timeout=60)
        assert_refused(result, "/dev/full", "character device")

    def test_device_nodes_and_sockets_refused(self, tmp_path: Path) -> None:
        """A full-device node (1:7) and a socket: refused, left as they are."""
        node = tmp_path / "full"
        try:
            os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 7))
        except OSError as exc:
            pytest.skip(f"cannot create a device node here ({exc})")
        sock = socket.socket(socket.AF_UNIX)
        try:
            sock.bind(str(tmp_path / "sock"))
            for path, kind in ((node, "character device"), (tmp_path / "sock", "socket")):
                with pytest.raises(OutputError, match=f"is a {kind}") as info:
                    write_output("x", path)
                assert str(path) in str(info.value)
        finally:
            sock.close()
        assert stat.S_ISCHR(os.lstat(node).st_mode)

    def test_full_disk_names_the_file(self, tmp_path: Path,
                                      monkeypatch: pytest.MonkeyPatch) -> None:
        """ENOSPC: the error names the file; the old content stays; no temporary file."""
        path = tmp_path / "page.html"
        path.write_text("the previous page", encoding="utf-8")

        def full(fd: int) -> None:
            raise OSError(errno.ENOSPC, "No space left on device")

        monkeypatch.setattr(os, "fsync", full)
        with pytest.raises(OutputError, match="No space left on device") as info:
            write_output("<html>new</html>", path)
        assert str(path) in str(info.value)
        assert path.read_text(encoding="utf-8") == "the previous page"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["page.html"]
        with pytest.raises(OutputError, match="nothing was written"):
            write_output("x", tmp_path / "new.html")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["page.html"]

    @pytest.mark.slow
    def test_full_disk_from_the_command(self, tmp_path: Path) -> None:
        """export -o FILE on a full disk (injected ENOSPC): exit 2, the file named, no temp."""
        code = ("import errno, os, sys\n"
                "def full(fd):\n"
                "    raise OSError(errno.ENOSPC, 'No space left on device')\n"
                "os.fsync = full\n"
                "from trainctl.cli.main import main\n"
                "sys.exit(main(sys.argv[1:]))\n")
        result = cli("export", "crh2-dmpc", "-o", "scenario.toml", cwd=tmp_path, code=code)
        assert_refused(result, "scenario.toml", "No space left on device")
        assert list(tmp_path.iterdir()) == []

    @pytest.mark.slow
    def test_full_standard_output(self, tmp_path: Path) -> None:
        """-o - with standard output on a full device: exit 2, standard output named."""
        if not Path("/dev/full").exists():
            pytest.skip("no /dev/full")
        env = dict(os.environ, PYTHONPATH=str(REPO))
        with open("/dev/full", "w") as full:
            result = subprocess.run([sys.executable, "-m", "trainctl", "export", "crh2-dmpc",
                                     "-o", "-"], stdout=full, stderr=subprocess.PIPE,
                                    text=True, env=env, cwd=tmp_path, timeout=120, check=False)
        assert_refused(result, "standard output", "No space left on device")
        assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- report --all


MARKED = '<!DOCTYPE html>\n<meta name="generator" content="trainctl">\n<p>an earlier page</p>\n'
"""The head of a page trainctl wrote (an earlier gallery's output, shortened)."""


class TestGallery:
    """report --all -o DIR replaces only the pages trainctl wrote; anything else is refused."""

    @pytest.fixture
    def one_builtin(self, monkeypatch: pytest.MonkeyPatch) -> str:
        """The gallery reduced to heavy-haul-hinf (a design review, no simulation)."""
        import trainctl.scenario as scenario_module

        chosen = [b for b in scenario_module.builtin_scenarios() if b.name == "heavy-haul-hinf"]
        assert len(chosen) == 1
        monkeypatch.setattr(scenario_module, "builtin_scenarios", lambda: chosen)
        return "heavy-haul-hinf"

    def _no_run(self, monkeypatch: pytest.MonkeyPatch) -> None:
        """Make any scenario run fail the test: a refusal must come before the work."""
        import trainctl.report.batch as batch

        def ran(*args: object, **kwargs: object) -> None:
            raise AssertionError("a scenario ran before the refusal")

        monkeypatch.setattr(batch, "run_report_data", ran)

    def test_users_index_refused_before_any_run(
        self, tmp_path: Path, one_builtin: str, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]
    ) -> None:
        """The issue's case: a user's index.html (and a page of a built-in's name) in DIR."""
        from trainctl.cli.main import main

        self._no_run(monkeypatch)
        out = tmp_path / "gallery"
        out.mkdir()
        (out / "index.html").write_text("<h1>my own index</h1>\n", encoding="utf-8")
        (out / f"{one_builtin}.html").write_text("my notes on the H-infinity design\n",
                                                 encoding="utf-8")
        (out / "notes.txt").write_text("keep me", encoding="utf-8")
        before = snapshot(tmp_path)
        assert main(["report", "--all", "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("trainctl: error: ") and "Traceback" not in err
        assert str(out) in err and "index.html" in err and f"{one_builtin}.html" in err
        assert "-o" in err and "move" in err
        assert "notes.txt" not in err  # a name the gallery does not write is no concern
        assert snapshot(tmp_path) == before

    def test_links_and_special_entries_refused(
        self, tmp_path: Path, one_builtin: str, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]
    ) -> None:
        """A link to a user's unmarked file, a broken link, a directory or a pipe of a page's
        name: refused (the output rules of -o), the link's target unchanged, no wait."""
        from trainctl.cli.main import main

        self._no_run(monkeypatch)
        elsewhere = tmp_path / "elsewhere"
        elsewhere.mkdir()
        (elsewhere / "mine.html").write_text("<p>mine</p>", encoding="utf-8")
        cases = {
            "link to an unmarked file": lambda p: p.symlink_to(elsewhere / "mine.html"),
            "broken link": lambda p: p.symlink_to(tmp_path / "nowhere"),
            "directory": lambda p: p.mkdir(),
            "pipe": lambda p: os.mkfifo(p),
        }
        for case, make in cases.items():
            out = tmp_path / case.replace(" ", "-")
            out.mkdir()
            make(out / "index.html")
            (out / f"{one_builtin}.html").write_text(MARKED, encoding="utf-8")
            before = snapshot(tmp_path)
            assert main(["report", "--all", "-o", str(out)]) == 2, case
            err = capsys.readouterr().err
            assert err.startswith("trainctl: error: ") and "Traceback" not in err, (case, err)
            assert "index.html" in err and f"{one_builtin}.html" not in err, (case, err)
            assert snapshot(tmp_path) == before, case

    def test_earlier_gallery_replaced(
        self, tmp_path: Path, one_builtin: str, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """An earlier gallery's pages (one through a link) are replaced; other files stay."""
        from trainctl.cli.main import main

        out, elsewhere = tmp_path / "gallery", tmp_path / "elsewhere"
        out.mkdir()
        elsewhere.mkdir()
        (out / "index.html").write_text(MARKED, encoding="utf-8")
        (elsewhere / "page.html").write_text(MARKED, encoding="utf-8")
        (out / f"{one_builtin}.html").symlink_to(elsewhere / "page.html")
        (out / "notes.txt").write_text("keep me", encoding="utf-8")
        (out / "crh2-dmpc.html").write_text("not in this gallery", encoding="utf-8")
        stale = out / ".index.html.0123456789ab.tmp"  # left by a killed gallery: empty
        stale.write_bytes(b"")
        theirs = out / ".index.html.abcdefabcdef.tmp"  # same pattern, a user's content
        theirs.write_text("user data", encoding="utf-8")
        assert main(["report", "--all", "-o", str(out)]) == 0
        assert "Traceback" not in capsys.readouterr().err
        index = (out / "index.html").read_text(encoding="utf-8")
        assert index != MARKED and f'href="{one_builtin}.html"' in index
        assert (out / f"{one_builtin}.html").is_symlink()
        page = (elsewhere / "page.html").read_text(encoding="utf-8")
        assert page != MARKED and 'content="trainctl"' in page
        assert (out / "notes.txt").read_text(encoding="utf-8") == "keep me"
        assert (out / "crh2-dmpc.html").read_text(encoding="utf-8") == "not in this gallery"
        assert not stale.exists()
        assert theirs.read_text(encoding="utf-8") == "user data"
        assert sorted(p.name for p in elsewhere.iterdir()) == ["page.html"]
        leftover = [n for n in temporary_entries(tmp_path) if n != f"gallery/{theirs.name}"]
        assert leftover == []

    def test_file_appearing_during_the_runs_is_kept(
        self, tmp_path: Path, one_builtin: str, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]
    ) -> None:
        """An index.html a user writes while the scenarios run is checked again: kept, exit 2."""
        import trainctl.report.batch as batch
        from trainctl.cli.main import main

        out = tmp_path / "gallery"
        out.mkdir()
        real = batch.run_report_data

        def run_then_write(*args: object, **kwargs: object) -> object:
            for data in real(*args, **kwargs):  # type: ignore[arg-type]
                (out / "index.html").write_text("written meanwhile", encoding="utf-8")
                yield data

        monkeypatch.setattr(batch, "run_report_data", run_then_write)
        assert main(["report", "--all", "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("trainctl: error: ") and "index.html" in err
        assert (out / "index.html").read_text(encoding="utf-8") == "written meanwhile"
        assert temporary_entries(tmp_path) == []


# --------------------------------------------------------------------------- inputs


class TestInputs:
    """A pipe, socket or device given as an input file is refused without blocking."""

    @pytest.mark.slow
    def test_fifo_as_the_scenario_file(self, tmp_path: Path) -> None:
        """analyse FIFO: exit 2 at once, naming the path (no writer needed)."""
        os.mkfifo(tmp_path / "s.toml")
        for command in (["analyse", "./s.toml"], ["report", "./s.toml", "-o", "r.html"],
                        ["sweep", "./s.toml", "--dry-run"]):
            result = cli(*command, cwd=tmp_path, timeout=60)
            assert_refused(result, "./s.toml", "a named pipe, not a regular file")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]

    def test_fifo_through_the_api(self, tmp_path: Path) -> None:
        """load_scenario, ReportData.load and write_output on pipes: refused, not waited on."""
        fifo = tmp_path / "s.toml"
        os.mkfifo(fifo)
        with pytest.raises(TrainctlError, match="a named pipe, not a regular file") as info:
            load_scenario(fifo)
        assert str(fifo) in str(info.value)
        with pytest.raises(OutputError, match="no process is reading"):
            write_output("x", fifo)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]

    def test_socket_as_the_scenario_file(self, tmp_path: Path) -> None:
        """A socket: refused by the API, naming it."""
        sock = socket.socket(socket.AF_UNIX)
        try:
            sock.bind(str(tmp_path / "s.toml"))
            with pytest.raises(TrainctlError, match="a socket, not a regular file"):
                load_scenario(tmp_path / "s.toml")
        finally:
            sock.close()

    @pytest.mark.slow
    @pytest.mark.parametrize("member", [
        "scenario.toml", MANIFEST, "simulations/decentralised/result.json",
        "simulations/decentralised/arrays.npz"])
    def test_fifo_inside_a_saved_run(self, tmp_path: Path, simulated: ReportData,
                                     member: str) -> None:
        """report RUN where one of its files is a pipe: exit 2, that file named, no wait."""
        run = simulated.save(tmp_path / "run")
        (run / member).unlink()
        os.mkfifo(run / member)
        result = cli("report", "run", "-o", "r.html", cwd=tmp_path, timeout=120)
        assert_refused(result, "run")
        if member != MANIFEST:  # without its manifest the directory is no saved run at all
            assert f"{member}: " in result.stderr and "named pipe" in result.stderr
        assert not (tmp_path / "r.html").exists()
        assert temporary_entries(tmp_path) == []

    @pytest.mark.slow
    def test_fifo_inside_a_sweep_store(self, tmp_path: Path) -> None:
        """A store's table or a point's summary as a pipe: refused or skipped, never waited on."""
        from trainctl.sweep import SweepStore, sweep_scenario

        store = tmp_path / "store"
        sweep_scenario("crh2-dmpc", store, axes=["controller.r_per_kn2=1,10"], simulate=False)
        summary = next((store / "points").glob("*/summary.json"))
        summary.unlink()
        os.mkfifo(summary)
        with pytest.raises(TrainctlError, match="named pipe") as info:
            SweepStore.load(store).summary(summary.parent.name)
        assert str(summary) in str(info.value)
        (store / "rows.parquet").unlink()
        os.mkfifo(store / "rows.parquet")
        result = cli("report", "store", "-o", "r.html", cwd=tmp_path, timeout=120)
        assert_refused(result, "store")
        assert stat.S_ISFIFO(os.lstat(summary).st_mode)
        assert not (tmp_path / "r.html").exists()
