# Robust H∞ leader-following speed consensus (seed 003): the loop, its gains, per-channel γ.
"""The structured H∞ consensus law of seed 003 (spec §4.2) and the synthesis of its two gains.

The law (linear β) adds, per unit mass, to vehicle i's acceleration

    a_i = −κ_p b_i (v_i − v_d − n_0i) − κ_c Σ_j a_ij (v_i − v_j − n_ij)   [m/s²],

i.e. the force M_i a_i, with B = diag(b_i) the pinning matrix and
L = D − A the Laplacian of the communication graph
(:meth:`~trainctl.models.graphs.CommunicationGraph.pinning_matrix`,
:meth:`~trainctl.models.graphs.CommunicationGraph.laplacian`); n_0i is the noise on
the reference speed vehicle i receives, n_ij the noise on vehicle j's speed
as vehicle i receives it. On the design model (speed deviations v and
coupler elongations δ from the cruise at v_d, no dummy state) the closed
loop is affine in the gains:

    ẋ = (A₀ + κ_p A_p + κ_c A_c) x + (B_f + κ_p B_0 + κ_c B_L) w,
    A_p = −E B S_v,  A_c = −E L S_v,

with E the acceleration input (the design B times diag(M_i) / 1000, the
speed rows), S_v the speed rows of the state, and the disturbances

- ``f[i]``: a force disturbance on vehicle i as specific force [m/s²] (a
  grade, a resistance error), column E e_i;
- ``n0[i]``: noise on the reference speed vehicle i receives [m/s]
  (b_i > 0 only), column κ_p b_i E e_i;
- ``n[i,j]``: noise on vehicle j's speed as vehicle i receives it [m/s]
  (a_ij > 0 only), column κ_c a_ij E e_i.

The plant part A₀ is the design model's, with an optional gain-free
``local_feedback`` F_loc [N per unit of the state] closed around it on
current data: A₀ = A + B F_loc. The hinf family passes its resistance
feedforward's slope [diag(m_i c_i), 0] (c_i = a1_i + 2 a2_i v_d; each
vehicle's own Davis resistance at its measured speed), which cancels the
resistance damping of the design model, so that the loop synthesised here is
the one the family closes (:meth:`~trainctl.controllers.hinf.law.HinfLaw.resistance_feedback`);
without it A₀ keeps that damping (≈ 8.4e-4 1/s on heavy-haul-hinf).

Which part of the law acts on delayed data (``own_speed``, as the family's
setting): ``"delayed"``, the whole law (both sides of every difference
taken at the send time); ``"current"``, only the neighbours' speeds
κ_c Σ_j a_ij v_j (the own-speed parts −κ_p b_i v_i − κ_c d_i v_i act now,
and the reference's delay does not enter the deviation loop). The delay-free
loop is the same either way.

Performance output s: the tracking errors e_i = v_i − v_d [m/s]
(``output="tracking"``), or the disagreement (I − 11ᵀ/n) e
(``output="disagreement"``), which ignores a common speed error.

Scaling. ‖T_ws‖∞ < γ = 1 (the paper's requirement) means nothing until w
and s are scaled: each channel j enters as w_j = c_j w̃_j with c_j its
``scaling`` (the disturbance size taken as one unit: default 1 m/s² per
force channel and 1 m/s per noise channel) and s = s_0 s̃ with s_0
``output_scale`` (default 1 m/s), and γ is the gain w̃ → s̃ [-]. Whatever the
gains, the tracking error follows the reference noise at DC: a noise common
to every received reference (the broadcast command itself is wrong)
reaches every e_i with gain κ_p b̄/(κ_p b̄ + c) → 1 (c ≈ 8e-4 1/s, the
resistance's damping, b̄ the mass-weighted mean pinning weight; exactly 1
when the resistance feedforward cancels c), so the reference-noise channels
together have γ ≳ 1 for any κ_p (with the default scaling), and only the
disagreement output escapes that floor.

Synthesis (:func:`synthesise_gains`). For fixed gains the bounded-real
lemma is an SDP in P (:class:`~trainctl.analysis.hinf.BoundedRealProblem`,
built once with κ_p and κ_c as ``cp.Parameter``; the products κ·P are DPP).
Jointly in (P, κ_p, κ_c) the condition is bilinear (non-convex), so the
gains are searched outside the SDP: a coarse grid over the bounds, then
Nelder–Mead from the best grid point (scipy, within the bounds), each
point's γ certified by its own SDP solution and checked in floating point.
The result is a certified γ for the gains returned — not a proof that no
better gains exist in the bounds.

Delays (``tau_max``). The same search on the delay-dependent LMI of
:class:`~trainctl.analysis.delay_lmi.DelayHinfProblem` (with ``own_speed =
"delayed"`` the whole law delayed, ẋ = A₀x + (κ_pA_p + κ_cA_c)x(t − τ) +
B_w w; with ``"current"`` the own-speed parts undelayed, h = τ_max fixed,
the gains as parameters): γ is then certified for every delay in [0, τ_max]
(constant, or any time-varying τ(t) with ``delay="varying"``). Each SDP is
larger (3N + channels + outputs) and Jensen's inequality makes γ
conservative; the Padé-loop norms at delays in (0, τ_max] are reported
next to it as the independent check.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import control as ct
import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from trainctl.analysis.delay_lmi import DELAY_KINDS, DelayHinf, DelayHinfProblem
from trainctl.analysis.hinf import (
    BoundedRealProblem,
    BoundedRealResult,
    ChannelNorms,
    HinfNorm,
    channel_norms,
    hinf_norm,
)
from trainctl.exceptions import DimensionError, ModelError

if TYPE_CHECKING:
    from trainctl.design.model import DesignModel
    from trainctl.models.graphs import CommunicationGraph

__all__ = [
    "CHANNEL_GROUPS", "DEFAULT_SCALING", "OUTPUTS", "OWN_SPEEDS", "PADE_POINTS", "Certificate",
    "ConsensusLoop", "GainSynthesis", "certify_gains", "consensus_loop", "synthesise_gains",
]

Array = NDArray[np.float64]

CHANNEL_GROUPS = ("force", "reference", "link")
"""Disturbance groups: force per vehicle, reference-speed noise, neighbour-speed noise."""

UNITS = {"force": "m/s²", "reference": "m/s", "link": "m/s"}
"""The unit of each group's disturbance."""

