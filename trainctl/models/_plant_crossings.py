# Section crossings of the plant's splitting integrator (private to models.plant).
"""Track sections in :meth:`trainctl.models.Plant.advance`.

A vehicle that crossed a section boundary during a substep is found at the
start of the next one (:class:`SectionTracker`); its crossing time τ is located
by Newton's method on the exact linear flow of the substep (seeded by cubic
Hermite interpolation), and the jump ΔF of its line resistance is added exactly
as Γ(h - τ) e_i ΔF (:func:`crossings`). The flow over arbitrary t <= h
(:func:`linear_flow`) comes from the plant's cached propagators for h/2^j and a
short Taylor series in the chain's structured product.

Cost (issue 14): near a grade change most of a long train's substeps see no
crossing, and those that do see one vehicle cross. So the tracker looks the
sections up only when the bound on the vehicles' motion since the last lookup
reaches the distance to a section's end (forward) or start (backward), kept
apart (:class:`SectionTracker`), and skips the second lookup after a fix that
cannot move a vehicle across; on the banded path each crossing is handled on
the window of the chain around its vehicle (:func:`_local_crossings`): the
Hermite seed in floats, Newton on the Taylor series of the vehicle's speed
over the whole substep (rows e_k A_w^j cached per window, so Newton's
iterates are scalar), and the response as one product with the cached
series columns A_w^j B e_k. The 204-vehicle chain's run over 60 s with ~120
crossings gives the result of the code before to rounding
(``tests/test_banded_plant.py``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl.models._plant_banded import LocalFlow, local_flow
from trainctl.models._plant_propagators import LADDER_LEVELS, TrackArrays, ladder
from trainctl.models.train import Train

if TYPE_CHECKING:
    from trainctl.models.plant import Plant

__all__ = ["SectionTracker", "crossings", "hermite_root", "hermite_root1", "linear_flow",
           "sections"]

TAYLOR_ORDER = 14
"""Order of the Taylor series for the flow over the remainder t < h/2^L."""

_Start = tuple[NDArray[np.float64], float, NDArray[np.intp], float]
"""A substep's start: (z = [v, delta, F], s, sections, vbar)."""


class SectionTracker:
    """Which section each vehicle is in, and the line-resistance forces that follow.

    Vehicle i is at p_i = s - Σ_{j<i}(gap_j + δ_j), so since the last lookup
    at (s_ref, d_ref) it has moved by Δs - Σ_{j<i} Δδ_j, within
    Δs ± Σ_j |Δδ_j|. No vehicle can have left its section forward while
    Δs + Σ|Δδ| stays below ``ahead`` (the least distance of a vehicle to the
    end of its section), nor backward while Σ|Δδ| - Δs stays below
    ``behind`` (the least distance past a section's start), and the sections
    then need no lookup. The two are kept apart because a vehicle that has
    just crossed is close behind its new section's start while the train
    moves away from it: one bound for both (the original |Δs| + Σ|Δδ| against
    the least of all distances) looked the sections up every substep or two
    near a grade change.
    """

    SLACK = 1e-6
    """[m] subtracted from both budgets: positions are recomputed by a cumulative sum
    whose rounding (~1e-12 m) the bound on the motion does not see."""

    def __init__(self, plant: Plant, track: TrackArrays, s: float, z: NDArray[np.float64]):
        n = plant.train.n_vehicles
        self.plant, self.track, self.n = plant, track, n
        # All set by the first visit, which always looks the sections up (ahead < 0).
        self.sec: NDArray[np.intp] = np.empty(0, dtype=np.intp)
        self.resist: NDArray[np.float64] = np.empty(0)
        """Line-resistance force of each vehicle in its section [N]."""
        self.ahead, self.behind = -1.0, -1.0
        self.s_ref, self.d_ref = s, z[n : 2 * n - 1]
        self.buf = np.empty(n - 1)
        self.writes = 0
        """How many times a visit has written the forces z[2n-1:] (so that the
        integrator knows when to recompute Γ F)."""
        self.prev: _Start | None = None
        self.crossed: tuple[NDArray[np.float64], NDArray[np.float64], float] | None = None
        """The last visit's crossings in the previous substep: (τ [s], the jumps as forcing
        columns G [N], v̄), or None (for the dense output inside the substep)."""

    def visit(
        self, z: NDArray[np.float64], s: float, force: NDArray[np.float64], vbar: float,
        h: float, final: bool,
    ) -> float:
        """At a substep boundary: add the previous substep's crossings, update F; new s.

        ``z`` = [v, delta, F] is updated in place (F = ``force`` - resistance
        when a section changed); the head position is returned.
        """
        n = self.n
        self.crossed = None
        if self.ahead < 0.0:
            s = self._locate(z, s, force, h)
        else:
            moved = s - self.s_ref
            buf = self.buf
            np.subtract(z[n : 2 * n - 1], self.d_ref, out=buf)
            spread = float(np.add.reduce(np.abs(buf, out=buf)))
            if moved + spread >= self.ahead or spread - moved >= self.behind:
                s = self._locate(z, s, force, h)
        if not final:
            self.prev = (z.copy(), s, self.sec, vbar)
        return s

    def _locate(
        self, z: NDArray[np.float64], s: float, force: NDArray[np.float64], h: float
    ) -> float:
        """Look the sections up; add the crossings since the last substep's start."""
        n, track, plant, prev = self.n, self.track, self.plant, self.prev
        p0, now = sections(plant.train, z, s, track)
        if prev is not None and (now != prev[2]).any():
            # Crossings in the previous substep: add their exact effect.
            fix, tau, jumps = crossings(plant, h, prev, p0, z[:n], now, track)
            self.crossed = (tau, jumps, prev[3])
            z[: 2 * n - 1] += fix[: 2 * n - 1]
            s += fix[2 * n - 1]
            # The fix moves vehicle i by fix_s - Σ_{j<i} fix_δj: at most `shift`.
            shift = abs(float(fix[2 * n - 1])) + float(np.abs(fix[n : 2 * n - 1]).sum())
        else:
            shift = 0.0
        lo, hi = track[2][now], track[3][now]
        ahead = float((hi - p0).min()) - shift - self.SLACK
        behind = float((p0 - lo).min()) - shift - self.SLACK
        if shift and (ahead <= 0.0 or behind <= 0.0):  # the fix may have moved one across
            p0, now = sections(plant.train, z, s, track)
            lo, hi = track[2][now], track[3][now]
            ahead = float((hi - p0).min()) - self.SLACK
            behind = float((p0 - lo).min()) - self.SLACK
        self.ahead, self.behind = max(ahead, 0.0), max(behind, 0.0)
        self.s_ref, self.d_ref = s, z[n : 2 * n - 1].copy()
        if prev is None or (now != self.sec).any():
            self.sec = now
            self.resist = plant.train.mass * track[1][now]
            z[2 * n - 1 :] = force - self.resist
            self.writes += 1
        return s

