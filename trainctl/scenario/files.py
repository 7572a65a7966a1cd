# Where scenario text comes from: built-in names, files, UTF-8 decoding; slugs.
"""Finding and reading scenario files, and file-name-safe slugs."""

from __future__ import annotations

import os
import re
import unicodedata
from importlib import resources
from pathlib import Path

from trainctl._files import read_regular
from trainctl.declare.constraints import suggest
from trainctl.exceptions import ScenarioError
from trainctl.scenario.core import BuiltinScenario, Scenario
from trainctl.scenario.parse import MAX_TEXT_BYTES, check_size, load_toml, parse_scenario

__all__ = [
    "builtin_scenario_text",
    "builtin_scenarios",
    "load_scenario",
    "read_scenario_text",
    "slugify",
]

_SLUG_MAX = 60


def slugify(text: str) -> str:
    """Turn any text into a short, safe identifier ``[a-z0-9-]``.

    Accents are stripped, everything else that is not a letter or digit
    becomes one ``-``; the result is at most 60 characters (cut at a word
    boundary where possible) and never empty (``"scenario"`` is the fallback).

    Parameters
    ----------
    text : str
        Any text, e.g. a scenario's display name.

    Returns
    -------
    str
        The slug.

    Examples
    --------
    >>> slugify("CRH2 half train — N-DMPC (Li & Zheng)")
    'crh2-half-train-n-dmpc-li-zheng'
    >>> slugify("<script>alert(1)</script>")
    'script-alert-1-script'
    >>> slugify("  ")
    'scenario'
    """
    ascii_text = unicodedata.normalize("NFKD", str(text)).encode("ascii", "ignore").decode()
    slug = re.sub(r"[^a-z0-9]+", "-", ascii_text.lower()).strip("-")
    if len(slug) > _SLUG_MAX:
        cut = slug[: _SLUG_MAX + 1].rfind("-")
        slug = slug[: cut if cut >= _SLUG_MAX // 2 else _SLUG_MAX].rstrip("-")
    return slug or "scenario"


def builtin_scenarios() -> list[BuiltinScenario]:
    """List the built-in scenarios, sorted by name.

    Returns
    -------
    list of BuiltinScenario
        One entry per shipped ``*.toml`` file.

    Examples
    --------
    >>> names = [b.name for b in builtin_scenarios()]
    >>> names[0], "crh2-dmpc-well-sampled" in names
    ('crh2-dmpc', True)
    """
    found = []
    for path in _builtin_paths():
        label = f"builtin:{path.stem}"
        data = load_toml(_decode(path.read_bytes(), label), label)
        description = data.get("description", "")
        found.append(
            BuiltinScenario(
                name=path.stem,
                description=description if isinstance(description, str) else "",
                path=path,
            )
        )
    return found


def builtin_scenario_text(name: str) -> str:
    """Return the TOML text of a built-in scenario.

    Parameters
    ----------
    name : str
        Built-in name, e.g. ``"crh2-dmpc"``.

    Returns
    -------
    str
        The file's text.

    Raises
    ------
    ScenarioError
        If there is no built-in of that name (the message lists them).

    Examples
    --------
    >>> builtin_scenario_text("crh2-dmpc").startswith("#")
    True
    """
    paths = {path.stem: path for path in _builtin_paths()}
    if name not in paths:
        raise ScenarioError(
            f"builtin:{name}: no built-in scenario named {name!r}.{suggest(name, paths)} "
            f"Available: {', '.join(sorted(paths)) or '(none)'}. To read a file, give a path "
            f"such as ./{name}.toml."
        )
    return _decode(paths[name].read_bytes(), f"builtin:{name}")


def load_scenario(source: str | os.PathLike[str]) -> Scenario:
    """Load a scenario from a built-in name or a file.

    Parameters
    ----------
    source : str or os.PathLike
        A bare name (no path separator, no ``.toml`` suffix) selects a
        built-in scenario; anything else is read as a UTF-8 TOML file.

    Returns
    -------
    Scenario
        The parsed scenario; its ``source`` is the path as given or
        ``"builtin:NAME"``.

    Raises
    ------
    ScenarioError
        If the file is missing, unreadable, not UTF-8, not TOML or does not
        follow the schema.

    Examples
    --------
    >>> scenario = load_scenario("crh2-dmpc")
    >>> scenario.source, scenario.train.mass.tolist()
    ('builtin:crh2-dmpc', [42800.0, 48000.0, 46500.0, 42000.0])
    >>> round(scenario.model.speed, 3), scenario.model.sample_time
    (83.333, 20.0)
    """
    text, label = read_scenario_text(source)
    return parse_scenario(text, source=label)


def read_scenario_text(source: str | os.PathLike[str]) -> tuple[str, str]:
    """The TOML text of a built-in name or a file, and its source label.

    Parameters
    ----------
    source : str or os.PathLike
        As for :func:`load_scenario`.

    Returns
    -------
    text : str
        The file's text (a report echoes it; ``parse_scenario(text,
        source=label)`` gives the scenario).
    label : str
        ``"builtin:NAME"`` or the path as given.

    Raises
    ------
    ScenarioError
        If the file is missing, unreadable or not UTF-8.

    Examples
    --------
    >>> text, label = read_scenario_text("crh2-dmpc")
    >>> label, parse_scenario(text, source=label).source
    ('builtin:crh2-dmpc', 'builtin:crh2-dmpc')
    """
    if isinstance(source, str) and _is_bare_name(source):
        return builtin_scenario_text(source), f"builtin:{source}"
    label = os.fspath(source)
    try:  # bounded, and a pipe or device is refused without blocking
        raw = read_regular(label, MAX_TEXT_BYTES)
    except FileNotFoundError:
        raise ScenarioError(
            f"{label}: file not found. Give an existing path, or a built-in name "
            f"({', '.join(_builtin_names())})."
        ) from None
    except IsADirectoryError:
        raise ScenarioError(
            f"{label}: is a directory, not a scenario file. Give a TOML file or a built-in "
            f"name ({', '.join(_builtin_names())})."
        ) from None
    except OSError as exc:
        raise ScenarioError(f"{label}: cannot read the file ({exc.strerror or exc}).") from None
    check_size(len(raw), label)
    return _decode(raw, label), label


def _decode(raw: bytes, label: str) -> str:
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ScenarioError(
            f"{label}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at line {line}, byte "
            f"offset {exc.start}). Save the file as UTF-8."
        ) from None


def _is_bare_name(source: str) -> bool:
    seps = {"/", "\\", os.sep} | ({os.altsep} if os.altsep else set())
    return not any(sep in source for sep in seps) and not source.lower().endswith(".toml")


def _builtin_dir() -> Path:
    try:
        candidate = resources.files("trainctl") / "builtin_analyses"
        if candidate.is_dir():
            return Path(str(candidate))
    except (ImportError, OSError, TypeError, ValueError):
        pass
    return Path(__file__).resolve().parent.parent.parent / "analyses"


def _builtin_paths() -> list[Path]:
    directory = _builtin_dir()
    if not directory.is_dir():
        return []
    return sorted((p for p in directory.glob("*.toml") if p.is_file()), key=lambda p: p.stem)


def _builtin_names() -> list[str]:
    return [path.stem for path in _builtin_paths()]
