# The flocking family's braking-curve supervisor: full braking where a follower could not stop.
"""A braking-curve supervisor over the flocking law: virtual coupling kept braking-safe.

Virtual coupling is safe only while every follower could stop behind its
leader if the leader braked at its strongest now, given what the radio has
told the follower: its gap must stay above the *relative braking distance*
(:func:`~trainctl.models.braking.relative_braking_distance`, the exact
closest approach of the two braking motions). The supervisor checks that
every control step and, where it fails, replaces the follower's command by
its full braking. It is an ETCS-style braking-curve supervision, chosen over
a control-barrier-function filter: it is transparent (one distance per
follower, a yes/no each step, the override is the brake), it needs no class-K
function whose tuning would trade capacity against late braking, and its
guarantee follows directly from the exact relative braking distance (below),
for the sampled loop as simulated rather than for a continuous-time idealisation.

The rule, at a control step t (interval T_c), for follower i and its leader
i - 1 (the train ahead):

1. *The leader's last received state*: the one it sent at t_r = t - τ, τ the
   delay. A message is lost when its link is down at any moment of its
   transit (:class:`~trainctl.models.network.Interruption`), so during a
   ``[network.interruption]`` window [s, e) on the link, and until e + τ,
   the newest received is the one sent at s - τ. The supervisor takes the
   newest control sample at or before t_r (an older state only makes the
   worst case worse); before anything can have arrived, the state at the
   first step.
2. *The leader's worst case*: braked at b_L ever since (dead reckoning,
   :func:`~trainctl.models.braking.braked`), giving its worst position and
   speed now.
3. *The follower runs on*: for one control interval under the command the
   law asks for (its speed rising by the command's specific force less its
   running resistance, never falling), then on at that speed for the
   remaining outage: while messages are overdue (t_r < t - τ) an outage is
   on, and as it lasts at most T (the assumed outage) the first fresh
   message arrives by A = t_r + T + 2τ. Then it brakes at b_f, its braking
   envelope at its speed over its mass. So the follower's delay is
   T_c (the reaction: the supervisor looks again one interval later) plus
   max(0, A - t).
4. *The run-on margin*: the worst-case gap one interval ahead minus the
   relative braking distance of these two motions (with the margin), and
   the worst-case gap now minus the margin; when the smaller is negative the
   follower brakes at full (its envelope's limit at its measured speed) for
   the step.

The guarantee, by induction over the steps: if every follower could brake in
time at the first step (:meth:`BrakingSupervisor.brake_now_margins` >= 0), a
step at which the supervisor lets a follower run on leaves braking at the
next step safe, and a follower braking at full stays safe; so no gap falls
below the margin, whatever the leaders do, as long as no leader decelerates
harder than b_L and every follower's brakes give at least b_f(v) at every
speed below v. It does not depend on the cruise law: the flocking law keeps
using the full state, and the supervisor only checks the command it
proposes. At a cruise speed v with equal trains and brakes the rule lets a
gap g run on through an outage of T when g >= v·(T_c + T + 2τ) + margin
(T_c + τ without an outage): the design-time ``flocking_braking_distance``
check (:mod:`~trainctl.controllers.flocking.checks`). Exactly so when τ is a
whole number of control intervals; otherwise the newest sample received is
older than t - τ by up to T_c, and the rule asks up to v·T_c more.

What the margin must cover (the model's assumptions): constant
decelerations; running resistance and grade left out of the braking on both
sides (they slow leader and follower alike for equal trains on a level line;
a down-grade takes braking away); random message losses (a lost message
makes the received state older than the rule assumes: raise the delay to
cover them).

The leader's worst deceleration b_L is ``leader_braking_m_s2`` when given,
else its braking envelope's strongest value over its mass: the envelope
min(F, P/v, μ·m·g) does not grow with speed, so its value at low speed bounds
the braking at every speed (at the leader's speed alone, a power-limited
brake would out-brake the constant the rule assumes as the train slows; for
a brake without a power limit the two agree).
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from trainctl._validation import check_nonnegative, check_positive
from trainctl.exceptions import ModelError, ScenarioError
from trainctl.models.braking import braked, relative_braking_distance
from trainctl.models.dynamics import vehicle_positions
from trainctl.models.train import Train

if TYPE_CHECKING:
    from trainctl.controllers.flocking.settings import FlockingSettings
    from trainctl.scenario import Scenario

__all__ = ["BrakingSupervisor", "supervisor_of"]

Array = NDArray[np.float64]

_TIME_TOL = 1e-9
"""Relative tolerance [-] of the comparisons of instants (a sample "at" t_r)."""


class BrakingSupervisor:
    """The braking-curve supervision of a virtually coupled formation (module docstring).

    Parameters
    ----------
    train : Train
        The formation, head first: follower i's leader is train i - 1.
    interval : float
        Control interval T_c [s], > 0: the follower's reaction time.
    margin : float
        Least gap [m] kept at the closest approach, >= 0.
    delay : float
        Delay τ of the leader's messages [s], >= 0.
    outage : float
        Longest outage T of the leader's messages assumed [s], >= 0.
    leader_braking : float or None
        Worst-case deceleration b_L of every leader [m/s²], > 0; None: each
        leader's strongest envelope braking over its mass.
    windows : sequence of sequence of (float, float) or None
        Per follower i = 1 .. n-1 (entry i - 1), the outage windows [start,
        end) [s] of its link from train i - 1; None: none.

    Raises
    ------
    ModelError
        If an argument is out of its range, or a train cannot brake.

    Examples
    --------
    Two 1000 t trains braking at 0.5 m/s², 200 m apart at 20 m/s, a 1 s
    interval and a 50 m margin: running on is safe, since 200 m >= 20 m/s ×
    1 s + 50 m, with 130 m to spare after the next interval.

    >>> from trainctl.models import Coupler, TractionEnvelope, Train, Vehicle
    >>> unit = Vehicle(mass=1e6, length=100.0, a0=0.0, a1=0.0, a2=0.0,
    ...                envelope=TractionEnvelope(max_traction=2e5, max_braking=5e5))
    >>> pair = Train(vehicles=(unit, unit), couplers=(Coupler(stiffness=0.0, spacing=300.0,
    ...                                                   virtual=True),))
    >>> sup = BrakingSupervisor(pair, interval=1.0, margin=50.0)
    >>> state = np.array([20.0, 20.0, 0.0, 0.0])  # speeds [m/s], gap deviation [m], head [m]
    >>> sup.observe(0.0, state)
    >>> sup.run_on_margins(0.0, state, np.zeros(2)).tolist()  # [m]
    [130.0]
    """

    def __init__(self, train: Train, *, interval: float, margin: float, delay: float = 0.0,
                 outage: float = 0.0, leader_braking: float | None = None,
                 windows: Sequence[Sequence[tuple[float, float]]] | None = None) -> None:
        where = "BrakingSupervisor"
        self.train, self.n = train, train.n_vehicles
        self.interval = check_positive(where, "interval", interval)
        self.margin = check_nonnegative(where, "margin", margin)
        self.delay = check_nonnegative(where, "delay", delay)
        self.outage = check_nonnegative(where, "outage", outage)
        self.leader_braking = None if leader_braking is None else check_positive(
            where, "leader_braking", leader_braking)
        if self.n < 2:
            raise ModelError(f"{where}: needs a formation of at least 2 trains (got {self.n}).")
        cannot = [i for i, veh in enumerate(train.vehicles)
                  if not float(veh.envelope.braking_limit(0.0, mass=veh.mass)) > 0.0]
        if cannot:
            raise ModelError(f"{where}: every train must be able to brake, the supervisor's "
                             f"override (got no braking force for train(s) {cannot}). Give "
                             "each unit train max_braking_kn > 0.")
        self.windows = tuple(tuple((float(s), float(e)) for s, e in follower)
                             for follower in (windows or [()] * (self.n - 1)))
        if len(self.windows) != self.n - 1:
            raise ModelError(f"{where}: 'windows' must hold one entry per follower "
                             f"({self.n - 1}), got {len(self.windows)}.")
        self._mass = [float(m) for m in train.mass]
        self._davis = [tuple(float(c) for c in column) for column in train.davis.T]
        length = [float(v.length) for v in train.vehicles]
        self._half = [0.5 * (length[i - 1] + length[i]) for i in range(1, self.n)]
        self._strongest = [self.leader_braking if self.leader_braking is not None
                           else self._braking(i, 0.0) / self._mass[i] for i in range(self.n)]
        self.reset()

    def reset(self) -> None:
        """Forget the received states (a new run)."""
        self._times: list[float] = []
        self._positions: list[list[float]] = []
        self._speeds: list[list[float]] = []

    def _braking(self, i: int, speed: float) -> float:
        """Train i's braking force limit [N] at ``speed`` [m/s]."""
        veh = self.train.vehicles[i]
        return float(veh.envelope.braking_limit(max(speed, 0.0), mass=veh.mass))

    def follower_deceleration(self, i: int, speed: float) -> float:
        """b_f of train ``i`` at ``speed``: its braking limit over its mass [m/s²].

        Parameters
        ----------
        i : int
            The train (0-based, head first).
        speed : float
            Its speed [m/s].

        Returns
        -------
        float
            The deceleration its brakes give at least at every lower speed [m/s²].
        """
        return self._braking(i, speed) / self._mass[i]

    def leader_deceleration(self, i: int) -> float:
        """b_L of train ``i``: the strongest deceleration it is assumed to brake at [m/s²].

        Parameters
        ----------
        i : int
            The train (0-based, head first).

        Returns
        -------
        float
            ``leader_braking`` when given, else its strongest envelope braking
            over its mass [m/s²].
        """
        return self._strongest[i]

    def full_braking(self, speeds: Array) -> Array:
        """Every train's full braking command at its speed [N] (negative).

        Parameters
        ----------
        speeds : ndarray
            The trains' speeds [m/s], shape (n,).

        Returns
        -------
        ndarray
            Minus each braking limit [N], shape (n,).
        """
        return np.array([-self._braking(i, float(v)) for i, v in enumerate(speeds)])

    def design_lag(self) -> float:
        """Time [s] between a leader's braking and the follower's in the worst case at cruise.

        Returns
        -------
        float
            T_c + τ without an assumed outage, T_c + T + 2τ with one (module
            docstring).
        """
        lag = self.interval + self.delay
        return lag + (self.outage + self.delay if self.outage > 0.0 else 0.0)

    def observe(self, t: float, state: Array) -> None:
        """Record the state at a step: what the followers may receive later.

        Parameters
        ----------
        t : float
            The step's time [s], after the last one recorded.
        state : ndarray
            The full plant state ``[v (n) [m/s], delta (n-1) [m], s [m]]``
            (copied).
        """
        x = np.asarray(state, dtype=float)
        self._times.append(float(t))
        self._positions.append(vehicle_positions(self.train, x).tolist())
        self._speeds.append(x[:self.n].tolist())

    def received(self, follower: int, t: float) -> float:
        """When the newest message follower ``follower`` holds from its leader at ``t`` was sent.

        Parameters
        ----------
        follower : int
            The follower, 1 .. n-1 (its vehicle index).
        t : float
            The time [s].

        Returns
        -------
        float
            The send time t_r [s]: t - τ, or for an outage window [s, e) of
            the link with s - τ < t - τ < e the instant s - τ (windows chained).
        """
        sent = t - self.delay
        moved = True
        while moved:
            moved = False
            for start, end in self.windows[follower - 1]:
                if start - self.delay < sent < end:
                    sent, moved = start - self.delay, True
        return sent

    def _worst(self, follower: int, t: float) -> tuple[float, float, float, float]:
        """(the leader's received position [m], speed [m/s], the time since [s], the time
        until fresh news at the latest [s]) for ``follower`` at ``t``."""
        sent = self.received(follower, t)
        tol = _TIME_TOL * max(1.0, abs(t))
        j = max(bisect.bisect_right(self._times, sent + tol) - 1, 0)
        overdue = sent < t - self.delay - tol
        news = max(0.0, sent + self.outage + 2.0 * self.delay - t) if overdue else 0.0
        return (self._positions[j][follower - 1], max(self._speeds[j][follower - 1], 0.0),
                t - self._times[j], news)

    def run_on_margins(self, t: float, state: Array, inputs: Array) -> Array:
        """Each follower's run-on margin [m] at the step ``t`` (module docstring, item 4).

        Call :meth:`observe` for the step first.

        Parameters
        ----------
        t : float
            The step's time [s].
        state : ndarray
            The full plant state at ``t``.
        inputs : ndarray
            The commands [N] the followers would hold over the interval, shape (n,).

        Returns
        -------
        ndarray
            Shape (n-1,), follower 1 first: negative where the follower must
            brake now.
        """
        x = np.asarray(state, dtype=float)
        u = np.asarray(inputs, dtype=float)
        p = self._positions[-1] if self._times and self._times[-1] == t else \
            vehicle_positions(self.train, x).tolist()
        T = self.interval
        out = np.empty(self.n - 1)
        for i in range(1, self.n):
            lead, speed, since, news = self._worst(i, t)
            b_lead = self._strongest[i - 1]
            v = max(float(x[i]), 0.0)
            a0, a1, a2 = self._davis[i]
            a = max(0.0, float(u[i]) / self._mass[i] - (a0 + a1 * v + a2 * v * v))
            ahead, speed_ahead = braked(speed, b_lead, since + T)
            gap_ahead = lead + ahead - (p[i] + v * T + 0.5 * a * T * T) - self._half[i - 1]
            now = lead + braked(speed, b_lead, since)[0] - p[i] - self._half[i - 1]
            v1 = v + a * T
            need = relative_braking_distance(
                v1, speed_ahead, follower_deceleration=self.follower_deceleration(i, v1),
                leader_deceleration=b_lead, delay=news, margin=self.margin)
            out[i - 1] = min(now - self.margin, gap_ahead - need)
        return out

    def brake_now_margins(self, t: float, state: Array) -> Array:
        """Each follower's margin [m] if it brakes at full from ``t`` on.

        Call :meth:`observe` for the step first.

        Parameters
        ----------
        t : float
            The step's time [s].
        state : ndarray
            The full plant state at ``t``.

        Returns
        -------
        ndarray
            Worst-case gap minus the relative braking distance without delay
            [m], shape (n-1,); negative where even full braking comes too late.
        """
        x = np.asarray(state, dtype=float)
        p = vehicle_positions(self.train, x).tolist()
        out = np.empty(self.n - 1)
        for i in range(1, self.n):
            lead, speed, since, _ = self._worst(i, t)
            b_lead = self._strongest[i - 1]
            v = max(float(x[i]), 0.0)
            ahead, speed_now = braked(speed, b_lead, since)
            need = relative_braking_distance(
                v, speed_now, follower_deceleration=self.follower_deceleration(i, v),
                leader_deceleration=b_lead, margin=self.margin)
            out[i - 1] = lead + ahead - p[i] - self._half[i - 1] - need
        return out

    def supervise(self, t: float, state: Array, inputs: Array) -> NDArray[np.intp]:
        """Observe the step and name the followers that must brake at full.

        Parameters
        ----------
        t : float
            The step's time [s].
        state : ndarray
            The full plant state at ``t`` (finite).
        inputs : ndarray
            The law's commands [N], shape (n,).

        Returns
        -------
        ndarray of int
            The vehicle indices (1 .. n-1) whose run-on margin is negative.
        """
        self.observe(t, state)
        return np.flatnonzero(self.run_on_margins(t, state, inputs) < 0.0) + 1


