# The published claims of seed 003 set against what trainctl computes for the scenario.
"""Seed 003's claims (Ning et al. 2016), each with trainctl's number and a verdict.

The paper states results, not equations (spec §4.4): under random delay the
tracking-speed deviation is 7.5 times the ideal case's; the distributed
H∞ controller settles clearly faster than centralised synchronous control;
an interruption at steady state raises the deviation and the forces between
the subsystems, and tracking recovers when the graph stays jointly
connected; the H∞ index ‖s‖₂ < γ‖w‖₂ with γ = 1 is met. :func:`paper_claims`
computes each of those that a run can decide, from the run's design,
simulations and repetitions (:mod:`trainctl.repetitions`), and says
``"reproduced"``, ``"not reproduced"`` or ``"depends on …"``. A claim the
scenario cannot decide (no delay, a single strategy, no outage) is left out:
each of the four seed-003 scenarios decides its own case (``analyses/``).

How each claim is measured
--------------------------
- **Deviation under delay** (case c, needs ``[simulation]
  baseline_network``): RMS speed error of subsystem 1 (the one the paper
  shows) over the whole run with the scenario's network, divided by the
  same over the baseline network (``"delay-free"``: the same noise without
  the delays, which isolates them; ``"ideal"``: no network at all); with
  ``repetitions`` the median and range over the runs. Reproduced when the
  median is within a factor 1.5 of 7.5 (5 to 11.25).
- **Settling** (case c, needs both the ``distributed`` and the
  ``synchronous`` strategies): subsystem 1's settling time after the
  reference's last breakpoint (:data:`~trainctl.repetitions.SETTLING_BAND`),
  median over the runs. Reproduced when the distributed law's is shorter.
- **Interruption** (case b, needs an interruption window): the largest
  |speed error|, and apart the largest |coupler force|, of the distributed
  run inside the windows against an equally long stretch just before the
  first one (each reproduced when larger inside), and recovery: the
  ``hinf_connectivity`` verdict beside the run's tracking after
  ``settle_time`` (reproduced when a jointly connected graph tracks again).
- **H∞ index** (case d, needs link noise): the simulated ratio
  ‖s̃‖₂ / ‖w̃‖₂ on the scaled channels, s̃ the speed errors over
  ``output_scale_m_s``, w̃ the noise of the values the law held over
  ``noise_scale_m_s`` (:func:`performance_energies`). Reproduced when it is at
  most the certified γ and at most 1.
- **γ = 1** (every scenario with the family): the certified γ with the
  scenario's scaling and the independent norm with every channel in SI
  units; always "depends on the scaling", the paper giving none.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from .run import AnalysisRun

__all__ = ["PAPER_DEVIATION_RATIO", "RATIO_FACTOR", "Claim", "paper_claims",
           "performance_energies"]

PAPER_DEVIATION_RATIO = 7.5
"""Speed deviation under random delay over the ideal case's, as the paper reports it (spec §4.4)."""

RATIO_FACTOR = 1.5
"""A ratio within this factor of the paper's counts as reproduced."""

VERDICTS = ("reproduced", "not reproduced", "depends")
"""Kinds of verdict (the text of a "depends" verdict says on what)."""


@dataclass(frozen=True, kw_only=True)
class Claim:
    """One published claim, trainctl's number and the verdict.

    Parameters
    ----------
    key : str
        ``"delay_deviation"``, ``"settling"``, ``"interruption_deviation"``,
        ``"interruption_force"``, ``"interruption_recovery"``,
        ``"performance_index"`` or ``"gamma"``.
    case : str
        The paper's case: ``"(a)"`` … ``"(d)"``, or ``"design"``.
    claim : str
        What the paper says.
    paper : str
        The paper's number or statement.
    trainctl : str
        trainctl's number(s).
    kind : {"reproduced", "not reproduced", "depends"}
        The verdict's kind.
    verdict : str
        The verdict as shown (``"depends on the scaling"`` for that kind).
    note : str
        How it was measured and what it depends on.
    """

    key: str
    case: str
    claim: str
    paper: str
    trainctl: str
    kind: str
    verdict: str
    note: str

    def to_dict(self) -> dict[str, str]:
        """JSON-safe."""
        return {"key": self.key, "case": self.case, "claim": self.claim, "paper": self.paper,
                "trainctl": self.trainctl, "kind": self.kind, "verdict": self.verdict,
                "note": self.note}


def _fmt(x: float, digits: int = 3) -> str:
    return f"{x:.{digits}g}" if math.isfinite(x) else "∞"


