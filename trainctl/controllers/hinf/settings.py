# Settings of the hinf family: the schema of its [controller] table (no solver imports).
"""The hinf family's settings, declared once (:mod:`trainctl.declare.keys`).

The distributed robust H∞ cooperative law of seed 003 as reconstructed in
spec §4.2: leader-following velocity consensus over the ``[communication]``
graph, each locomotive subsystem comparing its own speed with the
reference's and its neighbours' speeds as they arrive, delayed and noisy,
over the ``[network]`` radio links. The gains κ_p and κ_c are the
scenario's, or, with ``synthesise = true``, the ones within the bounds that
minimise the certified H∞ gain γ from the scaled disturbances (force per
unit mass, reference and link noise) to the scaled performance output
(:func:`trainctl.controllers.hinf.synthesis.synthesise_gains`).
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import model_validator

from trainctl.declare.constraints import Array, Choice, Flag, Integer, Number, Violation, raise_at
from trainctl.declare.keys import Key, settings

__all__ = ["DEFAULT_CONSENSUS_BOUNDS", "DEFAULT_CONSENSUS_GAIN", "DEFAULT_PINNING_BOUNDS",
           "DEFAULT_PINNING_GAIN", "OWN_SPEEDS", "PERFORMANCES", "HinfSettings"]

OWN_SPEEDS = ("delayed", "current")
"""Which own speed a vehicle compares with a received one (:class:`HinfSettings`)."""

PERFORMANCES = ("tracking", "disagreement")
"""Performance outputs of the H∞ gain: the speed errors e, or (I − 11ᵀ/n) e."""

DEFAULT_PINNING_BOUNDS = (0.01, 0.2)
"""[lo, hi] of κ_p [1/s] searched by the synthesis when the scenario gives none [reconstructed].

0.01 1/s is a 100 s time constant of the rigid speed mode (every vehicle
pinned), the slowest that still follows a timetable's speed changes;
0.2 1/s, twice :data:`DEFAULT_PINNING_GAIN`, a 5 s time constant, still an
order of magnitude below the coupler modes (about 1.7–4 rad/s), and a
0.3 m/s speed error then asks 0.06 m/s² (311 kN for a 5184 t subsystem),
within an SS4B's 329 kN at 70 km/h. Without a delay certificate the force
channels' γ falls like 1/κ_p, so the search ends at the upper bound: it is
the real design choice."""

DEFAULT_CONSENSUS_BOUNDS = (0.0, 0.2)
"""[lo, hi] of κ_c [1/s] searched by the synthesis when the scenario gives none [reconstructed].

