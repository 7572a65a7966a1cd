# The energy account of one simulated run: where the inputs' work went.
"""An exact energy account of a :class:`~trainctl.sim.SimulationResult`.

The plant (:func:`trainctl.models.train_rhs`) conserves

    d/dt [Σ ½ m_i v_i² + Σ ½ k_i δ_i²] = Σ u_i v_i - Σ m_i (a0 + a1 v_i + a2 v_i²) v_i
                                         - Σ m_i r(p_i) v_i - Σ d_i (v_i - v_{i+1})²

so over a run the work of the inputs equals the change of kinetic and
coupler-spring energy, plus the work against the line (grade and curves),
plus the running (Davis) and coupler-damping losses. Each term is taken as
exactly as the record allows:

- the inputs' work: u_i is held over each sample interval, so its work there
  is u_i times the distance vehicle i moved, p_i(t_{k+1}) - p_i(t_k), from
  the sampled states (no quadrature); traction where u_i > 0, braking
  (counted positive, the energy the brakes take) where u_i < 0
  (:func:`interval_work` gives them interval by interval);
- kinetic and spring energy at the first and last sample, from the states
  (a virtual link has k = 0: no spring energy);
- the line work m_i (R(p_i,end) - R(p_i,start)), with R the track's
  piecewise-linear antiderivative of the resistance per unit mass
  (:meth:`~trainctl.models.Track.resistance_integral`): r depends on the
  position only, so its work does not depend on the speed on the way. With
  the ``"tbt"`` formula the grade part is the potential energy m g Δh;
- the Davis loss: its constant part m a0 is a force like the line's, its
  work m a0 Δp exact from the positions; the rest, m (a1 + a2 v) v², and
  the coupler damping d (v_i - v_{i+1})² by quadrature over the dense grid
  (:func:`dense_quadrature`: Simpson within each sample interval, the
  trapezoid with a kink term, exact to O(h³), where a vehicle crosses a
  section boundary).

The regenerated energy is ``regen_efficiency`` × braking work and the net
energy drawn is traction - regenerated. The balance residual,
input work - (Δkinetic + Δspring + line work + losses), measures what the
plant's integrator and the quadrature leave unaccounted. Measured on short
runs of the built-in scenarios on a hilly, curved track (tests/test_energy.py),
relative to the traction plus braking work: 5e-11 (crh2-potential),
5e-10 (heavy-haul-hinf-ideal), 8e-10 (crh2-dmpc), 4e-9
(heavy-haul-flocking, 10 200 t trains: about 20 J per section crossing). The
quadrature is not what is left: on grids 4 and 16 times finer (flocking,
``output_interval``) the losses change by < 0.1 J and the residual stays;
it is the plant's own energy error where it switches a section's
resistance (:class:`~trainctl.models.Plant`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_finite
from trainctl.exceptions import ModelError
from trainctl.models.dynamics import vehicle_positions
from trainctl.models.track import Track
from trainctl.models.train import Train
from trainctl.sim.results import SimulationResult
from trainctl.units import j_to_kwh

__all__ = ["EnergyAccount", "OperatingCost", "dense_quadrature", "energy_account",
           "interval_work", "operating_cost", "trains_in"]

Array = NDArray[np.float64]

_PER_VEHICLE = ("traction_work", "braking_work", "regenerated", "net_energy", "kinetic_start",
                "kinetic_end", "grade_work", "curve_work", "running_loss")
_PER_COUPLER = ("spring_start", "spring_end", "damping_loss")


@dataclass(frozen=True, kw_only=True, eq=False)
class EnergyAccount:
    """Where the work of a run's inputs went, per vehicle and coupler [J].

    Parameters
    ----------
    traction_work : ndarray
        Work of the positive (traction) inputs [J], shape (n,).
    braking_work : ndarray
        Energy taken by the negative (braking) inputs, -u Δp summed where
        u < 0 [J], >= 0 when running forward, shape (n,).
    regen_efficiency : float
        Fraction of the braking work recovered [-], in [0, 1].
    kinetic_start, kinetic_end : ndarray
        ½ m v² at the first and the last sample [J], shape (n,).
    spring_start, spring_end : ndarray
        ½ k δ² of each coupler at the first and the last sample [J], shape
        (n-1,); 0 for virtual links.
    grade_work : ndarray
        Work against the grade resistance [J] (negative downhill): the gain of
        potential energy, shape (n,).
    curve_work : ndarray
        Work against the curve resistance [J], >= 0 running forward, shape (n,).
    running_loss : ndarray
        Work against the Davis resistance m (a0 + a1 v + a2 v²) [J], shape (n,).
    damping_loss : ndarray
        Energy dissipated in each coupler's damper, ∫ d (v_i - v_{i+1})² dt [J],
        shape (n-1,).
    mass : ndarray
        Vehicle masses [kg], shape (n,).
    distance : float
        Distance run by the head vehicle [m].

    Examples
    --------
    See :func:`energy_account`.
    """

    traction_work: Array
    braking_work: Array
    regen_efficiency: float
    kinetic_start: Array
    kinetic_end: Array
    spring_start: Array
    spring_end: Array
    grade_work: Array
    curve_work: Array
    running_loss: Array
    damping_loss: Array
    mass: Array
    distance: float

    @property
    def regenerated(self) -> Array:
        """Energy recovered from braking, ``regen_efficiency`` × braking work [J], shape (n,)."""
        return self.regen_efficiency * self.braking_work

    @property
    def net_energy(self) -> Array:
        """Net energy drawn, traction work - regenerated [J], shape (n,)."""
        return self.traction_work - self.regenerated

    def total(self, name: str) -> float:
        """The run's total of a per-vehicle or per-coupler quantity [J].

        Parameters
        ----------
        name : str
            A per-vehicle field or property (``"traction_work"``,
            ``"net_energy"``, ...) or a per-coupler one (``"damping_loss"``, ...).

        Returns
        -------
        float
            Its sum over vehicles or couplers [J].
        """
        names = _PER_VEHICLE + _PER_COUPLER
        if name not in names:
            raise ModelError(
                f"EnergyAccount.total: 'name' must be one of {', '.join(names)} (got {name!r})."
            )
        return float(np.sum(getattr(self, name)))

    @property
    def input_work(self) -> float:
        """Work of the inputs on the train, traction - braking work [J]."""
        return self.total("traction_work") - self.total("braking_work")

    @property
    def kinetic_change(self) -> float:
        """Change of the kinetic energy over the run [J]."""
        return self.total("kinetic_end") - self.total("kinetic_start")

    @property
    def spring_change(self) -> float:
        """Change of the coupler-spring energy over the run [J]."""
        return self.total("spring_end") - self.total("spring_start")

    @property
    def line_work(self) -> float:
        """Work against the line resistance, grade plus curves [J]."""
        return self.total("grade_work") + self.total("curve_work")

    @property
    def losses(self) -> float:
        """Running (Davis) plus coupler-damping losses [J]."""
        return self.total("running_loss") + self.total("damping_loss")

    @property
    def residual(self) -> float:
        """Input work - (Δkinetic + Δspring + line work + losses) [J]."""
        return self.input_work - (self.kinetic_change + self.spring_change + self.line_work
                                  + self.losses)

    @property
    def relative_residual(self) -> float:
        """|residual| / (traction + braking work) [-]; NaN when the inputs did no work."""
        scale = self.total("traction_work") + self.total("braking_work")
        return abs(self.residual) / scale if scale > 0 else math.nan

    @property
    def energy_per_tonne_km(self) -> float:
        """Net energy drawn per tonne of train and km run by the head [J/(t·km)]; NaN when
        the head did not move."""
        tonne_km = float(np.sum(self.mass)) / 1000.0 * self.distance / 1000.0
        return self.total("net_energy") / tonne_km if tonne_km > 0 else math.nan

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict (arrays as lists, non-finite numbers as None).

        Returns
        -------
        dict of str to object
            Every per-vehicle and per-coupler quantity by name as a list [J];
            ``regen_efficiency`` [-], ``mass`` [kg], ``distance`` [m];
            ``totals``: each quantity's run total [J] with ``input_work``,
            ``kinetic_change``, ``spring_change``, ``line_work``, ``losses``
            and ``residual`` [J]; ``relative_residual`` [-];
            ``energy_per_tonne_km`` [J/(t·km)]; and ``kwh``: the traction,
            braking, regenerated and net totals [kWh] and the energy per
            tonne-km [kWh/(t·km)].
        """

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        names = _PER_VEHICLE + _PER_COUPLER
        totals: dict[str, float | None] = {name: num(self.total(name)) for name in names}
        for name in ("input_work", "kinetic_change", "spring_change", "line_work", "losses",
                     "residual"):
            totals[name] = num(getattr(self, name))
        per_tonne_km = self.energy_per_tonne_km
        kwh = {name: num(j_to_kwh(self.total(name)))
               for name in ("traction_work", "braking_work", "regenerated", "net_energy")}
        kwh["energy_per_tonne_km"] = num(j_to_kwh(per_tonne_km))
        return {
            **{name: [float(x) for x in getattr(self, name)] for name in names},
            "regen_efficiency": self.regen_efficiency,
            "mass": [float(x) for x in self.mass],
            "distance": num(self.distance),
            "totals": totals,
            "relative_residual": num(self.relative_residual),
            "energy_per_tonne_km": num(per_tonne_km),
            "kwh": kwh,
        }


