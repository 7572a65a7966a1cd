"""ParametricQP's slack penalties: checked at build, as its docstring promises.

The two places mypy --strict flagged in ``controllers/mpc/qp/parametric.py``
(the constraint list given to ``cp.Problem`` and the terms of
``_slack_penalty``) are cvxpy objects at run time, not numpy arrays:
``ndarray @ Expression`` defers to cvxpy's ``__array_ufunc__``. Their real
defects were the unchecked weights: ``psd_wrap(diag(w2))`` tells cvxpy a
negative w2 is convex (OSQP then failed at setup with a bare OSQPException),
a negative scalar w2 or a NaN was reported as "not DPP", and a negative w1
silently rewarded violations (an "optimal" solution with a slack of 10).
"""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from trainctl.controllers.mpc.qp.parametric import ParametricQP
from trainctl.exceptions import ModelError

H, C, F = np.eye(2), np.eye(2), np.ones((1, 2))
BOUNDS = {"g": np.array([-2.0, -1.0]), "lb": np.full(2, -5.0), "ub": np.full(2, 5.0),
          "hl": np.array([-np.inf]), "hu": np.array([0.5])}


@pytest.mark.parametrize("solver", ["osqp", "daqp"])
@pytest.mark.parametrize(("linear", "quadratic", "named"), [
    (1.0, [-3.0], "soft_quadratic"),   # psd_wrap hid a non-convex QP from cvxpy
    (1.0, -3.0, "soft_quadratic"),     # was "the QP is not DPP"
    (1.0, np.nan, "soft_quadratic"),   # was "the QP is not DPP"
    (1.0, 0.0, "soft_quadratic"),      # the docstring asks for w2 > 0
    (-10.0, 1.0, "soft_linear"),       # was "optimal" with the violation rewarded
    ([-10.0], [1.0], "soft_linear"),
    (np.inf, 1.0, "soft_linear"),
    ([1.0, 2.0], 1.0, "soft_linear"),  # two weights for one soft row: was numpy's ValueError
    ([[1.0]], 1.0, "soft_linear"),
    ("much", 1.0, "soft_linear"),
])
def test_bad_slack_penalties_are_refused_by_name(solver, linear, quadratic, named):
    with pytest.raises(ModelError, match=f"demo: '{named}' must be one finite number"):
        ParametricQP(H, C, F, soft_linear=linear, soft_quadratic=quadratic, name="demo",
                     solver=solver)


def test_penalties_without_soft_rows_are_not_checked():
    qp = ParametricQP(H, C, np.zeros((0, 2)), soft_linear=-1.0, soft_quadratic=-1.0)
    assert qp.solve(g=BOUNDS["g"], lb=BOUNDS["lb"], ub=BOUNDS["ub"]).status == "optimal"


@pytest.mark.parametrize(("linear", "quadratic"), [
    (1e3, 1e2), ([1e3], [1e2]), (1e3, [1e2]), ([1e3], 1e2)])
def test_valid_penalties_one_or_per_row_give_the_same_qp(linear, quadratic):
    """Scalar and per-row weights: cvxpy constraints and terms, the same solution on both paths."""
    qp = ParametricQP(H, C, F, soft_linear=linear, soft_quadratic=quadratic)
    assert all(isinstance(c, cp.Constraint) for c in qp.problem.constraints)
    assert len(qp.problem.constraints) == 4  # lb, ub, hl - s, hu + s (s is nonneg)
    for path in ("fast", "cvxpy"):
        sol = qp.solve(**BOUNDS, path=path)
        assert sol.status == "optimal"
        np.testing.assert_allclose(sol.z, [0.75, -0.25], atol=1e-6)
        np.testing.assert_allclose(sol.slack, [0.0], atol=1e-6)


def test_violated_soft_row_costs_as_weighted():
    """hu = -1 forces a violation: min ½|z|² + w1 s + ½ w2 s² s.t. z1 + z2 <= -1 + s, per row."""
    qp = ParametricQP(H, C, F, soft_linear=[0.0], soft_quadratic=[0.5])
    for path in ("fast", "cvxpy"):
        sol = qp.solve(**{**BOUNDS, "g": np.zeros(2), "hu": np.array([-1.0])}, path=path)
        # z1 = z2 = -(1 - s)/2, s minimises (1 - s)²/4 + s²/4: s = 1/2
        assert sol.status == "optimal"
        np.testing.assert_allclose(sol.slack, [0.5], atol=1e-5)
        np.testing.assert_allclose(sol.z, [-0.25, -0.25], atol=1e-5)
