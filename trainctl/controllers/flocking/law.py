# Olfati-Saber's flocking law on a line of trains: the nonlinear law, its energy and linearisation.
"""The flocking law of seed 002 (spec §3.3) and its linearised closed loop.

Trains are numbered head first (0-based); link k joins train k (front) and
train k+1 (rear), and its gap is ``s_k = d + z_k`` [m] (tail of train k to
head of train k+1), z_k the plant's elongation of the virtual link (its gap
deviation, :class:`~trainctl.models.vehicle.Coupler`). With the errors
x̂_i = x_i − x̄_i [m] (x̄_i the virtual leader's slot for train i),
v̂_i = v_i − v_r [m/s], the force [N] on train i is

    u_i = ū_i + m_i [ Σ_k e_ik φ(s_k) + Σ_j a_ij(s)(v_j − v_i) − c₁ x̂_i − c₂ v̂_i ],

ū the cruise feedforward (:class:`~trainctl.models.feedforward.ForceSplit`),
φ(s) = :meth:`FlockingPotential.acceleration` [m/s²] and e_ik = +1 for the
rear train of link k (i = k+1), −1 for its front train (i = k), 0 otherwise:

* **Pair term, equal and opposite accelerations.** Each link's φ(s_k)
  pulls the rear train forward and the front train back by the same
  *specific* force (not the same force: u = m·a). It acts on every
  consecutive pair, whatever the communication graph: the gap is what each
  train measures of its neighbours. Only consecutive trains have a gap, so
  only they interact through the potential. With equal and opposite
  accelerations, ``H = ½ Σ v̂_i² + Σ_k E(s_k) + ½ c₁ Σ x̂_i²`` (per unit
  mass, E = :meth:`FlockingPotential.energy`) is non-increasing along the
  unsaturated continuous loop for any masses: the pair terms cancel the
  potential's rate, the consensus term contributes −½ Σ a_ij (v_i − v_j)²
  (a symmetric graph), the speed term −c₂ Σ v̂², the resistance
  −Σ v̂_i (R(v_i) − R(v_r)) <= 0.
* **Consensus weights.** a_ij(s) = c · g_ij · ρ_h(‖s_ij / l‖_σ / r_α)
  (:meth:`FlockingLaw.consensus_weights`): the consensus gain, the
  ``[communication]`` adjacency g_ij and the bump adjacency of the gap
  s_ij between trains i and j (tail of the front one to head of the rear
  one, the trains in between included). At the desired gap the bump factor
  is ρ_h(d_α / r_α) (≈ 0.18 for the spec's set), and 0 for non-neighbours
  (their gap exceeds the range).
* **Navigation.** −c₁ x̂_i (the virtual leader's slot; c₁ = 0 leaves a
  rigid translation mode) and −c₂ v̂_i, on every train.

The linear closed loop acts on ξ = [v̂ (n), z (n−1), p] with p = x̂_0 the
head's position error (x̂ = 1·p − S z, S[i, k] = 1 for k < i). At the
desired gaps φ = 0 and v_j − v_i = 0, so only φ'(d) = k_eff
(:meth:`FlockingPotential.stiffness`) and the weights at the desired gaps
survive: û = F ξ with

    F_v = −M (c₂ I + L_a),   F_z = −k_eff M E + c₁ M S,   F_p = −c₁ M 1,

E the incidence matrix (E[k, k] = 1, E[k+1, k] = −1) and L_a the Laplacian
of a_ij at the desired gaps. The open loop is the design model's continuous
SI model (resistance linearised as for every family) with ṗ = v̂_0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.potentials import FlockingPotential
from trainctl.controllers.continuous.sampled import cumulative, incidence
from trainctl.exceptions import ModelError, ScenarioError

if TYPE_CHECKING:
    from trainctl.controllers.flocking.settings import FlockingSettings
    from trainctl.models.track import Track
    from trainctl.scenario import Scenario

__all__ = ["FlockingLaw", "desired_gaps", "law_of"]

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True, eq=False)
class FlockingLaw:
    """The gains and the pair potential of the law (module docstring), SI.

    Parameters
    ----------
    mass : ndarray
        m_i [kg], shape (n,).
    length : ndarray
        Train lengths L_i [m], shape (n,) (for gaps between non-neighbours).
    potential : FlockingPotential
        The pair potential on the gap.
    graph : ndarray
        Communication adjacency g_ij [-], shape (n, n), zero diagonal.
    consensus_gain : float
        c [1/s].
    position_gain : float
        c₁ [1/s²].
    speed_gain : float
        c₂ [1/s].
    line : Track or None
        The line fed forward: each train adds m_i·r(p_i), the grade and curve
        resistance at its measured position
        (:func:`~trainctl.controllers.continuous.resistance.line_resistance`);
        None: no line feedforward.

    Examples
    --------
    >>> law = FlockingLaw(mass=np.full(2, 1e7), length=np.full(2, 1300.0),
    ...                   potential=FlockingPotential(), graph=np.array([[0., 1.], [1., 0.]]),
    ...                   consensus_gain=0.05, position_gain=0.0, speed_gain=0.0)
    >>> acc = law.acceleration(np.zeros(2), np.array([50.0]), np.zeros(2))
    >>> bool(acc[0] < 0.0 < acc[1]), bool(np.isclose(acc[0], -acc[1]))  # 550 m: pull together
    (True, True)
    """

    mass: Array
    length: Array
    potential: FlockingPotential
    graph: Array
    consensus_gain: float
    position_gain: float
    speed_gain: float
    line: Track | None = None

    @property
    def n(self) -> int:
        """Number of trains."""
        return int(self.mass.size)

    def gaps(self, z: Array) -> Array:
        """Gaps s_k = d + z_k [m] of the links, from their deviations z [m].

        Parameters
        ----------
        z : ndarray
            Gap deviations z_k [m] of the links, shape (n-1,).

        Returns
        -------
        ndarray
            The gaps s_k [m], shape (n-1,) (negative when two trains overlap;
            not checked here).
        """
        return self.potential.desired_gap + np.asarray(z, dtype=float)

    def pair_gaps(self, gaps: Array) -> Array:
        """Gap between every two trains [m], shape (n, n) (tail of the front to head of the rear).

        Parameters
        ----------
        gaps : ndarray
            Link gaps s_k [m], shape (n-1,).

        Returns
        -------
        ndarray
            The gaps s_ij = Σ_{k=i}^{j-1} s_k + Σ_{k=i+1}^{j-1} L_k for i < j, symmetric,
            0 diagonal.
        """
        head = -np.concatenate([[0.0], np.cumsum(self.length[:-1] + gaps)])
        tail = head - self.length
        out: NDArray[np.float64] = np.abs(tail[:, None] - head[None, :])
        lower = np.tril_indices(self.n, -1)
        out[lower] = out.T[lower]
        np.fill_diagonal(out, 0.0)
        return out

    def consensus_weights(self, gaps: Array) -> Array:
        """a_ij(s) = c · g_ij · ρ_h(gap_ij) [1/s], shape (n, n), zero diagonal.

        Parameters
        ----------
        gaps : ndarray
            Link gaps s_k [m], shape (n-1,), >= 0 (not checked: :meth:`pair_gaps`
            takes the distance |tail - head|, so an overlap counts as a gap of
            its length).

        Returns
        -------
        ndarray, shape (n, n)
            The consensus weights a_ij [1/s]: the consensus gain times the
            communication adjacency times the bump adjacency of the gap
            between trains i and j (:meth:`pair_gaps`); symmetric, zero
            diagonal.

        Raises
        ------
        ModelError
            If a gap is not finite.
        """
        bump = np.asarray(self.potential.adjacency(self.pair_gaps(gaps)), dtype=float)
        weights: NDArray[np.float64] = self.consensus_gain * self.graph * bump
        np.fill_diagonal(weights, 0.0)
        return weights

    def acceleration(self, v_err: Array, z: Array, x_err: Array) -> Array:
        """The law's specific force about the feedforward [m/s²], shape (n,) (no saturation).

        Parameters
        ----------
        v_err : ndarray
            v̂ [m/s], shape (n,).
        z : ndarray
            Gap deviations [m], shape (n-1,); every gap d + z must be >= 0.
        x_err : ndarray
            Position errors x̂ [m], shape (n,).

        Returns
        -------
        ndarray
            Pair + consensus + navigation terms [m/s²].

        Raises
        ------
        ModelError
            If a gap is negative (the trains overlap).
        """
        s = self.gaps(z)
        phi = np.asarray(self.potential.acceleration(s), dtype=float)
        W = self.consensus_weights(s)
        v = np.asarray(v_err, dtype=float)
        consensus = W @ v - W.sum(axis=1) * v
        force: NDArray[np.float64] = (incidence(self.n) @ -phi + consensus
                                      - self.position_gain * np.asarray(x_err)
                                      - self.speed_gain * v)
        return force

    def force(self, v_err: Array, z: Array, x_err: Array) -> Array:
        """m_i times :meth:`acceleration` [N], shape (n,).

        Parameters
        ----------
        v_err : ndarray
            v̂ [m/s], shape (n,).
        z : ndarray
            Gap deviations [m], shape (n-1,); every gap d + z must be >= 0.
        x_err : ndarray
            Position errors x̂ [m], shape (n,).

        Returns
        -------
        ndarray
            The forces û [N], shape (n,), about the feedforward (no saturation).

        Raises
        ------
        ModelError
            If a gap is negative (the trains overlap).
        """
        return self.mass * self.acceleration(v_err, z, x_err)

    def energy(self, v_err: Array, z: Array, x_err: Array) -> float:
        """H = ½ Σ v̂² + Σ_k E(s_k) + ½ c₁ Σ x̂² [m²/s²] (per unit mass; spec §3.4 item 1).

        Parameters
        ----------
        v_err, z, x_err : ndarray
            As :meth:`acceleration`.

        Returns
        -------
        float
            H [m²/s²].
        """
        v, x = np.asarray(v_err, dtype=float), np.asarray(x_err, dtype=float)
        pair = np.asarray(self.potential.energy(self.gaps(z)), dtype=float)
        return float(0.5 * v @ v + pair.sum() + 0.5 * self.position_gain * x @ x)

    def laplacian(self) -> Array:
        """L_a [1/s] of the weights at the desired gaps, (n, n).

        Returns
        -------
        ndarray, shape (n, n)
            The Laplacian diag(Σ_j a_ij) − a [1/s] of the consensus weights
            at the desired gaps (z = 0); its rows sum to 0.
        """
        W = self.consensus_weights(self.gaps(np.zeros(self.n - 1)))
        return np.diag(W.sum(axis=1)) - W

    def feedback(self) -> Array:
        """F [N per unit of ξ], (n, 2n): û = F ξ on ξ = [v̂, z, p] (module docstring).

        The law linearised at the desired gaps: the potential enters through
        its stiffness k_eff (:meth:`FlockingPotential.stiffness`).

        Returns
        -------
        ndarray, shape (n, 2n)
            The gain [F_v, F_z, F_p]: columns 0..n-1 act on v̂ [N/(m/s)],
            n..2n-2 on z [N/m] and the last on p [N/m].
        """
        n, m = self.n, self.mass[:, None]
        k_eff, c1 = self.potential.stiffness(), self.position_gain
        Fv = -m * (self.speed_gain * np.eye(n) + self.laplacian())
        Fz = -k_eff * m * incidence(n) + c1 * m * cumulative(n)
        return np.hstack([Fv, Fz, -c1 * m])


def desired_gaps(scenario: Scenario) -> Array:
    """The ``[train.coupler]`` gap of each link [m]: centre spacing minus the half-lengths.

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Returns
    -------
    ndarray
        Gaps [m], shape (n-1,).

    Examples
    --------
    Trains 1300 m long whose centres are 1800 m apart leave
    1800 - 1300 = 500 m between them:

    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> desired_gaps(scenario).tolist()
    [500.0, 500.0, 500.0]
    """
    train = scenario.train
    length = np.array([v.length for v in train.vehicles], dtype=float)
    return np.asarray(train.spacing - 0.5 * (length[:-1] + length[1:]), dtype=float)


def _potential(scenario: Scenario, settings: FlockingSettings) -> FlockingPotential:
    """The pair potential, its desired gap the ``[train.coupler]`` gap (checked)."""
    train, where = scenario.train, f"{scenario.source}: [controller] (flocking)"
    if train.n_vehicles < 2 or not np.all(train.virtual):
        raise ScenarioError(
            f"{where} needs at least 2 trains joined by virtual links (got {train.n_vehicles} "
            f"vehicle(s), virtual links {train.virtual.tolist()}): the potential acts on the "
            "gap of a virtual coupling. Set [train.coupler] virtual = true.")
    gaps = desired_gaps(scenario)
    if np.ptp(gaps) > 1e-6 * max(1.0, float(np.max(gaps))):
        raise ScenarioError(f"{where} needs one gap for every link (got {gaps.tolist()} m).")
    gap = float(gaps[0])
    if settings.desired_gap is not None and abs(settings.desired_gap - gap) > 1e-6 * gap:
        raise ScenarioError(
            f"{where}: 'desired_gap_m' must equal the [train.coupler] gap = {gap!r} m, from "
            f"which the plant measures the gap deviations (got {settings.desired_gap!r} m). "
            "Omit desired_gap_m to take the coupler's gap.")
    try:
        return FlockingPotential(
            desired_gap=gap, interaction_range=settings.interaction_range,
            length_scale=settings.length_scale, eps=settings.sigma_eps, h=settings.bump_h,
            a=settings.a, b=settings.b, force_scale=settings.force_scale)
    except ModelError as exc:
        raise ScenarioError(f"{where}: {exc}") from None


def law_of(scenario: Scenario, settings: FlockingSettings) -> FlockingLaw:
    """The law for a scenario (its train, ``[train.coupler]`` gap and ``[communication]`` graph).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    settings : FlockingSettings
        The family's settings.

    Returns
    -------
    FlockingLaw
        SI gains and the potential.

    Raises
    ------
    ScenarioError
        If a link is physical, the gaps differ, ``desired_gap_m`` disagrees
        with the coupler's gap, or the potential's parameters are invalid
        (e.g. the range not beyond the gap).

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> law = law_of(scenario, scenario.controllers["flocking"])
    >>> law.n, law.potential.desired_gap, law.potential.r  # trains, gap and range [m]
    (4, 500.0, 600.0)
    >>> law.graph.sum(axis=1).tolist()  # a chain: the end trains have one neighbour
    [1.0, 2.0, 2.0, 1.0]
    """
    train = scenario.train
    return FlockingLaw(
        mass=np.asarray(train.mass, dtype=float),
        length=np.array([v.length for v in train.vehicles], dtype=float),
        potential=_potential(scenario, settings),
        graph=np.asarray(scenario.graph().adjacency, dtype=float),
        consensus_gain=float(settings.consensus_gain),
        position_gain=float(settings.position_gain),
        speed_gain=float(settings.speed_gain),
        line=scenario.track if settings.line_feedforward else None)
