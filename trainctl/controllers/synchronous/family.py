# The synchronous family as a registry entry: the LOCOTROL-type centralised baseline.
"""The synchronous family object (:data:`FAMILY`), see :mod:`trainctl.registry`.

One strategy, ``"synchronous"``: centralised synchronous operation of a
distributed-power train (spec §4.2, the baseline of seed 003). The lead
locomotive closes a speed loop (:mod:`trainctl.controllers.synchronous.law`),
its command goes over the radio relay
(:mod:`trainctl.controllers.synchronous.relay`) and every remote applies it
scaled by its mass, holding the last one during outages; every vehicle adds
its own resistance feedforward. Its linear closed loop, with an
instantaneous relay, is continuous (dt = 0): :meth:`SynchronousFamily.closed_loop`
returns it with the inputs ``w[i]`` (specific-force disturbances [m/s²])
and the outputs ``v[i]`` [m/s], ``f[i]`` [kN] and ``d[i]`` [m].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.continuous.delay import seconds as _seconds
from trainctl.controllers.continuous.delay import worst_delay as network_worst_delay
from trainctl.controllers.continuous.family import QUANTITIES_TABLE, ContinuousFamily, SampledDesign

if TYPE_CHECKING:
    from trainctl.analysis.certificates import Certificate
    from trainctl.analysis.delay import DelayMargin
    from trainctl.controllers.synchronous.law import (
        LoopMatrices,
        SynchronousLaw,  # noqa: F401 (a type argument)
    )
    from trainctl.controllers.synchronous.relay import CommandRelay
    from trainctl.controllers.synchronous.settings import SynchronousSettings
    from trainctl.design import DesignModel
    from trainctl.models.network.schema import NetworkSettings
    from trainctl.scenario import Scenario

__all__ = ["CHECK_NAMES", "DELAY_SEARCH", "FAMILY", "STRATEGIES", "SynchronousDesign",
           "SynchronousFamily", "design_synchronous"]

STRATEGIES = ("synchronous",)
"""The synchronous family's one strategy."""

CHECK_NAMES = ("synchronous_closed_loop", "synchronous_sampling", "synchronous_delay_margin")
"""The synchronous family's design checks (:mod:`trainctl.controllers.synchronous.checks`)."""

DELAY_SEARCH = 60.0
"""Shortest delay range [s] searched for the margin: (0, max(10 s, 2 × the worst case)].

Five times GSM-R's 2 s worst case (spec §4.4), so that a margin above the
worst case is located rather than only bounded."""

Array = NDArray[np.float64]

PARTIAL = """\
<p>Centralised synchronous operation: the lead locomotive (vehicle {{ data.lead_number }})
closes a speed loop and relays its specific-force command over the radio link; every remote
applies it scaled by its mass, holding the last command while nothing arrives, and every
vehicle adds its own resistance at its speed. Sampled every {{ data.control_interval }} s{%
if not data.input_bounds %} (no saturation){% endif %}.</p>
""" + QUANTITIES_TABLE


@dataclass(frozen=True, kw_only=True, eq=False)
class SynchronousDesign(SampledDesign["SynchronousSettings", "SynchronousLaw"]):
    """The synchronous family's design of one scenario.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    model : DesignModel
        The run's design model.
    settings : SynchronousSettings
        The family's settings.
    law : SynchronousLaw
        The law's SI gains.
    control_interval : float
        T_c [s].
    loops : LoopMatrices
        Open loop, undelayed and relayed parts, delay-free closed loop.
    network : NetworkSettings or None
        The scenario's ``[network]`` (None: an instantaneous relay).

    Examples
    --------
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = FAMILY.design(scenario, build_model(scenario), SynchronousSettings())
    >>> design.law.lead, design.control_interval, design.network is None  # lead 0, T_c [s]
    (0, 0.1, True)
    >>> design.loops.K_relay.shape  # three remotes follow the lead
    (3, 7)
    """

    network: NetworkSettings | None
    loops: LoopMatrices

    @property
    def worst_delay(self) -> float | None:
        """The ``[network]`` worst-case delay [s] (upper end of the range); None without one."""
        return network_worst_delay(self.network)

    @property
    def worst_delay_sampled(self) -> float | None:
        """:attr:`worst_delay` rounded up to whole control intervals [s] (when it is applied)."""
        worst = self.worst_delay
        if worst is None:
            return None
        T = self.control_interval
        return math.ceil(worst / T - 1e-9) * T

    @cached_property
    def delay(self) -> DelayMargin:
        """The relay's delay margin (:func:`trainctl.analysis.delay.delay_margin`)."""
        from trainctl.analysis.delay import delay_margin

        worst = self.worst_delay or 0.0
        loops = self.loops
        return delay_margin(loops.A0, loops.B_relay, loops.K_relay,
                            tau_max=max(DELAY_SEARCH, 2.0 * worst))

    def _feedback(self) -> Array:
        """The delay-free law's gain at the model's speed."""
        return self.law.feedback(float(self.model.settings.speed))

    def make_relay(self, network: NetworkSettings | None | Literal["design"] = "design",
                   seed: int | None = None) -> CommandRelay:
        """A new relay, seeded ``[seed, RELAY_STREAM]``.

        The ``[network]``'s delays, losses and outages apply; its noise keys
        are for the speeds the networked families send, so the command
        carries ``command_noise_std_m_s2`` instead (0 by default: a digital
        command).

        Parameters
        ----------
        network : NetworkSettings or None or "design"
            The network settings; ``"design"`` (default): the design
            scenario's ``[network]``; None: an instantaneous relay.
        seed : int or None
            The run's seed; None: the design scenario's.

        Returns
        -------
        CommandRelay
            The relay from the law's lead to its remotes, with the network's
            delays, losses and outages and the settings' command noise
            [m/s²].
        """
        from trainctl.controllers.synchronous.relay import (
            RELAY_STREAM,
            CommandRelay,
            relay_settings,
        )

        settings = self.network if network == "design" else network
        run_seed = int(self.scenario.seed) if seed is None else int(seed)
        return CommandRelay(relay_settings(settings, float(self.settings.command_noise)),
                            self.law.n, self.law.lead,
                            seed=np.random.SeedSequence([run_seed, RELAY_STREAM]))