def linear_flow(
    plant: Plant,
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
    n = plant.train.n_vehicles
    levels = ladder(plant, h, vbar)
    Y = np.array(X, dtype=float)
    left = np.array(durations, dtype=float)
    for j in range(LADDER_LEVELS + 1):
        tj = h / 2.0**j
        use = left >= tj
        if np.any(use):
            level = levels[j]
            if isinstance(level, np.ndarray):
                Y[:, use] = level[:, : 2 * n] @ Y[:, use] + level[:, 2 * n :] @ G[:, use]
            else:  # banded (CSR): one product on the stacked [Y; G]
                Y[:, use] = level @ np.vstack([Y[:, use], G[:, use]])
            left[use] -= tj
    rate = plant._apply_a(Y, vbar)
    rate[:n] += G / plant.train.mass[:, None]
    term = left * rate
    Y += term
    tiny = 1e-17 * (float(np.abs(Y).max()) + 1e-300)
    for k in range(2, TAYLOR_ORDER + 1):
        if float(np.abs(term).max()) <= tiny:
            break
        term = (left / k) * plant._apply_a(term, vbar)
        Y += term
    return Y


def sections(
    train: Train, z: NDArray[np.float64], s: float, track: TrackArrays
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """Vehicle positions [m] and the index of the track section each is in."""
    n = train.n_vehicles
    behind = np.empty(n)
    behind[0] = 0.0
    np.cumsum(train.spacing + z[n : 2 * n - 1], out=behind[1:])
    p = s - behind
    return p, np.searchsorted(track[0], p, side="right") - 1


def crossings(
    plant: Plant,
    h: float,
    prev: _Start,
    p1: NDArray[np.float64],
    v1: NDArray[np.float64],
    sec1: NDArray[np.intp],
    track: TrackArrays,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Exact effect, at the end of a substep, of the section crossings within it.

    ``prev`` holds the substep's start ``(z, s, sections, vbar)``; ``p1``,
    ``v1`` and ``sec1`` the positions, speeds and sections at its end. Each
    crossing time τ is first estimated from the cubic Hermite interpolant of
    the vehicle's position, then refined by Newton's method on the exact
    linear flow of the substep; the jump ΔF of the vehicle's line
    resistance then adds Γ(h - τ) e_i ΔF. Returns that sum over the
    crossings, their times τ and their jumps as forcing columns e_i ΔF.
    """
    starts, per_mass = track[0], track[1]
    z0, s0, sec0, vbar = prev
    n = plant.train.n_vehicles
    m = plant.train.mass
    p0 = sections(plant.train, z0, s0, track)[0]
    vehicles: list[int] = []
    boundaries: list[float] = []
    jumps: list[float] = []
    for i in np.flatnonzero(sec1 != sec0).tolist():
        a, b = int(sec0[i]), int(sec1[i])
        step = 1 if b > a else -1
        for sec in range(a, b, step):
            new = sec + step
            vehicles.append(i)
            boundaries.append(float(starts[max(sec, new)]))
            jumps.append(float(-m[i] * (per_mass[new] - per_mass[sec])))
    idx = np.array(vehicles, dtype=np.intp)
    if plant._banded:
        fix, tau = _local_crossings(plant, h, vbar, z0, s0, p0, p1, v1, vehicles,
                                    boundaries, jumps)
        G = np.zeros((n, idx.size))
        G[idx, np.arange(idx.size)] = jumps
        return fix, tau, G
    x0 = np.r_[z0[: 2 * n - 1], s0]
    force0 = z0[2 * n - 1 :]
    bnd = np.array(boundaries)
    tau = hermite_root(h, p0[idx], z0[idx], p1[idx], v1[idx], bnd)
    # Newton on p_i(τ) = boundary; dp_i/dt = v_i. Position p_i = s - Σ_{j<i}(gap_j + δ_j).
    X = np.repeat(x0[:, None], idx.size, axis=1)
    G = np.repeat(force0[:, None], idx.size, axis=1)
    cols = np.arange(idx.size)
    for _ in range(8):
        Y = linear_flow(plant, h, vbar, X, G, tau)
        behind = np.cumsum(plant.train.spacing[:, None] + Y[n : 2 * n - 1], axis=0)
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
    response = linear_flow(plant, h, vbar, np.zeros((2 * n, idx.size)), G, h - tau)
    return response.sum(axis=1), tau, G


def _local_crossings(
    plant: Plant,
    h: float,
    vbar: float,
    z0: NDArray[np.float64],
    s0: float,
    p0: NDArray[np.float64],
    p1: NDArray[np.float64],
    v1: NDArray[np.float64],
    vehicles: list[int],
    boundaries: list[float],
    jumps: list[float],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`crossings` on the banded path: each crossing on the window of the chain
    around its vehicle (:func:`~trainctl.models._plant_banded.local_flow`).

    The same Hermite seed, Newton iteration and exact jump response as on
    the whole chain, but on the window (~3·(2M + core) states instead of
    3n): its flow equals the chain's near the vehicle to below the band
    tolerance, and the response Γ(h - τ) e_i ΔF outside the window is below
    it too (it is a column of the banded Γ). Both come from Taylor series
    over the whole substep (:func:`_series`): Newton evaluates the crossing
    vehicle's speed series v(t) = Σ t^j/j! v^(j)(0) and its integral, the
    position, in scalar Python (the derivatives v^(j)(0) = e_k A_w^j ... from
    one product with the window's state), and the response is one product
    Σ_j (h - τ)^(j+1)/(j+1)! A_w^j B e_k ΔF with the cached columns. Measured
    on the graded 1 h run of ``benchmarks/plant_banded.py`` (6 812 crossings,
    wall clock around this function, interleaved runs of both versions): 39 µs
    per crossing, the series' construction included, against 107–124 µs for the
    window ladders (h/2^j, j <= 10, dense products, their ``expm`` included) and
    short Taylor steps they replace; the hour's end state equal to 4e-14 m/s.
    Returns the summed response (2n,) and the crossing times τ [s].
    """
    n = plant.train.n_vehicles
    fix = np.zeros(2 * n)
    tau = np.empty(len(vehicles))
    for c, i in enumerate(vehicles):
        bnd = boundaries[c]
        t = hermite_root1(h, float(p0[i]), float(z0[i]), float(p1[i]), float(v1[i]), bnd)
        flow = local_flow(plant, h, vbar, i, None)
        lo, hi = flow.lo, flow.hi
        m = hi - lo
        derivs, cols, inv_fact, int_fact, ratio = _series(flow, h, i - lo)
        # The speed derivatives at the substep's start: v^(0) = e_k Y, and
        # v^(j) = e_k A^(j-1) (A Y + B G) (G: the window's forces, held).
        d = derivs @ np.concatenate((z0[lo:hi], z0[n + lo : n + hi - 1],
                                     z0[2 * n - 1 + lo : 2 * n - 1 + hi]))
        speed = (d * inv_fact).tolist()  # v(t) = Σ speed_j t^j
        travel = (d * int_fact).tolist()  # p(t) - p(0) = Σ travel_j t^(j+1)
        start = float(p0[i]) - bnd
        for _ in range(8):
            vel, pos = 0.0, 0.0
            for cv, cp in zip(reversed(speed), reversed(travel), strict=True):  # Horner
                vel = vel * t + cv
                pos = pos * t + cp
            pos = start + pos * t
            new = min(max(t - pos / vel, 0.0), h) if vel != 0.0 else t
            done = abs(new - t) <= 1e-6 * h
            t = new
            if done:
                break
        tau[c] = t
        # The response Γ_w(h - τ) e_k ΔF = Σ_j (h - τ)^(j+1)/(j+1)! A_w^j B e_k ΔF.
        Y = (jumps[c] * np.cumprod((h - t) * ratio)) @ cols
        fix[lo:hi] += Y[:m]
        fix[n + lo : n + hi - 1] += Y[m : 2 * m - 1]
        if lo == 0:  # the window's position is the head's
            fix[2 * n - 1] += Y[2 * m - 1]
    return fix, tau


def _series(flow: LocalFlow, h: float, k: int) -> tuple[NDArray[np.float64], ...]:
    """The Taylor series of vehicle k of a window over a substep of length h.

    Returns the map from the window's [v, delta, F] (3m-1) to the speed derivatives
    v_k^(j)(0) = e_k A_w^j Y + e_k A_w^(j-1) B G (J, 3m-1), the columns A_w^j B e_k
    (J, 2m) (B e_k = e_k/m_k on the speeds), 1/j!, 1/(j+1)! and 1/(j+1) (J,), j < J;
    cached in the window's ``rows``
    per k (shared by the windows of equal sub-chains). J is the first order
    whose term bound r^J/J! is at most 1e-17, r = ‖S A_w S⁻¹‖ h (the larger of
    the balanced 1- and ∞-norms, ~2.6 at 204 vehicles and h = 0.05 s: J = 27);
    the sums of the terms stay below e^r times the result's scale, so the
    series lose about one digit to rounding.
    """
    cache = flow.rows
    assert cache is not None
    found = cache.get(k)
    if found is not None:
        return found
    r = flow.norm * h
    order, bound = 1, r
    while bound > 1e-17 and order < 60:
        order += 1
        bound *= r / order
    # All core vehicles of the window at once (they all cross in turn): one matrix
    # product per order instead of one per vehicle. Measured on the 1 h run: the
    # series' construction took 0.13 s for ~1 500 (window, vehicle, v̄) one by one.
    lo, hi = flow.core
    ks = np.arange(lo, hi) if lo <= k < hi else np.array([k])
    A = flow.A
    m2 = A.shape[0]
    m = m2 // 2
    inverse_mass = flow.inverse_mass[:, 0]
    rows = np.zeros((order, ks.size, m2))  # e_k A^j
    cols = np.zeros((order, m2, ks.size))  # A^j B e_k
    rows[0, np.arange(ks.size), ks] = 1.0
    cols[0, ks, np.arange(ks.size)] = inverse_mass[ks]
    for j in range(1, order):
        np.matmul(rows[j - 1], A, out=rows[j])
        np.matmul(A, cols[j - 1], out=cols[j])
    fact = np.cumprod(np.r_[1.0, np.arange(1.0, order + 1.0)])  # j!, j = 0..order
    factors = (1.0 / fact[:-1], 1.0 / fact[1:], 1.0 / np.arange(1.0, order + 1.0))
    for c, kk in enumerate(ks.tolist()):
        derivs = np.zeros((order, 3 * m - 1))
        derivs[:, : 2 * m - 1] = rows[:, c, : 2 * m - 1]  # the window's s column of A_w is 0
        derivs[1:, 2 * m - 1 :] = rows[:-1, c, :m] * inverse_mass
        cache[kk] = (derivs, np.ascontiguousarray(cols[:, :, c]), *factors)
    return cache[k]


def hermite_root1(h: float, p0: float, v0: float, p1: float, v1: float, target: float
                  ) -> float:
    """:func:`hermite_root` for one crossing, in Python floats (the same arithmetic)."""
    travel = p1 - p0
    tau = h * (target - p0) / travel if travel != 0.0 else 0.5 * h
    tau = min(max(tau, 0.0), h)
    for _ in range(2):
        r = tau / h
        h00, h10 = (1 + 2 * r) * (1 - r) ** 2, r * (1 - r) ** 2
        h01, h11 = r * r * (3 - 2 * r), r * r * (r - 1)
        pos = h00 * p0 + h10 * h * v0 + h01 * p1 + h11 * h * v1
        d00, d10 = 6 * r * (r - 1), (1 - r) * (1 - 3 * r)
        d01, d11 = 6 * r * (1 - r), r * (3 * r - 2)
        vel = (d00 * p0 + d01 * p1) / h + d10 * v0 + d11 * v1
        step = (pos - target) / vel if vel != 0.0 else 0.0
        tau = min(max(tau - step, 0.0), h)
    return tau


def hermite_root(
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
