# Debian's headless Chromium for the page tests (test_browser, test_docs_site).
"""Find headless Chromium, load a page and collect its console messages.

Chromium logs every console message (errors, uncaught exceptions, blocked
loads reported by the page) to stderr as ``...:CONSOLE:...`` lines when run
with ``--enable-logging=stderr``; a clean page logs none.

Outside CI a missing browser skips the calling test with a visible reason;
with ``CI=true`` it is a failure (``.ci/run`` installs ``chromium``).
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def browser() -> str:
    """The path of a Chromium executable; skip (or fail under ``CI=true``) without one."""
    for name in CANDIDATES:
        found = shutil.which(name)
        if found:
            return found
    reason = ("no headless Chromium found (tried " + ", ".join(CANDIDATES) +
              "); install Debian's 'chromium' to run the browser test")
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(reason + " — required in CI (CI=true)")
    pytest.skip(reason)


def command(page: Path, profile: Path, width: int, height: int, *extra: str) -> list[str]:
    """The command line loading ``page`` headless in a ``width`` × ``height`` window."""
    line = [
        browser(), "--headless", "--disable-gpu", "--no-first-run", "--no-default-browser-check",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--disable-extensions", "--hide-scrollbars", "--enable-logging=stderr", "--v=0",
        f"--user-data-dir={profile}", f"--window-size={width},{height}", *extra,
        page.resolve().as_uri(),
    ]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        line.insert(1, "--no-sandbox")  # Chromium refuses to run as root with the sandbox
    return line


def console(stderr: str) -> list[str]:
    """The console messages in Chromium's stderr."""
    return [line for line in stderr.splitlines() if ":CONSOLE" in line]


def console_of(page: Path, profile: Path, *, width: int = 1280, height: int = 900) -> list[str]:
    """Load ``page``, let its scripts run (5 s of virtual time), return its console messages."""
    result = subprocess.run(
        command(page, profile, width, height, "--virtual-time-budget=5000", "--dump-dom"),
        capture_output=True, text=True, timeout=180, check=False)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "</html>" in result.stdout, "Chromium printed no document"
    return console(result.stderr)