def energy_account(result: SimulationResult, train: Train, track: Track | None = None, *,
                   regen_efficiency: float = 1.0) -> EnergyAccount:
    """The energy account of a run (module docstring for the rules).

    Parameters
    ----------
    result : SimulationResult
        The run, simulated with ``train`` on ``track``.
    train : Train
        The simulated train (masses [kg], Davis coefficients, couplers' k
        [N/m] and d [N·s/m], spacings [m]).
    track : Track or None
        The track it ran on; None for level straight track.
    regen_efficiency : float
        Fraction of the braking work recovered [-], in [0, 1].

    Returns
    -------
    EnergyAccount
        The terms per vehicle and coupler [J], their totals and the balance
        residual.

    Raises
    ------
    ModelError
        ``regen_efficiency`` outside [0, 1], a ``result`` of another number of
        vehicles than ``train``, or a dense grid that misses a sample instant.

    Examples
    --------
    One 1 t vehicle with a0 = 0.01 m/s² holds 10 m/s for 10 s up a 10 ‰
    grade (TB/T: 0.0981 m/s²): the input is 10 N + 98.1 N, its work over
    100 m 10 810 J, of which 9 810 J is potential energy (Δh = 1 m) and
    1 000 J the Davis loss.

    >>> from trainctl.models.track import Track, TrackSection
    >>> from trainctl.models.train import Train
    >>> from trainctl.models.vehicle import Vehicle
    >>> train = Train(vehicles=(Vehicle(mass=1000.0, a0=0.01, a1=0.0, a2=0.0),), couplers=())
    >>> track = Track(sections=(TrackSection(start=0.0, grade_permille=10.0),))
    >>> t = np.linspace(0.0, 10.0, 5)
    >>> result = SimulationResult(
    ...     time=t[[0, -1]], states=np.array([[10.0, 10.0], [0.0, 100.0]]),
    ...     velocities=np.array([[10.0, 10.0]]), coupler_forces=np.zeros((0, 2)),
    ...     inputs=np.array([[108.1]]), reference_speed=np.full(2, 10.0),
    ...     reference_acceleration=np.zeros(2), statuses=("optimal",),
    ...     iterations=np.array([1]), residuals=((),), solve_times=np.array([1e-3]),
    ...     fallbacks=("",), controller_name="demo", seed=0, dt=10.0, dense_time=t,
    ...     dense_states=np.vstack([np.full(5, 10.0), 10.0 * t]),
    ...     dense_coupler_forces=np.zeros((0, 5)), dense_reference_speed=np.full(5, 10.0))
    >>> account = energy_account(result, train, track)
    >>> [round(account.total(k), 6) for k in ("traction_work", "grade_work", "running_loss")]
    [10810.0, 9810.0, 1000.0]
    >>> abs(account.residual) < 1e-9, round(account.energy_per_tonne_km)  # [J], [J/(t·km)]
    (True, 108100)
    """
    where = "energy_account"
    eta = check_finite(where, "regen_efficiency", regen_efficiency)
    if not 0.0 <= eta <= 1.0:
        raise ModelError(
            f"{where}: 'regen_efficiency' must be in [0, 1] (got {regen_efficiency!r})."
        )
    _check_run(where, result, train, track)
    n = train.n_vehicles
    x = result.states
    positions = vehicle_positions(train, x)
    moved = np.diff(positions, axis=1)
    traction, braking = interval_work(result, train)
    ends = positions[:, [0, -1]]
    v, delta = x[:n][:, [0, -1]], x[n : 2 * n - 1][:, [0, -1]]
    kinetic = 0.5 * train.mass[:, None] * v**2
    spring = 0.5 * train.stiffness[:, None] * delta**2
    grade, curve = _line_work(train, track, ends)
    running, damping = _dense_losses(result, train, track, moved.sum(axis=1))
    return EnergyAccount(
        traction_work=traction.sum(axis=1),
        braking_work=braking.sum(axis=1),
        regen_efficiency=eta,
        kinetic_start=kinetic[:, 0], kinetic_end=kinetic[:, 1],
        spring_start=spring[:, 0], spring_end=spring[:, 1],
        grade_work=grade, curve_work=curve,
        running_loss=running, damping_loss=damping,
        mass=train.mass.copy(),
        distance=float(x[-1, -1] - x[-1, 0]),
    )


