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
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse
from numpy.typing import NDArray
from scipy.linalg import expm

from trainctl.controllers.mpc.theory.iteration import log_bisection, spectral_radius
from trainctl.controllers.mpc.theory.mpc import MPCDesign, prediction
from trainctl.exceptions import ModelError

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

Array = NDArray[np.float64]
Index = NDArray[np.int64]


def train_state_owner(n: int) -> tuple[int, ...]:
    """Owner of each state of the train design model [v_0..v_{n-1}, delta_0..delta_{n-2}].

    Coach i owns its speed and the elongation of the coupler behind it (z_i of eq. 12.12).

    Parameters
    ----------
    n : int
        Number of coaches.

    Returns
    -------
    tuple of int
        The owning coach of each of the 2n - 1 states.

    Examples
    --------
    >>> train_state_owner(3)
    (0, 1, 2, 0, 1)
    """
    return tuple(range(n)) + tuple(range(n - 1))


@dataclass(frozen=True, kw_only=True)
class LocalModel:
    """The continuous design model partitioned by coach.

    Parameters
    ----------
    A : ndarray
        Continuous state matrix (nx, nx) [1/s], design units.
    B : ndarray
        Continuous input matrix (nx, nu) [state unit per s per input unit, e.g. m/s² per kN].
    dt : float
        Sample time T [s].
    state_owner : tuple of int
        The coach owning each state.
    hold : {"foh", "zoh"}
        Outer states between the exchanged samples: linear or constant.
    substeps : int
        N >= 1: the trajectories are exchanged at T/N (the local models are
        sampled at T/N; the inputs are still held over T).
    boundary : {"state", "force"}
        What a neighbourhood takes from outside (:func:`local_model`).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> m.state_owner, m.hold, m.substeps, m.boundary
    ((0, 1), 'zoh', 1, 'state')
    """

    A: Array
    B: Array
    dt: float
    state_owner: tuple[int, ...]
    hold: str = "foh"
    substeps: int = 1
    boundary: str = "state"


HOLDS = ("zoh", "foh")
"""How the exchanged outer-state samples are held over a sample: constant, or linear."""

BOUNDARIES = ("state", "force")
"""What a neighbourhood takes from outside: the adjacent subsystems' states (the book's
Â_{i,i±1} z_{i±2}) or, in addition, the elongations of its boundary couplers."""


def local_model(design: MPCDesign, A: Array, B: Array, dt: float,
                state_owner: Sequence[int], *, hold: str = "foh", substeps: int = 1,
                boundary: str = "state", rtol: float = 1e-7) -> LocalModel:
    """A :class:`LocalModel` of ``design``, checked: ZOH(A, B, dt) must be the design's (A, B).

    Parameters
    ----------
    design : MPCDesign
        The discrete design (its A, B are the exact ZOH of the continuous model).
    A, B : ndarray
        The continuous design model.
    dt : float
        Sample time [s].
    state_owner : sequence of int
        Coach owning each state (:func:`train_state_owner` for the train).
    hold : {"foh", "zoh"}
        Outer states between the exchanged samples: linear (first-order
        hold, default) or constant (zero-order hold).
    substeps : int
        N >= 1 exchanged samples per sample T (the hold error falls like
        (ωT/N)² with the first-order hold, like ωT/N with the zero-order hold).
    boundary : {"state", "force"}
        ``"state"`` (the book's Â_{i,i±1}): the neighbourhood predicts all its
        members' states; the outer states z_{i±2} are exchanged. For the
        train this is asymmetric: at the front the outer elongation delta_{i-2}
        enters as a force on coach i-1, at the rear the outer speed v_{i+2}
        drives the boundary elongation delta_{i+1}, so the neighbourhood is
        tied to a prescribed motion there. ``"force"``: a member state
        without an input of its own that is driven from outside (the rear
        boundary elongation) is exchanged too (its owner, for whom it is
        inside, predicts it), so both ends see a coupler force and the
        neighbourhood keeps its rigid-body mode. The coach's own states are
        always predicted.
    rtol : float
        Relative tolerance of the check.

    Returns
    -------
    LocalModel
        The partitioned continuous model.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> m.dt, m.B.tolist()
    (0.5, [[0.7, 0.0], [0.0, 0.7]])
    >>> try:  # not the model the design was sampled from
    ...     local_model(d, Ac, 2 * Bc, T, (0, 1))
    ... except ModelError as err:
    ...     print(type(err).__name__, "zero-order hold of (A, B)" in str(err))
    ModelError True
    """
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    nx, nu = design.B.shape
    owner = tuple(int(o) for o in state_owner)
    if A.shape != (nx, nx) or B.shape != (nx, nu) or len(owner) != nx:
        raise ModelError(f"local_model: shapes disagree with the design (A {A.shape}, "
                         f"B {B.shape}, {len(owner)} owners; design {nx} states, {nu} inputs).")
    if hold not in HOLDS:
        raise ModelError(f"local_model: 'hold' must be one of {HOLDS} (got {hold!r}).")
    if boundary not in BOUNDARIES:
        raise ModelError(f"local_model: 'boundary' must be one of {BOUNDARIES} "
                         f"(got {boundary!r}).")
    if not (isinstance(substeps, int) and substeps >= 1):
        raise ModelError(f"local_model: 'substeps' must be an int >= 1 (got {substeps!r}).")
    if any(not 0 <= o < nu for o in owner):
        raise ModelError(f"local_model: state owners must be coaches 0..{nu - 1}.")
    Ad, Bd, _, _ = _discretise(A, B, np.zeros((nx, 0)), dt, "zoh")
    scale = max(float(np.abs(design.A).max()), float(np.abs(design.B).max()), 1e-300)
    if not (np.allclose(Ad, design.A, rtol=rtol, atol=rtol * scale)
            and np.allclose(Bd, design.B, rtol=rtol, atol=rtol * scale)):
        raise ModelError("local_model: the zero-order hold of (A, B) at dt is not the design's "
                         "discrete model.")
    return LocalModel(A=A, B=B, dt=float(dt), state_owner=owner, hold=hold, substeps=substeps,
                      boundary=boundary)


