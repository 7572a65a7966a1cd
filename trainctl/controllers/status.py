# Solver statuses mapped to step statuses, in one place.
"""Map cvxpy and OSQP solver statuses to trainctl step statuses."""

from __future__ import annotations

__all__ = ["from_cvxpy", "from_osqp", "is_usable"]

_CVXPY = {
    "optimal": "optimal",
    "optimal_inaccurate": "optimal_inaccurate",
    "infeasible": "infeasible",
    "infeasible_inaccurate": "infeasible",
    "unbounded": "error",
    "unbounded_inaccurate": "error",
    "user_limit": "max_iterations",
    "solver_error": "error",
}

_OSQP = {
    1: "optimal",               # solved
    2: "optimal_inaccurate",    # solved inaccurate
    -2: "max_iterations",       # maximum iterations reached
    -3: "infeasible",           # primal infeasible
    3: "infeasible",            # primal infeasible inaccurate
    -4: "error",                # dual infeasible (unbounded)
    4: "error",                 # dual infeasible inaccurate
    -6: "max_iterations",       # time limit reached
    -5: "error",                # interrupted
    -7: "error",                # non-convex
    -10: "error",               # unsolved
}


def from_cvxpy(status: str | None) -> str:
    """Step status for a cvxpy ``Problem.status`` string.

    Parameters
    ----------
    status : str or None
        cvxpy status (``cp.OPTIMAL`` ...); None when no solve happened.

    Returns
    -------
    str
        One of :data:`trainctl.controllers.base.STATUSES`.

    Examples
    --------
    >>> from_cvxpy("optimal_inaccurate")
    'optimal_inaccurate'
    """
    return _CVXPY.get(status or "", "error")


def from_osqp(status_val: int) -> str:
    """Step status for an OSQP ``info.status_val`` code.

    Parameters
    ----------
    status_val : int
        OSQP status code.

    Returns
    -------
    str
        One of :data:`trainctl.controllers.base.STATUSES`.

    Examples
    --------
    >>> from_osqp(1), from_osqp(-3)
    ('optimal', 'infeasible')
    """
    return _OSQP.get(int(status_val), "error")


def is_usable(status: str) -> bool:
    """True when a solution with this status may be applied (optimal or inaccurate)."""
    return status in ("optimal", "optimal_inaccurate")