def interval_work(result: SimulationResult, train: Train) -> tuple[Array, Array]:
    """Traction and braking work of each vehicle in each sample interval [J].

    The input u_i is held over sample interval k, so its work there is u_i
    times the distance vehicle i moved, p_i(t_{k+1}) - p_i(t_k), from the
    sampled states: no quadrature. :func:`energy_account`'s traction and
    braking work are these arrays summed over the intervals.

    Parameters
    ----------
    result : SimulationResult
        The run, simulated with ``train``.
    train : Train
        The simulated train (its spacings place the vehicles behind the head).

    Returns
    -------
    (ndarray, ndarray)
        Traction work (u_i > 0) and braking work (u_i < 0, counted positive:
        -u_i Δp_i, the energy the brakes take) [J], each shape (n, N); 0 where
        the input is of the other sign.

    Raises
    ------
    ModelError
        A ``result`` of another number of vehicles than ``train``.

    Examples
    --------
    One 1 t vehicle pulls 100 N over its first 10 m, then brakes with
    50 N over the next 8 m:

    >>> from trainctl.models.train import Train
    >>> from trainctl.models.vehicle import Vehicle
    >>> train = Train(vehicles=(Vehicle(mass=1000.0, a0=0.0, a1=0.0, a2=0.0),), couplers=())
    >>> result = SimulationResult(
    ...     time=np.array([0.0, 1.0, 2.0]),
    ...     states=np.array([[10.0, 10.0, 6.0], [0.0, 10.0, 18.0]]),
    ...     velocities=np.array([[10.0, 10.0, 6.0]]), coupler_forces=np.zeros((0, 3)),
    ...     inputs=np.array([[100.0, -50.0]]), reference_speed=np.full(3, 10.0),
    ...     reference_acceleration=np.zeros(3), statuses=("optimal",) * 2,
    ...     iterations=np.ones(2), residuals=((),) * 2, solve_times=np.zeros(2),
    ...     fallbacks=("",) * 2, controller_name="demo", seed=0, dt=1.0)
    >>> traction, braking = interval_work(result, train)  # [J]
    >>> traction.tolist(), braking.tolist()
    ([[1000.0, 0.0]], [[0.0, 400.0]])
    """
    _check_run("interval_work", result, train, None)
    moved = np.diff(vehicle_positions(train, result.states), axis=1)
    u = result.inputs
    work = u * moved
    return (np.asarray(np.where(u > 0, work, 0.0), dtype=float),
            np.asarray(np.where(u < 0, -work, 0.0), dtype=float))


