# The plant: the nonlinear train integrated between samples (simulation, observers).
"""The nonlinear train as a plant advanced with a held input.

:class:`Plant` integrates the nonlinear model of
:func:`trainctl.models.train_rhs` over one sample interval with the inputs
held constant. The couplers are stiff and nearly undamped (CRH2: coupler
modes up to about 30 rad/s), so forward Euler is unstable at any useful step
and adaptive Runge–Kutta solvers crawl. :meth:`Plant.advance` uses an
exponential (Strang) splitting instead, with both sub-flows solved exactly:

    dx/dt = A(v̄) x + B F(t) + N(v)

- ``A(v̄)``: the linear part, the chain of :mod:`trainctl.models.chain`
  (the one definition the linear and nonlinear models share): coupler
  springs and dampers, the kinematic rows d(delta_i)/dt = v_i - v_{i+1} and
  ds/dt = v_0, with the linear Davis term and the quadratic drag linearised
  about a grid speed v̄ as the speed damping, -(a1 + 2 a2 v̄) v.
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
204 vehicles on the dense path ≈ 90 µs at T = 0.05 s and ≈ 20 ms per 20 s
sample flat (≈ 160 µs and 130 ms with a section boundary every 2 km, where
~40 vehicles cross per 20 s sample); the banded path (the default at 204
vehicles) below.

Long trains: banded propagators. The chain couples only neighbours, so
[Φ | Γ] is numerically banded: its entries fall below 1e-13 of their block's
largest within ~11 vehicles of the diagonal at h = 0.05 s. From
:data:`~trainctl.models._plant_banded.BANDED_MIN_VEHICLES` (128) vehicles on
(``propagation="auto"``; ``"dense"`` or ``"banded"`` force either) the plant
builds that band from ``expm`` of overlapping windows of the chain, in O(n),
applies it as a sparse (CSR) product, O(n) per substep, and handles each
section crossing on the window of the chain around the crossing vehicle
(:mod:`trainctl.models._plant_banded`). The dropped entries are below 1e-13
of their block, and each row's dropped sum is lumped onto its own vehicle,
so a uniform speed is propagated exactly as by the whole matrix. Measured on
the 204-vehicle heavy-haul chain against the dense path: 5e-12 m/s and 1 µN
over 60 s with grade changes and a varying input (both 8e-9 m/s from
``solve_ivp`` at rtol 1e-9), at most 1e-10 m/s over 1 h. Costs, the two
paths timed interleaved in one process (``benchmarks/plant_banded.py``;
2-core machine shared with other jobs, single-threaded BLAS; absolute times
varied 2–5x with the load, the ratios less): per substep dense/banded =
0.7 at 64 vehicles, 0.96–0.99 at 124, 1.4–1.55 at 204 (22 against 34 µs),
3.3–6 at 404; a new (h, v̄) costs 0.04–0.1 s instead of an expm of the
612 × 612 matrix (0.25–0.35 s; at 404 vehicles ~0.1 s against 1.5 s). One
hour of the 204-vehicle chain at T = 1 s (72 000 substeps, cold caches, a
speed law visiting ~7 grid speeds): 2.7 s against 4.5 s on level track,
9.1 s against 18.2 s with a grade change every 2 km (~7 000 vehicle
crossings, which then took about half of the time). Making the crossings cheap
(issue 14; :mod:`trainctl.models._plant_crossings`: fewer section lookups,
scalar seeds, Newton on the crossing vehicle's speed series, CSR products in
the windows' Taylor terms; the substep's CSR product called without scipy's
dispatch) took the banded path's hour to 0.61x of its time with the grade
changes and 0.89x on level track (interleaved runs of the two versions, 3
each, same machine under load: 6.7 against 11.1 s and 3.3 against 3.7 s),
with the same result to 4e-14 m/s after the hour (level: bit for bit). Then
(the issue's target: the hour under 3 s) each substep applies only Φ on
[v, delta] (17 000 of the band's 25 000 entries) and adds Γ F computed once
per value of F (a change of v̄ or a section), and each crossing takes its
crossing time and jump response from Taylor series of its window over the
whole substep (one cached product each, no window ladders): interleaved
runs of ``benchmarks/plant_banded.py --hour``, 3 each, the previous version
first: banded 1 h 1.14, 1.10, 1.15 s against 2.50, 1.62, 1.58 s on level
track, 2.34, 2.24, 2.33 s against 4.81, 3.60, 3.61 s with the grade changes
(0.62–0.73x and 0.49–0.65x; per substep 15–16 against 22 µs level), the end
state equal to 3e-13 m/s (level) and 9e-13 m/s (grades), rounding of the
reordered sums. The substeps themselves stay: the quadratic drag's
remainder is applied between them (Strang splitting), so one propagator
over the whole sample would change the result by the splitting error
(~1e-9 m/s), not by rounding. The caches keep at most 128 MiB each, least
recently used first.

:meth:`Plant.advance_dense` also returns the states at the substep
boundaries (the between-sample truth of a simulation), with the same
integration bit for bit.

The propagators live in :mod:`trainctl.models._plant_propagators` (banded:
:mod:`trainctl.models._plant_banded`), the
substep loop and its dense output in :mod:`trainctl.models._plant_integrate`,
the section crossings in :mod:`trainctl.models._plant_crossings` and the
``solve_ivp`` reference in :mod:`trainctl.models._plant_reference`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_positive
from trainctl.exceptions import DimensionError, ModelError
from trainctl.models._plant_banded import BANDED_MIN_VEHICLES
from trainctl.models._plant_crossings import SectionTracker
from trainctl.models._plant_dense import DenseOutput, DenseRecord
from trainctl.models._plant_integrate import integrate
from trainctl.models._plant_propagators import CACHE_BYTES, LRU, Propagator, TrackArrays
from trainctl.models._plant_reference import advance_reference
from trainctl.models._plant_sample import SampleMap
from trainctl.models.chain import Chain
from trainctl.models.track import Track
from trainctl.models.train import Train

__all__ = ["Plant"]

@dataclass(frozen=True, kw_only=True)
class Plant(DenseOutput):
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
    propagation : {"auto", "dense", "banded"}
        How the exact linear steps are built and applied: ``"dense"``, one
        ``expm`` of the whole chain and dense products, O(n²) per substep;
        ``"banded"``, the band of the same matrices built from windows of the
        chain and applied as sparse products, O(n) per substep
        (:mod:`trainctl.models._plant_banded`; entries below 1e-13 of their
        block dropped); ``"auto"``, banded from
        :data:`~trainctl.models._plant_banded.BANDED_MIN_VEHICLES` vehicles on.

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
    propagation: str = "auto"
    _cache: LRU[Propagator] = field(
        default_factory=lambda: LRU(CACHE_BYTES), init=False, repr=False, compare=False
    )
    _ladders: LRU[Any] = field(
        default_factory=lambda: LRU(CACHE_BYTES), init=False, repr=False, compare=False
    )
    _drag: dict[float, tuple[NDArray[np.float64], NDArray[np.float64]]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _chains: dict[float, Chain] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _inner_flows: dict[tuple[float, float, int], NDArray[np.float64]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _offsets: dict[tuple[float, int, int], NDArray[np.float64]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _margins: dict[float, int] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _local_flows: LRU[Any] = field(
        default_factory=lambda: LRU(CACHE_BYTES), init=False, repr=False, compare=False
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
        if self.propagation not in ("auto", "dense", "banded"):
            raise ModelError(
                "Plant: 'propagation' must be 'auto', 'dense' or 'banded' "
                f"(got {self.propagation!r})."
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
        return Chain.from_train(self.train, self.train.davis[1], position=True).matrices()

    def _chain(self, vbar: float) -> Chain:
        """The chain with speed damping a1 + 2 a2 vbar (kept for the last few vbar)."""
        chain = self._chains.get(vbar)
        if chain is None:
            if len(self._chains) >= 8:
                self._chains.clear()
            davis = self.train.davis
            chain = self._chains[vbar] = Chain.from_train(
                self.train, davis[1] + 2.0 * vbar * davis[2], position=True
            )
        return chain

    @cached_property
    def _banded(self) -> bool:
        """True when the propagators are banded (``propagation``, or "auto" by size)."""
        if self.propagation == "auto":
            return self.train.n_vehicles >= BANDED_MIN_VEHICLES
        return self.propagation == "banded"

    @cached_property
    def _quadratic(self) -> bool:
        """True when some vehicle has quadratic drag (a2 > 0)."""
        return bool(np.any(self.train.davis[2] > 0))

    @cached_property
    def _track_arrays(self) -> TrackArrays | None:
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

    def _apply_a(self, Y: NDArray[np.float64], vbar: float) -> NDArray[np.float64]:
        """A(vbar) @ Y in O(n) per column: the chain's structured product (dense path,
        the arithmetic it always had) or its CSR matrix (banded path, ~7x faster)."""
        chain = self._chain(vbar)
        if self._banded:
            return np.asarray(chain.sparse @ Y)
        return chain.product(Y)

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
            The count ceil(dt / max_substep), at least 1 (a ratio within 1e-9 of an
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
        return self._advance(x, u, dt, None)

    def _advance(
        self, x: NDArray[np.float64], u: NDArray[np.float64], dt: float,
        record: DenseRecord | None,
    ) -> NDArray[np.float64]:
        """:meth:`advance` on checked arguments, recording into ``record`` (or not)."""
        n = self.train.n_vehicles
        steps = self._substeps(dt)
        base = u - self._forces[0]
        track = self._track_arrays
        if track is not None and track[0].size == 1:  # uniform grade: constant force
            base = base - self.train.mass * track[1][0]
            track = None
        z = np.empty(3 * n - 1)  # [v, delta, F]: the propagators act on the forces too
        z[: 2 * n - 1] = x[: 2 * n - 1]
        s = x[2 * n - 1]
        tracker = None if track is None else SectionTracker(self, track, s, z)
        s = integrate(self, z, s, base, dt / steps, steps, tracker, record)
        out = np.empty(2 * n)
        out[: 2 * n - 1] = z[: 2 * n - 1]
        out[2 * n - 1] = s
        return out

    def sample_map(self, dt: float, inner: int = 1) -> SampleMap | None:
        """The preallocated one-sample path of a closed loop, when it applies.

        :mod:`trainctl.models._plant_sample`: the operations of
        :meth:`advance_dense` for a sample of one substep, kept from sample to
        sample; the same result bit for bit.

        Parameters
        ----------
        dt : float
            Sample time [s], > 0.
        inner : int
            Dense points per sample, the last at its end (>= 1).

        Returns
        -------
        SampleMap or None
            The map; None unless ``dt`` is one substep on dense propagators
            (:meth:`advance_dense` is the path then).

        Examples
        --------
        >>> from trainctl.models import crh2_half
        >>> plant = Plant(train=crh2_half())
        >>> plant.sample_map(0.05) is not None, plant.sample_map(0.2)
        (True, None)
        """
        if self._banded or self._substeps(check_positive("Plant.sample_map", "dt", dt)) != 1:
            return None
        return SampleMap(self, dt, inner)

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
        return advance_reference(self, x, u, dt, rtol, atol, method)
