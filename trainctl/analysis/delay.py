# Time delays in the linear analysis: Padé closed loops, delay margins, discrete augmentation.
"""Linear loops with a delayed feedback: ẋ = A₀x(t) + B K x(t − τ).

A networked law acts on data that arrived late: a consensus controller
receives its neighbours' (and the reference's) speeds τ seconds after they
were measured. With the delay-free part of the loop in A₀ (plant, couplers,
undelayed feedback) and the delayed part written B K (B the acceleration or
force inputs, K the law on the delayed state), the loop is the retarded
system ẋ = A₀x + BKx(t − τ). python-control has no delay objects, so this
module builds what the generic analyses take:

- :func:`pade_loop`: the continuous loop with e^{−sτ} replaced by an
  order-q Padé approximant (``control.pade``) on each of the m delayed
  signals K x, a ``control.StateSpace`` with N + m·q states;
- :func:`delay_abscissa`: its spectral abscissa, the largest Re λ;
- :func:`delay_margin`: the smallest τ at which that abscissa reaches 0
  (a scan, then bisection), computed with two Padé orders that must agree
  (the issue's cross-check: a too-low order misplaces the crossing);
- :func:`consensus_delay_bound`: the first-order consensus bound
  τ < π / (2 λ_max(L_p)) of ẋ = −L_p x(t − τ) with L_p symmetric (pinned
  Laplacian), which ignores the couplers: compare, never substitute;
- :func:`discrete_delay_loop`: the sampled loop with the delayed signal
  buffered for d samples, x_{k+1} = A_d x_k + B_d u_k, u_k = K₀x_k + K₁x_{k−d},
  as a discrete ``control.StateSpace`` (the exact model of a delay that is
  a whole number of samples).

Examples
--------
ẋ = −x(t − τ) loses stability at τ = π/2:

>>> res = delay_margin(np.zeros((1, 1)), np.ones((1, 1)), -np.ones((1, 1)), tau_max=5.0)
>>> round(res.margin, 4), res.agree
(1.5708, True)
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import DimensionError, ModelError

if TYPE_CHECKING:
    import control as ct

__all__ = ["DEFAULT_ORDERS", "DataAge", "DelayMargin", "consensus_delay_bound",
           "delay_abscissa", "delay_margin", "discrete_delay_loop", "held_data_age",
           "pade_loop"]

Array = NDArray[np.float64]

DEFAULT_ORDERS = (8, 12)
"""Padé orders of :func:`delay_margin`: the margin, and its cross-check."""

AGREEMENT = 0.01
"""Relative difference of the two orders' margins within which they agree."""


def _matrices(A0: ArrayLike, B: ArrayLike, K: ArrayLike) -> tuple[Array, Array, Array]:
    A = np.atleast_2d(np.asarray(A0, dtype=float))
    Bm = np.atleast_2d(np.asarray(B, dtype=float))
    Km = np.atleast_2d(np.asarray(K, dtype=float))
    N = A.shape[0]
    if A.shape != (N, N) or Bm.shape[0] != N or Km.shape != (Bm.shape[1], N):
        raise DimensionError(f"delay loop: A0 must be (N, N), B (N, m) and K (m, N) (got "
                             f"{A.shape}, {Bm.shape}, {Km.shape}).")
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(Bm)) and np.all(np.isfinite(Km))):
        raise ModelError("delay loop: A0, B and K must be finite.")
    return A, Bm, Km


