# Synchronous operation: the lead's speed loop, the relayed command and the linear closed loop.
"""The centralised synchronous law (spec §4.2, last paragraph) and its linear closed loop.

The lead locomotive ℓ (``lead``, 0-based) computes the specific-force
command [m/s²]

    a_ℓ(t) = v̇_d(t) − κ (v_ℓ(t) − v_d(t)),

v_d the reference speed, κ ``speed_gain`` [1/s], and sends it over the radio
link to every remote locomotive. Vehicle i applies [N]

    u_i(t) = m_i â_i(t) + R_i(v_i(t)),   R_i(v) = m_i (a0_i + a1_i v + a2_i v²),

with â_ℓ = a_ℓ (the lead's own command, no link) and â_i, for a remote, the
newest command it has received (held while nothing new arrives; 0 before
the first one, so that a remote then applies its feedforward only). R_i is
the vehicle's own Davis resistance at its own measured speed: the estimate
F̂_ti of spec §4.2, which every vehicle computes locally. So a remote
applies m_i/m_ℓ times the lead's *feedback* force m_ℓ a_ℓ, delayed by the
link, plus its own resistance: the LOCOTROL-type rule
u_i(t) = (m_i/m_ℓ) u_ℓ(t − τ_i) of spec §4.2 with each vehicle's resistance
estimate taken at its own speed instead of the lead's (the same at
equilibrium for identical vehicles).

The line (grade and curve) resistance: with ``line_feedforward = true``
(the default) the lead adds the line resistance per unit mass under itself,
r(p_ℓ) [m/s²] (:meth:`trainctl.models.track.Track.resistance_per_mass` at
its position, from the line data and odometry a heavy-haul locomotive
carries: the rest of spec §4.1's F_wi), to the command it relays,

    a_ℓ(t) = v̇_d(t) − κ (v_ℓ(t) − v_d(t)) + r(p_ℓ(t)),

so the remotes brake or pull for the grade *under the lead*, late by their
link delay, as a driver's notch on a synchronous train does: on a grade
change the couplers take the difference until the whole train is on the
new grade. Without it (``false``) the grade is a disturbance the lead's
loop rejects, a constant grade's specific force r leaving the steady speed
error r/κ. At a constant reference speed on a constant grade the couplers
are unloaded in equilibrium (every vehicle supplies its own resistance),
whatever the masses.

Linear closed loop
------------------
On the design state x̂ = [v̂ (n) [m/s], δ̂ (n−1) [m]] (deviations from the
cruise at v_r, the design model's continuous SI model
:meth:`~trainctl.design.DesignModel.observer_model`, ẋ = A x̂ + B û, û [N])
the law linearises to û = F₀ x̂ + K x̂(t − τ) with

- F₀ = diag(m_i c_i) on v̂ (c_i = a1_i + 2 a2_i v_r, the slope of the
  feedforward, which cancels the resistance damping of a Jacobian design
  model) plus −κ m_ℓ on row ℓ, column v̂_ℓ (the lead's own feedback);
- K = −κ m_i on row i of every remote, column v̂_ℓ (the lead's feedback as
  the remote receives it, τ late).

A₀ = A + B F₀ is the undelayed part; the delay-free loop is
A_cl = A₀ + B K (τ = 0, an instantaneous relay). The delay margin of
ẋ = A₀x̂ + B_r K_r x̂(t − τ) (B_r, K_r the remotes' columns and rows) is the
uniform link delay at which the loop loses stability
(:func:`trainctl.analysis.delay.delay_margin`).
"""

from __future__ import annotations

from dataclasses import dataclass
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
from trainctl.exceptions import ScenarioError
from trainctl.models.track import Track

if TYPE_CHECKING:
    from trainctl.controllers.synchronous.settings import SynchronousSettings
    from trainctl.design import DesignModel
    from trainctl.scenario import Scenario