def dense_quadrature(result: SimulationResult, power: ArrayLike,
                     kinks: ArrayLike | None = None) -> Array:
    """∫ power dt over a run's dense grid: Simpson's rule on pairs of grid intervals.

    Parameters
    ----------
    result : SimulationResult
        The run; its dense grid holds every sample instant.
    power : array_like
        Signals on the dense grid [W], shape (m, D).
    kinks : array_like of bool or None
        Per grid interval, shape (D-1,): True where the signals may have a
        kink inside it (a vehicle crossed a section boundary); None: nowhere.

    Returns
    -------
    ndarray
        Their integrals over the run [J], shape (m,).

    Notes
    -----
    The rule: the trapezoid on every grid interval, and on each pair of equal
    grid intervals within one sample interval, with no kink in either,
    Simpson's correction -h/6 (P_0 - 2 P_1 + P_2), which makes the pair's
    sum Simpson's h/3 (P_0 + 4 P_1 + P_2). Why: within a sample interval the
    input is held and the plant is smooth, so Simpson's error falls as h⁴;
    across a sample instant the acceleration jumps with the input, so no
    pair spans one; and where a vehicle crosses a section boundary its
    acceleration jumps with the line resistance, and the pair holding that
    kink keeps the trapezoid, whose kink error, at most h²/8 · ΔP', has a
    known form that :func:`energy_account` corrects. An interval left
    over (an odd count in a sample interval) keeps the trapezoid. The dense
    points of a sample interval are where the integrator put them, evenly
    spaced (:func:`trainctl.sim.dense_grid`); a pair whose lengths differ
    keeps the trapezoid.

    Examples
    --------
    >>> t = np.linspace(0.0, 2.0, 5)
    >>> result = SimulationResult(
    ...     time=t[[0, 2, 4]], states=np.zeros((2, 3)), velocities=np.zeros((1, 3)),
    ...     coupler_forces=np.zeros((0, 3)), inputs=np.zeros((1, 2)),
    ...     reference_speed=np.zeros(3), reference_acceleration=np.zeros(3),
    ...     statuses=("optimal",) * 2, iterations=np.ones(2), residuals=((),) * 2,
    ...     solve_times=np.zeros(2), fallbacks=("",) * 2, controller_name="demo", seed=0,
    ...     dt=1.0, dense_time=t, dense_states=np.zeros((2, 5)),
    ...     dense_coupler_forces=np.zeros((0, 5)), dense_reference_speed=np.zeros(5))
    >>> dense_quadrature(result, [t**3]).tolist()  # ∫ t³ dt over [0, 2], Simpson: exact
    [4.0]

    A kink flagged in the first grid interval leaves the trapezoid on [0, 1]:

    >>> dense_quadrature(result, [t**3], kinks=[True, False, False, False]).tolist()
    [4.0625]
    """
    t = result.dense_time
    y = np.asarray(power, dtype=float)
    if y.ndim != 2 or y.shape[1] != t.size:
        raise ModelError(
            f"dense_quadrature: 'power' must have shape (m, {t.size}), one row per signal "
            f"on the dense grid (got {y.shape})."
        )
    h = np.diff(t)
    total = 0.5 * (y[:, :-1] + y[:, 1:]) @ h
    kinked = np.zeros(h.size, dtype=bool) if kinks is None else np.asarray(kinks, dtype=bool)
    index = _sample_index(result)
    # First interval of every pair: even offsets from the sample instant, the pair
    # inside the sample interval.
    offset = np.arange(h.size) - np.repeat(index[:-1], np.diff(index))
    last = np.repeat(index[1:], np.diff(index))
    first = np.flatnonzero((offset % 2 == 0) & (np.arange(h.size) + 2 <= last))
    equal = np.abs(h[first] - h[first + 1]) <= 1e-9 * h[first]
    first = first[equal & ~kinked[first] & ~kinked[first + 1]]
    second = y[:, first] - 2.0 * y[:, first + 1] + y[:, first + 2]
    return np.asarray(total - second @ h[first] / 6.0, dtype=float)


