# Modal analysis of continuous linear train models.
"""Eigenvalues of a linear train model, classified and named.

Each mode of ``[v; delta]`` models is classified from its eigenvalue and
eigenvector:

``"rigid-body"``
    Real mode in which the vehicles that move at all move the same way
    (non-negligible velocity components of one sign): a train, or each
    virtually coupled unit, speeding up or slowing down as a whole.
``"coupler"``
    Oscillatory pair: vehicles vibrating against each other on the couplers.
``"dummy"``
    Seed 000's dummy state of the last coach (eigenvalue 0, decoupled).
``"integrator"``
    Other zero eigenvalues, e.g. gap drift of virtually coupled trains.
``"real"``
    Any other real (overdamped) mode.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np

__all__ = ["ZERO_TOL", "Mode", "classify_mode", "continuous_modes", "nyquist_sample_time"]

ZERO_TOL = 1e-9
"""Eigenvalues with |lambda| below this times max(1, ||A||) count as zero."""


@dataclass(frozen=True, kw_only=True)
class Mode:
    """One eigenvalue (or conjugate pair) of a continuous model.

    Parameters
    ----------
    eigenvalue : complex
        Eigenvalue [1/s]; for a pair, the one with positive imaginary part.
    kind : str
        ``"rigid-body"``, ``"coupler"``, ``"dummy"``, ``"integrator"`` or ``"real"``.
    natural_frequency : float
        |lambda| [rad/s].
    damping_ratio : float
        -Re(lambda)/|lambda| [-]; NaN for a zero eigenvalue.
    multiplicity : int
        1 for a real eigenvalue, 2 for a conjugate pair.

    Examples
    --------
    Two vehicles with k/m = 0.5 1/s² on one coupler and a resistance slope of
    0.02 1/s: the coupler pair solves λ² + 0.02λ + 2·0.5 = 0, so |λ| = 1 rad/s
    and ζ = 0.01; the whole train decays at −0.02 1/s.

    >>> import control as ct
    >>> A = [[-0.02, 0.0, -0.5], [0.0, -0.02, 0.5], [1.0, -1.0, 0.0]]
    >>> sys = ct.ss(A, [[1.0], [0.0], [0.0]], [[1.0, 0.0, 0.0]], 0,
    ...             states=["v[0]", "v[1]", "delta[0]"])
    >>> rigid, pair = continuous_modes(sys, n_vehicles=2)
    >>> rigid.kind, round(rigid.eigenvalue.real, 4), rigid.period
    ('rigid-body', -0.02, inf)
    >>> pair.kind, pair.multiplicity, round(pair.natural_frequency, 4)
    ('coupler', 2, 1.0)
    >>> round(pair.damping_ratio, 4), round(pair.period, 5)  # 2π/√(1 - 0.01²) s
    (0.01, 6.2835)
    """

    eigenvalue: complex
    kind: str
    natural_frequency: float
    damping_ratio: float
    multiplicity: int

    @property
    def period(self) -> float:
        """Oscillation period 2π/Im(lambda) [s]; inf for real modes."""
        im = abs(self.eigenvalue.imag)
        return 2 * math.pi / im if im > 0 else math.inf

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict (complex as [re, im], NaN/inf as None).

        Returns
        -------
        dict
            ``kind``, ``eigenvalue`` ([re, im] [1/s]),
            ``natural_frequency`` [rad/s], ``damping_ratio`` [-] (None for
            a zero eigenvalue), ``period`` [s] (None for a real mode) and
            ``multiplicity``.
        """
        return {
            "kind": self.kind,
            "eigenvalue": [self.eigenvalue.real, self.eigenvalue.imag],
            "natural_frequency": self.natural_frequency,
            "damping_ratio": None if math.isnan(self.damping_ratio) else self.damping_ratio,
            "period": None if math.isinf(self.period) else self.period,
            "multiplicity": self.multiplicity,
        }


