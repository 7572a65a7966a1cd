# What the continuous-time consensus families share: their control interval and start errors.
"""Continuous-time laws sampled at a control interval (the potential, flocking,
synchronous and hinf families).

Each family designs a continuous-time law, simulates it sampled every
``control_interval`` (the controller's ``dt``, :func:`control_interval`),
judges it from the scenario's initial errors and compares the law held over
an interval with the continuous loop; this module holds those shared steps.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from trainctl.design.stage import law_interval as law_interval
from trainctl.exceptions import ScenarioError

if TYPE_CHECKING:
    from trainctl.analysis.check import Check
    from trainctl.design import DesignModel
    from trainctl.scenario import Scenario

__all__ = ["SAMPLING_THRESHOLD", "ZERO_TOL", "ClosedLoopSpectrum", "closed_loop_spectrum",
           "control_interval", "cumulative", "held_loop", "incidence", "initial_errors",
           "law_interval", "sampling_check"]

SAMPLING_THRESHOLD = 0.1
"""Largest ω_max·T_c [rad] for which the continuous analysis stands for the sampled law.

The zero-order hold delays the law by about T_c/2, a phase lag of
ω_max·T_c/2 ≤ 0.05 rad (3°) at the closed loop's fastest mode."""

_MULTIPLE_TOL = 1e-9  # relative tolerance of "duration is a whole multiple of the interval"

ZERO_TOL = 1e-9
"""|λ| below this times max(1, ‖A‖₂) is a zero eigenvalue (a translation mode)."""


class ClosedLoopSpectrum(NamedTuple):
    """A continuous closed loop's spectrum, split into zero and other modes.

    Parameters
    ----------
    eigenvalues : ndarray
        All eigenvalues [1/s].
    tol : float
        The zero tolerance used, :data:`ZERO_TOL` · max(1, ‖A‖₂) [1/s].
    zero : ndarray of bool
        Which eigenvalues are zero (|λ| <= tol).
    abscissa : float
        Largest real part of the other eigenvalues [1/s] (0.0 when all are zero).
    semisimple : bool
        The zero eigenvalues have as many eigenvectors as their multiplicity
        (rank deficiency of A = their count): a translation that stays
        constant, not one that grows.

    Examples
    --------
    A double integrator ẍ = 0 has a zero eigenvalue twice but one
    eigenvector (a Jordan block): the translation grows, so it is not
    semisimple.

    >>> s = closed_loop_spectrum(np.array([[0.0, 1.0], [0.0, 0.0]]))
    >>> int(s.zero.sum()), s.abscissa, s.semisimple
    (2, 0.0, False)
    """

    eigenvalues: NDArray[np.complex128]
    tol: float
    zero: NDArray[np.bool_]
    abscissa: float
    semisimple: bool


def closed_loop_spectrum(A: NDArray[np.float64]) -> ClosedLoopSpectrum:
    """Spectral abscissa of a continuous closed loop apart from its zero (translation) modes.

    Parameters
    ----------
    A : ndarray
        The closed-loop state matrix, (m, m).

    Returns
    -------
    ClosedLoopSpectrum
        Eigenvalues, tolerance, zero modes, abscissa of the rest, semisimplicity.

    Examples
    --------
    >>> s = closed_loop_spectrum(np.array([[0.0, 0.0], [0.0, -2.0]]))
    >>> int(s.zero.sum()), s.abscissa, s.semisimple
    (1, -2.0, True)
    """
    lam = np.linalg.eigvals(A).astype(complex)
    tol = ZERO_TOL * max(1.0, float(np.linalg.norm(A, 2)))
    zero = np.abs(lam) <= tol
    abscissa = float(np.max(lam[~zero].real)) if np.any(~zero) else 0.0
    semisimple = A.shape[0] - np.linalg.matrix_rank(A, tol=tol) == int(zero.sum())
    return ClosedLoopSpectrum(lam, tol, zero, abscissa, bool(semisimple))


