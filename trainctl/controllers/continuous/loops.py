# The linear loops of a continuous-time law: its matrices, its Hurwitz check, its report spectrum.
"""The continuous linear closed loop of a sampled law, shared by the continuous families.

:func:`closed_loop_matrices` closes the design model's continuous SI model
(:meth:`~trainctl.design.DesignModel.observer_model`) with a law's linear
gain, optionally with the head-position integrator ṗ = v̂_0 (the potential
and flocking laws' ξ = [v̂, z, p]) and a delayed part (the relayed or
received data of the synchronous and hinf laws); :func:`hurwitz_check`
judges the loop and :func:`report_spectrum` gives its spectrum for the
report's eigenvalue map and table.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, NamedTuple, TypeVar

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.sampled import closed_loop_spectrum

if TYPE_CHECKING:
    from trainctl.analysis.check import Check
    from trainctl.design import DesignModel

__all__ = ["LoopMatrices", "Translation", "closed_loop_matrices", "hurwitz_check",
           "report_spectrum"]

Array = NDArray[np.float64]


@dataclass(frozen=True, kw_only=True, eq=False)
class LoopMatrices:
    """A law's continuous loops on the design state, SI.

    Parameters
    ----------
    A_open, B_open : ndarray
        The open loop [1/s] and its input matrix [1/kg], (N, N) and (N, n).
    A0 : ndarray
        A_open + B_open F₀: the part of the law that acts on current data.
    A_cl : ndarray
        The delay-free closed loop A₀ + B_d K_d [1/s] (A₀ without a delayed part).
    B_delayed : ndarray
        The input columns of the delayed part B_d, (N, m); (N, 0) without one.
    K_delayed : ndarray
        The delayed feedback K_d [N per unit of state], (m, N); (0, N) without one.

    Examples
    --------
    >>> loops = LoopMatrices(A_open=-np.eye(1), B_open=np.ones((1, 1)), A0=-2 * np.eye(1),
    ...                      A_cl=-2 * np.eye(1))
    >>> loops.K_delayed.shape
    (0, 1)
    """

    A_open: Array
    B_open: Array
    A0: Array
    A_cl: Array
    B_delayed: Array = field(default_factory=lambda: np.zeros((0, 0)))
    K_delayed: Array = field(default_factory=lambda: np.zeros((0, 0)))

    def __post_init__(self) -> None:
        N = self.A_open.shape[0]
        if self.B_delayed.size == 0 and self.B_delayed.shape != (N, 0):
            object.__setattr__(self, "B_delayed", np.zeros((N, 0)))
        if self.K_delayed.size == 0 and self.K_delayed.shape != (0, N):
            object.__setattr__(self, "K_delayed", np.zeros((0, N)))


L = TypeVar("L", bound=LoopMatrices)


def closed_loop_matrices(model: DesignModel, feedback: Array, delayed: Array | None = None,
                         *, delayed_inputs: Sequence[int] | None = None,
                         head_position: bool = False,
                         factory: type[L] = LoopMatrices) -> L:  # type: ignore[assignment]
    """The open loop, the undelayed part and the delay-free closed loop of a linear law.

    ẋ = A x + B û on the design model's continuous SI model (no dummy
    state), û = F₀ x + K_d x(t − τ) [N]: A₀ = A + B F₀ and A_cl = A₀ + B_d K_d,
    B_d the columns of B the delayed part drives.

    Parameters
    ----------
    model : DesignModel
        The run's design model.
    feedback : ndarray
        F₀, (n, N): the law's gain on current data (the whole law without a
        delayed part).
    delayed : ndarray or None
        K_d, (m, N): the gain on delayed data; None: none.
    delayed_inputs : sequence of int or None
        The inputs (vehicles) K_d drives, m of them; None: every input (m = n).
    head_position : bool
        Append the head's position error p to the state, ṗ = v̂_0 (N = 2n).
    factory : type
        The class of the result, :class:`LoopMatrices` or a subclass.

    Returns
    -------
    LoopMatrices
        The matrices, of class ``factory``.

    Examples
    --------
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> model = build_model(load_scenario("crh2-dmpc-well-sampled"))
    >>> F = np.zeros((4, 8))
    >>> F[:, :4] = -1e4 * np.eye(4)  # speed feedback [N/(m/s)], nothing on z and p
    >>> loops = closed_loop_matrices(model, F, head_position=True)
    >>> loops.A_open.shape, loops.B_open.shape
    ((8, 8), (8, 4))
    >>> loops.A_open[-1].tolist()  # ṗ = v̂_0
    [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    >>> loops.A_cl is loops.A0  # no delayed part
    True
    """
    sys = model.observer_model()
    if head_position:
        nx, n = int(sys.nstates), model.n_vehicles
        A = np.zeros((nx + 1, nx + 1))
        A[:nx, :nx] = np.asarray(sys.A, dtype=float)
        A[nx, 0] = 1.0
        B = np.vstack([np.asarray(sys.B, dtype=float), np.zeros((1, n))])
    else:
        A = np.asarray(sys.A, dtype=float)
        B = np.asarray(sys.B, dtype=float)
    A0 = A + B @ feedback
    if delayed is None:
        return factory(A_open=A, B_open=B, A0=A0, A_cl=A0)
    B_delayed = B if delayed_inputs is None else B[:, list(delayed_inputs)]
    return factory(A_open=A, B_open=B, A0=A0, B_delayed=B_delayed, K_delayed=delayed,
                   A_cl=A0 + B_delayed @ delayed)


class Translation(NamedTuple):
    """What :func:`hurwitz_check` says of a semisimple zero eigenvalue (a rigid translation).

    Parameters
    ----------
    message : str
        The warning, formatted with ``alpha`` (the other modes' abscissa [1/s]).
    hint : str
        The warning's hint.
    jordan_hint : str
        The hint when the zero eigenvalue is in a Jordan block (a fail).

    Examples
    --------
    >>> Translation("offset remains; others {alpha:.2g} 1/s", "pin it", "pin it").message
    'offset remains; others {alpha:.2g} 1/s'
    """

    message: str
    hint: str
    jordan_hint: str


def hurwitz_check(name: str, A_cl: Array, *, unstable: str, stable: str, hint: str,
                  translation: Translation | None = None, value_key: str = "max_real_part",
                  unstable_note: str = "", stable_note: str = "",
                  details: dict[str, Any] | None = None) -> Check:
    """Hurwitz test of a continuous closed loop: pass, or fail with the abscissa.

    Without ``translation`` every eigenvalue must have Re λ < −tol (tol of
    :func:`~trainctl.controllers.continuous.sampled.closed_loop_spectrum`).
    With it, zero eigenvalues (a rigid translation) are set apart: the other
    modes must be stable, and the zero ones warn when semisimple (a constant
    offset) and fail in a Jordan block (the offset grows).

    Parameters
    ----------
    name : str
        The check's name.
    A_cl : ndarray
        The continuous closed loop [1/s].
    unstable, stable : str
        The fail and pass messages, formatted with ``alpha`` (max Re λ [1/s])
        and ``tau`` (−1/α [s]).
    hint : str
        The hint of an unstable loop.
    translation : Translation or None
        What to say of a zero eigenvalue; None: it fails as unstable.
    value_key : str
        The details' key of α.
    unstable_note, stable_note : str
        Appended to the fail and pass messages.
    details : dict or None
        Further details, after α, the zero count (with ``translation``) and
        the eigenvalues.

    Returns
    -------
    Check
        Value α [1/s] (0 for a zero eigenvalue), threshold 0.

    Examples
    --------
    >>> A = np.array([[0.0, 1.0], [-2.0, -3.0]])  # λ = -1, -2
    >>> check = hurwitz_check("demo", A, unstable="unstable: {alpha:.3g}",
    ...                       stable="stable: {alpha:.3g} 1/s ({tau:.3g} s)", hint="")
    >>> check.status, check.message
    ('pass', 'stable: -1 1/s (1 s)')
    >>> shift = Translation("offset remains, others {alpha:.3g} 1/s", "pin", "pin")
    >>> hurwitz_check("demo", np.diag([0.0, -2.0]), unstable="", stable="", hint="",
    ...               translation=shift).message
    'offset remains, others -2 1/s'
    """
    from trainctl.analysis.check import Check

    spectrum = closed_loop_spectrum(A_cl)
    lam, tol = spectrum.eigenvalues, spectrum.tol
    points = [[float(x.real), float(x.imag)] for x in lam]
    if translation is None:
        alpha = float(max(lam.real))
        info: dict[str, Any] = {value_key: alpha, "eigenvalues": points}
    else:
        alpha = spectrum.abscissa
        info = {value_key: alpha, "zero_eigenvalues": int(spectrum.zero.sum()),
                "eigenvalues": points}
    info.update(details or {})
    if alpha >= -tol:
        return Check(name=name, status="fail", value=alpha, threshold=0.0, unit="1/s",
                     message=unstable.format(alpha=alpha) + unstable_note, hint=hint,
                     details=info)
    if translation is not None and np.any(spectrum.zero):
        if not spectrum.semisimple:
            return Check(name=name, status="fail", value=0.0, threshold=0.0, unit="1/s",
                         message="zero eigenvalue in a Jordan block: the position error grows",
                         hint=translation.jordan_hint, details=info)
        return Check(name=name, status="warn", value=0.0, threshold=0.0, unit="1/s",
                     message=translation.message.format(alpha=alpha), hint=translation.hint,
                     details=info)
    return Check(name=name, status="pass", value=alpha, threshold=0.0, unit="1/s",
                 message=stable.format(alpha=alpha, tau=-1.0 / alpha) + stable_note,
                 details=info)


def report_spectrum(A_cl: Array,
                    sample_time: float) -> tuple[list[list[float]], list[tuple[str, str]]]:
    """The loop's eigenvalues mapped to z = exp(λ T_s), and its slowest and fastest mode rows.

    Parameters
    ----------
    A_cl : ndarray
        The continuous closed loop [1/s].
    sample_time : float
        T_s [s], the model's sample time (the eigenvalue map is discrete).

    Returns
    -------
    points : list of [float, float]
        The z as [re, im] pairs, for the report's ``spectra``.
    rows : list of (str, str)
        The rows ("Slowest mode, max Re λ [1/s]", α) and ("Fastest mode,
        max |λ| [rad/s]", ω_max), as text.

    Examples
    --------
    >>> points, rows = report_spectrum(np.diag([-1.0, -4.0]), 0.5)
    >>> [round(x, 4) for x, _ in points], rows[0][1], rows[1][1]
    ([0.6065, 0.1353], '-1', '4')
    """
    lam = np.linalg.eigvals(A_cl).astype(complex)
    z = np.exp(lam * sample_time)
    rows = [("Slowest mode, max Re λ [1/s]", f"{float(np.max(lam.real)):.4g}"),
            ("Fastest mode, max |λ| [rad/s]", f"{float(np.max(np.abs(lam))):.4g}")]
    return [[float(x.real), float(x.imag)] for x in z], rows