def _discretise(A: Array, B: Array, E: Array, dt: float,
                hold: str) -> tuple[Array, Array, Array, Array]:
    """Exact sampling of dz/dt = A z + B u + E w: u held; w held (zoh) or linear (foh).

    Returns Ad, Bd, E0, E1 with z(k+1) = Ad z(k) + Bd u(k) + E0 w(k) + E1 w(k+1)
    (E1 = 0 for the zero-order hold). In scaled time τ = t/T the first-order
    hold is w(τ) = w(k) + τ (w(k+1) - w(k)): the augmented state
    [z; u; w; dw/dτ] has the generator [[AT, BT, ET, 0], [0, 0, 0, 0],
    [0, 0, 0, I], [0, 0, 0, 0]], whose exponential holds the maps.
    """
    n, nb, ne = A.shape[0], B.shape[1], E.shape[1]
    size = n + nb + 2 * ne
    M = np.zeros((size, size))
    M[:n, :n], M[:n, n:n + nb], M[:n, n + nb:n + nb + ne] = A * dt, B * dt, E * dt
    if hold == "foh":
        M[n + nb:n + nb + ne, n + nb + ne:] = np.eye(ne)
    Md = expm(M)
    Ad, Bd = Md[:n, :n], Md[:n, n:n + nb]
    F1, F2 = Md[:n, n + nb:n + nb + ne], Md[:n, n + nb + ne:]
    return Ad, Bd, F1 - F2, F2


@dataclass(frozen=True, kw_only=True)
class LocalResponse:
    """Condensed local prediction of some rows over P steps (step-major rows).

    rows = Phi x_S + Phi_o z_O(k) + Su u_I(k-1) + Psi [z_O(k+1); ...; z_O(k+P)] + G U_I

    Parameters
    ----------
    Phi : ndarray
        From the neighbourhood states x_S(k).
    Phi_o : ndarray
        From the measured outer states z_O(k).
    Su : ndarray
        From u_I(k-1) (Δu-form; zeros in the u-form).
    Psi : ndarray
        From the outer-state trajectory z_O(k+1..k+P), step-major.
    G : ndarray
        From the moves of the inputs I (move-major, inputs in I order).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> r = coach_predictions(d, m)[0].y  # coach 0's prediction of z0(k+1), z0(k+2)
    >>> r.Phi.tolist(), r.Phi_o.round(4).tolist(), r.G.round(4).tolist()
    ([[1.0], [1.0]], [[0.15], [0.15]], [[0.35], [0.7]])
    """

    Phi: Array
    Phi_o: Array
    Su: Array
    Psi: Array
    G: Array


