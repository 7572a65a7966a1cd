# State and disturbance estimation from noisy speed measurements.
"""A Kalman observer for output feedback and offset-free tracking.

The MPC controllers can run from the measured coach speeds alone. The
observer estimates the full state [v, delta, s] and an unknown specific-force
disturbance r [m/s²] that acts on every vehicle alike — an unmodelled grade or
a resistance error — with

- a nonlinear predictor: the plant integrator :class:`trainctl.models.Plant`
  on the level-track model, driven by the applied forces minus m·r̂;
- a steady-state Kalman gain from ``control.dlqe`` for the linear model at the
  cruise speed augmented with r as a random walk:
  [x; r](k+1) = [[A_d, -b_r], [0, 1]] [x; r](k) + [B_d; 0] u(k), y = v + noise,
  where b_r is the zero-order-hold response of the velocities to a unit
  specific force.

The controller adds m·r̂ to its feedforward (allocated like the cruise
traction), which removes the steady-state error the disturbance would cause.
"""

from __future__ import annotations

from dataclasses import dataclass

import control as ct
import numpy as np
from numpy.typing import NDArray

from trainctl._validation import check_positive
from trainctl.models.discrete import discretise
from trainctl.models.linear import linearise
from trainctl.models.plant import Plant
from trainctl.models.train import Train

__all__ = ["KalmanObserver", "ObserverSettings"]

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True)
class ObserverSettings:
    """Noise levels that tune the Kalman gain.

    Parameters
    ----------
    measurement_noise : float
        Standard deviation of the speed measurements [m/s], > 0.
    speed_noise : float
        Process noise on each speed per sample [m/s], > 0.
    elongation_noise : float
        Process noise on each coupler elongation per sample [m], > 0.
    disturbance_noise : float
        Random-walk step of the disturbance per sample [m/s²], > 0; larger
        tracks grade changes faster, smaller filters noise more.

    Examples
    --------
    >>> settings = ObserverSettings(measurement_noise=0.1)
    >>> settings.measurement_noise, settings.disturbance_noise  # [m/s], [m/s²]
    (0.1, 0.001)
    >>> ObserverSettings(measurement_noise=0.0)
    Traceback (most recent call last):
    ...
    trainctl.exceptions.ModelError: ObserverSettings: 'measurement_noise' must be > 0 (got 0.0).
    """

    measurement_noise: float = 0.05
    speed_noise: float = 0.005
    elongation_noise: float = 1e-5
    disturbance_noise: float = 1e-3

    def __post_init__(self) -> None:
        for name in ("measurement_noise", "speed_noise", "elongation_noise", "disturbance_noise"):
            check_positive("ObserverSettings", name, getattr(self, name))


