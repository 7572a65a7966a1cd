# Settings of the MPC family that are light to import: strategy names and constraints.
"""Names and settings of the MPC family (no solver imports)."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["STRATEGIES", "MPCConstraints"]

STRATEGIES = ("centralised", "decentralised", "ndmpc", "cooperative")
"""The MPC strategies."""

@dataclass(frozen=True, kw_only=True)
class MPCConstraints:
    """Constraint settings of an MPC controller.

    Parameters
    ----------
    input_bounds : bool
        Bound every coach's force by its traction/braking envelope (hard).
    rate_limit : float
        Largest change of a coach's force per sample [N] (hard); inf for none.
    coupler_force_limit : float
        Largest absolute coupler force |f| [N] (soft); inf for none.
    soft_linear : float
        Linear penalty per kN of coupler-force violation.
    soft_quadratic : float
        Quadratic penalty per kN² of violation.
    force_steps : tuple of int or None
        Prediction steps (1..P) at which the coupler forces are bounded; None
        for every step. Bounding a subset (e.g. the first few steps, then every
        fifth) shrinks each QP with little effect when the bound is far from active.
    """

    input_bounds: bool = True
    rate_limit: float = math.inf
    coupler_force_limit: float = math.inf
    soft_linear: float = 1e3
    soft_quadratic: float = 1e2
    force_steps: tuple[int, ...] | None = None
