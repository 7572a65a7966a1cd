# Neighbourhood-local N-DMPC in closed form: local models, exchanged trajectories, Nash point.
"""N-DMPC with the neighbourhood prediction model of Li & Zheng (2015, eqs. 12.19–12.23).

The global variant (:mod:`trainctl.controllers.mpc.theory.iteration`) predicts every
neighbourhood cost with the *global* discrete model, so each coach needs
every other coach's plan and its QP data grow with the train. Here coach i
predicts only its neighbourhood, with its own discretisation of the
neighbourhood model, and the rest of the train enters through the states
just outside the neighbourhood, taken from the trajectories the other
coaches predicted for their own states at the previous iteration.

Local model of coach i (continuous, design units)
    S_i: the states owned by the members N_i of its neighbourhood (for the
    train, z_j = [v_j; delta_j] for j in {i-1, i, i+1});
    O_i: the states outside S_i that act on S_i (A[S_i, O_i] ≠ 0) or on the
    members' outputs (C[R_i, O_i] ≠ 0) — for the train v_{i+2} (through the
    elongation delta_{i+1}) and delta_{i-2} (through the force on coach i-1);
    I_i: the inputs acting on S_i (the members' forces);
    R_i: the output rows owned by the members.

        dz_S/dt = A_SS z_S + B_SI u_I + A_SO z_O,   y_R = C_RS z_S + C_RO z_O,

    which is (12.19)–(12.21): Â_ii = A_SS, B̂_i = B_SI, Â_{i,i±1} = A_SO.

Discretisation (the approximation)
    The outer states are known only at the exchanged samples, so between
    them they are interpolated: linearly (first-order hold, default) or held
    constant (zero-order hold), the inputs held as usual; the local model is
    sampled exactly under that assumption (:func:`_discretise`):

        z_S(k+1) = Â_d z_S(k) + B̂_d u_I(k) + E0 z_O(k) + E1 z_O(k+1)   (E1 = 0 for ZOH).

    The global model's exact discretisation expm(A T) is not local — within
    one sample every force reaches every coach — so the local prediction is
    exact only when z_O is piecewise linear (constant) in time. The error is
    of order (ωT)² (ωT) for the first-order (zero-order) hold, ω the fastest
    coupler frequency: with T = 0.05 s (ω_max T = 1.4 rad) the relative error
    of the neighbourhood output prediction is 12–15 % (FOH) or 60–77 % (ZOH)
    for the CRH2 half train; with T = 20 s (aliased couplers) the local
    model is meaningless (errors of 2–500 times the prediction).
    ``substeps`` = N exchanges the trajectories at T/N instead (the local
    QP's size is unchanged, the exchanged vectors grow N-fold): FOH errors
    3.9 / 1.0 / 0.25 % for N = 2 / 4 / 8 at T = 0.05 s.
    :func:`local_prediction_error` measures it against the global model fed
    with the true outer trajectories.

Iteration (Jacobi, what is exchanged)
    At iteration l every coach knows the measured state x(k), the inputs
    u(k-1) (Δu-form), the other coaches' plans U_j^l and their predicted
    own-state trajectories X_j^l = [z_j(k+1); ...; z_j(k+P)]. Coach i
    minimises its neighbourhood cost J_i = Σ_{j∈N_i} ‖Y_j‖²_Q + ‖U_i‖²_R over
    its own moves U_i with the members' plans at U^l and z_O(k+1..k+P) from
    X^l (z_O(k) is measured), then publishes U_i^{l+1} and the trajectory of
    its own states that its local model predicts with U_i^{l+1}. With
    ξ = [U; X] (plans move by move as in :mod:`trainctl.controllers.mpc.theory.mpc`, then
    the predicted states step by step, x(k+1), ..., x(k+P)) and
    θ = [x(k); u(k-1)]:

        ξ^{l+1} = D0 ξ^l + D1 θ,

    The row blocks::

        U_i rows:  U_i = K_i (-Φ_i x_S - Φ°_i x_O - S_i u_I - Ψ_i X_O - Σ_{j∈I_i, j≠i} G_ij U_j),
                   K_i = (G_iiᵀ Q_i G_ii + R_i)⁻¹ G_iiᵀ Q_i;
        X_i rows:  X_i = Φz x_S + Φz° x_O + Sz u_I + Ψz X_O + Σ_{j∈I_i} Gz_ij U_j
                   (U_i the new plan).

    Unlike the global D0 (size M·n), this D0 also carries the trajectories
    (size M·n + P·N·n_x): a second channel (waveform relaxation of the
    exchanged trajectories) through which the iteration can diverge even
    where the global one converges.

Fixed point: not the global Nash point
    At the fixed point the trajectories are consistent, but coach i's
    optimality condition differs from the global game's: it differentiates
    its cost with the *outer states* held at their exchanged values, the
    global game with the other coaches' *inputs* held. With stiff couplers
    the two sensitivities differ grossly (held outer states tie the
    neighbourhood to a prescribed motion), so the local Nash point is a
    different equilibrium even with an exact local discretisation
    (``substeps`` → ∞); ``boundary="force"`` changes which equilibrium.
    (The reconstruction note that exchanging the predictions every iteration
    gives the global-model fixed point holds for the trajectories, not for
    the plans: a sensitivity-corrected variant — the exact own-input
    sensitivity G_{N_i,i} of the global model in the QP, the local
    prediction for the rest — has that fixed point in exact arithmetic, but
    ρ(D0) 89–330 on crh2-dmpc-well-sampled: unusable.)

Fixed point and closed loop
    ξ* = (I - D0)⁻¹ D1 θ (the Nash point of the local formulation); the first
    move Γ U* = K_x x + K_u u(k-1) closes the loop on the true (global)
    discrete model: :func:`local_closed_loop`.

With every neighbourhood the whole train, S_i is every state, O_i is empty,
the local discretisation is the global one and the fixed point is the
centralised optimum (tested).

Numbers: CRH2 half train (``benchmarks/local_ndmpc.py``)
    ================================  ========  =======  ============  ==========
    crh2-dmpc-well-sampled, R = 0.2   ρ(D0)     R*       ρ(A_cl Nash)  pred. err.
    ================================  ========  =======  ============  ==========
    global                            0.6098    0.0563   0.998777      0
    centralised                                          0.998250
    local, state, FOH, N = 1          1.4090    24.6     1.001567      0.152
    local, state, ZOH, N = 1          1.3891    10.2     1.001080      0.77
    local, state, FOH, N = 4          1.4263    24.5     1.013531      0.0100
    local, force, FOH, N = 1          1.2980    2.50     0.998317      0.15
    local, force, FOH, N = 4          1.3442    3.61     0.998299      0.0100
    ================================  ========  =======  ============  ==========

    crh2-dmpc (T = 20 s, Δu-form, R = 10): global ρ(D0) 0.306, R* 2.25; local
    (state, FOH) ρ(D0) 1.002, R* 55.6, (state, ZOH) 2.016, (force, FOH) 0.699;
    the Nash loops keep the three internal-force eigenvalues at 1 as the
    global one does (state/ZOH: 1.196 and force/FOH, N = 1: 1.024, unstable),
    and the local predictions are meaningless (errors 60–570 times the
    prediction: a 20 s hold of states oscillating at 12–28 rad/s).

    Why the local variant is worse:

    - ρ(D0): the local iteration has a second channel, the exchanged
      trajectories, absent from the global D0. A coach's plan reacts to the
      outer trajectory (through the stiff boundary coupler) and the
      resulting own-state trajectory moves the next neighbourhood's
      boundary: a disturbance travels along the train every iteration. The
      gain grows with the horizon (well-sampled, R = 0.2: ρ = 0.30 / 0.62 /
      1.04 / 1.41 for P = 5 / 10 / 20 / 40) and with the train length (P =
      40, R = 30: 0.98 / 1.29 / 1.61 for 4 / 8 / 16 coaches), so R* is
      about 440 times the global one at P = 40; a finer exchange (N) does not help
      — it is not a discretisation effect.
    - Closed loop: the local Nash point is another equilibrium (see "Fixed
      point" above). With the book's state boundary the rear boundary ties
      the neighbourhood to the outer coach's predicted speed, so a coach
      near the head sees almost no authority over its neighbourhood's speed
      and a coach near the tail a lot (first moves for 1 m/s on every coach:
      local [-0.07, -0.18, -1.42, -1.66] kN, global [-0.82, -1.10, -1.12,
      -0.87] kN); the loop is then unstable (a coupler mode at 11 rad/s,
      ρ 1.0016), the more so the better the local model (N = 4: 1.0135).
      With force boundaries every neighbourhood keeps its rigid-body mode,
      the allocation is symmetric and the Nash loop (0.99832) is closer to
      the centralised one (0.99825) than the global Nash loop (0.99878) — but
      its iteration diverges too (ρ 1.30; relaxation ω ≈ 0.08 converges at a
      rate 0.9996; separate blends of plans and trajectories do no better:
      best ρ 1.009 (state), 0.994 (force)).

    Where it works: shorter horizons. T-M-M-T chains at 50 m/s, T = 0.05 s,
    P = 10, M = 5, R = 2 per kN² (``benchmarks/dmpc_step.py`` part 3):
    ρ(D0_local) = 0.316 / 0.459 / 0.466 / 0.468 for 4 / 16 / 32 / 64 coaches
    (global 0.038 / 0.025 / 0.025 / 0.025) — bounded in the train length —
    and Nash closed loops 0.999888 / 0.999911 / 0.999916 against the global
    0.999878 / 0.999898 / 0.999930 for 4 / 16 / 64 coaches.

The package, by job: :mod:`~trainctl.controllers.mpc.theory.local_iteration.model`
(each coach's local model), :mod:`~trainctl.controllers.mpc.theory.local_iteration.predictions`
(the local output predictions) and :mod:`~trainctl.controllers.mpc.theory.local_iteration.nash`
(the iteration, its Nash point and the closed loops).
"""

from trainctl.controllers.mpc.theory.local_iteration.model import (
    BOUNDARIES,
    HOLDS,
    LocalModel,
    local_model,
    train_state_owner,
)
from trainctl.controllers.mpc.theory.local_iteration.nash import (
    LocalIteration,
    local_closed_loop,
    local_finite_iteration_closed_loop,
    local_iteration,
    local_nash_gain,
    local_shift_matrix,
    local_threshold_weight,
)
from trainctl.controllers.mpc.theory.local_iteration.predictions import (
    CoachPrediction,
    LocalResponse,
    coach_predictions,
    local_prediction_error,
    rows_response,
)

__all__ = [
    "CoachPrediction",
    "BOUNDARIES",
    "HOLDS",
    "LocalIteration",
    "LocalModel",
    "LocalResponse",
    "coach_predictions",
    "local_closed_loop",
    "local_finite_iteration_closed_loop",
    "local_iteration",
    "local_model",
    "local_nash_gain",
    "local_prediction_error",
    "local_shift_matrix",
    "local_threshold_weight",
    "rows_response",
    "train_state_owner",
]