class KalmanObserver:
    """Estimate [v, delta, s] and the disturbance r from speed measurements.

    Parameters
    ----------
    train : Train
        The train (level-track model).
    dt : float
        Sample time [s].
    speed : float
        Speed at which the gain is designed [m/s].
    settings : ObserverSettings
        Noise levels.
    model : control.StateSpace or None
        The continuous linear model at ``speed`` (states ``[v, delta]``,
        inputs [N], outputs the speeds), e.g. the run's design model
        (:meth:`trainctl.design.DesignModel.observer_model`); None linearises
        the train here (Jacobian).

    Examples
    --------
    >>> from trainctl.models import crh2_half, equilibrium
    >>> train = crh2_half()
    >>> obs = KalmanObserver(train, 0.1, 80.0, ObserverSettings())
    >>> eq = equilibrium(train, 80.0)
    >>> obs.reset(eq.state(position=0.0))
    >>> for _ in range(600):          # a 0.02 m/s² extra resistance the model lacks
    ...     x, r = obs.correct(obs.predicted[:4] * 0 + 80.0)
    ...     obs.predict(eq.inputs + train.mass * 0.02)
    >>> round(r, 4)
    0.02
    """

    def __init__(self, train: Train, dt: float, speed: float, settings: ObserverSettings, *,
                 model: ct.StateSpace | None = None) -> None:
        self.train, self.settings = train, settings
        self.dt = check_positive("KalmanObserver", "dt", dt)
        self.plant = Plant(train=train)
        self.gain = self._gain(speed, model)
        self.reset()

    def _gain(self, speed: float, model: ct.StateSpace | None) -> Array:
        n = self.train.n_vehicles
        sys = linearise(self.train, speed) if model is None else model
        nx = sys.nstates
        b_r = np.zeros((nx, 1))
        b_r[:n, 0] = -1.0  # a specific force r decelerates every vehicle by r
        aug = ct.ss(sys.A, np.hstack([sys.B, b_r]), sys.C, 0)
        d = discretise(aug, self.dt)
        A = np.block([[d.A, d.B[:, n:]], [np.zeros((1, nx)), np.ones((1, 1))]])
        C = np.hstack([d.C, np.zeros((n, 1))])
        s = self.settings
        QN = np.diag(np.concatenate([np.full(n, s.speed_noise**2),
                                     np.full(nx - n, s.elongation_noise**2),
                                     [s.disturbance_noise**2]]))
        RN = np.eye(n) * s.measurement_noise**2
        # dlqe's gain is the predictor form x̂(k+1) = A x̂ + B u + L (y - C x̂); the filter
        # (measurement-update) gain from the same a-priori covariance P is P Cᵀ (C P Cᵀ + R)⁻¹.
        _, P, _ = ct.dlqe(A, np.eye(nx + 1), C, QN, RN)
        P = np.asarray(P, dtype=float)
        return np.asarray(np.linalg.solve(C @ P @ C.T + RN, C @ P).T, dtype=float)

    def reset(self, state: Array | None = None) -> None:
        """Restart from ``state`` ([v, delta, s]; None: wait for the first measurement).

        Parameters
        ----------
        state : ndarray, shape (2n,) or None
            Initial state ``[v (n) [m/s], delta (n-1) [m], s [m]]``, used as
            the prediction of the first sample; None starts from the first
            measured speeds instead (couplers at rest). The disturbance
            estimate restarts at 0.
        """
        self.predicted: Array = (np.zeros(2 * self.train.n_vehicles) if state is None
                                 else np.asarray(state, dtype=float).copy())
        self.disturbance = 0.0
        self._started = state is not None

    def correct(self, speeds: Array) -> tuple[Array, float]:
        """Measurement update with the measured speeds [m/s]; returns (state, r̂).

        Parameters
        ----------
        speeds : ndarray, shape (n,)
            Measured speed of each vehicle [m/s].

        Returns
        -------
        (ndarray, float)
            The state estimate ``[v (n) [m/s], delta (n-1) [m], s [m]]``,
            shape (2n,) (the position is the prediction's), and the
            disturbance estimate r̂ [m/s²].
        """
        n = self.train.n_vehicles
        y = np.asarray(speeds, dtype=float)
        if not self._started:  # first sample: speeds measured, couplers assumed at rest
            self.predicted = np.concatenate([y, np.zeros(n - 1), [0.0]])
            self._started = True
        innovation = y - self.predicted[:n]
        update = self.gain @ innovation
        self.estimate = self.predicted.copy()
        self.estimate[: 2 * n - 1] += update[:-1]
        self.disturbance += float(update[-1])
        return self.estimate, self.disturbance

    def skip(self) -> None:
        """No usable measurement at this sample: the estimate is the prediction.

        Before the first measurement there is nothing to estimate and nothing
        changes (:meth:`predict` then does nothing either).
        """
        if self._started:
            self.estimate = self.predicted.copy()

    def predict(self, inputs: Array) -> None:
        """Time update with the forces applied over the next sample [N].

        Parameters
        ----------
        inputs : ndarray, shape (n,)
            Force applied to each vehicle until the next sample [N]; the
            prediction subtracts m·r̂ from it. Nothing happens before the
            first measurement.
        """
        if not self._started:
            return
        effective = np.asarray(inputs, dtype=float) - self.train.mass * self.disturbance
        self.predicted = self.plant.advance(self.estimate, effective, self.dt)