def design_synchronous(scenario: Scenario, model: DesignModel,
                       settings: SynchronousSettings) -> SynchronousDesign:
    """The law's gains and its linear loops.

    Parameters
    ----------
    scenario : Scenario
        The scenario (train, ``[network]``, ``[simulation]``).
    model : DesignModel
        Its design model.
    settings : SynchronousSettings
        The family's settings.

    Returns
    -------
    SynchronousDesign
        The design.

    Raises
    ------
    ScenarioError
        If the simulation's duration is not a whole multiple of the control
        interval, or the train cannot carry the law
        (:func:`~trainctl.controllers.synchronous.law.law_of`).

    Examples
    --------
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> d = design_synchronous(scenario, build_model(scenario), SynchronousSettings())
    >>> d.loops.A_cl.shape, d.control_interval, d.worst_delay
    ((7, 7), 0.1, None)
    """
    from trainctl.controllers.continuous.sampled import control_interval
    from trainctl.controllers.synchronous.law import closed_loop_matrices, law_of

    T = control_interval(scenario, model, settings, "synchronous")
    law = law_of(scenario, settings)
    return SynchronousDesign(scenario=scenario, model=model, settings=settings, law=law,
                             control_interval=T, network=scenario.network,
                             loops=closed_loop_matrices(model, law))


class SynchronousFamily(ContinuousFamily[SynchronousDesign, "SynchronousSettings"]):
    """Centralised synchronous operation (the LOCOTROL-type baseline of seed 003).

    Examples
    --------
    >>> from trainctl.controllers.synchronous.settings import SynchronousSettings
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("heavy-haul-hinf")
    >>> design = FAMILY.design(scenario, build_model(scenario), SynchronousSettings())
    >>> FAMILY.name, FAMILY.strategies
    ('synchronous', ('synchronous',))
    >>> FAMILY.make(design, "synchronous").dt  # the control interval [s]
    0.1
    """

    name = "synchronous"
    batches_repetitions = True
    """Its laws run batched (the repetitions of a strategy as one batch)."""
    title = "Synchronous operation (centralised)"
    strategies = STRATEGIES
    check_names = CHECK_NAMES
    report_partial = PARTIAL
    settings_path = "trainctl.controllers.synchronous.settings:SynchronousSettings"
    checks_path = "trainctl.controllers.synchronous.checks:synchronous_checks"
    controller_path = "trainctl.controllers.synchronous.controller:SynchronousController"
    _design = staticmethod(design_synchronous)

    def _controller_options(self, design: SynchronousDesign) -> dict[str, Any]:
        """Its own relay over the design's ``[network]``, and the relay factory of each run."""
        return {"relay": design.make_relay(), "relay_factory": design.make_relay}

    def report_data(self, design: SynchronousDesign) -> dict[str, Any]:
        """κ, the lead, the control interval, the delay margin against the network's worst case.

        The delay-free loop's spectrum, sampled at the model's sample time,
        joins the eigenvalue map (``spectra``).

        Parameters
        ----------
        design : SynchronousDesign
            The family's design.

        Returns
        -------
        dict
            JSON-safe: ``spectra`` (the delay-free loop's eigenvalues mapped
            to z = exp(λ T_s), as [re, im] pairs), ``rows`` (name/value rows
            of the table), ``lead_number`` (1-based), ``control_interval``
            [s] (as text), ``input_bounds`` and ``delay`` (the delay margin,
            :meth:`~trainctl.analysis.delay.DelayMargin.to_dict`).
        """
        from trainctl.controllers.continuous.loops import report_spectrum

        points, modes = report_spectrum(design.loops.A_cl, design.model.settings.sample_time)
        s, res = design.settings, design.delay
        rows = [("Speed gain κ [1/s]", f"{s.speed_gain:g}"),
                ("Lead locomotive", f"vehicle {design.law.lead + 1}"),
                ("Control interval [s]", f"{design.control_interval:g}"),
                ("Delay margin [s]", _seconds(res.margin)),
                ("Network worst-case delay [s]", _seconds(design.worst_delay)), *modes]
        return {"spectra": {"synchronous": points},
                "rows": [{"name": a, "value": b} for a, b in rows],
                "lead_number": design.law.lead + 1,
                "control_interval": f"{design.control_interval:g}",
                "input_bounds": bool(s.input_bounds), "delay": res.to_dict()}

    def certificates(self) -> tuple[Certificate, ...]:
        """The delay margin of synchronous operation against the simulated loop.

        Returns
        -------
        tuple of Certificate
            ``synchronous_delay_margin`` against divergence (else tracking).
        """
        from trainctl.analysis.certificates import NOT_DIVERGED, TRACKING, Certificate

        return (Certificate(
            "synchronous_delay_margin", ("synchronous", "synchronous.synchronous"),
            (NOT_DIVERGED, TRACKING),
            "synchronous operation keeps stability up to the network's largest delay"),)


FAMILY = SynchronousFamily()
"""The registry entry of the synchronous family."""
