# Hard limits: values that cannot be computed are refused up front, with the key and the reason.
"""trainctl.declare.limits (bounds in a key's unit), non-finite models, oversized or deep TOML."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from trainctl._validation import check_finite_arrays, numerical_errors
from trainctl.cli.main import main
from trainctl.declare.constraints import Number
from trainctl.declare.limits import MASS, MAX_SAMPLES, SAMPLE_TIME, SPEED, in_unit
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.models import discretise
from trainctl.models.vehicle import Coupler, Vehicle
from trainctl.scenario import (
    ModelSettings,
    SimulationSettings,
    builtin_scenario_text,
    builtin_scenarios,
    parse_scenario,
)
from trainctl.scenario.parse import MAX_TEXT_BYTES, load_toml
from trainctl.units import tonnes_to_kg

HUGE_KEYS = ("duration", "sample_time", "stiffness_kn_per_m", "mass_t", "speed_kmh")
CASES = [(b.name, key) for b in builtin_scenarios() for key in HUGE_KEYS
         if re.search(rf"^{key}\s*=", builtin_scenario_text(b.name), re.M)]


def set_key(text: str, key: str, value: str) -> str:
    """``text`` with the first ``key = ...`` line's value replaced."""
    new, count = re.subn(rf"^({re.escape(key)}\s*=\s*)[^#\n]+", rf"\g<1>{value} ", text,
                         count=1, flags=re.M)
    assert count == 1, key
    return new