@functools.lru_cache(maxsize=32)
def _unit_pade(order: int) -> tuple[Array, Array, Array, Array]:
    """(A, B, C, D) of the order-``order`` Padé approximant of e^{−s} (``control.pade``
    of a 1 s delay, realised by python-control), read-only."""
    import control as ct

    num, den = ct.pade(1.0, order)
    sys = ct.ss(ct.tf(num, den))
    parts = tuple(np.array(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
    for part in parts:
        part.flags.writeable = False
    return parts  # type: ignore[return-value]


def _pade_ss(tau: float, order: int) -> tuple[Array, Array, Array, Array]:
    """(A, B, C, D) of the order-``order`` Padé approximant of e^{−sτ}.

    The approximant of a delay τ is that of 1 s at s·τ, so it is realised by
    ``(A₁/τ, B₁/τ, C₁, D₁)`` from the 1 s realisation (:func:`_unit_pade`):
    one python-control conversion per order instead of one per delay
    (a delay-margin scan asks for about 250 delays per order; the conversions
    were 70 % of ``heavy-haul-hinf-delay``'s design review).
    """
    if tau == 0.0:
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.ones((1, 1))
    A1, B1, C1, D1 = _unit_pade(order)
    return A1 / tau, B1 / tau, C1.copy(), D1.copy()


def _loop_matrix(A: Array, Bm: Array, Km: Array, tau: float, order: int) -> Array:
    """The state matrix of :func:`pade_loop` (arguments checked)."""
    Ap, Bp, Cp, Dp = _pade_ss(tau, order)
    m = Km.shape[0]
    eye = np.eye(m)
    Az, Bz, Cz, Dz = np.kron(eye, Ap), np.kron(eye, Bp), np.kron(eye, Cp), np.kron(eye, Dp)
    top = np.hstack([A + Bm @ Dz @ Km, Bm @ Cz])
    bottom = np.hstack([Bz @ Km, Az])
    return np.vstack([top, bottom])


def _check_delay(who: str, tau: float, order: int) -> None:
    if not (isinstance(tau, int | float | np.floating) and math.isfinite(tau) and tau >= 0):
        raise ModelError(f"{who}: 'tau' must be a finite number >= 0 s (got {tau!r}).")
    if isinstance(order, bool) or not isinstance(order, int | np.integer) or order < 1:
        raise ModelError(f"{who}: 'order' must be an integer >= 1 (got {order!r}).")


def pade_loop(A0: ArrayLike, B: ArrayLike, K: ArrayLike, tau: float,
              order: int = DEFAULT_ORDERS[0]) -> ct.StateSpace:
    """The closed loop ẋ = A₀x + B·Padé_τ(Kx) as a continuous ``control.StateSpace``.

    Each of the m signals y = Kx passes through its own order-q Padé
    approximant of e^{−sτ} (state z, q per signal); the states are
    ``[x (N), z (m·q)]``, the outputs x.

    Parameters
    ----------
    A0 : array_like
        The part of the loop acting on current data [1/s], (N, N): the whole
        loop less its delayed part ``B K`` (for a wholly delayed law, the
        open-loop plant).
    B : array_like
        Input matrix of the delayed feedback, (N, m).
    K : array_like
        Delayed feedback gain, (m, N): u = K x(t − τ).
    tau : float
        Delay [s], >= 0 (0: no Padé states).
    order : int
        Padé order q, >= 1.

    Returns
    -------
    control.StateSpace
        Continuous, N + m·q states, no inputs beyond a zero column.

    Examples
    --------
    >>> loop = pade_loop([[0.0]], [[1.0]], [[-1.0]], 1.0, order=4)
    >>> loop.nstates
    5
    """
    import control as ct

    A, Bm, Km = _matrices(A0, B, K)
    _check_delay("pade_loop", tau, order)
    Acl = _loop_matrix(A, Bm, Km, float(tau), int(order))
    total, N = Acl.shape[0], A.shape[0]
    C = np.eye(N, total)
    return ct.ss(Acl, np.zeros((total, 1)), C, np.zeros((N, 1)))


def delay_abscissa(A0: ArrayLike, B: ArrayLike, K: ArrayLike, tau: float,
                   order: int = DEFAULT_ORDERS[0]) -> float:
    """Largest Re λ [1/s] of :func:`pade_loop` (negative: stable at this delay).

    Parameters
    ----------
    A0 : array_like
        Open-loop state matrix (n, n) [1/s].
    B : array_like
        Input matrix (n, m).
    K : array_like
        Feedback gain (m, n) acting on the delayed state.
    tau : float
        Loop delay [s], ≥ 0.
    order : int
        Order of the Padé approximation of the delay.

    Returns
    -------
    float
        The spectral abscissa of the Padé loop [1/s].

    Examples
    --------
    >>> delay_abscissa([[0.0]], [[1.0]], [[-1.0]], 1.0) < 0 < delay_abscissa(
    ...     [[0.0]], [[1.0]], [[-1.0]], 2.0)
    True
    """
    A, Bm, Km = _matrices(A0, B, K)
    _check_delay("delay_abscissa", tau, order)
    return _abscissa(A, Bm, Km, float(tau), int(order))


def _abscissa(A: Array, Bm: Array, Km: Array, tau: float, order: int) -> float:
    """:func:`delay_abscissa` of checked arguments."""
    return float(np.max(np.linalg.eigvals(_loop_matrix(A, Bm, Km, tau, order)).real))


@dataclass(frozen=True, kw_only=True)
class DelayMargin:
    """The delay margin of ẋ = A₀x + BKx(t − τ).

    Parameters
    ----------
    margin : float
        Smallest delay [s] at which the loop loses stability (the first
        order's), inf when stable over the whole range, 0 when unstable
        without delay.
    orders : tuple of int
        The two Padé orders.
    margins : tuple of float
        The margin with each order [s].
    tau_max : float
        Upper end of the range searched [s].
    crossing_frequency : float
        |Im λ| [rad/s] of the eigenvalue that crosses at the margin (NaN
        when none crosses).

    Examples
    --------
    ẋ = −2x − x(t − τ): the delayed gain is smaller than the undelayed
    damping (|−1| < 2), so no delay destabilises it.

    >>> res = delay_margin([[-2.0]], [[1.0]], [[-1.0]], tau_max=5.0)
    >>> res.margin, res.orders, res.agree
    (inf, (8, 12), True)
    >>> res.to_dict()["margin"]  # inf is written as None
    """

    margin: float
    orders: tuple[int, int]
    margins: tuple[float, float]
    tau_max: float
    crossing_frequency: float

    @property
    def agree(self) -> bool:
        """The two orders' margins within :data:`AGREEMENT` (or both infinite)."""
        a, b = self.margins
        if math.isinf(a) or math.isinf(b):
            return math.isinf(a) and math.isinf(b)
        return abs(a - b) <= AGREEMENT * max(abs(a), abs(b), 1e-300)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe (inf as None).

        Returns
        -------
        dict
            ``margin`` [s], ``orders``, ``margins`` [s], ``tau_max`` [s],
            ``crossing_frequency`` [rad/s] and ``agree``; non-finite
            numbers (an infinite margin, a NaN frequency) as None.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        return {"margin": f(self.margin), "orders": list(self.orders),
                "margins": [f(x) for x in self.margins], "tau_max": self.tau_max,
                "crossing_frequency": f(self.crossing_frequency), "agree": self.agree}


def _margin(A: Array, B: Array, K: Array, order: int, tau_max: float, points: int,
            tol: float) -> float:
    """First τ in (0, tau_max] where the abscissa reaches 0 (scan, then bisection)."""
    if _abscissa(A, B, K, 0.0, order) >= 0.0:
        return 0.0
    grid = np.linspace(0.0, tau_max, points + 1)[1:]
    lo = 0.0
    for tau in grid:
        if _abscissa(A, B, K, float(tau), order) >= 0.0:
            hi = float(tau)
            while hi - lo > tol * hi:
                mid = 0.5 * (lo + hi)
                if _abscissa(A, B, K, mid, order) >= 0.0:
                    hi = mid
                else:
                    lo = mid
            return 0.5 * (lo + hi)
        lo = float(tau)
    return math.inf


def delay_margin(A0: ArrayLike, B: ArrayLike, K: ArrayLike, *, tau_max: float,
                 orders: tuple[int, int] = DEFAULT_ORDERS, points: int = 200,
                 tol: float = 1e-6) -> DelayMargin:
    """The smallest uniform delay that destabilises ẋ = A₀x + BKx(t − τ), with two Padé orders.

    The spectral abscissa of :func:`pade_loop` is scanned on ``points``
    delays in (0, ``tau_max``] and the first crossing of zero bisected to a
    relative ``tol``, once per order. A stability switch below the first
    grid step is missed; the grid is fine for margins above tau_max/points.

    Parameters
    ----------
    A0, B, K : array_like
        The loop (:func:`pade_loop`).
    tau_max : float
        Largest delay searched [s], > 0.
    orders : (int, int)
        Padé orders: the first gives ``margin``, the second checks it.
    points : int
        Scan points, >= 2.
    tol : float
        Relative bisection tolerance.

    Returns
    -------
    DelayMargin
        Margin [s] (inf: stable on the whole range), both orders' margins,
        the crossing frequency.

    Examples
    --------
    ẋ = −x − 2x(t − τ): ω = √3 rad/s, τ* = arccos(−1/2)/√3 = 1.2092 s.

    >>> res = delay_margin([[-1.0]], [[1.0]], [[-2.0]], tau_max=5.0)
    >>> round(res.margin, 4), round(res.crossing_frequency, 4)
    (1.2092, 1.7321)
    """
    A, Bm, Km = _matrices(A0, B, K)
    if not (isinstance(tau_max, int | float | np.floating) and math.isfinite(tau_max)
            and tau_max > 0):
        raise ModelError(f"delay_margin: 'tau_max' must be a finite number > 0 s (got "
                         f"{tau_max!r}).")
    if isinstance(points, bool) or not isinstance(points, int | np.integer) or points < 2:
        raise ModelError(f"delay_margin: 'points' must be an integer >= 2 (got {points!r}).")
    margins = tuple(_margin(A, Bm, Km, int(q), float(tau_max), int(points), float(tol))
                    for q in orders)
    first = margins[0]
    omega = math.nan
    if 0.0 < first < math.inf:
        lam = np.linalg.eigvals(_loop_matrix(A, Bm, Km, first, int(orders[0])))
        omega = float(abs(lam[int(np.argmax(lam.real))].imag))
    return DelayMargin(margin=first, orders=(int(orders[0]), int(orders[1])),
                       margins=(margins[0], margins[1]), tau_max=float(tau_max),
                       crossing_frequency=omega)


def consensus_delay_bound(L: ArrayLike) -> float:
    """τ < π / (2 λ_max(L)) [s]: the delay bound of first-order consensus ẋ = −L x(t − τ).

    For a symmetric positive semidefinite L (a pinned Laplacian κ(B + L_G)
    of an undirected graph) each mode ẋ = −λx(t − τ) is stable exactly when
    λτ < π/2. A train's couplers add modes this bound does not see, so the
    margin of the full loop (:func:`delay_margin`) can be far smaller.

    Parameters
    ----------
    L : array_like
        Symmetric (n, n) [1/s].

    Returns
    -------
    float
        The bound [s]; inf when λ_max ≤ 0.

    Examples
    --------
    >>> round(consensus_delay_bound([[2.0, -1.0], [-1.0, 2.0]]), 4)  # λ_max = 3
    0.5236
    """
    M = np.atleast_2d(np.asarray(L, dtype=float))
    if M.shape[0] != M.shape[1] or not np.allclose(M, M.T, rtol=1e-10, atol=1e-12):
        raise DimensionError(f"consensus_delay_bound: L must be a symmetric square matrix "
                             f"(got shape {M.shape}).")
    top = float(np.max(np.linalg.eigvalsh(M)))
    return math.inf if top <= 0 else math.pi / (2.0 * top)


def discrete_delay_loop(Ad: ArrayLike, Bd: ArrayLike, K0: ArrayLike, K1: ArrayLike,
                        delay_steps: int, dt: float) -> ct.StateSpace:
    """x_{k+1} = A_d x_k + B_d (K₀x_k + K₁x_{k−d}) as a discrete ``control.StateSpace``.

    The delayed signal y = K₁x is buffered d samples (state
    ``[x, y_{k−1}, …, y_{k−d}]``, N + m·d states), the exact sampled model of
    a measurement delay of d·dt seconds under a zero-order hold.

    Parameters
    ----------
    Ad, Bd : array_like
        Sampled plant, (N, N) and (N, m).
    K0, K1 : array_like
        Undelayed and delayed gains, (m, N) each.
    delay_steps : int
        d, >= 0.
    dt : float
        Sample time [s], > 0.

    Returns
    -------
    control.StateSpace
        Discrete (dt), outputs x.

    Examples
    --------
    >>> loop = discrete_delay_loop([[1.0]], [[0.1]], [[0.0]], [[-1.0]], 3, 0.1)
    >>> loop.nstates, loop.dt
    (4, 0.1)
    """
    import control as ct

    A, Bm, K1m = _matrices(Ad, Bd, K1)
    K0m = np.atleast_2d(np.asarray(K0, dtype=float))
    if K0m.shape != K1m.shape:
        raise DimensionError(f"discrete_delay_loop: K0 and K1 must both be (m, N) (got "
                             f"{K0m.shape} and {K1m.shape}).")
    if isinstance(delay_steps, bool) or not isinstance(delay_steps, int | np.integer) \
            or delay_steps < 0:
        raise ModelError(f"discrete_delay_loop: 'delay_steps' must be an integer >= 0 (got "
                         f"{delay_steps!r}).")
    if not (isinstance(dt, int | float | np.floating) and math.isfinite(dt) and dt > 0):
        raise ModelError(f"discrete_delay_loop: 'dt' must be a finite number > 0 s (got "
                         f"{dt!r}).")
    m, N = K1m.shape
    d = int(delay_steps)
    if d == 0:
        Acl = A + Bm @ (K0m + K1m)
        return ct.ss(Acl, np.zeros((N, 1)), np.eye(N), np.zeros((N, 1)), float(dt))
    total = N + m * d
    Acl = np.zeros((total, total))
    Acl[:N, :N] = A + Bm @ K0m
    Acl[:N, N + m * (d - 1):] = Bm            # u uses y_{k-d}, the last buffer slot
    Acl[N:N + m, :N] = K1m                    # y_{k} enters the buffer
    for j in range(1, d):
        Acl[N + m * j:N + m * (j + 1), N + m * (j - 1):N + m * j] = np.eye(m)
    return ct.ss(Acl, np.zeros((total, 1)), np.eye(N, total), np.zeros((N, 1)), float(dt))


@dataclass(frozen=True, kw_only=True)
class DataAge:
    """The age of the newest message a receiver holds, sampled at its control instants.

    Parameters
    ----------
    interval : float
        T [s]: one message per link at every control instant, read at them.
    ages : ndarray
        The possible ages j·T [s], j = 0, 1, ..., shape (J,).
    pmf : ndarray
        P(age = j·T) [-], shape (J,); the tail beyond the last age is below
        1e-12 (or the link never delivers: all zero).

    Examples
    --------
    No delay, but every other message lost: the newest datum is j·T old with
    probability 2^−(j+1), mean T·Σ j 2^−(j+1) = T = 0.5 s.

    >>> a = held_data_age(0.5, (0.0, 0.0), loss_probability=0.5)
    >>> np.round(a.pmf[:4], 4).tolist()
    [0.5, 0.25, 0.125, 0.0625]
    >>> round(a.mean, 4), a.quantile(0.75)  # [s]
    (0.5, 0.5)
    """

    interval: float
    ages: Array
    pmf: Array

    @property
    def mean(self) -> float:
        """Expected age [s] (inf when nothing is ever delivered)."""
        total = float(np.sum(self.pmf))
        return float(np.sum(self.ages * self.pmf) / total) if total > 0.5 else math.inf

    def quantile(self, q: float) -> float:
        """The smallest age a with P(age <= a) >= q [s] (inf when never reached).

        Parameters
        ----------
        q : float
            Probability, in (0, 1].

        Returns
        -------
        float
            The age [s], a multiple of :attr:`interval`; inf when the
            probabilities held never reach ``q``.

        Raises
        ------
        ModelError
            If ``q`` is not a number in (0, 1].
        """
        if isinstance(q, bool) or not isinstance(q, int | float | np.floating) \
                or not 0.0 < q <= 1.0:
            raise ModelError(f"DataAge.quantile: 'q' must be a probability in (0, 1] "
                             f"(got {q!r}).")
        cdf = np.cumsum(self.pmf)
        reached = np.flatnonzero(cdf >= q - 1e-12)
        return float(self.ages[reached[0]]) if reached.size else math.inf


def held_data_age(interval: float, delay_range: tuple[float, float], *,
                  loss_probability: float = 0.0) -> DataAge:
    """How old the newest datum held is, at steady state, for random per-message delays.

    A message sent at each control instant t − iT (i = 0, 1, ...) arrives
    with probability 1 − p after a delay uniform in [lo, hi] (constant when
    lo = hi), independently; the receiver holds the newest one arrived by t
    (:class:`trainctl.models.network.Network`). The held datum is older than jT
    only if none of the messages i = 0 … j has arrived:
    P(age > jT) = Π_{i≤j} (1 − (1 − p) F(iT)), F the delay's distribution
    function. With a message every 0.2 s and delays in 0–2 s the newest datum
    is far younger than the worst delay: why a law whose constant-delay margin
    is below 2 s can survive such a network.

    Parameters
    ----------
    interval : float
        T [s], > 0.
    delay_range : (float, float)
        [lo, hi] [s], 0 <= lo <= hi.
    loss_probability : float
        p [-], in [0, 1).

    Returns
    -------
    DataAge

    Examples
    --------
    Delays uniform in [0, 2] s, a message every 0.5 s: P(age = 0) = 0 (a
    message sent now has not arrived), P(age = 0.5 s) = 1/4, ...

    >>> a = held_data_age(0.5, (0.0, 2.0))
    >>> np.round(a.pmf[:5], 3).tolist()   # 0, 1/4, 3/4·1/2, 3/8·3/4, 3/32·1
    [0.0, 0.25, 0.375, 0.281, 0.094]
    >>> a.quantile(0.99)
    2.0
    """
    T = float(interval)
    lo, hi = (float(x) for x in delay_range)
    if not T > 0 or not 0 <= lo <= hi or not 0 <= loss_probability < 1:
        raise ModelError(f"held_data_age: need interval > 0, 0 <= lo <= hi and loss in [0, 1) "
                         f"(got {interval!r}, {delay_range!r}, {loss_probability!r}).")
    deliver = 1.0 - float(loss_probability)
    survive, pmf = 1.0, []
    j = 0
    while survive > 1e-12 and j < 1_000_000:
        x = j * T + 1e-9 * max(1.0, j * T)
        F = (1.0 if x >= lo else 0.0) if hi == lo else min(max((x - lo) / (hi - lo), 0.0), 1.0)
        arrived = deliver * F
        pmf.append(survive * arrived)
        survive *= 1.0 - arrived
        j += 1
    return DataAge(interval=T, ages=T * np.arange(len(pmf), dtype=float), pmf=np.asarray(pmf))