def supervisor_of(scenario: Scenario, settings: FlockingSettings,
                  interval: float) -> BrakingSupervisor:
    """The supervisor of a scenario: its formation, ``[network]`` and the family's settings.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its train and ``[network]``).
    settings : FlockingSettings
        The family's settings (``supervisor_*``, ``leader_braking``).
    interval : float
        The control interval T_c [s].

    Returns
    -------
    BrakingSupervisor
        Its delay τ is ``supervisor_delay_s``, else the ``[network]``'s largest
        delay, else 0; its outage T ``supervisor_outage_s``, else the longest
        ``[network.interruption]`` window, else 0; each follower's windows are
        those that cut its link from the train ahead.

    Raises
    ------
    ScenarioError
        If a train cannot brake.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-flocking-outage")
    >>> sup = supervisor_of(sc, sc.controllers["flocking"], 1.0)
    >>> sup.delay, sup.outage, sup.margin, sup.windows[0]  # [s], [s], [m], follower 1's
    (0.5, 30.0, 50.0, ((100.0, 130.0),))
    >>> sup.design_lag()  # T_c + τ + T + τ [s]
    32.0
    """
    network = scenario.network
    windows = tuple(network.interruptions) if network is not None else ()
    delay = settings.supervisor_delay
    if delay is None:
        delay = network.delay_bounds()[1] if network is not None else 0.0
    outage = settings.supervisor_outage
    if outage is None:
        outage = max((w.end - w.start for w in windows), default=0.0)
    n = scenario.train.n_vehicles
    try:
        return BrakingSupervisor(
            scenario.train, interval=interval, margin=settings.supervisor_margin,
            delay=delay, outage=outage, leader_braking=settings.leader_braking,
            windows=[[(w.start, w.end) for w in windows if w.blocks((i, i - 1))]
                     for i in range(1, n)])
    except ModelError as exc:
        raise ScenarioError(f"{scenario.source}: [controller] (flocking) supervisor: "
                            f"{exc}") from None
