# The MPC strategies as small coordinators of the QP blocks.
"""How the train MPC splits its plan among optimisers and combines their answers.

A strategy says which inputs each optimiser (QP block) decides for, whose
outputs its cost counts, which coupler-force rows it bounds, and how the
blocks' solutions become one plan:

``Centralised``
    One block over every coach's moves and the whole-train cost.
``Decentralised``
    One block per coach over its own outputs, the other coaches' plans at
    zero (their feedforward in the u form, their previous input in the Δu
    form; one solve each, no exchange).
``NDMPC``
    One block per coach over its neighbourhood's cost, the others' plans
    fixed at the previous iterate; relaxed Jacobi iterations from the shifted
    previous plan until every change is below the tolerance.
``Cooperative``
    One block per coach over the whole-train cost; the new plan is the
    convex combination Σ_i w_i (plan with block i replaced).
``LocalNDMPC`` (:mod:`.local`)
    N-DMPC on the neighbourhood models only: one block per coach whose data
    depend on the neighbours' plans and the exchanged predicted trajectories.

A block whose solve gives no usable solution takes the fallback plan it is
given (the shifted previous plan, clipped to the rate limit and the
envelope); the step keeps the solver's own outcome as its status
(``"infeasible"``, ``"max_iterations"``, ``"error"``) and names the fallback
(``"shifted plan"``). A solve that raises is such a solve: :func:`solve_block`
calls every block's QP through :func:`~trainctl.controllers.faults.call_solver`,
so the exception becomes the status ``"error"`` and its message the plan's
``reason``.
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

__all__ = ["Centralised", "Cooperative", "Decentralised", "NDMPC", "PlanResult", "Strategy",
           "make_strategy", "solve_block"]

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

    >>> ndmpc = make_strategy("ndmpc", max_iterations=10, tolerance=1e-3, relaxation=0.5,
    ...                       weights=np.full(2, 0.5))
    >>> ndmpc.name, [hasattr(ndmpc, m) for m in ("block_inputs", "members", "couplers", "plan")]
    ('ndmpc', [True, True, True, True])
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
    """One block per coach bounding the couplers next to it."""

    def block_inputs(self, n: int) -> list[tuple[int, ...]]:
        return [(i,) for i in range(n)]

    def couplers(self, inputs: tuple[int, ...], n_couplers: int) -> list[int]:
        return sorted({c for i in inputs for c in (i - 1, i) if 0 <= c < n_couplers})


class Centralised:
    """One QP over every coach's moves and the whole-train cost.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> strategy = Centralised()
    >>> strategy.block_inputs(3), strategy.couplers((0, 1, 2), 2)
    ([(0, 1, 2)], [0, 1])
    >>> strategy.members((0, 1, 2), SimpleNamespace(n_inputs=3))
    (0, 1, 2)

    Its plan is one solve of the single block: here min ½‖U‖² + gᵀU with
    g = (-2, 1) in the box |U| <= 0.5, whose solution clips -g to (0.5, -0.5).

    >>> from trainctl.controllers.mpc.qp.parametric import ParametricQP
    >>> from trainctl.controllers.mpc.condensed import block_parameters, build_block
    >>> qp = ParametricQP(np.eye(2), np.eye(2), np.zeros((0, 2)), name="demo")
    >>> params = {"g": np.arange(2), "lb": np.arange(2, 4), "ub": np.arange(4, 6),
    ...           "hl": np.arange(0), "hu": np.arange(0)}
    >>> block = build_block(qp, inputs=(0, 1), cols=np.arange(2), Kc=np.eye(2), params=params)
    >>> prep = block_parameters([block], np.array([-2.0, 1.0, -0.5, -0.5, 0.5, 0.5]), True)
    >>> problem = SimpleNamespace(blocks=[block], path="fast", residual_cols=None)
    >>> result = strategy.plan(problem, prep, np.zeros(2), fallback=None)
    >>> result.status, result.iterations, result.plan.round(6).tolist()
    ('optimal', 1, [0.5, -0.5])
    """

    name = "centralised"

    def block_inputs(self, n: int) -> list[tuple[int, ...]]:
        """One block deciding for every input.

        Parameters
        ----------
        n : int
            Number of inputs (coaches), >= 1.

        Returns
        -------
        list of tuple of int
            ``[(0, 1, ..., n-1)]``.
        """
        return [tuple(range(n))]

    def members(self, inputs: tuple[int, ...], design: MPCDesign) -> tuple[int, ...]:
        """Every coach: the block's cost is the whole train's.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        design : MPCDesign
            The design (its number of inputs n).

        Returns
        -------
        tuple of int
            ``(0, 1, ..., n-1)``.
        """
        return tuple(range(design.n_inputs))

    def couplers(self, inputs: tuple[int, ...], n_couplers: int) -> list[int]:
        """Every coupler.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        n_couplers : int
            Number of couplers of the train; coupler c joins coaches c and c+1.

        Returns
        -------
        list of int
            ``[0, 1, ..., n_couplers-1]``.
        """
        return list(range(n_couplers))

    def plan(self, problem: Blocks, params: Sequence[BlockParameters], plan0: Array,
             fallback: FallbackPlan) -> PlanResult:
        """One solve of the single block gives the plan.

        Parameters
        ----------
        problem : Blocks
            The problem: its QP blocks, solve path and residual columns.
        params : sequence of BlockParameters
            This step's parameters of each block, in the order of ``problem.blocks``.
        plan0 : ndarray, shape (M·n,)
            The starting plan (the shifted previous plan) [kN]; only its shape is used.
        fallback : callable
            ``fallback(block) -> z``: the block's moves [kN] when its solve
            gives no usable solution.

        Returns
        -------
        PlanResult
            The block's solution as the plan [kN] (its fallback where the solve failed), one
            iteration, no residuals.
        """
        return solve_once(problem, params, plan0, fallback)


class Decentralised(_PerCoach):
    """Each coach over its own outputs; the others' plans at zero (feedforward in u form).

    Examples
    --------
    One block per coach, bounding the couplers in front of and behind it:

    >>> strategy = Decentralised()
    >>> strategy.block_inputs(3), strategy.members((1,), None)
    ([(0,), (1,), (2,)], (1,))
    >>> [strategy.couplers((i,), 2) for i in range(3)]
    [[0], [0, 1], [1]]
    """

    name = "decentralised"

    def members(self, inputs: tuple[int, ...], design: MPCDesign) -> tuple[int, ...]:
        """The block's own coach only.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        design : MPCDesign
            The design (unused).

        Returns
        -------
        tuple of int
            ``inputs`` itself.
        """
        return inputs

    def plan(self, problem: Blocks, params: Sequence[BlockParameters], plan0: Array,
             fallback: FallbackPlan) -> PlanResult:
        """One solve per block, the others' plans at zero (u: feedforward; Δu: held).

        Parameters
        ----------
        problem : Blocks
            The problem: its QP blocks, solve path and residual columns.
        params : sequence of BlockParameters
            This step's parameters of each block, in the order of ``problem.blocks``.
        plan0 : ndarray, shape (M·n,)
            The starting plan (the shifted previous plan) [kN]; only its shape is used.
        fallback : callable
            ``fallback(block) -> z``: the block's moves [kN] when its solve
            gives no usable solution.

        Returns
        -------
        PlanResult
            Each block's solution in its columns of the plan [kN] (its fallback where the solve
            failed), one iteration, no residuals.
        """
        return solve_once(problem, params, plan0, fallback)


@dataclass(frozen=True)
class NDMPC(_PerCoach):
    """Neighbourhood optimisation, relaxed Jacobi iterations (relaxation ω in (0, 1]).

    Parameters
    ----------
    max_iterations : int
        Largest number of Jacobi iterations per step.
    tolerance : float
        Convergence tolerance on the change of the plans.
    relaxation : float
        Relaxation factor ω in (0, 1].

    Examples
    --------
    A coach's block counts the outputs of its neighbourhood:

    >>> from types import SimpleNamespace
    >>> strategy = NDMPC(max_iterations=20, tolerance=1e-3, relaxation=0.5)
    >>> design = SimpleNamespace(neighbourhoods=((0, 1), (0, 1, 2), (1, 2)))
    >>> strategy.name, strategy.block_inputs(3), strategy.members((1,), design)
    ('ndmpc', [(0,), (1,), (2,)], (0, 1, 2))
    """

    max_iterations: int
    tolerance: float
    relaxation: float
    name = "ndmpc"

    def members(self, inputs: tuple[int, ...], design: MPCDesign) -> tuple[int, ...]:
        """The coach's neighbourhood.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        design : MPCDesign
            The design (its neighbourhoods).

        Returns
        -------
        tuple of int
            ``design.neighbourhoods[inputs[0]]``.
        """
        return design.neighbourhoods[inputs[0]]

    def plan(self, problem: Blocks, params: Sequence[BlockParameters], plan0: Array,
             fallback: FallbackPlan) -> PlanResult:
        """Relaxed Jacobi iterations over the blocks until the plans settle.

        Parameters
        ----------
        problem : Blocks
            The problem: its QP blocks, solve path and residual columns.
        params : sequence of BlockParameters
            This step's parameters of each block, in the order of ``problem.blocks``.
        plan0 : ndarray, shape (M·n,)
            The starting plan of the iterations (the shifted previous plan) [kN].
        fallback : callable
            ``fallback(block) -> z``: the block's moves [kN] when its solve
            gives no usable solution.

        Returns
        -------
        PlanResult
            The last iterate [kN], the worst block status (``"max_iterations"`` when the plans did
            not settle within :attr:`max_iterations`), the iterations and the largest
            change of each [kN].
        """
        weights = [self.relaxation] * len(problem.blocks)
        return jacobi(problem, params, plan0, fallback, weights=weights,
                      max_iterations=self.max_iterations, tolerance=self.tolerance)


@dataclass(frozen=True)
class Cooperative(_PerCoach):
    """Every coach over the whole-train cost; convex combination with weights w.

    Parameters
    ----------
    max_iterations : int
        Largest number of iterations per step.
    tolerance : float
        Convergence tolerance on the change of the plans.
    weights : ndarray
        The combination weight w_i of each coach, summing to 1.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> strategy = Cooperative(max_iterations=20, tolerance=1e-3, weights=np.full(3, 1 / 3))
    >>> strategy.name, strategy.members((1,), SimpleNamespace(n_inputs=3))  # whole-train cost
    ('cooperative', (0, 1, 2))
    """

    max_iterations: int
    tolerance: float
    weights: Array
    name = "cooperative"

    def members(self, inputs: tuple[int, ...], design: MPCDesign) -> tuple[int, ...]:
        """Every coach: each block weighs the whole-train cost.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        design : MPCDesign
            The design (its number of inputs n).

        Returns
        -------
        tuple of int
            ``(0, 1, ..., n-1)``.
        """
        return tuple(range(design.n_inputs))

    def plan(self, problem: Blocks, params: Sequence[BlockParameters], plan0: Array,
             fallback: FallbackPlan) -> PlanResult:
        """Jacobi iterations combining the blocks' plans with the weights w.

        Parameters
        ----------
        problem : Blocks
            The problem: its QP blocks, solve path and residual columns.
        params : sequence of BlockParameters
            This step's parameters of each block, in the order of ``problem.blocks``.
        plan0 : ndarray, shape (M·n,)
            The starting plan of the iterations (the shifted previous plan) [kN].
        fallback : callable
            ``fallback(block) -> z``: the block's moves [kN] when its solve
            gives no usable solution.

        Returns
        -------
        PlanResult
            The last iterate [kN], the worst block status (``"max_iterations"`` when the plans did
            not settle within :attr:`max_iterations`), the iterations and the largest
            change of each [kN].
        """
        weights = [self.weights[block.inputs[0]] for block in problem.blocks]
        return jacobi(problem, params, plan0, fallback, weights=weights,
                      max_iterations=self.max_iterations, tolerance=self.tolerance)


def make_strategy(name: str, *, max_iterations: int, tolerance: float, relaxation: float,
                  weights: Array) -> Strategy:
    """The strategy called ``name`` (one of :data:`~.settings.STRATEGIES`).

    Parameters
    ----------
    name : str
        The strategy's name.
    max_iterations : int
        Largest number of iterations per step (iterating strategies).
    tolerance : float
        Convergence tolerance (iterating strategies).
    relaxation : float
        Relaxation factor ω in (0, 1] (N-DMPC).
    weights : ndarray
        Combination weights of the coaches (cooperative DMPC).

    Returns
    -------
    Strategy
        The strategy, with the settings it uses.

    Examples
    --------
    >>> common = dict(max_iterations=10, tolerance=1e-3, relaxation=0.5, weights=np.ones(1))
    >>> type(make_strategy("centralised", **common)).__name__
    'Centralised'
    >>> make_strategy("ndmpc", **common)
    NDMPC(max_iterations=10, tolerance=0.001, relaxation=0.5)
    """
    if name == "centralised":
        return Centralised()
    if name == "decentralised":
        return Decentralised()
    if name == "ndmpc":
        return NDMPC(max_iterations=max_iterations, tolerance=tolerance, relaxation=relaxation)
    if name == "ndmpc-local":
        from trainctl.controllers.mpc.local import LocalNDMPC

        return LocalNDMPC(max_iterations=max_iterations, tolerance=tolerance,
                          relaxation=relaxation)
    return Cooperative(max_iterations=max_iterations, tolerance=tolerance, weights=weights)


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
