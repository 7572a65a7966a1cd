# The report's figure of seed 003's case (d): ‖s(t)‖₂ against ‖w(t)‖₂ and their energy ratio.
"""The H∞ performance-index figure of a run of the hinf family over a noisy network.

Seed 003's case (d) plots the size of the performance output against the
size of the disturbance. The figure shows, for the run of the ``hinf``
strategy, the instantaneous norms ‖s̃(t)‖₂ (speed errors over
``output_scale_m_s``) and ‖w̃(t)‖₂ (the noise of the values the law held,
over ``noise_scale_m_s``), and below them the ratio of their energies from
0 to t, √(∫‖s̃‖² / ∫‖w̃‖²), against the certified γ and 1
(:func:`trainctl.controllers.hinf.claims.performance_energies`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from trainctl.plots._common import fixed_margins, legend_outside, series_style

if TYPE_CHECKING:
    from trainctl.plots.svg import ReportFigure
    from trainctl.report.data import ReportData

__all__ = ["performance_figure"]


def performance_figure(data: ReportData,
                       make: Callable[..., ReportFigure]) -> ReportFigure | None:
    """The case-(d) figure, or None (no hinf run over a noisy network, no claim).

    Parameters
    ----------
    data : ReportData
        The report's data (its ``performance_index`` claim, the hinf run, the
        family's certified γ).
    make : callable
        :func:`trainctl.report.figures.encode`.

    Returns
    -------
    ReportFigure or None

    Examples
    --------
    The CRH2 scenario has no hinf family, so no case-(d) figure:

    >>> import trainctl
    >>> from trainctl.run.analysis import run_scenario
    >>> from trainctl.scenario import read_scenario_text
    >>> text, _ = read_scenario_text("crh2-dmpc")
    >>> from trainctl.report import collect_report_data
    >>> run = run_scenario(trainctl.load_scenario("crh2-dmpc"), simulate=False)
    >>> data = collect_report_data(run, scenario_text=text)
    >>> from trainctl.plots.svg import encode
    >>> performance_figure(data, encode) is None
    True
    """
    from trainctl.controllers.hinf.claims import family_strategy, performance_energies

    claims = {c.get("key"): c for c in data.results.get("claims", [])}
    strategy = family_strategy(data.scenario, data.simulations, "hinf")
    settings = data.scenario.controllers.get("hinf")
    if "performance_index" not in claims or strategy is None or settings is None:
        return None
    result = data.simulations[strategy]
    energies = performance_energies(result, settings)
    if energies is None:
        return None
    s2, w2 = energies
    t = result.time[1:]
    e = result.velocities[:, 1:] - result.reference_speed[None, 1:]
    if settings.performance == "disagreement":
        e = e - e.mean(axis=0, keepdims=True)
    s_now = np.sqrt(np.sum(e * e, axis=0)) / settings.output_scale
    w_now = np.sqrt(result.held_noise_square) / settings.noise_scale
    gamma = float(data.families.get("hinf", {}).get("gamma", {}).get("gamma", np.nan))
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(np.where(w2 > 0, s2 / w2, np.nan))

    figure = Figure(figsize=(7.5, 4.8))
    top, bottom = figure.subplots(2, 1, sharex=True)
    w_style, s_style = series_style(1), series_style(0)
    top.plot(t, w_now, linewidth=0.6, **w_style)
    top.plot(t, s_now, linewidth=0.9, **s_style)
    top.set_yscale("log")
    top.set_ylabel("norm [-]")
    bottom.plot(t, ratio, linewidth=1.2, **s_style)
    handles = [Line2D([], [], linewidth=0.9, label="‖s̃(t)‖₂ speed errors", **s_style),
               Line2D([], [], linewidth=0.6, label="‖w̃(t)‖₂ noise held", **w_style),
               Line2D([], [], color="black", linestyle="--", label="certified γ"),
               Line2D([], [], color="0.5", linestyle=":", label="γ = 1 (paper)")]
    if np.isfinite(gamma):
        bottom.axhline(gamma, color="black", linestyle="--", linewidth=1.0)
    bottom.axhline(1.0, color="0.5", linestyle=":", linewidth=1.0)
    bottom.set_yscale("log")
    bottom.set_ylabel("√(∫‖s̃‖² / ∫‖w̃‖²) [-]")
    bottom.set_xlabel("time [s]")
    for ax in (top, bottom):
        ax.tick_params(labelsize="small")
    legend_outside(figure, handles)
    fixed_margins(figure, hspace=0.15)
    caption = (f"Run of {strategy}. Top: the size of the performance output s̃ (speed errors "
               f"over {settings.output_scale:g} m/s) and of the disturbance w̃ (the link and "
               f"reference noise the law held, over {settings.noise_scale:g} m/s) at each "
               "sample. Bottom: the ratio of their energies from 0 to t, which the H∞ "
               "performance index bounds by γ for any disturbance; white noise spreads its "
               "energy over all frequencies, so the ratio stays far below the certificate "
               "(dashed) and the paper's γ = 1 (dotted).")
    return make("performance-index", "H∞ performance index: ‖s̃(t)‖₂ against ‖w̃(t)‖₂",
                caption, figure)
