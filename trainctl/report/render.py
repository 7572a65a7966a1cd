# HTML report rendering: context building, Jinja environment, atomic writes.
"""Render the HTML model-summary report of a scenario.

The pipeline has three steps, each testable on its own:

1. :func:`build_summary_context` turns a scenario and its model summary into a
   plain dict of display-ready values (pure: no I/O, no clock unless
   ``generated_at`` is omitted).
2. :func:`render_summary_report` renders that dict with the package template
   ``templates/summary.html.j2``; the stylesheet ``static/report.css`` is read
   from package data and inlined, so the page loads no external resource and
   runs no JavaScript.
3. :func:`write_report` writes the page atomically.

Every string from a scenario file is escaped by the template (autoescape).
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import numbers
import os
import platform
import secrets
from collections.abc import Mapping, Sequence
from functools import lru_cache
from importlib import metadata, resources
from pathlib import Path
from typing import Any

import jinja2
from markupsafe import Markup

from .. import __version__

__all__ = [
    "REPORT_PACKAGES",
    "build_summary_context",
    "make_environment",
    "render_summary_report",
    "write_report",
    "write_text_atomic",
]

REPORT_PACKAGES = ("numpy", "scipy", "control", "cvxpy")
"""Distributions whose versions are printed in the report footer (besides trainctl)."""

SUMMARY_TEMPLATE = "summary.html.j2"
_CSS_RESOURCE = ("static", "report.css")

# Units of known keys of the model settings and the summary dict.
_UNITS = {
    "speed": "m/s",
    "speed_kmh": "km/h",
    "sample_time": "s",
    "natural_frequency": "rad/s",
    "frequency": "rad/s",
    "damping_ratio": "-",
    "time_constant": "s",
    "settling_time": "s",
    "period": "s",
    "mass": "kg",
    "mass_t": "t",
    "stiffness": "N/m",
    "damping": "N·s/m",
    "spacing": "m",
    "length": "m",
    "seed": "-",
    "traction_share": "-",
    "eigenvalue": "1/s",
    "nyquist_sample_time": "s",
    "omega_max_times_T": "rad",
    "discrete_spectral_radius": "-",
}

# Display labels of keys whose humanised form reads badly.
_LABELS = {
    "speed_kmh": "Speed",
    "n_vehicles": "Number of vehicles",
    "n_states": "Number of states",
    "n_inputs": "Number of inputs",
    "n_outputs": "Number of outputs",
    "omega_max_times_T": "ω_max·T",
}

# Units that depend on the enclosing section of the summary dict ("section.key").
_SECTION_UNITS = {
    "equilibrium.inputs": "N",
    "equilibrium.coupler_forces": "N",
    "equilibrium.elongations": "m",
    "equilibrium.traction_limit": "N",
}


# --------------------------------------------------------------------------- environment


def make_environment() -> jinja2.Environment:
    """Create the Jinja environment for the report templates.

    Returns
    -------
    jinja2.Environment
        Loads from the package's ``templates`` directory, escapes every
        substituted value and fails on undefined names.

    Examples
    --------
    >>> env = make_environment()
    >>> env.from_string("{{ x }}").render(x="<b>")
    '&lt;b&gt;'
    """
    return jinja2.Environment(
        loader=jinja2.PackageLoader("trainctl.report", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )


@lru_cache(maxsize=1)
def _stylesheet() -> str:
    css = resources.files("trainctl.report").joinpath(*_CSS_RESOURCE).read_text(encoding="utf-8")
    if "</" in css:
        raise ValueError("report.css must not contain '</' (it is inlined in a <style> block)")
    return css


# --------------------------------------------------------------------------- context


def build_summary_context(
    scenario: Any, summary: Any, *, generated_at: str | None = None
) -> dict[str, Any]:
    """Collect everything the summary template shows, as display-ready values.

    Parameters
    ----------
    scenario : trainctl.scenario.Scenario
        The scenario (name, description, source, train, model settings).
    summary : ModelSummary or Mapping
        Its model summary: an object with ``to_dict()`` or the dict itself.
    generated_at : str, optional
        Timestamp printed in the footer; the current UTC time when None.
        Pass a fixed value for reproducible output.

    Returns
    -------
    dict
        Keys ``title``, ``scenario``, ``train``, ``model``, ``sections``,
        ``failed_checks``, ``summary`` (the summary dict), ``versions`` and
        ``generated_at``. Numbers are pre-formatted strings.
    """
    data = summary.to_dict() if hasattr(summary, "to_dict") else dict(summary)
    if generated_at is None:
        now = datetime.datetime.now(datetime.UTC)
        generated_at = now.isoformat(timespec="seconds").replace("+00:00", "Z")
    failed = data.get("failed_checks", getattr(summary, "failed_checks", ())) or ()
    return {
        "title": f"{scenario.name} — model summary",
        "scenario": {
            "name": str(scenario.name),
            "description": str(getattr(scenario, "description", "") or ""),
            "source": str(getattr(scenario, "source", "") or ""),
            "seed": str(getattr(scenario, "seed", "")),
            "slug": str(getattr(scenario, "slug", "")),
        },
        "train": _train_context(scenario.train),
        "model": _settings_rows(getattr(scenario, "model", None)),
        "track": _track_rows(getattr(scenario, "track", None)),
        "sections": _summary_sections(data),
        "failed_checks": [_format_value(item) for item in _as_list(failed)],
        "summary": data,
        "versions": _versions(),
        "generated_at": str(generated_at),
    }


def _train_context(train: Any) -> dict[str, Any]:
    vehicles = []
    for i, vehicle in enumerate(train.vehicles):
        vehicles.append(
            {
                "index": str(i),
                "name": str(getattr(vehicle, "name", "")),
                "mass_t": _format_number(vehicle.mass / 1000.0),
                "a0": _format_number(vehicle.a0),
                "a1": _format_number(vehicle.a1),
                "a2": _format_number(vehicle.a2),
                "traction_share": _format_number(getattr(vehicle, "traction_share", math.nan)),
                "length": _format_number(getattr(vehicle, "length", math.nan)),
            }
        )
    couplers = []
    for i, coupler in enumerate(train.couplers):
        virtual = bool(getattr(coupler, "virtual", False))
        couplers.append(
            {
                "index": str(i),
                "between": f"{i}–{i + 1}",
                "kind": "virtual" if virtual else "physical",
                "stiffness_kn_per_m": _format_number(coupler.stiffness / 1000.0),
                "damping_kn_s_per_m": _format_number(getattr(coupler, "damping", 0.0) / 1000.0),
                "spacing": _format_number(getattr(coupler, "spacing", math.nan)),
            }
        )
    total_mass = sum(float(v.mass) for v in train.vehicles)
    return {
        "name": str(getattr(train, "name", "")),
        "n_vehicles": str(len(vehicles)),
        "total_mass_t": _format_number(total_mass / 1000.0),
        "vehicles": vehicles,
        "couplers": couplers,
    }


def _settings_rows(settings: Any) -> list[dict[str, str]]:
    """Rows (name, value, unit) of a settings dataclass or plain object."""
    if settings is None:
        return []
    if dataclasses.is_dataclass(settings) and not isinstance(settings, type):
        items = [(f.name, getattr(settings, f.name)) for f in dataclasses.fields(settings)]
    elif isinstance(settings, Mapping):
        items = list(settings.items())
    else:
        items = [(k, v) for k, v in vars(settings).items() if not k.startswith("_")]
    rows = []
    for name, value in items:
        rows.append({"name": _humanise(name), "value": _format_value(value), "unit": _unit(name)})
        if name == "speed" and _is_real(value):
            rows.append(
                {
                    "name": "Speed (km/h)",
                    "value": _format_number(float(value) * 3.6),
                    "unit": "km/h",
                }
            )
    return rows


def _track_rows(track: Any) -> list[dict[str, str]]:
    """Rows (start, grade, curve radius) of a track, or [] for flat straight track."""
    if track is None:
        return []
    rows = []
    for section in getattr(track, "sections", ()):
        radius = float(getattr(section, "curve_radius", math.inf))
        rows.append(
            {
                "start": _format_number(getattr(section, "start", math.nan)),
                "grade_permille": _format_number(getattr(section, "grade_permille", 0.0)),
                "curve_radius": "straight" if math.isinf(radius) else _format_number(radius),
            }
        )
    return rows


def _summary_sections(data: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Split a summary dict into displayable sections.

    Scalars (and lists of scalars) go to an "Overview" key/value section,
    lists of dicts become tables, dicts become key/value sections.
    """
    overview: list[dict[str, str]] = []
    sections: list[dict[str, Any]] = []
    for key, value in data.items():
        if key == "failed_checks":
            continue
        title = _humanise(key)
        if isinstance(value, Mapping):
            rows = [
                {"name": _humanise(k), "value": _format_value(v), "unit": _unit(k, key)}
                for k, v in value.items()
            ]
            sections.append({"title": title, "kind": "mapping", "rows": rows})
        elif _is_table(value):
            columns: list[str] = []
            for row in value:
                columns.extend(k for k in row if k not in columns)
            sections.append(
                {
                    "title": title,
                    "kind": "table",
                    "columns": [_column_header(c) for c in columns],
                    "rows": [[_format_cell(c, row.get(c)) for c in columns] for row in value],
                }
            )
        else:
            overview.append({"name": title, "value": _format_value(value), "unit": _unit(key)})
    if overview:
        sections.insert(0, {"title": "Overview", "kind": "mapping", "rows": overview})
    return sections


