# Control characters in names: refused in scenario files, escaped on every page and terminal.
"""Names and descriptions with control characters never reach a page or a terminal raw.

A scenario file's text fields refuse them (the ``Text`` rule); whatever else a
user gives (a file name, a name set in Python) is escaped on output: the
report page through the Jinja environment, the terminal through the CLI's
stdout and its error line.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from trainctl.naming import printable
from trainctl.report import build_report_context, collect_report_data, render_report
from trainctl.run.analysis import run_scenario
from trainctl.scenario import load_scenario

# Raw characters a page or a terminal must never receive, as TOML escapes
# (how a hostile file spells them) and as the characters themselves.
HOSTILE = {
    "NUL": "\\u0000",
    "ESC colour": "\\u001b[31mred\\u001b[0m",
    "OSC title": "\\u001b]0;pwned\\u0007",
    "RLO": "abc\\u202Efdp.exe",
    "isolate": "\\u2066x\\u2069",
    "carriage return": "over\\rwritten",
    "DEL": "x\\u007f",
    "C1 CSI": "\\u009b31m",
}
FORBIDDEN_BYTES = [bytes([c]) for c in (*range(0x00, 0x09), *range(0x0b, 0x20), 0x7f)] + [
    ch.encode("utf-8") for ch in ("\u202e", "\u2066", "\u2069", "\u0085", "\u009b")
]


def scenario_toml(*, name: str = "Two coaches", description: str = "Smallest coupled train",
                  vehicle: str = "T") -> str:
    """A small valid scenario; the strings are inserted as TOML basic-string bodies."""
    return (
        "schema_version = 1\n"
        f'name = "{name}"\n'
        f'description = "{description}"\n'
        "[train]\n"
        f'vehicle = [{{name = "{vehicle}", mass_t = 40.0, count = 2, '
        "davis_si = [0.01, 0.0, 1e-5]}]\n"
        "coupler = {stiffness_kn_per_m = 10000.0}\n"
        "[model]\n"
        "speed_kmh = 90.0\n"
        "sample_time = 0.5\n"
    )


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[bytes]:
    """``python -m trainctl ARGS`` with output kept as bytes."""
    env = {**os.environ, "PYTHONIOENCODING": "utf-8"}
    return subprocess.run([sys.executable, "-m", "trainctl", *args], cwd=cwd, env=env,
                          capture_output=True, timeout=120, check=False)


def assert_no_raw_controls(data: bytes) -> None:
    """No forbidden control byte (tab and line feed are text) and no bidi control."""
    found = [b for b in FORBIDDEN_BYTES if b in data]
    assert not found, found


@pytest.mark.parametrize(("field", "kind"), [
    *(("name", kind) for kind in sorted(HOSTILE)),
    ("description", "ESC colour"), ("description", "RLO"), ("vehicle", "NUL"), ("vehicle", "RLO"),
])
def test_file_text_fields_refuse_control_characters(tmp_path: Path, field: str,
                                                    kind: str) -> None:
    """Each hostile string in each text field: exit 2, the file and key named, no raw bytes."""
    from trainctl.exceptions import ScenarioError

    path = tmp_path / "hostile.toml"
    path.write_text(scenario_toml(**{field: f"ok {HOSTILE[kind]}"}), encoding="utf-8")
    key = {"name": "name", "description": "description", "vehicle": "[train.vehicle][0].name"}
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "hostile.toml" in message and key[field] in message, message
    assert "must not contain control characters" in message, message
    assert_no_raw_controls(message.encode("utf-8"))


def test_cli_refusal_writes_no_raw_bytes(tmp_path: Path) -> None:
    """``analyse`` of a hostile file: exit 2, one error line with the escapes spelled out."""
    path = tmp_path / "hostile.toml"
    path.write_text(scenario_toml(name="Evil\\u0000 \\u001b[31mred \\u202Eabc"), encoding="utf-8")
    result = run_cli("analyse", str(path), "--no-simulate", cwd=tmp_path)
    assert result.returncode == 2, result.stderr
    assert result.stdout == b""
    assert b"Traceback" not in result.stderr
    assert_no_raw_controls(result.stderr)
    assert b"hostile.toml: name must not contain control characters" in result.stderr
    assert b"U+0000" in result.stderr


def test_tab_and_line_feed_stay_allowed(tmp_path: Path) -> None:
    """Ordinary white space is text: a tab in the description, a line break in the name."""
    path = tmp_path / "ok.toml"
    path.write_text(scenario_toml(name="Two\\ncoaches", description="a\\tb"), encoding="utf-8")
    scenario = load_scenario(path)
    assert (scenario.name, scenario.description) == ("Two\ncoaches", "a\tb")


@pytest.mark.e2e  # a long end-to-end run (make test-e2e)
def test_file_name_with_escape_reaches_terminal_escaped(tmp_path: Path) -> None:
    """A hostile file name, valid or missing: stdout and stderr hold no raw escape."""
    name = "e\x1b[31mvil\u202e.toml"
    (tmp_path / name).write_text(scenario_toml(), encoding="utf-8")
    result = run_cli("analyse", name, "--no-simulate", cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert_no_raw_controls(result.stdout + result.stderr)
    assert b"Two coaches" in result.stdout
    missing = run_cli("analyse", "no\x1b[2Jsuch.toml", cwd=tmp_path)
    assert missing.returncode == 2
    assert_no_raw_controls(missing.stderr)
    assert b"no\\u001b[2Jsuch.toml" in missing.stderr


def test_python_names_are_escaped_on_the_page_and_in_json(tmp_path: Path) -> None:
    """A scenario and vehicle named in Python (no file rule): the page has no raw control."""
    path = tmp_path / "ok.toml"
    path.write_text(scenario_toml(), encoding="utf-8")
    scenario = load_scenario(path)
    vehicles = tuple(dataclasses.replace(v, name="V\x1b[31m\u202e")
                     for v in scenario.train.vehicles)
    scenario = dataclasses.replace(
        scenario, name="Evil\x00 \x1b[31mred \u202eabc", description="d\x07\u2066",
        train=dataclasses.replace(scenario.train, vehicles=vehicles))
    run = run_scenario(scenario, simulate=False)
    context = build_report_context(collect_report_data(run, scenario_text=path.read_text()),
                                   deterministic=True)
    html = render_report(context)
    assert_no_raw_controls(html.encode("utf-8"))
    assert "Evil\\u0000 \\u001b[31mred \\u202eabc" in html
    assert json.loads(json.dumps(printable("\u202e"))) == "\\u202e"
