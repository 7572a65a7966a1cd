# Settings keys shared by the tracking controllers: controlled outputs and quadratic weights.
"""Declarations shared by the settings of every tracking-controller family.

The MPC and LQR families weigh the same outputs with the same kind of
quadratic weights: velocity errors [per (m/s)²], coupler-force deviations
[per kN²] and the input force [per kN² or per N²]. Each key is declared here
once (:mod:`trainctl.declare.keys`) and used by both settings classes, together
with the rules that span several of them.

Examples
--------
>>> per_kn2(2e-6, "N")
2.0
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Annotated

from trainctl.declare.constraints import Choice, NameList, Number, Violation, raise_at
from trainctl.declare.keys import Alt, Key

__all__ = [
    "CONTROLLER_OUTPUTS",
    "INPUT_WEIGHT_UNITS",
    "InputWeight",
    "InputWeightUnit",
    "Outputs",
    "QForce",
    "QVelocity",
    "check_force_weight",
    "check_outputs_fit",
    "per_kn2",
]

CONTROLLER_OUTPUTS = ("v", "force")
"""Controlled outputs: the velocities [m/s] and the coupler forces [kN]."""

INPUT_WEIGHT_UNITS = ("kN", "N")
"""Force units in which an input weight may be given (per kN² or per N²)."""

_N2_PER_KN2 = 1e6
"""A weight per N² times this is the same weight per kN²."""

Outputs = Annotated[
    tuple[str, ...],
    NameList(
        CONTROLLER_OUTPUTS,
        noun="output",
        hint=" 'v' selects the velocities [m/s], 'force' the coupler forces [kN].",
    ),
    Key("Controlled outputs, in this order: 'v' velocities [m/s], 'force' coupler forces [kN]"),
]
QVelocity = Annotated[
    float, Number(ge=0), Key("Weight on the velocity tracking error", unit="per (m/s)²")
]
QForce = Annotated[
    float,
    Number(ge=0),
    Key("Weight on the coupler-force deviation; > 0 needs 'force' in outputs",
        file="q_force_per_kn2", unit="per kN²"),
]
InputWeight = Annotated[
    float,
    Number(gt=0),
    Key(
        "Input weight R",
        one_of=(
            Alt("r_per_kn2", unit="per kN²", sets={"input_weight_unit": "kN"}),
            Alt("r_per_n2", unit="per N²", sets={"input_weight_unit": "N"},
                si_text="= r_per_kn2 / 1e6"),
        ),
        hint=" The input weight R is per kN² (r_per_kn2) or per N² (r_per_n2); "
        "r_per_kn2 = r_per_n2 × 1e6.",
    ),
]
InputWeightUnit = Annotated[
    str,
    Choice(INPUT_WEIGHT_UNITS),
    Key("The force unit of R as given (set by r_per_kn2 or r_per_n2)", file=""),
]


def per_kn2(weight: float, unit: str) -> float:
    """An input weight given per square ``unit``, as a weight per kN² (the design unit).

    Parameters
    ----------
    weight : float
        The weight as given.
    unit : {"kN", "N"}
        The force unit it is given in.

    Returns
    -------
    float
        The weight per kN².

    Examples
    --------
    1 kN² = 10⁶ N², so a weight of 2e-6 per N² is 2 per kN²:

    >>> per_kn2(2e-6, "N"), per_kn2(0.5, "kN")
    (2.0, 0.5)
    """
    return weight * _N2_PER_KN2 if unit == "N" else weight


def check_force_weight(outputs: Sequence[str], q_force: float) -> None:
    """A coupler-force weight needs the coupler forces among the outputs.

    Parameters
    ----------
    outputs : sequence of str
        The design's outputs (``"v"``, ``"force"``).
    q_force : float
        The coupler-force weight.

    Raises
    ------
    pydantic.ValidationError
        At ``q_force`` when it is > 0 and ``"force"`` is not in ``outputs``.

    Examples
    --------
    >>> check_force_weight(("v", "force"), 1.0)  # weighted and controlled: fine
    >>> try:
    ...     check_force_weight(("v",), 1.0)
    ... except ValueError as exc:
    ...     print(type(exc).__name__, exc.errors()[0]["loc"])
    ValidationError ('q_force',)
    """
    if q_force > 0 and "force" not in outputs:
        raise_at(("q_force",), Violation(
            text="must be 0 when {outputs} has no 'force'",
            got_text=f"{q_force!r} with outputs {list(outputs)}",
            hint=' Add "force" to outputs to weight the coupler forces, or omit '
            "q_force_per_kn2.",
        ), q_force)


def check_outputs_fit(outputs: Sequence[str], n: int | None) -> None:
    """A train of one vehicle has no couplers, hence no force output.

    Parameters
    ----------
    outputs : sequence of str
        The design's outputs.
    n : int or None
        Number of vehicles (None: not known yet, nothing checked).

    Raises
    ------
    pydantic.ValidationError
        At the ``"force"`` item of ``outputs`` when ``n`` is 1.

    Examples
    --------
    >>> check_outputs_fit(("v", "force"), 2)  # two vehicles, one coupler: fine
    >>> try:
    ...     check_outputs_fit(("v", "force"), 1)
    ... except ValueError as exc:
    ...     print(type(exc).__name__, exc.errors()[0]["loc"])
    ValidationError ('outputs', 1)
    """
    if n is not None and n < 2 and "force" in outputs:
        raise_at(("outputs", list(outputs).index("force")), Violation(
            text="must be 'v' for a train of one vehicle, which has no couplers",
            got="force",
            hint=" Remove 'force', or give the train at least two vehicles.",
        ), "force")
