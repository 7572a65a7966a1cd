# The saved form of a SimulationResult, declared and checked: result.json and arrays.npz.
"""Validate a directory written by :meth:`SimulationResult.save` before loading it.

``result.json`` is declared by :class:`ResultFile` (format
:data:`~trainctl.sim.results.FORMAT`); ``arrays.npz`` must hold the result's
arrays (:data:`~trainctl.sim.results.ARRAY_NAMES`, and optionally
:data:`~trainctl.sim.results.OPTIONAL_ARRAY_NAMES`, nothing else), numeric and
finite, loadable without pickles. Every member's header (``numpy.lib.format``) is
read and checked first — its dtype, its shape against its uncompressed size
in the zip archive and the archive against :data:`MAX_ARRAY_BYTES` — so that
no array is read whose header lies. Then the values: statuses from
:data:`~trainctl.controllers.base.STATUSES`, iteration counts integral and
non-negative, time strictly increasing in steps of ``dt``. Problems are
:class:`~trainctl.exceptions.ModelError` s naming the file and the key or
array; the shapes are then checked by :class:`SimulationResult` itself, whose
message gets the file name in front.
"""

from __future__ import annotations

import math
import zipfile
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictFloat,
    StrictInt,
    StrictStr,
    field_validator,
)

from trainctl._files import require_regular
from trainctl.controllers.base import STATUSES
from trainctl.declare.constraints import Choice
from trainctl.declare.jsonfile import FiniteFloat, read_json, validate_json
from trainctl.exceptions import ModelError
from trainctl.sim.results import ARRAY_NAMES, FORMAT, OPTIONAL_ARRAY_NAMES

__all__ = ["MAX_ARRAY_BYTES", "RESULT_HINT", "ResultFile", "read_result"]

MAX_ARRAY_BYTES = 4 * 2**30
"""Largest total size of a saved result's arrays, uncompressed [bytes] (4 GiB): the
longest run allowed (:data:`~trainctl.declare.limits.MAX_SAMPLES`) of a long train is far
below it at the controller's samples; an archive declaring more is refused unread."""

_INTEGER_ARRAYS = {"iterations": "iu", "saturation": "biu"}
"""Arrays of counts or flags: their dtype must be integral (a count of 0.5 is refused)."""

RESULT_HINT = (" The saved result was edited or damaged; write it again with "
               "SimulationResult.save (or 'trainctl analyse SCENARIO --save DIR').")
"""The sentence every message about a saved result ends with."""


