# Settings of the potential family: the schema of its [controller] table (no solver imports).
"""The potential family's settings, declared once (:mod:`trainctl.declare.keys`).

Zhao & Wang's four-term law (spec §2.2): position pinning, speed feedback,
velocity consensus over the ``[communication]`` graph and the gradient of a
pair potential on the spacing deviation between physically coupled cars.
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import model_validator

from trainctl.declare.constraints import Choice, Flag, Number, Violation, raise_at
from trainctl.declare.keys import Key, settings

__all__ = ["POTENTIALS", "PotentialSettings"]

POTENTIALS = ("quadratic", "barrier", "sigma")
"""Pair potentials: (P1) quadratic, (P2) logarithmic barrier, (P3) Olfati-Saber sigma-norm."""


@settings
class PotentialSettings:
    """Zhao & Wang's potential-function consensus law for the cars of one train.

    Each field is declared once, with its ``[controller]`` key (``family =
    "potential"``, or a ``[controller.potential]`` sub-table); invalid values
    raise :class:`~trainctl.exceptions.ModelError`.

    Parameters
    ----------
    potential : {"quadratic", "barrier", "sigma"}
        The pair potential U(z) on the spacing deviation z [m] (file key
        ``pair_potential``: a key ``potential`` would name the family's
        sub-table).
    kappa : float
        Curvature of U at z = 0 [1/s²], > 0 (file key ``kappa_per_s2``): the
        virtual spring per unit mass of every potential.
    barrier : float or None
        Half-width Δ of the barrier's admissible band [m], > 0 (file key
        ``barrier_m``); only and always with ``potential = "barrier"``.
    position_gain : float
        d_d [-], >= 0: car i is pinned to its reference position by the
        virtual stiffness ``k · position_gain · p_i`` (k the mean coupler
        stiffness [N/m], p_i the ``[communication]`` pinning weight); 0 = no
        position pinning.
    speed_gain : float
        δ_i·d_vi [1/s], >= 0 (file key ``speed_gain_per_s``), the same for
        every car.
    consensus_gain : float
        Weight of the velocity consensus [1/s], >= 0 (file key
        ``consensus_gain_per_s``), times the graph's adjacency a_vij.
    control_interval : float or None
        T_c [s], > 0: the continuous-time law is sampled (zero-order hold)
        at this interval in simulation; None: ``[model].sample_time``. The
        simulation's duration must be a whole multiple of it.
    spacing_limit : float
        Admissible |spacing deviation| of a coupler [m], > 0 (file key
        ``spacing_limit_m``), judged by ``potential_spacing_bound``.
    position_tolerance : float
        Admissible final offset from the reference position [m], > 0 (file
        key ``position_tolerance_m``), judged by ``potential_position``: the
        offset a law without position pinning leaves for ever.
    input_bounds : bool
        Saturate the inputs to the traction/braking envelope.

    Examples
    --------
    >>> s = PotentialSettings()
    >>> s.potential, s.kappa, s.position_gain, s.speed_gain, s.consensus_gain
    ('quadratic', 0.5, 0.1, 0.5, 1.0)
    >>> PotentialSettings(potential="barrier", barrier=0.2).barrier
    0.2
    """

    family: ClassVar[str] = "potential"

    potential: Annotated[str, Choice(POTENTIALS), Key(
        "Pair potential on the spacing deviation: quadratic (P1), barrier (P2) or sigma "
        "(P3, Olfati-Saber)", file="pair_potential")] = "quadratic"
    kappa: Annotated[float, Number(gt=0), Key(
        "Curvature of the pair potential at zero deviation (virtual spring per unit mass)",
        file="kappa_per_s2", unit="1/s²")] = 0.5
    barrier: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Half-width of the barrier potential's admissible band; only with pair_potential = "
        "'barrier'", file="barrier_m", unit="m", omitted="no barrier")] = None
    position_gain: Annotated[float, Number(ge=0), Key(
        "Position pinning d_d: virtual stiffness to the reference position in units of the "
        "coupler stiffness, times the [communication] pinning weight (0: none)")] = 0.1
    speed_gain: Annotated[float, Number(ge=0), Key(
        "Speed feedback δ·d_v of every car", file="speed_gain_per_s", unit="1/s")] = 0.5
    consensus_gain: Annotated[float, Number(ge=0), Key(
        "Velocity-consensus gain, times the [communication] adjacency",
        file="consensus_gain_per_s", unit="1/s")] = 1.0
    control_interval: Annotated[Annotated[float, Number(gt=0)] | None, Key(
        "Interval at which the continuous-time law is sampled in simulation", unit="s",
        omitted="[model].sample_time")] = None
    spacing_limit: Annotated[float, Number(gt=0), Key(
        "Admissible spacing deviation of a coupler (potential_spacing_bound)",
        file="spacing_limit_m", unit="m")] = 0.1
    position_tolerance: Annotated[float, Number(gt=0), Key(
        "Admissible final offset from the reference position (potential_position)",
        file="position_tolerance_m", unit="m")] = 1.0
    input_bounds: Annotated[bool, Flag(), Key(
        "Saturate the plant input to the traction/braking envelope")] = True

    @model_validator(mode="after")
    def _cross_field_rules(self) -> PotentialSettings:
        if self.potential == "barrier" and self.barrier is None:
            raise_at(("barrier",), Violation(
                text="must be given when {potential} = 'barrier'", got_text="none",
                hint=" The barrier's half-width Δ [m] bounds every spacing deviation.",
                value=False))
        if self.potential != "barrier" and self.barrier is not None:
            raise_at(("barrier",), Violation(
                text="is allowed only with {potential} = 'barrier'",
                got_text=f"potential {self.potential!r}", value=False))
        return self
