# Stability of continuous and discrete linear models, mode by mode.
"""Eigenvalue-based stability with an explicit tolerance band.

Each eigenvalue is classified as

``"stable"``
    Re(lambda) < -tol (continuous) or |z| < 1 - tol (discrete).
``"marginal-semisimple"``
    On the boundary within ``tol`` and semisimple (as many independent
    eigenvectors as the eigenvalue's multiplicity): bounded, does not decay.
``"marginal-defective"``
    On the boundary with a Jordan block: grows polynomially (a double
    integrator); unstable in practice.
``"unstable"``
    Re(lambda) > tol or |z| > 1 + tol.

Multiplicities are found by clustering eigenvalues within ``tol`` and the
geometric multiplicity from the numerical rank of A - lambda I (singular
values below ``rank_tol`` times the largest count as zero).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np
from numpy.typing import ArrayLike

from trainctl.analysis.check import finite_or_none
from trainctl.analysis.modes import ZERO_TOL, classify_mode

__all__ = ["ModeStability", "StabilityResult", "analyse_stability", "mode_direction"]

CLASSES = ("stable", "marginal-semisimple", "marginal-defective", "unstable")
"""Stability classes, from best to worst."""


@dataclass(frozen=True, kw_only=True)
class ModeStability:
    """Stability of one eigenvalue.

    Parameters
    ----------
    eigenvalue : complex
        Eigenvalue (continuous [1/s] or discrete [-]).
    status : str
        One of ``CLASSES``.
    algebraic_multiplicity, geometric_multiplicity : int
        Multiplicities of the eigenvalue's cluster.
    natural_frequency : float
        |s| [rad/s] of the continuous eigenvalue (for discrete systems
        s = log(z)/dt).
    damping_ratio : float
        -Re(s)/|s| [-]; NaN when s = 0.
    name : str
        Structural name where one applies (``"rigid-body"``, ``"dummy"``,
        ``"coupler"``), else ``""``.
    direction : dict of str to float
        Largest components of the (normalised) eigenvector by state name.

    Examples
    --------
    A double integrator: one eigenvalue 0 of algebraic multiplicity 2 but a
    single eigenvector (a Jordan block), so the position grows like t.

    >>> import numpy as np
    >>> mode = analyse_stability(np.array([[0.0, 1.0], [0.0, 0.0]])).modes[0]
    >>> mode.status, mode.algebraic_multiplicity, mode.geometric_multiplicity
    ('marginal-defective', 2, 1)
    >>> mode.direction, mode.to_dict()["damping_ratio"]  # ζ undefined at s = 0
    ({'x[0]': 1.0}, None)
    """

    eigenvalue: complex
    status: str
    algebraic_multiplicity: int
    geometric_multiplicity: int
    natural_frequency: float
    damping_ratio: float
    name: str
    direction: dict[str, float]

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict (complex as [re, im], NaN as None).

        Returns
        -------
        dict
            ``eigenvalue`` as [re, im] ([1/s] or [-]), ``status``, the two
            multiplicities, ``natural_frequency`` [rad/s],
            ``damping_ratio`` [-] (None when s = 0), ``name`` and
            ``direction`` (a copy).
        """
        return {
            "eigenvalue": [self.eigenvalue.real, self.eigenvalue.imag],
            "status": self.status,
            "algebraic_multiplicity": self.algebraic_multiplicity,
            "geometric_multiplicity": self.geometric_multiplicity,
            "natural_frequency": self.natural_frequency,
            "damping_ratio": None if math.isnan(self.damping_ratio) else self.damping_ratio,
            "name": self.name,
            "direction": dict(self.direction),
        }


