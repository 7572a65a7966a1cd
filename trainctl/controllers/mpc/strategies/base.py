# What every MPC strategy shares: the protocol, the plan result and the block solves.
"""The strategy protocol and its plan result, and the block solves every strategy
uses (:func:`solve_block`, one solve per block or relaxed Jacobi iterations).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.faults import call_solver
from trainctl.controllers.mpc.condensed import BlockParameters, QPBlock
from trainctl.controllers.mpc.qp.fast import QPSolution
from trainctl.controllers.mpc.qp.status import is_usable
from trainctl.controllers.mpc.theory.mpc import MPCDesign

__all__ = ["PlanResult", "Strategy", "solve_block"]

Array = NDArray[np.float64]
FallbackPlan = Callable[[QPBlock], Array]
"""``fallback(block) -> z``: the block's moves when its solve failed."""

FALLBACK = "shifted plan"
"""Fallback recorded when a block's solve gave no usable solution."""


@dataclass(frozen=True)
class PlanResult:
    """The plan of one step and how it was reached.

    Parameters
    ----------
    plan : ndarray
        The decision vector U.
    status : str
        The step status: the worst block status (:func:`worst_status`), also
        after a fallback.
    iterations : int
        Iterations (1 for the single-solve strategies).
    residuals : list of float
        Largest change of the plan per iteration [kN].
    fallback : str
        The fallback applied ("" when none).
    reason : str
        Why a solve failed when it raised (the first such solve's exception), else "".

    Examples
    --------
    >>> result = PlanResult(np.array([0.5, -0.5]), "optimal", 3, [0.4, 0.05, 0.001], "")
    >>> result.iterations, result.residuals[-1], result.fallback  # last change [kN]
    (3, 0.001, '')
    """

    plan: Array
    status: str
    iterations: int
    residuals: list[float]
    fallback: str
    reason: str = ""


class Blocks(Protocol):
    """What a strategy needs of the problem: its blocks and how to solve them."""

    blocks: list[QPBlock]
    path: str
    residual_cols: NDArray[np.int64] | None


class Strategy(Protocol):
    """The protocol of the four strategies.

    Examples
    --------
    Each strategy built by :func:`make_strategy` has the protocol's members:

    >>> from trainctl.controllers.mpc.strategies.coordinators import make_strategy
    >>> ndmpc = make_strategy("ndmpc", max_iterations=10, tolerance=1e-3, relaxation=0.5,
    ...                       weights=np.full(2, 0.5))
    >>> ndmpc.name, [hasattr(ndmpc, m) for m in ("block_inputs", "members", "couplers",
    ...                                          "vehicles", "plan")]
    ('ndmpc', [True, True, True, True, True])
    """

    name: str

    def block_inputs(self, n: int) -> list[tuple[int, ...]]:
        """The inputs each block decides for.

        Parameters
        ----------
        n : int
            Number of inputs (coaches), >= 1.

        Returns
        -------
        list of tuple of int
            The input indices of each block, one tuple per block.
        """
        ...

    def members(self, inputs: tuple[int, ...], design: MPCDesign) -> tuple[int, ...]:
        """The coaches whose outputs a block's cost counts.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        design : MPCDesign
            The design (its number of inputs and its neighbourhoods).

        Returns
        -------
        tuple of int
            The coaches (0-based) whose outputs enter the block's cost.
        """
        ...

    def couplers(self, inputs: tuple[int, ...], n_couplers: int) -> list[int]:
        """The couplers whose force rows a block bounds.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        n_couplers : int
            Number of couplers of the train; coupler c joins coaches c and c+1.

        Returns
        -------
        list of int
            The coupler indices (0-based) whose force the block's soft rows bound.
        """
        ...

    def vehicles(self, inputs: tuple[int, ...], n: int) -> list[int]:
        """The vehicles whose speed rows a block bounds (under speed limits).

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        n : int
            Number of vehicles (= inputs) of the train.

        Returns
        -------
        list of int
            The vehicle indices (0-based) whose predicted speed the block's soft rows bound.
        """
        ...

    def plan(self, problem: Blocks, params: Sequence[BlockParameters], plan0: Array,
             fallback: FallbackPlan) -> PlanResult:
        """Solve the blocks and combine their solutions into the plan.

        Parameters
        ----------
        problem : Blocks
            The problem: its QP blocks, solve path and residual columns.
        params : sequence of BlockParameters
            This step's parameters of each block, in the order of ``problem.blocks``.
        plan0 : ndarray, shape (M·n,)
            The starting plan (the shifted previous plan) [kN].
        fallback : callable
            ``fallback(block) -> z``: the block's moves [kN] when its solve
            gives no usable solution.

        Returns
        -------
        PlanResult
            The plan U [kN], the step status, the iterations, the residuals and the fallback
            applied.
        """
        ...


