"""The tutorials run, and the numbers their text quotes are the numbers they print.

Every ``docs/tutorials/t*.py`` runs as a plain script in a subprocess, in
short mode (``TRAINCTL_TUTORIAL_SHORT=1``), with the Agg backend, warnings
as errors and a temporary working directory, so that nothing is written into
the repository. For each tutorial :data:`QUOTED` lists lines the script must
print; each must also be quoted in the tutorial's reStructuredText (the
module docstring and the ``#`` comment text of its cells), so that the prose
and the output cannot drift apart. The quoted numbers are analysis results
(eigenvalues, ρ(D0), margins, certificates), which the short mode does not
change; where possible they are checked by hand in the tutorial's text too
(√(3k/m), √(2k/m), π/ω_max, the LQR equivalence, ρ(D0) = 1 at R*).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
TUTORIALS = REPO / "docs" / "tutorials"
SHORT_LIMIT_S = 15.0
"""Longest acceptable short-mode run of one tutorial [s] (wall clock, shared machine: x2)."""

QUOTED: dict[str, tuple[str, ...]] = {
    "t01_train_as_system": (
        "vehicles = 4, couplers = 3",
        "k = 10488 kN/m",
        "coupler modes = 11.94, 21.66, 27.77 rad/s",
        "-k/m_1 = -245.05 1/s^2",
        "B_1 = 2.3364e-05 1/kg",
        "interconnection equals whole-train model: True",
    ),
    "t02_stability_sampling": (
        "v_r = 83.333 m/s, T = 20 s",
        "spectral abscissa = -1.342e-03 1/s",
        "controllability rank = 7/7",
        "observability rank = 7/7",
        "omega_max*T = 555.4 rad",
        "pi/omega_max = 0.1131 s",
        "input collapse = 0.000134",
        "omega_max*T = 1.388 rad",
    ),
    "t03_mpc_ndmpc": (
        "rho(D0) = 0.3057",
        "R* = 2.253 per kN^2",
        "rho(D0) at R* = 1.0000",
        "ndmpc_convergence at R = 1: fail",
        "rho(D0) at R = 1: 1.5849",
        "best omega = 0.666",
    ),
    "t04_generic_mpc": (
        "plan = [-1.0000, -1.0000, 0.1393, 0.3361]",
        "coupler mode = 15.76 rad/s",
        "first move equals LQR: True",
    ),
    "t05_potential_flocking": (
        "potential_closed_loop = -1.003 1/s",
        "max Re(eig) of the loop = -1.003 1/s",
        "spacing bound = 0.05402 m",
        "largest peak ratio = 0.9567",
        "unpinned string_stability: fail",
        "d_alpha = 23.17, r_alpha = 29.24",
        "H(0) = 14.28 m^2/s^2",
        "E(0) = 42.43 m^2/s^2",
        "flocking largest peak ratio = 0.7968",
    ),
    "t06_hinf_delay": (
        "first-order bound = 3.558 s",
        "delay margin = 0.574 s",
        "4.21 rad/s",
        "stable at 0.9 x margin: True, unstable at 1.1 x margin: True",
        "delayed own speed: fail",
        "current own speed: pass",
        "certified gamma = 0.255",
    ),
    "t07_sweeps": (
        "points in the file's sweep: 8",
        "rho(D0) at R = 0.05, T = 0.05 s: 1.0395",
        "rho(D0) at R = 1, T = 0.05 s: 0.2201",
        "converged: False",
        "converged: True",
        "certificate agrees with the simulation at every point: True",
        "Dask table equals local table: True",
    ),
    "t08_scenario_review_report": (
        "omega_max = 23.08 rad/s",
        "omega_max*T = 1.154 rad",
        "checks differing from [expected]: none",
        "plausibility with mass_t = 45000: warn",
    ),
}


def tutorial_files() -> list[Path]:
    return sorted(TUTORIALS.glob("t[0-9][0-9]_*.py"))


def rst_text(path: Path) -> str:
    """The tutorial's prose: module docstring and ``#`` comment lines, whitespace collapsed."""
    source = path.read_text(encoding="utf-8")
    match = re.match(r'\s*(?:"""|\'\'\')(.*?)(?:"""|\'\'\')', source, re.S)
    assert match, f"{path.name}: no module docstring"
    parts = [match.group(1)]
    for line in source[match.end():].splitlines():
        stripped = line.strip()
        if stripped.startswith("#") and not stripped.startswith("# %%"):
            parts.append(stripped.lstrip("#"))
    return re.sub(r"\s+", " ", " ".join(parts))


def run_tutorial(path: Path, tmp_path: Path) -> tuple[subprocess.CompletedProcess[str], float]:
    env = dict(os.environ, PYTHONPATH=str(REPO), TRAINCTL_TUTORIAL_SHORT="1", MPLBACKEND="Agg")
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-W", "error", str(path)], capture_output=True,
                            text=True, env=env, cwd=tmp_path, timeout=300, check=False)
    return result, time.perf_counter() - start


def test_every_tutorial_has_quotes() -> None:
    """The table and the directory name the same tutorials, eight of them."""
    assert sorted(p.stem for p in tutorial_files()) == sorted(QUOTED)
    assert len(QUOTED) == 8


@pytest.mark.parametrize("name", sorted(QUOTED))
def test_quotes_in_text(name: str) -> None:
    """Each quoted line appears in the tutorial's prose (cheap; no run)."""
    text = rst_text(TUTORIALS / f"{name}.py")
    missing = [q for q in QUOTED[name] if q not in text]
    assert not missing, f"{name}: not quoted in the text: {missing}"


def test_rst_text_reads_comments() -> None:
    """The prose extractor sees the docstring and cell comments, not code."""
    text = rst_text(TUTORIALS / "t03_mpc_ndmpc.py")
    assert "MPC and N-DMPC" in text and "rho(D0) = 0.3057" in text
    assert "build_design(scenario)" not in text


@pytest.mark.slow
@pytest.mark.e2e
@pytest.mark.parametrize("name", sorted(QUOTED))
def test_tutorial_runs_and_prints_its_quotes(name: str, tmp_path: Path) -> None:
    """Short mode: runs without error or warning, quickly, writing nothing, printing the quotes."""
    path = TUTORIALS / f"{name}.py"
    result, seconds = run_tutorial(path, tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stderr.strip() == "", result.stderr[-3000:]
    missing = [q for q in QUOTED[name] if q not in result.stdout]
    assert not missing, f"{name}: not printed: {missing}\n{result.stdout[-3000:]}"
    assert list(tmp_path.iterdir()) == [], "the tutorial wrote into its working directory"
    assert seconds < 2 * SHORT_LIMIT_S, f"{name}: {seconds:.1f} s in short mode"
