# The distributed robust H∞ cooperative law: pinning and consensus on received speeds.
"""The distributed cooperative law of seed 003 (spec §4.2) and its linear loops.

Vehicle i (a locomotive subsystem, 0-based, head first) applies the force [N]

    u_i(t) = m_i a_i(t) + R_i(v_i(t)),   R_i(v) = m_i (a0_i + a1_i v + a2_i v²),

with the specific-force command [m/s²]

    a_i = v̇_d(t) − κ_p b_i (v_i(t_i0) − v̂_d) − κ_c Σ_j a_ij (v_i(t_ij) − v̂_j),

where

- v̂_d and v̂_j are the newest reference speed and neighbour j's measured
  speed vehicle i has received over the network (noise included, held
  during outages and after losses: :class:`trainctl.models.network.Network`), and
  t_i0, t_ij the times at which they were sent;
- ``v_i(t_··)`` is vehicle i's own measured speed at that send time, from its
  record of its own measurements (``own_speed = "delayed"``: spec §4.2's
  β(v_i(t − τ), v_j(t − τ)) with β linear, β′ ≡ 1, so that both sides of
  each difference are equally old), or its measured speed now
  (``own_speed = "current"``);
- b_i is the ``[communication]`` pinning weight (does i hear the
  reference), a_ij its adjacency (does i hear j), κ_p and κ_c the gains;
- v̇_d(t) is the reference acceleration now (the timetable each
  locomotive carries) and R_i the vehicle's own Davis resistance at its
  own measured speed, the estimate F̂_ti of spec §4.2, as in the
  synchronous family.

With ``line_feedforward = true`` (the default) each vehicle also adds
m_i r(p_i), the grade and curve resistance under itself (the track's line
model at its measured position, :func:`~trainctl.controllers.continuous.resistance.line_resistance`:
the rest of spec §4.1's F_wi, which the estimate F̂_ti stands for), so a
constant grade leaves no steady speed error and a grade change is answered
by each vehicle where it happens. Without it the grade is a disturbance the
law rejects (a constant grade's specific force r leaves the steady speed
error r/κ_p when every vehicle is pinned with b_i = 1).

A term whose data vehicle i has never received (before the first message
arrives, or when every message so far was lost or blocked) is left out of
the sum: the vehicle acts on what it has. A vehicle that has heard nothing
applies v̇_d and its resistance only. Without a network (``messages`` None:
no ``[network]`` section) the law reads the true measured speeds and the
reference now: an ideal network, where both ``own_speed`` settings
coincide.

While a link is interrupted the receiver holds its last message, send time
included. With ``own_speed = "delayed"`` both sides of that difference
are then frozen: the vehicle applies a constant correction until new data
arrive, its speed following the timetable's v̇_d open loop. With
``"current"`` it keeps regulating its speed now towards the held value (an
old reference speed, if the reference changed meanwhile). Either way
tracking is restored only once data flow again (spec §4.3 item 4).

Linear closed loop
------------------
On the design state x̂ = [v̂ (n) [m/s], δ̂ (n−1) [m]] (deviations from the
cruise at v_r; :meth:`~trainctl.design.DesignModel.observer_model`,
ẋ = A x̂ + B û, û [N]) the delay-free law is û = F x̂ with

    F = [diag(m_i c_i) − diag(m_i) (κ_p P + κ_c L),  0],

c_i = a1_i + 2 a2_i v_r the slope of the feedforward (cancelling the
resistance damping of a Jacobian design model; :meth:`HinfLaw.resistance_feedback`),
P = diag(b_i), L the graph Laplacian. The same loop, affine in (κ_p, κ_c)
with the disturbance channels, is
:func:`~trainctl.controllers.hinf.synthesis.consensus_loop` with
``local_feedback = resistance_feedback(v_r)``: the H∞ synthesis and the
certificates of the family run on it. With a uniform delay τ on every message the loop is
ẋ = A₀x̂ + B K x̂(t − τ):

- ``own_speed = "delayed"``: A₀ = A + B [diag(m c), 0] and
  K = −[diag(m)(κ_p P + κ_c L), 0]: the whole pinning and consensus
  feedback acts on speeds τ old;
- ``own_speed = "current"``: A₀ = A + B [diag(m c) − diag(m)(κ_p P + κ_c D), 0]
  (D = diag of the in-degrees Σ_j a_ij: the own-speed parts, undelayed) and
  K = [κ_c diag(m) 𝒜, 0] (𝒜 the adjacency: the neighbours' speeds, τ old;
  the reference's delay does not enter the deviation loop, its speed being
  constant there).

Either way A₀ + B K is the delay-free loop A_cl = A + B F.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.controllers.continuous.loops import LoopMatrices as SharedLoops
from trainctl.controllers.continuous.loops import closed_loop_matrices as shared_closed_loop
from trainctl.controllers.continuous.resistance import (
    line_resistance,
    own_resistance,
    resistance_damping_per_vehicle,
)
from trainctl.models.track import Track

if TYPE_CHECKING:
    from trainctl.controllers.hinf.settings import HinfSettings
    from trainctl.design import DesignModel
    from trainctl.scenario import Scenario

__all__ = ["HinfLaw", "LoopMatrices", "closed_loop_matrices", "law_of"]

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True, eq=False)
class HinfLaw:
    """The gains and the graph of the distributed law (module docstring), SI.

    Parameters
    ----------
    mass : ndarray
        m_i [kg], shape (n,).
    davis : ndarray
        Davis coefficients per unit mass [m/s², 1/s, 1/m], shape (3, n)
        (:attr:`trainctl.models.train.Train.davis`).
    kappa_p : float
        κ_p [1/s], the pinning gain.
    kappa_c : float
        κ_c [1/s], the consensus gain.
    adjacency : ndarray
        a_ij [-], shape (n, n): i hears j when > 0.
    pinning : ndarray
        b_i [-], shape (n,): i hears the reference when > 0.
    own_speed : {"delayed", "current"}
        The own speed in each difference (module docstring).
    line : Track or None
        The line whose resistance each vehicle feeds forward at its own
        position (None: not fed forward).

    Examples
    --------
    >>> law = HinfLaw(mass=np.array([2.0, 1.0]), davis=np.zeros((3, 2)), kappa_p=0.5,
    ...               kappa_c=0.25, adjacency=np.array([[0.0, 1.0], [1.0, 0.0]]),
    ...               pinning=np.array([1.0, 0.0]), own_speed="delayed")
    >>> # vehicle 0: 0.1 − 0.5 (10 − 12) − 0.25 (10 − 11); vehicle 1: 0.1 − 0.25 (11 − 10)
    >>> law.commands(0.1, np.array([-2.0, np.nan]),
    ...              np.array([[np.nan, -1.0], [1.0, np.nan]])).tolist()
    [1.35, -0.15]
    """

    mass: Array
    davis: Array
    kappa_p: float
    kappa_c: float
    adjacency: Array
    pinning: Array
    own_speed: str
    line: Track | None = None

    @property
    def n(self) -> int:
        """Number of vehicles."""
        return int(self.mass.size)

    def pinned_laplacian(self) -> Array:
        """κ_p P + κ_c L [1/s], (n, n): the speed feedback of the delay-free law per unit mass.

        Returns
        -------
        ndarray, shape (n, n)
            The matrix κ_p diag(b_i) + κ_c (diag(Σ_j a_ij) − a) [1/s]: P the
            pinning weights, L the graph Laplacian.
        """
        laplacian = np.diag(self.adjacency.sum(axis=1)) - self.adjacency
        return np.asarray(self.kappa_p * np.diag(self.pinning) + self.kappa_c * laplacian,
                          dtype=float)

    def commands(self, reference_acceleration: float, reference_errors: ArrayLike,
                 neighbour_errors: ArrayLike) -> Array:
        """a_i = v̇_d − κ_p b_i e_i0 − κ_c Σ_j a_ij e_ij [m/s²], leaving out absent terms.

        Parameters
        ----------
        reference_acceleration : float
            v̇_d [m/s²].
        reference_errors : array_like
            e_i0 = v_i(t_i0) − v̂_d [m/s], shape (n,); NaN where vehicle i has
            no reference speed (the term is left out).
        neighbour_errors : array_like
            e_ij = v_i(t_ij) − v̂_j [m/s], shape (n, n); NaN where vehicle i
            has no speed of j (left out; the diagonal is never read).

        Returns
        -------
        ndarray
            The commands [m/s²], shape (n,).
        """
        e0 = np.asarray(reference_errors, dtype=float)
        e = np.asarray(neighbour_errors, dtype=float)
        pin_weights, weights = self._weights
        # An absent term (NaN) or a pair that does not listen adds 0.
        pin = np.where((pin_weights > 0) & ~np.isnan(e0), pin_weights * e0, 0.0)
        consensus = np.sum(np.where((weights > 0) & ~np.isnan(e), weights * e, 0.0), axis=1)
        return np.asarray(float(reference_acceleration) - self.kappa_p * pin
                          - self.kappa_c * consensus, dtype=float)

    @cached_property
    def _weights(self) -> tuple[Array, Array]:
        """b_i and a_ij with the non-positive entries (no link) set to 0."""
        return (np.where(self.pinning > 0, self.pinning, 0.0),
                np.where(self.adjacency > 0, self.adjacency, 0.0))

    def feedforward(self, speeds: ArrayLike) -> Array:
        """R_i(v_i) = m_i (a0_i + a1_i v_i + a2_i v_i²) [N]: each vehicle's own resistance.

        Parameters
        ----------
        speeds : array_like
            Each vehicle's measured speed [m/s], shape (n,).

        Returns
        -------
        ndarray
            Shape (n,).
        """
        return own_resistance(self.mass, self.davis, speeds)

    def forces(self, commands: ArrayLike, speeds: ArrayLike,
               positions: ArrayLike | None = None) -> Array:
        """u_i = m_i (a_i + r(p_i)) + R_i(v_i) [N] (no saturation).

        Parameters
        ----------
        commands : array_like
            a_i [m/s²], shape (n,).
        speeds : array_like
            Measured speeds [m/s], shape (n,).
        positions : array_like or None
            Each vehicle's position [m], shape (n,), for the line
            feedforward r(p_i)
            (:func:`~trainctl.controllers.continuous.resistance.line_resistance`); None, or
            a law without a line: r = 0.

        Returns
        -------
        ndarray
            Shape (n,).
        """
        line = line_resistance(self.line, positions, self.n)
        return np.asarray(self.mass * (np.asarray(commands, dtype=float) + line)
                          + self.feedforward(speeds), dtype=float)

    def _speed_columns(self, block: Array) -> Array:
        """An (n, n) block on v̂ padded with zero columns for δ̂: (n, 2n−1)."""
        out = np.zeros((self.n, 2 * self.n - 1))
        out[:, :self.n] = block
        return out

    def resistance_feedback(self, speed: float) -> Array:
        """[diag(m_i c_i), 0] [N per unit of x̂], (n, 2n−1): the feedforward's slope at ``speed``.

        c_i = a1_i + 2 a2_i v_r: the resistance feedforward R_i(v_i) about
        the cruise, a gain-free feedback on each vehicle's current speed that
        cancels the resistance damping of a Jacobian design model. It is the
        ``local_feedback`` of
        :func:`~trainctl.controllers.hinf.synthesis.consensus_loop`, so that the
        gains are synthesised on the loop the family closes.

        Parameters
        ----------
        speed : float
            The linearisation speed v_r [m/s].

        Returns
        -------
        ndarray, shape (n, 2n−1)
            The gain m_i c_i on (i, v̂_i) [N/(m/s)], zeros elsewhere (δ̂
            columns included).
        """
        return self._speed_columns(
            np.diag(self.mass * resistance_damping_per_vehicle(self.davis, speed)))

    def feedback(self, speed: float) -> Array:
        """F [N per unit of x̂], (n, 2n−1): the delay-free law about the cruise at ``speed``.

        Parameters
        ----------
        speed : float
            The linearisation speed v_r [m/s].

        Returns
        -------
        ndarray, shape (n, 2n−1)
            [diag(m_i c_i) − diag(m_i)(κ_p P + κ_c L), 0]: the gain on v̂
            [N/(m/s)], zero on δ̂.
        """
        return self.resistance_feedback(speed) - self._speed_columns(
            np.diag(self.mass) @ self.pinned_laplacian())

    def undelayed_feedback(self, speed: float) -> Array:
        """F₀ [N per unit of x̂], (n, 2n−1): the part of F that acts on current speeds.

        Parameters
        ----------
        speed : float
            The linearisation speed v_r [m/s].

        Returns
        -------
        ndarray, shape (n, 2n−1)
            :meth:`feedback` minus :meth:`delayed_feedback` [N/(m/s)] on v̂,
            zero on δ̂: the feedforward's slope, and with ``own_speed =
            "current"`` the own-speed parts −diag(m)(κ_p P + κ_c D).
        """
        return self.feedback(speed) - self.delayed_feedback()

    def delayed_feedback(self) -> Array:
        """K [N per unit of x̂], (n, 2n−1): the part of F that acts on the received speeds.

        ``"delayed"``: −diag(m)(κ_p P + κ_c L); ``"current"``: κ_c diag(m) 𝒜.

        Returns
        -------
        ndarray, shape (n, 2n−1)
            The gain K on v̂ [N/(m/s)] that acts τ late under a uniform
            message delay τ, zero on δ̂.
        """
        if self.own_speed == "delayed":
            return self._speed_columns(-np.diag(self.mass) @ self.pinned_laplacian())
        return self._speed_columns(self.kappa_c * np.diag(self.mass) @ self.adjacency)


def law_of(scenario: Scenario, settings: HinfSettings, gains: tuple[float, float] | None = None
           ) -> HinfLaw:
    """The law's gains on a scenario's train and ``[communication]`` graph.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    settings : HinfSettings
        The family's settings.
    gains : (float, float) or None
        (κ_p, κ_c) [1/s] in place of the settings' (synthesised gains);
        None: ``kappa_p_per_s`` and ``kappa_c_per_s``.

    Returns
    -------
    HinfLaw
        SI gains.

    Examples
    --------
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> law_of(scenario, HinfSettings()).pinning.tolist()  # every vehicle hears the reference
    [1.0, 1.0, 1.0, 1.0]
    >>> law = law_of(scenario, HinfSettings(), gains=(0.2, 0.05))
    >>> law.kappa_p, law.kappa_c  # [1/s]
    (0.2, 0.05)
    """
    train = scenario.train
    graph = scenario.graph()
    kp, kc = (settings.kappa_p, settings.kappa_c) if gains is None else gains
    return HinfLaw(mass=np.asarray(train.mass, dtype=float),
                   davis=np.asarray(train.davis, dtype=float),
                   kappa_p=float(kp), kappa_c=float(kc),
                   adjacency=np.array(graph.adjacency, dtype=float),
                   pinning=np.array(graph.pinning, dtype=float),
                   own_speed=str(settings.own_speed),
                   line=scenario.track if settings.line_feedforward else None)


class LoopMatrices(SharedLoops):
    """The continuous loops of the law on x̂ = [v̂, δ̂] (module docstring), SI.

    The delayed part acts on every input (its input matrix is ``B_open``).

    Parameters
    ----------
    A_open, B_open : ndarray
        The design model: (2n−1, 2n−1) [1/s] and (2n−1, n) [1/kg].
    A0 : ndarray
        A + B F₀: plant, feedforward slope and the undelayed feedback [1/s].
    A_cl : ndarray
        The delay-free loop A₀ + B K [1/s].
    B_delayed : ndarray
        ``B_open``, the delayed part's input matrix.
    K_delayed : ndarray
        The delayed feedback K [N per unit of x̂], (n, 2n−1) (:attr:`K_delay`).

    Examples
    --------
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> from trainctl.design import build_model
    >>> loops = closed_loop_matrices(build_model(scenario), law_of(scenario, HinfSettings()))
    >>> loops.A_open.shape, loops.K_delay.shape  # 4 vehicles: x̂ = [v̂ (4), δ̂ (3)]
    ((7, 7), (4, 7))
    >>> bool(np.allclose(loops.A_cl, loops.A0 + loops.B_open @ loops.K_delay))
    True
    """

    @property
    def K_delay(self) -> Array:
        """The delayed feedback K [N per unit of x̂], (n, 2n−1)."""
        return self.K_delayed


def closed_loop_matrices(model: DesignModel, law: HinfLaw) -> LoopMatrices:
    """The open loop, the undelayed part, the delayed part and the delay-free closed loop.

    :func:`trainctl.controllers.continuous.loops.closed_loop_matrices` with
    F₀ = :meth:`HinfLaw.undelayed_feedback` and K = :meth:`HinfLaw.delayed_feedback`.

    Parameters
    ----------
    model : DesignModel
        The run's design model (its continuous SI model, no dummy state).
    law : HinfLaw
        The gains.

    Returns
    -------
    LoopMatrices
        The matrices.

    Examples
    --------
    The slowest delay-free mode decays at the pinning gain κ_p = 0.1 1/s:

    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> from trainctl.design import build_model
    >>> loops = closed_loop_matrices(build_model(scenario), law_of(scenario, HinfSettings()))
    >>> round(float(np.max(np.linalg.eigvals(loops.A_cl).real)), 4)  # [1/s]
    -0.1
    """
    speed = float(model.settings.speed)
    return shared_closed_loop(model, law.undelayed_feedback(speed), law.delayed_feedback(),
                              factory=LoopMatrices)
