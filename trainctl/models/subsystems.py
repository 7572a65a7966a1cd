# Seed 000's per-coach subsystems, their interconnection and neighbourhoods.
"""Per-coach subsystems z_i = [v_i; delta_i] and neighbourhood models.

Li & Zheng (2015, eqs. 12.12–12.17) write the train as n coupled subsystems

    dz_i/dt = A_ii z_i + B_i u_i + A_{i,i-1} z_{i-1} + A_{i,i+1} z_{i+1},  y_i = C_i z_i,

with z_i = [v_i; delta_i], the speed deviation of coach i and the elongation
of the coupler *behind* it. The last coach has no rear coupler; the book gives
it a dummy elongation with all related parameters zero (eq. 12.16). Here the
dummy can be kept (``dummy_state=True``, the book's form) or dropped, in which
case the last subsystem has the single state v_{n-1}.

The blocks are built from each coach's own parameters (its mass, resistance
and the couplers on either side), independently of the monolithic model in
:mod:`trainctl.models.linear`; the tests check that the two agree.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import control as ct
import numpy as np
from numpy.typing import NDArray
from scipy.linalg import block_diag

from trainctl.exceptions import ModelError
from trainctl.models.linear import resistance_damping
from trainctl.models.train import Train

__all__ = [
    "CoachSubsystems",
    "Neighbourhood",
    "coach_subsystems",
    "neighbourhood",
    "neighbourhoods",
]


@dataclass(frozen=True, kw_only=True)
class CoachSubsystems:
    """The per-coach blocks of seed 000's decomposition.

    Parameters
    ----------
    A : dict of (int, int) to ndarray
        ``A[i, i]`` local dynamics; ``A[i, j]`` (|i-j| = 1) coupling from z_j.
    B : tuple of ndarray
        Input columns B_i [1/kg], u_i in N.
    C : tuple of ndarray
        Output rows C_i (speed of coach i).
    state_labels : tuple of tuple of str
        Names of each subsystem's states.

    Examples
    --------
    >>> from trainctl.models.train import Train
    >>> from trainctl.models.vehicle import Coupler, Vehicle
    >>> # Three 100 t coaches on 10⁶ N/m couplers, no resistance: k/m = 10 1/s².
    >>> car = Vehicle(mass=1e5, a0=0.0, a1=0.0, a2=0.0)
    >>> train = Train(vehicles=(car, car, car), couplers=(Coupler(stiffness=1e6),) * 2)
    >>> sub = coach_subsystems(train, 20.0)
    >>> sub.n_coaches, sub.state_labels[1]
    (3, ('v[1]', 'delta[1]'))
    >>> sub.A[1, 0].tolist()  # coach 0's coupler pulls coach 1 forward: +k/m on delta[0]
    [[0.0, 10.0], [0.0, 0.0]]
    >>> float(sub.B[0][0, 0])  # 1/m [1/kg]
    1e-05
    >>> A, B, C = sub.global_matrices()
    >>> A.shape, sub.block(0, 2).tolist()  # coaches 0 and 2 do not touch
    ((6, 6), [[0.0, 0.0], [0.0, 0.0]])
    """

    A: dict[tuple[int, int], NDArray[np.float64]]
    B: tuple[NDArray[np.float64], ...]
    C: tuple[NDArray[np.float64], ...]
    state_labels: tuple[tuple[str, ...], ...]

    @property
    def n_coaches(self) -> int:
        """Number of subsystems."""
        return len(self.B)

    def block(self, i: int, j: int) -> NDArray[np.float64]:
        """Block A_ij (zeros when coach j does not act on coach i).

        Parameters
        ----------
        i : int
            The coach acted on (0-based row block), 0 <= i < n_coaches.
        j : int
            The coach acting (0-based column block), 0 <= j < n_coaches.

        Returns
        -------
        ndarray, shape (nz_i, nz_j)
            ``A[i, j]``: how z_j enters ż_i (i = j: the local dynamics);
            zeros when the coaches do not touch.
        """
        if (i, j) in self.A:
            return self.A[i, j]
        return np.zeros((self.B[i].shape[0], self.B[j].shape[0]))

    def global_matrices(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Assemble (A, B, C) in the interleaved order [z_0; z_1; ...].

        Returns
        -------
        A : ndarray
            (N, N) the blocks A_ij, N the total number of subsystem states.
        B : ndarray
            (N, n) block-diagonal, the B_i [1/kg] (inputs u_i in N).
        C : ndarray
            (n, N) block-diagonal, the C_i (each coach's speed [m/s]).
        """
        n = self.n_coaches
        A = np.block([[self.block(i, j) for j in range(n)] for i in range(n)])
        B = block_diag(*self.B)
        C = block_diag(*self.C)
        return A, B, C

    def subsystem(self, i: int) -> ct.StateSpace:
        """Coach i as a ``StateSpace`` whose inputs are u_i and its neighbours' states.

        The outputs are its own states (named as the states, e.g. ``v[1]``,
        ``delta[1]``) so that :meth:`interconnection` can wire coaches by name.

        Parameters
        ----------
        i : int
            The coach, 0-based, 0 <= i < n_coaches.

        Returns
        -------
        control.StateSpace
            Continuous, named ``coach<i>``: inputs ``u[i]`` [N] then the
            states of the coaches acting on it (front, then rear); states and
            outputs z_i.
        """
        neighbours = [j for j in (i - 1, i + 1) if (i, j) in self.A]
        inputs = [f"u[{i}]"] + [lab for j in neighbours for lab in self.state_labels[j]]
        Bfull = np.hstack([self.B[i]] + [self.A[i, j] for j in neighbours])
        nz = self.B[i].shape[0]
        labels = list(self.state_labels[i])
        return ct.ss(
            self.A[i, i], Bfull, np.eye(nz), np.zeros((nz, Bfull.shape[1])),
            states=labels, inputs=inputs, outputs=labels, name=f"coach{i}",
        )

    def interconnection(self, *, name: str = "train") -> ct.StateSpace:
        """All coaches joined with ``control.interconnect`` by signal name.

        Parameters
        ----------
        name : str
            Name of the system returned.

        Returns
        -------
        control.StateSpace
            Inputs ``u[i]`` [N], outputs ``v[i]`` [m/s]; states named
            ``coach<i>_<state>`` in subsystem order.
        """
        n = self.n_coaches
        return ct.interconnect(
            [self.subsystem(i) for i in range(n)],
            inplist=[f"u[{i}]" for i in range(n)],
            inputs=[f"u[{i}]" for i in range(n)],
            outlist=[f"v[{i}]" for i in range(n)],
            outputs=[f"v[{i}]" for i in range(n)],
            name=name,
        )


