# The built-in MPC strategies: centralised, decentralised, N-DMPC and cooperative.
"""The built-in strategies, each a small coordinator of the QP blocks, and
:func:`make_strategy`, which builds one by name.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.mpc.condensed import BlockParameters
from trainctl.controllers.mpc.strategies.base import (
    Blocks,
    FallbackPlan,
    PlanResult,
    Strategy,
    _PerCoach,
    jacobi,
    solve_once,
)
from trainctl.controllers.mpc.theory.mpc import MPCDesign

__all__ = ["Centralised", "Cooperative", "Decentralised", "NDMPC", "make_strategy"]

Array = NDArray[np.float64]


class Centralised:
    """One QP over every coach's moves and the whole-train cost.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> strategy = Centralised()
    >>> strategy.block_inputs(3), strategy.couplers((0, 1, 2), 2), strategy.vehicles((0, 1, 2), 3)
    ([(0, 1, 2)], [0, 1], [0, 1, 2])
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

    def vehicles(self, inputs: tuple[int, ...], n: int) -> list[int]:
        """Every vehicle.

        Parameters
        ----------
        inputs : tuple of int
            The inputs (coaches, 0-based) the block decides for.
        n : int
            Number of vehicles of the train.

        Returns
        -------
        list of int
            ``[0, 1, ..., n-1]``.
        """
        return list(range(n))

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
    One block per coach, bounding the couplers in front of and behind it
    and its own speed:

    >>> strategy = Decentralised()
    >>> strategy.block_inputs(3), strategy.members((1,), None)
    ([(0,), (1,), (2,)], (1,))
    >>> [strategy.couplers((i,), 2) for i in range(3)], strategy.vehicles((1,), 3)
    ([[0], [0, 1], [1]], [1])
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
