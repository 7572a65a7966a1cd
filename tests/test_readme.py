# Every ```python block of README.md runs verbatim, each on its own, in a fresh directory.
"""The README's Python examples run as printed.

Each ``python`` block is self-contained (its own imports): it is written to a
file in a temporary directory and run there by a fresh interpreter, as a user
would paste it into a script (``if __name__ == "__main__"`` guards and worker
processes included). Shell blocks are not run.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
BLOCK = re.compile(r"^```python\n(.*?)^```$", re.M | re.S)


def python_blocks() -> list[tuple[int, str]]:
    """(line number, code) of every ```python block of the README, in order."""
    text = README.read_text(encoding="utf-8")
    return [(text.count("\n", 0, m.start()) + 1, m.group(1)) for m in BLOCK.finditer(text)]


BLOCKS = python_blocks()


def test_the_readme_has_python_examples() -> None:
    """The extraction finds the examples (a changed fence would silently test nothing)."""
    assert len(BLOCKS) >= 8
    assert any("consensus_loop" in code for _, code in BLOCKS)  # the robust-H∞ example


@pytest.mark.slow
@pytest.mark.e2e  # ten fresh interpreters, each importing trainctl: the README run as printed
@pytest.mark.parametrize(("line", "code"), BLOCKS, ids=[f"line{line}" for line, _ in BLOCKS])
def test_block_runs_verbatim(tmp_path: Path, line: int, code: str) -> None:
    """The block, as printed, runs without error in an empty directory."""
    script = tmp_path / "example.py"
    script.write_text(code, encoding="utf-8")
    env_python = sys.executable
    result = subprocess.run([env_python, str(script)],
                            cwd=tmp_path, capture_output=True, text=True, timeout=300,
                            check=False, env=_env())
    assert result.returncode == 0, f"README.md line {line}:\n{result.stderr[-3000:]}"
    assert "Traceback" not in result.stderr


def _env() -> dict[str, str]:
    """The test's environment, with the checkout first on the path and a headless backend."""
    import os

    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p)
    return {**os.environ, "PYTHONPATH": path, "MPLBACKEND": "Agg"}