def _check_run(where: str, result: SimulationResult, train: Train, track: Track | None) -> None:
    """ModelError unless ``result`` is a run of ``train`` (and ``track`` a Track or None)."""
    if not isinstance(train, Train):
        raise ModelError(f"{where}: 'train' must be a Train (got {type(train).__name__}).")
    if track is not None and not isinstance(track, Track):
        raise ModelError(
            f"{where}: 'track' must be a Track or None (got {type(track).__name__})."
        )
    n = train.n_vehicles
    rows = result.states.shape[0]
    if result.n_vehicles != n or rows != 2 * n:
        raise ModelError(
            f"{where}: 'result' must be a run of the train's {n} vehicles, with states "
            f"[v, delta, s] of {2 * n} rows (got a run of {result.n_vehicles} vehicles, "
            f"{rows} state rows). Pass the train that was simulated."
        )


def _sample_index(result: SimulationResult) -> NDArray[np.intp]:
    """Index of each sample instant in the dense grid (ModelError when one is missing)."""
    t = result.dense_time
    index = np.clip(np.searchsorted(t, result.time), 0, t.size - 1)
    if not np.array_equal(t[index], result.time):
        raise ModelError(
            "energy_account: the result's dense grid must hold every sample instant "
            f"(got dense_time from {t[0]!r} to {t[-1]!r} s with {t.size} points against "
            f"{result.time.size} samples)."
        )
    return index


