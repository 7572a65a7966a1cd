# Argument checks of the MPC core: one place for its messages.
"""Checks of the MPC core's arguments (:func:`~.linear.make_linear_mpc`, ``solve``).

Every failure is a trainctl error with the message shape
``where: what must hold (got what). hint.``: :class:`DimensionError` for
shapes, :class:`ModelError` for values, ``TypeError`` for a system that is
not a ``control.StateSpace``.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Mapping
from dataclasses import dataclass

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.controllers.mpc.theory.mpc import FORMS
from trainctl.exceptions import DimensionError, ModelError

__all__ = ["BOUND_GROUPS", "SOFT_PENALTY", "CoreSettings", "as_bound", "as_soft", "as_vector",
           "as_weight", "check_horizons", "check_system", "core_settings"]

Array = NDArray[np.float64]

BOUND_GROUPS = ("u", "du", "x", "y")
"""Bounded quantities: inputs, input rates, states, outputs."""

SOFT_PENALTY = (1e3, 1e2)
"""Default (linear, quadratic) penalty of a soft bound, as :class:`~.settings.MPCConstraints`."""


@dataclass(frozen=True, kw_only=True)
class CoreSettings:
    """Validated arguments of :func:`~.linear.make_linear_mpc` (see there).

    Parameters
    ----------
    A, B, C : ndarray
        The discrete model's matrices.
    dt : float
        Its sample time [s].
    Q : ndarray
        Output weight (ny, ny).
    R : ndarray
        Plan weight (nu, nu).
    Qf : ndarray or None
        Terminal state weight (nx, nx), or None.
    P : int
        Prediction horizon [samples].
    M : int
        Control horizon [moves].
    form : {"u", "du"}
        The decision.
    bounds : dict
        Per group (``"u"``, ``"du"``, ``"x"``, ``"y"``): the (lower, upper) vectors.
    soft : dict
        Per group: None (hard) or the (linear, quadratic) slack penalties.

    Examples
    --------
    The settings of a double integrator sampled at 0.1 s (position
    measured), one move per step over 5 steps:

    >>> sysd = ct.ss([[1.0, 0.1], [0.0, 1.0]], [[0.0], [0.1]], [[1.0, 0.0]], 0, dt=0.1)
    >>> cs = core_settings("demo", sysd, Q=1.0, R=0.1, P=5, M=None, Qf=None, form="u",
    ...                    bounds={"u": (-1.0, 1.0)}, soft=None)
    >>> cs.P, cs.M, cs.dt, cs.R.tolist()
    (5, 5, 0.1, [[0.1]])
    >>> cs.bounds["u"][1].tolist(), cs.soft["u"]
    ([1.0], None)
    """

    A: Array
    B: Array
    C: Array
    dt: float
    Q: Array
    R: Array
    Qf: Array | None
    P: int
    M: int
    form: str
    bounds: dict[str, tuple[Array, Array]]
    soft: dict[str, tuple[float, float] | None]


_DISCRETISE = ("Discretise it first, e.g. control.sample_system(sys, T) or "
               "trainctl.models.discretise(sys, T).")


def check_system(where: str, sysd: object) -> tuple[Array, Array, Array, float]:
    """(A, B, C, dt) of a discrete, strictly proper ``control.StateSpace``.

    Parameters
    ----------
    where : str
        The caller's name, for error messages.
    sysd : object
        The model given.

    Returns
    -------
    tuple
        The matrices A, B, C and the sample time dt [s].

    Examples
    --------
    >>> sysd = ct.ss([[1.0, 0.1], [0.0, 1.0]], [[0.0], [0.1]], [[1.0, 0.0]], 0, dt=0.1)
    >>> A, B, C, dt = check_system("demo", sysd)
    >>> A.shape, B.shape, C.shape, dt
    ((2, 2), (2, 1), (1, 2), 0.1)
    >>> continuous = ct.ss([[0.0]], [[1.0]], [[1.0]], 0)  # dt = 0: continuous time
    >>> check_system("demo", continuous)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: demo: 'sysd' must be discrete-time with a sample time ...
    """
    if not isinstance(sysd, ct.StateSpace):
        raise TypeError(f"{where}: 'sysd' must be a discrete control.StateSpace (got "
                        f"{type(sysd).__name__}). Build one with control.ss(A, B, C, 0, dt=T).")
    dt = sysd.dt
    if dt is None or isinstance(dt, bool) or not dt > 0:
        kind = ("a continuous-time system" if dt == 0 else
                "a discrete system without a sample time" if dt is True
                else "an unspecified time base")
        raise ModelError(f"{where}: 'sysd' must be discrete-time with a sample time dt > 0 "
                         f"(got dt = {dt!r}, {kind}). {_DISCRETISE}")
    A, B, C, D = (np.asarray(m, dtype=float) for m in (sysd.A, sysd.B, sysd.C, sysd.D))
    if A.shape[0] == 0 or B.shape[1] == 0:
        raise DimensionError(f"{where}: 'sysd' needs at least one state and one input "
                             f"(got {A.shape[0]} states, {B.shape[1]} inputs).")
    if np.any(D != 0):
        raise ModelError(f"{where}: 'sysd' must have no direct feedthrough, D = 0 (got max |D| = "
                         f"{float(np.max(np.abs(D))):.3g}). The MPC predicts y = C x; put the "
                         "feedthrough into the model (augment the state with u) or leave it out.")
    for name, m in (("A", A), ("B", B), ("C", C)):
        if not np.all(np.isfinite(m)):
            raise ModelError(f"{where}: 'sysd' has non-finite entries in {name}.")
    return A, B, C, float(dt)


def check_horizons(where: str, prediction_horizon: object,
                   control_horizon: object | None) -> tuple[int, int]:
    """(P, M) as ints with 1 <= M <= P (M = P when None).

    Parameters
    ----------
    where : str
        The caller's name, for error messages.
    prediction_horizon : object
        P as given.
    control_horizon : object or None
        M as given, or None.

    Returns
    -------
    tuple of int
        The horizons (P, M).

    Examples
    --------
    >>> check_horizons("demo", 10, None), check_horizons("demo", 10, 3)
    ((10, 10), (10, 3))
    >>> check_horizons("demo", 4, 6)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: demo: 'control_horizon' must be an int with 1 <= M <= P ...
    """
    P = _int(where, "prediction_horizon", prediction_horizon)
    if P < 1:
        raise ModelError(f"{where}: 'prediction_horizon' must be an int >= 1 (got {P}).")
    M = P if control_horizon is None else _int(where, "control_horizon", control_horizon)
    if not 1 <= M <= P:
        raise ModelError(f"{where}: 'control_horizon' must be an int with 1 <= M <= P = {P} "
                         f"(got M = {M}). The plan has at most one move per prediction step; "
                         "leave control_horizon out for M = P.")
    return P, M


def _int(where: str, name: str, value: object) -> int:
    if isinstance(value, bool):
        raise ModelError(f"{where}: {name!r} must be an int (got {value!r}).")
    try:
        return operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise ModelError(f"{where}: {name!r} must be an int (got {value!r}).") from None


def _array(where: str, name: str, value: object) -> Array:
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{where}: {name!r} must be real numbers in a scalar, vector or "
                         f"matrix (got {value!r}).") from None
    if np.any(np.isnan(arr)):
        raise ModelError(f"{where}: {name!r} must not contain NaN (got {arr.tolist()}).")
    return arr


def as_weight(where: str, name: str, value: ArrayLike, n: int, what: str) -> Array:
    """An (n, n) symmetric positive semidefinite weight from a scalar, a diagonal or a matrix.

    Parameters
    ----------
    where : str
        The caller's name, for error messages.
    name : str
        The argument's name.
    value : array_like
        The weight given.
    n : int
        The size wanted.
    what : str
        What the weighted entries are, for messages.

    Returns
    -------
    ndarray
        The weight matrix, shape (n, n).

    Examples
    --------
    A scalar weights every entry alike; a vector is the diagonal:

    >>> as_weight("demo", "Q", 2.0, 2, "outputs").tolist()
    [[2.0, 0.0], [0.0, 2.0]]
    >>> as_weight("demo", "Q", [1.0, 3.0], 2, "outputs").tolist()
    [[1.0, 0.0], [0.0, 3.0]]
    >>> indefinite = [[1.0, 2.0], [2.0, 1.0]]  # eigenvalues 3 and -1
    >>> as_weight("demo", "Q", indefinite, 2, "outputs")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: demo: 'Q' must be positive semidefinite (got smallest ...
    """
    arr = _array(where, name, value)
    if arr.ndim == 0:
        arr = float(arr) * np.eye(n)
    elif arr.ndim == 1 and arr.shape == (n,):
        arr = np.diag(arr)
    elif arr.shape != (n, n):
        raise DimensionError(f"{where}: {name!r} weights the {n} {what} and must be an ({n}, {n}) "
                             f"matrix, a length-{n} diagonal or a scalar (got shape {arr.shape}).")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: {name!r} must be finite (got {arr.tolist()}).")
    scale = max(1.0, float(np.max(np.abs(arr))))
    if not np.allclose(arr, arr.T, rtol=0.0, atol=1e-10 * scale):
        raise ModelError(f"{where}: {name!r} must be symmetric (max |{name} - {name}ᵀ| = "
                         f"{float(np.max(np.abs(arr - arr.T))):.3g}). Use ({name} + {name}ᵀ)/2, "
                         "which has the same cost.")
    smallest = float(np.min(np.linalg.eigvalsh(arr)))
    if smallest < -1e-10 * scale:
        raise ModelError(f"{where}: {name!r} must be positive semidefinite (got smallest "
                         f"eigenvalue {smallest:.3g}). A weight is a cost: every eigenvalue "
                         "must be >= 0, e.g. W = Lᵀ L.")
    return np.asarray(arr, dtype=np.float64)


def as_vector(where: str, name: str, value: ArrayLike, n: int, what: str) -> Array:
    """A length-n float vector from a length-n sequence or column (finite entries).

    Parameters
    ----------
    where : str
        The caller's name, for error messages.
    name : str
        The argument's name.
    value : array_like
        The vector given.
    n : int
        The length wanted.
    what : str
        What the entries are, for messages.

    Returns
    -------
    ndarray
        The vector, shape (n,).

    Examples
    --------
    >>> as_vector("demo", "x0", [[1.0], [2.0]], 2, "states").tolist()  # a column is flattened
    [1.0, 2.0]
    >>> as_vector("demo", "x0", [1.0, 2.0, 3.0], 2, "states")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    trainctl.exceptions.DimensionError: demo: 'x0' must be a vector of the 2 states (got ...
    """
    arr = _array(where, name, value)
    if arr.shape == (n, 1):
        arr = arr[:, 0]
    if arr.ndim != 1 or arr.shape[0] != n:
        raise DimensionError(f"{where}: {name!r} must be a vector of the {n} {what} "
                             f"(got shape {arr.shape}).")
    if not np.all(np.isfinite(arr)):
        raise ModelError(f"{where}: {name!r} must be finite (got {arr.tolist()}).")
    return np.asarray(arr, dtype=np.float64)


def as_bound(where: str, name: str, value: ArrayLike | None, n: int, what: str,
             fill: float) -> Array:
    """A length-n bound from None (``fill``), a scalar or a vector; ±inf allowed.

    Parameters
    ----------
    where : str
        The caller's name, for error messages.
    name : str
        The argument's name.
    value : array_like or None
        The bound given.
    n : int
        The length wanted.
    what : str
        What the entries are, for messages (e.g. "inputs").
    fill : float
        The value of a bound not given (±inf).

    Returns
    -------
    ndarray
        The bound, shape (n,).

    Examples
    --------
    >>> as_bound("demo", "u_max", None, 2, "inputs", np.inf).tolist()  # not given: no bound
    [inf, inf]
    >>> as_bound("demo", "u_max", 300.0, 2, "inputs", np.inf).tolist()  # a scalar for each [kN]
    [300.0, 300.0]
    """
    if value is None:
        return np.full(n, fill)
    arr = _array(where, name, value)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise DimensionError(f"{where}: {name!r} bounds the {n} {what} and must be a scalar or "
                             f"a length-{n} vector (got shape {arr.shape}).")
    return np.asarray(arr, dtype=np.float64)


def check_order(where: str, lower: tuple[str, Array], upper: tuple[str, Array]) -> None:
    """Raise unless lower <= upper elementwise."""
    (lname, lo), (uname, hi) = lower, upper
    bad = np.flatnonzero(lo > hi)
    if bad.size:
        i = int(bad[0])
        raise ModelError(f"{where}: {lname!r} must not exceed {uname!r} (got {lname}[{i}] = "
                         f"{lo[i]!r} > {uname}[{i}] = {hi[i]!r}).")


def as_soft(where: str, soft: Mapping[str, object] | None,
            bounded: Mapping[str, bool]) -> dict[str, tuple[float, float] | None]:
    """Per bound group: None (hard) or the (linear, quadratic) penalty of its slack.

    Parameters
    ----------
    where : str
        The caller's name, for error messages.
    soft : mapping or None
        The soft groups given: True or a (linear, quadratic) pair each.
    bounded : mapping
        Per group, whether it has any finite bound.

    Returns
    -------
    dict
        Per group: None or the (w1, w2) penalties.

    Examples
    --------
    ``True`` takes the default penalties :data:`SOFT_PENALTY`; a pair is
    checked and kept:

    >>> soft = as_soft("demo", {"x": True, "u": (10.0, 1.0)},
    ...                {"u": True, "du": False, "x": True, "y": False})
    >>> soft["x"], soft["u"], soft["du"]
    ((1000.0, 100.0), (10.0, 1.0), None)
    """
    out: dict[str, tuple[float, float] | None] = dict.fromkeys(BOUND_GROUPS)
    for key, value in (soft or {}).items():
        if key not in BOUND_GROUPS:
            raise ModelError(f"{where}: the keys of 'soft' must be among {BOUND_GROUPS} "
                             f"(got {key!r}).")
        if value is False:
            continue
        if not bounded[key]:
            raise ModelError(f"{where}: soft[{key!r}] is given but no {key} bound is (set "
                             f"{key}_min/{key}_max, or du_max for 'du').")
        out[key] = SOFT_PENALTY if value is True else _penalty(where, key, value)
    return out


def _penalty(where: str, key: str, value: object) -> tuple[float, float]:
    msg = (f"{where}: soft[{key!r}] must be True (default penalties {SOFT_PENALTY}) or a pair "
           f"(linear >= 0, quadratic > 0) of finite slack penalties (got {value!r}).")
    try:
        linear, quadratic = (float(v) for v in value)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise ModelError(msg) from None
    if not (math.isfinite(linear) and math.isfinite(quadratic) and linear >= 0
            and quadratic > 0):
        raise ModelError(msg)
    return linear, quadratic


def core_settings(where: str, sysd: object, *, Q: ArrayLike, R: ArrayLike, P: object,
                  M: object | None, Qf: ArrayLike | None, form: str,
                  bounds: Mapping[str, tuple[ArrayLike | None, ArrayLike | None]],
                  soft: Mapping[str, object] | None) -> CoreSettings:
    """Validate the arguments of :func:`~.linear.make_linear_mpc`.

    Parameters
    ----------
    where : str
        The caller's name, for error messages.
    sysd : object
        The discrete model.
    Q, R : array_like
        Output and plan weights.
    P : object
        Prediction horizon.
    M : object or None
        Control horizon (None: P).
    Qf : array_like or None
        Terminal state weight.
    form : str
        ``"u"`` or ``"du"``.
    bounds : mapping
        Per group, the (lower, upper) bounds given.
    soft : mapping or None
        The soft groups given.

    Returns
    -------
    CoreSettings
        The validated settings.

    Examples
    --------
    A rate bound ``du_max`` is symmetric: its lower bound is -du_max.

    >>> sysd = ct.ss([[1.0, 0.1], [0.0, 1.0]], [[0.0], [0.1]], [[1.0, 0.0]], 0, dt=0.1)
    >>> cs = core_settings("demo", sysd, Q=1.0, R=0.1, P=8, M=2, Qf=None, form="du",
    ...                    bounds={"du": (None, 0.5), "y": (None, None)}, soft={"du": True})
    >>> (cs.P, cs.M, cs.form), [b.tolist() for b in cs.bounds["du"]]
    ((8, 2, 'du'), [[-0.5], [0.5]])
    >>> sorted(cs.bounds), cs.soft["du"]  # an unbounded group is dropped
    (['du'], (1000.0, 100.0))
    """
    A, B, C, dt = check_system(where, sysd)
    (nx, nu), ny = B.shape, C.shape[0]
    P, M = check_horizons(where, P, M)
    if form not in FORMS:
        raise ModelError(f"{where}: 'form' must be one of {FORMS} (got {form!r}).")
    sizes = {"u": (nu, "inputs"), "du": (nu, "inputs"), "x": (nx, "states"),
             "y": (ny, "outputs")}
    checked: dict[str, tuple[Array, Array]] = {}
    for key, (lower, upper) in bounds.items():
        n, what = sizes[key]
        lname, uname = (f"{key}_min", f"{key}_max")
        hi = as_bound(where, uname, upper, n, what, np.inf)
        lo = -hi if key == "du" else as_bound(where, lname, lower, n, what, -np.inf)
        if key == "du" and np.any(hi < 0):
            raise ModelError(f"{where}: 'du_max' must be >= 0 (got {hi.tolist()}).")
        check_order(where, (lname, lo), (uname, hi))
        if np.any(np.isfinite(lo)) or np.any(np.isfinite(hi)):
            checked[key] = (lo, hi)
    Qf_checked = None if Qf is None else as_weight(where, "terminal_weight", Qf, nx, "states")
    return CoreSettings(A=A, B=B, C=C, dt=dt, Q=as_weight(where, "Q", Q, ny, "outputs"),
                        R=as_weight(where, "R", R, nu, "inputs"), Qf=Qf_checked, P=P, M=M,
                        form=form, bounds=checked,
                        soft=as_soft(where, soft, {k: k in checked for k in sizes}))