def control_interval(scenario: Scenario, model: DesignModel, settings: Any,
                     family: str) -> float:
    """The interval [s] at which the family's law runs: its setting, else the sample time.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its ``[simulation]`` duration).
    model : DesignModel
        Its design model (``[model] sample_time``).
    settings : object
        The family's settings, with ``control_interval`` [s] or None.
    family : str
        The family's name, for the message.

    Returns
    -------
    float
        The control interval [s], > 0.

    Raises
    ------
    ScenarioError
        If the simulated duration is not a whole multiple of it.

    Examples
    --------
    ``crh2-dmpc-well-sampled`` samples at 0.05 s and simulates 1200 s:

    >>> from types import SimpleNamespace
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc-well-sampled")
    >>> model = build_model(scenario)
    >>> control_interval(scenario, model, SimpleNamespace(control_interval=None), "potential")
    0.05
    >>> control_interval(scenario, model, SimpleNamespace(control_interval=0.1), "potential")
    0.1
    >>> try:  # 1200 s / 0.7 s = 1714.29 intervals
    ...     control_interval(scenario, model, SimpleNamespace(control_interval=0.7), "potential")
    ... except ScenarioError as exc:
    ...     print(type(exc).__name__)
    ScenarioError
    """
    interval = law_interval(settings, model.settings.sample_time)
    sim = scenario.simulation
    if sim is not None:
        steps = round(sim.duration / interval)
        if steps < 1 or abs(steps * interval - sim.duration) > _MULTIPLE_TOL * sim.duration:
            raise ScenarioError(
                f"{scenario.source}: [simulation] duration = {sim.duration!r} s must be a whole "
                f"multiple of the {family} family's control_interval = {interval!r} s (got "
                f"{sim.duration / interval:.6g} intervals).")
    return interval


def initial_errors(scenario: Scenario) -> NDArray[np.float64]:
    """ξ(0) = [v̂(0) (n) m/s, z(0) (n-1) m, 0 m] from ``[simulation]`` (zeros without one).

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Returns
    -------
    ndarray
        Speed errors, spacing deviations and the head's position error, shape (2n,).

    Examples
    --------
    ``heavy-haul-flocking`` starts its four trains ±2 m/s off the reference
    and its three gaps off by 90, -100 and 90 m:

    >>> from trainctl.scenario import load_scenario
    >>> initial_errors(load_scenario("heavy-haul-flocking")).tolist()
    [-2.0, 2.0, -2.0, 2.0, 90.0, -100.0, 90.0, 0.0]
    """
    n = scenario.train.n_vehicles
    xi = np.zeros(2 * n)
    if scenario.simulation is not None:
        xi[:n], xi[n:2 * n - 1] = scenario.simulation.initial_offsets(n)
    return xi


def incidence(n: int) -> NDArray[np.float64]:
    """E (n × n−1): E[k, k] = 1 (front vehicle of link k), E[k+1, k] = −1 (rear vehicle).

    Parameters
    ----------
    n : int
        Number of vehicles.

    Returns
    -------
    ndarray
        The incidence matrix E, shape (n, n − 1).

    Examples
    --------
    >>> incidence(3).tolist()
    [[1.0, 0.0], [-1.0, 1.0], [0.0, -1.0]]
    """
    E = np.zeros((n, max(n - 1, 0)))
    k = np.arange(n - 1)
    E[k, k], E[k + 1, k] = 1.0, -1.0
    return E


def cumulative(n: int) -> NDArray[np.float64]:
    """S (n × n−1): S[i, k] = 1 for k < i, so that x̂ = 1·p − S z.

    Parameters
    ----------
    n : int
        Number of vehicles.

    Returns
    -------
    ndarray
        The matrix S, shape (n, n − 1).

    Examples
    --------
    >>> cumulative(3).tolist()
    [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]
    """
    return np.tril(np.ones((n, max(n - 1, 0))), -1)