DEFAULT_SCALING = {"force": 1.0, "reference": 1.0, "link": 1.0}
"""Disturbance taken as one unit, per group: 1 m/s² per force channel, 1 m/s per noise."""

OUTPUTS = ("tracking", "disagreement")
"""Performance outputs: the errors e, or (I − 11ᵀ/n) e."""

OWN_SPEEDS = ("delayed", "current")
"""What the delay acts on: the whole law, or the neighbours' speeds only (module docstring)."""

_KN = 1e3

PADE_POINTS = 4
"""Delays in (0, tau_max] at which :func:`synthesise_gains` checks the Padé-loop norm."""

Certificate = BoundedRealResult | DelayHinf
"""A γ certificate: delay-free (bounded-real lemma) or delay-dependent (LK)."""


@dataclass(frozen=True, kw_only=True, eq=False)
class ConsensusLoop:
    """The closed loop of the consensus law, affine in (κ_p, κ_c) (module docstring).

    Parameters
    ----------
    A0, Ap, Ac : ndarray
        (N, N): the plant [1/s], and the parts multiplied by κ_p and κ_c
        [-] (A_p, A_c per unit gain, the gains in [1/s]).
    Bf, Bp, Bc : ndarray
        (N, nw): the disturbance input at zero gains and its parts
        multiplied by κ_p and κ_c, on the scaled channels w̃.
    C : ndarray
        (ns, N): the scaled performance output s̃ = s / output_scale.
    channels : tuple of str
        Channel names (``f[i]``, ``n0[i]``, ``n[i,j]``, vehicles from 0).
    groups : tuple of str
        Each channel's group (:data:`CHANNEL_GROUPS`).
    scaling : ndarray
        (nw,) each channel's unit c_j [m/s² or m/s].
    outputs : tuple of str
        Output names.
    output : str
        ``"tracking"`` or ``"disagreement"``.
    output_scale : float
        s_0 [m/s].
    E : ndarray
        (N, n): the acceleration input (per-unit-mass law → state derivative).
    pinning, laplacian : ndarray
        (n, n): B and L of the graph.
    Kp_delayed, Kc_delayed : ndarray
        (n, N) [1/s per unit gain]: the specific-force law, per unit κ_p
        and κ_c, that acts on delayed data (``own_speed``); E K is the part
        of A_p, A_c that the delay moves.
    own_speed : str
        ``"delayed"`` or ``"current"`` (:data:`OWN_SPEEDS`).
    local_feedback : ndarray or None
        F_loc [N per unit of the state], (n, N), closed into A₀ (None:
        none).

    Examples
    --------
    The heavy-haul train has 4 cars (4 speeds and 3 coupler extensions); every
    car is pinned to the reference, so κ_p feeds back each car's own speed
    error: A_p is −1 on the speed diagonal and 0 on the couplers.

    >>> import numpy as np
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-hinf")
    >>> loop = consensus_loop(build_model(sc), sc.graph())
    >>> loop.n_states, loop.columns("force").tolist(), loop.units()[0]
    (7, [0, 1, 2, 3], '1 m/s²')
    >>> np.diag(loop.Ap).tolist()
    [-1.0, -1.0, -1.0, -1.0, 0.0, 0.0, 0.0]
    >>> A, Bw, C, D = loop.matrices(kp=0.1, kc=0.0)
    >>> bool(np.all(np.linalg.eigvals(A).real < 0))  # κ_p = 0.1 1/s stabilises
    True
    """

    A0: Array
    Ap: Array
    Ac: Array
    Bf: Array
    Bp: Array
    Bc: Array
    C: Array
    channels: tuple[str, ...]
    groups: tuple[str, ...]
    scaling: Array
    outputs: tuple[str, ...]
    output: str
    output_scale: float
    E: Array
    pinning: Array
    laplacian: Array
    Kp_delayed: Array
    Kc_delayed: Array
    own_speed: str = "delayed"
    local_feedback: Array | None = None

    @property
    def n_states(self) -> int:
        """N."""
        return int(self.A0.shape[0])

    def units(self) -> tuple[str, ...]:
        """Each channel's unit, e.g. ``"1 m/s²"`` (its scaling and group unit).

        Returns
        -------
        tuple of str
            One text per channel, in the order of :attr:`channels`: the
            channel's scaling c_j and its group's unit (m/s² or m/s).
        """
        return tuple(f"{c:g} {UNITS[g]}" for c, g in zip(self.scaling, self.groups, strict=True))

    def columns(self, group: str) -> Array:
        """Indices of the channels of one group (:data:`CHANNEL_GROUPS`).

        Parameters
        ----------
        group : {"force", "reference", "link"}
            The group.

        Returns
        -------
        ndarray of int
            The 0-based columns of B_w (positions in :attr:`channels`) of
            the group's channels, in order; empty when the loop has none.

        Raises
        ------
        ModelError
            If ``group`` is not in :data:`CHANNEL_GROUPS`.
        """
        if group not in CHANNEL_GROUPS:
            raise ModelError(f"ConsensusLoop.columns: 'group' must be one of {CHANNEL_GROUPS} "
                             f"(got {group!r}).")
        return np.array([j for j, g in enumerate(self.groups) if g == group], dtype=int)

    def matrices(self, kp: float, kc: float) -> tuple[Array, Array, Array, Array]:
        """(A, B_w, C, D) at the gains κ_p, κ_c [1/s], scaled channels.

        Parameters
        ----------
        kp : float
            κ_p, the gain on the reference-speed error [1/s].
        kc : float
            κ_c, the gain on the neighbours' speed differences [1/s].

        Returns
        -------
        A : ndarray
            (N, N) the delay-free closed loop A₀ + κ_p A_p + κ_c A_c [1/s].
        B_w : ndarray
            (N, nw) the input of the scaled disturbances w̃,
            B_f + κ_p B_p + κ_c B_c.
        C : ndarray
            (ns, N) the scaled performance output s̃ (:attr:`C`).
        D : ndarray
            (ns, nw) zeros.
        """
        A = self.A0 + kp * self.Ap + kc * self.Ac
        Bw = self.Bf + kp * self.Bp + kc * self.Bc
        return A, Bw, self.C, np.zeros((self.C.shape[0], Bw.shape[1]))

    def system(self, kp: float, kc: float) -> ct.StateSpace:
        """T_w̃s̃ at κ_p, κ_c as a continuous ``control.StateSpace`` with named signals.

        Parameters
        ----------
        kp : float
            κ_p, the gain on the reference-speed error [1/s].
        kc : float
            κ_c, the gain on the neighbours' speed differences [1/s].

        Returns
        -------
        control.StateSpace
            The delay-free loop of :meth:`matrices`, named
            ``"consensus_loop"``: inputs the channels, outputs the
            performance outputs (``e[i]`` or ``d[i]``).
        """
        A, Bw, C, D = self.matrices(kp, kc)
        return ct.ss(A, Bw, C, D, inputs=list(self.channels), outputs=list(self.outputs),
                     name="consensus_loop")

    def delayed_terms(self) -> tuple[Array, Array]:
        """(A_p, A_c) parts on delayed data, E K_p and E K_c, per unit gain [1/s per 1/s].

        Returns
        -------
        Apd : ndarray
            (N, N) E K_p: the part of A_p acting on delayed data (zero
            with ``own_speed = "current"``).
        Acd : ndarray
            (N, N) E K_c: the part of A_c acting on delayed data (the
            neighbours' speeds only with ``own_speed = "current"``).
        """
        return self.E @ self.Kp_delayed, self.E @ self.Kc_delayed

    def delay_matrices(self, kp: float, kc: float) -> tuple[Array, Array]:
        """(A, A_d) of the loop with the delay: ẋ = A x + A_d x(t − τ), A + A_d the delay-free loop.

        ``own_speed = "delayed"``: A = A₀, A_d = κ_pA_p + κ_cA_c (the whole
        law delayed); ``"current"``: only the neighbours' speeds delayed.

        Parameters
        ----------
        kp : float
            κ_p, the gain on the reference-speed error [1/s].
        kc : float
            κ_c, the gain on the neighbours' speed differences [1/s].

        Returns
        -------
        A : ndarray
            (N, N) the part of the loop on current data [1/s].
        A_d : ndarray
            (N, N) the part on data delayed by τ, κ_p E K_p + κ_c E K_c [1/s].
        """
        Apd, Acd = self.delayed_terms()
        Ad = kp * Apd + kc * Acd
        return self.A0 + kp * self.Ap + kc * self.Ac - Ad, Ad

    def delayed_system(self, kp: float, kc: float, tau: float, order: int = 8) -> ct.StateSpace:
        """T_w̃s̃ with the delayed part of the law delayed by τ [s] (order-q Padé approximants).

        The law's n delayed acceleration signals (K_p κ_p + K_c κ_c) x pass
        through :func:`~trainctl.analysis.delay.pade_loop` (N + n·q states);
        the disturbances enter the plant undelayed. A common delay on the
        noise channels multiplies their columns by e^{−jωτ}, a unitary
        factor, so it would not change any norm reported here.

        Parameters
        ----------
        kp : float
            κ_p, the gain on the reference-speed error [1/s].
        kc : float
            κ_c, the gain on the neighbours' speed differences [1/s].
        tau : float
            The delay τ [s], >= 0 (0: no Padé states).
        order : int
            Padé order q, >= 1.

        Returns
        -------
        control.StateSpace
            Continuous, N + n·q states (N when τ = 0), named
            ``"consensus_loop_delayed"``: inputs the channels (entering the
            plant states), outputs the performance outputs (read from the
            plant states).
        """
        from trainctl.analysis.delay import pade_loop

        A, _ = self.delay_matrices(kp, kc)
        K = kp * self.Kp_delayed + kc * self.Kc_delayed
        loop = pade_loop(A, self.E, K, tau, order)
        total = int(loop.nstates)
        _, Bw, C, _ = self.matrices(kp, kc)
        Bx = np.zeros((total, Bw.shape[1]))
        Bx[:self.n_states] = Bw
        Cx = np.zeros((C.shape[0], total))
        Cx[:, :self.n_states] = C
        return ct.ss(np.asarray(loop.A), Bx, Cx, np.zeros((C.shape[0], Bw.shape[1])),
                     inputs=list(self.channels), outputs=list(self.outputs),
                     name="consensus_loop_delayed")