def _line_work(train: Train, track: Track | None, ends: Array) -> tuple[Array, Array]:
    """Grade and curve work of each vehicle [J] between its positions ``ends`` (n, 2) [m]."""
    if track is None or track.is_flat:
        return np.zeros(train.n_vehicles), np.zeros(train.n_vehicles)
    m = train.mass
    grade = track.resistance_integral(ends, part="grade")
    whole = track.resistance_integral(ends)
    # The curve part as the whole minus the grade part, so that the two add up to the
    # resistance the plant applied (Track.resistance_per_mass) to rounding.
    return m * (grade[:, 1] - grade[:, 0]), m * ((whole - grade)[:, 1] - (whole - grade)[:, 0])


def _dense_losses(result: SimulationResult, train: Train, track: Track | None,
                  moved: Array) -> tuple[Array, Array]:
    """Davis loss of each vehicle and damping loss of each coupler [J].

    The constant Davis term m a0 is a force that depends on nothing, so its work is
    exact from the distance each vehicle ``moved`` [m]; the rest, m (a1 + a2 v) v², and
    the damping d (v_i - v_{i+1})² by :func:`dense_quadrature`, with kinks where a
    vehicle crossed a section boundary of ``track`` (:func:`_kink_corrections`).
    """
    n = train.n_vehicles
    x = result.dense_states
    v = x[:n]
    a0, a1, a2 = (c[:, None] for c in train.davis)
    running = train.mass[:, None] * (a1 + a2 * v) * v * v
    slip = v[:-1] - v[1:]
    damping = train.damping[:, None] * slip * slip
    power = np.vstack([running, damping])
    if track is None or track.is_flat:
        losses = dense_quadrature(result, power)
    else:
        crossing = _crossings(train, track, x)
        losses = (dense_quadrature(result, power, np.any(crossing[0], axis=0))
                  + _kink_corrections(result, train, track, crossing))
    return train.mass * a0[:, 0] * moved + losses[:n], losses[n:]


