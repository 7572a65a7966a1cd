# Lint gate: ruff and mypy must be clean, so `make test` (and CI) enforces them.
"""``ruff check .`` and ``mypy`` (configured in pyproject.toml) exit with status 0."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


def _run_module(module: str, *args: str) -> subprocess.CompletedProcess[str]:
    """Run ``python -m module args...`` from the repository root, or skip if not installed."""
    if importlib.util.find_spec(module) is None:
        pytest.skip(
            f"{module} is not installed in {sys.executable}; "
            "install the test extras with pip install -e '.[test]'"
        )
    return subprocess.run(
        [sys.executable, "-m", module, *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


def _report(result: subprocess.CompletedProcess[str]) -> str:
    return (
        f"{' '.join(result.args)} exited with status {result.returncode}\n"
        f"--- stdout\n{result.stdout}\n--- stderr\n{result.stderr}"
    )


def test_ruff_check_is_clean() -> None:
    """``ruff check .`` reports no errors (the rule set is in pyproject.toml)."""
    result = _run_module("ruff", "check", ".")
    assert result.returncode == 0, _report(result)


@pytest.mark.e2e  # mypy --strict of the whole package: minutes
def test_mypy_is_clean() -> None:
    """``mypy`` reports no errors on the files listed in pyproject.toml."""
    result = _run_module("mypy")
    assert result.returncode == 0, _report(result)
