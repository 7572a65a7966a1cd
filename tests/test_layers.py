# The import contracts of pyproject.toml ([tool.importlinter]) hold, and they can fail.
"""The layering of trainctl, checked by import-linter.

The contracts (``[tool.importlinter]`` in ``pyproject.toml``): the stages
import only earlier stages, the worker pool sits above the process guards,
and the controller families are independent of each other. The package
passes them; a copy of it with a deliberately backward import (a model
importing the report) and a cross-family import (MPC importing LQR) breaks
the stage contract and the family contract, and the failure names both.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CONFIG = ROOT / "pyproject.toml"
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(not LINT_IMPORTS.exists(), reason="import-linter is not installed "
                       "(pip install -e '.[test]')"),
]


def lint_imports(package_parent: Path, cache: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` on the contracts of pyproject.toml, trainctl found in ``package_parent``."""
    env = {**os.environ, "PYTHONPATH": str(package_parent)}
    return subprocess.run(
        [str(LINT_IMPORTS), "--no-logo", "--cache-dir", str(cache), str(CONFIG)],
        cwd=package_parent, env=env, capture_output=True, text=True, timeout=300, check=False)


def test_contracts_pass(tmp_path: Path) -> None:
    """The package as it is keeps every contract."""
    found = lint_imports(ROOT, tmp_path / "cache")
    assert found.returncode == 0, found.stdout + found.stderr
    assert "0 broken" in found.stdout


def test_backward_imports_break_the_contracts(tmp_path: Path) -> None:
    """A stage importing a later one, and a family importing another, fail by name."""
    copy = tmp_path / "src"
    shutil.copytree(ROOT / "trainctl", copy / "trainctl",
                    ignore=shutil.ignore_patterns("__pycache__", "builtin_analyses"))
    (copy / "trainctl" / "models" / "_backward.py").write_text(
        '"""A model importing the report: backward."""\n\nimport trainctl.report  # noqa: F401\n')
    (copy / "trainctl" / "controllers" / "mpc" / "_cross.py").write_text(
        '"""MPC importing LQR: across families."""\n\n'
        'import trainctl.controllers.lqr  # noqa: F401\n')
    found = lint_imports(copy, tmp_path / "cache")
    assert found.returncode != 0
    out = " ".join(found.stdout.split())  # import-linter wraps long lines
    assert "Stages import only earlier stages BROKEN" in out
    assert "Controller families are independent of each other BROKEN" in out
    assert "trainctl.models._backward -> trainctl.report" in out
    assert "trainctl.controllers.mpc._cross -> trainctl.controllers.lqr" in out