@dataclass(frozen=True, kw_only=True)
class StabilityResult:
    """Mode-by-mode stability of a linear system.

    Parameters
    ----------
    discrete : bool
        True for a discrete-time system.
    dt : float
        Sample time [s] (0 for continuous).
    tol : float
        Half-width of the marginal band around the stability boundary.
    modes : tuple of ModeStability
        One entry per eigenvalue.

    Examples
    --------
    A discrete system with z = 0.5 and z = −1 at T = 0.1 s: the second sits on
    the unit circle; the first is s = ln(0.5)/T = −6.931 1/s.

    >>> import control as ct
    >>> res = analyse_stability(ct.ss([[0.5, 0.0], [0.0, -1.0]], [[1.0], [1.0]], [[1.0, 0.0]], 0,
    ...                               0.1))
    >>> res.discrete, res.status, res.count("stable"), round(res.spectral_abscissa, 4)
    (True, 'marginal-semisimple', 1, 1.0)
    >>> round(res.modes[0].natural_frequency, 3)  # [rad/s]
    6.931
    """

    discrete: bool
    dt: float
    tol: float
    modes: tuple[ModeStability, ...]

    @property
    def status(self) -> str:
        """Worst class over all modes."""
        return max((m.status for m in self.modes), key=CLASSES.index, default="stable")

    @property
    def spectral_abscissa(self) -> float:
        """max Re(lambda) (continuous) or max |z| (discrete)."""
        values = [abs(m.eigenvalue) if self.discrete else m.eigenvalue.real for m in self.modes]
        return max(values, default=-math.inf)

    def count(self, status: str) -> int:
        """Number of eigenvalues with this status.

        Parameters
        ----------
        status : str
            One of ``CLASSES`` (another string counts nothing).

        Returns
        -------
        int
            How many of :attr:`modes` have it, >= 0.
        """
        return sum(1 for m in self.modes if m.status == status)

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict.

        Returns
        -------
        dict
            ``discrete``, ``dt`` [s], ``tol``, the worst ``status``,
            ``spectral_abscissa`` ([1/s] continuous, [-] discrete; None
            without modes) and
            ``modes`` (each mode's dict).
        """
        return {
            "discrete": self.discrete,
            "dt": self.dt,
            "tol": self.tol,
            "status": self.status,
            # -inf for a system without modes: strict JSON has no infinity
            "spectral_abscissa": finite_or_none(self.spectral_abscissa),
            "modes": [m.to_dict() for m in self.modes],
        }

    def _repr_html_(self) -> str:
        counts = ", ".join(f"{c}: {self.count(c)}" for c in CLASSES if self.count(c))
        kind = "discrete" if self.discrete else "continuous"
        return f"<p><b>Stability ({kind})</b>: {self.status} — {counts}</p>"


def analyse_stability(
    sys: ct.StateSpace | ArrayLike,
    *,
    tol: float = 1e-9,
    rank_tol: float = 1e-8,
    n_vehicles: int | None = None,
) -> StabilityResult:
    """Classify every eigenvalue of a linear system.

    Parameters
    ----------
    sys : control.StateSpace or array_like
        The system, or a bare state matrix A (then continuous).
    tol : float
        Marginal band: |Re(lambda)| <= tol (continuous) or ||z| - 1| <= tol
        (discrete), relative to max(1, ||A||) for continuous systems.
    rank_tol : float
        Relative singular-value threshold for the geometric multiplicity.
    n_vehicles : int or None
        Number of vehicles when the states are ``[v, delta]``; enables the
        structural names (rigid-body, dummy, coupler).

    Returns
    -------
    StabilityResult
        The classified modes.

    Examples
    --------
    >>> import numpy as np
    >>> analyse_stability(np.array([[0.0, 1.0], [0.0, 0.0]])).status
    'marginal-defective'
    >>> analyse_stability(np.zeros((2, 2))).status
    'marginal-semisimple'
    """
    A, dt, labels = _unpack(sys)
    discrete = dt != 0
    lam, vec = np.linalg.eig(A)
    scale = 1.0 if discrete else max(1.0, float(np.linalg.norm(A, ord=np.inf)))
    modes = []
    for k, value in enumerate(lam):
        dist = abs(value) - 1.0 if discrete else value.real
        cluster = np.abs(lam - value) <= max(tol * scale, 1e-12)
        alg = int(cluster.sum())
        # A simple eigenvalue has one eigenvector: the SVD (O(n³) per mode) only for clusters.
        geo = 1 if alg == 1 else _geometric_multiplicity(A, value, rank_tol)
        if dist > tol * scale:
            status = "unstable"
        elif dist < -tol * scale:
            status = "stable"
        else:
            status = "marginal-semisimple" if geo >= alg else "marginal-defective"
        s = _continuous_equivalent(complex(value), dt)
        wn = abs(s)
        modes.append(ModeStability(
            eigenvalue=complex(value), status=status, algebraic_multiplicity=alg,
            geometric_multiplicity=min(geo, alg), natural_frequency=wn,
            damping_ratio=-s.real / wn if wn > ZERO_TOL else math.nan,
            name=_structural_name(s, vec[:, k], labels, n_vehicles),
            direction=mode_direction(vec[:, k], labels),
        ))
    return StabilityResult(discrete=discrete, dt=float(dt), tol=tol, modes=tuple(modes))


def _unpack(sys: ct.StateSpace | ArrayLike) -> tuple[np.ndarray, float, list[str]]:
    if isinstance(sys, ct.StateSpace):
        dt = 0.0 if sys.dt in (0, None) else (1.0 if sys.dt is True else float(sys.dt))
        return np.asarray(sys.A, dtype=float), dt, list(sys.state_labels)
    A = np.atleast_2d(np.asarray(sys, dtype=float))
    return A, 0.0, [f"x[{i}]" for i in range(A.shape[0])]


def _geometric_multiplicity(A: np.ndarray, value: complex, rank_tol: float) -> int:
    sv = np.linalg.svd(A - value * np.eye(A.shape[0]), compute_uv=False)
    return int(np.sum(sv <= rank_tol * max(1.0, sv[0])))


def _continuous_equivalent(value: complex, dt: float) -> complex:
    if dt == 0:
        return value
    return complex(np.log(value) / dt) if value != 0 else complex(-math.inf)


def _structural_name(s: complex, vec: np.ndarray, labels: list[str], n: int | None) -> str:
    if n is None or not math.isfinite(s.real):
        return ""
    kind = classify_mode(s, vec, n, labels, 1.0)
    return kind if kind in ("rigid-body", "dummy", "coupler") else ""


def mode_direction(vec: np.ndarray, labels: list[str], keep: int = 4) -> dict[str, float]:
    """The states an eigenvector mostly lies along, with their normalised weights.

    Parameters
    ----------
    vec : ndarray
        The eigenvector.
    labels : list of str
        State names, one per entry of ``vec``.
    keep : int
        How many states to list at most.

    Returns
    -------
    dict of str to float
        State name -> |component| / ||vec|| for the largest components above 1e-3.

    Examples
    --------
    >>> mode_direction(np.array([3.0, 4.0, 0.0]), ["a", "b", "c"])
    {'b': 0.8, 'a': 0.6}
    """
    w = np.abs(vec) / max(float(np.linalg.norm(vec)), 1e-300)
    order = np.argsort(-w)[:keep]
    return {labels[i]: round(float(w[i]), 6) for i in order if w[i] > 1e-3}
