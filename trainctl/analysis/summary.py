# Model summary of a scenario: what `trainctl analyse` prints.
"""A model summary of a scenario: vehicles, signals, equilibrium, modes, sampling."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from trainctl.analysis.modes import Mode, continuous_modes, nyquist_sample_time
from trainctl.models.dynamics import Equilibrium

if TYPE_CHECKING:
    from trainctl.design import DesignModel
    from trainctl.scenario import Scenario

__all__ = ["ModelSummary", "model_summary"]


@dataclass(frozen=True, kw_only=True)
class ModelSummary:
    """What a scenario's model looks like before any controller is designed.

    Parameters
    ----------
    scenario_name : str
        Display name of the scenario.
    train_name : str
        Name of the train.
    vehicles : tuple of dict
        Per vehicle: ``name``, ``mass`` [kg], ``length`` [m], ``traction_share``.
    state_labels, input_labels, output_labels : tuple of str
        Signal names of the linear model.
    speed : float
        Linearisation (cruise) speed [m/s].
    linearisation : str
        ``"jacobian"`` or ``"book"``.
    equilibrium : Equilibrium
        Cruise equilibrium (inputs, static coupler forces).
    modes : tuple of Mode
        Continuous-time modes.
    sample_time : float
        The scenario's sample time T [s].
    nyquist_sample_time : float
        Largest T that resolves the coupler modes, π/ω_max [s].
    discrete_spectral_radius : float
        Largest |eigenvalue| of the discretised model [-].
    failed_checks : tuple of str
        Names of failed design checks (none at this level).

    Examples
    --------
    The CRH2 half train (T-M-M-T) at 300 km/h, sampled at 0.05 s, below the
    limit π/ω_max = 0.113 s:

    >>> from trainctl.scenario import load_scenario
    >>> s = model_summary(load_scenario("crh2-dmpc-well-sampled"))
    >>> s.train_name, round(s.speed * 3.6, 1), s.sample_time, s.resolves_couplers  # km/h, s
    ('T-M-M-T', 300.0, 0.05, True)
    >>> s.vehicles[0]  # [kg], [m]
    {'name': 'T', 'mass': 42800.0, 'length': 25.0, 'traction_share': 0.0}
    >>> [m.kind for m in s.modes]
    ['dummy', 'rigid-body', 'coupler', 'coupler', 'coupler']
    """

    scenario_name: str
    train_name: str
    vehicles: tuple[dict[str, str | float], ...]
    state_labels: tuple[str, ...]
    input_labels: tuple[str, ...]
    output_labels: tuple[str, ...]
    speed: float
    linearisation: str
    equilibrium: Equilibrium
    modes: tuple[Mode, ...]
    sample_time: float
    nyquist_sample_time: float
    discrete_spectral_radius: float
    failed_checks: tuple[str, ...] = field(default=())

    @property
    def resolves_couplers(self) -> bool:
        """True when T < π/ω_max (the coupler modes are not aliased)."""
        return self.sample_time < self.nyquist_sample_time

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dict of the summary (SI units, inf as None).

        Returns
        -------
        dict
            ``scenario``, ``train``, the counts and copies of ``vehicles``,
            ``states``, ``inputs`` and ``outputs``, ``speed`` [m/s] and
            ``speed_kmh`` [km/h], ``linearisation``, ``equilibrium``
            (``inputs`` and ``coupler_forces`` [N], ``elongations`` [m],
            ``traction_limit`` and ``braking_limit`` [N], ``feasible``),
            ``modes`` (each :meth:`Mode.to_dict
            <trainctl.analysis.modes.Mode.to_dict>`), ``sampling``
            (``sample_time`` and ``nyquist_sample_time`` [s],
            ``resolves_couplers``, ``omega_max_times_T`` [rad],
            ``discrete_spectral_radius`` [-]) and ``failed_checks``.
        """
        eq = self.equilibrium
        nyq = None if math.isinf(self.nyquist_sample_time) else self.nyquist_sample_time
        return {
            "scenario": self.scenario_name,
            "train": self.train_name,
            "n_vehicles": len(self.vehicles),
            "vehicles": [dict(v) for v in self.vehicles],
            "n_states": len(self.state_labels),
            "n_inputs": len(self.input_labels),
            "n_outputs": len(self.output_labels),
            "states": list(self.state_labels),
            "inputs": list(self.input_labels),
            "outputs": list(self.output_labels),
            "speed": self.speed,
            "speed_kmh": self.speed * 3.6,
            "linearisation": self.linearisation,
            "equilibrium": {
                "inputs": eq.inputs.tolist(),
                "coupler_forces": eq.coupler_forces.tolist(),
                "elongations": eq.elongations.tolist(),
                "traction_limit": [
                    None if math.isinf(x) else x for x in eq.traction_limit.tolist()
                ],
                "braking_limit": None if eq.braking_limit is None else [
                    None if math.isinf(x) else x for x in eq.braking_limit.tolist()
                ],
                "feasible": eq.feasible,
            },
            "modes": [m.to_dict() for m in self.modes],
            "sampling": {
                "sample_time": self.sample_time,
                "nyquist_sample_time": nyq,
                "resolves_couplers": self.resolves_couplers,
                "omega_max_times_T": None if nyq is None else math.pi * self.sample_time / nyq,
                "discrete_spectral_radius": self.discrete_spectral_radius,
            },
            "failed_checks": list(self.failed_checks),
        }

    def format_text(self) -> str:
        """Human-readable multi-line summary (what ``trainctl analyse`` prints).

        Returns
        -------
        str
            Scenario, train and model lines, a vehicle table (masses [t],
            equilibrium inputs [kN]; a long train shortened), the static
            coupler forces [kN], the cruise feasibility, the continuous
            modes and the sampling; lines joined by newlines.
        """
        return "\n".join(_text_lines(self))