__all__ = ["LoopMatrices", "SynchronousLaw", "closed_loop_matrices", "law_of", "line_resistance",
           "own_resistance"]

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True, eq=False)
class SynchronousLaw:
    """The gains of the synchronous law (module docstring), SI.

    Parameters
    ----------
    mass : ndarray
        m_i [kg], shape (n,).
    davis : ndarray
        Davis coefficients per unit mass [m/s², 1/s, 1/m], shape (3, n)
        (:attr:`trainctl.models.train.Train.davis`).
    speed_gain : float
        κ [1/s].
    lead : int
        Index ℓ of the lead locomotive (0-based).
    line : Track or None
        The line whose resistance the lead feeds forward (None: not fed forward).

    Examples
    --------
    >>> law = SynchronousLaw(mass=np.array([2.0, 1.0]), davis=np.zeros((3, 2)),
    ...                      speed_gain=0.5, lead=0)
    >>> law.command(10.0, 12.0, 0.1)    # 0.1 − 0.5 (10 − 12)
    1.1
    >>> law.forces(np.array([1.1, 1.1]), np.array([10.0, 10.0])).tolist()
    [2.2, 1.1]
    """

    mass: Array
    davis: Array
    speed_gain: float
    lead: int
    line: Track | None = None
    """The line whose resistance the lead feeds forward (None: not fed forward)."""

    @property
    def n(self) -> int:
        """Number of vehicles."""
        return int(self.mass.size)

    @property
    def remotes(self) -> tuple[int, ...]:
        """The remote locomotives' indices, increasing."""
        return tuple(i for i in range(self.n) if i != self.lead)

    def command(self, lead_speed: float, reference_speed: float,
                reference_acceleration: float, lead_line: float = 0.0) -> float:
        """a_ℓ = v̇_d − κ(v_ℓ − v_d) + r(p_ℓ) [m/s²].

        Parameters
        ----------
        lead_speed : float
            The lead's measured speed v_ℓ [m/s].
        reference_speed : float
            v_d [m/s].
        reference_acceleration : float
            v̇_d [m/s²].
        lead_line : float
            r(p_ℓ), the line resistance per unit mass under the lead [m/s²]
            (:meth:`line_resistance`; 0 when the line is not fed forward).

        Returns
        -------
        float
            The specific-force command [m/s²].
        """
        return float(reference_acceleration - self.speed_gain * (lead_speed - reference_speed)
                     + lead_line)

    def line_resistance(self, positions: ArrayLike | None) -> Array:
        """r(p_i) [m/s²], shape (n,): the line resistance per unit mass at each position.

        See :func:`line_resistance`.

        Parameters
        ----------
        positions : array_like or None
            Each vehicle's position along the line [m], shape (n,); None: not
            measured.

        Returns
        -------
        ndarray, shape (n,)
            The grade and curve resistance per unit mass [m/s²] at each
            position, negative on down-grades; zeros when the law has no
            ``line`` or ``positions`` is None.

        Raises
        ------
        ModelError
            If ``positions`` does not have shape (n,).
        """
        return line_resistance(self.line, positions, self.n)

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

    def forces(self, commands: ArrayLike, speeds: ArrayLike) -> Array:
        """u_i = m_i â_i + R_i(v_i) [N] (no saturation).

        Parameters
        ----------
        commands : array_like
            The specific-force command each vehicle applies, â_i [m/s²], shape (n,).
        speeds : array_like
            Measured speeds [m/s], shape (n,).

        Returns
        -------
        ndarray
            Shape (n,).
        """
        return np.asarray(self.mass * np.asarray(commands, dtype=float)
                          + self.feedforward(speeds), dtype=float)

    def local_feedback(self, speed: float) -> Array:
        """F₀ [N per unit of x̂], (n, 2n−1): the feedforward's slope and the lead's own loop.

        Parameters
        ----------
        speed : float
            The linearisation speed v_r [m/s].

        Returns
        -------
        ndarray, shape (n, 2n−1)
            F₀ on x̂ = [v̂, δ̂]: m_i c_i on (i, v̂_i) [N/(m/s)] (c_i the slope
            of the Davis resistance per unit mass at v_r), minus κ m_ℓ on the
            lead's (ℓ, v̂_ℓ); zero on δ̂.
        """
        n = self.n
        F = np.zeros((n, 2 * n - 1))
        F[np.arange(n), np.arange(n)] = self.mass * resistance_damping_per_vehicle(
            self.davis, speed)
        F[self.lead, self.lead] -= self.speed_gain * self.mass[self.lead]
        return F

    def relayed_feedback(self) -> Array:
        """K_r [N per unit of x̂], (n−1, 2n−1): row r is remote ``remotes[r]``, −κ m_i on v̂_ℓ.

        Returns
        -------
        ndarray, shape (n−1, 2n−1)
            The remotes' feedback on the lead's speed deviation [N/(m/s)]:
            −κ m_i in column ℓ of remote i's row, zeros elsewhere.
        """
        K = np.zeros((self.n - 1, 2 * self.n - 1))
        K[:, self.lead] = -self.speed_gain * self.mass[list(self.remotes)]
        return K

    def feedback(self, speed: float) -> Array:
        """F = F₀ + the remotes' rows [N per unit of x̂], (n, 2n−1): the delay-free law.

        Parameters
        ----------
        speed : float
            The linearisation speed v_r [m/s].

        Returns
        -------
        ndarray, shape (n, 2n−1)
            :meth:`local_feedback` with :meth:`relayed_feedback` added on the
            remotes' rows [N per unit of x̂]: the law with an instantaneous
            relay.
        """
        F = self.local_feedback(speed)
        F[list(self.remotes)] += self.relayed_feedback()
        return F