def _scaling_vector(scaling: Mapping[str, float] | ArrayLike | None,
                    groups: Sequence[str]) -> Array:
    nw = len(groups)
    if scaling is None:
        scaling = DEFAULT_SCALING
    if isinstance(scaling, Mapping):
        unknown = set(scaling) - set(CHANNEL_GROUPS)
        if unknown:
            raise ModelError(f"consensus_loop: 'scaling' keys must be among {CHANNEL_GROUPS} "
                             f"(got {sorted(unknown)}).")
        merged = {**DEFAULT_SCALING, **{k: float(v) for k, v in scaling.items()}}
        vec = np.array([merged[g] for g in groups], dtype=float)
    else:
        vec = np.asarray(scaling, dtype=float).reshape(-1)
        if vec.shape != (nw,):
            raise DimensionError(f"consensus_loop: 'scaling' must be a mapping by group or one "
                                 f"number per channel ({nw} channels; got shape {vec.shape}).")
    if not (np.all(np.isfinite(vec)) and np.all(vec > 0)):
        raise ModelError(f"consensus_loop: every 'scaling' entry must be a finite number > 0 "
                         f"[m/s² or m/s] (got {vec.tolist()}).")
    return vec


def consensus_loop(model: DesignModel, graph: CommunicationGraph, *, output: str = "tracking",
                   scaling: Mapping[str, float] | ArrayLike | None = None,
                   output_scale: float = 1.0, local_feedback: ArrayLike | None = None,
                   own_speed: str = "delayed") -> ConsensusLoop:
    """The affine closed loop of the consensus law on a scenario's design model.

    Parameters
    ----------
    model : DesignModel
        The scenario's linear models (``model.design``: no dummy state,
        inputs [kN], speeds first).
    graph : CommunicationGraph
        Who hears whom (A, L) and the reference (B); its n must be the
        train's.
    output : {"tracking", "disagreement"}
        Performance output.
    scaling : mapping or array_like or None
        Units of the disturbance channels: by group (``{"force": m/s²,
        "reference": m/s, "link": m/s}``, missing groups default to 1) or
        one value per channel; None: :data:`DEFAULT_SCALING`.
    output_scale : float
        s_0 [m/s], > 0.
    local_feedback : array_like or None
        F_loc [N per unit of the state], (n, N): a gain-free feedback on
        current data closed into A₀ = A + B F_loc (the hinf family's
        resistance feedforward slope); None: A₀ = A.
    own_speed : {"delayed", "current"}
        Which part of the law a delay acts on (module docstring).

    Returns
    -------
    ConsensusLoop
        The loop, channels ``f[i]`` then ``n0[i]`` then ``n[i,j]``.

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-hinf")
    >>> loop = consensus_loop(build_model(sc), sc.graph())
    >>> loop.n_states, len(loop.channels), loop.channels[4], loop.channels[8]
    (7, 14, 'n0[0]', 'n[0,1]')
    """
    if output not in OUTPUTS:
        raise ModelError(f"consensus_loop: 'output' must be one of {OUTPUTS} (got {output!r}).")
    if not (isinstance(output_scale, int | float | np.floating) and math.isfinite(output_scale)
            and output_scale > 0):
        raise ModelError(f"consensus_loop: 'output_scale' must be a finite number > 0 m/s (got "
                         f"{output_scale!r}).")
    if own_speed not in OWN_SPEEDS:
        raise ModelError(f"consensus_loop: 'own_speed' must be one of {OWN_SPEEDS} (got "
                         f"{own_speed!r}).")
    sys = model.design
    A0 = np.asarray(sys.A, dtype=float)
    B = np.asarray(sys.B, dtype=float)
    n = model.n_vehicles
    N = A0.shape[0]
    if graph.n != n:
        raise DimensionError(f"consensus_loop: the graph must have one node per vehicle "
                             f"(n = {n}; got a graph on {graph.n}).")
    F_loc: Array | None = None
    if local_feedback is not None:
        F_loc = np.asarray(local_feedback, dtype=float)
        if F_loc.shape != (n, N) or not np.all(np.isfinite(F_loc)):
            raise DimensionError(f"consensus_loop: 'local_feedback' must be a finite ({n}, {N}) "
                                 f"matrix in N per unit of the state (got shape "
                                 f"{F_loc.shape}).")
        A0 = A0 + B @ F_loc / _KN                   # the design B takes kN
    mass = np.asarray(model.train.mass, dtype=float)
    E = B @ np.diag(mass) / _KN                     # acceleration [m/s²] → state derivative
    Sv = np.eye(n, N)                               # speeds are the first n states
    Pin = np.asarray(graph.pinning_matrix(), dtype=float)
    Lap = np.asarray(graph.laplacian(), dtype=float)
    adj = np.asarray(graph.adjacency, dtype=float)
    Ap = -E @ Pin @ Sv
    Ac = -E @ Lap @ Sv
    if own_speed == "delayed":
        Kp_d, Kc_d = -Pin @ Sv, -Lap @ Sv
    else:
        Kp_d, Kc_d = np.zeros((n, N)), adj @ Sv

    channels: list[str] = []
    groups: list[str] = []
    cols: list[tuple[Array, Array, Array]] = []   # (at zero gains, per κ_p, per κ_c)
    zero = np.zeros(N)
    for i in range(n):
        channels.append(f"f[{i}]")
        groups.append("force")
        cols.append((E[:, i], zero, zero))
    for i in range(n):
        if Pin[i, i] > 0:
            channels.append(f"n0[{i}]")
            groups.append("reference")
            cols.append((zero, Pin[i, i] * E[:, i], zero))
    for i in range(n):
        for j in range(n):
            if adj[i, j] > 0:
                channels.append(f"n[{i},{j}]")
                groups.append("link")
                cols.append((zero, zero, adj[i, j] * E[:, i]))
    scale = _scaling_vector(scaling, groups)
    Bf, Bp, Bc = (np.column_stack([c[k] for c in cols]) * scale[None, :] for k in range(3))
    if output == "tracking":
        C = Sv.copy()
        outputs = tuple(f"e[{i}]" for i in range(n))
    else:
        C = (np.eye(n) - np.ones((n, n)) / n) @ Sv
        outputs = tuple(f"d[{i}]" for i in range(n))
    return ConsensusLoop(A0=A0, Ap=Ap, Ac=Ac, Bf=Bf, Bp=Bp, Bc=Bc, C=C / float(output_scale),
                         channels=tuple(channels), groups=tuple(groups), scaling=scale,
                         outputs=outputs, output=output, output_scale=float(output_scale),
                         E=E, pinning=Pin, laplacian=Lap, Kp_delayed=Kp_d, Kc_delayed=Kc_d,
                         own_speed=own_speed, local_feedback=F_loc)