From 0 (every pinned vehicle tracks the reference alone) to the same 0.2 1/s
as κ_p's upper bound, where the disagreement modes on the default chain
decay at up to κ_p + 3.41 κ_c ≈ 0.9 1/s, still below the coupler modes."""

_GAIN_WHY = (
    "A gain above 1e4 1/s asks for a speed-error time constant shorter than 0.1 ms, the "
    "shortest sample time trainctl accepts: no sampled law realises it (real designs: "
    "0.01 to 1 1/s), and far beyond it the closed-loop matrices overflow.")
_PINNING_GAIN = Number(ge=1e-6, le=1e4, why=_GAIN_WHY + (
    " Below 1e-6 1/s the speed follows the reference with a time constant of more than "
    "11 days: no timetable is tracked, and the rigid mode is singular for floating point."))
_CONSENSUS_GAIN = Number(ge=0, le=1e4, why=_GAIN_WHY)

_FORCE_SCALE = Number(ge=1e-6, le=1e3, why=(
    "One unit of force disturbance from 1e-6 m/s² (a thousandth of a ‰ of grade) to "
    "1000 m/s² (about 100 g; real ones: 0.001 to 0.1 m/s²); outside, the weighted channels' "
    "numbers span more than the H∞ solvers resolve."))
_SPEED_SCALE = Number(ge=1e-6, le=300.0, why=(
    "One unit of speed noise or error from 1 µm/s to 300 m/s (above the fastest train's "
    "speed; real ones: 0.01 to 1 m/s); outside, the weighted channels' numbers span more "
    "than the H∞ solvers resolve."))

DEFAULT_SYNTHESIS_GRID = 7
"""Grid points per gain of the synthesis (a 7 × 7 grid, 49 SDPs)."""

DEFAULT_SYNTHESIS_EVALUATIONS = 40
"""SDP solves of the local refinement (Nelder–Mead) after the grid."""

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
    """The distributed robust H∞ cooperative law (spec §4.2): given or synthesised gains.

    Each field is declared once, with its ``[controller]`` key (``family =
    "hinf"``, or a ``[controller.hinf]`` sub-table); invalid values raise
    :class:`~trainctl.exceptions.ModelError` (a
    :class:`~trainctl.exceptions.ScenarioError` naming the key in a file).

    Parameters
    ----------
    kappa_p : float
        κ_p [1/s], 1e-6 to 1e4 (file key ``kappa_p_per_s``): gain of the pinning term
        −κ_p b_i (v_i − v̂_d), b_i the ``[communication]`` pinning weight
        (:data:`DEFAULT_PINNING_GAIN`).
    kappa_c : float
        κ_c [1/s], from 0 to 1e4 (file key ``kappa_c_per_s``): gain of the consensus
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
    line_feedforward : bool
        Each vehicle adds the grade and curve resistance under itself (the
        track's line model at its measured position) to its feedforward
        (:mod:`trainctl.controllers.hinf.law`); False: the grade is a
        disturbance the law rejects (steady error r/κ_p on a constant grade).
    synthesise : bool
        False: the law uses ``kappa_p`` and ``kappa_c``; True: the gains
        within the bounds that minimise the certified γ (found once, at the
        design stage, and used by the law, the loops, the checks and the
        simulation).
    kappa_p_bounds, kappa_c_bounds : (float, float)
        [lo, hi] [1/s] searched for κ_p (lo >= 1e-6) and κ_c (lo >= 0), hi <= 1e4, lo <= hi
        (file keys ``kappa_p_bounds_per_s``, ``kappa_c_bounds_per_s``;
        :data:`DEFAULT_PINNING_BOUNDS`, :data:`DEFAULT_CONSENSUS_BOUNDS`).
    performance : {"tracking", "disagreement"}
        The performance output s: the speed errors v_i − v_d, or their
        deviations from the train's mean error.
    delay_certificate : float or None
        τ_max [s], > 0 (file key ``delay_certificate_s``): γ certified (and
        synthesised) for every constant delay in [0, τ_max] of the data the
        law acts on, by the Lyapunov–Krasovskii H∞ LMI; None: delay-free
        (the bounded-real lemma).
    force_scale : float
        [m/s²], 1e-6 to 1e3 (file key ``force_scale_m_s2``): the force disturbance per
        unit mass taken as one unit of each force channel.
    noise_scale : float
        [m/s], 1e-6 to 300 (file key ``noise_scale_m_s``): the speed noise taken as
        one unit of each reference and link channel.
    output_scale : float
        [m/s], 1e-6 to 300 (file key ``output_scale_m_s``): the speed error taken as
        one unit of the performance output. γ = ‖T_w̃s̃‖∞ on the scaled
        channels; whether γ <= 1 depends entirely on these three.
    synthesis_grid : int
        Grid points per gain of the search, >= 1.
    synthesis_evaluations : int
        SDP solves of the local refinement after the grid, >= 0 (0: the grid
        alone).

    Examples
    --------
    >>> s = HinfSettings()
    >>> s.kappa_p, s.kappa_c, s.control_interval, s.own_speed, s.input_bounds
    (0.1, 0.1, None, 'delayed', True)
    >>> s.synthesise, s.kappa_p_bounds, s.performance, s.delay_certificate, s.output_scale
    (False, (0.01, 0.2), 'tracking', None, 1.0)
    >>> HinfSettings(kappa_c_bounds=(0.3, 0.1))
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: HinfSettings: 'kappa_c_bounds' must be [lo, hi] with lo \
<= hi (got [0.3, 0.1]).
    >>> HinfSettings(own_speed="now")
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: HinfSettings: 'own_speed' must be one of ('delayed', \
'current') (got 'now').
    """

    family: ClassVar[str] = "hinf"

    kappa_p: Annotated[float, _PINNING_GAIN, Key(
        "Pinning gain κ_p on the reference term −κ_p b_i (v_i − v̂_d)",
        file="kappa_p_per_s", unit="1/s")] = DEFAULT_PINNING_GAIN
    kappa_c: Annotated[float, _CONSENSUS_GAIN, Key(
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
    line_feedforward: Annotated[bool, Flag(), Key(
        "Each vehicle feeds the grade and curve resistance under itself forward (false: the "
        "law rejects the grade as a disturbance)")] = True
    synthesise: Annotated[bool, Flag(), Key(
        "Synthesise κ_p and κ_c within the bounds for the smallest certified H∞ gain γ "
        "(false: kappa_p_per_s and kappa_c_per_s)")] = False
    kappa_p_bounds: Annotated[tuple[float, ...], Array(_PINNING_GAIN, length=2), Key(
        "[lo, hi] searched for κ_p when synthesise = true, lo <= hi",
        file="kappa_p_bounds_per_s", unit="1/s")] = DEFAULT_PINNING_BOUNDS
    kappa_c_bounds: Annotated[tuple[float, ...], Array(_CONSENSUS_GAIN, length=2), Key(
        "[lo, hi] searched for κ_c when synthesise = true, lo <= hi",
        file="kappa_c_bounds_per_s", unit="1/s")] = DEFAULT_CONSENSUS_BOUNDS
    performance: Annotated[str, Choice(PERFORMANCES), Key(
        "Performance output of γ: 'tracking' (the speed errors v_i − v_d) or 'disagreement' "
        "(their deviations from the mean error)")] = "tracking"
    delay_certificate: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "γ certified (and synthesised) for every constant delay in [0, τ_max] of the law's "
        "data (Lyapunov–Krasovskii LMI)", file="delay_certificate_s", unit="s",
        omitted="the delay-free γ (bounded-real lemma)")] = None
    force_scale: Annotated[float, _FORCE_SCALE, Key(
        "Force disturbance per unit mass taken as one unit of each force channel of γ",
        file="force_scale_m_s2", unit="m/s²")] = 1.0
    noise_scale: Annotated[float, _SPEED_SCALE, Key(
        "Speed noise taken as one unit of each reference and link noise channel of γ",
        file="noise_scale_m_s", unit="m/s")] = 1.0
    output_scale: Annotated[float, _SPEED_SCALE, Key(
        "Speed error taken as one unit of the performance output of γ",
        file="output_scale_m_s", unit="m/s")] = 1.0
    synthesis_grid: Annotated[int, Integer(ge=1), Key(
        "Grid points per gain of the synthesis")] = DEFAULT_SYNTHESIS_GRID
    synthesis_evaluations: Annotated[int, Integer(ge=0), Key(
        "SDP solves of the local refinement after the grid (0: the grid alone)")
    ] = DEFAULT_SYNTHESIS_EVALUATIONS

    @model_validator(mode="after")
    def _cross_field_rules(self) -> HinfSettings:
        for name in ("kappa_p_bounds", "kappa_c_bounds"):
            lo, hi = getattr(self, name)
            if lo > hi:
                raise_at((name,), Violation(text="must be [lo, hi] with lo <= hi",
                                            got_text=f"[{lo!r}, {hi!r}]"), (lo, hi))
        return self

    def scaling(self) -> dict[str, float]:
        """The unit of each disturbance group: force [m/s²], reference and link noise [m/s].

        Returns
        -------
        dict of str to float
            ``"force"``: ``force_scale`` [m/s²]; ``"reference"`` and
            ``"link"``: ``noise_scale`` [m/s] (the ``scaling`` of
            :func:`~trainctl.controllers.hinf.synthesis.consensus_loop`).

        Examples
        --------
        >>> HinfSettings(noise_scale=0.5).scaling()
        {'force': 1.0, 'reference': 0.5, 'link': 0.5}
        """
        return {"force": float(self.force_scale), "reference": float(self.noise_scale),
                "link": float(self.noise_scale)}
