# Output targets: files replaced atomically, devices and pipes written through, others refused.
"""trainctl.report.output and the -o options of report and export."""

from __future__ import annotations

import os
import socket
import stat
import threading
from pathlib import Path

import pytest

from trainctl.cli.main import main
from trainctl.report.output import (
    OutputError,
    output_target,
    write_output,
    write_text_atomic,
)
from trainctl.scenario import builtin_scenario_text


@pytest.fixture
def char_device(tmp_path: Path) -> Path:
    """A character device node like /dev/null, made in the temporary directory."""
    path = tmp_path / "null"
    try:
        os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except (PermissionError, AttributeError, OSError) as exc:
        pytest.skip(f"cannot create a device node here ({exc})")
    return path


def assert_is_device(path: Path) -> None:
    """The node is still the character device 1:3."""
    st = os.lstat(path)
    assert stat.S_ISCHR(st.st_mode) and os.major(st.st_rdev) == 1 and os.minor(st.st_rdev) == 3


class TestTargets:
    """output_target() classifies before anything is written."""

    def test_kinds(self, tmp_path: Path, char_device: Path) -> None:
        """'-', a device, a new file, an existing file, a directory with a default name."""
        assert output_target("-").is_stdout
        assert output_target(char_device).kind == "stream"
        assert output_target(tmp_path / "new.html").kind == "file"
        (tmp_path / "old.html").write_text("x", encoding="utf-8")
        assert output_target(tmp_path / "old.html").exists
        target = output_target(f"{tmp_path}/sub/", default_name="a.html")
        assert target.kind == "file" and target.path == tmp_path / "sub" / "a.html"
        assert output_target(tmp_path, default_name="a.html").path == tmp_path / "a.html"
        assert output_target("/dev/stdout").is_stdout

    def test_refusals(self, tmp_path: Path) -> None:
        """A directory without a default name, a file given as dir/, a socket, a broken link."""
        with pytest.raises(OutputError, match="is a directory"):
            output_target(tmp_path)
        (tmp_path / "f").write_text("x", encoding="utf-8")
        with pytest.raises(OutputError, match="is not a directory"):
            output_target(f"{tmp_path}/f/", default_name="a.html")
        sock = socket.socket(socket.AF_UNIX)
        try:
            sock.bind(str(tmp_path / "sock"))
            with pytest.raises(OutputError, match="is a socket; trainctl writes only to"):
                output_target(tmp_path / "sock")
        finally:
            sock.close()
        (tmp_path / "dangling").symlink_to(tmp_path / "missing")
        with pytest.raises(OutputError, match="broken symbolic link"):
            output_target(tmp_path / "dangling")

    def test_atomic_write_keeps_links_and_modes(self, tmp_path: Path) -> None:
        """A link to a file stays a link; the replaced file keeps its permissions."""
        real = tmp_path / "real.html"
        real.write_text("old", encoding="utf-8")
        real.chmod(0o640)
        link = tmp_path / "link.html"
        link.symlink_to(real.name)
        write_output("new", link)
        assert link.is_symlink() and real.read_text(encoding="utf-8") == "new"
        assert stat.S_IMODE(real.stat().st_mode) == 0o640
        assert sorted(p.name for p in tmp_path.iterdir()) == ["link.html", "real.html"]

    def test_atomic_write_never_replaces_a_device(self, char_device: Path) -> None:
        """write_text_atomic refuses a device instead of renaming a file over it."""
        with pytest.raises(OutputError, match="not a regular file"):
            write_text_atomic("x", char_device)
        assert_is_device(char_device)

    def test_fifo_written_through(self, tmp_path: Path) -> None:
        """A named pipe that a process reads is opened and written, not replaced."""
        fifo = tmp_path / "pipe"
        os.mkfifo(fifo)
        reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # the reader is there first
        got: list[bytes] = []

        def read_all() -> None:
            os.set_blocking(reader, True)
            with os.fdopen(reader, "rb") as handle:
                got.append(handle.read())

        write_output("through the pipe", fifo)
        thread = threading.Thread(target=read_all)
        thread.start()
        thread.join(timeout=10)
        assert got == [b"through the pipe"]
        assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


class TestReportOutput:
    """report -o with a device, a directory and standard output."""

    def test_character_device_written_through(self, char_device: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
        """report -o DEVICE writes through and leaves the node in place."""
        assert main(["report", "heavy-haul-hinf", "-o", str(char_device)]) == 0
        assert_is_device(char_device)
        assert capsys.readouterr().out.startswith(f"wrote {char_device} (")
        assert sorted(p.name for p in char_device.parent.iterdir()) == ["null"]

    def test_directory_with_slash(self, tmp_path: Path) -> None:
        """report -o dir/ writes dir/<name>.html, creating the directory."""
        assert main(["report", "heavy-haul-hinf", "-o", f"{tmp_path}/new/"]) == 0
        assert [p.name for p in (tmp_path / "new").iterdir()] == ["heavy-haul-hinf.html"]

    def test_standard_output(self, capsys: pytest.CaptureFixture[str]) -> None:
        """report -o - prints the page on stdout and its summary on stderr."""
        assert main(["report", "heavy-haul-hinf", "-o", "-"]) == 0
        captured = capsys.readouterr()
        assert captured.out.startswith("<!DOCTYPE html>")
        assert captured.out.rstrip().endswith("</html>")
        assert captured.err.startswith("wrote - (")

    def test_socket_refused_before_running(self, tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
        """An output that cannot take the page is refused before the analysis runs."""
        def refuse(*args: object, **kwargs: object) -> None:
            raise AssertionError("nothing may run")

        monkeypatch.setattr("trainctl.report.batch.run_report_data", refuse)
        sock = socket.socket(socket.AF_UNIX)
        try:
            sock.bind(str(tmp_path / "sock"))
            assert main(["report", "heavy-haul-hinf", "-o", str(tmp_path / "sock")]) == 2
        finally:
            sock.close()
        assert "is a socket" in capsys.readouterr().err


class TestExportOutput:
    """export -o / --force with devices and directories."""

    def test_device_never_replaced(self, char_device: Path) -> None:
        """export to a device needs no --force and, with --force, still writes through."""
        assert main(["export", "crh2-dmpc", "-o", str(char_device)]) == 0
        assert main(["export", "crh2-dmpc", "-o", str(char_device), "--force"]) == 0
        assert_is_device(char_device)

    def test_directory_and_force(self, tmp_path: Path,
                                 capsys: pytest.CaptureFixture[str]) -> None:
        """export -o dir/ writes NAME.toml there; an existing file needs --force."""
        assert main(["export", "crh2-dmpc", "-o", f"{tmp_path}/"]) == 0
        path = tmp_path / "crh2-dmpc.toml"
        assert path.read_text(encoding="utf-8") == builtin_scenario_text("crh2-dmpc")
        capsys.readouterr()
        assert main(["export", "crh2-dmpc", "-o", f"{tmp_path}/"]) == 2
        assert "--force" in capsys.readouterr().err
        assert main(["export", "crh2-dmpc", "-o", str(path), "--force"]) == 0

    def test_dev_stdout_is_standard_output(self, capsys: pytest.CaptureFixture[str]) -> None:
        """/dev/stdout means standard output (Python's), not a file to replace."""
        assert main(["export", "heavy-haul-hinf", "-o", "/dev/stdout"]) == 0
        captured = capsys.readouterr()
        assert captured.out == builtin_scenario_text("heavy-haul-hinf")
        assert captured.err == ""  # as with -o -: only the data