def _crossings(train: Train, track: Track,
               x: Array) -> tuple[NDArray[np.bool_], Array, NDArray[np.intp]]:
    """Where vehicles cross section boundaries on the dense grid: a flag per vehicle and
    grid interval (n, D-1), the positions (n, D) [m] and the section numbers (n, D)."""
    starts = np.array([s.start for s in track.sections])
    positions = vehicle_positions(train, x)
    section = np.searchsorted(starts, positions, side="right")
    return np.diff(section, axis=1) != 0, positions, section


def _kink_corrections(result: SimulationResult, train: Train, track: Track,
                      crossing: tuple[NDArray[np.bool_], Array, NDArray[np.intp]]) -> Array:
    """The kink terms of the trapezoid on the grid intervals where a vehicle crossed a
    section boundary [J]: (running losses (n,), damping losses (n-1,)).

    Where vehicle i crosses at τ = t_0 + θ h its acceleration jumps by
    Δa = -(r_after - r_before), so a power P(v_i) has a slope that jumps by
    J = P'(v) Δa there; the trapezoid over the grid interval then overestimates
    the integral by J θ (1 - θ) h / 2 · h, to O(h³). θ comes from the positions
    (linear interpolation, an O(h) error in an O(h²) term); one crossing per
    vehicle and grid interval is assumed (a second one, within one grid interval,
    keeps an O(h²) error).
    """
    flags, p, section = crossing
    n = train.n_vehicles
    starts = np.array([s.start for s in track.sections])
    t, v = result.dense_time, result.dense_states[:n]
    out = np.zeros(2 * n - 1)
    for i, j in zip(*np.nonzero(flags), strict=True):
        boundary = starts[max(section[i, j], section[i, j + 1]) - 1]
        theta = float(np.clip((boundary - p[i, j]) / (p[i, j + 1] - p[i, j]), 0.0, 1.0))
        jump = -float(np.diff(track.resistance_per_mass(p[i, j : j + 2]))[0])
        h = t[j + 1] - t[j]
        weight = 0.5 * theta * (1.0 - theta) * h * h * jump
        vi = v[:, j] + theta * (v[:, j + 1] - v[:, j])
        a1, a2 = train.davis[1, i], train.davis[2, i]
        out[i] -= weight * train.mass[i] * (2.0 * a1 + 3.0 * a2 * vi[i]) * vi[i]
        if i > 0:  # the coupler ahead: slip v_{i-1} - v_i falls by Δa
            out[n + i - 1] -= weight * train.damping[i - 1] * 2.0 * (vi[i - 1] - vi[i]) * -1.0
        if i < n - 1:  # the coupler behind: slip v_i - v_{i+1} rises by Δa
            out[n + i] -= weight * train.damping[i] * 2.0 * (vi[i] - vi[i + 1])
    return out


