# The hinf family as a registry entry: seed 003's distributed robust H∞ cooperative law.
"""The hinf family object (:data:`FAMILY`), see :mod:`trainctl.registry`.

One strategy, ``"distributed"``: the reconstructed distributed robust H∞
cooperative law of seed 003 (spec §4.2, :mod:`trainctl.controllers.hinf.law`),
leader-following velocity consensus of the locomotive subsystems over the
``[communication]`` graph, each vehicle acting on the reference's and its
neighbours' speeds as they arrive over the ``[network]`` radio links
(delayed, lost, interrupted, noisy; :mod:`trainctl.models.network`), sampled at the
family's ``control_interval``, about each vehicle's own resistance
feedforward, clipped to the envelope. The gains κ_p and κ_c are the
scenario's, or (``synthesise = true``) synthesised once at the design stage
for the smallest certified H∞ gain γ on the family's own loop
(:func:`trainctl.controllers.hinf.synthesis.consensus_loop` with the
feedforward's slope as its local feedback, the family's ``own_speed``,
channel scaling and performance output). Its linear closed loop on the
design model (no delay, ideal network) is continuous (dt = 0):
:meth:`HinfFamily.closed_loop` returns it with the inputs ``w[i]``
(specific-force disturbances [m/s²]) and the outputs ``v[i]`` [m/s],
``f[i]`` [kN] and ``d[i]`` [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.delay import seconds as _seconds
from trainctl.controllers.continuous.delay import worst_delay as network_worst_delay
from trainctl.controllers.continuous.family import QUANTITIES_TABLE, ContinuousFamily, SampledDesign
from trainctl.controllers.hinf.hooks import HinfHooks

if TYPE_CHECKING:
    from trainctl.analysis.connectivity import WindowConnectivity
    from trainctl.analysis.delay import DelayMargin
    from trainctl.controllers.hinf.law import (
        HinfLaw,  # noqa: F401 (a type argument)
        LoopMatrices,
    )
    from trainctl.controllers.hinf.settings import HinfSettings
    from trainctl.controllers.hinf.synthesis import ConsensusLoop, GainSynthesis
    from trainctl.design import DesignModel
    from trainctl.models.graphs import CommunicationGraph
    from trainctl.models.network import NetworkSettings
    from trainctl.scenario import Scenario

__all__ = ["CHECK_NAMES", "DELAY_POINTS", "DELAY_SEARCH", "FAMILY", "GRAPH_USAGE", "STRATEGIES",
           "HinfDesign", "HinfFamily", "design_hinf"]

STRATEGIES = ("distributed",)
"""The hinf family's one strategy."""

CHECK_NAMES = ("hinf_closed_loop", "hinf_sampling", "hinf_delay_margin", "hinf_connectivity",
               "hinf_gamma")
"""The hinf family's design checks (:mod:`trainctl.controllers.hinf.checks`)."""

DELAY_SEARCH = 10.0
"""Shortest delay range [s] searched for the margin: (0, max(10 s, 4 × the worst case)].

Five times GSM-R's 2 s worst case (spec §4.4), so that a margin above the
worst case is located rather than only bounded."""

DELAY_POINTS = 400
"""Scan points of the delay margin: a 25 ms grid on 10 s, fine against the
coupler-mode margins of a fraction of a second (spec §4.3)."""

GRAPH_USAGE = ("Each vehicle compares its speed with the speeds it receives over these links "
               "(consensus gain κ_c × a_ij) and with the reference, where pinned "
               "(pinning gain κ_p × b_i), as they arrive over the [network] links.")
"""What the law does with the graph, for the caption of its figure."""

Array = NDArray[np.float64]

PARTIAL = """\
<p>Distributed robust H∞ cooperative control: every locomotive subsystem applies
v̇_d − κ_p b_i (v_i − v̂_d) − κ_c Σ_j a_ij (v_i − v̂_j) per unit mass, on the reference's and
its neighbours' speeds as received over the radio network (held during outages), about its
own resistance at its speed; its own speed is taken {% if data.own_speed == "delayed" %}at the
received data's send time{% else %}now{% endif %}. Sampled every {{ data.control_interval }}
s{% if not data.input_bounds %} (no saturation){% endif %}. The gains are
{{ data.gains_source }}.</p>
<p>{{ data.gamma_sentence }}</p>
""" + QUANTITIES_TABLE