class ResultFile(BaseModel):
    """``result.json``: everything of a result except its arrays.

    Parameters
    ----------
    format : str
        The file format's name and version.
    controller_name : str
        The controller's name.
    seed : int
        Seed of the measurement-noise generator.
    dt : float
        Sample time [s], > 0.
    statuses : list of str
        Step status per sample.
    fallbacks : list of str
        Fallback applied per sample ("" when none).
    residuals : list of list of float
        Iteration residuals per sample [kN].
    meta : dict
        The result's JSON-safe extras.

    Examples
    --------
    >>> from pydantic import ValidationError
    >>> doc = {"format": FORMAT, "controller_name": "demo", "seed": 0, "dt": 10.0,
    ...        "statuses": ["optimal"], "fallbacks": [""], "residuals": [[]], "meta": {}}
    >>> ResultFile.model_validate(doc).dt  # [s]
    10.0
    >>> try:
    ...     ResultFile.model_validate({**doc, "dt": 0.0})  # a sample time must be > 0
    ... except ValidationError as exc:
    ...     print(exc.errors()[0]["loc"], exc.errors()[0]["type"])
    ('dt',) greater_than
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    format: StrictStr
    controller_name: StrictStr
    seed: StrictInt
    dt: FiniteFloat = Field(gt=0)
    statuses: list[Annotated[str, Choice(STATUSES)]]
    fallbacks: list[StrictStr]
    residuals: list[list[StrictFloat]]
    meta: dict[str, Any]

    @field_validator("format")
    @classmethod
    def _this_format(cls, value: str) -> str:
        if value != FORMAT:
            raise ValueError(f"must be {FORMAT!r}")
        return value


def read_result(directory: str | Path) -> dict[str, Any]:
    """The keyword arguments of :class:`SimulationResult` from a saved directory.

    Parameters
    ----------
    directory : str or pathlib.Path
        Holds ``result.json`` and ``arrays.npz``.

    Returns
    -------
    dict
        Arrays and fields, checked (not yet against each other's shapes).

    Raises
    ------
    ModelError
        Naming the file and the key or array at fault.

    Examples
    --------
    A one-sample result saved and read back (in a temporary directory):

    >>> import tempfile
    >>> from trainctl.sim.results import SimulationResult
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 10.0]), states=np.array([[10.0, 20.0], [0.0, 150.0]]),
    ...     velocities=np.array([[10.0, 20.0]]), coupler_forces=np.zeros((0, 2)),
    ...     inputs=np.array([[1000.0]]), reference_speed=np.array([10.0, 20.0]),
    ...     reference_acceleration=np.ones(2), statuses=("optimal",),
    ...     iterations=np.array([2]), residuals=((),), solve_times=np.array([0.01]),
    ...     fallbacks=("",), controller_name="demo", seed=0, dt=10.0)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     _ = result.save(folder)
    ...     fields = read_result(folder)
    >>> fields["controller_name"], fields["statuses"], fields["inputs"].tolist()  # [N]
    ('demo', ('optimal',), [[1000.0]])
    >>> SimulationResult(**fields).velocities.tolist()  # [m/s]
    [[10.0, 20.0]]
    """
    path = Path(directory)
    raw = read_json(path / "result.json", hint=RESULT_HINT, error=ModelError, finite=False)
    found = raw.get("format") if isinstance(raw, dict) else None
    if found != FORMAT:
        raise ModelError(f"{path / 'result.json'}: must be a {FORMAT!r} file (got format "
                         f"{found!r}). Write it with SimulationResult.save.")
    doc = validate_json(raw, ResultFile, path / "result.json", hint=RESULT_HINT,
                        error=ModelError)
    arrays = _read_arrays(path / "arrays.npz")
    _check_values(path, doc, arrays)
    return {**arrays, "statuses": tuple(doc.statuses), "fallbacks": tuple(doc.fallbacks),
            "residuals": tuple(tuple(r) for r in doc.residuals),
            "controller_name": doc.controller_name, "seed": doc.seed, "dt": doc.dt,
            "meta": doc.meta}


def _read_arrays(path: Path) -> dict[str, np.ndarray]:
    try:
        require_regular(path)  # a zip reader would block on a named pipe
    except OSError as exc:
        raise ModelError(f"{path}: {exc.strerror}.{RESULT_HINT}") from None
    try:
        if not path.is_file():
            raise FileNotFoundError(path)
        with zipfile.ZipFile(path) as archive:
            headers = _headers(path, archive)
            arrays = {}
            for name, info in headers.items():
                with archive.open(info) as member:
                    arrays[name] = np.lib.format.read_array(member, allow_pickle=False)
    except FileNotFoundError:
        raise ModelError(f"{path}: file not found.{RESULT_HINT}") from None
    except zipfile.BadZipFile as exc:
        raise ModelError(f"{path}: not a NumPy .npz archive ({exc}).{RESULT_HINT}") from None
    except ModelError:
        raise
    except (OSError, ValueError, EOFError, RuntimeError, NotImplementedError) as exc:
        raise ModelError(f"{path}: not a readable NumPy archive ({exc}).{RESULT_HINT}") from None
    for name, value in arrays.items():
        if value.dtype.kind == "f" and not np.all(np.isfinite(value)):
            index = [int(i) for i in np.argwhere(~np.isfinite(value))[0]]
            raise ModelError(f"{path}: array {name!r} must be finite (got "
                             f"{value[tuple(index)]} at {index}).{RESULT_HINT}")
    return arrays


def _headers(path: Path, archive: zipfile.ZipFile) -> dict[str, zipfile.ZipInfo]:
    """Each member's .npy header checked against its size, before any array is read."""
    members: dict[str, zipfile.ZipInfo] = {}
    for info in archive.infolist():
        name = info.filename.removesuffix(".npy")
        if name in members or not info.filename.endswith(".npy"):
            what = "twice" if name in members else "(not an .npy array)"
            raise ModelError(f"{path}: holds member {info.filename!r} {what}.{RESULT_HINT}")
        members[name] = info
    missing = [name for name in ARRAY_NAMES if name not in members]
    if missing:
        raise ModelError(f"{path}: missing array {missing[0]!r} (it must hold "
                         f"{', '.join(ARRAY_NAMES)}).{RESULT_HINT}")
    unknown = sorted(set(members) - set(ARRAY_NAMES) - set(OPTIONAL_ARRAY_NAMES))
    if unknown:
        raise ModelError(f"{path}: unknown array {unknown[0]!r}.{RESULT_HINT}")
    total = sum(info.file_size for info in members.values())
    if total > MAX_ARRAY_BYTES:
        raise ModelError(f"{path}: its arrays declare {total} bytes uncompressed, more than the "
                         f"{MAX_ARRAY_BYTES} bytes ({MAX_ARRAY_BYTES / 2**30:g} GiB) a saved "
                         f"result may hold.{RESULT_HINT}")
    for name, info in members.items():
        with archive.open(info) as member:
            version = np.lib.format.read_magic(member)
            if version == (1, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_1_0(member)
            elif version == (2, 0):
                shape, fortran, dtype = np.lib.format.read_array_header_2_0(member)
            else:
                raise ModelError(f"{path}: array {name!r} has .npy format version {version}; "
                                 f"it must be 1.0 or 2.0.{RESULT_HINT}")
            offset = member.tell()
        kinds = _INTEGER_ARRAYS.get(name, "iuf")
        if dtype.hasobject or dtype.kind not in kinds or dtype.subdtype is not None \
                or dtype.names is not None:
            want = "integers" if name in _INTEGER_ARRAYS else "numbers"
            raise ModelError(f"{path}: array {name!r} must hold {want} (got dtype "
                             f"{dtype}).{RESULT_HINT}")
        if not all(isinstance(n, int) and n >= 0 for n in shape):
            raise ModelError(f"{path}: array {name!r} has an invalid shape {shape}.{RESULT_HINT}")
        size = math.prod(shape) * dtype.itemsize
        if offset + size != info.file_size:
            raise ModelError(f"{path}: array {name!r} declares shape {shape} of {dtype} "
                             f"({size} bytes) but its member holds {info.file_size - offset} "
                             f"bytes of data.{RESULT_HINT}")
    return members


def _check_values(path: Path, doc: ResultFile, arrays: dict[str, np.ndarray]) -> None:
    """Relations between the values: counts, time, the vehicle count of ``meta``."""
    where = path / "arrays.npz"
    for name in ("iterations", "solve_times"):
        value = arrays[name]
        if value.size and value.min() < 0:
            raise ModelError(f"{where}: array {name!r} must be >= 0 (got {value.min()})."
                             f"{RESULT_HINT}")
    time = arrays["time"]
    if time.ndim == 1 and time.size > 1:
        steps = np.diff(time)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0))
            raise ModelError(f"{where}: array 'time' must increase strictly (got {time[i]!r} then "
                             f"{time[i + 1]!r} at [{i + 1}]).{RESULT_HINT}")
        if not np.allclose(steps, doc.dt, rtol=1e-9, atol=1e-9 * abs(doc.dt)):
            i = int(np.argmax(~np.isclose(steps, doc.dt, rtol=1e-9, atol=1e-9 * abs(doc.dt))))
            raise ModelError(f"{where}: array 'time' must advance by dt = {doc.dt!r} s per sample "
                             f"(result.json) (got a step of {steps[i]!r} s at [{i + 1}])."
                             f"{RESULT_HINT}")
    n_meta = doc.meta.get("n_vehicles")
    velocities = arrays["velocities"]
    if n_meta is not None and velocities.ndim == 2 and n_meta != velocities.shape[0]:
        raise ModelError(f"{path / 'result.json'}: meta.n_vehicles must be the arrays' vehicle "
                         f"count {velocities.shape[0]} (got {n_meta!r}).{RESULT_HINT}")