def coach_subsystems(
    train: Train, speed: float, *, method: str = "jacobian", dummy_state: bool = True
) -> CoachSubsystems:
    """Seed 000's per-coach matrices A_ii, A_ij, B_i, C_i.

    Parameters
    ----------
    train : Train
        The train (physical couplers; virtual links give zero coupling blocks).
    speed : float
        Linearisation speed v_r [m/s].
    method : {"jacobian", "book"}
        Treatment of the quadratic Davis term.
    dummy_state : bool
        Keep the book's dummy elongation of the last coach.

    Returns
    -------
    CoachSubsystems
        The blocks.

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> sub = coach_subsystems(crh2_half(), 300 / 3.6, method="book")
    >>> sub.A[0, 0].round(5).tolist()
    [[-0.00147, -245.04673], [1.0, 0.0]]
    >>> sub.A[1, 0].round(1).tolist()
    [[0.0, 218.5], [0.0, 0.0]]
    """
    n = train.n_vehicles
    damp = resistance_damping(train, speed, method)
    k, d, m = train.stiffness, train.damping, train.mass
    A: dict[tuple[int, int], NDArray[np.float64]] = {}
    B, C, labels = [], [], []
    for i in range(n):
        rear = i < n - 1
        nz = 2 if (rear or dummy_state) else 1
        d_front = d[i - 1] if i > 0 else 0.0
        d_rear = d[i] if rear else 0.0
        a = np.zeros((nz, nz))
        a[0, 0] = -damp[i] - (d_front + d_rear) / m[i]
        if rear:
            a[0, 1] = -k[i] / m[i]
            a[1, 0] = 1.0
        A[i, i] = a
        if i > 0:
            nprev = 2
            block = np.zeros((nz, nprev))
            block[0, 0] = d[i - 1] / m[i]
            block[0, 1] = k[i - 1] / m[i]
            A[i, i - 1] = block
        if rear:
            nnext = 2 if (i + 1 < n - 1 or dummy_state) else 1
            block = np.zeros((nz, nnext))
            block[0, 0] = d[i] / m[i]
            block[1, 0] = -1.0
            A[i, i + 1] = block
        B.append(np.eye(nz, 1) / m[i])
        C.append(np.eye(1, nz))
        labels.append((f"v[{i}]", f"delta[{i}]")[:nz])
    return CoachSubsystems(A=A, B=tuple(B), C=tuple(C), state_labels=tuple(labels))


