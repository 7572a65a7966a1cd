# Which modules a command loads: the light commands import no solver, plotting or python-control.
"""The import graph of the light commands, read from ``python -X importtime``.

``trainctl --help``, ``list``, ``schema``, ``export``, ``sweep --dry-run`` and
loading a scenario need none of the solvers (cvxpy, DAQP, OSQP, Clarabel), matplotlib,
python-control (which imports ``scipy.signal`` and ``scipy.stats``), Jinja,
pandas, pyarrow or Dask: each runs in a fresh interpreter under ``-X
importtime`` (every module it imports is one line on stderr), must do its job,
and none of those modules may be among the lines. What is measured is which
modules load, never how long they take. The stage packages re-export their
names on first use (:func:`trainctl._lazy_exports`); the names they list for
the type checker (``if TYPE_CHECKING:``) and the ones they import at run time
must agree.
"""

from __future__ import annotations

import ast
import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

HEAVY = (
    "cvxpy", "daqp", "osqp", "clarabel", "scs",   # solvers
    "matplotlib",
    "control", "scipy.signal", "scipy.stats",    # python-control imports both
    "jinja2", "pandas", "pyarrow", "dask", "distributed",
)
"""Modules (and their submodules) a light command must not import."""

LOAD = ("from trainctl.scenario import load_scenario; "
        "print(type(load_scenario('crh2-dmpc')).__name__)")

COMMANDS: dict[str, tuple[list[str], str]] = {
    "--help": (["--help"], "usage: trainctl"),
    "list": (["list"], "crh2-dmpc"),
    "schema": (["schema"], '"$schema"'),
    "schema --markdown": (["schema", "--markdown"], "|"),
    "export": (["export", "crh2-dmpc", "-o", "-"], "[train"),
    "sweep --dry-run": (["sweep", "crh2-dmpc", "--set", "controller.r_per_kn2=1,10", "--dry-run"],
                        "controller.r_per_kn2"),
    "report --help": (["report", "--help"], "usage: trainctl report"),
    "load_scenario": ([], "Scenario"),
    "import trainctl": ([], "0."),
}
"""Command -> (``trainctl`` arguments, a fragment its stdout shows when it worked)."""

SNIPPETS = {"load_scenario": LOAD,
            "import trainctl": "import trainctl; print(trainctl.__version__)"}
"""The commands that are Python code rather than ``trainctl`` arguments."""

_AT_EXIT = ("import atexit, sys; atexit.register(lambda: print('MODULES:', *sys.modules, "
            "file=sys.stderr)); ")
"""Prints the modules loaded at exit: ``-X importtime`` misses ``importlib.import_module``."""


