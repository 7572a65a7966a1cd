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

The package, by job: :mod:`~trainctl.controllers.mpc.strategies.base` (the protocol,
the plan result and the block solves) and
:mod:`~trainctl.controllers.mpc.strategies.coordinators` (the built-in strategies).
"""

from trainctl.controllers.mpc.strategies.base import PlanResult, Strategy, solve_block
from trainctl.controllers.mpc.strategies.coordinators import (
    NDMPC,
    Centralised,
    Cooperative,
    Decentralised,
    make_strategy,
)

__all__ = ["Centralised", "Cooperative", "Decentralised", "NDMPC", "PlanResult", "Strategy",
           "make_strategy", "solve_block"]
