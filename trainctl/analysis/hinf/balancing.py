# The system data of the H∞ routes: matrix checks and state balancing.
"""The system data of the H∞ routes: the matrix checks, the state balancing and
the square-root balancing (Gramian) transform.
"""

from __future__ import annotations

from typing import Any

import control as ct
import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import DimensionError, ModelError

__all__ = ["gramian_transform", "state_balance"]

Array = NDArray[np.float64]


def _as_matrices(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike | None,
                 who: str) -> tuple[Array, Array, Array, Array]:
    """(A, B, C, D) as float arrays with consistent shapes (D None: zeros)."""
    Am = np.atleast_2d(np.asarray(A, dtype=float))
    Bm = np.atleast_2d(np.asarray(B, dtype=float))
    Cm = np.atleast_2d(np.asarray(C, dtype=float))
    n = Am.shape[0]
    if Am.ndim != 2 or Am.shape != (n, n):
        raise DimensionError(f"{who}: 'A' must be a square (n, n) matrix (got shape "
                             f"{Am.shape}).")
    if Bm.ndim != 2 or Bm.shape[0] != n:
        raise DimensionError(f"{who}: 'B' must have n = {n} rows, one per state (got shape "
                             f"{Bm.shape}).")
    if Cm.ndim != 2 or Cm.shape[1] != n:
        raise DimensionError(f"{who}: 'C' must have n = {n} columns, one per state (got "
                             f"shape {Cm.shape}).")
    m, p = Bm.shape[1], Cm.shape[0]
    Dm = np.zeros((p, m)) if D is None else np.atleast_2d(np.asarray(D, dtype=float))
    if Dm.shape != (p, m):
        raise DimensionError(f"{who}: 'D' must be (p, m) = ({p}, {m}) for {p} outputs and "
                             f"{m} inputs (got shape {Dm.shape}).")
    if m == 0 or p == 0:
        raise DimensionError(f"{who}: the system needs at least one input and one output "
                             f"(got {m} inputs, {p} outputs).")
    for name, M in (("A", Am), ("B", Bm), ("C", Cm), ("D", Dm)):
        if not np.all(np.isfinite(M)):
            raise ModelError(f"{who}: '{name}' must be finite (got NaN or inf).")
    return Am, Bm, Cm, Dm


def _system_data(sys: Any, who: str) -> tuple[Array, Array, Array, Array, float | None]:
    """(A, B, C, D, dt) of a ``control`` system; dt None for a continuous one."""
    if isinstance(sys, ct.TransferFunction):
        sys = ct.ss(sys)
    if not isinstance(sys, ct.StateSpace):
        raise ModelError(f"{who}: 'sys' must be a control.StateSpace or TransferFunction "
                         f"(got {type(sys).__name__}).")
    A, B, C, D = _as_matrices(sys.A, sys.B, sys.C, sys.D, who)
    if sys.isctime():
        return A, B, C, D, None
    dt = 1.0 if sys.dt is True else float(sys.dt)
    return A, B, C, D, dt


def state_balance(A: Array, B: Array, C: Array) -> Array:
    """Diagonal state scaling d that balances [[A, B],[C, 0]] (x = diag(d) x̃).

    ``scipy.linalg.matrix_balance`` (no permutation) on the square matrix
    [[A, b],[c, 0]] with b the row norms of B and c the column norms of C:
    one extra coordinate stands for all inputs and outputs, so the scaling
    acts on the states only and G = C(sI − A)⁻¹B is unchanged by
    Ã = D⁻¹AD, B̃ = D⁻¹B, C̃ = CD.

    Parameters
    ----------
    A, B, C : ndarray
        (n, n), (n, m), (p, n).

    Returns
    -------
    ndarray
        The scaling d, shape (n,), positive powers of 2.

    Examples
    --------
    >>> A = np.array([[-1.0, 1e6], [-1e-6, -1.0]])
    >>> d = state_balance(A, np.ones((2, 1)), np.ones((1, 2)))
    >>> At = A / d[:, None] * d[None, :]
    >>> bool(abs(At[0, 1]) < 1e3 and abs(At[1, 0]) > 1e-3)
    True
    """
    n = A.shape[0]
    if n == 0:
        return np.ones(0)
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = A
    M[:n, n] = np.linalg.norm(B, axis=1)
    M[n, :n] = np.linalg.norm(C, axis=0)
    _, (scale, _) = scipy.linalg.matrix_balance(M, permute=False, separate=True)
    s = np.asarray(scale, dtype=float)
    ratios: NDArray[np.float64] = s[:n] / s[n]
    return ratios