def _is_table(value: Any) -> bool:
    return (
        isinstance(value, Sequence)
        and not isinstance(value, (str, bytes))
        and len(value) > 0
        and all(isinstance(row, Mapping) for row in value)
    )


def _versions() -> list[dict[str, str]]:
    rows = [{"name": "trainctl", "version": __version__}]
    for name in REPORT_PACKAGES:
        try:
            version = metadata.version(name)
        except metadata.PackageNotFoundError:
            version = "not installed"
        rows.append({"name": name, "version": version})
    rows.append({"name": "python", "version": platform.python_version()})
    return rows


# --------------------------------------------------------------------------- formatting


def _humanise(key: str) -> str:
    if key in _LABELS:
        return _LABELS[key]
    text = str(key).replace("_", " ").strip()
    return text[:1].upper() + text[1:]


def _unit(key: str, section: str | None = None) -> str:
    if section is not None and f"{section}.{key}" in _SECTION_UNITS:
        return _SECTION_UNITS[f"{section}.{key}"]
    return _UNITS.get(str(key), "")


def _column_header(key: str) -> str:
    unit = _unit(key)
    return f"{_humanise(key)} [{unit}]" if unit else _humanise(key)


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _format_number(value: Any) -> str:
    """Format a real number compactly (6 significant digits)."""
    x = float(value)
    if math.isnan(x):
        return "—"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return f"{x:.6g}"


