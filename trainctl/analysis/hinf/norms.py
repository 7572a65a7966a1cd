# The H∞ norm by python-control and by the level set, compared; the norm of every channel.
"""The H∞ norm by python-control (the reference) and by the level set, compared
(:func:`hinf_norm`), and the norm of every input → output channel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control as ct
import numpy as np
from numpy.typing import NDArray

from trainctl.analysis.hinf.balancing import _system_data
from trainctl.analysis.hinf.level_set import MAX_LEVELS, _own_norm

__all__ = [
    "AGREEMENT", "ChannelNorms", "HinfNorm", "channel_norms", "control_hinf_norm", "hinf_norm",
]

Array = NDArray[np.float64]

AGREEMENT = 1e-4
"""Relative difference within which the two norm routes agree."""

_LINFNORM_TOL = 1e-10


def control_hinf_norm(sys: ct.StateSpace | ct.TransferFunction) -> tuple[float, float]:
    """‖G‖∞ and its peak frequency from python-control's ``linfnorm`` (slycot ``ab13dd``).

    ``ab13dd`` balances the system itself (``equil='S'``) and returns the L∞
    norm; this function returns inf for a system whose A is not Hurwitz (not
    Schur), as the H∞ norm of such a system is infinite.

    Parameters
    ----------
    sys : control.StateSpace or control.TransferFunction
        Continuous or discrete system.

    Returns
    -------
    (float, float)
        The norm and the peak frequency [rad/s] (discrete: θ/dt; NaN when
        unstable).

    Examples
    --------
    >>> import control as ct
    >>> g, w = control_hinf_norm(ct.tf([2.0], [1.0, 4.0]))
    >>> round(g, 9), w
    (0.5, 0.0)
    """
    A, B, C, D, dt = _system_data(sys, "control_hinf_norm")
    n = A.shape[0]
    if n:
        lam = np.linalg.eigvals(A)
        if (dt is None and np.max(lam.real) >= 0.0) or (dt is not None
                                                        and np.max(np.abs(lam)) >= 1.0):
            return math.inf, math.nan
    system = ct.ss(A, B, C, D) if dt is None else ct.ss(A, B, C, D, dt)
    g, w = ct.linfnorm(system, tol=_LINFNORM_TOL)
    return float(g), float(w)


@dataclass(frozen=True, kw_only=True)
class HinfNorm:
    """The H∞ norm of one system by two routes.

    Parameters
    ----------
    norm : float
        ‖G‖∞ [output unit per input unit], python-control's value (the
        level set's when python-control raised; inf: not stable).
    frequency : float
        Its peak frequency [rad/s].
    control : float
        python-control / slycot ``ab13dd`` (:func:`control_hinf_norm`);
        NaN when it raised (``error``).
    control_frequency : float
        Its peak frequency [rad/s].
    hamiltonian : float
        The level set (:func:`hamiltonian_hinf_norm`).
    hamiltonian_frequency : float
        Its peak frequency [rad/s]. Equal peaks at several frequencies (a
        symmetric train) can make the two frequencies differ while the
        norms agree.
    stable : bool
        A Hurwitz (continuous) or Schur (discrete).
    abscissa : float
        Spectral abscissa max Re λ [1/s] (continuous) or spectral radius
        max |λ| [-] (discrete).
    dt : float or None
        Sample time [s]; None for a continuous system.
    iterations : int
        Level-set iterations.
    error : str
        The exception python-control raised, if any ("" otherwise).

    Examples
    --------
    A resonance 1/(s² + 2ζs + 1) with ζ = 0.1 peaks at ω = √(1 − 2ζ²) =
    0.99 rad/s with 1/(2ζ√(1 − ζ²)) = 5.0252:

    >>> import control as ct
    >>> res = hinf_norm(ct.tf([1.0], [1.0, 0.2, 1.0]))
    >>> round(res.norm, 4), round(res.frequency, 3), res.agree, res.stable
    (5.0252, 0.99, True, True)
    >>> round(res.abscissa, 4)  # poles at -0.1 ± 0.995j [1/s]
    -0.1
    """

    norm: float
    frequency: float
    control: float
    control_frequency: float
    hamiltonian: float
    hamiltonian_frequency: float
    stable: bool
    abscissa: float
    dt: float | None
    iterations: int
    error: str = ""

    @property
    def agree(self) -> bool:
        """Both routes within :data:`AGREEMENT` relative (both inf for an unstable system)."""
        a, b = self.control, self.hamiltonian
        if math.isnan(a) or math.isnan(b):
            return False
        if math.isinf(a) or math.isinf(b):
            return math.isinf(a) and math.isinf(b)
        return abs(a - b) <= AGREEMENT * max(abs(a), abs(b), 1e-300)

    @property
    def message(self) -> str:
        """One line for a report."""
        if not self.stable:
            what = "max Re λ" if self.dt is None else "spectral radius"
            return (f"not stable ({what} = {self.abscissa:.4g}): the H∞ norm is infinite")
        text = (f"‖G‖∞ = {self.norm:.6g} at {self.frequency:.4g} rad/s (python-control); "
                f"level set {self.hamiltonian:.6g} at {self.hamiltonian_frequency:.4g} rad/s")
        if self.error:
            text += f"; python-control failed: {self.error}"
        return text + ("" if self.agree else f" — routes DISAGREE beyond {AGREEMENT:g}")

    def to_dict(self) -> dict[str, object]:
        """JSON-safe (inf and NaN as None).

        Returns
        -------
        dict
            ``norm``, ``control`` and ``hamiltonian`` [output unit per
            input unit] with their frequencies [rad/s], ``stable``,
            ``abscissa``, ``dt`` [s], ``iterations``, ``agree``, ``error``
            and the one-line ``message``.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        return {"norm": f(self.norm), "frequency": f(self.frequency),
                "control": f(self.control), "control_frequency": f(self.control_frequency),
                "hamiltonian": f(self.hamiltonian),
                "hamiltonian_frequency": f(self.hamiltonian_frequency),
                "stable": self.stable, "abscissa": f(self.abscissa), "dt": self.dt,
                "iterations": self.iterations, "agree": self.agree, "error": self.error,
                "message": self.message}