@dataclass(frozen=True, kw_only=True, eq=False)
class GainSynthesis:
    """The gains of the consensus law found by the certified search, and their γ.

    Parameters
    ----------
    kp, kc : float
        κ_p, κ_c [1/s].
    certificate : BoundedRealResult or DelayHinf
        The certificate of T_w̃s̃ (all channels) at the gains, bounded-real
        (delay-free) or Lyapunov–Krasovskii (``tau_max``):
        ``certificate.gamma`` is the certified γ [-].
    channel_certificates : dict of str to BoundedRealResult or DelayHinf
        Per channel (input j → all outputs), its own SDP; where that SDP
        certifies nothing or more than the all-channel certificate, the
        latter (valid for every subset of the channels: its LMI restricted
        to them is a principal submatrix), said in its message and in
        ``notes``.
    group_certificates : dict of str to BoundedRealResult or DelayHinf
        Per group of :data:`CHANNEL_GROUPS` present, the same way.
    norm : HinfNorm
        ‖T_w̃s̃‖∞ at the gains by python-control and the level set
        (independent of the LMI).
    channels : ChannelNorms
        SISO norms channel × output at the gains (independent of the LMI).
    kp_grid, kc_grid : ndarray
        The coarse grid [1/s].
    gamma_grid : ndarray
        Certified γ on the grid, (len(kp_grid), len(kc_grid)) (inf where no
        certificate: an unstable loop or solver trouble).
    evaluations : int
        SDP solves of the search.
    trouble : tuple of str
        Every search point whose solve was not ``optimal``, and every
        certificate at the gains found (all channels, per channel, per
        group) that was not ``optimal`` or needed the fallback solver
        (status, gains and the solver's message).
    scaling, units : tuple
        Each channel's unit c_j and its text (e.g. ``"1 m/s²"``).
    output, output_scale : str, float
        Performance output and s_0 [m/s].
    bounds : ((float, float), (float, float))
        κ_p and κ_c bounds [1/s].
    search_time : float
        Wall time of grid and refinement [s].
    tau_max : float or None
        The delay range [0, tau_max] [s] the certificates cover (None:
        delay-free, bounded-real lemma).
    delay : str
        ``"constant"`` or ``"varying"`` (with ``tau_max``).
    pade_norms : tuple of (float, HinfNorm)
        With ``tau_max``: the norm of the Padé loop (order 8) at delays in
        (0, tau_max], independent of the LMI.
    notes : tuple of str
        Remarks (a gain on its bound, the refinement's stop).

    Examples
    --------
    The result of :func:`certify_gains` at one pair of gains:

    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-hinf")
    >>> res = certify_gains(consensus_loop(build_model(sc), sc.graph()), 1.0, 0.0)
    >>> res.kp, res.kc, res.evaluations, res.tau_max
    (1.0, 0.0, 1, None)
    >>> round(res.gamma, 2)  # certified γ [-], equal to the norm up to the SDP tolerance
    1.41
    >>> round(res.norm.norm, 2), res.consistent
    (1.41, True)
    """

    kp: float
    kc: float
    certificate: Certificate
    channel_certificates: dict[str, Certificate]
    group_certificates: dict[str, Certificate]
    norm: HinfNorm
    channels: ChannelNorms
    kp_grid: Array
    kc_grid: Array
    gamma_grid: Array
    evaluations: int
    trouble: tuple[str, ...]
    scaling: tuple[float, ...]
    units: tuple[str, ...]
    output: str
    output_scale: float
    bounds: tuple[tuple[float, float], tuple[float, float]]
    search_time: float
    tau_max: float | None = None
    delay: str = "constant"
    pade_norms: tuple[tuple[float, HinfNorm], ...] = field(default=())
    notes: tuple[str, ...] = field(default=())

    @property
    def gamma(self) -> float:
        """The certified γ of all channels together [-]."""
        return self.certificate.gamma

    @property
    def consistent(self) -> bool:
        """The independent norms (delay-free, per channel, Padé) do not exceed the certified γ."""
        tol = 1e-9
        if not self.norm.norm <= self.gamma * (1 + tol):
            return False
        if any(not r.norm <= self.gamma * (1 + tol) for _, r in self.pade_norms):
            return False
        for j, name in enumerate(self.channels.inputs):
            cert = self.channel_certificates.get(name)
            if cert is not None and not self.channels.per_input[j] <= cert.gamma * (1 + tol):
                return False
        return True

    def to_dict(self) -> dict[str, object]:
        """JSON-safe summary (per channel: certified γ, independent norm, unit).

        Returns
        -------
        dict
            The gains ``kp``, ``kc`` [1/s], the certified ``gamma`` [-],
            the ``certificate`` and ``norm`` as dicts, ``channels`` (per
            channel: name, unit, certified γ, independent norm), ``groups``
            (each group's certificate as a dict), the search's
            ``evaluations``, ``trouble``, ``bounds`` [1/s] and
            ``search_time`` [s], ``output``, ``output_scale`` [m/s],
            ``tau_max`` [s], ``delay``, ``pade_norms`` (pairs of delay [s]
            and norm dict), ``consistent`` and ``notes``; non-finite γ and
            norms as None.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        per = []
        for j, name in enumerate(self.channels.inputs):
            cert = self.channel_certificates.get(name)
            per.append({"channel": name, "unit": self.units[j],
                        "gamma_certified": f(cert.gamma) if cert else None,
                        "norm": f(float(self.channels.per_input[j]))})
        return {"kp": self.kp, "kc": self.kc, "gamma": f(self.gamma),
                "certificate": self.certificate.to_dict(), "norm": self.norm.to_dict(),
                "channels": per,
                "groups": {g: c.to_dict() for g, c in self.group_certificates.items()},
                "evaluations": self.evaluations, "trouble": list(self.trouble),
                "output": self.output, "output_scale": self.output_scale,
                "bounds": [list(b) for b in self.bounds], "search_time": self.search_time,
                "tau_max": self.tau_max, "delay": self.delay,
                "pade_norms": [[tau, r.to_dict()] for tau, r in self.pade_norms],
                "consistent": self.consistent, "notes": list(self.notes)}


def _axis(lo: float, hi: float, k: int) -> Array:
    if lo > 0 and hi / lo > 10:
        return np.geomspace(lo, hi, k)
    return np.linspace(lo, hi, k)


def _check_bounds(b: Sequence[float], name: str) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in b)
    except (TypeError, ValueError):
        raise ModelError(f"synthesise_gains: '{name}' must be two numbers (lo, hi) in 1/s "
                         f"(got {b!r}).") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
        raise ModelError(f"synthesise_gains: '{name}' must satisfy 0 <= lo <= hi, finite, in "
                         f"1/s (got {b!r}).")
    return lo, hi


def _problem(loop: ConsensusLoop, columns: Array | None, solver: str | None,
             reference: tuple[float, float], tau_max: float | None, delay: str
             ) -> BoundedRealProblem | DelayHinfProblem:
    cols = slice(None) if columns is None else columns
    ref = {"kp": reference[0], "kc": reference[1]}
    if tau_max is None:
        return BoundedRealProblem(
            loop.A0, loop.Bf[:, cols], loop.C, None, A_terms={"kp": loop.Ap, "kc": loop.Ac},
            B_terms={"kp": loop.Bp[:, cols], "kc": loop.Bc[:, cols]}, reference=ref,
            solver=solver)
    Apd, Acd = loop.delayed_terms()
    return DelayHinfProblem(
        loop.A0, np.zeros_like(loop.A0), loop.Bf[:, cols], loop.C, None, tau_max,
        A_terms={"kp": loop.Ap - Apd, "kc": loop.Ac - Acd}, A_d_terms={"kp": Apd, "kc": Acd},
        B_terms={"kp": loop.Bp[:, cols], "kc": loop.Bc[:, cols]}, reference=ref, delay=delay,
        solver=solver)


def _not_hurwitz(loop: ConsensusLoop, kp: float, kc: float, tau_max: float | None,
                 delay: str) -> Certificate | None:
    """A γ = inf answer without a solve when the delay-free loop is not Hurwitz (else None).

    No SDP can certify such a loop (delay-free, or with delays from 0 up),
    and the solvers take long to say so (the bounded-real problem then also
    tries its SCS fallback).
    """
    A = loop.matrices(kp, kc)[0]
    alpha = float(np.max(np.linalg.eigvals(A).real))
    if alpha < -1e-9 * max(1.0, float(np.abs(A).max())):
        return None
    text = (f"not solved: the delay-free loop is not Hurwitz at kp={kp:.6g} kc={kc:.6g} "
            f"(max Re λ = {alpha:.3g} 1/s)")
    theta = {"kp": float(kp), "kc": float(kc)}
    if tau_max is None:
        return BoundedRealResult(gamma=math.inf, gamma_solver=math.nan, P=None,
                                 status="not_hurwitz", solver="none", solve_time=0.0,
                                 parameters=theta, message=text)
    return DelayHinf(gamma=math.inf, gamma_solver=math.nan, tau_max=float(tau_max), delay=delay,
                     status="not_hurwitz", solver="none", solve_time=0.0, parameters=theta,
                     message=text)


def synthesise_gains(loop: ConsensusLoop, *, kp_bounds: Sequence[float] = (0.01, 1.0),
                     kc_bounds: Sequence[float] = (0.0, 1.0), grid: tuple[int, int] = (7, 7),
                     refine: bool = True, max_evaluations: int = 60,
                     tau_max: float | None = None, delay: str = "constant",
                     solver: str | None = None) -> GainSynthesis:
    """κ_p, κ_c within the bounds that minimise the certified γ of T_w̃s̃ (module docstring).

    One :class:`~trainctl.analysis.hinf.BoundedRealProblem` (κ_p, κ_c as
    ``cp.Parameter``) is compiled once and re-solved at every point of a
    ``grid`` over the bounds (geometric spacing when lo > 0 and hi/lo > 10),
    then, with ``refine``, by Nelder–Mead (scipy, bounded, on coordinates
    normalised to the bounds) from the best grid point, at most
    ``max_evaluations`` solves. The problem is bilinear in (P, κ): the
    result is the best *certified* point found, not a global optimum. At
    the gains found, every channel and every group gets its own
    certificate, and the norm is recomputed independently of the LMI
    (:func:`~trainctl.analysis.hinf.hinf_norm`,
    :func:`~trainctl.analysis.hinf.channel_norms`).

    Parameters
    ----------
    loop : ConsensusLoop
        From :func:`consensus_loop`.
    kp_bounds, kc_bounds : (float, float)
        [1/s], 0 <= lo <= hi.
    grid : (int, int)
        Grid points per gain, >= 1 each.
    refine : bool
        Run the local refinement.
    max_evaluations : int
        Solves of the refinement.
    tau_max : float or None
        None: the delay-free loop (bounded-real lemma). A number h [s]: the
        law delayed as the loop's ``own_speed`` says (the whole law:
        ẋ = A₀x + (κ_pA_p + κ_cA_c)x(t − τ) + B_w w), and γ certified for
        every delay in [0, h] by the Lyapunov–Krasovskii LMI
        (:class:`~trainctl.analysis.delay_lmi.DelayHinfProblem`, h fixed,
        κ_p and κ_c parameters); the independent checks then add the
        Padé-loop norms (order 8) at delays in (0, h].
    delay : {"constant", "varying"}
        With ``tau_max``: constant delays or any time-varying τ(t) ∈ [0, h].
    solver : str or None
        cvxpy solver (None: Clarabel, SCS as fallback for the delay-free SDP).

    Returns
    -------
    GainSynthesis
        The gains, the certified γ and the independent checks.

    Raises
    ------
    SolverError
        No point of the search has a certificate (every loop unstable, or
        the solver failed everywhere; the grid statuses are in the message).

    Examples
    --------
    A coarse search over κ_p alone (κ_c fixed at 0): three grid points
    0.01, 0.1 and 1 1/s (geometric, since hi/lo > 10). The largest gain damps
    the disturbances most.

    >>> import numpy as np
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-hinf")
    >>> loop = consensus_loop(build_model(sc), sc.graph())
    >>> res = synthesise_gains(loop, kc_bounds=(0.0, 0.0), grid=(3, 1), refine=False)
    >>> res.kp_grid.tolist(), res.kp, res.evaluations
    ([0.01, 0.1, 1.0], 1.0, 3)
    >>> np.round(res.gamma_grid[:, 0], 1).tolist()  # certified γ per grid point [-]
    [92.3, 10.0, 1.4]
    """
    from trainctl.exceptions import SolverError

    kp_lo, kp_hi = _check_bounds(kp_bounds, "kp_bounds")
    kc_lo, kc_hi = _check_bounds(kc_bounds, "kc_bounds")
    if (len(grid) != 2 or any(isinstance(g, bool) or not isinstance(g, int | np.integer)
                              or g < 1 for g in grid)):
        raise ModelError(f"synthesise_gains: 'grid' must be two integers >= 1 (got {grid!r}).")
    if tau_max is not None and not (isinstance(tau_max, int | float | np.floating)
                                    and math.isfinite(tau_max) and tau_max >= 0):
        raise ModelError(f"synthesise_gains: 'tau_max' must be None or a finite number >= 0 s "
                         f"(got {tau_max!r}).")
    if delay not in DELAY_KINDS:
        raise ModelError(f"synthesise_gains: 'delay' must be one of {DELAY_KINDS} (got "
                         f"{delay!r}).")
    h = None if tau_max is None else float(tau_max)
    start = time.perf_counter()
    mid = (0.5 * (kp_lo + kp_hi), 0.5 * (kc_lo + kc_hi))
    problem = _problem(loop, None, solver, mid, h, delay)
    cache: dict[tuple[float, float], Certificate] = {}
    trouble: list[str] = []

    def evaluate(kp: float, kc: float) -> Certificate:
        key = (round(kp, 12), round(kc, 12))
        if key not in cache:
            skipped = _not_hurwitz(loop, kp, kc, h, delay)
            res = skipped if skipped is not None else problem.solve(kp=kp, kc=kc)
            cache[key] = res
            if skipped is None and (res.status != "optimal" or "after" in res.message):
                trouble.append(f"kp={kp:.6g} kc={kc:.6g}: {res.status}: {res.message}")
        return cache[key]

    kp_grid = _axis(kp_lo, kp_hi, int(grid[0]))
    kc_grid = _axis(kc_lo, kc_hi, int(grid[1]))
    gamma_grid = np.array([[evaluate(float(a), float(b)).gamma for b in kc_grid]
                           for a in kp_grid])
    if not np.any(np.isfinite(gamma_grid)):
        raise SolverError(f"synthesise_gains: no gains on the grid are certified (every loop "
                          f"unstable or the solver failed); statuses: "
                          f"{sorted({r.status for r in cache.values()})}.")
    i, j = np.unravel_index(int(np.argmin(gamma_grid)), gamma_grid.shape)
    best = (float(kp_grid[i]), float(kc_grid[j]))
    notes: list[str] = []
    if refine and (kp_hi > kp_lo or kc_hi > kc_lo):
        span = np.array([kp_hi - kp_lo, kc_hi - kc_lo])
        low = np.array([kp_lo, kc_lo])
        active = span > 0
        finite = gamma_grid[np.isfinite(gamma_grid)]
        penalty = 1e6 * float(finite.max())

        def to_gains(u: Array) -> tuple[float, float]:
            full = low.copy()
            full[active] = low[active] + np.clip(u, 0.0, 1.0) * span[active]
            return float(full[0]), float(full[1])

        def objective(u: Array) -> float:
            g = evaluate(*to_gains(u)).gamma
            return g if math.isfinite(g) else penalty

        u0 = (np.array(best) - low)[active] / span[active]
        steps = np.array([1.0 / max(int(grid[0]) - 1, 1), 1.0 / max(int(grid[1]) - 1, 1)])
        steps = steps[active]
        simplex = [u0] + [u0 + np.where(np.arange(u0.size) == k,
                                        steps[k] * (1 if u0[k] + steps[k] <= 1 else -1), 0.0)
                          for k in range(u0.size)]
        res = scipy.optimize.minimize(
            objective, u0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * int(active.sum()),
            options={"initial_simplex": np.array(simplex), "maxfev": int(max_evaluations),
                     "xatol": 1e-4, "fatol": 1e-7 * float(gamma_grid[i, j])})
        cand = to_gains(np.asarray(res.x))
        if evaluate(*cand).gamma < evaluate(*best).gamma:
            best = cand
        if not res.success:
            notes.append(f"Nelder–Mead stopped: {res.message}")
    search_time = time.perf_counter() - start
    skipped = sum(r.status == "not_hurwitz" for r in cache.values())
    if skipped:
        notes.append(f"{skipped} search point(s) not solved: the delay-free loop is not Hurwitz "
                     "there")
    kp, kc = best
    if (kp_lo < kp_hi and kp in (kp_lo, kp_hi)) or (kc_lo < kc_hi and kc in (kc_lo, kc_hi)):
        notes.append("a gain sits on its bound: wider bounds may lower γ")
    return _at_gains(loop, best, evaluate(kp, kc), solver=solver, tau_max=h, delay=delay,
                     kp_grid=kp_grid, kc_grid=kc_grid, gamma_grid=gamma_grid,
                     evaluations=len(cache), trouble=trouble,
                     bounds=((kp_lo, kp_hi), (kc_lo, kc_hi)), search_time=search_time,
                     notes=notes)


def _at_gains(loop: ConsensusLoop, gains: tuple[float, float], certificate: Certificate, *,
              solver: str | None, tau_max: float | None, delay: str, kp_grid: Array,
              kc_grid: Array, gamma_grid: Array, evaluations: int, trouble: list[str],
              bounds: tuple[tuple[float, float], tuple[float, float]], search_time: float,
              notes: list[str]) -> GainSynthesis:
    """Per-channel and per-group certificates and the independent norms at the gains found."""
    kp, kc = gains
    h = tau_max
    skipped = _not_hurwitz(loop, kp, kc, h, delay)

    def solve(columns: Array) -> Certificate:
        if skipped is not None:
            return skipped
        return _problem(loop, columns, solver, gains, h, delay).solve(kp=kp, kc=kc)

    channel_certs: dict[str, Certificate] = {}
    for jj, name in enumerate(loop.channels):
        channel_certs[name] = solve(np.array([jj]))
    group_certs: dict[str, Certificate] = {}
    for group in CHANNEL_GROUPS:
        cols = loop.columns(group)
        if cols.size:
            group_certs[group] = solve(cols)
    if skipped is not None:
        notes.append(skipped.message)
    for label, cert in [("all channels", certificate), *channel_certs.items(),
                        *((f"group {g}", c) for g, c in group_certs.items())]:
        if cert.status == "not_hurwitz":
            continue
        if cert.status != "optimal" or "after" in cert.message:
            trouble.append(f"{label} at kp={kp:.6g} kc={kc:.6g}: {cert.status}: "
                           f"{cert.message}")

    def bounded(label: str, cert: Certificate) -> Certificate:
        # the all-channel LMI restricted to some channels is a principal submatrix of it,
        # so its solution certifies every subset with the same γ
        if not certificate.certified or cert.gamma <= certificate.gamma:
            return cert
        notes.append(f"{label}: its own SDP gave {cert.gamma:.6g} ({cert.status}); bounded by "
                     f"the all-channel certificate {certificate.gamma:.6g}")
        return dataclasses.replace(
            certificate, message=f"bounded by the all-channel certificate (γ "
            f"{certificate.gamma:.6g}); its own SDP: {cert.status}: {cert.message}")

    channel_certs = {k: bounded(f"channel {k}", c) for k, c in channel_certs.items()}
    group_certs = {k: bounded(f"group {k}", c) for k, c in group_certs.items()}
    sys = loop.system(kp, kc)
    norm = hinf_norm(sys)
    chans = channel_norms(sys)
    pade: list[tuple[float, HinfNorm]] = []
    if h is not None and h > 0:
        for tau in np.linspace(0.0, h, PADE_POINTS + 1)[1:]:
            pade.append((float(tau), hinf_norm(loop.delayed_system(kp, kc, float(tau)))))
    return GainSynthesis(kp=kp, kc=kc, certificate=certificate,
                         channel_certificates=channel_certs, group_certificates=group_certs,
                         norm=norm, channels=chans, kp_grid=kp_grid, kc_grid=kc_grid,
                         gamma_grid=gamma_grid, evaluations=evaluations,
                         trouble=tuple(dict.fromkeys(trouble)),
                         scaling=tuple(float(x) for x in loop.scaling), units=loop.units(),
                         output=loop.output, output_scale=loop.output_scale,
                         bounds=bounds, search_time=search_time, tau_max=h, delay=delay,
                         pade_norms=tuple(pade), notes=tuple(notes))


def certify_gains(loop: ConsensusLoop, kp: float, kc: float, *, tau_max: float | None = None,
                  delay: str = "constant", solver: str | None = None) -> GainSynthesis:
    """The certified γ of given gains, with the same checks as :func:`synthesise_gains`.

    No search: one SDP for all channels, one per channel and one per group
    at (κ_p, κ_c), and the independent norms (delay-free, and the Padé
    loops with ``tau_max``). A loop that no SDP certifies (unstable, or the
    solver failed) has γ = inf, its status in ``trouble``; nothing raises.

    Parameters
    ----------
    loop : ConsensusLoop
        From :func:`consensus_loop`.
    kp, kc : float
        κ_p, κ_c [1/s], finite, >= 0.
    tau_max : float or None
        As in :func:`synthesise_gains`.
    delay : {"constant", "varying"}
        As in :func:`synthesise_gains`.
    solver : str or None
        cvxpy solver.

    Returns
    -------
    GainSynthesis
        With a one-point grid (``bounds`` the gains themselves, ``evaluations`` 1).

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-hinf")
    >>> res = certify_gains(consensus_loop(build_model(sc), sc.graph()), 0.1, 0.0)
    >>> res.norm.norm <= res.gamma <= res.norm.norm * (1 + 1e-4), res.consistent
    (True, True)
    """
    for name, value in (("kp", kp), ("kc", kc)):
        if not (isinstance(value, int | float | np.floating) and not isinstance(value, bool)
                and math.isfinite(value) and value >= 0):
            raise ModelError(f"certify_gains: '{name}' must be a finite number >= 0 1/s (got "
                             f"{value!r}).")
    if tau_max is not None and not (isinstance(tau_max, int | float | np.floating)
                                    and math.isfinite(tau_max) and tau_max >= 0):
        raise ModelError(f"certify_gains: 'tau_max' must be None or a finite number >= 0 s "
                         f"(got {tau_max!r}).")
    if delay not in DELAY_KINDS:
        raise ModelError(f"certify_gains: 'delay' must be one of {DELAY_KINDS} (got {delay!r}).")
    h = None if tau_max is None else float(tau_max)
    gains = (float(kp), float(kc))
    start = time.perf_counter()
    certificate = (_not_hurwitz(loop, gains[0], gains[1], h, delay)
                   or _problem(loop, None, solver, gains, h, delay).solve(kp=gains[0],
                                                                          kc=gains[1]))
    elapsed = time.perf_counter() - start
    return _at_gains(loop, gains, certificate, solver=solver, tau_max=h, delay=delay,
                     kp_grid=np.array([gains[0]]), kc_grid=np.array([gains[1]]),
                     gamma_grid=np.array([[certificate.gamma]]), evaluations=1, trouble=[],
                     bounds=((gains[0], gains[0]), (gains[1], gains[1])), search_time=elapsed,
                     notes=[])
