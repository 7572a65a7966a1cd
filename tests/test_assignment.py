"""The assignment template works as its page says.

``trainctl analyse --strict docs/assignment/scenario.toml`` exits 0, the
student script runs in short mode and prints its results, and the CI
workflow is valid YAML whose steps run that same command and the script.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ASSIGNMENT = REPO / "docs" / "assignment"
COMMAND = "trainctl analyse --strict scenario.toml"


def run(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(REPO), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, "-W", "error", *args], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=300, check=False)


def test_files_present_and_page_includes_them() -> None:
    page = (ASSIGNMENT / "index.rst").read_text(encoding="utf-8")
    for name in ("scenario.toml", "student.py", "ci.yml"):
        assert (ASSIGNMENT / name).is_file()
        assert f".. literalinclude:: {name}" in page
    assert COMMAND in page


def test_scenario_declares_every_check() -> None:
    """``[expected]`` names every check the review runs, so --strict compares them all."""
    import trainctl
    from trainctl.analysis import review_design

    scenario = trainctl.load_scenario(ASSIGNMENT / "scenario.toml")
    review = review_design(scenario)
    assert set(scenario.expected) == {c.name for c in review.checks}
    assert not review.failed_checks


@pytest.mark.slow
def test_analyse_strict_exits_0(tmp_path: Path) -> None:
    result = run(["-m", "trainctl", "analyse", "--strict", str(ASSIGNMENT / "scenario.toml")],
                 tmp_path)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "--strict exits 0" in result.stdout
    assert "all 21 declared statuses match" in result.stdout
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_analyse_strict_catches_a_changed_verdict(tmp_path: Path) -> None:
    """The CI check can fail: a weight below R* changes a verdict and --strict exits 1."""
    text = (ASSIGNMENT / "scenario.toml").read_text(encoding="utf-8")
    changed, count = re.subn(r"(?m)^r_per_kn2 = 0\.2 ", "r_per_kn2 = 0.02", text, count=1)
    assert count == 1
    path = tmp_path / "scenario.toml"
    path.write_text(changed, encoding="utf-8")
    result = run(["-m", "trainctl", "analyse", "--strict", "--no-simulate", str(path)], tmp_path)
    assert result.returncode == 1, result.stdout[-3000:] + result.stderr[-3000:]
    assert "ndmpc_convergence: expected PASS, found FAIL" in result.stdout


@pytest.mark.slow
def test_student_script_runs_short(tmp_path: Path) -> None:
    result = run([str(ASSIGNMENT / "student.py"), "--short"], tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stderr.strip() == ""
    out = result.stdout
    assert "scenario: Assignment: CRH2 half train" in out
    assert re.search(r"rho\(D0\) = 0\.6101 ", out)
    assert "simulated ndmpc for 10 s" in out
    error = float(re.search(r"max speed error after 5 s = (\S+) m/s", out).group(1))
    assert error < 1.0  # the scenario's tracking tolerance [m/s]
    assert "solver statuses: ['optimal']" in out
    assert list(tmp_path.iterdir()) == []


def test_ci_workflow() -> None:
    text = (ASSIGNMENT / "ci.yml").read_text(encoding="utf-8")
    try:
        import yaml
    except ImportError:  # pragma: no cover - PyYAML is in the dev environment
        assert "jobs:" in text and "steps:" in text
        runs = [line.split("run:", 1)[1].strip() for line in text.splitlines() if "run:" in line]
    else:
        doc = yaml.safe_load(text)
        # YAML 1.1 reads the bare key `on` as True; GitHub reads it as "on"
        assert "on" in doc or True in doc
        steps = [step for job in doc["jobs"].values() for step in job["steps"]]
        runs = [str(step["run"]).strip() for step in steps if "run" in step]
        assert any(str(step.get("uses", "")).startswith("actions/checkout") for step in steps)
    assert COMMAND in runs
    assert "python student.py --short" in runs
    assert any("pip install" in r for r in runs)


@pytest.mark.slow
@pytest.mark.e2e  # a wheel built and installed in a fresh venv
def test_ci_workflow_installs_the_built_wheel_and_passes(tmp_path: Path) -> None:
    """The workflow's steps, run verbatim in a fresh venv, install trainctl-toolbox from a
    wheel that ``make dist`` just built and pass: ``--strict`` exits 0, the script runs."""
    import shutil

    import yaml

    import trainctl

    doc = yaml.safe_load((ASSIGNMENT / "ci.yml").read_text(encoding="utf-8"))
    target = doc["env"]["TRAINCTL"]
    assert target == f"wheels/trainctl_toolbox-{trainctl.__version__}-py3-none-any.whl"

    dist = tmp_path / "dist"
    built = subprocess.run(["make", "-s", "-C", str(REPO), "dist", f"DIST={dist}"],
                           capture_output=True, text=True, timeout=600, check=False)
    assert built.returncode == 0, built.stdout + built.stderr
    wheels = list(dist.glob("*.whl"))
    assert [w.name for w in wheels] == [Path(target).name]

    course = tmp_path / "course"
    (course / "wheels").mkdir(parents=True)
    for name in ("scenario.toml", "student.py"):
        shutil.copy(ASSIGNMENT / name, course / name)
    shutil.copy(wheels[0], course / target)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=300)
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PYTHON", "VIRTUAL_ENV"))}
    env.update(PATH=f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}", MPLBACKEND="Agg",
               **{str(k): str(v) for k, v in doc["env"].items()})
    steps = [step for job in doc["jobs"].values() for step in job["steps"] if "run" in step]
    assert len(steps) == 3
    for step in steps:
        result = subprocess.run(["bash", "-eo", "pipefail", "-c", str(step["run"])], cwd=course,
                                env={**env, **{str(k): str(v) for k, v in
                                               step.get("env", {}).items()}},
                                capture_output=True, text=True, timeout=600, check=False)
        assert result.returncode == 0, (step["name"], result.stdout[-3000:],
                                        result.stderr[-3000:])
        if step["run"] == COMMAND:
            assert "--strict exits 0" in result.stdout

    probe = ("import importlib.metadata as m, trainctl; print(m.version('trainctl-toolbox'));"
             " print(trainctl.__file__)\n"
             "try:\n    m.distribution('trainctl')\nexcept m.PackageNotFoundError:\n"
             "    print('no trainctl distribution')")
    out = subprocess.run([str(venv / "bin" / "python"), "-c", probe], cwd=course, env=env,
                         capture_output=True, text=True, timeout=120, check=True).stdout
    version, location, other = out.splitlines()
    assert version == trainctl.__version__
    assert Path(location).is_relative_to(venv), location
    assert other == "no trainctl distribution"
