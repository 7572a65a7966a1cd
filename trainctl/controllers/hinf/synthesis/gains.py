# The synthesis of the consensus law's two gains: a certified γ, delay-free or for every delay.
"""The gain search (grid, then Nelder–Mead) with a certified γ per point
(:func:`synthesise_gains`), and the certificate at given gains (:func:`certify_gains`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from trainctl.analysis.delay_lmi.gain import DelayHinf, DelayHinfProblem
from trainctl.analysis.delay_lmi.stability import DELAY_KINDS
from trainctl.analysis.hinf.bounded_real import BoundedRealProblem, BoundedRealResult
from trainctl.analysis.hinf.norms import ChannelNorms, HinfNorm, channel_norms, hinf_norm
from trainctl.controllers.hinf.synthesis.loop import CHANNEL_GROUPS, ConsensusLoop
from trainctl.exceptions import ModelError

__all__ = ["PADE_POINTS", "Certificate", "GainSynthesis", "certify_gains", "synthesise_gains"]

Array = NDArray[np.float64]

PADE_POINTS = 4
"""Delays in (0, tau_max] at which :func:`synthesise_gains` checks the Padé-loop norm."""

Certificate = BoundedRealResult | DelayHinf
"""A γ certificate: delay-free (bounded-real lemma) or delay-dependent (LK)."""


@dataclass(frozen=True, kw_only=True, eq=False)
class GainSynthesis:
    """The gains of the consensus law found by the certified search, and their γ.

    Parameters
    ----------
    kp, kc : float
        κ_p, κ_c [1/s].
    certificate : BoundedRealResult or DelayHinf
        The certificate of T_w̃s̃ (all channels) at the gains, bounded-real
        (delay-free) or Lyapunov–Krasovskii (``tau_max``):
        ``certificate.gamma`` is the certified γ [-].
    channel_certificates : dict of str to BoundedRealResult or DelayHinf
        Per channel (input j → all outputs), its own SDP; where that SDP
        certifies nothing or more than the all-channel certificate, the
        latter (valid for every subset of the channels: its LMI restricted
        to them is a principal submatrix), said in its message and in
        ``notes``.
    group_certificates : dict of str to BoundedRealResult or DelayHinf
        Per group of :data:`CHANNEL_GROUPS` present, the same way.
    norm : HinfNorm
        ‖T_w̃s̃‖∞ at the gains by python-control and the level set
        (independent of the LMI).
    channels : ChannelNorms
        SISO norms channel × output at the gains (independent of the LMI).
    kp_grid, kc_grid : ndarray
        The coarse grid [1/s].
    gamma_grid : ndarray
        Certified γ on the grid, (len(kp_grid), len(kc_grid)) (inf where no
        certificate: an unstable loop or solver trouble).
    evaluations : int
        SDP solves of the search.
    trouble : tuple of str
        Every search point whose solve was not ``optimal``, and every
        certificate at the gains found (all channels, per channel, per
        group) that was not ``optimal`` or needed the fallback solver
        (status, gains and the solver's message).
    scaling, units : tuple
        Each channel's unit c_j and its text (e.g. ``"1 m/s²"``).
    output, output_scale : str, float
        Performance output and s_0 [m/s].
    bounds : ((float, float), (float, float))
        κ_p and κ_c bounds [1/s].
    search_time : float
        Wall time of grid and refinement [s].
    tau_max : float or None
        The delay range [0, tau_max] [s] the certificates cover (None:
        delay-free, bounded-real lemma).
    delay : str
        ``"constant"`` or ``"varying"`` (with ``tau_max``).
    pade_norms : tuple of (float, HinfNorm)
        With ``tau_max``: the norm of the Padé loop (order 8) at delays in
        (0, tau_max], independent of the LMI.
    notes : tuple of str
        Remarks (a gain on its bound, the refinement's stop).

    Examples
    --------
    The result of :func:`certify_gains` at one pair of gains:

    >>> from trainctl.controllers.hinf.synthesis.loop import consensus_loop
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-hinf")
    >>> res = certify_gains(consensus_loop(build_model(sc), sc.graph()), 1.0, 0.0)
    >>> res.kp, res.kc, res.evaluations, res.tau_max
    (1.0, 0.0, 1, None)
    >>> round(res.gamma, 2)  # certified γ [-], equal to the norm up to the SDP tolerance
    1.41
    >>> round(res.norm.norm, 2), res.consistent
    (1.41, True)
    """

    kp: float
    kc: float
    certificate: Certificate
    channel_certificates: dict[str, Certificate]
    group_certificates: dict[str, Certificate]
    norm: HinfNorm
    channels: ChannelNorms
    kp_grid: Array
    kc_grid: Array
    gamma_grid: Array
    evaluations: int
    trouble: tuple[str, ...]
    scaling: tuple[float, ...]
    units: tuple[str, ...]
    output: str
    output_scale: float
    bounds: tuple[tuple[float, float], tuple[float, float]]
    search_time: float
    tau_max: float | None = None
    delay: str = "constant"
    pade_norms: tuple[tuple[float, HinfNorm], ...] = field(default=())
    notes: tuple[str, ...] = field(default=())

    @property
    def gamma(self) -> float:
        """The certified γ of all channels together [-]."""
        return self.certificate.gamma

    @property
    def consistent(self) -> bool:
        """The independent norms (delay-free, per channel, Padé) do not exceed the certified γ."""
        tol = 1e-9
        if not self.norm.norm <= self.gamma * (1 + tol):
            return False
        if any(not r.norm <= self.gamma * (1 + tol) for _, r in self.pade_norms):
            return False
        for j, name in enumerate(self.channels.inputs):
            cert = self.channel_certificates.get(name)
            if cert is not None and not self.channels.per_input[j] <= cert.gamma * (1 + tol):
                return False
        return True

    def to_dict(self) -> dict[str, object]:
        """JSON-safe summary (per channel: certified γ, independent norm, unit).

        Returns
        -------
        dict
            The gains ``kp``, ``kc`` [1/s], the certified ``gamma`` [-],
            the ``certificate`` and ``norm`` as dicts, ``channels`` (per
            channel: name, unit, certified γ, independent norm), ``groups``
            (each group's certificate as a dict), the search's
            ``evaluations``, ``trouble``, ``bounds`` [1/s] and
            ``search_time`` [s], ``output``, ``output_scale`` [m/s],
            ``tau_max`` [s], ``delay``, ``pade_norms`` (pairs of delay [s]
            and norm dict), ``consistent`` and ``notes``; non-finite γ and
            norms as None.
        """
        def f(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None
        per = []
        for j, name in enumerate(self.channels.inputs):
            cert = self.channel_certificates.get(name)
            per.append({"channel": name, "unit": self.units[j],
                        "gamma_certified": f(cert.gamma) if cert else None,
                        "norm": f(float(self.channels.per_input[j]))})
        return {"kp": self.kp, "kc": self.kc, "gamma": f(self.gamma),
                "certificate": self.certificate.to_dict(), "norm": self.norm.to_dict(),
                "channels": per,
                "groups": {g: c.to_dict() for g, c in self.group_certificates.items()},
                "evaluations": self.evaluations, "trouble": list(self.trouble),
                "output": self.output, "output_scale": self.output_scale,
                "bounds": [list(b) for b in self.bounds], "search_time": self.search_time,
                "tau_max": self.tau_max, "delay": self.delay,
                "pade_norms": [[tau, r.to_dict()] for tau, r in self.pade_norms],
                "consistent": self.consistent, "notes": list(self.notes)}


def _axis(lo: float, hi: float, k: int) -> Array:
    if lo > 0 and hi / lo > 10:
        return np.geomspace(lo, hi, k)
    return np.linspace(lo, hi, k)


def _check_bounds(b: Sequence[float], name: str) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in b)
    except (TypeError, ValueError):
        raise ModelError(f"synthesise_gains: '{name}' must be two numbers (lo, hi) in 1/s "
                         f"(got {b!r}).") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
        raise ModelError(f"synthesise_gains: '{name}' must satisfy 0 <= lo <= hi, finite, in "
                         f"1/s (got {b!r}).")
    return lo, hi


def _problem(loop: ConsensusLoop, columns: Array | None, solver: str | None,
             reference: tuple[float, float], tau_max: float | None, delay: str
             ) -> BoundedRealProblem | DelayHinfProblem:
    cols = slice(None) if columns is None else columns
    ref = {"kp": reference[0], "kc": reference[1]}
    if tau_max is None:
        return BoundedRealProblem(
            loop.A0, loop.Bf[:, cols], loop.C, None, A_terms={"kp": loop.Ap, "kc": loop.Ac},
            B_terms={"kp": loop.Bp[:, cols], "kc": loop.Bc[:, cols]}, reference=ref,
            solver=solver)
    Apd, Acd = loop.delayed_terms()
    return DelayHinfProblem(
        loop.A0, np.zeros_like(loop.A0), loop.Bf[:, cols], loop.C, None, tau_max,
        A_terms={"kp": loop.Ap - Apd, "kc": loop.Ac - Acd}, A_d_terms={"kp": Apd, "kc": Acd},
        B_terms={"kp": loop.Bp[:, cols], "kc": loop.Bc[:, cols]}, reference=ref, delay=delay,
        solver=solver)


def _not_hurwitz(loop: ConsensusLoop, kp: float, kc: float, tau_max: float | None,
                 delay: str) -> Certificate | None:
    """A γ = inf answer without a solve when the delay-free loop is not Hurwitz (else None).

    No SDP can certify such a loop (delay-free, or with delays from 0 up),
    and the solvers take long to say so (the bounded-real problem then also
    tries its SCS fallback).
    """
    A = loop.matrices(kp, kc)[0]
    alpha = float(np.max(np.linalg.eigvals(A).real))
    if alpha < -1e-9 * max(1.0, float(np.abs(A).max())):
        return None
    text = (f"not solved: the delay-free loop is not Hurwitz at kp={kp:.6g} kc={kc:.6g} "
            f"(max Re λ = {alpha:.3g} 1/s)")
    theta = {"kp": float(kp), "kc": float(kc)}
    if tau_max is None:
        return BoundedRealResult(gamma=math.inf, gamma_solver=math.nan, P=None,
                                 status="not_hurwitz", solver="none", solve_time=0.0,
                                 parameters=theta, message=text)
    return DelayHinf(gamma=math.inf, gamma_solver=math.nan, tau_max=float(tau_max), delay=delay,
                     status="not_hurwitz", solver="none", solve_time=0.0, parameters=theta,
                     message=text)


def synthesise_gains(loop: ConsensusLoop, *, kp_bounds: Sequence[float] = (0.01, 1.0),
                     kc_bounds: Sequence[float] = (0.0, 1.0), grid: tuple[int, int] = (7, 7),
                     refine: bool = True, max_evaluations: int = 60,
                     tau_max: float | None = None, delay: str = "constant",
                     solver: str | None = None) -> GainSynthesis:
    """κ_p, κ_c within the bounds that minimise the certified γ of T_w̃s̃ (module docstring).

    One :class:`~trainctl.analysis.hinf.BoundedRealProblem` (κ_p, κ_c as
    ``cp.Parameter``) is compiled once and re-solved at every point of a
    ``grid`` over the bounds (geometric spacing when lo > 0 and hi/lo > 10),
    then, with ``refine``, by Nelder–Mead (scipy, bounded, on coordinates
    normalised to the bounds) from the best grid point, at most
    ``max_evaluations`` solves. The problem is bilinear in (P, κ): the
    result is the best *certified* point found, not a global optimum. At
    the gains found, every channel and every group gets its own
    certificate, and the norm is recomputed independently of the LMI
    (:func:`~trainctl.analysis.hinf.hinf_norm`,
    :func:`~trainctl.analysis.hinf.channel_norms`).

    Parameters
    ----------
    loop : ConsensusLoop
        From :func:`consensus_loop`.
    kp_bounds, kc_bounds : (float, float)
        [1/s], 0 <= lo <= hi.
    grid : (int, int)
        Grid points per gain, >= 1 each.
    refine : bool
        Run the local refinement.
    max_evaluations : int
        Solves of the refinement.
    tau_max : float or None
        None: the delay-free loop (bounded-real lemma). A number h [s]: the
        law delayed as the loop's ``own_speed`` says (the whole law:
        ẋ = A₀x + (κ_pA_p + κ_cA_c)x(t − τ) + B_w w), and γ certified for
        every delay in [0, h] by the Lyapunov–Krasovskii LMI
        (:class:`~trainctl.analysis.delay_lmi.DelayHinfProblem`, h fixed,
        κ_p and κ_c parameters); the independent checks then add the
        Padé-loop norms (order 8) at delays in (0, h].
    delay : {"constant", "varying"}
        With ``tau_max``: constant delays or any time-varying τ(t) ∈ [0, h].
    solver : str or None
        cvxpy solver (None: Clarabel, SCS as fallback for the delay-free SDP).

    Returns
    -------
    GainSynthesis
        The gains, the certified γ and the independent checks.

    Raises
    ------
    SolverError
        No point of the search has a certificate (every loop unstable, or
        the solver failed everywhere; the grid statuses are in the message).

    Examples
    --------
    A coarse search over κ_p alone (κ_c fixed at 0): three grid points
    0.01, 0.1 and 1 1/s (geometric, since hi/lo > 10). The largest gain damps
    the disturbances most.

    >>> from trainctl.controllers.hinf.synthesis.loop import consensus_loop
    >>> import numpy as np
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-hinf")
    >>> loop = consensus_loop(build_model(sc), sc.graph())
    >>> res = synthesise_gains(loop, kc_bounds=(0.0, 0.0), grid=(3, 1), refine=False)
    >>> res.kp_grid.tolist(), res.kp, res.evaluations
    ([0.01, 0.1, 1.0], 1.0, 3)
    >>> np.round(res.gamma_grid[:, 0], 1).tolist()  # certified γ per grid point [-]
    [92.3, 10.0, 1.4]
    """
    from trainctl.exceptions import SolverError

    kp_lo, kp_hi = _check_bounds(kp_bounds, "kp_bounds")
    kc_lo, kc_hi = _check_bounds(kc_bounds, "kc_bounds")
    if (len(grid) != 2 or any(isinstance(g, bool) or not isinstance(g, int | np.integer)
                              or g < 1 for g in grid)):
        raise ModelError(f"synthesise_gains: 'grid' must be two integers >= 1 (got {grid!r}).")
    if tau_max is not None and not (isinstance(tau_max, int | float | np.floating)
                                    and math.isfinite(tau_max) and tau_max >= 0):
        raise ModelError(f"synthesise_gains: 'tau_max' must be None or a finite number >= 0 s "
                         f"(got {tau_max!r}).")
    if delay not in DELAY_KINDS:
        raise ModelError(f"synthesise_gains: 'delay' must be one of {DELAY_KINDS} (got "
                         f"{delay!r}).")
    h = None if tau_max is None else float(tau_max)
    start = time.perf_counter()
    mid = (0.5 * (kp_lo + kp_hi), 0.5 * (kc_lo + kc_hi))
    problem = _problem(loop, None, solver, mid, h, delay)
    cache: dict[tuple[float, float], Certificate] = {}
    trouble: list[str] = []

    def evaluate(kp: float, kc: float) -> Certificate:
        key = (round(kp, 12), round(kc, 12))
        if key not in cache:
            skipped = _not_hurwitz(loop, kp, kc, h, delay)
            res = skipped if skipped is not None else problem.solve(kp=kp, kc=kc)
            cache[key] = res
            if skipped is None and (res.status != "optimal" or "after" in res.message):
                trouble.append(f"kp={kp:.6g} kc={kc:.6g}: {res.status}: {res.message}")
        return cache[key]

    kp_grid = _axis(kp_lo, kp_hi, int(grid[0]))
    kc_grid = _axis(kc_lo, kc_hi, int(grid[1]))
    gamma_grid = np.array([[evaluate(float(a), float(b)).gamma for b in kc_grid]
                           for a in kp_grid])
    if not np.any(np.isfinite(gamma_grid)):
        raise SolverError(f"synthesise_gains: no gains on the grid are certified (every loop "
                          f"unstable or the solver failed); statuses: "
                          f"{sorted({r.status for r in cache.values()})}.")
    i, j = np.unravel_index(int(np.argmin(gamma_grid)), gamma_grid.shape)
    best = (float(kp_grid[i]), float(kc_grid[j]))
    notes: list[str] = []
    if refine and (kp_hi > kp_lo or kc_hi > kc_lo):
        span = np.array([kp_hi - kp_lo, kc_hi - kc_lo])
        low = np.array([kp_lo, kc_lo])
        active = span > 0
        finite = gamma_grid[np.isfinite(gamma_grid)]
        penalty = 1e6 * float(finite.max())

        def to_gains(u: Array) -> tuple[float, float]:
            full = low.copy()
            full[active] = low[active] + np.clip(u, 0.0, 1.0) * span[active]
            return float(full[0]), float(full[1])

        def objective(u: Array) -> float:
            g = evaluate(*to_gains(u)).gamma
            return g if math.isfinite(g) else penalty

        u0 = (np.array(best) - low)[active] / span[active]
        steps = np.array([1.0 / max(int(grid[0]) - 1, 1), 1.0 / max(int(grid[1]) - 1, 1)])
        steps = steps[active]
        simplex = [u0] + [u0 + np.where(np.arange(u0.size) == k,
                                        steps[k] * (1 if u0[k] + steps[k] <= 1 else -1), 0.0)
                          for k in range(u0.size)]
        res = scipy.optimize.minimize(
            objective, u0, method="Nelder-Mead", bounds=[(0.0, 1.0)] * int(active.sum()),
            options={"initial_simplex": np.array(simplex), "maxfev": int(max_evaluations),
                     "xatol": 1e-4, "fatol": 1e-7 * float(gamma_grid[i, j])})
        cand = to_gains(np.asarray(res.x))
        if evaluate(*cand).gamma < evaluate(*best).gamma:
            best = cand
        if not res.success:
            notes.append(f"Nelder–Mead stopped: {res.message}")
    search_time = time.perf_counter() - start
    skipped = sum(r.status == "not_hurwitz" for r in cache.values())
    if skipped:
        notes.append(f"{skipped} search point(s) not solved: the delay-free loop is not Hurwitz "
                     "there")
    kp, kc = best
    if (kp_lo < kp_hi and kp in (kp_lo, kp_hi)) or (kc_lo < kc_hi and kc in (kc_lo, kc_hi)):
        notes.append("a gain sits on its bound: wider bounds may lower γ")
    return _at_gains(loop, best, evaluate(kp, kc), solver=solver, tau_max=h, delay=delay,
                     kp_grid=kp_grid, kc_grid=kc_grid, gamma_grid=gamma_grid,
                     evaluations=len(cache), trouble=trouble,
                     bounds=((kp_lo, kp_hi), (kc_lo, kc_hi)), search_time=search_time,
                     notes=notes)


def _at_gains(loop: ConsensusLoop, gains: tuple[float, float], certificate: Certificate, *,
              solver: str | None, tau_max: float | None, delay: str, kp_grid: Array,
              kc_grid: Array, gamma_grid: Array, evaluations: int, trouble: list[str],
              bounds: tuple[tuple[float, float], tuple[float, float]], search_time: float,
              notes: list[str]) -> GainSynthesis:
    """Per-channel and per-group certificates and the independent norms at the gains found."""
    kp, kc = gains
    h = tau_max
    skipped = _not_hurwitz(loop, kp, kc, h, delay)

    def solve(columns: Array) -> Certificate:
        if skipped is not None:
            return skipped
        return _problem(loop, columns, solver, gains, h, delay).solve(kp=kp, kc=kc)

    channel_certs: dict[str, Certificate] = {}
    for jj, name in enumerate(loop.channels):
        channel_certs[name] = solve(np.array([jj]))
    group_certs: dict[str, Certificate] = {}
    for group in CHANNEL_GROUPS:
        cols = loop.columns(group)
        if cols.size:
            group_certs[group] = solve(cols)
    if skipped is not None:
        notes.append(skipped.message)
    for label, cert in [("all channels", certificate), *channel_certs.items(),
                        *((f"group {g}", c) for g, c in group_certs.items())]:
        if cert.status == "not_hurwitz":
            continue
        if cert.status != "optimal" or "after" in cert.message:
            trouble.append(f"{label} at kp={kp:.6g} kc={kc:.6g}: {cert.status}: "
                           f"{cert.message}")

    def bounded(label: str, cert: Certificate) -> Certificate:
        # the all-channel LMI restricted to some channels is a principal submatrix of it,
        # so its solution certifies every subset with the same γ
        if not certificate.certified or cert.gamma <= certificate.gamma:
            return cert
        notes.append(f"{label}: its own SDP gave {cert.gamma:.6g} ({cert.status}); bounded by "
                     f"the all-channel certificate {certificate.gamma:.6g}")
        return dataclasses.replace(
            certificate, message=f"bounded by the all-channel certificate (γ "
            f"{certificate.gamma:.6g}); its own SDP: {cert.status}: {cert.message}")

    channel_certs = {k: bounded(f"channel {k}", c) for k, c in channel_certs.items()}
    group_certs = {k: bounded(f"group {k}", c) for k, c in group_certs.items()}
    sys = loop.system(kp, kc)
    norm = hinf_norm(sys)
    chans = channel_norms(sys)
    pade: list[tuple[float, HinfNorm]] = []
    if h is not None and h > 0:
        for tau in np.linspace(0.0, h, PADE_POINTS + 1)[1:]:
            pade.append((float(tau), hinf_norm(loop.delayed_system(kp, kc, float(tau)))))
    return GainSynthesis(kp=kp, kc=kc, certificate=certificate,
                         channel_certificates=channel_certs, group_certificates=group_certs,
                         norm=norm, channels=chans, kp_grid=kp_grid, kc_grid=kc_grid,
                         gamma_grid=gamma_grid, evaluations=evaluations,
                         trouble=tuple(dict.fromkeys(trouble)),
                         scaling=tuple(float(x) for x in loop.scaling), units=loop.units(),
                         output=loop.output, output_scale=loop.output_scale,
                         bounds=bounds, search_time=search_time, tau_max=h, delay=delay,
                         pade_norms=tuple(pade), notes=tuple(notes))


def certify_gains(loop: ConsensusLoop, kp: float, kc: float, *, tau_max: float | None = None,
                  delay: str = "constant", solver: str | None = None) -> GainSynthesis:
    """The certified γ of given gains, with the same checks as :func:`synthesise_gains`.

    No search: one SDP for all channels, one per channel and one per group
    at (κ_p, κ_c), and the independent norms (delay-free, and the Padé
    loops with ``tau_max``). A loop that no SDP certifies (unstable, or the
    solver failed) has γ = inf, its status in ``trouble``; nothing raises.

    Parameters
    ----------
    loop : ConsensusLoop
        From :func:`consensus_loop`.
    kp, kc : float
        κ_p, κ_c [1/s], finite, >= 0.
    tau_max : float or None
        As in :func:`synthesise_gains`.
    delay : {"constant", "varying"}
        As in :func:`synthesise_gains`.
    solver : str or None
        cvxpy solver.

    Returns
    -------
    GainSynthesis
        With a one-point grid (``bounds`` the gains themselves, ``evaluations`` 1).

    Examples
    --------
    >>> from trainctl.controllers.hinf.synthesis.loop import consensus_loop
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> sc = load_scenario("heavy-haul-hinf")
    >>> res = certify_gains(consensus_loop(build_model(sc), sc.graph()), 0.1, 0.0)
    >>> res.norm.norm <= res.gamma <= res.norm.norm * (1 + 1e-4), res.consistent
    (True, True)
    """
    for name, value in (("kp", kp), ("kc", kc)):
        if not (isinstance(value, int | float | np.floating) and not isinstance(value, bool)
                and math.isfinite(value) and value >= 0):
            raise ModelError(f"certify_gains: '{name}' must be a finite number >= 0 1/s (got "
                             f"{value!r}).")
    if tau_max is not None and not (isinstance(tau_max, int | float | np.floating)
                                    and math.isfinite(tau_max) and tau_max >= 0):
        raise ModelError(f"certify_gains: 'tau_max' must be None or a finite number >= 0 s "
                         f"(got {tau_max!r}).")
    if delay not in DELAY_KINDS:
        raise ModelError(f"certify_gains: 'delay' must be one of {DELAY_KINDS} (got {delay!r}).")
    h = None if tau_max is None else float(tau_max)
    gains = (float(kp), float(kc))
    start = time.perf_counter()
    certificate = (_not_hurwitz(loop, gains[0], gains[1], h, delay)
                   or _problem(loop, None, solver, gains, h, delay).solve(kp=gains[0],
                                                                          kc=gains[1]))
    elapsed = time.perf_counter() - start
    return _at_gains(loop, gains, certificate, solver=solver, tau_max=h, delay=delay,
                     kp_grid=np.array([gains[0]]), kc_grid=np.array([gains[1]]),
                     gamma_grid=np.array([[certificate.gamma]]), evaluations=1, trouble=[],
                     bounds=((gains[0], gains[0]), (gains[1], gains[1])), search_time=elapsed,
                     notes=[])
