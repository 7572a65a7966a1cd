# Reading trainctl's own JSON files back: parsed, validated by a pydantic model, worded once.
"""Read a JSON file that trainctl wrote and validate it with a declared model.

Saved runs (``trainctl-run.json``, ``result.json``) are declared as pydantic
models, as scenario files are; :func:`load_json` reads one, and any problem —
a missing file, text that is not JSON, a number that is not finite, a key
missing, unknown or of the wrong type — becomes one trainctl error whose
message names the file and the key path (``results.checks[3].status``), says
what must hold and what was found, and how to get a good file again.

Examples
--------
>>> import tempfile, pathlib
>>> from pydantic import BaseModel
>>> class Doc(BaseModel):
...     format: str
...     dt: FiniteFloat
>>> with tempfile.TemporaryDirectory() as tmp:
...     path = pathlib.Path(tmp) / "doc.json"
...     _ = path.write_text('{"format": "x", "dt": "fast"}')
...     try:
...         load_json(path, Doc)
...     except ValueError as exc:
...         print(str(exc).split(": ", 1)[1])
dt must be a valid number (got 'fast', a string).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, TypeVar

from pydantic import AfterValidator, BaseModel, StrictFloat, ValidationError

from trainctl._files import read_regular
from trainctl.declare.keys import first_error, violation_of
from trainctl.declare.violations import ERROR_TYPE, NOTHING
from trainctl.exceptions import ScenarioError, TrainctlError

__all__ = ["MAX_JSON_BYTES", "FiniteFloat", "json_path", "load_json", "model_error", "read_json",
           "validate_json"]

MAX_JSON_BYTES = 256 * 2**20
"""Largest JSON file trainctl reads back [bytes] (256 MiB): the manifest of a saved run of
the longest train is a few megabytes; parsing takes about twice a file's size in memory, so a
larger (or sparse) file is refused before it is read."""

_M = TypeVar("_M", bound=BaseModel)


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("must be a finite number")
    return value


FiniteFloat = Annotated[StrictFloat, AfterValidator(_finite)]
"""A JSON number that must be finite (JSON files may hold NaN and Infinity tokens)."""


def json_path(loc: Sequence[str | int]) -> str:
    """``("results", "checks", 3, "status")`` -> ``"results.checks[3].status"``.

    Parameters
    ----------
    loc : sequence of str or int
        Keys and list indices from the document's root.

    Returns
    -------
    str
        The dotted path, "the document" for the root.

    Examples
    --------
    >>> json_path(("results", "checks", 3, "status")), json_path(())
    ('results.checks[3].status', 'the document')
    """
    text = ""
    for part in loc:
        if part == "[key]":  # pydantic's marker: the key itself of the mapping is at fault
            text += " key"
            continue
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else str(part))
    return text or "the document"


def _got(value: Any) -> str:
    if value is NOTHING:
        return ""
    if isinstance(value, bool):
        return f" (got {str(value).lower()}, a boolean)"
    if isinstance(value, int | float):
        text = repr(value)
        return f" (got {text if len(text) <= 40 else f'a number of {len(text)} digits'})"
    if isinstance(value, str):
        short = value if len(value) <= 40 else value[:37] + "..."
        return f" (got {short!r}, a string)"
    if isinstance(value, list):
        return f" (got a list of {len(value)} items)"
    if isinstance(value, dict):
        return " (got an object)"
    return f" (got {type(value).__name__})" if value is not None else " (got null)"


def model_error(exc: ValidationError) -> str:
    """One sentence for the first error of a validation: the key path, what must hold, the value.

    Parameters
    ----------
    exc : pydantic.ValidationError
        The validation error.

    Returns
    -------
    str
        ``"missing required key 'results.equilibrium'"``, ``"unknown key 'x'"``
        or ``"dt must be a valid number (got 'fast', a string)"``.

    Examples
    --------
    >>> from pydantic import BaseModel, ConfigDict, ValidationError
    >>> class Doc(BaseModel):
    ...     model_config = ConfigDict(extra="forbid")
    ...     format: str
    ...     dt: FiniteFloat
    >>> for document in ({"format": "x"}, {"format": "x", "dt": 0.1, "x": 1},
    ...                  {"format": "x", "dt": float("nan")}):
    ...     try:
    ...         Doc.model_validate(document)
    ...     except ValidationError as exc:
    ...         print(model_error(exc))
    missing required key 'dt'
    unknown key 'x'
    dt must be a finite number (got nan)
    """
    errors = exc.errors()
    error = next((e for e in errors if e["type"] == "missing"), None) or first_error(exc)
    path = json_path(error["loc"])
    kind = error["type"]
    if kind == "missing":
        return f"missing required key {path!r}"
    if kind == "extra_forbidden":
        return f"unknown key {path!r}"
    if kind == ERROR_TYPE:
        violation = violation_of(error)
        return f"{path} {violation.text}{_got(violation.got)}"
    message = str(error["msg"])
    message = message.removeprefix("Value error, ").removeprefix("Input ")
    message = message.replace("should be", "must be", 1)
    for noun in ("String", "List", "Dictionary", "Tuple", "Value"):  # "List should have ..."
        if message.startswith(f"{noun} should "):
            message = "must " + message.removeprefix(f"{noun} should ")
    if not message.startswith("must"):
        message = f"is invalid: {message}"
    return f"{path} {message}{_got(error.get('input', NOTHING))}"


def _no_constant(name: str) -> float:
    raise ValueError(f"the non-finite number {name} (JSON has no NaN or Infinity)")


def read_json(path: Path, *, hint: str = "", error: type[TrainctlError] = ScenarioError,
              finite: bool = True, max_bytes: int = MAX_JSON_BYTES) -> Any:
    """Parse a JSON file; a missing, unreadable or non-JSON file is a trainctl error.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    hint : str
        Sentences appended to every message (how to get a good file).
    error : type
        The trainctl error class to raise.
    finite : bool
        Refuse the ``NaN`` and ``Infinity`` tokens (Python's JSON writes
        them for non-finite floats); False leaves them to the model, whose
        :data:`FiniteFloat` fields refuse them where a number must be finite.
    max_bytes : int
        Largest size accepted [bytes]; a larger file is refused from its
        size, before it is read (:data:`MAX_JSON_BYTES`).

    Returns
    -------
    object
        The document.

    Raises
    ------
    TrainctlError
        Of class ``error``, naming the file.

    Examples
    --------
    Python's ``json`` module writes ``NaN`` for a non-finite float, which is
    not JSON; it is refused unless ``finite=False``:

    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = Path(tmp) / "run.json"
    ...     _ = path.write_text('{"dt": 0.5, "cost": NaN}')
    ...     print(read_json(path, finite=False))
    ...     try:
    ...         read_json(path)
    ...     except ScenarioError as exc:
    ...         print(str(exc).split(": ", 1)[1])
    {'dt': 0.5, 'cost': nan}
    not a valid trainctl file (the non-finite number NaN (JSON has no NaN or Infinity)).
    """
    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise error(f"{path}: is {size} bytes, more than the {max_bytes} bytes "
                        f"({max_bytes / 2**20:g} MiB) a trainctl file may have; it is not "
                        f"one trainctl wrote.{hint}")
        # a pipe or device is refused, never waited on; bounded whatever the file is
        raw = read_regular(path, max_bytes)
        if len(raw) > max_bytes:
            raise error(f"{path}: holds more than the {max_bytes} bytes "
                        f"({max_bytes / 2**20:g} MiB) a trainctl file may have; it is not one "
                        f"trainctl wrote.{hint}")
        text = raw.decode("utf-8")
    except FileNotFoundError:
        raise error(f"{path}: file not found.{hint}") from None
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start}).{hint}") from None
    except OSError as exc:
        raise error(f"{path}: cannot read the file ({exc.strerror or exc}).{hint}") from None
    try:
        return json.loads(text, parse_constant=_no_constant if finite else None)
    except json.JSONDecodeError as exc:
        raise error(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno}, column "
                    f"{exc.colno}).{hint}") from None
    except (ValueError, RecursionError) as exc:
        raise error(f"{path}: not a valid trainctl file ({exc}).{hint}") from None


def load_json(path: Path, model: type[_M], *, hint: str = "",
              error: type[TrainctlError] = ScenarioError) -> _M:
    """Read ``path`` and validate it with ``model``.

    Parameters
    ----------
    path : pathlib.Path
        The file.
    model : type of pydantic.BaseModel
        Its declaration.
    hint : str
        Sentences appended to every message.
    error : type
        The trainctl error class to raise.

    Returns
    -------
    pydantic.BaseModel
        The validated document.

    Raises
    ------
    TrainctlError
        Of class ``error``: ``"FILE: KEY must ... (got ...).hint"``.

    Examples
    --------
    >>> import tempfile
    >>> from pydantic import BaseModel
    >>> class Doc(BaseModel):
    ...     format: str
    ...     dt: FiniteFloat
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = Path(tmp) / "doc.json"
    ...     _ = path.write_text('{"format": "run", "dt": 0.5}')
    ...     doc = load_json(path, Doc)
    ...     try:
    ...         load_json(Path(tmp) / "missing.json", Doc, hint=" Save the run again.")
    ...     except ScenarioError as exc:
    ...         print(str(exc).split(": ", 1)[1])
    file not found. Save the run again.
    >>> doc.format, doc.dt  # dt [s]
    ('run', 0.5)
    """
    return validate_json(read_json(path, hint=hint, error=error), model, path, hint=hint,
                         error=error)


def validate_json(document: Any, model: type[_M], path: Path, *, hint: str = "",
                  error: type[TrainctlError] = ScenarioError) -> _M:
    """Validate a parsed document with ``model`` (see :func:`load_json`).

    Parameters
    ----------
    document : object
        From :func:`read_json`.
    model : type of pydantic.BaseModel
        Its declaration.
    path : pathlib.Path
        The file it came from (for the message).
    hint : str
        Sentences appended to the message.
    error : type
        The trainctl error class to raise.

    Returns
    -------
    pydantic.BaseModel
        The validated document.

    Raises
    ------
    TrainctlError
        Of class ``error``, naming the file and the key.

    Examples
    --------
    The path only labels the message; nothing is read:

    >>> from pydantic import BaseModel
    >>> class Doc(BaseModel):
    ...     format: str
    ...     dt: FiniteFloat
    >>> validate_json({"format": "run", "dt": 0.5}, Doc, Path("run.json")).dt
    0.5
    >>> validate_json({"format": "run"}, Doc, Path("run.json"), hint=" Save the run again.")
    Traceback (most recent call last):
        ...
    trainctl.exceptions.ScenarioError: run.json: missing required key 'dt'. Save the run again.
    """
    try:
        return model.model_validate(document)
    except ValidationError as exc:
        raise error(f"{path}: {model_error(exc)}.{hint}") from None