def _response(Ad: Array, Bd: Array, E0: Array, E1: Array, Cs: Array, Co: Array, *, P: int,
              M: int, form: str, substeps: int, every: int) -> LocalResponse:
    """Condensed response on the fine grid h = T/N (N = ``substeps``), by recursion.

    The state is propagated over the P·N fine steps τ (inputs held over each
    sample T, outer states w(τ) at the fine samples, held by E0, E1); the rows
    Cs z(τ) + Co w(τ) are recorded at every ``every``-th fine step.
    """
    N, ns, nI, no = substeps, Ad.shape[0], Bd.shape[1], E0.shape[1]
    fine = P * N
    Zx, Zu = np.eye(ns), np.zeros((ns, M * nI))
    Zp, Zw = np.zeros((ns, nI)), np.zeros((ns, (fine + 1) * no))
    rec: dict[str, list[Array]] = {"x": [], "u": [], "p": [], "w": []}
    for tau in range(1, fine + 1):
        move = min((tau - 1) // N, M - 1)
        Zx, Zu, Zp, Zw = Ad @ Zx, Ad @ Zu, Ad @ Zp, Ad @ Zw
        if form == "u":
            Zu[:, move * nI:(move + 1) * nI] += Bd
        else:
            for m in range(move + 1):
                Zu[:, m * nI:(m + 1) * nI] += Bd
            Zp += Bd
        Zw[:, (tau - 1) * no:tau * no] += E0
        Zw[:, tau * no:(tau + 1) * no] += E1
        if tau % every == 0:
            w = Cs @ Zw
            w[:, tau * no:(tau + 1) * no] += Co
            rec["x"].append(Cs @ Zx)
            rec["u"].append(Cs @ Zu)
            rec["p"].append(Cs @ Zp)
            rec["w"].append(w)
    full = np.vstack(rec["w"])
    return LocalResponse(Phi=np.vstack(rec["x"]), Phi_o=full[:, :no], Su=np.vstack(rec["p"]),
                         Psi=full[:, no:], G=np.vstack(rec["u"]))


@dataclass(frozen=True, kw_only=True)
class CoachPrediction:
    """Coach i's neighbourhood model, discretised, and its condensed predictions.

    Parameters
    ----------
    coach : int
        The coach i.
    members : tuple of int
        Its neighbourhood N_i.
    states, outer, inputs, rows, own : ndarray of int
        Global indices of S_i, O_i, I_i (ascending, containing i), the output
        rows R_i and the states owned by i (in S_i).
    Ad, Bd, E0, E1 : ndarray
        Sampled (A_SS, B_SI, A_SO): z_S(k+1) = Ad z_S + Bd u_I + E0 z_O(k) + E1 z_O(k+1).
    y : LocalResponse
        Prediction of the members' outputs R_i.
    z : LocalResponse
        Prediction of coach i's own states (published trajectory).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> c = coach_predictions(d, m)[0]
    >>> c.coach, c.members, c.inputs.tolist(), c.own_input
    (0, (0,), [0], 0)
    >>> # Own output over P = 2 steps: z0(k+1) = z0 + 0.35 u0 + 0.15 z1(k), z0(k+2) adds the same
    >>> # input again and 0.15 z1(k+1), which comes from the exchanged trajectory (Psi).
    >>> c.y.G.round(4).tolist(), c.y.Psi.round(4).tolist()
    ([[0.35], [0.7]], [[0.0, 0.0], [0.15, 0.0]])
    """

    coach: int
    members: tuple[int, ...]
    states: Index
    outer: Index
    inputs: Index
    rows: Index
    own: Index
    Ad: Array
    Bd: Array
    E0: Array
    E1: Array
    y: LocalResponse
    z: LocalResponse

    @property
    def own_input(self) -> int:
        """Position of the coach's own input in ``inputs``."""
        return int(np.searchsorted(self.inputs, self.coach))


def _coach_prediction(design: MPCDesign, model: LocalModel, coach: int,
                      members: Sequence[int], C_rows: Array | None = None,
                      row_owner: Sequence[int] | None = None) -> CoachPrediction:
    A, B, C = model.A, model.B, design.C if C_rows is None else C_rows
    owners = design.output_owner if row_owner is None else tuple(row_owner)
    mem = tuple(sorted(set(int(j) for j in members)))
    so = np.asarray(model.state_owner)
    S = np.flatnonzero(np.isin(so, mem))
    R = np.flatnonzero(np.isin(np.asarray(owners), mem))
    rest = np.setdiff1d(np.arange(A.shape[0]), S)
    if model.boundary == "force":
        driven = np.any(A[np.ix_(S, rest)] != 0, axis=1) & ~np.any(B[S] != 0, axis=1)
        driven &= so[S] != coach
        S = S[~driven]
        rest = np.setdiff1d(np.arange(A.shape[0]), S)
    acts = np.any(A[np.ix_(S, rest)] != 0, axis=0)
    if R.size:
        acts |= np.any(C[np.ix_(R, rest)] != 0, axis=0)
    out = rest[acts]
    inputs = np.union1d(np.flatnonzero(np.any(B[S] != 0, axis=0)), [coach]).astype(np.int64)
    Ad, Bd, E0, E1 = _discretise(A[np.ix_(S, S)], B[np.ix_(S, inputs)], A[np.ix_(S, out)],
                                 model.dt / model.substeps, model.hold)
    P, M, form = design.prediction_horizon, design.control_horizon, design.form
    N = model.substeps
    y = _response(Ad, Bd, E0, E1, C[np.ix_(R, S)], C[np.ix_(R, out)], P=P, M=M, form=form,
                  substeps=N, every=N)
    own = np.flatnonzero(so == coach)
    sel = np.searchsorted(S, own)
    Iz = np.eye(S.size)[sel]
    z = _response(Ad, Bd, E0, E1, Iz, np.zeros((own.size, out.size)), P=P, M=M, form=form,
                  substeps=N, every=1)
    return CoachPrediction(coach=coach, members=mem, states=S, outer=out, inputs=inputs, rows=R,
                           own=own, Ad=Ad, Bd=Bd, E0=E0, E1=E1, y=y, z=z)


def rows_response(design: MPCDesign, model: LocalModel, coach: CoachPrediction, rows: Array, *,
                  every: int) -> LocalResponse:
    """The local prediction of other rows on the global state (e.g. coupler forces).

    Parameters
    ----------
    design : MPCDesign
        The design (horizons, form).
    model : LocalModel
        The partitioned model the coach's prediction was built with.
    coach : CoachPrediction
        The coach's local prediction.
    rows : ndarray
        Rows (k, nx) on the global state; they may only involve the
        neighbourhood's states and its outer states.
    every : int
        Record every ``every``-th fine step (``model.substeps``: the samples).

    Returns
    -------
    LocalResponse
        The rows' prediction, step-major.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> c = coach_predictions(d, m)[0]
    >>> # The difference z0 - z1 as coach 0 predicts it: z1 enters from the exchanged trajectory.
    >>> r = rows_response(d, m, c, np.array([[1.0, -1.0]]), every=1)
    >>> r.Psi.round(4).tolist()  # columns z1(k+1), z1(k+2)
    [[-1.0, 0.0], [0.15, -1.0]]
    """
    rows = np.asarray(rows, dtype=float).reshape(-1, design.A.shape[0])
    known = np.union1d(coach.states, coach.outer)
    if np.any(np.delete(rows, known, axis=1)):
        raise ModelError(f"rows_response: the rows involve states outside coach {coach.coach}'s "
                         "neighbourhood and its outer states.")
    return _response(coach.Ad, coach.Bd, coach.E0, coach.E1, rows[:, coach.states],
                     rows[:, coach.outer], P=design.prediction_horizon,
                     M=design.control_horizon, form=design.form, substeps=model.substeps,
                     every=every)


def coach_predictions(design: MPCDesign, model: LocalModel) -> tuple[CoachPrediction, ...]:
    """Every coach's local prediction (independent of the weights).

    Parameters
    ----------
    design : MPCDesign
        The design (horizons, form, outputs, neighbourhoods).
    model : LocalModel
        Its continuous model partitioned by coach.

    Returns
    -------
    tuple of CoachPrediction
        One per coach.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> c0, c1 = coach_predictions(d, m)
    >>> c0.states.tolist(), c0.outer.tolist(), c1.states.tolist(), c1.outer.tolist()
    ([0], [1], [1], [0])
    >>> # Sampled with z1 held: Ad = 1, Bd = 0.7·T = 0.35, E0 = 0.3·T = 0.15.
    >>> np.round([c0.Ad[0, 0], c0.Bd[0, 0], c0.E0[0, 0]], 4).tolist()
    [1.0, 0.35, 0.15]
    """
    return tuple(_coach_prediction(design, model, i, design.neighbourhoods[i])
                 for i in range(design.n_inputs))


@dataclass(frozen=True, kw_only=True)
class LocalIteration:
    """The stacked Jacobi iteration ξ^{l+1} = D0 ξ^l + D1 θ of local N-DMPC.

    Parameters
    ----------
    D0 : ndarray
        Iteration matrix on ξ = [U; X] (M·n plans, then P·nx predicted states).
    D1 : ndarray
        Map from θ = [x(k); u(k-1)] (u(k-1) unused in the u-form).
    n_plan : int
        M·n, the length of U in ξ.
    gains : tuple of ndarray
        K_i of every coach (M × P·|R_i|).
    coaches : tuple of CoachPrediction
        The local predictions.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> it = local_iteration(d, m)
    >>> it.n_plan, it.D0.shape, it.D1.shape  # xi = [u0, u1, z(k+1), z(k+2)]
    (2, (6, 6), (6, 4))
    >>> np.round(it.gains[0], 4).tolist()  # K_0 = (GᵀQG + R)⁻¹GᵀQ, G = [0.35, 0.7]
    [[0.4308, 0.8615]]
    """

    D0: Array
    D1: Array
    n_plan: int
    gains: tuple[Array, ...]
    coaches: tuple[CoachPrediction, ...]

    @property
    def rho(self) -> float:
        """ρ(D0): the iteration converges from any start iff it is < 1."""
        return spectral_radius(self.D0)


def local_iteration(design: MPCDesign, model: LocalModel,
                    coaches: Sequence[CoachPrediction] | None = None,
                    r: float | Array | None = None) -> LocalIteration:
    """D0, D1 of local N-DMPC (module docstring).

    Parameters
    ----------
    design : MPCDesign
        The design (weights q, r; ``r`` overrides its input weights).
    model : LocalModel
        Its continuous model partitioned by coach.
    coaches : sequence of CoachPrediction or None
        Precomputed :func:`coach_predictions`.
    r : float or ndarray or None
        Input weights (scalar: common) [per design unit²]; None: ``design.r``.

    Returns
    -------
    LocalIteration
        The iteration matrices.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> # By hand (β = 0.35, γ = 0.15, q = 2, r = 0.4): ρ(D0) = 2qβ²γ/(5qβ² + r) = 0.04523.
    >>> round(local_iteration(d, m).rho, 5)
    0.04523
    """
    coaches = coach_predictions(design, model) if coaches is None else tuple(coaches)
    n, nx = design.n_inputs, design.A.shape[0]
    P, M = design.prediction_horizon, design.control_horizon
    rr = design.r if r is None else np.broadcast_to(np.asarray(r, dtype=float), (n,))
    MN = M * n
    fine = P * model.substeps
    size = MN + fine * nx
    D0 = np.zeros((size, size))
    D1 = np.zeros((size, nx + n))
    moves = np.arange(M)
    steps = np.arange(fine)
    gains = []
    for c in coaches:
        i, nI = c.coach, c.inputs.size
        own_pos = c.own_input
        q = np.tile(design.q[c.rows], P)
        own_cols = moves * nI + own_pos                      # own moves in the local G
        Gii = c.y.G[:, own_cols]
        H = Gii.T @ (q[:, None] * Gii) + np.eye(M) * rr[i]
        K = np.linalg.solve(H, Gii.T * q[None, :])
        gains.append(K)
        ui = moves * n + i                                   # own moves in ξ
        xo = (MN + steps[:, None] * nx + c.outer[None, :]).ravel()  # X_O in ξ (step-major)
        uI = (moves[:, None] * n + c.inputs[None, :]).ravel()       # U_I in ξ (move-major)
        others = np.setdiff1d(np.arange(M * nI), own_cols)
        # U_i rows
        D0[np.ix_(ui, xo)] = -K @ c.y.Psi
        D0[np.ix_(ui, uI[others])] = -K @ c.y.G[:, others]
        D1[np.ix_(ui, c.states)] = -K @ c.y.Phi
        D1[np.ix_(ui, c.outer)] += -K @ c.y.Phi_o
        D1[np.ix_(ui, nx + c.inputs)] += -K @ c.y.Su
        # X_i rows: own-state trajectory with the new own plan
        xi = (MN + steps[:, None] * nx + c.own[None, :]).ravel()
        Gz_own = c.z.G[:, own_cols]
        D0[xi] = Gz_own @ D0[ui]
        D1[xi] = Gz_own @ D1[ui]
        D0[np.ix_(xi, xo)] += c.z.Psi
        D0[np.ix_(xi, uI[others])] += c.z.G[:, others]
        D1[np.ix_(xi, c.states)] += c.z.Phi
        D1[np.ix_(xi, c.outer)] += c.z.Phi_o
        D1[np.ix_(xi, nx + c.inputs)] += c.z.Su
    return LocalIteration(D0=D0, D1=D1, n_plan=MN, gains=tuple(gains), coaches=coaches)


def local_nash_gain(it: LocalIteration) -> Array:
    """(I - D0)⁻¹ D1: the fixed point ξ* = gain θ (plans, then predicted states).

    Parameters
    ----------
    it : LocalIteration
        The local iteration, with its matrices D0 and D1.

    Returns
    -------
    ndarray
        The gain from θ = [x(k); u(k-1)] to the fixed point ξ*.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> it = local_iteration(d, m)
    >>> g = local_nash_gain(it)
    >>> g.shape  # rows: the plans, then the trajectories; columns: x(k), u(k-1)
    (6, 4)
    >>> xi = g @ np.array([1.0, 1.0, 0.0, 0.0])  # both coaches at z = 1
    >>> bool(np.allclose(it.D0 @ xi + it.D1 @ np.array([1.0, 1.0, 0.0, 0.0]), xi))  # fixed point
    True
    >>> # By hand: u = -qβ(3a + 2γs)/(5qβ² + r), a = 1 + γ, s = a(2qβ² + r)/(5qβ² + r + 2qβ²γ).
    >>> np.round(xi[:2], 4).tolist()  # first moves [design units]
    [-1.564, -1.564]
    """
    return np.asarray(np.linalg.solve(np.eye(it.D0.shape[0]) - it.D0, it.D1), dtype=np.float64)


def local_closed_loop(design: MPCDesign, plan_gain: Array) -> Array:
    """Closed loop on the global discrete model when the plan is U = plan_gain θ.

    Parameters
    ----------
    design : MPCDesign
        The design (its A, B: the true discrete model).
    plan_gain : ndarray
        (M·n, nx + n): the plan's dependence on θ = [x(k); u(k-1)] (the
        first M·n rows of :func:`local_nash_gain`).

    Returns
    -------
    ndarray
        A_cl on x (u-form) or on [x; u(k-1)] (Δu-form).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> it = local_iteration(d, m)
    >>> A_cl = local_closed_loop(d, local_nash_gain(it)[:it.n_plan])
    >>> np.round(np.abs(np.linalg.eigvals(A_cl)), 4).tolist()  # stable
    [0.5712, 0.5242]
    """
    nx, n = design.A.shape[0], design.n_inputs
    K = prediction(design).first_move @ plan_gain
    Kx, Ku = K[:, :nx], K[:, nx:]
    A, B = design.A, design.B
    if design.form == "u":
        return np.asarray(A + B @ Kx, dtype=np.float64)
    top = np.hstack([A + B @ Kx, B @ (np.eye(n) + Ku)])
    bottom = np.hstack([Kx, np.eye(n) + Ku])
    return np.asarray(np.vstack([top, bottom]), dtype=np.float64)


def local_shift_matrix(design: MPCDesign, it: LocalIteration, substeps: int) -> Array:
    """Warm start of the next sample: ξ = [U; X] shifted by one sample.

    The plan as :func:`~trainctl.controllers.mpc.theory.iteration.shift_matrix`; the
    trajectories drop their first N fine samples and repeat the last one N
    times (as ``ndmpc-local`` does).

    Parameters
    ----------
    design : MPCDesign
        The design (horizons, inputs, form).
    it : LocalIteration
        The local iteration whose ξ is shifted.
    substeps : int
        N, the fine samples per controller sample.

    Returns
    -------
    ndarray
        The square matrix mapping ξ to the next sample's warm start.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> S = local_shift_matrix(d, local_iteration(d, m), 1)
    >>> S[2:].astype(int).tolist()  # z(k+1) <- z(k+2), z(k+2) <- z(k+2)
    [[0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1]]
    """
    from trainctl.controllers.mpc.theory.iteration import shift_matrix

    MN, size = it.n_plan, it.D0.shape[0]
    nx = design.A.shape[0]
    fine = (size - MN) // nx
    S = np.zeros((size, size))
    S[:MN, :MN] = shift_matrix(design)
    for tau in range(fine):
        src = min(tau + substeps, fine - 1)
        rows = MN + tau * nx + np.arange(nx)
        S[rows, MN + src * nx + np.arange(nx)] = 1.0
    return S


def local_finite_iteration_closed_loop(design: MPCDesign, it: LocalIteration, iterations: int,
                                       substeps: int = 1) -> Array:
    """Closed loop with L local Jacobi iterations per sample from the shifted previous ξ.

    The state is augmented with the previous [plans; trajectories]:
    [x; ξ_prev] (u-form) or [x; u(k-1); ξ_prev] (Δu-form), with
    ξ = D0^L S ξ_prev + Σ_{k<L} D0^k D1 θ, θ = [x; u(k-1)].

    Parameters
    ----------
    design : MPCDesign
        The design (its A, B: the true discrete model).
    it : LocalIteration
        The local iteration.
    iterations : int
        L >= 1.
    substeps : int
        N of the local model (the trajectories' fine samples per sample).

    Returns
    -------
    ndarray
        The augmented closed-loop matrix.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> it = local_iteration(d, m)
    >>> F = local_finite_iteration_closed_loop(d, it, 3)
    >>> F.shape  # [x; xi_prev]
    (8, 8)
    >>> # ρ(D0) = 0.045: three sweeps already give nearly the converged loop's 0.5712.
    >>> round(spectral_radius(F), 4)
    0.5713
    """
    nx, n = design.A.shape[0], design.n_inputs
    # D0 couples each coach with its neighbours only (0.8 % nonzero for the 204-vehicle chain,
    # 4682 rows): its powers are taken sparse, and Σ_{k<L} D0^k D1 by Horner on D1's columns
    # (dense matrix_power and the sum of powers: 51 s there; this: under a second).
    D0 = scipy.sparse.csr_array(it.D0)
    D1 = it.D1
    xi_prev = scipy.sparse.csr_array(local_shift_matrix(design, it, substeps))
    xi_theta = D1.copy()
    for _ in range(iterations):
        xi_prev = D0 @ xi_prev                                 # ξ from ξ_prev: D0^L S
    for _ in range(iterations - 1):
        xi_theta = D1 + D0 @ xi_theta                          # ξ from θ: Σ_{k<L} D0^k D1
    xi_prev = xi_prev.toarray()
    F = np.zeros((n, D0.shape[0]))
    F[:, :n] = np.eye(n)                                       # first move of every coach
    A, B = design.A, design.B
    if design.form == "u":
        Kx = F @ xi_theta[:, :nx]
        top = np.hstack([A + B @ Kx, B @ F @ xi_prev])
        return np.asarray(np.vstack([top, np.hstack([xi_theta[:, :nx], xi_prev])]),
                          dtype=np.float64)
    Kx, Ku = F @ xi_theta[:, :nx], F @ xi_theta[:, nx:]
    rows_x = np.hstack([A + B @ Kx, B @ (np.eye(n) + Ku), B @ F @ xi_prev])
    rows_u = np.hstack([Kx, np.eye(n) + Ku, F @ xi_prev])
    rows_p = np.hstack([xi_theta[:, :nx], xi_theta[:, nx:], xi_prev])
    return np.asarray(np.vstack([rows_x, rows_u, rows_p]), dtype=np.float64)


def local_threshold_weight(design: MPCDesign, model: LocalModel, *, low: float = 1e-12,
                           high: float = 1e12, rtol: float = 1e-6) -> float:
    """Smallest common input weight R* with ρ(D0_local) < 1, by bisection on log R.

    Parameters
    ----------
    design : MPCDesign
        The design (its own ``r`` is ignored).
    model : LocalModel
        Its partitioned continuous model.
    low, high : float
        Search bracket [per design unit²].
    rtol : float
        Relative accuracy of R*.

    Returns
    -------
    float
        R* (``low`` if converging already there; inf if diverging even at ``high``).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> # ρ(D0) = 2qβ²γ/(5qβ² + R) < 2γ/5 = 0.06 for every R: already converging at low.
    >>> local_threshold_weight(d, m)
    1e-12
    """
    coaches = coach_predictions(design, model)

    def excess(log_r: float) -> float:
        return local_iteration(design, model, coaches, r=10.0**log_r).rho - 1.0

    return log_bisection(excess, low, high, rtol)


def local_prediction_error(design: MPCDesign, model: LocalModel,
                           coaches: Sequence[CoachPrediction] | None = None) -> Array:
    """Size of the local discretisation: relative error of each coach's output prediction.

    Each coach's local prediction of its members' outputs is fed with the
    *true* outer trajectories (the global model's prediction) and compared
    with the global model's prediction of the same outputs, as maps from
    θ = [x; u(k-1)] and from the whole plan U:

        err_i = ‖[T_θ, T_U]_local - [T_θ, T_U]_global‖_F / ‖[T_θ, T_U]_global‖_F.

    It is zero when every neighbourhood is the whole train (and whenever the
    outer states stay constant over each sample).

    Parameters
    ----------
    design : MPCDesign
        The design.
    model : LocalModel
        Its partitioned continuous model.
    coaches : sequence of CoachPrediction or None
        Precomputed :func:`coach_predictions`.

    Returns
    -------
    ndarray
        The relative error err_i of each coach [-].

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.linalg import expm
    >>> # Two coaches, dz0/dt = 0.7 u0 + 0.3 z1 and dz1/dt = 0.7 u1 + 0.3 z0, sampled at T = 0.5 s;
    >>> # each neighbourhood is the coach alone, so z_j is its outer state.
    >>> Ac, Bc, T = np.array([[0.0, 0.3], [0.3, 0.0]]), 0.7 * np.eye(2), 0.5
    >>> Md = expm(np.block([[Ac, Bc], [np.zeros((2, 4))]]) * T)
    >>> d = MPCDesign(A=Md[:2, :2], B=Md[:2, 2:], C=np.eye(2), prediction_horizon=2,
    ...               control_horizon=1, form="u", q=np.full(2, 2.0), r=np.full(2, 0.4),
    ...               output_owner=(0, 1), neighbourhoods=((0,), (1,)))
    >>> m = local_model(d, Ac, Bc, T, (0, 1), hold="zoh")
    >>> # The zero-order hold of z1 over a sample misses its change: a few per cent;
    >>> # holding it linearly (first-order hold) is closer.
    >>> np.round(local_prediction_error(d, m), 4).tolist()
    [0.0383, 0.0383]
    >>> foh = local_model(d, Ac, Bc, T, (0, 1), hold="foh")
    >>> bool(np.all(local_prediction_error(d, foh) < local_prediction_error(d, m)))
    True
    """
    coaches = coach_predictions(design, model) if coaches is None else tuple(coaches)
    n, nx = design.n_inputs, design.A.shape[0]
    P, M = design.prediction_horizon, design.control_horizon
    pred = prediction(design)
    # Global state prediction on the fine grid x(τ) = Phi_x x + Su_x u(k-1) + G_x U.
    N = model.substeps
    Ah, Bh, E0, E1 = _discretise(model.A, model.B, np.zeros((nx, 0)), model.dt / N, "zoh")
    fine = _response(Ah, Bh, E0, E1, np.eye(nx), np.zeros((nx, 0)), P=P, M=M,
                     form=design.form, substeps=N, every=1)
    Phi_x, Su_x, G_x = fine.Phi, fine.Su, fine.G
    out = np.zeros(n)
    for c in coaches:
        ny = c.rows.size
        rows = (np.arange(P)[:, None] * design.C.shape[0] + c.rows[None, :]).ravel()
        glob = np.hstack([pred.Phi[rows], pred.Su[rows], pred.G[rows]])
        xo = (np.arange(P * N)[:, None] * nx + c.outer[None, :]).ravel()
        loc = np.zeros((P * ny, nx + n + M * n))
        loc[:, c.states] += c.y.Phi
        loc[:, c.outer] += c.y.Phi_o
        loc[:, nx + c.inputs] += c.y.Su
        loc[:, :nx] += c.y.Psi @ Phi_x[xo]
        loc[:, nx:nx + n] += c.y.Psi @ Su_x[xo]
        loc[:, nx + n:] += c.y.Psi @ G_x[xo]
        uI = (np.arange(M)[:, None] * n + c.inputs[None, :]).ravel()
        loc[:, nx + n + uI] += c.y.G
        scale = np.linalg.norm(glob)
        out[c.coach] = np.linalg.norm(loc - glob) / scale if scale > 0 else 0.0
    return out