def _spread_text(values: Sequence[float], unit: str = "") -> str:
    x = np.asarray(values, dtype=float)
    if x.size == 1:
        return f"{_fmt(float(x[0]))}{unit}"
    return (f"median {_fmt(float(np.median(x)))}{unit}, range {_fmt(float(np.min(x)))} to "
            f"{_fmt(float(np.max(x)))}{unit} over {x.size} runs")


def _hinf_strategy(run: AnalysisRun, family: str) -> str | None:
    """The simulated strategy name of a family's (only) strategy, or None."""
    sim = run.scenario.simulation
    if sim is None:
        return None
    for name in sim.strategies:
        if run.design.resolve(name)[0] == family and name in run.simulations:
            return name
    return None


def paper_claims(run: AnalysisRun) -> list[Claim]:
    """Every seed-003 claim the run can decide (module docstring); empty without ``hinf``.

    Parameters
    ----------
    run : AnalysisRun
        A scenario's run (its design, simulations and repetitions).

    Returns
    -------
    list of Claim
        In the paper's order: (a)–(d), then γ.
    """
    if "hinf" not in run.design.families:
        return []
    out: list[Claim] = []
    hinf = _hinf_strategy(run, "hinf")
    sync = _hinf_strategy(run, "synchronous")
    network = run.scenario.network
    if hinf is not None and network is not None:
        windows = tuple(network.interruptions)
        if windows:
            out += _interruption(run, hinf, windows)
        lo, hi = network.delay_bounds()
        if hi > 0 and hinf in run.baseline:
            out.append(_delay_deviation(run, hinf, sync))
        if hinf is not None and sync is not None and hi > 0:
            out.append(_settling(run, hinf, sync))
        if network.communication_noise_std > 0 or (network.reference_noise_std or 0) > 0:
            index = _performance_index(run, hinf)
            if index is not None:
                out.append(index)
    out.append(_gamma(run))
    return out


def _runs(run: AnalysisRun, strategy: str) -> list[Any]:
    """The strategy's repetitions (run 0 alone when there are none)."""
    from .repetitions import summarise

    reps = run.repetitions.get(strategy)
    if reps:
        return list(reps)
    return [summarise(run.simulations[strategy], run.scenario, strategy, 0,
                      int(run.scenario.seed))]


def _delay_deviation(run: AnalysisRun, hinf: str, sync: str | None) -> Claim:
    sim = run.scenario.simulation
    kind = (sim.baseline_network if sim is not None else None) or "ideal"
    base_run = run.baseline[hinf].deviation
    base = float(base_run.rms_error[0])
    ratios = [float(r.deviation.rms_error[0]) / base if base > 0 else math.inf
              for r in _runs(run, hinf)]
    peak = [float(r.deviation.max_error[0]) / float(base_run.max_error[0])
            if base_run.max_error[0] > 0 else math.inf for r in _runs(run, hinf)]
    median = float(np.median(ratios))
    lo, hi = PAPER_DEVIATION_RATIO / RATIO_FACTOR, PAPER_DEVIATION_RATIO * RATIO_FACTOR
    ok = lo <= median <= hi
    text = f"RMS ratio {_spread_text(ratios, '×')}; peak ratio {_spread_text(peak, '×')}"
    if sync is not None and sync in run.baseline:
        sbase = float(run.baseline[sync].deviation.rms_error[0])
        sratios = [float(r.deviation.rms_error[0]) / sbase if sbase > 0 else math.inf
                   for r in _runs(run, sync)]
        text += f"; synchronous RMS ratio {_spread_text(sratios, '×')}"
    lo_d, hi_d = run.scenario.network.delay_bounds() if run.scenario.network else (0.0, 0.0)
    against = ("the same run without the delays (the same noise, drawn the same)"
               if kind == "delay-free" else "the same run on an ideal network")
    note = (f"Subsystem 1's RMS speed error over the whole run with delays drawn per message "
            f"in [{lo_d:g}, {hi_d:g}] s, over {against}: {_fmt(base * 1e3)} mm/s. The "
            "ratio depends on what the baseline leaves to deviate and on the profile's "
            "accelerations (a reference τ old lags by v̇_d·τ); the paper gives neither its "
            "measure nor its ideal deviation.")
    return Claim(key="delay_deviation", case="(c)",
                 claim="Under random delay the tracking-speed deviation is 7.5 times the "
                 "ideal case's", paper=f"{PAPER_DEVIATION_RATIO:g}×", trainctl=text,
                 kind="reproduced" if ok else "not reproduced",
                 verdict="reproduced" if ok else "not reproduced", note=note)