@dataclass(frozen=True, kw_only=True, eq=False)
class HinfDesign(SampledDesign["HinfSettings", "HinfLaw"]):
    """The hinf family's design of one scenario.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        The run's design model.
    settings : HinfSettings
        The family's settings.
    law : HinfLaw
        The law's SI gains and graph.
    control_interval : float
        T_c [s].
    loops : LoopMatrices
        Open loop, undelayed and delayed parts, delay-free closed loop.
    network : NetworkSettings or None
        The scenario's ``[network]`` (None: data arrive when sent).
    graph : CommunicationGraph
        The ``[communication]`` graph.
    consensus : ConsensusLoop
        The same loop affine in (κ_p, κ_c) with the scaled disturbance
        channels and performance output of the settings
        (:func:`~trainctl.controllers.hinf.synthesis.consensus_loop`, the
        feedforward's slope as its local feedback).
    synthesis : GainSynthesis or None
        With ``synthesise = true``: the search's result, whose gains the law
        uses; None otherwise, or when the search certified nothing
        (``synthesis_error``).
    synthesis_error : str
        Why a requested synthesis gave no gains ("" otherwise); the law then
        keeps ``kappa_p_per_s`` and ``kappa_c_per_s``.

    Examples
    --------
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = design_hinf(scenario, build_model(scenario), HinfSettings())
    >>> design.gains_source, design.law.kappa_p, design.control_interval  # [1/s], [s]
    ('given', 0.1, 0.1)
    >>> design.network is None, design.loops.A_cl.shape
    (True, (7, 7))
    """

    network: NetworkSettings | None
    graph: CommunicationGraph
    loops: LoopMatrices
    consensus: ConsensusLoop
    synthesis: GainSynthesis | None = None
    synthesis_error: str = ""

    @property
    def gains_source(self) -> str:
        """``"synthesised"``, ``"given"``, or ``"given (synthesis failed)"``."""
        if self.synthesis is not None:
            return "synthesised"
        return "given (synthesis failed)" if self.synthesis_error else "given"

    @cached_property
    def gamma(self) -> GainSynthesis:
        """The certified γ of the gains in use and the independent norms beside it.

        The synthesis's result when the gains were synthesised; otherwise
        :func:`~trainctl.controllers.hinf.synthesis.certify_gains` at the law's
        gains (delay-free, or for constant delays in [0, τ_max] with
        ``delay_certificate_s``).
        """
        from trainctl.controllers.hinf.synthesis import certify_gains

        if self.synthesis is not None:
            return self.synthesis
        return certify_gains(self.consensus, self.law.kappa_p, self.law.kappa_c,
                             tau_max=self.settings.delay_certificate)

    @property
    def worst_delay(self) -> float | None:
        """The ``[network]`` worst-case delay [s] (upper end of the range); None without one."""
        return network_worst_delay(self.network)

    @property
    def run_length(self) -> float:
        """The run judged by ``hinf_connectivity`` [s]: the ``[simulation]`` duration.

        Without ``[simulation]``: twice the last interruption window's end
        (1 s without a window), a run that outlasts every window.
        """
        if self.scenario.simulation is not None:
            return float(self.scenario.simulation.duration)
        ends = [float(w.end) for w in (self.network.interruptions if self.network else ())]
        return 2.0 * max(ends) if ends else 1.0

    @cached_property
    def delay(self) -> DelayMargin:
        """The full loop's delay margin (:func:`trainctl.analysis.delay.delay_margin`)."""
        from trainctl.analysis.delay import delay_margin

        worst = self.worst_delay or 0.0
        loops = self.loops
        return delay_margin(loops.A0, loops.B_open, loops.K_delay,
                            tau_max=max(DELAY_SEARCH, 4.0 * worst), points=DELAY_POINTS)

    @cached_property
    def consensus_bound(self) -> float | None:
        """π/(2 λ_max(κ_p P + κ_c L)) [s]; None for a directed graph (the bound needs symmetry)."""
        from trainctl.analysis.delay import consensus_delay_bound

        Lp = self.law.pinned_laplacian()
        if not np.allclose(Lp, Lp.T, rtol=1e-10, atol=1e-12):
            return None
        return float(consensus_delay_bound(Lp))

    @cached_property
    def connectivity(self) -> list[WindowConnectivity]:
        """Per ``[network]`` interruption window: who is cut off, whether reached again."""
        from trainctl.analysis.connectivity import joint_connectivity

        windows = self.network.interruptions if self.network is not None else ()
        if not windows:
            return []
        return joint_connectivity(self.graph, windows, self.run_length)

    def _feedback(self) -> Array:
        """The delay-free law's gain at the model's speed."""
        return self.law.feedback(float(self.model.settings.speed))