def law_of(scenario: Scenario, settings: SynchronousSettings) -> SynchronousLaw:
    """The law's gains for a scenario's train.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    settings : SynchronousSettings
        The family's settings.

    Returns
    -------
    SynchronousLaw
        SI gains.

    Raises
    ------
    ScenarioError
        If the train has a single vehicle (no remote to relay to) or
        ``lead`` is not one of its vehicles.

    Examples
    --------
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> law = law_of(scenario, SynchronousSettings())
    >>> law.n, law.lead, law.speed_gain  # four locomotives, the head leads; κ [1/s]
    (4, 0, 0.1)
    >>> (law.mass / 1e3).tolist()  # [t]
    [5184.0, 5184.0, 5184.0, 5184.0]
    """
    train = scenario.train
    n = train.n_vehicles
    if n < 2:
        raise ScenarioError(
            f"{scenario.source}: the synchronous family needs a train of at least 2 vehicles, "
            f"a lead locomotive and a remote (got {n}).")
    if not 0 <= settings.lead < n:
        raise ScenarioError(
            f"{scenario.source}: [controller] lead must be a vehicle index from 0 to {n - 1} "
            f"(got {settings.lead}). The train has {n} vehicles, numbered from 0, head first.")
    return SynchronousLaw(mass=np.asarray(train.mass, dtype=float),
                          davis=np.asarray(train.davis, dtype=float),
                          speed_gain=float(settings.speed_gain), lead=int(settings.lead),
                          line=scenario.track if settings.line_feedforward else None)


class LoopMatrices(SharedLoops):
    """The continuous loops of the law on x̂ = [v̂, δ̂] (module docstring), SI.

    The relayed part is the remotes' feedback on the lead's speed.

    Parameters
    ----------
    A_open, B_open : ndarray
        The design model: (2n−1, 2n−1) [1/s] and (2n−1, n) [1/kg].
    A0 : ndarray
        A + B F₀: plant, feedforward slope and the lead's own feedback.
    A_cl : ndarray
        The delay-free loop A₀ + B_r K_r.
    B_delayed : ndarray
        B's remote columns B_r, (2n−1, n−1) (:attr:`B_relay`).
    K_delayed : ndarray
        The remotes' feedback K_r, (n−1, 2n−1) (:attr:`K_relay`).

    Examples
    --------
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> from trainctl.design import build_model
    >>> law = law_of(scenario, SynchronousSettings())
    >>> loops = closed_loop_matrices(build_model(scenario), law)
    >>> loops.B_relay.shape, loops.K_relay.shape  # the three remotes' columns and rows
    ((7, 3), (3, 7))
    >>> bool(np.allclose(loops.A_cl, loops.A0 + loops.B_relay @ loops.K_relay))
    True
    """

    @property
    def B_relay(self) -> Array:
        """B's remote columns, (2n−1, n−1)."""
        return self.B_delayed

    @property
    def K_relay(self) -> Array:
        """The remotes' feedback K_r, (n−1, 2n−1)."""
        return self.K_delayed


def closed_loop_matrices(model: DesignModel, law: SynchronousLaw) -> LoopMatrices:
    """The open loop, the undelayed part, the relayed part and the delay-free closed loop.

    :func:`trainctl.controllers.continuous.loops.closed_loop_matrices` with
    F₀ = :meth:`SynchronousLaw.local_feedback` and the relayed part
    K_r = :meth:`SynchronousLaw.relayed_feedback` on the remotes' inputs.

    Parameters
    ----------
    model : DesignModel
        The run's design model (its continuous SI model, no dummy state).
    law : SynchronousLaw
        The gains.

    Returns
    -------
    LoopMatrices
        The matrices.

    Examples
    --------
    The delay-free loop is stable; its slowest mode (time constant 35.4 s)
    is the one ``synchronous_closed_loop`` reports:

    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> loops = closed_loop_matrices(build_model(scenario),
    ...                              law_of(scenario, SynchronousSettings()))
    >>> round(float(np.max(np.linalg.eigvals(loops.A_cl).real)), 4)  # [1/s]
    -0.0282
    """
    speed = float(model.settings.speed)
    return shared_closed_loop(model, law.local_feedback(speed), law.relayed_feedback(),
                              delayed_inputs=law.remotes, factory=LoopMatrices)
