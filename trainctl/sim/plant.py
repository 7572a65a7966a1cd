# The simulated plant: the nonlinear train integrated between samples.
"""The nonlinear train as a plant advanced with a held input.

:class:`Plant` integrates the nonlinear model of
:func:`trainctl.models.train_rhs` over one sample interval with the inputs
held constant. The couplers are stiff and nearly undamped (CRH2: coupler
modes up to about 30 rad/s), so forward Euler is unstable at any useful step
and adaptive Runge–Kutta solvers crawl. :meth:`Plant.advance` uses an
exponential (Strang) splitting instead, with both sub-flows solved exactly:

    dx/dt = A(v̄) x + B F(t) + N(v)

- ``A(v̄)``: the linear part: coupler springs and dampers, the linear Davis
  term and the quadratic drag linearised about a grid speed v̄,
  -(a1 + 2 a2 v̄) v, the kinematic rows d(delta_i)/dt = v_i - v_{i+1} and
  ds/dt = v_0.
- ``F(t)`` [N]: the forces that do not depend on speed: the held input u,
  the constant Davis term -m a0, the constant of the linearisation
  +m a2 v̄², and the line resistance -m r(p_i) of the track at each
  vehicle's position. F is piecewise constant in time: it changes only when
  a vehicle crosses a section boundary.
- ``N(v) = -a2 (v - v̄)²`` per vehicle: the remainder of the quadratic drag.
  It acts on velocities only and its flow is exact:
  v(t) = v̄ + w / (1 + a2 w t), w = v - v̄.

v̄ is the head speed rounded to a 2 m/s grid, re-chosen every substep, so
|v - v̄| stays ~1 m/s and N is ~100 times weaker than the full drag
(2 a2 |v - v̄| ≈ 3e-5 s⁻¹ against 2 a2 v ≈ 2e-3 s⁻¹ for CRH2 at 80 m/s).

One substep of length h = dt / ceil(dt / max_substep) is a half step of the
N-flow, the exact linear step x ← Φ x + Γ F with Φ = e^{A h} and
Γ = ∫_0^h e^{A s} ds B (one ``scipy.linalg.expm`` of the augmented matrix
[[A, B], [0, 0]], cached per (h, v̄) on the instance), and another half
N-step (adjacent half steps are merged). A vehicle that crossed a section
boundary during a substep is found at the start of the next one; its
crossing time τ is located by Newton's method on the exact linear flow
(seeded by cubic Hermite interpolation), and the jump ΔF of its line
resistance is added exactly as Γ(h - τ) e_i ΔF (the flow over arbitrary
t <= h comes from cached propagators for h/2^j and a short Taylor series).
Grade changes therefore cost no first-order error.

What is left is the O(h²) splitting error of the weak remainder N, and
rounding. On a linear model (a0 = a2 = 0, flat track) :meth:`Plant.advance`
*is* the exact zero-order hold, to rounding.

:meth:`Plant.advance_reference` integrates ``train_rhs`` with
``scipy.integrate.solve_ivp`` instead (restarted at every section crossing),
for tests and cross-checks.

Accuracy/speed trade-off, measured against ``advance_reference`` at rtol
1e-11 over 1200 s of the CRH2 half train in closed loop (proportional plus
feedforward; 0 → 80 → 60 m/s; a 6 ‰ climb, a 4 ‰ descent on a 5 km curve),
inputs held at T = 0.05 s and at T = 20 s. Errors are max |Δv| / max v and
max |Δf| / (max f - min f) over all samples; times are per 20 s sample of
:meth:`Plant.advance` on flat track (2-core machine, warm caches):

===============  =============  ===========  =============  ===========  ===========
max_substep [s]  Δv/v (T=0.05)  Δf/Δf_range  Δv/v (T=20 s)  Δf/Δf_range  µs per 20 s
===============  =============  ===========  =============  ===========  ===========
0.01             5e-11          1.4e-7       4e-11          1.9e-7       15 000
0.05 (default)   1.2e-9         3.5e-6       1.0e-9         4.7e-6       5 700
0.2              1.2e-9 (*)     3.5e-6 (*)   1.7e-8         8.3e-5       2 100
0.5              1.2e-9 (*)     3.5e-6 (*)   1.2e-7         5.1e-4       380
===============  =============  ===========  =============  ===========  ===========

(*) At T = 0.05 s one substep covers the sample for every max_substep >= 0.05.
Force ranges were 10.7 kN (T = 0.05 s) and 5.6 kN (T = 20 s). The error is
the O(h²) splitting error of the quadratic drag, which scales with
a2·(dv/dt)²; without it (a2 = 0) the speeds agree to ~3e-13 relative.
Section crossings cost no accuracy: CRH2 crossing a boundary every 200 m
(96 crossings in 60 s) agrees to 2e-10 in speed and 5 mN in force; the
204-vehicle chain over 20 s with 500 m sections to 1e-9 m/s and 4 mN of a
419 kN force range. Per sample of :meth:`Plant.advance` (warm caches):
CRH2 ≈ 30 µs at T = 0.05 s flat (≈ 65 µs on a track with many sections);
204 vehicles ≈ 90 µs at T = 0.05 s and ≈ 20 ms per 20 s sample flat
(≈ 160 µs and 130 ms with a section boundary every 2 km, where ~40
vehicles cross per 20 s sample).

For the 204-vehicle heavy-haul chain the first use of each (h, v̄) costs
one expm of a 612 × 612 matrix (0.1–0.3 s; with a track also four squarings
for the crossing ladder); every substep is then one dense (408 × 611)
product. The caches keep at most 128 MiB each, least recently used first.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import TypeVar

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from .._validation import check_positive
from ..exceptions import DimensionError, ModelError, SolverError
from ..models.dynamics import train_rhs
from ..models.track import Track
from ..models.train import Train

__all__ = ["Plant"]

_LADDER_LEVELS = 4
"""Binary levels h/2^j, j = 0..4, used to build the flow over any t in [0, h]."""

_TAYLOR_ORDER = 14
"""Order of the Taylor series for the flow over the remainder t < h/2^L."""

_SPEED_GRID = 2.0
"""Grid [m/s] of the speeds vbar about which the quadratic drag is linearised."""

_CACHE_BYTES = 1 << 27
"""Byte budget of each propagator cache (128 MiB); least recently used entries go first."""

_T = TypeVar("_T")

_TrackArrays = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]
]


def _grid_speed(speed: float) -> float:
    """The grid speed nearest ``speed`` [m/s]."""
    return float(_SPEED_GRID * round(speed / _SPEED_GRID))


def _drag_flow(z: NDArray[np.float64], n: int, ta2: NDArray[np.float64], vbar: float) -> None:
    """Exact flow of dv/dt = -a2 (v - vbar)² over t [s], in place on z[:n]; ta2 = t·a2."""
    w = z[:n] - vbar
    z[:n] = vbar + w / (1.0 + ta2 * w)


@dataclass(frozen=True)
class _Propagator:
    """Exact linear step of length h about speed vbar on ``[v, delta, s]`` with forcing F [N]."""

    step: NDArray[np.float64]
    """[Φ | Γ] restricted to columns [v, delta, F], (2n, 3n-1); the last row is the
    increment of s (its own column, e_s, is left out so that s is added exactly)."""


class _LRU(OrderedDict[tuple[float, float], _T]):
    """A small least-recently-used cache with a byte budget."""

    def __init__(self, budget: int = 1 << 27) -> None:
        super().__init__()
        self.budget = budget
        self.limit = 1 << 30

    def fetch(self, key: tuple[float, float]) -> _T | None:
        value = self.get(key)
        if value is not None:
            self.move_to_end(key)
        return value

    def store(self, key: tuple[float, float], value: _T, nbytes: int) -> None:
        self.limit = max(2, self.budget // max(nbytes, 1))
        self[key] = value
        while len(self) > self.limit:
            self.popitem(last=False)


@dataclass(frozen=True, kw_only=True)
class Plant:
    """The nonlinear train on its track, advanced over held-input intervals.

    Parameters
    ----------
    train : Train
        The train.
    track : Track or None
        Track for grade and curve resistance; None for level straight track.
    max_substep : float
        Longest substep of the splitting integrator [s], > 0 (module docstring
        for the accuracy/speed trade-off).

    Examples
    --------
    >>> import numpy as np
    >>> from trainctl.models import crh2_half, equilibrium
    >>> train = crh2_half()
    >>> eq = equilibrium(train, 80.0)
    >>> plant = Plant(train=train)
    >>> x = plant.advance(eq.state(position=0.0), eq.inputs, 20.0)
    >>> bool(np.allclose(x[:4], 80.0, rtol=1e-12)), round(float(x[-1]), 6)
    (True, 1600.0)
    """

    train: Train
    track: Track | None = None
    max_substep: float = 0.05
    _cache: _LRU[_Propagator] = field(
        default_factory=lambda: _LRU(_CACHE_BYTES), init=False, repr=False, compare=False
    )
    _ladders: _LRU[NDArray[np.float64]] = field(
        default_factory=lambda: _LRU(_CACHE_BYTES), init=False, repr=False, compare=False
    )
    _drag: dict[float, tuple[NDArray[np.float64], NDArray[np.float64]]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        if not isinstance(self.train, Train):
            raise ModelError(f"Plant: 'train' must be a Train (got {type(self.train).__name__}).")
        if self.track is not None and not isinstance(self.track, Track):
            raise ModelError(
                f"Plant: 'track' must be a Track or None (got {type(self.track).__name__})."
            )
        object.__setattr__(
            self, "max_substep", check_positive("Plant", "max_substep", self.max_substep)
        )

    # ------------------------------------------------------------------ model
    @property
    def n_vehicles(self) -> int:
        """Number of vehicles n."""
        return self.train.n_vehicles

    @property
    def n_states(self) -> int:
        """Dimension of the nonlinear state ``[v, delta, s]``, 2n."""
        return 2 * self.train.n_vehicles

    @cached_property
    def _linear(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(A, B) on the full state [v, delta, s] at vbar = 0: (2n, 2n) and (2n, n)."""
        train = self.train
        n = train.n_vehicles
        m = train.mass
        A = np.zeros((2 * n, 2 * n))
        A[np.arange(n), np.arange(n)] = -train.davis[1]
        if n > 1:
            i = np.arange(n - 1)
            k, d = train.stiffness, train.damping
            # f_i = k delta_i + d (v_i - v_{i+1}) pulls vehicle i back and i+1 forward.
            A[i, n + i] -= k / m[i]
            A[i + 1, n + i] += k / m[i + 1]
            A[i, i] -= d / m[i]
            A[i, i + 1] += d / m[i]
            A[i + 1, i] += d / m[i + 1]
            A[i + 1, i + 1] -= d / m[i + 1]
            A[n + i, i] = 1.0
            A[n + i, i + 1] = -1.0
        A[2 * n - 1, 0] = 1.0
        B = np.zeros((2 * n, n))
        B[np.arange(n), np.arange(n)] = 1.0 / m
        return A, B

    def _matrix_a(self, vbar: float) -> NDArray[np.float64]:
        """A with the quadratic drag linearised about vbar: -(a1 + 2 a2 vbar) on the v rows."""
        A = self._linear[0]
        if vbar == 0.0:
            return A
        n = self.train.n_vehicles
        A = A.copy()
        A[np.arange(n), np.arange(n)] -= 2.0 * vbar * self.train.davis[2]
        return A

    @cached_property
    def _quadratic(self) -> bool:
        """True when some vehicle has quadratic drag (a2 > 0)."""
        return bool(np.any(self.train.davis[2] > 0))

    @cached_property
    def _track_arrays(self) -> _TrackArrays | None:
        """Section starts (the first replaced by -inf) [m], resistance per mass [m/s²],
        and each section's lower and upper bound [m]; None on flat track."""
        if self.track is None or self.track.is_flat:
            return None
        starts = np.array([s.start for s in self.track.sections])
        per_mass = self.track.resistance_per_mass(starts)
        if np.all(per_mass == per_mass[0]):
            starts, per_mass = starts[:1], per_mass[:1]
        starts[0] = -math.inf
        return starts, per_mass, starts.copy(), np.append(starts[1:], math.inf)

    def _augmented_expm(self, h: float, vbar: float) -> NDArray[np.float64]:
        """expm([[A(vbar), B], [0, 0]] h), shape (3n, 3n)."""
        B = self._linear[1]
        n = self.train.n_vehicles
        M = np.zeros((3 * n, 3 * n))
        M[: 2 * n, : 2 * n] = self._matrix_a(vbar)
        M[: 2 * n, 2 * n :] = B
        return np.asarray(scipy.linalg.expm(M * h))

    def _propagator(self, h: float, vbar: float) -> _Propagator:
        cached = self._cache.fetch((h, vbar))
        if cached is not None:
            return cached
        n = self.train.n_vehicles
        track = self._track_arrays
        if track is not None and track[0].size > 1:
            E = self._ladder(h, vbar)[0]  # crossings will need the ladder anyway
        else:
            E = self._augmented_expm(h, vbar)[: 2 * n]
        # Drop the s column: A has a zero s column, so Φ[:, s] = e_s exactly.
        cols = np.r_[0 : 2 * n - 1, 2 * n : 3 * n]
        prop = _Propagator(step=np.ascontiguousarray(E[:, cols]))
        self._cache.store((h, vbar), prop, prop.step.nbytes)
        return prop

    def _ladder(self, h: float, vbar: float) -> NDArray[np.float64]:
        """[Φ | Γ] for durations h/2^j, j = 0..L, shape (L+1, 2n, 3n)."""
        cached = self._ladders.fetch((h, vbar))
        if cached is not None:
            return cached
        n = self.train.n_vehicles
        levels = np.empty((_LADDER_LEVELS + 1, 2 * n, 3 * n))
        levels[_LADDER_LEVELS] = self._augmented_expm(h / 2.0**_LADDER_LEVELS, vbar)[: 2 * n]
        for j in range(_LADDER_LEVELS - 1, -1, -1):
            # [Φ | Γ] over 2t: [Φ², ΦΓ + Γ].
            finer = levels[j + 1]
            np.matmul(finer[:, : 2 * n], finer, out=levels[j])
            levels[j, :, 2 * n :] += finer[:, 2 * n :]
        self._ladders.store((h, vbar), levels, levels.nbytes)
        return levels

    def _apply_a(self, Y: NDArray[np.float64], vbar: float) -> NDArray[np.float64]:
        """A(vbar) @ Y computed from the chain structure in O(n) per column."""
        train = self.train
        n = train.n_vehicles
        m = train.mass[:, None]
        v = Y[:n]
        out = np.empty_like(Y)
        out[:n] = -(train.davis[1] + 2.0 * vbar * train.davis[2])[:, None] * v
        if n > 1:
            rel = v[:-1] - v[1:]
            f = train.stiffness[:, None] * Y[n : 2 * n - 1] + train.damping[:, None] * rel
            out[: n - 1] -= f / m[:-1]
            out[1:n] += f / m[1:]
            out[n : 2 * n - 1] = rel
        out[2 * n - 1] = v[0]
        return out

    def _flow(
        self,
        h: float,
        vbar: float,
        X: NDArray[np.float64],
        G: NDArray[np.float64],
        durations: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """Columns e^{A t_c} X_c + Γ(t_c) G_c of the linear flow, t_c in [0, h] [s].

        Built from the cached ladder of propagators for h/2^j (they commute),
        then a Taylor series (structured, O(n) per term) for the remainder
        below h/2^L, where ‖A t‖ is small.
        """
        n = self.train.n_vehicles
        ladder = self._ladder(h, vbar)
        Y = np.array(X, dtype=float)
        left = np.array(durations, dtype=float)
        for j in range(_LADDER_LEVELS + 1):
            tj = h / 2.0**j
            use = left >= tj
            if np.any(use):
                level = ladder[j]
                Y[:, use] = level[:, : 2 * n] @ Y[:, use] + level[:, 2 * n :] @ G[:, use]
                left[use] -= tj
        rate = self._apply_a(Y, vbar)
        rate[:n] += G / self.train.mass[:, None]
        term = left * rate
        Y += term
        tiny = 1e-17 * (float(np.abs(Y).max()) + 1e-300)
        for k in range(2, _TAYLOR_ORDER + 1):
            if float(np.abs(term).max()) <= tiny:
                break
            term = (left / k) * self._apply_a(term, vbar)
            Y += term
        return Y

    # -------------------------------------------------------------- stepping
    def _check(
        self, where: str, state: ArrayLike, inputs: ArrayLike, dt: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
        n = self.train.n_vehicles
        x = np.array(state, dtype=float)
        u = np.array(inputs, dtype=float)
        if x.shape != (2 * n,):
            raise DimensionError(
                f"{where}: 'state' must have shape ({2 * n},) = [v ({n}), delta ({n - 1}), s] "
                f"(got {x.shape})."
            )
        if u.shape != (n,):
            raise DimensionError(
                f"{where}: 'inputs' must have shape ({n},), one force per vehicle [N] "
                f"(got {u.shape})."
            )
        if not (np.isfinite(x).all() and np.isfinite(u).all()):
            raise ModelError(
                f"{where}: 'state' and 'inputs' must be finite (got state={x.tolist()}, "
                f"inputs={u.tolist()})."
            )
        return x, u, check_positive(where, "dt", dt)

    def substeps(self, dt: float) -> int:
        """Number of substeps :meth:`advance` takes over ``dt`` [s].

        Parameters
        ----------
        dt : float
            Interval [s], > 0.

        Returns
        -------
        int
            ceil(dt / max_substep), at least 1 (a ratio within 1e-9 of an
            integer is taken as that integer).

        Examples
        --------
        >>> from trainctl.models import crh2_half
        >>> Plant(train=crh2_half()).substeps(20.0)
        400
        """
        return self._substeps(check_positive("Plant.substeps", "dt", dt))

    @cached_property
    def _forces(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """m·a0 and m·a2 per vehicle [N, N·s²/m²], as :meth:`advance` uses them."""
        m, davis = self.train.mass, self.train.davis
        return m * davis[0], m * davis[2]

    def _drag_steps(self, h: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(h/2·a2, h·a2) for the drag flow over half and whole substeps of length h.

        Kept for the last h only (a closed loop uses one).
        """
        cached = self._drag.get(h)
        if cached is None:
            a2 = self.train.davis[2]
            self._drag.clear()
            cached = self._drag[h] = (0.5 * h * a2, h * a2)
        return cached

    def _substeps(self, dt: float) -> int:
        ratio = dt / self.max_substep
        return max(1, math.ceil(ratio - 1e-9 * max(1.0, ratio)))

    def advance(self, state: ArrayLike, inputs: ArrayLike, dt: float) -> NDArray[np.float64]:
        """Advance the state by ``dt`` [s] holding ``inputs`` [N] constant.

        Parameters
        ----------
        state : array_like
            ``[v (n) [m/s], delta (n-1) [m], s [m]]``.
        inputs : array_like
            Traction (> 0) or braking (< 0) force per vehicle [N], held over ``dt``.
        dt : float
            Interval [s], > 0.

        Returns
        -------
        ndarray
            The state after ``dt``, shape (2n,).

        Examples
        --------
        >>> import numpy as np
        >>> from trainctl.models import crh2_half
        >>> plant = Plant(train=crh2_half())
        >>> x0 = np.r_[np.full(4, 50.0), np.zeros(3), 0.0]
        >>> x1 = plant.advance(x0, np.zeros(4), 10.0)
        >>> bool(np.all(x1[:4] < 50.0)), bool(x1[-1] > 490.0)
        (True, True)
        """
        x, u, dt = self._check("Plant.advance", state, inputs, dt)
        train = self.train
        n = train.n_vehicles
        steps = self._substeps(dt)
        h = dt / steps
        m = train.mass
        quadratic = self._quadratic
        half, full = self._drag_steps(h)
        base = u - self._forces[0]
        track = self._track_arrays
        if track is not None and track[0].size == 1:  # uniform grade: constant force
            base = base - m * track[1][0]
            track = None
        z = np.empty(3 * n - 1)
        z[: 2 * n - 1] = x[: 2 * n - 1]
        s = x[2 * n - 1]
        vbar = _grid_speed(z[0]) if quadratic else 0.0
        prop = self._propagator(h, vbar)
        force = base + self._forces[1] * vbar**2 if quadratic else base
        z[2 * n - 1 :] = force
        if quadratic:
            _drag_flow(z, n, half, vbar)
        # Track bookkeeping: the section of each vehicle (sec), the line-resistance
        # force it gives (resist), and a travel budget: while the head has moved
        # less than `budget` (plus the elongation changes) since (s_ref, d_ref), no
        # vehicle can have left its section, and the sections need no lookup.
        sec = np.zeros(n, dtype=np.intp)
        resist = np.zeros(n)
        budget, s_ref, d_ref = -1.0, s, z[n : 2 * n - 1].copy()
        prev: tuple[NDArray[np.float64], float, NDArray[np.intp], float] | None = None
        for j in range(steps + 1):
            if track is not None:
                moved = abs(s - s_ref) + float(np.abs(z[n : 2 * n - 1] - d_ref).sum())
                if moved >= budget:
                    p0, now = self._sections(z, s, track)
                    if prev is not None and np.any(now != prev[2]):
                        # Crossings in the previous substep: add their exact effect.
                        fix = self._crossings(h, prev, p0, z[:n], now, track)
                        z[: 2 * n - 1] += fix[: 2 * n - 1]
                        s += fix[2 * n - 1]
                        p0, now = self._sections(z, s, track)
                    lo, hi = track[2][now], track[3][now]
                    budget = min(float((p0 - lo).min()), float((hi - p0).min()))
                    s_ref, d_ref = s, z[n : 2 * n - 1].copy()
                    if prev is None or np.any(now != sec):
                        sec = now
                        resist = m * track[1][sec]
                        z[2 * n - 1 :] = force - resist
                if j == steps:
                    break
                prev = (z.copy(), s, sec, vbar)
            elif j == steps:
                break
            new = prop.step @ z
            s += new[2 * n - 1]
            z[: 2 * n - 1] = new[: 2 * n - 1]
            if not quadratic:
                continue
            if j == steps - 1:
                _drag_flow(z, n, half, vbar)
                continue
            nbar = _grid_speed(z[0])
            if nbar == vbar:
                _drag_flow(z, n, full, vbar)
                continue
            _drag_flow(z, n, half, vbar)
            vbar = nbar
            prop = self._propagator(h, vbar)
            force = base + self._forces[1] * vbar**2
            z[2 * n - 1 :] = force - resist
            _drag_flow(z, n, half, vbar)
        out = np.empty(2 * n)
        out[: 2 * n - 1] = z[: 2 * n - 1]
        out[2 * n - 1] = s
        return out

    def _sections(
        self,
        z: NDArray[np.float64],
        s: float,
        track: _TrackArrays,
    ) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
        """Vehicle positions [m] and the index of the track section each is in."""
        n = self.train.n_vehicles
        behind = np.empty(n)
        behind[0] = 0.0
        np.cumsum(self.train.spacing + z[n : 2 * n - 1], out=behind[1:])
        p = s - behind
        return p, np.searchsorted(track[0], p, side="right") - 1

    def _crossings(
        self,
        h: float,
        prev: tuple[NDArray[np.float64], float, NDArray[np.intp], float],
        p1: NDArray[np.float64],
        v1: NDArray[np.float64],
        sec1: NDArray[np.intp],
        track: _TrackArrays,
    ) -> NDArray[np.float64]:
        """Exact effect, at the end of a substep, of the section crossings within it.

        ``prev`` holds the substep's start ``(z, s, sections, vbar)``; ``p1``,
        ``v1`` and ``sec1`` the positions, speeds and sections at its end. Each
        crossing time τ is first estimated from the cubic Hermite interpolant of
        the vehicle's position, then refined by Newton's method on the exact
        linear flow of the substep; the jump ΔF of the vehicle's line
        resistance then adds Γ(h - τ) e_i ΔF.
        """
        starts, per_mass = track[0], track[1]
        z0, s0, sec0, vbar = prev
        n = self.train.n_vehicles
        m = self.train.mass
        x0 = np.r_[z0[: 2 * n - 1], s0]
        force0 = z0[2 * n - 1 :]
        p0 = self._sections(z0, s0, track)[0]
        vehicles: list[int] = []
        boundaries: list[float] = []
        jumps: list[float] = []
        for i in np.flatnonzero(sec1 != sec0):
            step = 1 if sec1[i] > sec0[i] else -1
            for sec in range(int(sec0[i]), int(sec1[i]), step):
                new = sec + step
                vehicles.append(int(i))
                boundaries.append(float(starts[max(sec, new)]))
                jumps.append(-m[i] * (per_mass[new] - per_mass[sec]))
        idx = np.array(vehicles, dtype=np.intp)
        bnd = np.array(boundaries)
        tau = _hermite_root(h, p0[idx], z0[idx], p1[idx], v1[idx], bnd)
        # Newton on p_i(τ) = boundary; dp_i/dt = v_i. Position p_i = s - Σ_{j<i}(gap_j + δ_j).
        X = np.repeat(x0[:, None], idx.size, axis=1)
        G = np.repeat(force0[:, None], idx.size, axis=1)
        cols = np.arange(idx.size)
        for _ in range(8):
            Y = self._flow(h, vbar, X, G, tau)
            behind = np.cumsum(self.train.spacing[:, None] + Y[n : 2 * n - 1], axis=0)
            behind = np.vstack([np.zeros((1, idx.size)), behind])
            pos = Y[2 * n - 1] - behind[idx, cols]
            vel = Y[idx, cols]
            with np.errstate(divide="ignore", invalid="ignore"):
                delta = np.where(vel != 0.0, (pos - bnd) / vel, 0.0)
            new_tau = np.clip(tau - delta, 0.0, h)
            # Newton converges quadratically: a step below 1e-6 h leaves ~(1e-6 h)² error.
            done = bool(np.all(np.abs(new_tau - tau) <= 1e-6 * h))
            tau = new_tau
            if done:
                break
        G = np.zeros((n, idx.size))
        G[idx, np.arange(idx.size)] = jumps
        response = self._flow(h, vbar, np.zeros((2 * n, idx.size)), G, h - tau)
        return response.sum(axis=1)

    # ------------------------------------------------------------- reference
    def advance_reference(
        self,
        state: ArrayLike,
        inputs: ArrayLike,
        dt: float,
        rtol: float = 1e-11,
        atol: float | ArrayLike | None = None,
        *,
        method: str = "DOP853",
    ) -> NDArray[np.float64]:
        """Advance with ``scipy.integrate.solve_ivp`` on ``train_rhs`` (slow, for checks).

        The integration restarts at every section crossing (located as a
        terminal event), so the right-hand side is smooth on each piece.

        Parameters
        ----------
        state : array_like
            ``[v, delta, s]`` as in :meth:`advance`.
        inputs : array_like
            Force per vehicle [N], held over ``dt``.
        dt : float
            Interval [s], > 0.
        rtol : float
            Relative tolerance of ``solve_ivp``.
        atol : float, array_like or None
            Absolute tolerance; None uses rtol times the scales 1 m/s
            (speeds), 1e-5 m (elongations, ~100 N of CRH2 coupler force) and
            1 m (position).
        method : str
            ``solve_ivp`` method (``"DOP853"``, ``"Radau"``, ...).

        Returns
        -------
        ndarray
            The state after ``dt``, shape (2n,).

        Raises
        ------
        SolverError
            When ``solve_ivp`` fails.

        Examples
        --------
        >>> import numpy as np
        >>> from trainctl.models import crh2_half
        >>> plant = Plant(train=crh2_half())
        >>> x0 = np.r_[np.full(4, 50.0), 1e-4, 0.0, 0.0, 0.0]
        >>> u = np.array([0.0, 3e4, 3e4, 0.0])
        >>> a, b = plant.advance(x0, u, 1.0), plant.advance_reference(x0, u, 1.0)
        >>> bool(np.abs(a - b)[:4].max() < 1e-8)  # speeds [m/s]
        True
        """
        x, u, dt = self._check("Plant.advance_reference", state, inputs, dt)
        train = self.train
        n = train.n_vehicles
        if atol is None:
            scale = np.r_[np.ones(n), np.full(n - 1, 1e-5), 1.0]
            atol = rtol * scale
        track = self._track_arrays
        t = 0.0
        for _ in range(10 * n * (1 if track is None else track[0].size) + 10):
            if track is None:
                frozen = np.zeros(n)
                events = None
            else:
                lo, hi, frozen = _section_bounds(train, x, track)
                events = _leave_event(train, lo, hi)
            sol = solve_ivp(
                _frozen_rhs(train, u, frozen), (t, dt), x, method=method, rtol=rtol,
                atol=atol, events=events,
            )
            if sol.status == -1:
                raise SolverError(
                    f"Plant.advance_reference: solve_ivp failed at t={sol.t[-1]!r} s "
                    f"({sol.message}). Loosen rtol/atol or try method='Radau'."
                )
            if sol.status == 1:
                t = float(sol.t_events[0][-1])
                x = np.asarray(sol.y_events[0][-1], dtype=float)
                continue
            return np.asarray(sol.y[:, -1], dtype=float)
        raise SolverError(
            "Plant.advance_reference: too many section crossings within one interval "
            f"(dt={dt!r} s). Check the track sections."
        )


def _hermite_root(
    h: float,
    p0: NDArray[np.float64],
    v0: NDArray[np.float64],
    p1: NDArray[np.float64],
    v1: NDArray[np.float64],
    target: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Times in [0, h] where the cubic Hermite interpolants of positions reach ``target``.

    Two Newton steps per column (clipped to [0, h]), started from the linear
    interpolation; the result only seeds Newton on the exact flow.
    """
    travel = p1 - p0
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(travel != 0.0, h * (target - p0) / travel, 0.5 * h)
    tau = np.clip(tau, 0.0, h)
    for _ in range(2):
        r = tau / h
        h00, h10 = (1 + 2 * r) * (1 - r) ** 2, r * (1 - r) ** 2
        h01, h11 = r * r * (3 - 2 * r), r * r * (r - 1)
        pos = h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1
        d00, d10 = 6 * r * (r - 1), (1 - r) * (1 - 3 * r)
        d01, d11 = 6 * r * (1 - r), r * (3 * r - 2)
        vel = (d00 * p0 + d01 * p1) / h + d10 * v0 + d11 * v1
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(vel != 0.0, (pos - target) / vel, 0.0)
        tau = np.clip(tau - step, 0.0, h)
    return tau


def _frozen_rhs(
    train: Train, u: NDArray[np.float64], frozen: NDArray[np.float64]
) -> Callable[[float, NDArray[np.float64]], NDArray[np.float64]]:
    n = train.n_vehicles

    def rhs(t: float, x: NDArray[np.float64]) -> NDArray[np.float64]:
        dx = train_rhs(train, x, u)
        dx[:n] -= frozen
        return dx

    return rhs


def _positions(train: Train, x: NDArray[np.float64]) -> NDArray[np.float64]:
    n = train.n_vehicles
    behind = np.concatenate([[0.0], np.cumsum(train.spacing + x[n : 2 * n - 1])])
    return x[2 * n - 1] - behind


def _section_bounds(
    train: Train, x: NDArray[np.float64], track: _TrackArrays
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per vehicle: the bounds to watch in its current section, and its resistance per mass.

    A vehicle within 1e-6 m of a boundary is put on the side it is moving to,
    and that boundary is not watched (-inf/inf), so that an integration
    restarted at a located crossing moves on.
    """
    starts, per_mass = track[0], track[1]
    n = train.n_vehicles
    p = _positions(train, x)
    v = x[:n]
    sec = np.clip(np.searchsorted(starts, p, side="right") - 1, 0, starts.size - 1)
    near = np.clip(np.searchsorted(starts, p), 0, starts.size - 1)
    for i in range(n):
        for j in (near[i] - 1, near[i]):
            if 1 <= j < starts.size and abs(p[i] - starts[j]) <= 1e-6:
                sec[i] = j if v[i] > 0 else j - 1
    bounds = np.r_[-math.inf, starts[1:], math.inf]
    lo, hi = bounds[sec], bounds[sec + 1]
    # A vehicle just past a bound and moving away from it cannot be watched for it:
    # the event function would start at zero and the root finder stick there.
    lo = np.where((p - lo <= 1e-6) & (v > 0), -math.inf, lo)
    hi = np.where((hi - p <= 1e-6) & (v < 0), math.inf, hi)
    return lo, hi, per_mass[sec]


def _leave_event(
    train: Train, lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> Callable[[float, NDArray[np.float64]], float]:
    finite_lo, finite_hi = np.isfinite(lo), np.isfinite(hi)

    def event(t: float, x: NDArray[np.float64]) -> float:
        p = _positions(train, x)
        gaps = np.r_[(p - lo)[finite_lo], (hi - p)[finite_hi]]
        return float(gaps.min()) if gaps.size else 1.0

    event.terminal = True  # type: ignore[attr-defined]
    event.direction = -1  # type: ignore[attr-defined]
    return event
