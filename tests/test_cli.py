# Tests of the `trainctl` command line (in-process through main(), plus python -m).
"""Command-line interface: list, export, analyse, report, exit codes and errors."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

import trainctl
from trainctl.cli.main import main
from trainctl.design.review import review_design
from trainctl.scenario import builtin_scenario_text, load_scenario

REPO = Path(__file__).resolve().parents[1]
# Every file in the repository's analyses/ is a built-in scenario.
BUILTINS = tuple(sorted(p.stem for p in (REPO / "analyses").glob("*.toml")))
XSS_NAME = "<script>alert(1)</script>"


def scenario_text(*, name: str = "Two coaches", mass_t: str = "40.0", extra: str = "") -> str:
    """A small valid scenario file (two coupled coaches); ``extra`` goes on top."""
    # json.dumps gives a valid TOML basic string for BMP text.
    return (
        f"{extra}\n"
        "schema_version = 1\n"
        f"name = {json.dumps(name)}\n"
        'description = "Smallest coupled train"\n'
        "[train]\n"
        f"vehicle = [{{mass_t = {mass_t}, count = 2, davis_si = [0.01, 0.0, 1e-5]}}]\n"
        "coupler = {stiffness_kn_per_m = 10000.0}\n"
        "[model]\n"
        "speed_kmh = 90.0\n"
        "sample_time = 0.5\n"
    )


def write_bytes(path: Path, data: str | bytes) -> Path:
    """Write text (UTF-8) or bytes to ``path`` and return it."""
    path.write_bytes(data.encode("utf-8") if isinstance(data, str) else data)
    return path


class _PageParser(HTMLParser):
    """Collects start tags, their attributes and the text inside each tag."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[str] = []
        self.attrs: list[tuple[str, str, str]] = []
        self.text: dict[str, list[str]] = {}
        self._open: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.tags.append(tag)
        self.attrs.extend((tag, name, value or "") for name, value in attrs)
        if tag not in {"meta", "br", "link", "img", "input", "hr"}:
            self._open.append(tag)

    def handle_endtag(self, tag: str) -> None:
        if tag in self._open:
            while self._open and self._open.pop() != tag:
                pass

    def handle_data(self, data: str) -> None:
        for tag in set(self._open):
            self.text.setdefault(tag, []).append(data)

    def text_of(self, tag: str) -> str:
        return "".join(self.text.get(tag, []))


def parse_page(html: str) -> _PageParser:
    """Parse an HTML page with the standard-library parser."""
    parser = _PageParser()
    parser.feed(html)
    parser.close()
    return parser


