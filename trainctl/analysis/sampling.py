# Sampling adequacy: does the sample time resolve the coupler modes?
"""Sampling adequacy of a sample time for a continuous train model.

Two numbers decide whether a sampled controller can act on the couplers:

- T·ω_max against π: above π the fastest coupler mode is aliased (its
  discrete eigen-angle folds back), so no controller at this rate can damp it.
- The collapse of the discrete input directions: the columns of B_d
  normalised to unit length, and the ratio of their smallest to largest
  singular value. Near 0 every input acts the same way over one sample
  (seed 000 at T = 20 s: the train moves as one rigid body), and distributed
  controllers fight over one direction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np

from trainctl.analysis.modes import continuous_modes, nyquist_sample_time
from trainctl.models.discrete import discretise

__all__ = ["SamplingResult", "analyse_sampling"]


@dataclass(frozen=True, kw_only=True)
class SamplingResult:
    """Sampling adequacy numbers.

    Parameters
    ----------
    sample_time : float
        T [s].
    omega_max : float
        Largest coupler-mode frequency |Im(lambda)| [rad/s] (0 without couplers).
    nyquist_sample_time : float
        π/ω_max [s] (inf without couplers).
    input_collapse : float
        σ_min/σ_max of B_d with unit-norm columns [-]: 1 = independent input
        directions, 0 = all inputs act identically.

    Examples
    --------
    The CRH2 half train's fastest coupler mode is 27.77 rad/s; T = 0.05 s
    resolves it (ω_max·T = 1.39 rad < π), the book's T = 20 s does not.

    >>> from trainctl.models import crh2_half, linearise
    >>> sys = linearise(crh2_half(), 300 / 3.6)
    >>> fine = analyse_sampling(sys, 0.05, n_vehicles=4)
    >>> round(fine.omega_max, 2), round(fine.omega_t, 2), fine.resolves_couplers
    (27.77, 1.39, True)
    >>> round(fine.nyquist_sample_time, 4)  # π/ω_max [s]
    0.1131
    >>> analyse_sampling(sys, 20.0, n_vehicles=4).resolves_couplers
    False
    """

    sample_time: float
    omega_max: float
    nyquist_sample_time: float
    input_collapse: float

    @property
    def omega_t(self) -> float:
        """ω_max·T [rad], to compare with π."""
        return self.omega_max * self.sample_time

    @property
    def resolves_couplers(self) -> bool:
        """True when ω_max·T < π."""
        return self.omega_t < math.pi

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``sample_time`` [s], ``omega_max`` [rad/s], ``omega_t`` [rad],
            ``nyquist_sample_time`` [s] (None without couplers),
            ``resolves_couplers`` and ``input_collapse`` [-].
        """
        nyq = None if math.isinf(self.nyquist_sample_time) else self.nyquist_sample_time
        return {"sample_time": self.sample_time, "omega_max": self.omega_max,
                "omega_t": self.omega_t, "nyquist_sample_time": nyq,
                "resolves_couplers": self.resolves_couplers, "input_collapse": self.input_collapse}

    def _repr_html_(self) -> str:
        verdict = "resolves" if self.resolves_couplers else "aliases"
        return (f"<p><b>Sampling</b>: T = {self.sample_time:g} s {verdict} the coupler modes "
                f"(ω_max·T = {self.omega_t:.3g} rad vs π); input collapse "
                f"{self.input_collapse:.3g}</p>")


def analyse_sampling(
    sys: ct.StateSpace, dt: float, *, n_vehicles: int, method: str = "zoh",
    sysd: ct.StateSpace | None = None,
) -> SamplingResult:
    """Sampling adequacy of ``dt`` for the continuous model ``sys``.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous linear train model (states ``[v, delta]``).
    dt : float
        Sample time T [s].
    n_vehicles : int
        Number of vehicles.
    method : {"zoh", "tustin"}
        Discretisation used for B_d.
    sysd : control.StateSpace or None
        ``sys`` already discretised at ``dt`` with ``method`` (not
        discretised again); None discretises here.

    Returns
    -------
    SamplingResult
        The product ω_max·T, the Nyquist sample time and the input collapse.

    Examples
    --------
    >>> from trainctl.models import crh2_half, linearise
    >>> sys = linearise(crh2_half(), 300 / 3.6)
    >>> res = analyse_sampling(sys, 20.0, n_vehicles=4)
    >>> res.resolves_couplers, res.input_collapse < 1e-2
    (False, True)
    """
    modes = continuous_modes(sys, n_vehicles=n_vehicles)
    omega = max((abs(m.eigenvalue.imag) for m in modes if m.kind == "coupler"), default=0.0)
    if sysd is None:
        sysd = discretise(sys, dt, method=method)
    Bd = np.asarray(sysd.B, dtype=float)
    norms = np.linalg.norm(Bd, axis=0)
    sv = np.linalg.svd(Bd / np.where(norms > 0, norms, 1.0), compute_uv=False)
    collapse = float(sv[-1] / sv[0]) if Bd.shape[1] > 1 and sv[0] > 0 else 1.0
    return SamplingResult(sample_time=float(dt), omega_max=omega,
                          nyquist_sample_time=nyquist_sample_time(modes), input_collapse=collapse)
