# Solver statuses mapped to step statuses, in one place.
"""Map cvxpy and OSQP solver statuses to trainctl step statuses."""

from __future__ import annotations

__all__ = ["from_cvxpy", "from_daqp", "from_osqp", "is_usable"]

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

# OSQP >= 1.0 (the version pyproject requires) numbers its statuses from 1
# (``osqp.SolverStatus``); the names are the contract, the numbers are read
# from the enum at import so a renumbering cannot silently remap them.
_OSQP_BY_NAME = {
    "OSQP_SOLVED": "optimal",
    "OSQP_SOLVED_INACCURATE": "optimal_inaccurate",
    "OSQP_PRIMAL_INFEASIBLE": "infeasible",
    "OSQP_PRIMAL_INFEASIBLE_INACCURATE": "infeasible",
    "OSQP_DUAL_INFEASIBLE": "error",            # unbounded: a modelling error
    "OSQP_DUAL_INFEASIBLE_INACCURATE": "error",
    "OSQP_MAX_ITER_REACHED": "max_iterations",
    "OSQP_TIME_LIMIT_REACHED": "max_iterations",
    "OSQP_NON_CVX": "error",
    "OSQP_SIGINT": "error",                     # interrupted (re-raised by fastqp)
    "OSQP_UNSOLVED": "error",
}


def _osqp_codes() -> dict[int, str]:
    from osqp import SolverStatus  # OSQP >= 1.0

    return {int(member.value): _OSQP_BY_NAME.get(member.name, "error")
            for member in SolverStatus}


_OSQP = _osqp_codes()

# DAQP's exit flags (daqp's constants.h; the Python module does not export them).
_DAQP = {
    2: "optimal",          # EXIT_SOFT_OPTIMAL: optimal, some soft constraint violated
    1: "optimal",          # EXIT_OPTIMAL
    -1: "infeasible",      # EXIT_INFEASIBLE
    -2: "error",           # EXIT_CYCLE: the active-set iteration cycled
    -3: "error",           # EXIT_UNBOUNDED: a modelling error
    -4: "max_iterations",  # EXIT_ITERLIMIT
    -5: "error",           # EXIT_NONCONVEX
    -6: "error",           # EXIT_OVERDETERMINED_INITIAL: bad warm-start working set
    -7: "max_iterations",  # EXIT_TIMELIMIT
    -8: "error",           # EXIT_UNSUPPORTED
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
    >>> from_osqp(1), from_osqp(3), from_osqp(7)
    ('optimal', 'infeasible', 'max_iterations')
    """
    return _OSQP.get(int(status_val), "error")


def from_daqp(exitflag: int) -> str:
    """Step status for a DAQP exit flag.

    Parameters
    ----------
    exitflag : int
        DAQP's ``exitflag`` (> 0 success, < 0 failure).

    Returns
    -------
    str
        One of :data:`trainctl.controllers.base.STATUSES` (unknown flags: ``"error"``).

    Examples
    --------
    >>> from_daqp(1), from_daqp(2), from_daqp(-1), from_daqp(-4), from_daqp(-3)
    ('optimal', 'optimal', 'infeasible', 'max_iterations', 'error')
    """
    return _DAQP.get(int(exitflag), "error")


def is_usable(status: str) -> bool:
    """True when a solution with this status may be applied (optimal or inaccurate).

    Parameters
    ----------
    status : str
        A solver status as trainctl names it.

    Returns
    -------
    bool
        Whether the solution may drive the train.

    Examples
    --------
    >>> [is_usable(s) for s in ("optimal", "optimal_inaccurate", "max_iterations", "infeasible")]
    [True, True, False, False]
    """
    return status in ("optimal", "optimal_inaccurate")