def design_hinf(scenario: Scenario, model: DesignModel, settings: HinfSettings) -> HinfDesign:
    """The law's gains, its graph and its linear loops.

    With ``synthesise = true`` the gains come from one run of
    :func:`~trainctl.controllers.hinf.synthesis.synthesise_gains` on the
    family's consensus loop (the settings' bounds, grid, refinement,
    scaling, performance output and ``delay_certificate_s``); when it
    certifies nothing the law keeps the given gains and the reason is
    recorded (``synthesis_error``, reported by ``hinf_gamma``).

    Parameters
    ----------
    scenario : Scenario
        The scenario (train, ``[communication]``, ``[network]``, ``[simulation]``).
    model : DesignModel
        Its design model.
    settings : HinfSettings
        The family's settings.

    Returns
    -------
    HinfDesign
        The design.

    Raises
    ------
    ScenarioError
        If the simulation's duration is not a whole multiple of the control
        interval.

    Examples
    --------
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> d = design_hinf(scenario, build_model(scenario), HinfSettings())
    >>> d.loops.A_cl.shape, d.control_interval, d.worst_delay, d.graph.topology
    ((7, 7), 0.1, None, 'bidirectional')
    >>> d.gains_source, d.consensus.channels[:2]
    ('given', ('f[0]', 'f[1]'))
    """
    from trainctl.controllers.continuous.sampled import control_interval
    from trainctl.controllers.hinf.law import closed_loop_matrices, law_of
    from trainctl.controllers.hinf.synthesis import consensus_loop, synthesise_gains
    from trainctl.exceptions import SolverError

    T = control_interval(scenario, model, settings, "hinf")
    law = law_of(scenario, settings)
    graph = scenario.graph()
    loop = consensus_loop(model, graph, output=settings.performance,
                          scaling=settings.scaling(), output_scale=settings.output_scale,
                          local_feedback=law.resistance_feedback(float(model.settings.speed)),
                          own_speed=settings.own_speed)
    synthesis: GainSynthesis | None = None
    error = ""
    if settings.synthesise:
        grid = int(settings.synthesis_grid)
        try:
            synthesis = synthesise_gains(
                loop, kp_bounds=settings.kappa_p_bounds, kc_bounds=settings.kappa_c_bounds,
                grid=(grid, grid), refine=settings.synthesis_evaluations > 0,
                max_evaluations=int(settings.synthesis_evaluations),
                tau_max=settings.delay_certificate)
        except SolverError as exc:
            error = str(exc)
        else:
            law = law_of(scenario, settings, (synthesis.kp, synthesis.kc))
    return HinfDesign(scenario=scenario, model=model, settings=settings, law=law,
                      control_interval=T, network=scenario.network, graph=graph,
                      loops=closed_loop_matrices(model, law), consensus=loop,
                      synthesis=synthesis, synthesis_error=error)


GAMMA_SENTENCE = (
    "γ is the H∞ gain from the disturbances, each in units of its scale (force per unit mass "
    "force_scale_m_s2, reference and link noise noise_scale_m_s), to the speed errors in units "
    "of output_scale_m_s: whether γ = 1 (the paper's requirement) is met depends entirely on "
    "that scaling, which the paper does not give. With the tracking output a noise common to "
    "every received reference passes to the speed errors with gain 1 at DC whatever the gains, "
    "so with equal noise and output scales γ cannot get below 1.")
"""The report's sentence on what γ = 1 means."""


def _gains_text(design: HinfDesign) -> str:
    """Where the gains come from, for the report."""
    if design.synthesis is not None:
        (a, b), (c, d) = design.synthesis.bounds
        return (f"synthesised for the smallest certified γ, κ_p in [{a:g}, {b:g}], κ_c in "
                f"[{c:g}, {d:g}] 1/s ({design.synthesis.evaluations} SDPs)")
    if design.synthesis_error:
        return "kappa_p_per_s, kappa_c_per_s (the synthesis certified nothing)"
    return "kappa_p_per_s, kappa_c_per_s"


def _gamma_value(x: float) -> str:
    return f"{x:.4g}" if math.isfinite(x) else "none certified"


def _gamma_rows(design: HinfDesign, gamma: GainSynthesis) -> list[tuple[str, str]]:
    """Certified γ (all, per group), the independent norm, the scaling and the delay range."""
    from trainctl.controllers.hinf.synthesis import CHANNEL_GROUPS

    names = {"force": "force", "reference": "reference noise", "link": "link noise"}
    s = design.settings
    delay = ("delay-free (bounded-real lemma)" if gamma.tau_max is None else
             f"constant delays in [0, {gamma.tau_max:g}] s (Lyapunov–Krasovskii)")
    rows = [("Certified γ, all channels [-]", _gamma_value(gamma.gamma)),
            *((f"Certified γ, {names[g]} channels [-]",
               _gamma_value(gamma.group_certificates[g].gamma))
              for g in CHANNEL_GROUPS if g in gamma.group_certificates),
            ("Closed-loop ‖T‖∞ without delay, independent of the LMI [-]",
             _gamma_value(gamma.norm.norm)),
            ("γ certified for", delay),
            ("Performance output", f"{s.performance}, scale {s.output_scale:g} m/s"),
            ("Scaling of the force channels [m/s²]", f"{s.force_scale:g}"),
            ("Scaling of the reference and link noise channels [m/s]", f"{s.noise_scale:g}")]
    return rows