def _settling(run: AnalysisRun, hinf: str, sync: str) -> Claim:
    from .repetitions import SETTLING_BAND

    a = [float(r.deviation.settling_time[0]) for r in _runs(run, hinf)]
    b = [float(r.deviation.settling_time[0]) for r in _runs(run, sync)]
    ma, mb = float(np.median(a)), float(np.median(b))
    faster = ma < mb
    since = run.repetitions[hinf][0].deviation.since if run.repetitions.get(hinf) else float(
        run.scenario.simulation.reference_times[-1]) if run.scenario.simulation else 0.0
    return Claim(key="settling", case="(c)",
                 claim="The distributed robust H∞ controller settles clearly faster than "
                 "centralised synchronous control", paper="shorter settling time",
                 trainctl=f"distributed {_spread_text(a, ' s')}; synchronous "
                 f"{_spread_text(b, ' s')}",
                 kind="reproduced" if faster else "not reproduced",
                 verdict="reproduced" if faster else "not reproduced",
                 note=f"Subsystem 1's time after the reference's last change (t = {since:g} s) "
                 f"until its speed error stays within {SETTLING_BAND:g} m/s for the rest of the "
                 "run; the synchronous remotes answer the grade under the lead, late by their "
                 "link delay, while each distributed subsystem answers its own.")


def _interruption(run: AnalysisRun, hinf: str, windows: Sequence[Any]) -> list[Claim]:
    result = run.simulations[hinf]
    t = np.asarray(result.dense_time, dtype=float)
    n = result.velocities.shape[0]
    e = np.abs(result.dense_states[:n] - result.dense_reference_speed[None, :])
    f = np.abs(result.dense_coupler_forces)
    inside = np.zeros(t.size, dtype=bool)
    for w in windows:
        inside |= (t >= w.start) & (t < min(w.end, t[-1] + 1.0))
    end = float(t[-1])
    first = min(w.start for w in windows)
    length = sum(max(0.0, min(w.end, end) - min(w.start, end)) for w in windows)
    before = (t >= first - length) & (t < first)
    claims: list[Claim] = []
    if np.any(inside) and np.any(before):
        e_in, e_out = float(np.max(e[:, inside])), float(np.max(e[:, before]))
        f_in = float(np.max(f[:, inside])) if f.size else 0.0
        f_out = float(np.max(f[:, before])) if f.size else 0.0
        claims.append(_window_claim(
            "interruption_deviation", "the tracking deviation", e_in, e_out, "m/s", length,
            "each subsystem keeps regulating towards the last reference value it received, "
            "noise included, and its neighbours' last speeds, so their errors stop averaging "
            "out"))
        claims.append(_window_claim(
            "interruption_force", "the forces between the subsystems", f_in / 1e3,
            f_out / 1e3, "kN", length,
            "two effects pull against each other: the subsystems aim at different held "
            "values, which the couplers take up, but fresh noise no longer arrives to shake "
            "them"))
    check = next((c for c in run.review.checks if c.name == "hinf_connectivity"), None)
    connected = check is not None and check.status == "pass"
    tracks = run.tracking_ok(hinf)
    ok = connected == tracks
    sim = run.scenario.simulation
    settle = sim.settle_time if sim is not None else 0.0
    claims.append(Claim(
        key="interruption_recovery", case="(b)",
        claim="Tracking recovers after the outage when the digraph stays jointly connected",
        paper="recovers", trainctl=(
            f"hinf_connectivity {check.status if check else 'missing'}; after {settle:g} s "
            f"max |e| {_fmt(float(np.max(run.metrics[hinf].max_error)))} m/s "
            + ("within" if tracks else "outside") + " the tolerance"),
        kind="reproduced" if ok else "not reproduced",
        verdict="reproduced" if ok else "not reproduced",
        note="The analysis (joint connectivity of the graph over each window) and the "
        "simulation (tracking after settle_time) agree when both say recovery or both say "
        "none."))
    return claims


def _window_claim(key: str, what: str, inside: float, before: float, unit: str,
                  length: float, why: str) -> Claim:
    larger = inside > before
    return Claim(
        key=key, case="(b)", claim=f"An interruption at steady state raises {what}",
        paper="larger during the outage",
        trainctl=f"max {_fmt(inside)} {unit} inside against {_fmt(before)} {unit} before "
        f"({_fmt(inside / before if before > 0 else math.inf)}×)",
        kind="reproduced" if larger else "not reproduced",
        verdict="reproduced" if larger else "not reproduced",
        note=f"The distributed run inside the outage windows ({length:g} s) against the "
        f"{length:g} s just before the first: {why}.")