MAX_TRANSFORM_CONDITION = 1e8
"""Largest condition number of the Gramian-balancing transformation that is used."""


def gramian_transform(A: Array, B: Array, C: Array) -> tuple[Array, Array] | None:
    """(T, T⁻¹) of the square-root balanced realisation x = T x_b, or None.

    Controllability and observability Gramians from the Lyapunov equations
    (scipy), W_c = L_c L_cᵀ, W_o = L_o L_oᵀ, L_oᵀL_c = UΣVᵀ, T = L_c V Σ^{−1/2}:
    both Gramians become Σ (the Hankel singular values). In these
    coordinates the bounded-real P lies between Σ and γ²Σ⁻¹, which keeps the
    SDP well conditioned when a diagonal scaling does not (non-normal A,
    large ‖G‖∞). None when A is not Hurwitz, a Gramian is not positive
    definite (non-minimal realisation) or T is worse conditioned than
    :data:`MAX_TRANSFORM_CONDITION`.

    Parameters
    ----------
    A, B, C : ndarray
        Continuous realisation.

    Returns
    -------
    (ndarray, ndarray) or None
        T and T⁻¹, (n, n).

    Examples
    --------
    >>> A = np.array([[-1.0, 100.0], [0.0, -2.0]])
    >>> B, C = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])
    >>> T, Ti = gramian_transform(A, B, C)
    >>> Ab, Bb, Cb = Ti @ A @ T, Ti @ B, C @ T
    >>> import scipy.linalg
    >>> Wc = scipy.linalg.solve_continuous_lyapunov(Ab, -Bb @ Bb.T)
    >>> Wo = scipy.linalg.solve_continuous_lyapunov(Ab.T, -Cb.T @ Cb)
    >>> bool(np.allclose(Wc, Wo) and np.allclose(Wc, np.diag(np.diag(Wc))))
    True
    """
    n = A.shape[0]
    if n == 0 or np.max(np.linalg.eigvals(A).real) >= 0.0:
        return None
    try:
        Wc = scipy.linalg.solve_continuous_lyapunov(A, -B @ B.T)
        Wo = scipy.linalg.solve_continuous_lyapunov(A.T, -C.T @ C)
        Lc = np.linalg.cholesky(0.5 * (Wc + Wc.T))
        Lo = np.linalg.cholesky(0.5 * (Wo + Wo.T))
        U, s, Vt = np.linalg.svd(Lo.T @ Lc)
    except (np.linalg.LinAlgError, ValueError):
        return None
    if not np.all(np.isfinite(s)) or s.min() <= 0.0:
        return None
    T = Lc @ Vt.T / np.sqrt(s)[None, :]
    Ti = (U / np.sqrt(s)[None, :]).T @ Lo.T
    if not (np.all(np.isfinite(T)) and np.linalg.cond(T) < MAX_TRANSFORM_CONDITION):
        return None
    return np.asarray(T, dtype=float), np.asarray(Ti, dtype=float)


def _balanced(A: Array, B: Array, C: Array) -> tuple[Array, Array, Array, Array]:
    d = state_balance(A, B, C)
    return A / d[:, None] * d[None, :], B / d[:, None], C * d[None, :], d