def hinf_norm(sys: ct.StateSpace | ct.TransferFunction) -> HinfNorm:
    """‖G‖∞ by python-control (slycot) and by the Hamiltonian level set, and their agreement.

    Parameters
    ----------
    sys : control.StateSpace or control.TransferFunction
        Continuous or discrete system, any D.

    Returns
    -------
    HinfNorm
        Both values and peak frequencies [rad/s], stability, ``agree``
        (relative :data:`AGREEMENT`).

    Examples
    --------
    An unstable system has an infinite norm, by both routes:

    >>> import control as ct
    >>> res = hinf_norm(ct.tf([1.0], [1.0, -1.0]))
    >>> res.norm, res.stable, res.agree
    (inf, False, True)
    """
    A, B, C, D, dt = _system_data(sys, "hinf_norm")
    own = _own_norm(A, B, C, D, dt)
    error = ""
    if not own.stable:
        ref, w_ref = math.inf, math.nan
    else:
        system = ct.ss(A, B, C, D) if dt is None else ct.ss(A, B, C, D, dt)
        try:
            ref, w_ref = control_hinf_norm(system)
        except Exception as exc:  # slycot raises its own arithmetic/value errors
            ref, w_ref, error = math.nan, math.nan, f"{type(exc).__name__}: {exc}"
    if not own.converged:
        error = (error + "; " if error else "") + (
            f"level set not converged in {MAX_LEVELS} iterations")
    return HinfNorm(norm=ref if not math.isnan(ref) else own.gamma,
                    frequency=w_ref if not math.isnan(ref) else own.frequency,
                    control=ref, control_frequency=w_ref, hamiltonian=own.gamma,
                    hamiltonian_frequency=own.frequency, stable=own.stable,
                    abscissa=own.abscissa, dt=dt, iterations=own.iterations, error=error)