class TestHugeValues:
    """The mutation cases of issue 10: 1e300-scale values in every built-in."""

    def test_cases_cover_the_issue(self) -> None:
        """Every key of the issue occurs in some built-in, and the cases are at least nine."""
        assert {key for _, key in CASES} == set(HUGE_KEYS)
        assert len(CASES) >= 9

    @pytest.mark.parametrize("name, key", CASES)
    def test_refused_with_the_key(self, name: str, key: str, tmp_path: Path,
                                  monkeypatch: pytest.MonkeyPatch,
                                  capsys: pytest.CaptureFixture[str]) -> None:
        """analyse exits 2 naming the key and a bound, without a traceback or a file."""
        path = tmp_path / "huge.toml"
        path.write_text(set_key(builtin_scenario_text(name), key, "1e300"), encoding="utf-8")
        monkeypatch.chdir(tmp_path)
        assert main(["analyse", str(path), "--json", "--save", "run"]) == 2
        captured = capsys.readouterr()
        assert captured.err.startswith(f"trainctl: error: {path}: ")
        assert key in captured.err and "Traceback" not in captured.err
        assert re.search(r"must be (a number|at most) .*(<=|from|samples)", captured.err)
        assert captured.out == ""
        assert [p.name for p in tmp_path.iterdir()] == ["huge.toml"]

    @pytest.mark.parametrize("value, key", [("1e6", "grade_permille"),
                                            ("1e8", "initial_speed_error")])
    def test_grade_and_speed_error(self, value: str, key: str, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
        """A 1e6 ‰ grade or a 1e8 m/s initial speed error is a clean exit 2."""
        text = builtin_scenario_text("crh2-dmpc").replace(
            "[simulation]\n", "[simulation]\ninitial_speed_error = 0.0\n", 1)
        text += "\n[track]\n[[track.section]]\nstart = 0.0\ngrade_permille = 0.0\n"
        path = tmp_path / "s.toml"
        path.write_text(set_key(text, key, value), encoding="utf-8")
        assert main(["analyse", str(path), "--no-simulate"]) == 2
        err = capsys.readouterr().err
        assert f"{key} must be a number <=" in err and "Traceback" not in err


class TestBounds:
    """Each bound is declared once, in SI, and checked in the key's own unit."""

    def test_file_key_in_its_unit(self) -> None:
        """mass_t gets the kilogram bounds in tonnes; speed_kmh the m/s bound in km/h."""
        assert in_unit(MASS, tonnes_to_kg).want() == "a number from 0.001 to 1e+06"
        assert in_unit(SPEED, lambda kmh: kmh / 3.6).le == 1000.0

    def test_in_unit_needs_a_scale_factor(self) -> None:
        """A converter that is not a positive scale cannot carry bounds (declaration error)."""
        with pytest.raises(ValueError, match="not a positive scale factor"):
            in_unit(Number(gt=0, le=10), lambda x: x + 1.0)
        assert in_unit(Number(), lambda x: x + 1.0) == Number()  # nothing to convert

    def test_python_objects_share_the_bound(self) -> None:
        """A Vehicle built in Python is held to the same limit, in kg, with the reason."""
        with pytest.raises(ModelError, match=r"'mass' must be a finite number <= 1e\+09 "
                                             r"\(got 1e\+300\)\. A vehicle"):
            Vehicle(mass=1e300, a0=0.0, a1=0.0, a2=0.0)
        with pytest.raises(ModelError, match="'stiffness' must be a finite number <= 1e"):
            Coupler(stiffness=1e300, spacing=25.0)

    def test_sample_time_and_speed(self) -> None:
        """Sample times outside [0.1 ms, 1 h] and speeds over 1000 km/h are refused."""
        for dt in (1e-9, 1e4):
            with pytest.raises(ModelError, match="'sample_time'"):
                ModelSettings(speed=25.0, sample_time=dt)
        with pytest.raises(ModelError, match="'speed' must be a finite number <= 277.778"):
            ModelSettings(speed=1e3, sample_time=0.1)
        with pytest.raises(ModelError) as upper:
            ModelSettings(speed=25.0, sample_time=1e4)
        assert str(upper.value).endswith(SAMPLE_TIME.why)  # the reason, on either bound
        with pytest.raises(ModelError) as lower:
            ModelSettings(speed=25.0, sample_time=0.0)
        assert str(lower.value).endswith(SAMPLE_TIME.why)  # 0.1 ms is a bound with a reason
        with pytest.raises(ModelError) as sign:
            ModelSettings(speed=-1.0, sample_time=0.1)
        assert str(sign.value).endswith("(got -1.0).")  # "> 0" needs no reason

    def test_samples_per_run(self) -> None:
        """duration / sample_time above MAX_SAMPLES is refused, in Python and in files."""
        sim = SimulationSettings(duration=7200.0, strategies=("centralised",),
                                 reference_times=(0.0,), reference_speeds=(20.0,))
        assert sim.n_steps(1.0) == 7200
        with pytest.raises(ModelError, match=f"at most {MAX_SAMPLES} samples"):
            sim.n_steps(1e-4)
        text = set_key(builtin_scenario_text("crh2-dmpc"), "sample_time", "1e-4")
        text = set_key(text, "duration", "1200.0")
        with pytest.raises(ScenarioError, match=r"\[simulation\]\.duration must be at most "
                                                r"10000000 samples .*1\.2e\+07 samples"):
            parse_scenario(text, source="t.toml")

    @pytest.mark.parametrize("key", ["iterations", "max_iterations"])
    def test_iteration_counts(self, key: str) -> None:
        """An iteration count of 1e9 (a run of days) is refused; 10000 is accepted."""
        with pytest.raises(ScenarioError, match=rf"\[controller\]\.{key} must be an integer "
                                                r"<= 10000 \(got 1000000000\)\. A distributed"):
            parse_scenario(set_key(builtin_scenario_text("crh2-dmpc"), key, "1000000000"))
        parse_scenario(set_key(builtin_scenario_text("crh2-dmpc"), key, "10000"))

    def test_builtins_within_bounds(self) -> None:
        """Every built-in loads: the limits are far from real trains."""
        refused = {}
        for item in builtin_scenarios():
            try:
                parse_scenario(builtin_scenario_text(item.name), source=item.name)
            except ScenarioError as exc:
                refused[item.name] = str(exc)
        assert refused == {}


class TestNonFiniteModel:
    """A non-finite number in the model is a named ModelError, never a numpy traceback."""

    def test_check_finite_arrays_names_the_entry(self) -> None:
        """The message names the array, the value and where it is."""
        with pytest.raises(ModelError, match=r"^m: B must be finite \(got nan at \[1\]\)\. h$"):
            check_finite_arrays("m", " h", A=np.eye(2), B=[0.0, math.nan])

    def test_discretise_overflow(self) -> None:
        """A model whose exp(A·T) overflows is refused by discretise."""
        import control as ct

        sys = ct.ss([[800.0]], [[1.0]], [[1.0]], 0)
        with pytest.raises(ModelError, match=r"discretise: A must be finite .*T = 1\.0 s"):
            discretise(sys, 1.0)

    def test_linear_algebra_failure(self) -> None:
        """LinAlgError and overflow inside numerical_errors become a ModelError."""
        with pytest.raises(ModelError, match="^run.toml: the model's linear algebra failed"):
            with numerical_errors("run.toml"):
                np.linalg.eigvals(np.array([[np.inf]]))
        with pytest.raises(ModelError, match="a computation overflowed"):
            with numerical_errors("run.toml"):
                math.exp(1e4)

    @pytest.mark.filterwarnings("ignore::RuntimeWarning")
    def test_degenerate_scenario_exits_2(self, tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
        """A 1 kg vehicle on a 1e9 kN·s/m coupler: the review's linear algebra fails cleanly."""
        text = set_key(builtin_scenario_text("crh2-dmpc"), "damping_kn_s_per_m", "1e9")
        path = tmp_path / "d.toml"
        path.write_text(text, encoding="utf-8")
        code = main(["analyse", str(path), "--no-simulate"])
        err = capsys.readouterr().err
        assert code in (0, 2) and "Traceback" not in err
        if code == 2:
            assert "linear algebra failed" in err or "must be finite" in err


class TestTomlSize:
    """Oversized or deeply nested TOML is a ScenarioError."""

    def test_deep_nesting(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """A 5000-deep array: exit 2, not tomllib's RecursionError."""
        path = tmp_path / "deep.toml"
        path.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n", encoding="utf-8")
        assert main(["analyse", str(path)]) == 2
        err = capsys.readouterr().err
        assert "nested too deeply" in err and "Traceback" not in err
        with pytest.raises(ScenarioError, match="nested too deeply"):
            load_toml("x = " + "{a = " * 3000 + "1" + "}" * 3000, "inline.toml")

    def test_oversized(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """A file over the size limit is refused after a bounded read (also /dev/zero)."""
        path = tmp_path / "big.toml"
        path.write_bytes(b"#" * (MAX_TEXT_BYTES + 1))
        assert main(["analyse", str(path)]) == 2
        assert "too large for a scenario file" in capsys.readouterr().err
        with pytest.raises(ScenarioError, match="too large"):
            parse_scenario("#" * (MAX_TEXT_BYTES + 1))
        if Path("/dev/zero").exists():
            assert main(["analyse", "/dev/zero"]) == 2  # refused unread: not a regular file
            assert "/dev/zero: cannot read the file (a character device" in capsys.readouterr().err
