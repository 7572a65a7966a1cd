# The DMPC design conditions of one MPC design, as one frozen result.
"""Convergence and closed-loop conditions of N-DMPC, cooperative and centralised MPC.

:func:`analyse_dmpc` judges the global formulation (every coach predicts with
the global model); :func:`analyse_local_dmpc` the neighbourhood-local one of
:mod:`trainctl.controllers.mpc.theory.local_iteration` (strategy ``"ndmpc-local"``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.mpc.theory.iteration import (
    RelaxationResult,
    closed_loop_matrix,
    cooperative_iteration,
    finite_iteration_closed_loop,
    iteration_matrices,
    nash_gain,
    relaxation,
    spectral_radius,
    threshold_weight,
)
from trainctl.controllers.mpc.theory.local_iteration.model import LocalModel
from trainctl.controllers.mpc.theory.local_iteration.nash import (
    local_closed_loop,
    local_finite_iteration_closed_loop,
    local_iteration,
    local_nash_gain,
    local_threshold_weight,
)
from trainctl.controllers.mpc.theory.local_iteration.predictions import local_prediction_error
from trainctl.controllers.mpc.theory.mpc import MPCDesign, prediction

__all__ = ["LOCAL_THRESHOLD_SIZE", "DMPCAnalysis", "LocalDMPCAnalysis", "analyse_dmpc",
           "analyse_local_dmpc"]


@dataclass(frozen=True, kw_only=True)
class DMPCAnalysis:
    """Unconstrained (D)MPC design conditions, in design units.

    Parameters
    ----------
    rho_d0 : float
        Spectral radius of the N-DMPC Jacobi iteration matrix D0.
    d0_eigenvalues : ndarray
        Eigenvalues of D0.
    threshold_weight : float
        R*: smallest common input weight with ρ(D0) < 1 [per design unit²].
    relaxation : RelaxationResult
        Relaxed-Jacobi range and best rate.
    closed_loop_nash : ndarray
        Closed-loop matrix with the converged Nash plan.
    closed_loop_iterations : ndarray
        Closed-loop matrix with ``iterations`` Jacobi sweeps from the shifted plan.
    closed_loop_centralised : ndarray
        Closed-loop matrix of centralised MPC.
    iterations : int
        Sweeps per sample in ``closed_loop_iterations``.
    cost_gap : float
        (J_Nash - J_centralised)/J_centralised for a unit speed error on every coach.
    rho_cooperative : float
        Spectral radius of the cooperative (convex-combination) iteration.

    Examples
    --------
    Two inputs on one integrator, the output owned by coach 0 alone: coach 1
    sees no cost and stays at 0, coach 0 minimises (x + u0)² + u0², so
    u0 = −x/2 and x(k+1) = x/2; the centralised plan u0 = u1 = −x/3 gives x/3.
    Costs for x = 1: Nash 1/4 + 1/4, centralised 1/9 + 2/9, a gap of 50 %.

    >>> import numpy as np
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 2)), C=np.eye(1), prediction_horizon=1,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.ones(2),
    ...               output_owner=(0,), neighbourhoods=((0,), (1,)))
    >>> res = analyse_dmpc(d, iterations=2)
    >>> res.converges, round(res.rho_d0, 4)  # coach 1 never reacts: D0 is nilpotent
    (True, 0.0)
    >>> {k: round(v, 4) for k, v in res.radii().items()}
    {'nash': 0.5, 'iterations': 0.5, 'centralised': 0.3333}
    >>> round(res.cost_gap, 4)
    0.5
    """

    rho_d0: float
    d0_eigenvalues: NDArray[np.complex128]
    threshold_weight: float
    relaxation: RelaxationResult
    closed_loop_nash: NDArray[np.float64]
    closed_loop_iterations: NDArray[np.float64]
    closed_loop_centralised: NDArray[np.float64]
    iterations: int
    cost_gap: float
    rho_cooperative: float

    @property
    def converges(self) -> bool:
        """True when plain Jacobi iteration converges (ρ(D0) < 1)."""
        return self.rho_d0 < 1

    def radii(self) -> dict[str, float]:
        """Closed-loop spectral radii: nash, iterations, centralised.

        Returns
        -------
        dict of str to float
            ``"nash"``, ``"iterations"`` and ``"centralised"``: the
            spectral radius [-] of :attr:`closed_loop_nash`,
            :attr:`closed_loop_iterations` and
            :attr:`closed_loop_centralised` (a new dict each call).
        """
        return dict(self._radii)

    @cached_property
    def _radii(self) -> dict[str, float]:
        return {name: spectral_radius(getattr(self, f"closed_loop_{name}"))
                for name in ("nash", "iterations", "centralised")}

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``rho_d0``, ``d0_eigenvalues`` (pairs of real and imaginary
            part), ``threshold_weight`` (None when infinite),
            ``relaxation`` as a dict, ``closed_loop_radius`` (the
            :meth:`radii`), ``iterations``, ``cost_gap`` and
            ``rho_cooperative``.
        """
        r_star = self.threshold_weight
        return {"rho_d0": self.rho_d0,
                "d0_eigenvalues": [[float(z.real), float(z.imag)] for z in self.d0_eigenvalues],
                "threshold_weight": None if math.isinf(r_star) else r_star,
                "relaxation": self.relaxation.to_dict(), "closed_loop_radius": self.radii(),
                "iterations": self.iterations, "cost_gap": self.cost_gap,
                "rho_cooperative": self.rho_cooperative}

    def _repr_html_(self) -> str:
        radii = self.radii()
        return (f"<p><b>N-DMPC</b>: ρ(D0) = {self.rho_d0:.4g}, R* = {self.threshold_weight:.4g}; "
                f"closed-loop ρ: Nash {radii['nash']:.6g}, {self.iterations} iterations "
                f"{radii['iterations']:.6g}, centralised {radii['centralised']:.6g}; "
                f"cost gap {100 * self.cost_gap:.3g} %</p>")