@dataclass(frozen=True, kw_only=True)
class OperatingCost:
    """A run's operating cost at declared prices (:func:`operating_cost`).

    Parameters
    ----------
    supply_energy : float
        Energy drawn from the supply [kWh]: the net energy at the wheels
        (traction minus regenerated) over the drive's efficiency.
    train_hours : float
        Trains times the run's duration [h].
    energy : float
        Cost of the energy [currency].
    time : float
        Cost of the train-hours [currency].
    currency : str
        The currency label.

    Examples
    --------
    >>> cost = OperatingCost(supply_energy=100.0, train_hours=2.0, energy=12.0, time=900.0,
    ...                      currency="EUR")
    >>> cost.total, cost.to_dict()["total"]
    (912.0, 912.0)
    """

    supply_energy: float
    train_hours: float
    energy: float
    time: float
    currency: str

    @property
    def total(self) -> float:
        """Energy plus time [currency]."""
        return self.energy + self.time

    def to_dict(self) -> dict[str, object]:
        """The cost as JSON-safe numbers.

        Returns
        -------
        dict
            ``supply_energy_kwh``, ``train_hours``, ``energy``, ``time``, ``total``
            and ``currency``.
        """
        return {"supply_energy_kwh": self.supply_energy, "train_hours": self.train_hours,
                "energy": self.energy, "time": self.time, "total": self.total,
                "currency": self.currency}


def trains_in(train: Train) -> int:
    """The trains a formation is made of: one, plus one per virtual coupler.

    Parameters
    ----------
    train : Train
        A physically coupled train, or a formation of unit trains.

    Returns
    -------
    int
        The number of trains (each with its crew and its timetable path).

    Examples
    --------
    >>> from trainctl.models import crh2_half
    >>> trains_in(crh2_half())
    1
    """
    return 1 + int(np.count_nonzero(train.virtual))


def operating_cost(account: EnergyAccount, *, duration: float, trains: int,
                   energy_price: float, train_hour_price: float,
                   drive_efficiency: float = 1.0, currency: str = "EUR") -> OperatingCost:
    """The operating cost of a run: its supply energy and its train-hours at their prices.

    cost = energy_price · (Σ net energy [kWh]) / drive_efficiency
    + train_hour_price · trains · duration [h].

    Parameters
    ----------
    account : EnergyAccount
        The run's energy account (:func:`energy_account`).
    duration : float
        The run's duration [s], >= 0.
    trains : int
        Trains that ran (:func:`trains_in`), >= 1.
    energy_price : float
        Price of a kWh from the supply [currency/kWh], >= 0.
    train_hour_price : float
        Price of a train-hour [currency/h], >= 0.
    drive_efficiency : float
        Supply-to-wheel efficiency [-], in (0, 1].
    currency : str
        The currency label.

    Returns
    -------
    OperatingCost
        Energy, time and total.

    Raises
    ------
    ModelError
        For a price or duration below 0, an efficiency outside (0, 1] or no train.

    Examples
    --------
    A run that drew 360 MJ (100 kWh) net over two hours, one train, at 0.12 per kWh
    and 450 per train-hour:

    >>> from types import SimpleNamespace
    >>> account = SimpleNamespace(total=lambda name: 3.6e8)
    >>> cost = operating_cost(account, duration=7200.0, trains=1, energy_price=0.12,
    ...                       train_hour_price=450.0)
    >>> round(cost.energy, 6), cost.time, round(cost.total, 6)
    (12.0, 900.0, 912.0)
    """
    where = "operating_cost"
    for name, value in (("duration", duration), ("energy_price", energy_price),
                        ("train_hour_price", train_hour_price)):
        if not check_finite(where, name, value) >= 0:
            raise ModelError(f"{where}: {name!r} must be >= 0 (got {value!r}).")
    if not 0.0 < check_finite(where, "drive_efficiency", drive_efficiency) <= 1.0:
        raise ModelError(f"{where}: 'drive_efficiency' must be in (0, 1] "
                         f"(got {drive_efficiency!r}).")
    if isinstance(trains, bool) or not isinstance(trains, int | np.integer) or trains < 1:
        raise ModelError(f"{where}: 'trains' must be a whole number >= 1 (got {trains!r}).")
    supply = j_to_kwh(account.total("net_energy")) / drive_efficiency
    hours = int(trains) * duration / 3600.0
    return OperatingCost(supply_energy=supply, train_hours=hours, energy=energy_price * supply,
                         time=train_hour_price * hours, currency=currency)
