# Nonlinear longitudinal dynamics and the cruise equilibrium.
"""Nonlinear longitudinal train dynamics, vectorised over vehicles and samples.

State (SI): ``[v_0 .. v_{n-1}, delta_0 .. delta_{n-2}, s]`` with vehicle
speeds v [m/s], coupler elongations delta [m] (tension positive) and the head
position s [m]. Inputs are the traction (> 0) or braking (< 0) forces u [N].

    m_i dv_i/dt = u_i - m_i (a0_i + a1_i v_i + a2_i v_i²) - m_i r(p_i) + f_{i-1} - f_i
    d delta_i/dt = v_i - v_{i+1}
    ds/dt = v_0

with coupler forces f_i = k_i delta_i + d_i (v_i - v_{i+1}) (f_{-1} = f_{n-1} = 0),
vehicle positions p_i = s - sum_{j<i} (spacing_j + delta_j) and the line
resistance r(p) of the track (grade and curves). The Davis law assumes
forward running, v >= 0. The couplers and kinematic rows come from the one
chain definition, :class:`~trainctl.models.Chain`; the traction split of
:func:`equilibrium` from :class:`~trainctl.models.ForceSplit`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from trainctl._validation import check_finite, check_positive
from trainctl.exceptions import DimensionError
from trainctl.models.chain import train_chain
from trainctl.models.feedforward import ALLOCATIONS, ForceSplit
from trainctl.models.track import Track
from trainctl.models.train import Train
from trainctl.units import permille_to_accel

if TYPE_CHECKING:
    import control as ct

__all__ = [
    "ALLOCATIONS",
    "Equilibrium",
    "coupler_forces",
    "equilibrium",
    "nonlinear_system",
    "train_rhs",
    "vehicle_positions",
]

def coupler_forces(train: Train, state: ArrayLike) -> NDArray[np.float64]:
    """Coupler forces f = k*delta + d*(v_i - v_{i+1}) [N], tension positive.

    Parameters
    ----------
    train : Train
        The train.
    state : array_like
        State ``[v, delta, ...]``, shape (nx,) or (nx, m); extra trailing
        states (the position) are ignored.

    Returns
    -------
    ndarray
        Forces [N], shape (n-1,) or (n-1, m).

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> train = crh2_half()
    >>> coupler_forces(train, [80, 80, 80, 80, 1e-4, 0, 0]).round(1).tolist()
    [1048.8, 0.0, 0.0]
    """
    return train_chain(train).forces(state)


def train_rhs(
    train: Train, state: ArrayLike, inputs: ArrayLike, track: Track | None = None
) -> NDArray[np.float64]:
    """Time derivative of the nonlinear train state.

    Vectorised: ``state`` may be (2n,) or (2n, m) and ``inputs`` (n,) or
    (n, m), evaluating m states at once (as ``solve_ivp(vectorized=True)``
    asks for). Cost is O(n) per sample.

    Parameters
    ----------
    train : Train
        The train.
    state : array_like
        ``[v (n) [m/s], delta (n-1) [m], s [m]]``.
    inputs : array_like
        Traction/braking forces u [N], one per vehicle.
    track : Track or None
        Track for grade and curve resistance; None for level straight track.

    Returns
    -------
    ndarray
        The derivative d(state)/dt, same shape as ``state``.

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> train = crh2_half()
    >>> eq = equilibrium(train, 83.3333)
    >>> x = eq.state(position=0.0)
    >>> float(np.abs(train_rhs(train, x, eq.inputs)[:-1]).max()) < 1e-9
    True
    """
    x = np.asarray(state, dtype=float)
    u = np.asarray(inputs, dtype=float)
    n = train.n_vehicles
    if x.shape[0] != 2 * n:
        raise DimensionError(
            f"train_rhs: state must have {2 * n} rows for {n} vehicles (got {x.shape[0]})."
        )
    if u.shape[0] != n:
        raise DimensionError(f"train_rhs: inputs must have {n} rows (got {u.shape[0]}).")
    shape = (-1,) + (1,) * (x.ndim - 1)
    v = x[:n]
    a0, a1, a2 = (c.reshape(shape) for c in train.davis)
    m = train.mass.reshape(shape)
    accel = u / m - (a0 + a1 * v + a2 * v * v)
    if track is not None and not track.is_flat:
        accel = accel - track.resistance_per_mass(vehicle_positions(train, x))
    out = np.empty((2 * n,) + np.broadcast_shapes(x.shape[1:], accel.shape[1:]))
    out[:n] = accel
    train_chain(train).couple(x, out)
    return out


def vehicle_positions(train: Train, x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Position of every vehicle from the head position and the coupler elongations.

    p_i = s - Σ_{j<i} (spacing_j + delta_j), vectorised over trailing axes of ``x``.

    Parameters
    ----------
    train : Train
        The train (nominal spacings).
    x : ndarray
        State ``[v (n), delta (n-1), s]``, shape (2n,) or (2n, m).

    Returns
    -------
    ndarray
        Positions [m], shape (n,) or (n, m); the head vehicle first.

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> train = crh2_half()
    >>> vehicle_positions(train, np.r_[np.zeros(4), np.zeros(3), 100.0]).tolist()
    [100.0, 75.0, 50.0, 25.0]
    """
    n = train.n_vehicles
    shape = (-1,) + (1,) * (x.ndim - 1)
    gaps = train.spacing.reshape(shape) + x[n : 2 * n - 1]
    behind = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(gaps, axis=0)])
    positions: NDArray[np.float64] = x[2 * n - 1] - behind
    return positions