@dataclass(frozen=True, kw_only=True)
class ChannelNorms:
    """SISO H∞ norms of every channel, laid out like the transfer matrix.

    Parameters
    ----------
    gamma : ndarray
        (p, m): ``gamma[i, j]`` = ‖G_ij‖∞, input j → output i [output unit
        per input unit], python-control's value.
    gamma_hamiltonian : ndarray
        (p, m), the level set's.
    frequency : ndarray
        (p, m) peak frequencies [rad/s] (python-control's).
    per_input : ndarray
        (m,): ‖G e_j‖∞, input j → the whole output vector (python-control).
    per_input_hamiltonian : ndarray
        (m,), the level set's.
    inputs, outputs : tuple of str
        Channel labels.

    Examples
    --------
    y = 1/(s + 1)·a + 1/(s + 2)·b: the channels' DC gains 1 and 1/2 are their norms.

    >>> import control as ct
    >>> sys = ct.ss([[-1.0, 0.0], [0.0, -2.0]], np.eye(2), [[1.0, 1.0]], np.zeros((1, 2)),
    ...             inputs=["a", "b"], outputs=["y"])
    >>> res = channel_norms(sys)
    >>> res.gamma.round(4).tolist(), res.inputs, res.agree
    ([[1.0, 0.5]], ('a', 'b'), True)
    """

    gamma: Array
    gamma_hamiltonian: Array
    frequency: Array
    per_input: Array
    per_input_hamiltonian: Array
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]

    @property
    def agree(self) -> bool:
        """Every channel's two routes within :data:`AGREEMENT` (inf with inf)."""
        pairs = [(self.gamma, self.gamma_hamiltonian),
                 (self.per_input, self.per_input_hamiltonian)]
        for a, b in pairs:
            both_inf = np.isinf(a) & np.isinf(b)
            with np.errstate(invalid="ignore"):
                close = np.abs(a - b) <= AGREEMENT * np.maximum(np.maximum(abs(a), abs(b)),
                                                                1e-300)
            if not np.all(both_inf | close):
                return False
        return True

    def to_dict(self) -> dict[str, object]:
        """JSON-safe (inf as None).

        Returns
        -------
        dict
            ``inputs`` and ``outputs`` (labels), ``gamma`` and
            ``gamma_hamiltonian`` (nested lists, one row per output)
            [output unit per input unit], ``frequency`` (nested lists)
            [rad/s], ``per_input`` and ``per_input_hamiltonian`` (one value
            per input), and ``agree``.
        """
        def f(M: Array) -> list[Any]:
            return [None if not math.isfinite(x) else float(x) for x in np.ravel(M)] \
                if M.ndim == 1 else [f(row) for row in M]
        return {"inputs": list(self.inputs), "outputs": list(self.outputs),
                "gamma": f(self.gamma), "gamma_hamiltonian": f(self.gamma_hamiltonian),
                "frequency": f(self.frequency), "per_input": f(self.per_input),
                "per_input_hamiltonian": f(self.per_input_hamiltonian), "agree": self.agree}


def channel_norms(sys: ct.StateSpace) -> ChannelNorms:
    """The H∞ norm of each input → output channel and of each input → all outputs.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous or discrete; inputs are the disturbance channels,
        outputs the performance outputs.

    Returns
    -------
    ChannelNorms
        ``gamma[i, j]`` for input j → output i (the transfer matrix's
        layout), both routes, and ``per_input[j]`` (input j → every output).

    Examples
    --------
    >>> import control as ct
    >>> G = ct.ss([[-1.0, 0.0], [0.0, -2.0]], [[1.0, 0.0], [0.0, 1.0]], np.eye(2), 0)
    >>> res = channel_norms(G)
    >>> np.round(res.gamma, 6).tolist(), res.agree
    ([[1.0, 0.0], [0.0, 0.5]], True)
    """
    A, B, C, D, dt = _system_data(sys, "channel_norms")
    p, m = D.shape
    gamma = np.zeros((p, m))
    own = np.zeros((p, m))
    freq = np.zeros((p, m))
    per_input = np.zeros(m)
    per_own = np.zeros(m)

    def one(b: Array, c: Array, d: Array) -> tuple[float, float, float]:
        res = hinf_norm(ct.ss(A, b, c, d) if dt is None else ct.ss(A, b, c, d, dt))
        return res.control, res.frequency, res.hamiltonian

    for j in range(m):
        b = B[:, j:j + 1]
        per_input[j], _, per_own[j] = one(b, C, D[:, j:j + 1])
        for i in range(p):
            gamma[i, j], freq[i, j], own[i, j] = one(b, C[i:i + 1], D[i:i + 1, j:j + 1])
    inputs = tuple(getattr(sys, "input_labels", None) or [f"u[{j}]" for j in range(m)])
    outputs = tuple(getattr(sys, "output_labels", None) or [f"y[{i}]" for i in range(p)])
    return ChannelNorms(gamma=gamma, gamma_hamiltonian=own, frequency=freq,
                        per_input=per_input, per_input_hamiltonian=per_own, inputs=inputs,
                        outputs=outputs)