def continuous_modes(sys: ct.StateSpace, *, n_vehicles: int) -> tuple[Mode, ...]:
    """Classified modes of a continuous linear train model.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous model with states ordered ``[v (n), delta (...)]`` as built
        by :func:`trainctl.models.linearise`.
    n_vehicles : int
        Number of vehicles n (the first n states are velocities).

    Returns
    -------
    tuple of Mode
        Sorted by natural frequency; conjugate pairs reported once.

    Examples
    --------
    >>> from trainctl.models import crh2_half, linearise
    >>> modes = continuous_modes(linearise(crh2_half(), 300 / 3.6, dummy_state=True),
    ...                          n_vehicles=4)
    >>> [m.kind for m in modes]
    ['dummy', 'rigid-body', 'coupler', 'coupler', 'coupler']
    >>> round(modes[-1].natural_frequency, 3)
    27.77
    """
    A = np.asarray(sys.A, dtype=float)
    lam, vec = np.linalg.eig(A)
    scale = max(1.0, float(np.linalg.norm(A, ord=np.inf)))
    labels = list(sys.state_labels)
    modes = []
    for k in np.argsort(np.abs(lam), kind="stable"):
        value = complex(lam[k])
        if value.imag < -ZERO_TOL * scale:
            continue
        kind = classify_mode(value, vec[:, k], n_vehicles, labels, scale)
        wn = abs(value)
        zeta = -value.real / wn if wn > ZERO_TOL * scale else math.nan
        pair = 2 if value.imag > ZERO_TOL * scale else 1
        modes.append(Mode(eigenvalue=value, kind=kind, natural_frequency=wn,
                          damping_ratio=zeta, multiplicity=pair))
    return tuple(modes)


def classify_mode(value: complex, vec: np.ndarray, n: int, labels: list[str], scale: float) -> str:
    """The structural kind of an eigenvalue of a train model with states ``[v, delta]``.

    Parameters
    ----------
    value : complex
        The eigenvalue (continuous time) [1/s].
    vec : ndarray
        Its eigenvector.
    n : int
        Number of vehicles (the first n states are speeds).
    labels : list of str
        State names (``delta[n-1]`` is seed 000's dummy state).
    scale : float
        max(1, ||A||): the zero tolerance is :data:`ZERO_TOL` times this.

    Returns
    -------
    str
        ``"coupler"`` (oscillatory), ``"dummy"``, ``"integrator"`` (zero),
        ``"rigid-body"`` (all speeds of one sign) or ``"real"``.

    Examples
    --------
    >>> import numpy as np
    >>> labels = ["v[0]", "v[1]", "delta[0]"]
    >>> classify_mode(-0.02, np.array([1.0, 1.0, 0.0]), 2, labels, 1.0)  # both speeds alike
    'rigid-body'
    >>> classify_mode(-0.02, np.array([1.0, -1.0, 0.5]), 2, labels, 1.0)  # opposite speeds
    'real'
    >>> classify_mode(0.0, np.array([1.0, 1.0, 0.0]), 2, labels, 1.0)  # no resistance: drift
    'integrator'
    >>> classify_mode(-0.01 + 1j, np.array([1.0, -1.0, 1j]), 2, labels, 1.0)
    'coupler'
    """
    if abs(value.imag) > ZERO_TOL * scale:
        return "coupler"
    weights = np.abs(vec)
    if abs(value) <= ZERO_TOL * scale:
        top = int(np.argmax(weights))
        dummy = f"delta[{n - 1}]"
        if labels[top] == dummy and weights[top] > 0.999 * np.linalg.norm(vec):
            return "dummy"
        return "integrator"
    v = vec[:n].real
    v = v[np.abs(v) > 1e-6 * np.max(np.abs(v), initial=0.0)]
    if v.size and (np.all(v > 0) or np.all(v < 0)):
        return "rigid-body"
    return "real"


def nyquist_sample_time(modes: tuple[Mode, ...]) -> float:
    """Largest sample time that resolves every coupler mode, π/ω_max [s].

    Parameters
    ----------
    modes : tuple of Mode
        Modes from :func:`continuous_modes`.

    Returns
    -------
    float
        The time π / max |Im λ| over the coupler modes [s]; inf without
        coupler modes.

    Examples
    --------
    >>> from trainctl.models import crh2_half, linearise
    >>> sys = linearise(crh2_half(), 300 / 3.6)
    >>> round(nyquist_sample_time(continuous_modes(sys, n_vehicles=4)), 4)
    0.1131
    """
    freqs = [abs(m.eigenvalue.imag) for m in modes if m.kind == "coupler"]
    return math.pi / max(freqs) if freqs else math.inf