def nonlinear_system(
    train: Train, track: Track | None = None, *, name: str = "train"
) -> ct.NonlinearIOSystem:
    """The nonlinear train as a python-control ``NonlinearIOSystem``.

    Parameters
    ----------
    train : Train
        The train.
    track : Track or None
        Track for grade/curve resistance; None for level straight track.
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        States ``v[i]``, ``delta[i]``, ``s``; inputs ``u[i]`` [N];
        outputs the velocities ``v[i]`` [m/s].

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> sys = nonlinear_system(crh2_half())
    >>> sys.nstates, sys.ninputs, sys.noutputs
    (8, 4, 4)
    """
    import control as ct

    n = train.n_vehicles

    def update(
        t: float, x: NDArray[np.float64], u: NDArray[np.float64], params: dict[str, object]
    ) -> NDArray[np.float64]:
        return train_rhs(train, x, u, track)

    def output(
        t: float, x: NDArray[np.float64], u: NDArray[np.float64], params: dict[str, object]
    ) -> NDArray[np.float64]:
        return x[:n]

    return ct.nlsys(
        update,
        output,
        states=train.state_labels(position=True),
        inputs=[f"u[{i}]" for i in range(n)],
        outputs=[f"v[{i}]" for i in range(n)],
        name=name,
    )


@dataclass(frozen=True, kw_only=True)
class Equilibrium:
    """Cruise equilibrium of a train at a constant speed.

    Parameters
    ----------
    speed : float
        Cruise speed v_r [m/s].
    inputs : ndarray
        Equilibrium traction force per vehicle [N].
    coupler_forces : ndarray
        Static coupler forces [N], tension positive.
    elongations : ndarray
        Static elongations delta^e [m] (force / stiffness; 0 for virtual links).
    resistance : ndarray
        Running plus line resistance of each vehicle [N].
    traction_limit : ndarray
        Traction available at ``speed`` per vehicle [N].
    braking_limit : ndarray or None
        Braking available at ``speed`` per vehicle, as positive numbers [N];
        None: not limited.

    Examples
    --------
    A locomotive hauling one wagon, each 100 t with 0.01 m/s² of resistance
    (1 kN): the locomotive supplies both 2 kN, so the coupler carries the
    wagon's 1 kN in tension and stretches 1 kN / (10⁶ N/m) = 1 mm.

    >>> from trainctl.models.train import Train
    >>> from trainctl.models.vehicle import Coupler, Vehicle
    >>> loco = Vehicle(mass=1e5, a0=0.01, a1=0.0, a2=0.0, traction_share=1.0)
    >>> wagon = Vehicle(mass=1e5, a0=0.01, a1=0.0, a2=0.0, traction_share=0.0)
    >>> eq = equilibrium(Train(vehicles=(loco, wagon), couplers=(Coupler(stiffness=1e6),)), 20.0)
    >>> eq.inputs.tolist(), eq.coupler_forces.tolist()  # [N]
    ([2000.0, 0.0], [1000.0])
    >>> eq.state().round(6).tolist()  # [v0, v1 (m/s), delta0 (m)]
    [20.0, 20.0, 0.001]
    >>> eq.feasible  # no traction limits given
    True
    """

    speed: float
    inputs: NDArray[np.float64]
    coupler_forces: NDArray[np.float64]
    elongations: NDArray[np.float64]
    resistance: NDArray[np.float64]
    traction_limit: NDArray[np.float64]
    braking_limit: NDArray[np.float64] | None = None

    @property
    def feasible(self) -> bool:
        """True when every vehicle's force is within its traction and braking envelope.

        A positive (traction) force must not exceed :attr:`traction_limit`, a
        negative (braking) one must not exceed :attr:`braking_limit` in
        magnitude (relative tolerance 1e-12, absolute 1e-9 N).
        """
        u = self.inputs
        traction_ok = np.all(u <= self.traction_limit * (1 + 1e-12) + 1e-9)
        if self.braking_limit is None:
            return bool(traction_ok)
        return bool(traction_ok and np.all(-u <= self.braking_limit * (1 + 1e-12) + 1e-9))

    def state(self, *, position: float | None = None) -> NDArray[np.float64]:
        """Equilibrium state ``[v, delta]`` (plus ``s`` when ``position`` is given).

        Parameters
        ----------
        position : float or None
            Head position s [m] to append (the nonlinear model's last state).

        Returns
        -------
        ndarray
            The equilibrium state vector.
        """
        x = np.concatenate([np.full(self.inputs.shape, self.speed), self.elongations])
        return x if position is None else np.append(x, position)


