# String stability of a linear closed loop: peak gains from the head's disturbance along the train.
"""Whether a disturbance at the head grows as it travels down the train.

The input is a linear closed loop (``Design.closed_loop``; discrete for MPC
and LQR, continuous for laws such as the potential and flocking families):
a ``control.StateSpace`` from the specific-force disturbances ``w[i]``
[m/s²] to, among others, the spacing deviations ``d[i]`` [m] and the coupler
forces ``f[i]`` [kN] (i = 0 the coupler behind the head vehicle).
:func:`string_stability` takes one input (``w[0]``: a force disturbance at
the head) and, per output family, the peak gain over frequency of every
single-input single-output channel,

    γ_i = sup_ω |G_i(jω)|  (continuous)   or   sup_{0 ≤ ω ≤ π/T} |G_i(e^{jωT})|  (discrete),

in [m per (m/s²)] = s² for spacings and [kN per (m/s²)] for forces, with the
frequency where it occurs. The train is *string stable* (in the ℓ₂/H∞ sense
of predecessor-following platoons) for that family when the peaks do not
grow along the train: γ_{i+1} ≤ γ_i (1 + :data:`RELATIVE_TOL`). The result
also gives the largest consecutive ratio γ_{i+1}/γ_i and, for long trains,
the growth factor per vehicle: exp of the least-squares slope of log γ_i
over the rear half of the train (at least :data:`MIN_FIT` channels), which
tends to ‖H‖∞ for a homogeneous chain e_{i+1} = H e_i.

The sup is taken on a logarithmic grid (:func:`~trainctl.analysis.sensitivity.frequency_grid`
up to π/T for a discrete loop; two decades beyond the nonzero pole
magnitudes for a continuous one), enriched with the loop's pole frequencies, refined around
each channel's grid maximum (bounded scalar search) and compared with the
DC gain. A channel that a closed-loop integrator (pole at z = 1 or s = 0)
reaches has an infinite peak (``inf``, frequency 0): the check then cannot
judge the string and says so. Each channel's
peak is a SISO H∞ norm; :func:`trainctl.analysis.hinf.hinf_norm` computes it
by two routes where a certified value is needed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import control as ct
import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from trainctl.analysis.check import Check
from trainctl.analysis.sensitivity import UNIT_CIRCLE_TOL, frequency_grid
from trainctl.exceptions import DimensionError

if TYPE_CHECKING:
    from trainctl.design import Design

__all__ = [
    "MIN_FIT", "QUANTITIES", "RELATIVE_TOL", "ChainPeaks", "StringStabilityResult",
    "string_stability", "string_stability_check",
]

Array = NDArray[np.float64]

RELATIVE_TOL = 1e-6
"""γ_{i+1} ≤ γ_i (1 + RELATIVE_TOL) counts as not growing (numerical ties pass)."""

MIN_FIT = 3
"""Fewest channels the growth factor per vehicle is fitted on (else NaN)."""

QUANTITIES = {"d": ("spacing deviation", "m/(m/s²)"), "f": ("coupler force", "kN/(m/s²)")}
"""Output families by label prefix: what they are and the unit of their gains."""

_INTEGRATOR_GROWTH = 5.0
"""|G(ε/10)| / |G(ε)| above which a channel rises like 1/ω towards DC (infinite peak)."""


@dataclass(frozen=True, kw_only=True, eq=False)
class ChainPeaks:
    """Peak gains of one output family along the train.

    Parameters
    ----------
    quantity : str
        Label prefix: ``"d"`` spacing deviations [m], ``"f"`` coupler forces [kN].
    labels : tuple of str
        The channels' output names, head first.
    gains : ndarray
        Peak gain γ_i of each channel (``inf`` behind an integrator), in
        :data:`QUANTITIES` units.
    frequencies : ndarray
        Where each peak occurs [rad/s] (0: the DC gain).
    curves : ndarray
        |G_i| on the result's ``omega``, shape (channels, len(omega)).

    Examples
    --------
    Peaks that double along the train (a string-unstable chain):

    >>> import numpy as np
    >>> g = np.array([1.0, 2.0, 4.0, 8.0])
    >>> c = ChainPeaks(quantity="d", labels=("d[0]", "d[1]", "d[2]", "d[3]"), gains=g,
    ...                frequencies=np.zeros(4), curves=np.zeros((4, 1)))
    >>> c.ratios.tolist(), c.non_increasing, c.finite
    ([2.0, 2.0, 2.0], False, True)
    >>> round(c.growth_rate, 6)  # exp of the slope of log γ_i over the rear half
    2.0
    """

    quantity: str
    labels: tuple[str, ...]
    gains: Array
    frequencies: Array
    curves: Array

    @property
    def present(self) -> bool:
        """False when every channel is identically zero (virtual links carry no force)."""
        return bool(np.any(self.gains > 0))

    @property
    def ratios(self) -> Array:
        """γ_{i+1}/γ_i (NaN where undefined: an infinite peak, or 0/0)."""
        g = self.gains
        with np.errstate(divide="ignore", invalid="ignore"):
            r = g[1:] / g[:-1]
        r[~np.isfinite(g[1:]) | ~np.isfinite(g[:-1])] = np.nan
        return r

    @property
    def max_ratio(self) -> float:
        """Largest consecutive ratio (NaN when none is defined)."""
        r = self.ratios[~np.isnan(self.ratios)]
        return float(np.max(r)) if r.size else math.nan

    @property
    def finite(self) -> bool:
        """True when every peak is finite (no integrator reaches the family)."""
        return bool(np.all(np.isfinite(self.gains)))

    @property
    def non_increasing(self) -> bool:
        """γ_{i+1} ≤ γ_i (1 + :data:`RELATIVE_TOL`) along the train (False if a peak is inf)."""
        g = self.gains
        return self.finite and bool(np.all(g[1:] <= g[:-1] * (1 + RELATIVE_TOL)))

    @property
    def growth_rate(self) -> float:
        """Growth factor per vehicle: geometric fit of the rear half's peaks (module docstring)."""
        g = self.gains
        tail = g[min(g.size // 2, max(g.size - MIN_FIT, 0)):]
        if tail.size < MIN_FIT or not np.all(np.isfinite(tail)) or np.any(tail <= 0):
            return math.nan
        slope = np.polyfit(np.arange(tail.size, dtype=float), np.log(tail), 1)[0]
        return float(math.exp(slope))

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe: peaks and frequencies per channel, ratios, verdict, growth rate.

        Returns
        -------
        dict
            ``quantity`` (what the family is) and ``unit`` (of its gains,
            from :data:`QUANTITIES`), ``labels``, ``peak_gains`` and
            ``peak_frequencies`` [rad/s] per channel, the consecutive
            ``ratios`` and ``max_ratio`` [-], ``non_increasing`` and
            ``growth_rate_per_vehicle`` [-]; non-finite numbers as None.
        """
        return {"quantity": QUANTITIES[self.quantity][0], "unit": QUANTITIES[self.quantity][1],
                "labels": list(self.labels), "peak_gains": _json(self.gains),
                "peak_frequencies": _json(self.frequencies), "ratios": _json(self.ratios),
                "max_ratio": _finite(self.max_ratio), "non_increasing": self.non_increasing,
                "growth_rate_per_vehicle": _finite(self.growth_rate)}


@dataclass(frozen=True, kw_only=True, eq=False)
class StringStabilityResult:
    """String stability of one closed loop (module docstring).

    Parameters
    ----------
    name : str
        The loop's name.
    input : str
        The disturbance input (``"w[0]"``: the head vehicle).
    dt : float or None
        Sample time T [s]; None for a continuous loop.
    omega : ndarray
        Grid frequencies [rad/s] of the curves.
    chains : dict of str to ChainPeaks
        By output family (``"d"``, ``"f"``), those the loop has.

    Examples
    --------
    A continuous toy loop: the head's disturbance reaches d[0] through
    1/(s + 1) and d[1] through 0.5/(s + 1); both peak at DC.

    >>> import control as ct
    >>> sys = ct.ss([[-1.0]], [[1.0]], [[1.0], [0.5]], [[0.0], [0.0]], inputs=["w[0]"],
    ...             outputs=["d[0]", "d[1]"], name="toy")
    >>> res = string_stability(sys)
    >>> res.dt, list(res.chains), res.chains["d"].gains.tolist()  # [s²]
    (None, ['d'], [1.0, 0.5])
    >>> res.string_stable, res.max_ratio
    (True, 0.5)
    """

    name: str
    input: str
    dt: float | None
    omega: Array
    chains: dict[str, ChainPeaks]

    @property
    def judged(self) -> list[ChainPeaks]:
        """The families that carry a signal (zero rows of virtual links left out)."""
        return [c for c in self.chains.values() if c.present]

    @property
    def finite(self) -> bool:
        """True when no judged peak is infinite."""
        return all(c.finite for c in self.judged)

    @property
    def string_stable(self) -> bool:
        """True when every judged family's peaks are finite and do not grow."""
        return bool(self.judged) and all(c.non_increasing for c in self.judged)

    @property
    def max_ratio(self) -> float:
        """Largest consecutive peak ratio over the judged families (NaN: none defined)."""
        r = [c.max_ratio for c in self.judged if not math.isnan(c.max_ratio)]
        return max(r) if r else math.nan

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe numbers: per family the peaks [unit, rad/s], ratios and growth rate.

        Returns
        -------
        dict
            ``input``, ``sample_time`` [s] (None when continuous),
            ``string_stable``, ``finite``, ``max_ratio`` [-] (None when
            none is defined), ``relative_tolerance`` and ``chains`` (each
            family's :meth:`ChainPeaks.to_dict`, by label prefix).
        """
        return {"input": self.input, "sample_time": self.dt,
                "string_stable": self.string_stable, "finite": self.finite,
                "max_ratio": _finite(self.max_ratio), "relative_tolerance": RELATIVE_TOL,
                "chains": {q: c.to_dict() for q, c in self.chains.items()}}

    def curves(self) -> dict[str, Any]:
        """JSON-safe arrays for plotting: ``omega`` and |G_i| per family and channel.

        Returns
        -------
        dict
            ``omega`` [rad/s], ``nyquist`` (π/T [rad/s], None when
            continuous) and ``chains``: per family that carries a signal,
            its ``labels`` and ``gains`` (one list over ``omega`` per
            channel, in the family's unit); values to 6 significant digits.
        """
        return {"omega": _short(self.omega), "nyquist": None if self.dt is None
                else math.pi / self.dt,
                "chains": {q: {"labels": list(c.labels), "gains": [_short(r) for r in c.curves]}
                           for q, c in self.chains.items() if c.present}}


def string_stability(
    sys: ct.StateSpace,
    *,
    input: str = "w[0]",
    outputs: Sequence[str] = ("d", "f"),
    omega: Array | None = None,
) -> StringStabilityResult:
    """Peak gains from one disturbance to each spacing and coupler force along the train.

    Parameters
    ----------
    sys : control.StateSpace
        Linear closed loop, discrete or continuous, with named signals:
        inputs ``w[i]`` [m/s²], outputs ``d[i]`` [m] and ``f[i]`` [kN]
        among others (``Design.closed_loop``).
    input : str
        The disturbance input; ``"w[0]"`` is the head vehicle.
    outputs : sequence of str
        Output families by label prefix (``"d"``, ``"f"``); a family the
        loop lacks is left out.
    omega : ndarray or None
        Frequencies [rad/s]; None: a logarithmic grid (module docstring).

    Returns
    -------
    StringStabilityResult
        Peaks per family and channel, their frequencies, the verdict.

    Raises
    ------
    DimensionError
        If ``input`` is not an input of ``sys``, or a family is unknown.

    Examples
    --------
    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> loop = build_design(load_scenario("crh2-dmpc-well-sampled")).closed_loop("ndmpc")
    >>> res = string_stability(loop)
    >>> list(res.chains), res.chains["d"].labels
    (['d', 'f'], ('d[0]', 'd[1]', 'd[2]'))
    """
    if input not in sys.input_labels:
        raise DimensionError(f"string_stability: the input must be one of the loop's "
                             f"{list(sys.input_labels)} (got {input!r}).")
    unknown = [q for q in outputs if q not in QUANTITIES]
    if unknown:
        raise DimensionError(f"string_stability: output families must be among "
                             f"{list(QUANTITIES)} (got {unknown}).")
    j = list(sys.input_labels).index(input)
    w = _grid(sys) if omega is None else np.asarray(omega, dtype=float)
    # One eigendecomposition for every output family (O(n³)); the loop's poles from it.
    D = np.asarray(sys.D, dtype=float)
    modal = _Modal.build(sys, np.asarray(sys.B, dtype=float)[:, j],
                         np.asarray(sys.C, dtype=float), D[:, j])
    poles = (modal.poles if modal is not None else
             np.linalg.eigvals(np.asarray(sys.A, dtype=float)) if sys.nstates else np.zeros(0))
    chains = {}
    for q in outputs:
        rows = [k for k, name in enumerate(sys.output_labels) if name.startswith(f"{q}[")]
        if rows:
            chains[q] = _chain(sys, q, rows, j, w, modal, poles)
    dt = float(sys.dt) if sys.isdtime(strict=True) else None
    return StringStabilityResult(name=str(sys.name), input=input, dt=dt, omega=w, chains=chains)


def _grid(sys: ct.StateSpace) -> Array:
    """The default grid: up to π/T, or python-control's range; pole frequencies added."""
    poles = np.linalg.eigvals(np.asarray(sys.A, dtype=float)) if sys.nstates else np.zeros(0)
    if sys.isdtime(strict=True):
        grid = frequency_grid(float(sys.dt))
        extra = np.abs(np.angle(poles)) / float(sys.dt)
    else:
        grid = _continuous_grid(poles)
        extra = np.abs(poles.imag)
    inside = extra[(extra > grid[0]) & (extra < grid[-1])]
    return np.unique(np.concatenate([grid, np.round(inside, 12)]))


def _continuous_grid(poles: Array) -> Array:
    """Two decades beyond the loop's nonzero pole magnitudes each way, 50 points a decade.

    Poles at s = 0 are left to :func:`_dc_gain`: near them the resolvent is
    too ill-conditioned to evaluate (python-control's default range reaches
    down to them).
    """
    size = np.abs(poles)
    nonzero = size[size > UNIT_CIRCLE_TOL * max(float(np.max(size, initial=0.0)), 1.0)]
    if not nonzero.size:
        nonzero = np.ones(1)
    lo = math.floor(math.log10(float(np.min(nonzero)))) - 2
    hi = math.ceil(math.log10(float(np.max(nonzero)))) + 2
    return np.logspace(lo, hi, 50 * (hi - lo) + 1)


def _chain(sys: ct.StateSpace, q: str, rows: list[int], j: int, w: Array,
           modal: _Modal | None, poles: NDArray[Any]) -> ChainPeaks:
    """Peaks of the channels ``rows`` from input ``j``.

    The grid is evaluated once for all channels (one single-input system,
    one resolvent solve per frequency; per channel it was 2(n−1) solves per
    frequency, measured 77 s of the 86 s review of a 64-car train), and
    the loop's poles once for every channel's DC test. The refinement
    evaluates channels in modal coordinates (``modal``, every output of input
    ``j``; None: python-control for every channel) where that is accurate
    (:class:`_Modal`).
    """
    C, D = np.asarray(sys.C, dtype=float), np.asarray(sys.D, dtype=float)
    B = np.asarray(sys.B, dtype=float)[:, [j]]
    column = ct.ss(sys.A, B, C[rows], D[rows][:, [j]], sys.dt)
    response = ct.frequency_response(column, w, squeeze=False)
    curves = np.abs(np.asarray(response.magnitude, dtype=float))[:, 0, :]
    peaks = []
    for k, curve in zip(rows, curves, strict=True):
        channel = modal.channel(k, w, curve) if modal is not None else None
        if channel is None:
            channel = _Channel.of(ct.ss(sys.A, B, C[[k]], D[[k]][:, [j]], sys.dt))
        peaks.append(_peak(channel, w, curve, poles))
    return ChainPeaks(quantity=q, labels=tuple(sys.output_labels[k] for k in rows),
                      gains=np.array([p[0] for p in peaks]),
                      frequencies=np.array([p[1] for p in peaks]), curves=curves)


@dataclass(frozen=True)
class _Channel:
    """A SISO channel's gain |G| at a frequency [rad/s], and its time base."""

    gain: Callable[[float], float]
    dt: float | None  # None: continuous

    @classmethod
    def of(cls, g: ct.StateSpace) -> _Channel:
        """python-control's evaluation (slycot's tb05ad: a Hessenberg reduction per call)."""
        dt = float(g.dt) if g.isdtime(strict=True) else None
        return cls(gain=lambda w: _gain(g, w), dt=dt)


class _Modal:
    """The channels c_k (sI − A)⁻¹ b + d_k of one input (k: output index), in A's
    eigenvector basis.

    With A = V Λ V⁻¹ (computed once), G_k(s) = Σ_i (c_k V)_i (V⁻¹ b)_i / (s − λ_i) + d_k:
    O(n) per evaluation instead of python-control's O(n³) Hessenberg reduction at every
    call (4866 calls of 0.06 s, 286 s, in the review of the 204-vehicle chain). Used only
    when V is well conditioned (cond(V) ≤ :attr:`MAX_COND`, so rounding stays below about
    1e-8 of the terms) and, per channel, when it reproduces python-control's value at the
    channel's grid maximum to :attr:`AGREE` (an independent route); otherwise the channel
    is evaluated by python-control as before.
    """

    MAX_COND = 1e8
    AGREE = 1e-7

    def __init__(self, poles: NDArray[np.complex128], cv: NDArray[np.complex128],
                 vb: NDArray[np.complex128], d: Array, dt: float | None) -> None:
        self.poles, self.cv, self.vb, self.d, self.dt = poles, cv, vb, d, dt

    @classmethod
    def build(cls, sys: ct.StateSpace, b: Array, C: Array, d: Array) -> _Modal | None:
        A = np.asarray(sys.A, dtype=float)
        if not A.size:
            return None
        poles, V = np.linalg.eig(A)
        if not np.all(np.isfinite(V)) or np.linalg.cond(V) > cls.MAX_COND:
            return None
        dt = float(sys.dt) if sys.isdtime(strict=True) else None
        return cls(poles, C @ V, np.linalg.solve(V, b.astype(complex)), d, dt)

    def channel(self, index: int, w: Array, curve: Array) -> _Channel | None:
        """Channel ``index``, or None when it disagrees with ``curve`` (python-control's)."""
        weights = self.cv[index] * self.vb
        d, poles, dt = float(self.d[index]), self.poles, self.dt

        def gain(x: float) -> float:
            point = 1j * x if dt is None else np.exp(1j * x * dt)
            return float(abs(np.sum(weights / (point - poles)) + d))

        k = int(np.argmax(curve))
        if abs(gain(float(w[k])) - curve[k]) > self.AGREE * max(float(curve[k]), 1e-300):
            return None
        return _Channel(gain=gain, dt=dt)


def _gain(g: ct.StateSpace, w: float) -> float:
    """|G(jω)| or |G(e^{jωT})| of a SISO channel."""
    point = 1j * w if g.isctime() else np.exp(1j * w * float(g.dt))
    return float(np.abs(np.asarray(g(point, warn_infinite=False), dtype=complex)).max())


def _dc_gain(g: _Channel, poles: NDArray[Any]) -> float:
    """|G| at DC; ``inf`` when a closed-loop pole at DC (z = 1, s = 0) reaches the channel.

    The resolvent is singular at such a pole even when the channel cannot
    see it (uncontrollable or unobservable), so there the DC gain is the
    limit, the gain at a frequency 10⁻⁷ of the loop's scale; a channel that
    sees the pole rises like 1/ω towards DC (:data:`_INTEGRATOR_GROWTH`).
    """
    discrete = g.dt is not None
    at_dc = np.abs(poles - 1.0) if discrete else np.abs(poles)
    if not np.any(at_dc < UNIT_CIRCLE_TOL):
        return g.gain(0.0)
    scale = math.pi / float(g.dt) if g.dt is not None else max(float(np.max(np.abs(poles))), 1.0)
    low, lower = g.gain(1e-6 * scale), g.gain(1e-7 * scale)
    return math.inf if lower > _INTEGRATOR_GROWTH * low else lower


def _peak(g: _Channel, w: Array, curve: Array, poles: NDArray[Any]) -> tuple[float, float]:
    """(sup gain, frequency [rad/s]): the DC gain, the grid's maximum refined, or inf."""
    dc = _dc_gain(g, poles)
    if math.isinf(dc):
        return math.inf, 0.0
    k = int(np.argmax(curve))
    best = (float(curve[k]), float(w[k]))
    if dc >= best[0]:
        best = (dc, 0.0)
    lo, hi = float(w[max(k - 1, 0)]), float(w[min(k + 1, w.size - 1)])
    if hi > lo:
        res = scipy.optimize.minimize_scalar(lambda x: -g.gain(x), bounds=(lo, hi),
                                             method="bounded", options={"xatol": 1e-10 * hi})
        if res.success and -float(res.fun) > best[0]:
            best = (-float(res.fun), float(res.x))
    return best


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _json(values: Array) -> list[float | None]:
    """Full precision, non-finite values as None."""
    return [_finite(float(x)) for x in values]


def _short(values: Array) -> list[float]:
    """Values to 6 significant digits (plenty for a plot)."""
    return [float(f"{x:.6g}") for x in values]


def string_stability_check(design: Design) -> Check | None:
    """The design-review check ``string_stability`` of a run's design.

    It judges the primary family's first strategy (the centralised
    reference loop of the MPC and LQR families), so that listing more
    strategies in ``[simulation]`` never changes the review; the numbers
    of every analysed strategy are in ``analyse --json``
    (``frequency.<strategy>.string_stability``). Pass: the peaks of every
    family (spacings, coupler forces) from ``w[0]`` do not grow along the
    train; fail: one grows; warn: a peak is infinite (a closed-loop
    integrator) or nothing can be judged.

    Parameters
    ----------
    design : Design
        The run's design (:func:`trainctl.design.build_design`).

    Returns
    -------
    Check or None
        Value the largest consecutive peak ratio γ_{i+1}/γ_i [-], threshold
        1; None without a linear closed loop, without a disturbance input
        ``w[0]`` or with a single vehicle.

    Examples
    --------
    The book's CRH2 design (T = 20 s) amplifies the head's disturbance down
    the train; sampled at 0.05 s it does not:

    >>> from trainctl.design import build_design
    >>> from trainctl.scenario import load_scenario
    >>> check = string_stability_check(build_design(load_scenario("crh2-dmpc")))
    >>> check.status, round(check.value, 2)  # largest γ_{i+1}/γ_i [-]
    ('fail', 1.4)
    >>> string_stability_check(build_design(load_scenario("crh2-dmpc-well-sampled"))).status
    'pass'
    >>> string_stability_check(build_design(load_scenario("heavy-haul-hinf"))) is None  # no law
    True
    """
    from trainctl.registry import get_family

    if not design.families or design.model.n_vehicles < 2:
        return None
    family = next(iter(design.families))
    strategy = get_family(family).strategies[0]
    loop = get_family(family).closed_loop(design.family(family), strategy)
    if loop is None or "w[0]" not in loop.input_labels:
        return None
    res = string_stability(loop)
    return _judge(res, family if family == strategy else f"{family} {strategy}")


_LISTED_PEAKS = 8
"""Peaks listed in full in a check message; longer trains show the ends and the growth."""


def _peaks_text(chain: ChainPeaks) -> str:
    """"spacing deviation peaks 1, 2, 3 m/(m/s²)" (ends only for long trains), with the growth."""
    g = chain.gains
    values = [f"{x:.3g}" for x in g]
    if len(values) > _LISTED_PEAKS:
        values = values[:3] + ["…"] + values[-2:]
    what, unit = QUANTITIES[chain.quantity]
    text = f"{what} peaks {', '.join(values)} {unit}"
    growth = chain.growth_rate
    if len(g) > _LISTED_PEAKS:
        text += f" ({len(g)} channels"
        text += (f"; growth {growth:.4g} per vehicle along the rear half)"
                 if math.isfinite(growth) else ")")
    return text


def _judge(res: StringStabilityResult, what: str) -> Check:
    """Status, message and hint of :func:`string_stability_check`."""
    ratio = res.max_ratio
    peaks = "; ".join(_peaks_text(c) for c in res.judged)
    if not res.judged or not res.finite:
        why = ("no spacing or coupler-force output" if not res.judged else
               "infinite peak gain: a closed-loop integrator (pole at z = 1 or s = 0) "
               "reaches the spacings")
        status, message = "warn", f"{what}: string stability undefined, {why}"
        hint = ("remove the integrator from the spacing channels (weight the spacings or "
                "coupler forces) to judge the string")
    elif res.string_stable:
        status, hint = "pass", ""
        message = (f"{what}: from the head's disturbance the peaks do not grow along the "
                   f"train (largest ratio {ratio:.4g}); {peaks}")
    else:
        status = "fail"
        message = (f"{what}: a disturbance at the head grows along the train (largest peak "
                   f"ratio {ratio:.4g} > 1); {peaks}")
        hint = ("damp the coupler modes (coupler-force or spacing weights) or let each "
                "vehicle see its predecessor's spacing")
    return Check(name="string_stability", status=status, value=ratio, threshold=1.0, unit="",
                 message=message, hint=hint, details={"strategy": what, **res.to_dict()})