class _PerCoach:
    """One block per coach bounding the couplers next to it and its own speed."""

    def block_inputs(self, n: int) -> list[tuple[int, ...]]:
        return [(i,) for i in range(n)]

    def couplers(self, inputs: tuple[int, ...], n_couplers: int) -> list[int]:
        return sorted({c for i in inputs for c in (i - 1, i) if 0 <= c < n_couplers})

    def vehicles(self, inputs: tuple[int, ...], n: int) -> list[int]:
        return sorted(inputs)


def solve_once(problem: Blocks, params: Sequence[BlockParameters], plan0: Array,
               fallback: FallbackPlan) -> PlanResult:
    """Solve every block once with the other blocks' plans at zero (u form: their
    feedforward; Δu form: their previous input held)."""
    U = np.zeros(plan0.shape)
    statuses, applied, reason = [], "", ""
    for block, prep in zip(problem.blocks, params, strict=True):
        sol, why = solve_block(block, prep, None, problem.path)
        reason = reason or why
        z, status = sol.z, sol.status
        if not is_usable(status):
            z, applied = fallback(block), FALLBACK
        U[block.cols] = z
        statuses.append(status)
    return PlanResult(U, worst_status(statuses, applied), 1, [], applied, reason)


def jacobi(problem: Blocks, params: Sequence[BlockParameters], plan0: Array,
           fallback: FallbackPlan, *, weights: Sequence[float], max_iterations: int,
           tolerance: float) -> PlanResult:
    """Weighted Jacobi iterations U ← (1 - w_i) U_i + w_i z_i from ``plan0``.

    Stops when the largest change of the blocks' moves is at most ``tolerance``.
    """
    U = plan0.copy()
    residuals: list[float] = []
    statuses, applied, reason = [], "", ""
    converged = False
    cols = problem.residual_cols
    for _ in range(max_iterations):
        new = U.copy()
        for block, prep, w in zip(problem.blocks, params, weights, strict=True):
            sol, why = solve_block(block, prep, U, problem.path)
            reason = reason or why
            z, status = sol.z, sol.status
            if not is_usable(status):
                z, applied = fallback(block), FALLBACK
            statuses.append(status)
            if w == 1.0:
                new[block.cols] = z  # = 1·z + 0·U (up to the sign of a zero)
            else:
                new[block.cols] = w * z + (1 - w) * U[block.cols]
        # Largest change of any block's moves (the blocks' columns, usually all of U).
        step = new - U if cols is None else new[cols] - U[cols]
        change = float(np.maximum.reduce(np.abs(step)))
        residuals.append(change)
        U = new
        if change <= tolerance:
            converged = True
            break
    status = worst_status(statuses, applied)
    if not converged and status == "optimal":
        status = "max_iterations"
    return PlanResult(U, status, len(residuals), residuals, applied, reason)


def solve_block(block: QPBlock, prep: BlockParameters, U: Array | None,
                path: str) -> tuple[QPSolution, str]:
    """One block's solve at the solver boundary: an exception becomes the status ``"error"``.

    Every strategy solves its blocks through this function
    (:func:`~trainctl.controllers.faults.call_solver` around
    :meth:`QPBlock.solve`), so a solver that raises fails the step like an
    infeasible QP: the strategy applies its fallback and the run goes on.

    Parameters
    ----------
    block : QPBlock
        The block.
    prep : BlockParameters
        Its parameters of this step.
    U : ndarray or None
        The whole plan the block's data depend on (None: zero).
    path : {"fast", "cvxpy"}
        Solve path.

    Returns
    -------
    (QPSolution, str)
        The solution and ""; or, when the solve raised, a solution of NaN
        with status ``"error"`` and the reason.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> def broken(prep, U, path):
    ...     raise RuntimeError("workspace lost")
    >>> sol, reason = solve_block(SimpleNamespace(solve=broken, cols=np.arange(2)), None,
    ...                           None, "fast")
    >>> sol.status, sol.z.tolist(), reason
    ('error', [nan, nan], 'the solver raised RuntimeError: workspace lost')
    """
    sol, reason = call_solver(block.solve, prep, U, path)
    if sol is None:
        return QPSolution(np.full(block.cols.size, np.nan), np.zeros(0), "error", 0, 0.0), reason
    return sol, ""


def worst_status(statuses: list[str], fallback: str) -> str:
    """The step status: the worst of the blocks' solver outcomes.

    The order is error, infeasible, max_iterations, optimal_inaccurate,
    optimal. ``fallback`` (the fallback applied, "" when none) does not
    change it: the step records the solver's outcome beside the fallback.
    A fallback without a failed solve cannot happen; it is recorded as
    ``"error"``.

    Examples
    --------
    >>> worst_status(["optimal", "infeasible", "max_iterations"], "shifted plan")
    'infeasible'
    >>> worst_status(["optimal", "optimal_inaccurate"], "")
    'optimal_inaccurate'
    """
    for status in ("error", "infeasible", "max_iterations", "optimal_inaccurate"):
        if status in statuses:
            return status
    return "error" if fallback else "optimal"