def equilibrium(
    train: Train,
    speed: float,
    *,
    allocation: str = "shares",
    grade_permille: float = 0.0,
    track: Track | None = None,
    position: float = 0.0,
    acceleration: float = 0.0,
) -> Equilibrium:
    """Cruise equilibrium: inputs and static coupler forces at speed v_r.

    With ``allocation="shares"`` each physically coupled group's total
    resistance is spread over its vehicles in proportion to their
    ``traction_share`` (T-M-M-T: trailers carry none), so the couplers carry
    static forces f_i = sum_{j<=i} (u_j - w_j). With ``"own"`` every vehicle
    supplies its own resistance (seed 000, eq. 12.8) and all static coupler
    forces vanish.

    Parameters
    ----------
    train : Train
        The train.
    speed : float
        Cruise speed v_r [m/s], > 0.
    allocation : {"shares", "own"}
        How traction is spread.
    grade_permille : float
        Uniform grade [‰] (TB/T: i N/kN), used when ``track`` is None.
    track : Track or None
        Track whose resistance is evaluated at the vehicles' equilibrium positions.
    position : float
        Head position s [m] for ``track``.
    acceleration : float
        Common acceleration of every vehicle [m/s²] (0 for cruise). With a
        non-zero value the result is the quasi-static force distribution that
        accelerates the whole train uniformly (the MPC feedforward).

    Returns
    -------
    Equilibrium
        Inputs, static coupler forces and elongations, and the traction and
        braking limits at ``speed`` (:attr:`Equilibrium.feasible` compares
        the inputs with both).

    Examples
    --------
    >>> from trainctl.models.presets import crh2_half
    >>> eq = equilibrium(crh2_half(), 300 / 3.6)
    >>> (eq.coupler_forces / 1e3).round(3).tolist()
    [-5.627, -0.151, 5.521]

    Holding 300 km/h down a 30 ‰ grade needs braking, which the motor
    coaches' 40 kN cannot give:

    >>> steep = equilibrium(crh2_half(), 300 / 3.6, grade_permille=-30.0)
    >>> (steep.inputs / 1e3).round(1).tolist(), steep.feasible
    ([-0.0, -14.6, -14.6, -0.0], False)
    """
    speed = check_positive("equilibrium", "speed", speed)
    accel = check_finite("equilibrium", "acceleration", acceleration)
    grade = check_finite("equilibrium", "grade_permille", grade_permille)
    split = ForceSplit(train, allocation=allocation, where="equilibrium")
    # The acceleration joins the line resistance, m (davis + (line + a)): the order the
    # equilibrium has always added them in.
    extra = None
    if track is not None or grade != 0.0 or accel != 0.0:
        extra = _line_resistance(train, grade, track, position) + accel
    q = split(np.array([speed]), np.zeros(1), extra)
    limits = np.array([v.envelope.traction_limit(speed, mass=v.mass) for v in train.vehicles])
    braking = np.array([v.envelope.braking_limit(speed, mass=v.mass) for v in train.vehicles])
    return Equilibrium(
        speed=speed,
        inputs=q.inputs[0],
        coupler_forces=q.coupler_forces[0],
        elongations=q.elongations[0],
        resistance=q.resistance[0],
        traction_limit=limits,
        braking_limit=braking,
    )


def _line_resistance(
    train: Train, grade: float, track: Track | None, position: float
) -> NDArray[np.float64]:
    if track is None:
        return np.full(train.n_vehicles, permille_to_accel(grade))
    x = np.concatenate([np.zeros(train.n_vehicles), np.zeros(train.n_couplers), [position]])
    return track.resistance_per_mass(vehicle_positions(train, x))