def held_loop(A_open: NDArray[np.float64], B_open: NDArray[np.float64],
              feedback: NDArray[np.float64], interval: float) -> NDArray[np.float64]:
    """The closed loop over one interval with the law held: Φ + Γ F (exact ZOH of the plant).

    Parameters
    ----------
    A_open, B_open : ndarray
        Continuous open loop [1/s] and input matrix, (N, N) and (N, m).
    feedback : ndarray
        The law's linear gain F, û = F ξ, (m, N).
    interval : float
        T [s], > 0.

    Returns
    -------
    ndarray
        (N, N) [-].

    Examples
    --------
    >>> H = held_loop(np.zeros((1, 1)), np.ones((1, 1)), -np.ones((1, 1)), 0.5)
    >>> float(H[0, 0])  # ẋ = u, u = -x held: x+ = x - T x
    0.5
    """
    N, m = B_open.shape
    block = np.zeros((N + m, N + m))
    block[:N, :N], block[:N, N:] = A_open, B_open
    E = scipy.linalg.expm(block * float(interval))
    return np.asarray(E[:N, :N] + E[:N, N:] @ feedback, dtype=float)


def sampling_check(name: str, A_cl: NDArray[np.float64], held: NDArray[np.float64],
                   interval: float, threshold: float = SAMPLING_THRESHOLD) -> Check:
    """ω_max·T_c of a continuous law against ``threshold``; the held loop's spectral radius.

    Pass when ω_max·T_c ≤ ``threshold`` (the continuous analysis stands for
    the sampled law, :data:`SAMPLING_THRESHOLD`), warn above it while the
    held loop is stable, fail when its spectral radius exceeds 1. The
    message compares that radius with e^(αT), α the continuous spectral
    abscissa: equal to many digits when the sampling is fine.

    Parameters
    ----------
    name : str
        The check's name.
    A_cl : ndarray
        The continuous linear closed loop [1/s].
    held : ndarray
        The same loop with the law held over each interval (:func:`held_loop`).
    interval : float
        T_c [s].
    threshold : float
        Largest ω_max·T_c [rad] that passes.

    Returns
    -------
    Check
        Value ω_max·T_c [rad].

    Examples
    --------
    ẋ = u with u = -x: ω_max = 1 rad/s, and held over T the loop is
    x⁺ = (1 - T) x.

    >>> A_cl, A, B, F = -np.ones((1, 1)), np.zeros((1, 1)), np.ones((1, 1)), -np.ones((1, 1))
    >>> [sampling_check("demo", A_cl, held_loop(A, B, F, T), T).status for T in (0.05, 0.5, 3.0)]
    ['pass', 'warn', 'fail']
    >>> check = sampling_check("demo", A_cl, held_loop(A, B, F, 3.0), 3.0)
    >>> round(check.details["sampled_radius"], 6)  # |1 - 3| = 2 > 1: unstable
    2.0
    """
    from trainctl.analysis.check import Check

    lam = np.linalg.eigvals(A_cl)
    omega = float(np.max(np.abs(lam)))
    alpha = float(np.max(lam.real))
    rho = float(np.max(np.abs(np.linalg.eigvals(held))))
    expected = math.exp(alpha * interval)
    value = omega * interval
    details = {"omega_max": omega, "sampled_radius": rho, "continuous_radius": expected}
    text = (f"ω_max·T_c = {omega:.4g} rad/s × {interval:g} s = {value:.3g} rad; sampled loop "
            f"ρ = {rho:.8g} (continuous e^(αT) = {expected:.8g})")
    if rho > 1.0 + 1e-9:
        return Check(name=name, status="fail", value=value, threshold=threshold,
                     unit="rad", message=f"sampled law unstable: {text}",
                     hint="shorten control_interval", details=details)
    status = "pass" if value <= threshold else "warn"
    return Check(name=name, status=status, value=value, threshold=threshold, unit="rad",
                 message=text, hint="" if status == "pass" else
                 f"shorten control_interval below {threshold / omega:.3g} s",
                 details=details)