def _format_complex(re: Any, im: Any) -> str:
    real, imag = float(re), float(im)
    if imag == 0.0:
        return _format_number(real)
    sign = "+" if imag > 0 else "−"
    return f"{_format_number(real)} {sign} {_format_number(abs(imag))}j"


def _format_cell(key: str, value: Any) -> str:
    if (
        key == "eigenvalue"
        and isinstance(value, Sequence)
        and not isinstance(value, str)
        and len(value) == 2
        and all(_is_real(v) for v in value)
    ):
        return _format_complex(value[0], value[1])
    return _format_value(value)


def _format_value(value: Any) -> str:
    """Format any JSON-like value as short display text."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, complex):
        return _format_complex(value.real, value.imag)
    if _is_real(value):
        return _format_number(value)
    if isinstance(value, str):
        return value
    if isinstance(value, Mapping):
        return ", ".join(f"{k}: {_format_value(v)}" for k, v in value.items())
    if isinstance(value, Sequence) or hasattr(value, "tolist"):
        items = value.tolist() if hasattr(value, "tolist") else value
        if not isinstance(items, list):
            return _format_value(items)
        return "[" + ", ".join(_format_value(v) for v in items) + "]"
    return str(value)


def _as_list(value: Any) -> list[Any]:
    if isinstance(value, (str, bytes, Mapping)):
        return [value]
    return list(value)


# --------------------------------------------------------------------------- render / write


def render_summary_report(context: Mapping[str, Any]) -> str:
    """Render the summary report page.

    Parameters
    ----------
    context : Mapping
        The dict from :func:`build_summary_context`.

    Returns
    -------
    str
        A complete, self-contained HTML5 document.
    """
    template = make_environment().get_template(SUMMARY_TEMPLATE)
    return template.render(**context, css=Markup(_stylesheet()))


def write_text_atomic(text: str, path: str | os.PathLike[str]) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically.

    The text goes to a temporary file in the destination directory, which is
    then renamed over ``path`` with :func:`os.replace`; readers never see a
    partial file, and on error nothing is left behind. Missing parent
    directories are created.

    Parameters
    ----------
    text : str
        File content.
    path : str or os.PathLike
        Destination file.

    Returns
    -------
    pathlib.Path
        ``path`` as a :class:`~pathlib.Path`.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     out = write_text_atomic("hi", Path(tmp) / "sub" / "a.txt")
    ...     out.read_text(encoding="utf-8")
    'hi'
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    data = text.encode("utf-8")
    tmp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
    # os.open honours the umask (unlike mkstemp's 0600), so the result gets the
    # permissions a plain open() would give it.
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return target


def write_report(html: str, path: str | os.PathLike[str]) -> Path:
    """Write a rendered report atomically, creating the parent directory.

    Parameters
    ----------
    html : str
        The page from :func:`render_summary_report`.
    path : str or os.PathLike
        Destination file, e.g. ``reports/crh2-dmpc.html``.

    Returns
    -------
    pathlib.Path
        ``path`` as a :class:`~pathlib.Path`.
    """
    return write_text_atomic(html, path)