def analyse_dmpc(
    design: MPCDesign,
    *,
    iterations: int = 10,
    cooperative_weights: NDArray[np.float64] | None = None,
) -> DMPCAnalysis:
    """Convergence, closed-loop stability and optimality of a DMPC design.

    Parameters
    ----------
    design : MPCDesign
        The design (design units, e.g. inputs in kN).
    iterations : int
        Jacobi sweeps per sample for the finite-iteration closed loop, >= 1.
    cooperative_weights : ndarray or None
        Convex weights of cooperative DMPC (default 1/n each).

    Returns
    -------
    DMPCAnalysis
        The numbers the design review judges.

    Examples
    --------
    >>> import numpy as np
    >>> # Three identical inputs on one integrator: each player over-corrects for two others.
    >>> d = MPCDesign(A=np.eye(1), B=np.ones((1, 3)), C=np.eye(1), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.ones(1), r=np.full(3, 0.1),
    ...               output_owner=(0,), neighbourhoods=((0, 1, 2),) * 3)
    >>> res = analyse_dmpc(d)
    >>> res.converges, round(res.rho_d0, 4), round(res.threshold_weight, 4)
    (False, 1.9608, 5.0)
    """
    pred = prediction(design)
    D0, D1 = iteration_matrices(design, pred)
    nash = nash_gain(D0, D1)
    n = design.n_inputs
    x = np.zeros(design.A.shape[0])
    x[:n] = 1.0  # every coach 1 m/s off (the first n states are velocities)
    e = -pred.Phi @ x
    j_c = pred.cost(pred.centralised_gain() @ e, e)
    j_n = pred.cost(nash @ e, e)
    T_coop, _ = cooperative_iteration(design, cooperative_weights, None)
    eig = np.asarray(np.linalg.eigvals(D0), dtype=np.complex128)
    return DMPCAnalysis(
        rho_d0=float(np.max(np.abs(eig))) if eig.size else 0.0,
        d0_eigenvalues=eig,
        threshold_weight=threshold_weight(design),
        relaxation=relaxation(D0, eig),
        closed_loop_nash=closed_loop_matrix(design, nash, pred),
        closed_loop_iterations=finite_iteration_closed_loop(design, D0, D1, iterations, pred),
        closed_loop_centralised=closed_loop_matrix(design, pred.centralised_gain(), pred),
        iterations=iterations,
        cost_gap=(j_n - j_c) / j_c if j_c > 0 else 0.0,
        rho_cooperative=spectral_radius(T_coop),
    )


