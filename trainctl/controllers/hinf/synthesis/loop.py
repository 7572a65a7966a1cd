# The closed loop of seed 003's H∞ consensus law, affine in its two gains.
"""The closed loop of the consensus law, affine in (κ_p, κ_c), with its scaled
disturbance channels and performance output (:func:`consensus_loop`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import control as ct
import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl.exceptions import DimensionError, ModelError

if TYPE_CHECKING:
    from trainctl.design.model import DesignModel
    from trainctl.models.graphs import CommunicationGraph

__all__ = [
    "CHANNEL_GROUPS", "DEFAULT_SCALING", "OUTPUTS", "OWN_SPEEDS", "ConsensusLoop", "consensus_loop",
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