@dataclass(frozen=True, kw_only=True)
class Neighbourhood:
    """Model of one coach's neighbourhood (Li & Zheng eqs. 12.19–12.21).

    Parameters
    ----------
    owner : int
        The coach whose neighbourhood this is.
    members : tuple of int
        Coaches in the neighbourhood, ascending.
    A_hat : ndarray
        Dynamics of the stacked member states Z = [z_j for j in members].
    couplings : dict of int to ndarray
        For each coach j outside the neighbourhood that acts on it, the
        matrix multiplying z_j (the book's Â_{i,i±1}).
    B_hat : ndarray
        Block-diagonal input matrix for the stacked member inputs [1/kg].
    C_hat : ndarray
        Block-diagonal output matrix (member speeds).

    Examples
    --------
    >>> from trainctl.models.train import Train
    >>> from trainctl.models.vehicle import Coupler, Vehicle
    >>> # Three 100 t coaches on 10⁶ N/m couplers, no resistance: k/m = 10 1/s².
    >>> car = Vehicle(mass=1e5, a0=0.0, a1=0.0, a2=0.0)
    >>> train = Train(vehicles=(car, car, car), couplers=(Coupler(stiffness=1e6),) * 2)
    >>> sub = coach_subsystems(train, 20.0)
    >>> nb = neighbourhood(sub, 0)  # coaches {0, 1}
    >>> nb.owner, nb.members, nb.A_hat.shape
    (0, (0, 1), (4, 4))
    >>> nb.couplings[2].tolist()  # v[2] stretches delta[1], the last member state
    [[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [-1.0, 0.0]]
    """

    owner: int
    members: tuple[int, ...]
    A_hat: NDArray[np.float64]
    couplings: dict[int, NDArray[np.float64]]
    B_hat: NDArray[np.float64]
    C_hat: NDArray[np.float64]


def neighbourhood(
    subsystems: CoachSubsystems, owner: int, members: Sequence[int] | None = None
) -> Neighbourhood:
    """The neighbourhood model of coach ``owner``.

    Parameters
    ----------
    subsystems : CoachSubsystems
        Per-coach blocks from :func:`coach_subsystems`.
    owner : int
        Index of the coach (0-based).
    members : sequence of int or None
        Members of the neighbourhood; default {owner-1, owner, owner+1}.

    Returns
    -------
    Neighbourhood
        Â_ii, the couplings to coaches outside, B̂_i and Ĉ_i.

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> sub = coach_subsystems(crh2_half(), 300 / 3.6)
    >>> nb = neighbourhood(sub, 0)
    >>> nb.members, sorted(nb.couplings), nb.couplings[2].tolist()
    ((0, 1), [2], [[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [-1.0, 0.0]])
    """
    n = subsystems.n_coaches
    if not 0 <= owner < n:
        raise ModelError(f"neighbourhood: 'owner' must be in 0..{n - 1} (got {owner}).")
    if members is None:
        members = [j for j in (owner - 1, owner, owner + 1) if 0 <= j < n]
    mem = tuple(sorted(set(int(j) for j in members)))
    if owner not in mem or any(not 0 <= j < n for j in mem):
        raise ModelError(
            f"neighbourhood: 'members' must be coaches in 0..{n - 1} including the owner "
            f"{owner} (got {list(members)})."
        )
    A_hat = np.block([[subsystems.block(i, j) for j in mem] for i in mem])
    couplings = {}
    for j in range(n):
        if j in mem:
            continue
        col = np.vstack([subsystems.block(i, j) for i in mem])
        if np.any(col):
            couplings[j] = col
    return Neighbourhood(
        owner=owner,
        members=mem,
        A_hat=A_hat,
        couplings=couplings,
        B_hat=block_diag(*[subsystems.B[j] for j in mem]),
        C_hat=block_diag(*[subsystems.C[j] for j in mem]),
    )


def neighbourhoods(subsystems: CoachSubsystems) -> tuple[Neighbourhood, ...]:
    """Every coach's default neighbourhood {i-1, i, i+1}.

    Parameters
    ----------
    subsystems : CoachSubsystems
        Per-coach blocks.

    Returns
    -------
    tuple of Neighbourhood
        One per coach.

    Examples
    --------
    >>> from trainctl.models.train import Train
    >>> from trainctl.models.vehicle import Coupler, Vehicle
    >>> # Three 100 t coaches on 10⁶ N/m couplers, no resistance: k/m = 10 1/s².
    >>> car = Vehicle(mass=1e5, a0=0.0, a1=0.0, a2=0.0)
    >>> train = Train(vehicles=(car, car, car), couplers=(Coupler(stiffness=1e6),) * 2)
    >>> sub = coach_subsystems(train, 20.0)
    >>> [(nb.owner, nb.members, sorted(nb.couplings)) for nb in neighbourhoods(sub)]
    [(0, (0, 1), [2]), (1, (0, 1, 2), []), (2, (1, 2), [0])]
    """
    return tuple(neighbourhood(subsystems, i) for i in range(subsystems.n_coaches))

