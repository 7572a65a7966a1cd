# Zhao & Wang's four-term law: its gains, its pair potential and its linear closed loop.
"""The law of seed 001 (spec §2.2) and its linearised closed loop.

For car i (head i = 0 here, 0-based), with the error variables
x̂_i = x_i − x̄_i (x̄_i(t) = x̄_0(t) − Σ_{k<i} l_k, l_k the equilibrium centre
distance of coupler k), v̂_i = v_i − v_r and the spacing deviations
z_k = δ_k − δ̄_k (δ̄ the quasi-static elongations of the feedforward), the
force [N] is

    u_i = ū_i − K_i x̂_i − m_i d_v v̂_i + m_i Σ_j c a_ij (v_j − v_i)
          − m_i Σ_{k adjacent} ∂U(z_k)/∂x_i,

ū the cruise feedforward (:class:`~trainctl.models.feedforward.ForceSplit`),
K_i = k · d_d · p_i the pinning stiffness [N/m] (k the mean coupler
stiffness, d_d ``position_gain``, p_i the ``[communication]`` pinning
weight), d_v ``speed_gain`` [1/s], c ``consensus_gain`` [1/s] and a_ij the
``[communication]`` adjacency. Since z_k = x̂_k − x̂_{k+1},
∂U(z_k)/∂x_k = U'(z_k) and ∂U(z_k)/∂x_{k+1} = −U'(z_k): a stretched
coupler pulls the front car back and the rear car forward.

The linear closed loop acts on ξ = [v̂ (n) [m/s], z (n−1) [m], p [m]] with
p = x̂_0 the head's position error (the plant's states are elongations, so
the absolute position needs this one integrator): x̂ = 1·p − S z with
S[i, k] = 1 for k < i. Linearising U' at 0 (U''(0) = κ, every potential's
``curvature()``) gives û = F ξ with

    F_v = −M (d_v I + c L_a),  F_z = −κ M E + K S,  F_p = −K 1,

E the (n × n−1) incidence matrix (E[k, k] = 1, E[k+1, k] = −1), L_a the
Laplacian of a, K = diag(K_i). The open loop is the design model's
continuous SI model (couplers, damping, resistance and unequal masses as
everywhere else) with ṗ = v̂_0.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, cast

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.sampled import cumulative, incidence
from trainctl.exceptions import ScenarioError

if TYPE_CHECKING:
    from trainctl.controllers.continuous.potentials import PairPotential
    from trainctl.controllers.potential.settings import PotentialSettings
    from trainctl.models.train import Train
    from trainctl.scenario import Scenario

__all__ = ["PotentialLaw", "law_of", "make_potential"]

Array = NDArray[np.float64]


def make_potential(settings: PotentialSettings, train: Train) -> PairPotential:
    """The pair potential the settings name, with curvature κ at z = 0.

    ``"quadratic"``: U = κz²/2. ``"barrier"``: U = (κΔ²/2) ln(Δ²/(Δ² − z²)).
    ``"sigma"``: Olfati-Saber's ψ_α on the centre distance, desired distance
    and length scale the mean nominal spacing l [m], its force scale chosen
    so that the curvature at z = 0 is κ.

    Parameters
    ----------
    settings : PotentialSettings
        ``potential``, ``kappa`` [1/s²], ``barrier`` [m].
    train : Train
        The train (nominal spacings, for ``"sigma"``).

    Returns
    -------
    PairPotential
        Per unit mass, on the spacing deviation z [m].

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> from trainctl.models import crh2_half
    >>> s = SimpleNamespace(potential="sigma", kappa=0.5, barrier=None)
    >>> round(make_potential(s, crh2_half()).curvature(), 12)
    0.5
    """
    from trainctl.controllers.continuous.potentials import (
        BarrierPotential,
        FlockingPotential,
        QuadraticPotential,
        SigmaNormPotential,
    )

    kappa = float(settings.kappa)
    if settings.potential == "barrier":
        return BarrierPotential.with_stiffness(kappa, float(cast(float, settings.barrier)))
    if settings.potential == "sigma":
        spacing = float(np.mean(train.spacing))
        unit = FlockingPotential(desired_gap=spacing, length_scale=spacing, force_scale=1.0)
        return SigmaNormPotential(FlockingPotential(
            desired_gap=spacing, length_scale=spacing, force_scale=kappa / unit.stiffness()))
    return QuadraticPotential(kappa)


@dataclass(frozen=True, kw_only=True, eq=False)
class PotentialLaw:
    """The gains of the law (module docstring), SI.

    Parameters
    ----------
    mass : ndarray
        m_i [kg], shape (n,).
    pinning : ndarray
        K_i [N/m], shape (n,).
    speed_gain : float
        d_v [1/s].
    consensus : ndarray
        c·a_ij [1/s], shape (n, n), zero diagonal.
    potential : PairPotential
        U on the spacing deviation [m²/s² per unit mass].

    Examples
    --------
    Two 10 t cars with a spring κ = 0.5 1/s² and speed gain d_v = 0.5 1/s:
    a gap 0.2 m too wide pulls them together with m κ z = 1e4·0.5·0.2 =
    1000 N; the front car 0.1 m/s too fast is braked by m d_v v̂ = 500 N.

    >>> from trainctl.controllers.continuous.potentials import QuadraticPotential
    >>> law = PotentialLaw(mass=np.full(2, 1e4), pinning=np.zeros(2), speed_gain=0.5,
    ...                    consensus=np.zeros((2, 2)), potential=QuadraticPotential(0.5))
    >>> law.force(np.zeros(2), np.array([0.2]), np.zeros(2)).tolist()  # [N], front first
    [-1000.0, 1000.0]
    >>> float(law.force(np.array([0.1, 0.0]), np.zeros(1), np.zeros(2))[0])
    -500.0
    """

    mass: Array
    pinning: Array
    speed_gain: float
    consensus: Array
    potential: PairPotential

    @property
    def n(self) -> int:
        """Number of cars."""
        return int(self.mass.size)

    def consensus_laplacian(self) -> Array:
        """c·L_a [1/s], (n, n): ``L @ v`` is Σ_j c a_ij (v_i − v_j).

        Returns
        -------
        ndarray, shape (n, n)
            The weighted Laplacian diag(Σ_j c a_ij) − c a [1/s] of the
            consensus graph; its rows sum to 0.
        """
        return np.diag(self.consensus.sum(axis=1)) - self.consensus

    def feedback(self) -> Array:
        """F [N per unit of ξ], (n, 2n): û = F ξ for ξ = [v̂, z, p] (module docstring).

        The potential enters through its curvature κ at z = 0 (the law
        linearised about the nominal spacing).

        Returns
        -------
        ndarray, shape (n, 2n)
            The gain [F_v, F_z, F_p]: columns 0..n-1 act on v̂ [N/(m/s)],
            n..2n-2 on z [N/m] and the last on p [N/m].
        """
        n, m = self.n, self.mass
        E, S = incidence(n), cumulative(n)
        Fv = -m[:, None] * (self.speed_gain * np.eye(n) + self.consensus_laplacian())
        Fz = -self.potential.curvature() * m[:, None] * E + self.pinning[:, None] * S
        return np.hstack([Fv, Fz, -self.pinning[:, None]])

    def force(self, v_err: Array, z: Array, x_err: Array) -> Array:
        """The feedback û [N] of the nonlinear law (no feedforward, no saturation).

        Parameters
        ----------
        v_err : ndarray
            v̂ [m/s], shape (n,).
        z : ndarray
            Spacing deviations [m], shape (n-1,).
        x_err : ndarray
            Position errors x̂ [m], shape (n,).

        Returns
        -------
        ndarray
            The forces û [N], shape (n,); NaN where the potential is undefined (a
            barrier crossed).
        """
        grad = np.asarray(self.potential.gradient(np.asarray(z, dtype=float)), dtype=float)
        laplacian, links = self._constant
        damping = self.speed_gain * v_err + laplacian @ v_err
        force: NDArray[np.float64] = (-self.pinning * x_err
                                      - self.mass * (damping + links @ grad))
        return force

    @cached_property
    def _constant(self) -> tuple[Array, Array]:
        """The Laplacian and the incidence matrix :meth:`force` applies every step (the
        gains are frozen: built once, the same matrices)."""
        return self.consensus_laplacian(), incidence(self.n)


def law_of(scenario: Scenario, settings: PotentialSettings) -> PotentialLaw:
    """The law's gains for a scenario (its train and ``[communication]`` graph).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    settings : PotentialSettings
        The family's settings.

    Returns
    -------
    PotentialLaw
        SI gains.

    Raises
    ------
    ScenarioError
        If the train has fewer than 2 cars or no physical coupler (k is the
        mean stiffness of the physical couplers).

    Examples
    --------
    Every car is pinned (weight 1) with position_gain = 0.1 times the
    coupler stiffness 1.0488e7 N/m:

    >>> from trainctl.controllers.potential.settings import PotentialSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc-well-sampled")
    >>> law = law_of(scenario, PotentialSettings())
    >>> law.pinning.tolist()  # [N/m]
    [1048800.0, 1048800.0, 1048800.0, 1048800.0]
    >>> law.speed_gain, law.potential  # [1/s]
    (0.5, QuadraticPotential(kappa=0.5))
    """
    train = scenario.train
    physical = train.stiffness[~train.virtual] if train.n_couplers else np.zeros(0)
    if physical.size == 0 or not np.all(physical > 0):
        raise ScenarioError(
            f"{scenario.source}: the potential family needs a train of at least 2 cars joined "
            f"by physical couplers with stiffness > 0 (got {train.n_vehicles} car(s), "
            f"stiffnesses {train.stiffness.tolist()} N/m): its pinning stiffness is "
            "position_gain times the coupler stiffness.")
    graph = scenario.graph()
    return PotentialLaw(
        mass=np.asarray(train.mass, dtype=float),
        pinning=float(np.mean(physical)) * settings.position_gain * np.asarray(graph.pinning),
        speed_gain=float(settings.speed_gain),
        consensus=settings.consensus_gain * np.asarray(graph.adjacency, dtype=float),
        potential=make_potential(settings, train))
