# The flocking controller: Olfati-Saber's law sampled at its control interval, clipped.
"""The flocking controller: u = ū(v_r, a_r) + m·a(v̂, z, x̂), clipped to the envelope.

The law (:mod:`trainctl.controllers.flocking.law`) is continuous in time; the
simulation calls :meth:`FlockingController.step` every ``dt`` (the family's
``control_interval``) and holds the force until the next call. The virtual
leader's position x̄_0(t) starts at the head's measured position at the
first step after :meth:`~FlockingController.reset` and follows the
reference speed (trapezoid between steps; exact on each linear piece of the
reference). Train i's slot is x̄_0 minus the nominal centre distances
ahead of it, so x̂_i = x̂_0 − Σ_{k<i} z_k.

Faults (:mod:`trainctl.controllers.faults`): a state that is not finite, two
trains that overlap, a law that raises or a force that is not finite gives
the status ``"error"`` with the reason in ``info["reason"]`` and the cruise
feedforward (fallback ``"feedforward"``), clipped to the envelope at the
measured speeds (at the reference speed when they are not finite).

With a braking supervisor (:mod:`~trainctl.controllers.flocking.supervisor`,
``supervisor = true``) every step with a finite state is also checked: a
follower that could not stop behind its leader braking at its strongest gets
its full braking instead of the law's force. Such a step is recorded through
``step`` and ``step_inputs`` alike, status ``"optimal"``, fallback
``"supervisor_braking"``
(:data:`~trainctl.controllers.faults.SUPERVISOR_BRAKING`) and
``info["supervisor"]`` the followers braked (their vehicle indices, 1 for the
first train behind the head); on a faulty step the fault's status, fallback
and reason stand and ``info["supervisor"]`` is added. Steps the supervisor
lets pass are recorded as without it.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.base import StepRecord
from trainctl.controllers.continuous.controller import SampledLawController
from trainctl.controllers.faults import SUPERVISOR_BRAKING, finite
from trainctl.controllers.flocking.law import FlockingLaw
from trainctl.exceptions import ModelError

if TYPE_CHECKING:
    from trainctl.controllers.flocking.supervisor import BrakingSupervisor
    from trainctl.models.train import Train

__all__ = ["FlockingController"]

Array = NDArray[np.float64]


class FlockingController(SampledLawController[FlockingLaw]):
    """Olfati-Saber's flocking law about the cruise feedforward (module docstring).

    Parameters
    ----------
    train : Train
        The formation: one vehicle per train, virtual links.
    law : FlockingLaw
        Gains and pair potential.
    dt : float
        Control interval [s], > 0.
    input_bounds : bool
        Clip each force to the train's envelope at its measured speed.
    name : str or None
        Label; None: ``"flocking"``.
    supervisor : BrakingSupervisor or None
        The braking supervisor over the law (module docstring), its interval
        ``dt``; None: the law alone.

    Raises
    ------
    ModelError
        If the law does not fit the train, or the supervisor's formation or
        interval differ from the controller's.

    Examples
    --------
    >>> from trainctl.controllers.base import Measurement, ReferencePreview
    >>> from trainctl.scenario import load_scenario
    >>> from trainctl.controllers.flocking.law import law_of
    >>> from trainctl.models import equilibrium
    >>> scenario = load_scenario("heavy-haul-flocking")
    >>> law = law_of(scenario, scenario.controllers["flocking"])
    >>> ctl = FlockingController(scenario.train, law, dt=1.0)
    >>> eq = equilibrium(scenario.train, 22.0)
    >>> ref = ReferencePreview(times=np.zeros(1), speed=np.full(1, 22.0),
    ...                        acceleration=np.zeros(1))
    >>> rec = ctl.step(0.0, Measurement(state=eq.state(position=0.0)), ref)
    >>> bool(np.allclose(rec.inputs, eq.inputs)), rec.status
    (True, 'optimal')
    """

    default_name = "flocking"
    vehicles = ("trains", "formation")

    def __init__(self, train: Train, law: FlockingLaw, *, dt: float, input_bounds: bool = True,
                 name: str | None = None, supervisor: BrakingSupervisor | None = None) -> None:
        super().__init__(train, law, dt=dt, input_bounds=input_bounds, name=name)
        if supervisor is not None and (supervisor.n != train.n_vehicles
                                       or supervisor.interval != self.dt):
            raise ModelError(
                f"{type(self).__name__}: the supervisor must watch this formation at the "
                f"control interval ({train.n_vehicles} trains every {self.dt!r} s; got "
                f"{supervisor.n} trains every {supervisor.interval!r} s).")
        self.supervisor = supervisor

    def reset(self) -> None:
        """Forget the reference position and the supervisor's received states."""
        super().reset()
        if self.supervisor is not None:
            self.supervisor.reset()

    def _law_inputs(self, t: float, x: Array, speed: float, accel: float,
                    start: float) -> tuple[Array, int, dict[str, Any]] | StepRecord:
        """The law's step (:class:`SampledLawController`), then the supervisor's check."""
        result = super()._law_inputs(t, x, speed, accel, start)
        if self.supervisor is None:
            return result
        return self._supervised(t, x, result, start)

    def _supervised(self, t: float, x: Array,
                    result: tuple[Array, int, dict[str, Any]] | StepRecord,
                    start: float) -> tuple[Array, int, dict[str, Any]] | StepRecord:
        """The step with the followers that must brake at full overridden (module docstring)."""
        assert self.supervisor is not None
        if not finite(x):
            return result  # the fault's record: nothing to judge
        if isinstance(result, StepRecord):
            inputs = np.asarray(result.inputs, dtype=float)
        else:
            inputs = result[0]
        brake = self.supervisor.supervise(t, x, inputs)
        if not brake.size:
            return result
        n = self.train.n_vehicles
        forced = inputs.copy()
        forced[brake] = self.supervisor.full_braking(x[:n])[brake]
        followers = [int(i) for i in brake]
        if isinstance(result, StepRecord):
            return StepRecord(inputs=forced, status=result.status, iterations=result.iterations,
                              residuals=result.residuals,
                              solve_time=time.perf_counter() - start, fallback=result.fallback,
                              info={**result.info, "supervisor": followers})
        _, saturated, info = result
        return StepRecord(inputs=forced, status="optimal", iterations=0,
                          solve_time=time.perf_counter() - start, fallback=SUPERVISOR_BRAKING,
                          info={"saturated": saturated, **info, "supervisor": followers})

    def _refuse(self, z: Array) -> tuple[str, dict[str, Any]]:
        """Two trains that overlap; the smallest gap [m] (``info["min_gap"]``)."""
        gaps = self.law.gaps(z)
        if np.any(gaps < 0.0):
            return f"two trains overlap (smallest gap {float(np.min(gaps)):.4g} m)", {}
        return "", {"min_gap": float(np.min(gaps))}
