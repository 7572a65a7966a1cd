# Settings of the flocking family: the schema of its [controller] table (no solver imports).
"""The flocking family's settings, declared once (:mod:`trainctl.declare.keys`).

Olfati-Saber's (2006) Algorithm 2 mapped to virtually coupled trains
(spec §3.3): a pair potential on the gap between consecutive trains, velocity
consensus weighted by the ``[communication]`` graph and the bump adjacency of
the gap, and navigational feedback on the position and speed errors. The
defaults are the seed-002 set of spec §3.5.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import model_validator

from trainctl.declare.constraints import Flag, Number, Violation, raise_at
from trainctl.declare.keys import Key, settings

__all__ = ["FlockingSettings"]

_H_REASON = (
    "With h = 1 (the patent's value) the bump rho_h is the discontinuous indicator of [0, 1): "
    "the adjacency jumps from 1 to 0 at the interaction range, which makes the closed loop "
    "non-Lipschitz (spec §5 item 11). Use 0 < h < 1 (Olfati-Saber uses h = 0.2).")


@settings
class FlockingSettings:
    """Olfati-Saber's flocking law for a formation of virtually coupled trains.

    Each field is declared once, with its ``[controller]`` key (``family =
    "flocking"``, or a ``[controller.flocking]`` sub-table); invalid values
    raise :class:`~trainctl.exceptions.ModelError` (a
    :class:`~trainctl.exceptions.ScenarioError` naming the key in a file).

    Parameters
    ----------
    desired_gap : float or None
        d [m], > 0 (file key ``desired_gap_m``); None: the ``[train.coupler]
        gap``. A value is checked against that gap by the design (they must
        agree: the plant's gap deviations are measured from it).
    interaction_range : float or None
        r [m], > d (file key ``interaction_range_m``); None: 1.2 d.
    length_scale : float
        l [m], > 0 (file key ``length_scale_m``): gaps enter the sigma-norm as s / l.
    sigma_eps : float
        Sigma-norm parameter eps [-], > 0 (on normalised gaps).
    bump_h : float
        Bump parameter h [-], 0 < h < 1 (h = 1 refused with the reason).
    a, b : float
        Attraction and repulsion levels of phi [-], 0 < a <= b.
    force_scale : float
        a_s [m/s²], > 0 (file key ``force_scale_m_s2``): specific force of a unit action.
    consensus_gain : float
        Velocity-consensus gain [1/s], >= 0 (file key ``consensus_gain_per_s``),
        times the graph adjacency and the bump adjacency of the gap.
    position_gain : float
        c₁^γ [1/s²], >= 0 (file key ``position_gain_per_s2``); 0: no position term.
    speed_gain : float
        c₂^γ [1/s], >= 0 (file key ``speed_gain_per_s``).
    control_interval : float or None
        T_c [s], > 0: the law is sampled (zero-order hold) at this interval in
        simulation; None: ``[model].sample_time``.
    input_bounds : bool
        Clip the forces to each train's traction/braking envelope.
    line_feedforward : bool
        Each train adds the grade and curve resistance at its own position
        to its feedforward (as the synchronous and hinf laws do); false: the
        line is left to the feedback.
    supervisor : bool
        Run the braking-curve supervisor
        (:mod:`~trainctl.controllers.flocking.supervisor`): a follower that
        could not stop behind its leader braking at its strongest brakes at
        full instead of following the law. Off by default.
    supervisor_margin : float
        Least gap [m] the supervisor keeps at the closest approach, >= 0
        (file key ``supervisor_margin_m``).
    leader_braking : float or None
        The leaders' worst-case (strongest) deceleration [m/s²], > 0 (file key
        ``leader_braking_m_s2``); None: each leader's braking envelope over its
        mass, at its strongest (low speed: the envelope does not grow with
        speed; for a brake without a power limit the value at every speed).
    supervisor_delay : float or None
        Delay of the leader's messages the supervisor assumes [s], >= 0 (file
        key ``supervisor_delay_s``); None: the largest ``[network]`` delay, 0
        without a ``[network]``.
    supervisor_outage : float or None
        Longest outage of the leader's messages the supervisor and the
        ``flocking_braking_distance`` check assume [s], >= 0 (file key
        ``supervisor_outage_s``); None: the longest ``[network.interruption]``
        window, 0 without one.

    Examples
    --------
    >>> s = FlockingSettings()
    >>> s.desired_gap, s.length_scale, s.bump_h, s.force_scale, s.speed_gain
    (None, 50.0, 0.2, 0.05, 0.02)
    >>> s.supervisor, s.supervisor_margin, s.supervisor_delay  # off; 50 m; from [network]
    (False, 50.0, None)
    >>> FlockingSettings(bump_h=1.0)
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: FlockingSettings: 'bump_h' must be < 1 (got 1.0). With h = 1 ...
    """

    family: ClassVar[str] = "flocking"

    desired_gap: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Desired gap d between the tail of a train and the head of the next; must agree with "
        "[train.coupler] gap", file="desired_gap_m", unit="m",
        omitted="the [train.coupler] gap")] = None
    interaction_range: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Interaction range r of the pair potential and the adjacency, > desired gap",
        file="interaction_range_m", unit="m", omitted="1.2 times the desired gap")] = None
    length_scale: Annotated[float, Number(gt=0), Key(
        "Length scale l: gaps enter the sigma-norm as gap / l", file="length_scale_m",
        unit="m")] = 50.0
    sigma_eps: Annotated[float, Number(gt=0), Key(
        "Sigma-norm parameter eps on normalised gaps")] = 0.1
    bump_h: Annotated[float, Number(gt=0, le=1), Key(
        "Bump parameter h of rho_h, 0 < h < 1")] = 0.2
    a: Annotated[float, Number(gt=0), Key("Attraction level a of phi, 0 < a <= b")] = 1.0
    b: Annotated[float, Number(gt=0), Key("Repulsion level b of phi, b >= a")] = 1.0
    force_scale: Annotated[float, Number(gt=0), Key(
        "Specific force a_s of a unit action", file="force_scale_m_s2", unit="m/s²")] = 0.05
    consensus_gain: Annotated[float, Number(ge=0), Key(
        "Velocity-consensus gain, times the [communication] adjacency and the bump of the gap",
        file="consensus_gain_per_s", unit="1/s")] = 0.05
    position_gain: Annotated[float, Number(ge=0), Key(
        "Position feedback c1 to the virtual leader's slot (0: none)",
        file="position_gain_per_s2", unit="1/s²")] = 1e-4
    speed_gain: Annotated[float, Number(ge=0), Key(
        "Speed feedback c2 to the reference speed", file="speed_gain_per_s",
        unit="1/s")] = 0.02
    control_interval: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Interval at which the continuous-time law is sampled in simulation", unit="s",
        omitted="[model].sample_time")] = None
    input_bounds: Annotated[bool, Flag(), Key(
        "Saturate the plant input to the traction/braking envelope")] = True
    line_feedforward: Annotated[bool, Flag(), Key(
        "Each train feeds forward the grade and curve resistance at its own position "
        "(false: the feedback alone meets the line)")] = False
    supervisor: Annotated[bool, Flag(), Key(
        "Braking-curve supervisor: a follower that could not stop behind its leader braking "
        "at its strongest (from the leader's last received state) brakes at full")] = False
    supervisor_margin: Annotated[float, Number(ge=0), Key(
        "Least gap the supervisor keeps at the closest approach of a follower to its leader",
        file="supervisor_margin_m", unit="m")] = 50.0
    leader_braking: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Worst-case (strongest) deceleration of a leader, for the supervisor and its check",
        file="leader_braking_m_s2", unit="m/s²",
        omitted="each leader's strongest envelope braking over its mass")] = None
    supervisor_delay: Annotated[Annotated[float, Number(ge=0)] | None, Key(
        "Delay of the leader's messages that the supervisor assumes", file="supervisor_delay_s",
        unit="s", omitted="the largest [network] delay, else 0")] = None
    supervisor_outage: Annotated[Annotated[float, Number(ge=0)] | None, Key(
        "Longest outage of the leader's messages that the supervisor and its check assume",
        file="supervisor_outage_s", unit="s",
        omitted="the longest [network.interruption] window, else 0")] = None

    @model_validator(mode="after")
    def _cross_field_rules(self) -> FlockingSettings:
        if self.bump_h == 1.0:
            raise_at(("bump_h",), Violation(text="must be < 1", got=self.bump_h,
                                            hint=f" {_H_REASON}"))
        if self.a > self.b:
            raise_at(("b",), Violation(
                text=f"must be >= a = {self.a!r} (b is the repulsion level, a the attraction "
                "level; phi's shift assumes a <= b)", got=self.b))
        if (self.desired_gap is not None and self.interaction_range is not None
                and self.interaction_range <= self.desired_gap):
            raise_at(("interaction_range",), Violation(
                text=f"must be > the desired gap ({self.desired_gap!r} m)",
                got=self.interaction_range))
        return self
