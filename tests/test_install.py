# Packaging test: build the wheel, `pip install .` elsewhere (non-editable), run outside the repo.
"""The built wheel ships the built-in scenarios, templates and static files and runs."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# Every file in the repository's analyses/ is a built-in scenario.
BUILTINS = tuple(sorted(p.stem for p in (REPO / "analyses").glob("*.toml")))

pytestmark = [pytest.mark.slow, pytest.mark.e2e]  # a wheel built, installed and run


def _run(cmd: list[str], **kwargs: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        cmd,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        **kwargs,  # type: ignore[call-overload]
    )


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The wheel built from this checkout (no build isolation, no deps)."""
    out = tmp_path_factory.mktemp("wheel")
    result = _run(
        [
            sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
            "--disable-pip-version-check", "-q", "-w", str(out), str(REPO),
        ],
        cwd=REPO,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    wheels = sorted(out.glob("trainctl_toolbox-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A directory holding a non-editable ``pip install .`` of this checkout (--target)."""
    target = tmp_path_factory.mktemp("install") / "site"
    result = _run(
        [
            sys.executable, "-m", "pip", "install", "--no-deps", "--no-index",
            "--no-build-isolation", "--disable-pip-version-check", "-q",
            "--target", str(target), ".",
        ],
        cwd=REPO,
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    assert not list(target.glob("__editable__*")), "the install must not be editable"
    return target


def _run_installed(site: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """Run ``python -m trainctl ARGS`` against the installed copy, outside the repo."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env["PYTHONPATH"] = str(site)
    return _run([sys.executable, "-m", "trainctl", *args], cwd=cwd, env=env)


class TestWheelContents:
    """What the wheel ships."""

    def test_package_data(self, wheel: Path) -> None:
        """Built-ins, template, stylesheet, py.typed and the CLI are in the wheel."""
        with zipfile.ZipFile(wheel) as archive:
            names = set(archive.namelist())
        expected = {
            "trainctl/__init__.py",
            "trainctl/__main__.py",
            "trainctl/cli/__init__.py",
            "trainctl/cli/main.py",
            "trainctl/py.typed",
            "trainctl/report/templates/report.html.j2",
            "trainctl/report/templates/index.html.j2",
            "trainctl/report/templates/_layout.html.j2",
            "trainctl/report/templates/_macros.html.j2",
            *(f"trainctl/report/templates/sections/_{name}.html.j2" for name in (
                "scenario", "model", "checks", "controllers", "figures", "reproducibility")),
            "trainctl/report/static/report.css",
            *(f"trainctl/builtin_analyses/{name}.toml" for name in BUILTINS),
        }
        assert expected <= names, sorted(expected - names)
        assert not [n for n in names if n.startswith(("tests/", "analyses/")) or "__pycache__" in n]

    def test_metadata(self, wheel: Path) -> None:
        """The metadata has the version, Python requirement and console script."""
        with zipfile.ZipFile(wheel) as archive:
            dist_info = next(
                n.split("/")[0] for n in archive.namelist() if n.endswith(".dist-info/METADATA")
            )
            metadata = archive.read(f"{dist_info}/METADATA").decode()
            entry_points = archive.read(f"{dist_info}/entry_points.txt").decode()
        assert "Name: trainctl-toolbox\n" in metadata  # the index's "trainctl" is another project
        assert "Version: 0.1.0" in metadata
        assert "Requires-Python: >=3.11" in metadata
        assert "Requires-Dist: control>=0.10.2" in metadata
        assert "trainctl = trainctl.cli:main" in entry_points


class TestInstalledWheel:
    """The installed wheel runs outside the repository."""

    def test_imports_installed_copy(self, site: Path, tmp_path: Path) -> None:
        """trainctl is imported from the install target, not from the checkout."""
        env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
        env["PYTHONPATH"] = str(site)
        result = _run(
            [sys.executable, "-c", "import trainctl; print(trainctl.__file__)"],
            cwd=tmp_path,
            env=env,
        )
        assert result.returncode == 0, result.stderr
        location = Path(result.stdout.strip()).resolve()
        assert location.is_relative_to(site.resolve()), location

    def test_list(self, site: Path, tmp_path: Path) -> None:
        """list shows the four built-ins shipped as package data."""
        result = _run_installed(site, tmp_path, "list")
        assert result.returncode == 0, result.stderr
        assert [line.split()[0] for line in result.stdout.splitlines()] == list(BUILTINS)

    def test_analyse(self, site: Path, tmp_path: Path) -> None:
        """analyse crh2-dmpc runs from the installed package."""
        result = _run_installed(site, tmp_path, "analyse", "crh2-dmpc")
        assert result.returncode == 0, result.stderr
        assert "Vehicles" in result.stdout

    def test_report(self, site: Path, tmp_path: Path) -> None:
        """report finds its templates and stylesheet in the installed package."""
        result = _run_installed(site, tmp_path, "report")
        assert result.returncode == 0, result.stderr
        page = tmp_path / "reports" / "crh2-dmpc.html"
        assert result.stdout.startswith(f"wrote {Path('reports') / 'crh2-dmpc.html'} (")
        html = page.read_text(encoding="utf-8")
        assert "border-collapse" in html
        assert html.count("<svg") == 13  # 5 time, 5 frequency, string, eigenvalues, ρ(D0)
        assert 'id="reproducibility"' in html