def _performance_index(run: AnalysisRun, hinf: str) -> Claim | None:
    result = run.simulations[hinf]
    design = run.design.family("hinf")
    s = design.settings
    energies = performance_energies(result, s)
    if energies is None:
        return None
    ratio = float(math.sqrt(energies[0][-1] / energies[1][-1]))
    gamma = float(design.gamma.gamma)
    ok = ratio <= min(gamma, 1.0)
    return Claim(
        key="performance_index", case="(d)",
        claim="The H∞ performance index ‖s‖₂ < γ‖w‖₂ with γ = 1 is met",
        paper="met (γ = 1)",
        trainctl=f"simulated ‖s̃‖₂/‖w̃‖₂ = {_fmt(ratio)} against certified γ = {_fmt(gamma)}",
        kind="reproduced" if ok else "not reproduced",
        verdict="reproduced" if ok else "not reproduced",
        note=f"Scaled as γ is (noise {s.noise_scale:g} m/s, output {s.output_scale:g} m/s): "
        "the speed errors' energy over the energy of the noise the law read. White noise "
        "spreads its energy over all frequencies, so the ratio is far below ‖T‖∞; the "
        "certificate bounds it for every w.")


def performance_energies(result: Any, settings: Any) -> tuple[Any, Any] | None:
    """∫₀ᵗ‖s̃‖² and ∫₀ᵗ‖w̃‖² at the samples t_1 … t_N [-·s], or None without link noise.

    s̃ is the performance output over ``output_scale`` (the speed errors, or
    their deviations from the mean, at the end of each sample interval), w̃
    the noise the law held during each interval over ``noise_scale``
    (:attr:`~trainctl.sim.results.SimulationResult.held_noise_square`);
    each is held over the interval Δt.

    Parameters
    ----------
    result : SimulationResult
        A run of the hinf family over a noisy network.
    settings : HinfSettings
        The family's settings (scales, performance output).

    Returns
    -------
    (ndarray, ndarray) or None
        The two cumulative energies, shape (N,) each.
    """
    held = np.asarray(result.held_noise_square, dtype=float)
    if held.size == 0 or not np.any(held > 0):
        return None
    dt = float(result.dt)
    e = result.velocities - result.reference_speed[None, :]
    if settings.performance == "disagreement":
        e = e - e.mean(axis=0, keepdims=True)
    s2 = dt * np.cumsum(np.sum(e[:, 1:] ** 2, axis=0)) / settings.output_scale ** 2
    w2 = dt * np.cumsum(held) / settings.noise_scale ** 2
    return s2, w2


def _gamma(run: AnalysisRun) -> Claim:
    from .analysis.consensus_hinf import consensus_loop
    from .analysis.hinf import hinf_norm

    design = run.design.family("hinf")
    s = design.settings
    gamma = float(design.gamma.gamma)
    unit = consensus_loop(design.model, design.graph, output=s.performance,
                          output_scale=1.0,
                          local_feedback=design.law.resistance_feedback(
                              float(design.model.settings.speed)),
                          own_speed=s.own_speed)
    si = float(hinf_norm(unit.system(design.law.kappa_p, design.law.kappa_c)).norm)
    return Claim(
        key="gamma", case="design", claim="γ = 1 is achieved", paper="γ = 1",
        trainctl=f"certified γ = {_fmt(gamma, 4)} with the scenario's scaling (force "
        f"{s.force_scale:g} m/s², noise {s.noise_scale:g} m/s, output {s.output_scale:g} m/s); "
        f"‖T‖∞ = {_fmt(si, 4)} with every channel in SI units (1 m/s², 1 m/s)",
        kind="depends", verdict="depends on the scaling",
        note="γ is a gain between scaled signals and the paper gives no scaling. With the "
        "tracking output a noise common to every received reference reaches the speed errors "
        "with gain 1 at DC whatever the gains, so γ cannot fall below noise_scale / "
        "output_scale; the force channels' gain is about 1/κ_p in SI units.")


def claims_dict(claims: Sequence[Claim]) -> list[dict[str, str]]:
    """JSON-safe list."""
    return [c.to_dict() for c in claims]


def claims_by_key(claims: Sequence[Mapping[str, str]]) -> dict[str, Mapping[str, str]]:
    """Claims (dicts) by key."""
    return {c["key"]: c for c in claims}