def imported_modules(code: str, cwd: Path) -> tuple[subprocess.CompletedProcess[str], set[str]]:
    """Run ``python -X importtime -c CODE`` on this tree: the process, the modules it imported."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    found = subprocess.run([sys.executable, "-X", "importtime", "-c", _AT_EXIT + code], cwd=cwd,
                           env=env, capture_output=True, text=True, timeout=300, check=False)
    logged, at_exit = set(), set()
    for line in found.stderr.splitlines():
        # "import time: self [us] | cumulative | name", the name indented by its depth
        if line.startswith("import time:") and line.count("|") == 2:
            name = line.rsplit("|", 1)[1].strip()
            if name != "imported package":   # the header line
                logged.add(name)
        elif line.startswith("MODULES: "):
            at_exit.update(line.split()[1:])
    assert "trainctl" in logged or found.returncode != 0   # -X importtime did log
    return found, logged | at_exit


def trainctl_code(args: list[str]) -> str:
    """Python code that runs ``trainctl ARGS`` as ``python -m trainctl`` does."""
    return (f"import runpy; sys.argv = ['trainctl', *{args!r}]; "
            "runpy.run_module('trainctl', run_name='__main__', alter_sys=True)")


def command_code(command: str) -> str:
    """The Python code that runs ``command`` of :data:`COMMANDS`."""
    return SNIPPETS.get(command) or trainctl_code(COMMANDS[command][0])


def heavy(modules: set[str]) -> list[str]:
    """The modules of :data:`HEAVY` (or their submodules) among ``modules``."""
    return sorted(m for m in modules if any(m == h or m.startswith(h + ".") for h in HEAVY))


@pytest.mark.slow
@pytest.mark.parametrize("command", list(COMMANDS))
def test_light_commands_import_nothing_heavy(command: str, tmp_path: Path) -> None:
    """The command works and imports none of :data:`HEAVY`."""
    found, modules = imported_modules(command_code(command), tmp_path)
    shows = COMMANDS[command][1]
    assert found.returncode == 0, found.stderr[-3000:]
    assert shows in found.stdout
    assert "trainctl" in modules   # the graph was read
    assert heavy(modules) == []
    if command == "schema":
        assert json.loads(found.stdout)["$schema"]


@pytest.mark.slow
def test_the_graph_sees_a_heavy_import(tmp_path: Path) -> None:
    """The check can fail: an analysis module imports python-control and, through it, the rest."""
    found, modules = imported_modules("import trainctl.analysis.stability", tmp_path)
    assert found.returncode == 0, found.stderr[-3000:]
    assert {"control", "scipy.signal", "scipy.stats"} <= set(heavy(modules))


def lazy_packages() -> list[str]:
    """The packages of trainctl that re-export through :func:`trainctl._lazy_exports`."""
    found = []
    for init in sorted((REPO / "trainctl").rglob("__init__.py")):
        if "_lazy_exports(__name__" in init.read_text(encoding="utf-8"):
            found.append(".".join(init.parent.relative_to(REPO).parts))
    return found


def type_checking_exports(package: str) -> dict[str, str]:
    """Name -> module of the ``from M import N as N`` lines under ``if TYPE_CHECKING:``."""
    init = REPO.joinpath(*package.split("."), "__init__.py")
    tree = ast.parse(init.read_text(encoding="utf-8"))
    names: dict[str, str] = {}
    for node in tree.body:
        if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING":
            for stmt in node.body:
                if isinstance(stmt, ast.ImportFrom) and stmt.module and stmt.level == 0:
                    names.update((alias.asname or alias.name, stmt.module)
                                 for alias in stmt.names)
    return names


def test_lazy_packages_are_found() -> None:
    """The stage packages that re-export lazily include the ones the light commands pass."""
    assert {"trainctl", "trainctl.models", "trainctl.analysis", "trainctl.run",
            "trainctl.report"} <= set(lazy_packages())


@pytest.mark.parametrize("package", lazy_packages())
def test_lazy_exports_match_the_type_checking_names(package: str) -> None:
    """Each lazy package imports at run time what its TYPE_CHECKING block names, from there."""
    module = importlib.import_module(package)
    exports = type_checking_exports(package)
    lazy = getattr(module, "_EXPORTS", None)
    if lazy is not None:   # the root package passes its one name inline
        assert dict(lazy) == exports
    for name, home in exports.items():
        assert getattr(module, name) is getattr(importlib.import_module(home), name), name
        assert name in dir(module)
    assert set(getattr(module, "__all__", ())) <= set(exports) | set(dir(module))
    with pytest.raises(AttributeError):
        _ = module.no_such_name


@pytest.mark.slow
def test_a_submodule_import_keeps_the_re_exported_function(tmp_path: Path) -> None:
    """``trainctl.analysis.string_stability`` is the function, also after its module is imported."""
    code = ("import trainctl.analysis.string_stability, trainctl.analysis as a; "
            "from trainctl.analysis import string_stability as f; "
            "print(type(a.string_stability).__name__, "
            "f is a.string_stability.__globals__['string_stability'])")
    env = dict(os.environ, PYTHONPATH=str(REPO))
    found = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=300, check=True)
    assert found.stdout.split() == ["function", "True"]


REPORT_UNUSED = ("pandas", "pyarrow", "dask", "distributed", "trainctl.sweep",
                 "trainctl.scenario.sweep_definition")
"""What the default report (one scenario, simulated in this process) does not use."""


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
@pytest.mark.slow
def test_the_default_report_imports_no_sweep_or_dataframe(tmp_path: Path) -> None:
    """``trainctl report`` of a scenario loads neither the sweep machinery nor pandas/Arrow/Dask."""
    out = tmp_path / "report.html"
    found, modules = imported_modules(trainctl_code(["report", "-o", str(out)]), tmp_path)
    assert found.returncode == 0, found.stderr[-3000:]
    assert out.stat().st_size > 0
    assert {"control", "matplotlib", "trainctl.report.render"} <= modules   # it did the work
    assert sorted(m for m in modules
                  if any(m == u or m.startswith(u + ".") for u in REPORT_UNUSED)) == []
