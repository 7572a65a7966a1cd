# `make test` is the fast suite, `make test-e2e` the end-to-end group; CI runs both.
"""The split of the test suite into ``make test`` and ``make test-e2e``.

``make test`` deselects the tests marked ``e2e`` (registered in
pyproject.toml), ``make test-e2e`` selects exactly them, ``.ci/run`` runs
the one after the other under ``set -e`` (both must pass for a green CI) and
the README says what each is for.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def recipe(target: str) -> str:
    """The recipe lines of ``target`` in the Makefile."""
    makefile = (REPO / "Makefile").read_text(encoding="utf-8")
    match = re.search(rf"^{re.escape(target)}:[^\n]*\n((?:\t[^\n]*\n)+)", makefile, re.M)
    assert match, f"no target {target} in the Makefile"
    return match.group(1)


def test_the_e2e_marker_is_registered() -> None:
    """--strict-markers: the marker must be declared, with what it means."""
    pytest_ini = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    markers = pytest_ini["tool"]["pytest"]["ini_options"]["markers"]
    assert any(m.startswith("e2e: ") for m in markers), markers


def test_make_test_leaves_the_e2e_group_out_and_test_e2e_runs_it() -> None:
    fast, e2e = recipe("test"), recipe("test-e2e")
    assert "pytest" in fast and '-m "not e2e"' in fast
    assert "pytest" in e2e and re.search(r"-m e2e\b", e2e)
    assert "test-e2e" in (REPO / "Makefile").read_text(encoding="utf-8").split(".PHONY:")[1] \
        .splitlines()[0]


def test_ci_runs_both_and_fails_on_either() -> None:
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    assert "set -euo pipefail" in ci
    lines = [line.strip() for line in ci.splitlines()]
    e2e = [k for k, line in enumerate(lines) if re.fullmatch(r"(\w+=\S+ )*make test-e2e", line)]
    assert "make test" in lines and len(e2e) == 1
    assert lines.index("make test") < e2e[0]
    # the site test_docs_site.py checks is the one `make docs` built just before
    assert lines.index("make docs") < e2e[0]
    assert "TRAINCTL_DOCS_SITE=docs/_build/html" in lines[e2e[0]]


def test_readme_says_what_each_is_for() -> None:
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    quick = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    block = re.search(r"```sh\n(.*?)```", quick, re.S)
    assert block
    commands = [line.split("#")[0].strip() for line in block.group(1).splitlines()]
    assert commands == ["make report", "make test"]  # the quick start stays these two
    assert "make test-e2e" in quick and "e2e" in quick
