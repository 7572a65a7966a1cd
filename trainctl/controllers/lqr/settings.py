# Settings of the LQR family: the schema of its [controller] table (no solver imports).
"""The LQR family's settings, declared once (:mod:`trainctl.declare.keys`).

The outputs and weights are the same keys, with the same rules, as the MPC
family's (:mod:`trainctl.controllers.tracking`).
"""

from __future__ import annotations

from typing import Annotated, ClassVar

from pydantic import model_validator

from trainctl.controllers.tracking import (
    InputWeight,
    InputWeightUnit,
    Outputs,
    QForce,
    QVelocity,
    check_force_weight,
    per_kn2,
)
from trainctl.declare.constraints import Flag
from trainctl.declare.keys import Key, settings

__all__ = ["LQRSettings"]


@settings
class LQRSettings:
    """A discrete LQR design of the train, centralised or per coach.

    Each field is declared once, with its ``[controller]`` key (``family =
    "lqr"``, or a ``[controller.lqr]`` sub-table); invalid values raise
    :class:`~trainctl.exceptions.ModelError`.

    Parameters
    ----------
    outputs : tuple of {"v", "force"}
        Weighted outputs in this order, distinct, non-empty: ``"v"`` the
        velocities [m/s], ``"force"`` the coupler forces [kN].
    q_velocity : float
        Weight on the velocity tracking error [per (m/s)^2], >= 0.
    q_force : float
        Weight on the coupler-force deviation [per kN^2], >= 0; > 0 needs
        ``"force"`` in ``outputs``.
    input_weight : float
        Input weight R as given, in ``input_weight_unit`` [per kN^2 or per
        N^2], > 0.
    input_weight_unit : {"kN", "N"}
        The force unit the user chose for R.
    input_bounds : bool
        Saturate the plant input to the traction/braking envelope.

    Examples
    --------
    >>> lqr = LQRSettings(input_weight=1e-5, input_weight_unit="N")
    >>> lqr.outputs, lqr.input_weight_per_kn2(), lqr.input_bounds
    (('v',), 10.0, True)
    """

    family: ClassVar[str] = "lqr"

    outputs: Outputs = ("v",)
    q_velocity: QVelocity = 1.0
    q_force: QForce = 0.0
    input_weight: InputWeight
    input_weight_unit: InputWeightUnit = "kN"
    input_bounds: Annotated[bool, Flag(), Key(
        "Saturate the plant input to the traction/braking envelope")] = True

    @model_validator(mode="after")
    def _cross_field_rules(self) -> LQRSettings:
        check_force_weight(self.outputs, self.q_force)
        return self

    def input_weight_per_kn2(self) -> float:
        """The input weight R converted to per kN^2 (the design unit).

        Returns
        -------
        float
            ``input_weight`` [per kN^2]; a weight given per N^2 is multiplied
            by 1e6.

        Examples
        --------
        >>> LQRSettings(input_weight=2.0).input_weight_per_kn2()
        2.0
        """
        return per_kn2(self.input_weight, self.input_weight_unit)
