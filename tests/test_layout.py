# The package's layout: no family's vocabulary outside its folder.
"""Outside ``trainctl/controllers/<family>/`` no module names a family's strategy or check.

What a stage asks of a family goes through the family's hooks
(:class:`trainctl.registry.ControllerFamily`,
:class:`trainctl.controllers.hooks.FamilyHooks`), never through a string that
only one family knows. The scan reads every module's AST: a string constant
(docstrings aside) equal to a built-in family's strategy or check name fails.
Family names themselves are allowed where the registry lists its module paths
(``trainctl/registry.py``).
"""

from __future__ import annotations

import ast
from collections.abc import Iterable, Iterator
from pathlib import Path

from trainctl.registry import FAMILY_MODULES, family_names, get_family

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "trainctl"
FAMILY_FOLDERS = tuple(PACKAGE.joinpath(*module.split(".")[1:]) for module in
                       FAMILY_MODULES.values())


def family_vocabulary() -> set[str]:
    """Every built-in family's strategy and check names."""
    names: set[str] = set()
    for name in family_names():
        family = get_family(name)
        names.update(family.strategies)
        names.update(family.check_names)
        names.update(getattr(family, "trajectory_check_names", ()))
    return names


def _docstrings(tree: ast.AST) -> set[int]:
    """ids of the docstring constants of a module, its classes and functions."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    # A bare string after an assignment documents it (attribute docstrings).
    for node in ast.walk(tree):
        for field in ("body", "orelse", "finalbody"):
            stmts = getattr(node, field, None)
            if not isinstance(stmts, list):
                continue
            for before, stmt in zip(stmts, stmts[1:], strict=False):
                if (isinstance(before, ast.Assign | ast.AnnAssign) and isinstance(stmt, ast.Expr)
                        and isinstance(stmt.value, ast.Constant)):
                    out.add(id(stmt.value))
    return out


def named_vocabulary(source: str, vocabulary: Iterable[str]) -> Iterator[tuple[int, str]]:
    """(line, name) for each string constant of ``source`` that is a name of ``vocabulary``.

    Docstrings are not code and are skipped.
    """
    words = set(vocabulary)
    tree = ast.parse(source)
    skip = _docstrings(tree)
    for node in ast.walk(tree):
        if (isinstance(node, ast.Constant) and isinstance(node.value, str)
                and id(node) not in skip and node.value in words):
            yield node.lineno, node.value


def scanned_modules() -> Iterator[Path]:
    """Every module of trainctl outside the family folders."""
    for path in sorted(PACKAGE.rglob("*.py")):
        if not any(path.is_relative_to(folder) for folder in FAMILY_FOLDERS):
            yield path


REGISTRY = PACKAGE / "registry.py"
"""The registry names the families (a family's name may also be one of its strategies')."""


def test_no_family_names_outside_families() -> None:
    vocabulary = family_vocabulary()
    found = [f"{path.relative_to(ROOT)}:{line}: {word!r}"
             for path in scanned_modules()
             for line, word in named_vocabulary(path.read_text(encoding="utf-8"), vocabulary)
             if not (path == REGISTRY and word in FAMILY_MODULES)]
    assert not found, "family vocabulary outside its folder:\n" + "\n".join(found)


def test_the_scan_sees_the_vocabulary(tmp_path: Path) -> None:
    """The scanner fails a module that names a strategy in code, not in its docstring."""
    vocabulary = family_vocabulary()
    assert {"ndmpc", "ndmpc_convergence", "consensus"} <= vocabulary
    module = tmp_path / "stage.py"
    module.write_text('"""Prices "ndmpc" by its iterations."""\n\n'
                      'def cost(strategy):\n'
                      '    """The cost of "ndmpc"."""\n'
                      '    return 2.5 if strategy == "ndmpc" else 1.0\n', encoding="utf-8")
    assert list(named_vocabulary(module.read_text(encoding="utf-8"), vocabulary)) == \
        [(5, "ndmpc")]
    assert list(named_vocabulary('"""ndmpc"""\nX = 1\n"""ndmpc"""\n', vocabulary)) == []


def test_the_family_folders_are_the_registry_s() -> None:
    assert all(folder.is_dir() for folder in FAMILY_FOLDERS)
    assert PACKAGE / "controllers" / "mpc" in FAMILY_FOLDERS
