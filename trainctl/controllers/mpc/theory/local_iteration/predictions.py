# Each coach's local output prediction: its own moves and the exchanged outside trajectories.
"""Each coach's local output prediction (:func:`coach_predictions`, :func:`rows_response`)
and its error against the global model (:func:`local_prediction_error`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.mpc.theory.local_iteration.model import LocalModel, _discretise
from trainctl.controllers.mpc.theory.mpc import MPCDesign, prediction
from trainctl.exceptions import ModelError

__all__ = [
    "CoachPrediction", "LocalResponse", "coach_predictions", "local_prediction_error",
    "rows_response",
]

Array = NDArray[np.float64]
Index = NDArray[np.int64]


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
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
    >>> from trainctl.controllers.mpc.theory.local_iteration.model import local_model
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
