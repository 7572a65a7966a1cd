# The synchronous controller: the lead's speed loop, relayed to the remotes, sampled.
"""The synchronous controller: u_i = m_i â_i + R_i(v_i), clipped to the envelope.

At every sample (the family's ``control_interval``) the lead computes its
command a_ℓ from its measured speed and the reference
(:meth:`~trainctl.controllers.synchronous.law.SynchronousLaw.command`), sends
it over the relay (:class:`~trainctl.controllers.synchronous.relay.CommandRelay`)
and every vehicle applies its mass times the command it holds plus its own
resistance at its measured speed; a remote that has received nothing yet
applies its resistance only. The forces are held until the next sample.

The law reads the measured speeds (``Measurement.outputs``, with the
simulation's measurement noise; the true speeds when only the state is
given), nothing else: no position, no coupler elongation.

Faults (:mod:`trainctl.controllers.faults`): a measured speed that is not
finite, a law that raises or forces that are not finite give the status
``"error"`` with the reason in ``info["reason"]`` and the law's feedforward
of the reference, each vehicle's mass times the reference acceleration plus
its resistance at the reference speed (fallback ``"feedforward"``), clipped
to the envelope at the measured speeds (at the reference speed when they are
not finite).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import (
    Measurement,
    ReferencePreview,
    StepRecord,
    control_dt,
    measured_speeds,
)
from trainctl.controllers.continuous.resistance import feedforward_fallback
from trainctl.controllers.faults import call_solver, non_finite_reason
from trainctl.controllers.synchronous.law import SynchronousLaw
from trainctl.controllers.synchronous.relay import CommandRelay
from trainctl.exceptions import ModelError
from trainctl.models.envelope import EnvelopeBounds
from trainctl.models.network.schema import NetworkSettings
from trainctl.models.train import Train

if TYPE_CHECKING:
    from trainctl.controllers.synchronous.batch import SynchronousBatch

__all__ = ["SynchronousController"]

Array = NDArray[np.float64]


class SynchronousController:
    """Synchronous operation of a distributed-power train (module docstring).

    Parameters
    ----------
    train : Train
        The train (envelopes).
    law : SynchronousLaw
        Gains, masses and resistance coefficients.
    relay : CommandRelay
        The radio link from the lead to the remotes (reset with the controller).
    dt : float
        Control interval [s], > 0.
    input_bounds : bool
        Clip each force to the vehicle's envelope at its measured speed.
    name : str
        Label.
    relay_factory : callable or None
        Makes a fresh relay from a run's ``[network]`` settings and seed when
        the controller is reset for that run (None: ``relay`` is reseeded).

    Examples
    --------
    >>> from trainctl.models import equilibrium
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.synchronous.law import law_of
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> law = law_of(scenario, SynchronousSettings())
    >>> ctl = SynchronousController(scenario.train, law, CommandRelay(None, 4, 0, seed=0),
    ...                             dt=0.1)
    >>> eq = equilibrium(scenario.train, 19.5)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 19.5),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(outputs=np.full(4, 19.5)), ref)
    >>> bool(np.allclose(rec.inputs, eq.inputs)), rec.status
    (True, 'optimal')
    """

    preview_steps = 1
    needs_full_state = False
    uses_network = False
    """The relay is the controller's own (:mod:`~trainctl.controllers.synchronous.relay`):
    the simulation's speed messages are not used."""

    def __init__(self, train: Train, law: SynchronousLaw, relay: CommandRelay, *, dt: float,
                 input_bounds: bool = True, name: str = "synchronous",
                 relay_factory: Callable[[NetworkSettings | None, int], CommandRelay] | None
                 = None) -> None:
        dt = control_dt("SynchronousController", dt)
        if law.n != train.n_vehicles or relay.n != train.n_vehicles:
            raise ModelError(f"SynchronousController: the law is for {law.n} vehicles and the "
                             f"relay for {relay.n}; the train has {train.n_vehicles}.")
        if relay.lead != law.lead:
            raise ModelError(f"SynchronousController: the relay's lead ({relay.lead}) is not "
                             f"the law's ({law.lead}).")
        self.train, self.law, self.relay, self.dt = train, law, relay, float(dt)
        self._relay_factory = relay_factory
        self.input_bounds, self.name = bool(input_bounds), name
        self._envelope = EnvelopeBounds(train, enabled=self.input_bounds)

    @staticmethod
    def batched(controllers: list[Any]) -> SynchronousBatch:
        """The law of these controllers (one per run) over R runs at once.

        For :func:`trainctl.sim.batch.simulate_batch`
        (:mod:`trainctl.controllers.synchronous.batch`).

        Parameters
        ----------
        controllers : list
            One controller of this class per run.

        Returns
        -------
        SynchronousBatch
        """
        from trainctl.controllers.synchronous.batch import SynchronousBatch

        return SynchronousBatch(controllers)

    def reset(self) -> None:
        """Forget every relayed command and restart the relay's random stream."""
        self.relay.reset()

    def prepare(self, network: NetworkSettings | None, seed: int) -> None:
        """A new relay for the run about to start: its ``[network]`` and its seed.

        :func:`trainctl.run.analysis.simulate_strategy` calls it with the simulated
        scenario's ``[network]`` and seed, so that a repetition with another
        seed (``[simulation] repetitions``) draws other delays, losses and
        noise, and a baseline run over another network
        (``baseline_network``) relays over that one. Without a relay factory
        (a controller built by hand) only the seed changes.

        Parameters
        ----------
        network : NetworkSettings or None
            The run's network settings (None: an instantaneous relay).
        seed : int
            The run's seed, >= 0.
        """
        from trainctl.controllers.synchronous.relay import RELAY_STREAM

        if self._relay_factory is not None:
            self.relay = self._relay_factory(network, int(seed))
        else:
            self.relay.reseed(np.random.SeedSequence([int(seed), RELAY_STREAM]))

    def step(self, t: float, measurement: Measurement, reference: ReferencePreview) -> StepRecord:
        """The lead's command, relayed; each vehicle's force, clipped to its envelope.

        Parameters
        ----------
        t : float
            Simulation time [s], >= the previous step's: the lead sends its
            command over the relay at t.
        measurement : Measurement
            The measured speeds [m/s] (``outputs``, else the state's speeds)
            and, for the line feedforward, the vehicle positions [m]
            (``positions``; without them the line resistance is taken as 0).
        reference : ReferencePreview
            The reference; only its first sample (speed v_d [m/s] and
            acceleration v̇_d [m/s²]) is used.

        Returns
        -------
        StepRecord
            The forces [N] per vehicle to hold over [t, t + dt), clipped to
            the envelope at the measured speeds, status ``"optimal"``, with
            ``info`` holding ``saturated``, the lead's ``command`` [m/s²], the
            number of remotes still ``waiting`` for a first command and
            ``oldest_command_age`` [s]; or, on a fault (module docstring), the
            feedforward [N] within the envelope, status ``"error"``, fallback
            ``"feedforward"`` and ``info["reason"]``.

        Raises
        ------
        ModelError
            If the measurement holds neither n speeds nor a state, or its
            positions are not n (with the line fed forward).
        """
        start = time.perf_counter()
        speeds = self._speeds(measurement)
        n = self.law.n
        v_ref, a_ref = float(reference.speed[0]), float(reference.acceleration[0])
        reason = non_finite_reason("outputs", speeds)
        if reason:
            return self._fallback(v_ref, a_ref, np.full(n, v_ref), reason, start)
        line = self.law.line_resistance(measurement.positions)
        command, reason = call_solver(self.law.command, float(speeds[self.law.lead]), v_ref,
                                      a_ref, float(line[self.law.lead]))
        if command is None or not np.isfinite(command):
            return self._fallback(v_ref, a_ref, speeds, reason or "the command is not finite",
                                  start)
        commands, ages = self.relay.relay(t, command)
        waiting = np.isnan(commands)
        inputs = self.law.forces(np.where(waiting, 0.0, commands), speeds)
        inputs, saturated = self._envelope.clip(inputs, speeds)
        return StepRecord(inputs=inputs, status="optimal", iterations=0,
                          solve_time=time.perf_counter() - start,
                          info={"saturated": saturated, "command": command,
                                "waiting": int(np.count_nonzero(waiting)),
                                "oldest_command_age": float(np.nanmax(ages))})

    def _fallback(self, v_ref: float, a_ref: float, speeds: Array, reason: str,
                  start: float) -> StepRecord:
        """The faulty step's record: m a_ref + R(v_ref) [N] within the envelope at ``speeds``."""
        return feedforward_fallback(self.law, self._envelope, v_ref, a_ref, speeds, reason, start)

    def _speeds(self, measurement: Measurement) -> Array:
        """The measured speeds [m/s]: the outputs, else the state's speeds."""
        return measured_speeds(measurement, self.law.n, self.name)
