# The saved form of a SimulationResult, declared and checked: result.json and arrays.npz.
"""Validate a directory written by :meth:`SimulationResult.save` before loading it.

``result.json`` is declared by :class:`ResultFile` (format
:data:`~trainctl.sim.results.FORMAT`); ``arrays.npz`` must hold the result's
arrays (:data:`~trainctl.sim.results.ARRAY_NAMES`, and optionally
:data:`~trainctl.sim.results.OPTIONAL_ARRAY_NAMES`, nothing else), numeric and
finite, loadable without pickles. Problems are
:class:`~trainctl.exceptions.ModelError` s naming the file and the key or
array; the shapes are then checked by :class:`SimulationResult` itself, whose
message gets the file name in front.
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Any

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

from .._files import require_regular
from ..exceptions import ModelError
from ..jsonfile import FiniteFloat, read_json, validate_json
from .results import ARRAY_NAMES, FORMAT, OPTIONAL_ARRAY_NAMES

__all__ = ["RESULT_HINT", "ResultFile", "read_result"]

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
    statuses: list[StrictStr]
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
    return {**arrays, "statuses": tuple(doc.statuses), "fallbacks": tuple(doc.fallbacks),
            "residuals": tuple(tuple(r) for r in doc.residuals),
            "controller_name": doc.controller_name, "seed": doc.seed, "dt": doc.dt,
            "meta": doc.meta}


def _read_arrays(path: Path) -> dict[str, np.ndarray]:
    try:
        require_regular(path)  # numpy.load would block on a named pipe
    except OSError as exc:
        raise ModelError(f"{path}: {exc.strerror}.{RESULT_HINT}") from None
    if path.is_file() and not zipfile.is_zipfile(path):
        raise ModelError(f"{path}: not a NumPy .npz archive (no zip structure).{RESULT_HINT}")
    try:
        with np.load(path, allow_pickle=False) as data:
            names = set(data.files)
            missing = [name for name in ARRAY_NAMES if name not in names]
            if missing:
                raise ModelError(f"{path}: missing array {missing[0]!r} (it must hold "
                                 f"{', '.join(ARRAY_NAMES)}).{RESULT_HINT}")
            unknown = sorted(names - set(ARRAY_NAMES) - set(OPTIONAL_ARRAY_NAMES))
            if unknown:
                raise ModelError(f"{path}: unknown array {unknown[0]!r}.{RESULT_HINT}")
            arrays = {name: data[name] for name in (*ARRAY_NAMES, *OPTIONAL_ARRAY_NAMES)
                      if name in names}
    except FileNotFoundError:
        raise ModelError(f"{path}: file not found.{RESULT_HINT}") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        if isinstance(exc, ModelError):
            raise
        raise ModelError(f"{path}: not a readable NumPy archive ({exc}).{RESULT_HINT}") from None
    for name, value in arrays.items():
        if value.dtype.kind not in "iuf":
            raise ModelError(f"{path}: array {name!r} must hold numbers (got dtype "
                             f"{value.dtype}).{RESULT_HINT}")
        if value.dtype.kind == "f" and not np.all(np.isfinite(value)):
            index = [int(i) for i in np.argwhere(~np.isfinite(value))[0]]
            raise ModelError(f"{path}: array {name!r} must be finite (got "
                             f"{value[tuple(index)]} at {index}).{RESULT_HINT}")
    return arrays