def _age_rows(design: HinfDesign) -> list[tuple[str, str]]:
    """The age of the newest datum held over a random-delay network (median, 99 %)."""
    from trainctl.analysis.delay import held_data_age

    network = design.network
    if network is None:
        return []
    lo, hi = network.delay_bounds()
    if hi <= lo:
        return []
    age = held_data_age(design.control_interval, (lo, hi),
                        loss_probability=float(network.loss_probability))
    return [("Age of the newest datum held, median / 99 % [s]",
             f"{age.quantile(0.5):.4g} / {age.quantile(0.99):.4g} (a message every "
             f"{design.control_interval:g} s, delays in [{lo:g}, {hi:g}] s)")]


class HinfFamily(HinfHooks, ContinuousFamily[HinfDesign, "HinfSettings"]):
    """Seed 003's distributed robust H∞ cooperative law (leader-following speed consensus).

    Examples
    --------
    >>> from trainctl.controllers.hinf.settings import HinfSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = FAMILY.design(scenario, build_model(scenario), HinfSettings())
    >>> FAMILY.name, FAMILY.strategies
    ('hinf', ('distributed',))
    >>> FAMILY.make(design, "distributed").dt  # the control interval [s]
    0.1
    """

    name = "hinf"
    batches_repetitions = True
    """Its laws run batched (the repetitions of a strategy as one batch)."""
    title = "Distributed robust H∞ cooperative control"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    report_partial = PARTIAL
    settings_path = "trainctl.controllers.hinf.settings:HinfSettings"
    checks_path = "trainctl.controllers.hinf.checks:hinf_checks"
    controller_path = "trainctl.controllers.hinf.controller:HinfController"
    graph_usage = GRAPH_USAGE
    _design = staticmethod(design_hinf)

    def report_data(self, design: HinfDesign) -> dict[str, Any]:
        """Gains, delay margin against the consensus bound and the network, the graph.

        The delay-free loop's spectrum, sampled at the model's sample time,
        joins the eigenvalue map (``spectra``); the ``[communication]`` graph
        is stored under ``graph``
        (:func:`trainctl.plots.graph_figures.graph_report_data`), JSON-safe.

        Parameters
        ----------
        design : HinfDesign
            The family's design.

        Returns
        -------
        dict
            JSON-safe: ``spectra`` (the delay-free loop's eigenvalues mapped
            to z = exp(λ T_s), as [re, im] pairs), ``rows`` (name/value rows
            of the table), ``gains_source``, ``gamma_sentence``, ``gamma``
            (the certified γ), ``synthesis_error``, ``own_speed``,
            ``control_interval`` [s] (as text), ``input_bounds``, ``delay``
            (the delay margin), ``consensus_bound`` [s] (None for a directed
            graph or no bound), ``connectivity`` (per window) and ``graph``.
        """
        from trainctl.analysis.check import finite_or_none
        from trainctl.controllers.continuous.loops import report_spectrum
        from trainctl.plots.graph_figures import graph_report_data

        points, modes = report_spectrum(design.loops.A_cl, design.model.settings.sample_time)
        s, res = design.settings, design.delay
        gamma = design.gamma
        rows = [("Pinning gain κ_p [1/s]", f"{design.law.kappa_p:.4g}"),
                ("Consensus gain κ_c [1/s]", f"{design.law.kappa_c:.4g}"),
                ("Gains", _gains_text(design)),
                *_gamma_rows(design, gamma),
                ("Own speed in the differences", s.own_speed),
                ("Control interval [s]", f"{design.control_interval:g}"),
                ("Delay margin, full loop [s]", _seconds(res.margin)),
                ("First-order consensus bound [s]",
                 _seconds(design.consensus_bound, "directed graph")),
                ("Network worst-case delay [s]", _seconds(design.worst_delay)),
                *_age_rows(design), *modes]
        return {"spectra": {"hinf distributed": points},
                "rows": [{"name": a, "value": b} for a, b in rows],
                "gains_source": design.gains_source,
                "gamma_sentence": GAMMA_SENTENCE,
                "gamma": gamma.to_dict(), "synthesis_error": design.synthesis_error,
                "own_speed": s.own_speed,
                "control_interval": f"{design.control_interval:g}",
                "input_bounds": bool(s.input_bounds), "delay": res.to_dict(),
                "consensus_bound": finite_or_none(design.consensus_bound),
                "connectivity": [w.to_dict() for w in design.connectivity],
                "graph": graph_report_data(design.graph)}


FAMILY = HinfFamily()
"""The registry entry of the hinf family."""