def model_summary(scenario: Scenario, model: DesignModel | None = None) -> ModelSummary:
    """Summarise a scenario's train model.

    Parameters
    ----------
    scenario : Scenario
        A loaded scenario (:func:`trainctl.scenario.load_scenario`).
    model : DesignModel or None
        The run's design model (:func:`trainctl.design.build_model`); built
        here when None.

    Returns
    -------
    ModelSummary
        Vehicles, signals, cruise equilibrium, continuous modes and sampling.

    Examples
    --------
    >>> from trainctl.scenario import load_scenario
    >>> summary = model_summary(load_scenario("crh2-dmpc"))
    >>> summary.resolves_couplers, round(summary.nyquist_sample_time, 3)
    (False, 0.113)
    """
    if model is None:
        from trainctl.design import build_model

        model = build_model(scenario)
    train, cfg = scenario.train, scenario.model
    sys = model.speed_model()
    modes = continuous_modes(sys, n_vehicles=train.n_vehicles)
    radius = float(np.max(np.abs(np.linalg.eigvals(model.discrete.A))))
    if model.has_dummy:  # the dummy state is decoupled with eigenvalue 0: e^(0·T) = 1
        radius = max(radius, 1.0)
    eq = model.equilibrium
    vehicles: tuple[dict[str, str | float], ...] = tuple(
        {"name": v.name, "mass": v.mass, "length": v.length, "traction_share": v.traction_share}
        for v in train.vehicles
    )
    return ModelSummary(
        scenario_name=scenario.name,
        train_name=train.name,
        vehicles=vehicles,
        state_labels=tuple(sys.state_labels),
        input_labels=tuple(sys.input_labels),
        output_labels=tuple(sys.output_labels),
        speed=cfg.speed,
        linearisation=cfg.linearisation,
        equilibrium=eq,
        modes=modes,
        sample_time=cfg.sample_time,
        nyquist_sample_time=nyquist_sample_time(modes),
        discrete_spectral_radius=radius,
    )


_MODES_SHOWN = 24
"""Rows of the text summary's mode table; a longer list shows its first and last halves."""


def _text_lines(s: ModelSummary) -> list[str]:
    eq = s.equilibrium
    lines = [
        f"Scenario: {s.scenario_name}",
        f"Train:    {s.train_name}; {len(s.vehicles)} vehicles, "
        f"{sum(float(v['mass']) for v in s.vehicles) / 1e3:.1f} t",
        f"Model:    {len(s.state_labels)} states, {len(s.input_labels)} inputs [N], "
        f"{len(s.output_labels)} outputs; linearised ({s.linearisation}) at "
        f"{s.speed * 3.6:.1f} km/h ({s.speed:.3f} m/s)",
        "",
        "Vehicles:",
        f"  {'i':>3}  {'name':<14}{'mass [t]':>10}{'share':>8}{'u_eq [kN]':>11}",
    ]
    shown = list(enumerate(s.vehicles))
    if len(shown) > 12:
        shown = shown[:6] + [(-1, {})] + shown[-6:]
    for i, v in shown:
        if i < 0:
            lines.append(f"  {'...':>3}")
            continue
        lines.append(f"  {i:>3}  {str(v['name']):<14}{float(v['mass']) / 1e3:>10.1f}"
                     f"{float(v['traction_share']):>8.2f}{eq.inputs[i] / 1e3:>11.3f}")
    if eq.coupler_forces.size:
        fmax = float(np.max(np.abs(eq.coupler_forces)))
        forces = ", ".join(f"{f / 1e3:.3f}" for f in eq.coupler_forces[:8])
        more = ", ..." if eq.coupler_forces.size > 8 else ""
        lines.append(f"Static coupler forces [kN], tension positive: {forces}{more} "
                     f"(max |f| = {fmax / 1e3:.3f} kN)")
    lines.append(
        "Cruise force within every vehicle's traction and braking envelope (at the model speed, "
        f"head at 0 m): {'yes' if eq.feasible else 'NO'}; along the route: see the check "
        "'feasibility'"
    )
    lines += ["", "Modes (continuous):",
              f"  {'kind':<12}{'Re [1/s]':>12}{'Im [rad/s]':>12}{'wn [rad/s]':>12}{'zeta':>10}"]
    modes: list[Mode | None] = list(s.modes)
    if len(modes) > _MODES_SHOWN:  # a long train: the slowest and the fastest modes
        half = _MODES_SHOWN // 2
        modes = modes[:half] + [None] + modes[-half:]
    for m in modes:
        if m is None:
            lines.append(f"  ... {len(s.modes) - 2 * half} more modes (analyse --json lists "
                         "every mode)")
            continue
        zeta = "-" if math.isnan(m.damping_ratio) else f"{m.damping_ratio:.2e}"
        lines.append(f"  {m.kind:<12}{m.eigenvalue.real:>12.4e}{m.eigenvalue.imag:>12.4f}"
                     f"{m.natural_frequency:>12.4f}{zeta:>10}")
    lines += ["", "Sampling:"]
    if math.isinf(s.nyquist_sample_time):
        lines.append(f"  T = {s.sample_time:g} s; no coupler modes to resolve.")
    else:
        verdict = "resolves" if s.resolves_couplers else "ALIASES"
        lines.append(f"  T = {s.sample_time:g} s vs largest T resolving the coupler modes "
                     f"pi/w_max = {s.nyquist_sample_time:.4f} s: {verdict} the coupler modes "
                     f"(w_max*T = {math.pi * s.sample_time / s.nyquist_sample_time:.3g} rad vs pi)")
    lines.append(f"  discrete spectral radius at T: {s.discrete_spectral_radius:.6f}")
    return lines
