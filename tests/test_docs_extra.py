# The docs extra installs what the documentation build imports: `make docs` works on a fresh clone.
"""Every module a tutorial or docs/conf.py imports is installed by the docs extra.

``make docs`` installs ``.[docs]`` only (the project's dependencies and the
docs extra); a tutorial importing anything else (``distributed`` in the
sweeps tutorial, once) fails the build on a fresh clone, although CI's
``make test`` (which installs the test extra first) would not see it.
"""

from __future__ import annotations

import ast
import re
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

# Import name -> distribution name, where the two differ.
DISTRIBUTIONS = {"control": "control", "sklearn": "scikit-learn", "yaml": "pyyaml",
                 "PIL": "pillow"}


def imported_modules(path: Path) -> set[str]:
    """Top-level names of every module ``path`` imports (inside functions too)."""
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def requirement_name(spec: str) -> str:
    """``"distributed>=2024.1"`` -> ``"distributed"`` (normalised)."""
    name = re.match(r"[A-Za-z0-9_.\-]+", spec)
    assert name, spec
    return re.sub(r"[-_.]+", "-", name.group()).lower()


def test_docs_extra_covers_the_imports_of_the_docs_build() -> None:
    """Tutorials and conf.py import only the stdlib, trainctl, its dependencies and docs extra."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    installed = {requirement_name(s)
                 for s in [*project["dependencies"], *project["optional-dependencies"]["docs"]]}
    local = {p.stem for p in (REPO / "docs").glob("*.py")} | {"trainctl"}
    sources = [REPO / "docs" / "conf.py", *sorted((REPO / "docs" / "tutorials").glob("*.py"))]
    assert len(sources) > 5
    missing = {}
    for path in sources:
        for module in imported_modules(path) - local - set(sys.stdlib_module_names):
            if requirement_name(DISTRIBUTIONS.get(module, module)) not in installed:
                missing.setdefault(path.name, []).append(module)
    assert not missing, f"imported by the docs build but not in the docs extra: {missing}"


def test_makefile_takes_another_venv() -> None:
    """``make docs VENV=DIR`` (the fresh-venv proof build of .ci/run) is supported."""
    makefile = (REPO / "Makefile").read_text(encoding="utf-8")
    assert re.search(r"^VENV \?= \.venv$", makefile, re.M)
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    proof, test = ci.index("make docs VENV=.venv-docs"), ci.index("\nmake test")
    assert proof < test, "the fresh-venv docs build must run before make test"
