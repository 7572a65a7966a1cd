# Extreme values (1e300 and the like): refused naming the file and key, never a traceback or a hang.
"""Values far outside any train are refused before anything runs, naming the key.

The hard limits (:mod:`trainctl.declare.limits`, the hinf settings' gains and scales)
refuse them with the reason; values inside the limits but outside any real
train are warned about by the plausibility check (tests/test_review.py).
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from trainctl.cli.main import main
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.scenario import builtin_scenario_text, load_scenario


def edited(tmp_path: Path, name: str, old: str, new: str) -> Path:
    """The built-in ``name`` written to tmp_path with one line's text replaced."""
    text = builtin_scenario_text(name)
    assert text.count(old) >= 1, old
    path = tmp_path / f"{name}-edited.toml"
    path.write_text(text.replace(old, new, 1), encoding="utf-8")
    return path


def assert_refused(path: Path, key: str, capsys: pytest.CaptureFixture[str]) -> str:
    """``analyse PATH`` exits 2 at once with one line naming the file and the key."""
    start = time.perf_counter()
    code = main(["analyse", str(path), "--no-simulate"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert time.perf_counter() - start < 30.0
    assert "Traceback" not in err and err.count("\n") == 1, err
    assert f"{path}: {key} " in err, err
    return err


@pytest.mark.parametrize(("key", "line", "value", "words"), [
    ("davis_n_per_kn_kmh", "davis_n_per_kn_kmh = [0.8806, 0.007444, 0.0001143]",
     "davis_n_per_kn_kmh = [1e300, 0, 0]", "must give a Davis a0 <= 100 m/s² in SI"),
    ("davis_n_per_kn_kmh", "davis_n_per_kn_kmh = [0.8806, 0.007444, 0.0001143]",
     "davis_n_per_kn_kmh = [0, 0, 1e300]", "a2 <= 0.01 1/m"),
    ("davis_book_literal", "davis_n_per_kn_kmh = [0.8806, 0.007444, 0.0001143]",
     "davis_book_literal = [0, 2.0, 0]", "a1 <= 1 1/s"),
    ("length", "length = 25.0 ", "length = 1e300 ", "must be a number <= 1e+09"),
])
def test_vehicle_extremes_name_the_file_key(tmp_path, capsys, key, line, value, words):
    """A Davis key whose SI coefficients overflow a limit: the file key is named, not 'a0'."""
    err = assert_refused(edited(tmp_path, "crh2-dmpc", line, value),
                         f"[train.vehicle][0].{key}", capsys)
    assert words in err, err
    assert "'a0'" not in err and "Vehicle " not in err, err


def test_coupler_gap_of_1e300_is_refused_at_once(tmp_path, capsys):
    """heavy-haul-hinf-interruption with a 1e300 m coupler gap: exit 2 naming the gap."""
    path = edited(tmp_path, "heavy-haul-hinf-interruption", "gap = 0.0 ", "gap = 1e300 ")
    err = assert_refused(path, "[train.coupler].gap", capsys)
    assert "must be a number <= 1e+09" in err and "floating point" in err, err


def test_gap_within_the_limit_warns(tmp_path):
    """A 20 km gap is computable but no train's: the plausibility check names it."""
    from trainctl.analysis.plausibility import plausibility_check

    path = edited(tmp_path, "heavy-haul-hinf-interruption", "gap = 0.0 ", "gap = 20000.0 ")
    check = plausibility_check(load_scenario(path))
    assert check.status == "warn", check.message
    assert check.message.startswith("couplers 1–3: gap = 20000 m"), check.message


@pytest.mark.parametrize(("key", "value"), [
    *((key, "1e300") for key in ("controller.kappa_p_per_s", "controller.kappa_c_per_s",
                                 "controller.force_scale_m_s2", "controller.noise_scale_m_s",
                                 "controller.output_scale_m_s")),
    *((key, "1e-300") for key in ("controller.kappa_p_per_s", "controller.force_scale_m_s2",
                                  "controller.noise_scale_m_s", "controller.output_scale_m_s")),
])
def test_seed003_sweep_gains_and_scales(capsys, key, value):
    """The seed-003 sweep with a gain or a scale at 1e300 (a scale at 1e-300): exit 2, the key."""
    code = main(["sweep", "heavy-haul-hinf-delay-sweep", "--set", f"{key}={value}",
                 "--seeds", "1", "--dry-run"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err and "ZeroDivisionError" not in err, err
    assert f"[controller].{key.split('.', 1)[1]} must be a number" in err, err


def test_hinf_settings_refuse_extremes_in_python():
    """The same limits hold for settings built in Python (a ModelError naming the field)."""
    from trainctl.controllers.hinf.settings import HinfSettings

    for field in ("kappa_p", "kappa_c", "force_scale", "noise_scale", "output_scale"):
        with pytest.raises(ModelError, match=f"'{field}' must be"):
            HinfSettings(**{field: 1e300})
    with pytest.raises(ModelError, match="'kappa_p_bounds'"):
        HinfSettings(kappa_p_bounds=(0.1, 1e300))


def test_zero_margin_has_no_ratio():
    """The delay check's bound text with a zero margin: no division (was ZeroDivisionError)."""
    from trainctl.controllers.hinf.checks import _bound_text

    design = SimpleNamespace(consensus_bound=1e-300)
    text = _bound_text(design, 0.0)  # type: ignore[arg-type]
    assert "= 1e-300 s" in text and "× the full margin" not in text
    assert "2× the full margin" in _bound_text(SimpleNamespace(consensus_bound=2.0), 1.0)


def test_cli_refusal_in_a_subprocess(tmp_path):
    """The command itself: exit 2, no traceback on stderr, nothing on stdout."""
    path = edited(tmp_path, "crh2-dmpc", "davis_n_per_kn_kmh = [0.8806, 0.007444, 0.0001143]",
                  "davis_n_per_kn_kmh = [1e300, 0, 0]")
    result = subprocess.run([sys.executable, "-m", "trainctl", "analyse", str(path)],
                            capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 2, result.stderr
    assert result.stdout == "" and "Traceback" not in result.stderr
    assert "davis_n_per_kn_kmh" in result.stderr


def test_python_vehicle_and_coupler_limits():
    """Vehicle lengths and coupler spacings beyond 1e9 m are refused in Python too."""
    from trainctl.models.vehicle import Coupler, Vehicle

    with pytest.raises(ModelError, match="'length'"):
        Vehicle(mass=40e3, a0=0.01, a1=0.0, a2=1e-5, length=1e300)
    with pytest.raises(ModelError, match="'spacing'"):
        Coupler(stiffness=1e7, damping=0.0, spacing=1e300)
    with pytest.raises(ScenarioError):
        load_scenario("crh2-dmpc").replace("train.coupler.gap", 1e300)