@dataclass(frozen=True, kw_only=True)
class LocalDMPCAnalysis:
    """Unconstrained conditions of neighbourhood-local N-DMPC, in design units.

    Parameters
    ----------
    rho_d0 : float
        Spectral radius of the local iteration matrix (plans and exchanged trajectories).
    d0_eigenvalues : ndarray
        Its eigenvalues.
    relaxation : RelaxationResult
        Relaxed-Jacobi range and best rate.
    closed_loop_nash : ndarray
        Closed loop (on the global model) with the converged local Nash plan.
    closed_loop_iterations : ndarray
        Closed loop with ``iterations`` local sweeps per sample from the
        shifted plans and trajectories (state augmented with them).
    iterations : int
        Sweeps per sample in ``closed_loop_iterations``.
    prediction_error : ndarray
        Relative error of each coach's local output prediction
        (:func:`~trainctl.controllers.mpc.theory.local_iteration.local_prediction_error`).
    threshold_weight : float or None
        R* of the local iteration [per design unit²] (None: not computed).
    hold, boundary : str
        The local model's hold and boundary.
    substeps : int
        Exchanged samples per sample time.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> from trainctl.controllers.mpc.theory.local_iteration import local_model
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> res = analyse_local_dmpc(d, m, iterations=3)
    >>> res.converges, res.hold, res.substeps
    (True, 'zoh', 1)
    >>> # ρ(D0) = 2qβ²γ/(5qβ² + r) with β = 0.35, γ = 0.15, q = 2, r = 0.4.
    >>> round(res.rho_d0, 5), round(res.closed_loop_radius, 4)
    (0.04523, 0.5712)
    """

    rho_d0: float
    d0_eigenvalues: NDArray[np.complex128]
    relaxation: RelaxationResult
    closed_loop_nash: NDArray[np.float64]
    closed_loop_iterations: NDArray[np.float64]
    iterations: int
    prediction_error: NDArray[np.float64]
    threshold_weight: float | None
    hold: str
    boundary: str
    substeps: int

    @property
    def converges(self) -> bool:
        """True when plain Jacobi iteration converges (ρ(D0) < 1)."""
        return self.rho_d0 < 1

    @cached_property
    def closed_loop_radius(self) -> float:
        """Spectral radius of the converged local closed loop."""
        return spectral_radius(self.closed_loop_nash)

    @cached_property
    def closed_loop_iterations_radius(self) -> float:
        """Spectral radius of the closed loop with ``iterations`` sweeps per sample."""
        return spectral_radius(self.closed_loop_iterations)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``rho_d0``, ``relaxation`` as a dict, ``closed_loop_radius``,
            ``closed_loop_iterations_radius``, ``iterations``,
            ``prediction_error`` (one relative error per coach),
            ``threshold_weight`` (None when not computed or infinite),
            ``hold``, ``boundary`` and ``substeps``.
        """
        r_star = self.threshold_weight
        return {"rho_d0": self.rho_d0, "relaxation": self.relaxation.to_dict(),
                "closed_loop_radius": self.closed_loop_radius,
                "closed_loop_iterations_radius": self.closed_loop_iterations_radius,
                "iterations": self.iterations,
                "prediction_error": [float(e) for e in self.prediction_error],
                "threshold_weight": None if r_star is None or math.isinf(r_star) else r_star,
                "hold": self.hold, "boundary": self.boundary, "substeps": self.substeps}


LOCAL_THRESHOLD_SIZE = 1000
"""Largest local iteration matrix D0 [rows] whose R* :func:`analyse_local_dmpc` finds by
default: the bisection solves some 28 eigenproblems of that size (0.3 s at the 300 rows of
the well-sampled CRH2 design; the 204-vehicle chain's 4682 rows would take minutes)."""


def analyse_local_dmpc(design: MPCDesign, model: LocalModel, *, iterations: int = 10,
                       threshold: bool | None = None) -> LocalDMPCAnalysis:
    """Convergence and closed loop of neighbourhood-local N-DMPC.

    Parameters
    ----------
    design : MPCDesign
        The design (design units).
    model : LocalModel
        Its continuous model partitioned by coach.
    iterations : int
        Sweeps per sample for the finite-iteration closed loop, >= 1.
    threshold : bool or None
        Also find R* by bisection (tens of eigenvalue problems of size
        M·n + P·N·nx); None: when D0 has at most :data:`LOCAL_THRESHOLD_SIZE`
        rows.

    Returns
    -------
    LocalDMPCAnalysis
        The numbers.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> from trainctl.controllers.mpc.theory.local_iteration import local_model
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> res = analyse_local_dmpc(d, m)
    >>> round(res.closed_loop_iterations_radius, 4)  # 10 sweeps: the converged loop's radius
    0.5712
    >>> res.threshold_weight  # converges at any weight: the bracket's low end
    1e-12
    >>> np.round(res.prediction_error, 4).tolist()  # the held z_j misses its change
    [0.0383, 0.0383]
    """
    it = local_iteration(design, model)
    if threshold is None:
        threshold = it.D0.shape[0] <= LOCAL_THRESHOLD_SIZE
    eig = np.asarray(np.linalg.eigvals(it.D0), dtype=np.complex128)
    return LocalDMPCAnalysis(
        rho_d0=float(np.max(np.abs(eig))) if eig.size else 0.0,
        d0_eigenvalues=eig,
        relaxation=relaxation(it.D0, eig),
        closed_loop_nash=local_closed_loop(design, local_nash_gain(it)[:it.n_plan]),
        closed_loop_iterations=local_finite_iteration_closed_loop(design, it, iterations,
                                                                  model.substeps),
        iterations=iterations,
        prediction_error=local_prediction_error(design, model, it.coaches),
        threshold_weight=local_threshold_weight(design, model, rtol=1e-3) if threshold else None,
        hold=model.hold, boundary=model.boundary, substeps=model.substeps,
    )
