# Settings of the hinf family: the schema of its [controller] table (no solver imports).
"""The hinf family's settings, declared once (:mod:`trainctl.declare`).

The distributed robust H∞ cooperative law of seed 003 as reconstructed in
spec §4.2: leader-following velocity consensus over the ``[communication]``
graph, each locomotive subsystem comparing its own speed with the
reference's and its neighbours' speeds as they arrive, delayed and noisy,
over the ``[network]`` radio links. For now the gains κ_p and κ_c are the
scenario's; a synthesis of them is left to a later step.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from ...constraints import Choice, Flag, Number
from ...declare import Key, settings

__all__ = ["DEFAULT_CONSENSUS_GAIN", "DEFAULT_PINNING_GAIN", "OWN_SPEEDS", "HinfSettings"]

OWN_SPEEDS = ("delayed", "current")
"""Which own speed a vehicle compares with a received one (:class:`HinfSettings`)."""

DEFAULT_PINNING_GAIN = 0.1
"""κ_p [1/s] of the reference (pinning) term when the scenario gives none [reconstructed].

With every vehicle pinned (the default ``[communication]``, B = I, spec
§4.4's "neighbourhood matrix = I_4") the rigid speed mode of the train
obeys v̇ = −κ_p (v − v_d): κ_p = 0.1 1/s is a 10 s time constant, the
synchronous baseline's default (so the two are compared at one speed of
response), slow against the coupler modes (about 1.7–4 rad/s) and at the
top of the range κ ≈ 0.05–0.1 1/s spec §4.3 examines. A 0.5 m/s error asks
0.05 m/s² (259 kN for a 5184 t subsystem), within an SS4B's 329 kN at
70 km/h."""

DEFAULT_CONSENSUS_GAIN = 0.1
"""κ_c [1/s] of the neighbour (consensus) term when the scenario gives none [reconstructed].

Equal to κ_p, as in spec §4.3's example (κ_p = κ_c = κ): on the default
bidirectional chain of four subsystems the disagreement modes then decay
at κ_p + κ_c λ(L), λ(L) = 0.59, 2 and 3.41, i.e. 0.16–0.44 1/s, still an
order of magnitude below the coupler modes."""


@settings
class HinfSettings:
    """The distributed robust H∞ cooperative law (spec §4.2) with the scenario's gains.

    Each field is declared once, with its ``[controller]`` key (``family =
    "hinf"``, or a ``[controller.hinf]`` sub-table); invalid values raise
    :class:`~trainctl.exceptions.ModelError` (a
    :class:`~trainctl.exceptions.ScenarioError` naming the key in a file).

    Parameters
    ----------
    kappa_p : float
        κ_p [1/s], > 0 (file key ``kappa_p_per_s``): gain of the pinning term
        −κ_p b_i (v_i − v̂_d), b_i the ``[communication]`` pinning weight
        (:data:`DEFAULT_PINNING_GAIN`).
    kappa_c : float
        κ_c [1/s], >= 0 (file key ``kappa_c_per_s``): gain of the consensus
        term −κ_c Σ_j a_ij (v_i − v̂_j), a_ij the ``[communication]``
        adjacency (:data:`DEFAULT_CONSENSUS_GAIN`); 0: every vehicle tracks
        the reference alone.
    control_interval : float or None
        T_c [s], > 0: the law is sampled (zero-order hold) at this interval
        in simulation, and the speeds are sent and read over the network at
        it; None: ``[model].sample_time``. The simulation's duration must be
        a whole multiple of it.
    own_speed : {"delayed", "current"}
        Which own speed vehicle i compares with a received value:
        ``"delayed"``, its own measured speed at the message's send time
        (spec §4.2's β(v_i(t − τ), v_j(t − τ)), from its record of its own
        measurements), or ``"current"``, its measured speed now.
    input_bounds : bool
        Clip each vehicle's force to its traction/braking envelope at its
        measured speed.

    Examples
    --------
    >>> s = HinfSettings()
    >>> s.kappa_p, s.kappa_c, s.control_interval, s.own_speed, s.input_bounds
    (0.1, 0.1, None, 'delayed', True)
    >>> HinfSettings(own_speed="now")
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: HinfSettings: 'own_speed' must be one of ('delayed', \
'current') (got 'now').
    """

    family: ClassVar[str] = "hinf"

    kappa_p: Annotated[float, Number(gt=0), Key(
        "Pinning gain κ_p on the reference term −κ_p b_i (v_i − v̂_d)",
        file="kappa_p_per_s", unit="1/s")] = DEFAULT_PINNING_GAIN
    kappa_c: Annotated[float, Number(ge=0), Key(
        "Consensus gain κ_c on the neighbour term −κ_c Σ a_ij (v_i − v̂_j)",
        file="kappa_c_per_s", unit="1/s")] = DEFAULT_CONSENSUS_GAIN
    control_interval: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Interval at which the law is sampled and the speeds are exchanged in simulation",
        unit="s", omitted="[model].sample_time")] = None
    own_speed: Annotated[str, Choice(OWN_SPEEDS), Key(
        "Own speed compared with a received one: 'delayed' (measured when the message was "
        "sent) or 'current' (measured now)")] = "delayed"
    input_bounds: Annotated[bool, Flag(), Key(
        "Saturate the plant input to the traction/braking envelope")] = True