def run_module(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    """Run ``python -m trainctl ARGS`` with this checkout first on the path."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run(
        [sys.executable, "-m", "trainctl", *args],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd or REPO,
        timeout=300,
        check=False,
    )


def assert_refused(path: Path, match: str, capsys: pytest.CaptureFixture[str]) -> None:
    """``trainctl analyse PATH --no-simulate``, run in this process, refuses the scenario:
    exit 2, ``match`` in the message, no traceback."""
    code = main(["analyse", str(path), "--no-simulate"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert match in err
    assert "Traceback" not in err


def assert_user_error(code: int, err: str) -> None:
    """Exit status 2, a one-line-prefixed message on stderr and no traceback."""
    assert code == 2
    assert err.startswith("trainctl: error: ")
    assert "Traceback" not in err


class TestVersionAndHelp:
    """--version, --help and usage errors."""

    def test_version_in_process(self, capsys: pytest.CaptureFixture[str]) -> None:
        """--version prints 'trainctl X.Y.Z' and exits 0."""
        with pytest.raises(SystemExit) as exc:
            main(["--version"])
        assert exc.value.code == 0
        assert capsys.readouterr().out == f"trainctl {trainctl.__version__}\n"

    def test_version_matches_metadata(self) -> None:
        """The version is the one in the installed metadata of the distribution's own name."""
        from importlib.metadata import version

        assert trainctl.DISTRIBUTION == "trainctl-toolbox"
        assert version(trainctl.DISTRIBUTION) == trainctl.__version__ == "0.1.0"

    @pytest.mark.slow
    def test_help_via_python_m(self) -> None:
        """python -m trainctl --help lists every subcommand and exits 0."""
        result = run_module("--help")
        assert result.returncode == 0, result.stderr
        assert result.stdout.startswith("usage: trainctl")
        for command in ("list", "export", "analyse", "report"):
            assert command in result.stdout

    @pytest.mark.slow
    def test_version_via_python_m(self) -> None:
        """python -m trainctl --version prints the version."""
        result = run_module("--version")
        assert result.returncode == 0
        assert result.stdout.strip() == f"trainctl {trainctl.__version__}"

    @pytest.mark.parametrize("argv", [[], ["frobnicate"], ["analyse"], ["list", "--bogus"]])
    def test_usage_error_exits_2(self, argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
        """argparse usage errors exit with status 2 and print usage, no traceback."""
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert "usage: trainctl" in err
        assert "Traceback" not in err

    def test_import_is_light(self) -> None:
        """import trainctl loads neither cvxpy nor matplotlib."""
        code = (
            "import sys, trainctl; "
            "print(sorted(m for m in ('cvxpy', 'matplotlib', 'control') if m in sys.modules))"
        )
        env = dict(os.environ, PYTHONPATH=str(REPO))
        result = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True
        )
        assert result.stdout.strip() == "[]"

    def test_lazy_load_scenario(self) -> None:
        """trainctl.load_scenario is the scenario module's function."""
        assert trainctl.load_scenario is load_scenario
        assert "load_scenario" in dir(trainctl)
        with pytest.raises(AttributeError):
            _ = trainctl.no_such_name


class TestList:
    """trainctl list."""

    def test_lists_all_builtins(self, capsys: pytest.CaptureFixture[str]) -> None:
        """One line per built-in, name first, then its description."""
        assert main(["list"]) == 0
        lines = capsys.readouterr().out.splitlines()
        assert [line.split()[0] for line in lines] == list(BUILTINS)
        for line in lines:
            assert len(line.split(maxsplit=1)) == 2, f"no description in {line!r}"


class TestExport:
    """trainctl export."""

    def test_default_path_round_trips(
        self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """export NAME writes ./NAME.toml, which load_scenario reads back."""
        monkeypatch.chdir(tmp_path)
        assert main(["export", "crh2-dmpc"]) == 0
        path = tmp_path / "crh2-dmpc.toml"
        assert capsys.readouterr().out.strip() == "wrote crh2-dmpc.toml"
        assert path.read_text(encoding="utf-8") == builtin_scenario_text("crh2-dmpc")
        exported, builtin = load_scenario(path), load_scenario("crh2-dmpc")
        assert exported.source == str(path)
        assert exported.name == builtin.name
        assert exported.train == builtin.train
        assert exported.model == builtin.model

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_output_option(self, tmp_path: Path) -> None:
        """-o PATH writes there, creating missing parent directories."""
        path = tmp_path / "sub" / "mine.toml"
        assert main(["export", "heavy-haul-hinf", "-o", str(path)]) == 0
        assert load_scenario(path).name == load_scenario("heavy-haul-hinf").name

    def test_stdout(self, capsys: pytest.CaptureFixture[str]) -> None:
        """-o - prints the text instead of writing a file."""
        assert main(["export", "crh2-potential", "-o", "-"]) == 0
        assert capsys.readouterr().out == builtin_scenario_text("crh2-potential")

    def test_refuses_to_overwrite(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """An existing file is kept (exit 2) unless --force is given."""
        path = write_bytes(tmp_path / "mine.toml", "keep me\n")
        code = main(["export", "crh2-dmpc", "-o", str(path)])
        out, err = capsys.readouterr()
        assert_user_error(code, err)
        assert "--force" in err
        assert out == ""
        assert path.read_text(encoding="utf-8") == "keep me\n"

        assert main(["export", "crh2-dmpc", "-o", str(path), "--force"]) == 0
        assert path.read_text(encoding="utf-8") == builtin_scenario_text("crh2-dmpc")

    def test_unknown_builtin(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """An unknown built-in name is a user error and writes nothing."""
        target = tmp_path / "out.toml"
        code = main(["export", "crh2-dmcp", "-o", str(target)])
        assert_user_error(code, capsys.readouterr().err)
        assert not target.exists()


class TestAnalyse:
    """trainctl analyse."""

    def test_text_mentions_vehicles(self, capsys: pytest.CaptureFixture[str]) -> None:
        """The text summary lists the vehicles with their masses."""
        assert main(["analyse", "crh2-dmpc"]) == 0
        out = capsys.readouterr().out
        scenario = load_scenario("crh2-dmpc")
        assert scenario.name in out
        assert "Vehicles" in out
        for vehicle in scenario.train.vehicles:
            assert f"{vehicle.mass / 1000:.1f}" in out

    def test_json(self, capsys: pytest.CaptureFixture[str]) -> None:
        """--json prints one JSON document that json.loads parses."""
        assert main(["analyse", "crh2-dmpc", "--json"]) == 0
        data = json.loads(capsys.readouterr().out)
        assert data["n_vehicles"] == 4
        assert len(data["vehicles"]) == 4
        assert data["n_states"] > 0
        assert all({"kind", "eigenvalue"} <= set(mode) for mode in data["modes"])

    @pytest.mark.parametrize("name", BUILTINS)
    def test_every_builtin(self, name: str, capsys: pytest.CaptureFixture[str]) -> None:
        """Every built-in analyses with exit 0; --strict exits 1 exactly when a check fails."""
        assert main(["analyse", name, "--no-simulate"]) == 0
        assert load_scenario(name).name in capsys.readouterr().out
        # The checks as the --strict run itself reports them (one design review fewer than
        # a separate review_design: the seed 003 cases take seconds each).
        code = main(["analyse", name, "--strict", "--no-simulate", "--json"])
        checks = json.loads(capsys.readouterr().out)["checks"]
        assert len(checks) >= 7
        assert code == (1 if any(c["status"] == "fail" for c in checks) else 0)

    def test_scenario_file(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """A scenario file path is read as a file."""
        path = write_bytes(tmp_path / "two.toml", scenario_text())
        assert main(["analyze", str(path), "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["n_vehicles"] == 2

    def test_strict_failing_check_exits_1(self, capsys: pytest.CaptureFixture[str]) -> None:
        """The book's T = 20 s fails the sampling check: --strict exits 1 and names it."""
        # (without --strict the same run exits 0: test_text_mentions_vehicles)
        assert main(["analyse", "crh2-dmpc", "--strict"]) == 1
        out, err = capsys.readouterr()
        assert "Vehicles" in out and "Design checks" in out
        assert "sampling" in err and "input_collapse" in err
        assert "Traceback" not in err
        assert main(["analyse", "crh2-dmpc-well-sampled", "--strict", "--no-simulate"]) == 0


BAD_FILES: dict[str, str | bytes] = {
    "negative-mass": scenario_text(mass_t="-40.0"),
    "unknown-key": scenario_text(extra="colour = 'red'"),
    "not-toml": "this is [not toml\n",
    "non-utf8": b'name = "caf\xe9"\n\xff\xfe',
    "empty": "",
}


class TestScenarioErrors:
    """Bad scenarios: exit 2, 'trainctl: error:' on stderr, no traceback, no file."""

    @pytest.fixture(params=[*BAD_FILES, "missing", "directory", "unknown-builtin"])
    def bad_source(self, request: pytest.FixtureRequest, tmp_path: Path) -> str:
        """A scenario argument that must be rejected."""
        kind = request.param
        if kind == "missing":
            return str(tmp_path / "nope.toml")
        if kind == "directory":
            (tmp_path / "dir.toml").mkdir()
            return str(tmp_path / "dir.toml")
        if kind == "unknown-builtin":
            return "crh2-dpmc"
        return str(write_bytes(tmp_path / f"{kind}.toml", BAD_FILES[kind]))

    def test_analyse(self, bad_source: str, capsys: pytest.CaptureFixture[str]) -> None:
        """analyse exits 2 with a one-line error."""
        code = main(["analyse", bad_source])
        out, err = capsys.readouterr()
        assert_user_error(code, err)
        assert out == ""

    def test_analyse_json(self, bad_source: str, capsys: pytest.CaptureFixture[str]) -> None:
        """analyse --json prints nothing on stdout on error."""
        code = main(["analyse", bad_source, "--json"])
        out, err = capsys.readouterr()
        assert_user_error(code, err)
        assert out == ""

    def test_report_writes_nothing(
        self,
        bad_source: str,
        tmp_path: Path,
        monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str],
    ) -> None:
        """report exits 2 and creates neither the file nor its directory."""
        monkeypatch.chdir(tmp_path)
        before = sorted(p.name for p in tmp_path.iterdir())
        out_dir = tmp_path / "out"
        code = main(["report", bad_source, "-o", str(out_dir / "x.html")])
        assert_user_error(code, capsys.readouterr().err)
        assert not out_dir.exists()
        assert sorted(p.name for p in tmp_path.iterdir()) == before

    def test_message_names_the_problem(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """The error message names the file and the offending key."""
        path = write_bytes(tmp_path / "neg.toml", BAD_FILES["negative-mass"])
        assert main(["analyse", str(path)]) == 2
        err = capsys.readouterr().err
        assert str(path) in err
        assert "mass_t" in err
        assert len(err.strip().splitlines()) == 1


class TestReport:
    """trainctl report."""

    WROTE = re.compile(r"wrote (?P<path>\S+) \((?P<checks>\d+) checks: \d+ pass, \d+ warn, "
                       r"\d+ fail(; \d+ controllers simulated)?; [\d.]+ s\)")

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_output_option(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """report -o writes a parseable page that names the scenario, and says so in one line."""
        path = tmp_path / "tmp" / "x.html"
        assert main(["report", "crh2-dmpc", "-o", str(path)]) == 0
        out = capsys.readouterr().out
        match = self.WROTE.fullmatch(out.strip())
        assert match, out
        review = review_design(load_scenario("crh2-dmpc"))
        assert match["path"] == str(path) and match["checks"] == str(len(review.checks))
        assert int(match["checks"]) >= 19  # 7 model checks, 11 of the MPC family, string
        html = path.read_text(encoding="utf-8")
        page = parse_page(html)
        name = load_scenario("crh2-dmpc").name
        assert page.text_of("h1").strip() == name
        assert name in page.text_of("title")
        assert {"html", "head", "body", "table", "style", "svg", "figure"} <= set(page.tags)
        assert not [p for p in tmp_path.rglob("*") if p.name.endswith(".tmp")]

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_default_scenario_and_path(
        self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """Without arguments, crh2-dmpc goes to reports/crh2-dmpc.html in the cwd."""
        monkeypatch.chdir(tmp_path)
        assert main(["report"]) == 0
        expected = Path("reports") / "crh2-dmpc.html"
        match = self.WROTE.fullmatch(capsys.readouterr().out.strip())
        assert match and match["path"] == str(expected)
        html = (tmp_path / expected).read_text(encoding="utf-8")
        assert load_scenario("crh2-dmpc").name.replace("&", "&amp;") in html

    def test_no_external_resources(self, tmp_path: Path) -> None:
        """The page loads nothing from the network and has no script."""
        path = tmp_path / "x.html"
        assert main(["report", "heavy-haul-flocking", "-o", str(path)]) == 0
        html = path.read_text(encoding="utf-8")
        page = parse_page(html)
        assert "script" not in page.tags
        assert "link" not in page.tags
        for tag, name, value in page.attrs:
            if name in {"src", "href", "srcset", "action", "data", "xlink:href"}:
                assert not re.match(r"\s*(https?:)?//", value, re.I), (tag, name, value)
        assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", html, re.I)
        assert not re.search(r"url\(|@import", page.text_of("style"))

    def test_escapes_scenario_name(
        self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """A hostile scenario name is escaped, and its default file name is a safe slug."""
        source = write_bytes(tmp_path / "xss.toml", scenario_text(name=XSS_NAME))
        assert load_scenario(source).name == XSS_NAME
        monkeypatch.chdir(tmp_path)
        assert main(["report", str(source)]) == 0
        match = self.WROTE.fullmatch(capsys.readouterr().out.strip())
        assert match
        written = Path(match["path"])
        assert written.parent == Path("reports")
        assert re.fullmatch(r"[a-z0-9][a-z0-9-]*\.html", written.name), written.name
        html = (tmp_path / written).read_text(encoding="utf-8")
        assert XSS_NAME not in html
        assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
        page = parse_page(html)
        assert "script" not in page.tags
        assert page.text_of("h1").strip() == XSS_NAME

    def test_unwritable_output(self, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
        """An output path that cannot be written is a user error; a directory gets the file."""
        blocker = write_bytes(tmp_path / "file", "x")
        code = main(["report", "heavy-haul-hinf", "-o", str(blocker / "x.html")])
        assert_user_error(code, capsys.readouterr().err)
        code = main(["report", "heavy-haul-hinf", "-o", f"{blocker}/"])
        assert_user_error(code, capsys.readouterr().err)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]

    def test_existing_directory_receives_the_default_name(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """-o DIR (an existing directory, with or without '/') writes DIR/<name>.html."""
        (tmp_path / "dir.html").mkdir()
        code = main(["report", "heavy-haul-hinf", "-o", str(tmp_path / "dir.html")])
        assert code == 0, capsys.readouterr().err
        assert [p.name for p in (tmp_path / "dir.html").iterdir()] == ["heavy-haul-hinf.html"]

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_deterministic_renders_identical(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """Two --deterministic runs (analysis and simulations included) write the same bytes."""
        paths = [tmp_path / "a.html", tmp_path / "b.html"]
        for path in paths:
            assert main(["report", "crh2-dmpc", "--deterministic", "--timestamp",
                         "2026-01-02T03:04:05Z", "-o", str(path)]) == 0
        first, second = (p.read_bytes() for p in paths)
        assert first == second
        assert b"2026-01-02T03:04:05Z" in first
        assert b"Step time" not in first  # wall-clock columns left out

    def test_source_date_epoch(
        self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
    ) -> None:
        """SOURCE_DATE_EPOCH sets the printed time (reproducible-builds convention)."""
        monkeypatch.setenv("SOURCE_DATE_EPOCH", "86400")
        path = tmp_path / "r.html"
        assert main(["report", "heavy-haul-hinf", "-o", str(path)]) == 0
        assert "1970-01-02T00:00:00Z" in path.read_text(encoding="utf-8")

    @pytest.mark.parametrize(
        "argv, needle",
        [
            (["report", "crh2-dmpc", "--all"], "either a SCENARIO or --all"),
            (["report", "heavy-haul-hinf", "--timestamp", "soon"], "ISO 8601"),
        ],
    )
    def test_usage_errors(self, argv: list[str], needle: str, tmp_path: Path,
                          monkeypatch: pytest.MonkeyPatch,
                          capsys: pytest.CaptureFixture[str]) -> None:
        """Contradictory or malformed options exit 2 with a message and write nothing."""
        monkeypatch.chdir(tmp_path)
        code = main(argv)
        err = capsys.readouterr().err
        assert_user_error(code, err)
        assert needle in err
        assert list(tmp_path.iterdir()) == []

    def test_bad_jobs(self, capsys: pytest.CaptureFixture[str]) -> None:
        """--jobs must be a positive whole number (argparse usage error, exit 2)."""
        with pytest.raises(SystemExit) as exc:
            main(["report", "--jobs", "0"])
        assert exc.value.code == 2
        assert "--jobs" in capsys.readouterr().err

    def test_directory_that_is_not_a_saved_run(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """A directory without the saved-run manifest is a user error."""
        code = main(["report", str(tmp_path), "-o", str(tmp_path / "r.html")])
        err = capsys.readouterr().err
        assert_user_error(code, err)
        assert "analyse --save" in err
        assert list(tmp_path.iterdir()) == []

    @pytest.mark.e2e  # a long end-to-end run (make test-e2e)
    def test_save_then_render_without_rerunning(
        self, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]
    ) -> None:
        """analyse --save DIR, then report DIR renders the saved results without simulating."""
        saved = tmp_path / "saved"
        assert main(["analyse", "crh2-dmpc", "--save", str(saved)]) == 0
        assert (saved / "trainctl-run.json").is_file()
        assert "saved results" in capsys.readouterr().err

        def refuse(*args: object, **kwargs: object) -> None:
            raise AssertionError("report DIR must not re-run anything")

        monkeypatch.setattr("trainctl.run.analysis.simulate_strategy", refuse)
        monkeypatch.setattr("trainctl.run.analysis.run_scenario", refuse)
        path = tmp_path / "r.html"
        assert main(["report", str(saved), "-o", str(path), "--deterministic"]) == 0
        html = path.read_text(encoding="utf-8")
        assert html.count("<svg") == 13  # 5 time, 5 frequency, string, eigenvalues, ρ(D0)
        assert "trainctl analyse crh2-dmpc --save saved" in html

    def test_save_refuses_foreign_directory(
        self, tmp_path: Path, capsys: pytest.CaptureFixture[str]
    ) -> None:
        """--save into a non-empty directory that is not a saved run: exit 2 before running."""
        (tmp_path / "keep.txt").write_text("x", encoding="utf-8")
        code = main(["analyse", "heavy-haul-hinf", "--save", str(tmp_path)])
        assert_user_error(code, capsys.readouterr().err)
        assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]

    @pytest.mark.parametrize("which", [
        "two",
        pytest.param("every", marks=pytest.mark.e2e),  # every built-in's report: 30 s and more
    ])
    def test_all_writes_gallery(
        self, which: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]
    ) -> None:
        """--all writes a report per built-in and an index linking each with key results."""
        import trainctl.scenario as scenario_module

        # The long well-sampled simulation is covered by benchmarks/report.py, seed 003's
        # cases by tests/test_seed003_cases.py; here the gallery machinery runs on the others
        # (e2e), or on two quick ones of two families, one simulated (make test).
        every = scenario_module.builtin_scenarios()
        chosen = [b for b in every if b.name != "crh2-dmpc-well-sampled"
                  and not b.name.startswith("heavy-haul-hinf-")]
        if which == "two":
            chosen = [b for b in chosen if b.name in ("heavy-haul-flocking-collision",
                                                      "heavy-haul-hinf")]
            assert len(chosen) == 2
        monkeypatch.setattr(scenario_module, "builtin_scenarios", lambda: chosen)
        out = tmp_path / "gallery"
        assert main(["report", "--all", "-o", str(out)]) == 0
        summary = capsys.readouterr().out
        assert summary.startswith(f"wrote {out / 'index.html'} and {len(chosen)} reports")
        index = (out / "index.html").read_text(encoding="utf-8")
        page = parse_page(index)
        hrefs = [v for t, n, v in page.attrs if t == "a" and n == "href"]
        assert hrefs == [f"{b.name}.html" for b in chosen]
        for b in chosen:
            report = (out / f"{b.name}.html").read_text(encoding="utf-8")
            assert "<svg" in report
        assert index.count('class="headline"') == len(chosen)
        assert "checks:" in index
