# Settings of the synchronous family: the schema of its [controller] table (no solver imports).
"""The synchronous family's settings, declared once (:mod:`trainctl.declare.keys`).

Centralised synchronous operation of a distributed-power train (spec §4.2,
last paragraph): the lead locomotive closes a speed loop and every remote
locomotive applies the lead's command, scaled by its mass, as it arrives
over the radio link.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import ValidationInfo, model_validator

from trainctl.declare.constraints import Flag, Integer, Number, Violation, raise_at
from trainctl.declare.keys import Key, settings

__all__ = ["DEFAULT_SPEED_GAIN", "SynchronousSettings"]

DEFAULT_SPEED_GAIN = 0.1
"""κ [1/s] of the lead's speed loop when the scenario gives none [reconstructed].

The remotes repeat the lead's specific-force command, so the whole train's
rigid speed mode obeys v̇ = −κ(v − v_d): κ = 0.1 1/s is a 10 s time constant,
slow against the coupler modes of a heavy-haul train (about 1.7–4 rad/s,
spec §4.3) so that the loop does not excite them, and inside the range
κ ≈ 0.05–0.1 1/s spec §4.3 examines. A 0.5 m/s speed error asks 0.05 m/s², the
acceleration of the suggested speed profile (spec §4.4): 259 kN for a 5184 t
locomotive subsystem, within the 329 kN an SS4B's 6.4 MW give at 70 km/h."""


def _n_vehicles(info: ValidationInfo | None) -> int | None:
    """The number of vehicles from the validation context (a scenario file), if known."""
    context = info.context if info is not None else None
    n = context.get("n_coaches") if isinstance(context, dict) else None
    return int(n) if isinstance(n, int) else None


@settings
class SynchronousSettings:
    """Synchronous operation: the lead's speed loop, its command relayed to the remotes.

    Each field is declared once, with its ``[controller]`` key (``family =
    "synchronous"``, or a ``[controller.synchronous]`` sub-table); invalid
    values raise :class:`~trainctl.exceptions.ModelError` (a
    :class:`~trainctl.exceptions.ScenarioError` naming the key in a file).

    Parameters
    ----------
    speed_gain : float
        κ [1/s], > 0 (file key ``speed_gain_per_s``): the lead's command is
        a_1 = v̇_d − κ(v_lead − v_d) [m/s²] (:data:`DEFAULT_SPEED_GAIN`).
    control_interval : float or None
        T_c [s], > 0: the law is sampled (zero-order hold) at this interval
        in simulation and the radio link is read at it; None:
        ``[model].sample_time``. The simulation's duration must be a whole
        multiple of it.
    lead : int
        Index of the lead locomotive, from 0 (head first); every other
        vehicle is a remote. Checked against the train in a scenario file
        and by the design.
    input_bounds : bool
        Clip each vehicle's force to its traction/braking envelope at its
        measured speed.
    command_noise : float
        [m/s²], >= 0 (file key ``command_noise_std_m_s2``): standard
        deviation of the noise on the relayed command, drawn per message on
        the relay's stream; 0 (default): a digital command arrives as sent.
        The ``[network]`` noise keys are speeds' and do not apply to it.
    line_feedforward : bool
        The lead adds the grade and curve resistance per unit mass under
        itself (the track's line model at its measured position) to the
        command it relays, so the remotes answer the grade under the lead
        (:mod:`trainctl.controllers.synchronous.law`); False: the grade is a
        disturbance the loop rejects (steady error r/κ on a constant grade).

    Examples
    --------
    >>> s = SynchronousSettings()
    >>> s.speed_gain, s.control_interval, s.lead, s.input_bounds
    (0.1, None, 0, True)
    >>> SynchronousSettings(speed_gain=0.0)
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: SynchronousSettings: 'speed_gain' must be a finite number \
> 0 (got 0.0).
    """

    family: ClassVar[str] = "synchronous"

    speed_gain: Annotated[float, Number(gt=0), Key(
        "Speed gain κ of the lead locomotive's loop: command v̇_d − κ(v_lead − v_d)",
        file="speed_gain_per_s", unit="1/s")] = DEFAULT_SPEED_GAIN
    control_interval: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Interval at which the law is sampled and the radio link read in simulation",
        unit="s", omitted="[model].sample_time")] = None
    lead: Annotated[int, Integer(ge=0), Key(
        "Index of the lead locomotive (from 0, head first); the other vehicles are remotes"
        )] = 0
    input_bounds: Annotated[bool, Flag(), Key(
        "Saturate the plant input to the traction/braking envelope")] = True
    command_noise: Annotated[float, Number(ge=0), Key(
        "Standard deviation of the noise on the relayed command (the [network] noise keys are "
        "for speeds)", file="command_noise_std_m_s2", unit="m/s²")] = 0.0
    line_feedforward: Annotated[bool, Flag(), Key(
        "The lead feeds the grade and curve resistance under itself forward into the command "
        "it relays (false: the loop rejects the grade as a disturbance)")] = True

    @model_validator(mode="after")
    def _lead_in_train(self, info: ValidationInfo) -> SynchronousSettings:
        n = _n_vehicles(info)
        if n is not None and self.lead >= n:
            raise_at(("lead",), Violation(
                text=f"must be a vehicle index from 0 to {n - 1}", got=self.lead,
                hint=f" The train has {n} vehicle{'s' if n != 1 else ''}, numbered from 0, "
                "head first."), self.lead)
        return self
