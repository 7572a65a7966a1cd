# Killing `trainctl report` never leaves a partial report behind.
"""Interrupt a real ``trainctl report`` process at its most delicate moment.

The child is the real CLI; a small start-up hook makes ``os.fsync`` announce
itself on stderr and pause, so the test can signal the process exactly while
the new page sits, complete but not yet renamed, in its temporary file. The
signal then decides: SIGTERM and SIGINT unwind (the temporary file is
removed), SIGKILL cannot (a stray ``.tmp`` may stay, never the output path).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[1]
PREVIOUS = "<!DOCTYPE html><p>the previous report</p>\n"

_HOOK = """
import os, sys, time
_real_fsync = os.fsync
def _announced_fsync(fd):
    sys.stderr.write("FSYNC\\n"); sys.stderr.flush()
    time.sleep(60)
    _real_fsync(fd)
os.fsync = _announced_fsync
from trainctl.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


def _start(out: Path, *, hook: bool) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    plain = "import sys; from trainctl.cli.main import main; sys.exit(main(sys.argv[1:]))"
    code = _HOOK if hook else plain
    return subprocess.Popen(
        [sys.executable, "-c", code, "report", "heavy-haul-hinf", "-o", str(out)],
        cwd=out.parent, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


def _wait_for_fsync(process: subprocess.Popen[str]) -> None:
    assert process.stderr is not None
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        line = process.stderr.readline()
        if line.strip() == "FSYNC":
            return
        if not line and process.poll() is not None:
            break
    process.kill()
    pytest.fail("the report process never reached its write")


@pytest.mark.parametrize("signum", [
    pytest.param(signal.SIGTERM, id="SIGTERM"),
    # SIGINT unwinds as SIGTERM does (tests/test_no_hang.py: both, in process): e2e
    pytest.param(signal.SIGINT, id="SIGINT", marks=pytest.mark.e2e),
    pytest.param(signal.SIGKILL, id="SIGKILL")])
def test_killed_during_write_keeps_previous_report(tmp_path: Path, signum: int) -> None:
    """Signalled mid-write, the output keeps the previous report whole."""
    out = tmp_path / "report.html"
    out.write_text(PREVIOUS, encoding="utf-8")
    process = _start(out, hook=True)
    _wait_for_fsync(process)
    assert any(p.name.endswith(".tmp") for p in tmp_path.iterdir())  # mid-write indeed
    process.send_signal(signum)
    _, err = process.communicate(timeout=60)
    assert out.read_text(encoding="utf-8") == PREVIOUS
    leftovers = [p.name for p in tmp_path.iterdir() if p.name != "report.html"]
    if signum == signal.SIGKILL:
        assert process.returncode == -signal.SIGKILL
    else:
        assert process.returncode == 128 + signum, err  # 130 SIGINT, 143 SIGTERM
        assert "interrupted" in err and "Traceback" not in err
        assert leftovers == []


def test_killed_early_writes_nothing(tmp_path: Path) -> None:
    """Killed before the write (while it computes), no output file appears at all."""
    out = tmp_path / "report.html"
    process = _start(out, hook=False)
    time.sleep(0.5)
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=60)
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.suffix == ".html"]


def test_uninterrupted_run_completes(tmp_path: Path) -> None:
    """Control: the same command left alone replaces the previous report with a full page."""
    out = tmp_path / "report.html"
    out.write_text(PREVIOUS, encoding="utf-8")
    process = _start(out, hook=False)
    _, err = process.communicate(timeout=300)
    assert process.returncode == 0, err
    html = out.read_text(encoding="utf-8")
    assert html.startswith("<!DOCTYPE html>") and html.rstrip().endswith("</html>")
    assert [p.name for p in tmp_path.iterdir()] == ["report.html"]
