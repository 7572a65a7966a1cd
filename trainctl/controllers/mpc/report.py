# What the report shows of the MPC family: closed-loop spectra, the ρ(D0)-against-R curve.
"""Report data, figures and section of the MPC family.

:func:`mpc_report_data` computes, from the family's design, JSON-safe data
(saved with a run and read back for re-rendering): the eigenvalues of the
unconstrained closed loops and the spectral radius of the Jacobi iteration
matrix D0 over a range of input weights. :func:`mpc_report_figures` draws the
convergence curve from that data only.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from trainctl.controllers.mpc.family import MPCFamilyDesign
    from trainctl.plots.svg import ReportFigure

__all__ = ["PARTIAL", "SWEEP_POINTS", "mpc_report_data", "mpc_report_figures"]

SWEEP_POINTS = 61
"""Weights in the ρ(D0)-against-R curve."""

PARTIAL = """\
<p>Unconstrained design: prediction horizon P = {{ data.horizons[0] }}, control horizon
M = {{ data.horizons[1] }}, {{ data.form }}-form. The N-DMPC (Jacobi) iteration converges
where ρ(D0) &lt; 1: ρ(D0) = {{ data.rho_text }} at the design weight, threshold weight
R* = {{ data.threshold_text }} {{ data.unit }}.</p>
"""
"""Jinja source of the MPC family's report section (``data`` is :func:`mpc_report_data`)."""


def mpc_report_data(design: MPCFamilyDesign) -> dict[str, Any]:
    """JSON-safe report data of the MPC family.

    Parameters
    ----------
    design : MPCFamilyDesign
        The family's design.

    Returns
    -------
    dict
        ``spectra``: label -> list of [re, im] discrete eigenvalues of the
        centralised, N-DMPC (Nash) and N-DMPC (k iterations) closed loops;
        ``weight_sweep``: ``weights`` and ``radii`` (ρ(D0)) lists,
        ``threshold`` R* (None when infinite) and ``design_weight`` R, in
        ``unit``; plus display values for the section.

    Examples
    --------
    >>> from trainctl.controllers.mpc.family import FAMILY
    >>> from trainctl.design import build_model
    >>> from trainctl.scenario import load_scenario
    >>> scenario = load_scenario("crh2-dmpc")
    >>> design = FAMILY.design(scenario, build_model(scenario), scenario.controllers["mpc"])
    >>> data = mpc_report_data(design)
    >>> data["horizons"], data["form"], data["rho_text"], data["unit"]
    ([4, 2], 'du', '0.3057', 'per kN²')
    >>> list(data["spectra"])
    ['centralised', 'N-DMPC (Nash)', 'N-DMPC (10 iterations)']
    """
    from trainctl.controllers.mpc.theory.iteration import convergence_sweep, threshold_weight

    ctl, res = design.settings, design.analysis
    k = ctl.iterations
    spectra = {
        "centralised": res.closed_loop_centralised,
        "N-DMPC (Nash)": res.closed_loop_nash,
        f"N-DMPC ({k} iteration{'s' if k != 1 else ''})": res.closed_loop_iterations,
    }
    r_design = ctl.input_weight_per_kn2()
    r_star = threshold_weight(design.mpc)
    finite = [x for x in (r_design, r_star) if math.isfinite(x) and x > 0]
    low = min(finite) / 100.0 if finite else 1e-3
    high = max(finite) * 100.0 if finite else 1e3
    weights = np.logspace(math.log10(low), math.log10(high), SWEEP_POINTS)
    radii = convergence_sweep(design.mpc, weights)
    scale = 1.0 if ctl.input_weight_unit == "kN" else 1e-6  # per kN² -> per N²
    unit = f"per {ctl.input_weight_unit}²"
    threshold = r_star * scale
    return {
        "spectra": {label: _eig(A) for label, A in spectra.items()},
        "weight_sweep": {"weights": (weights * scale).tolist(), "radii": radii.tolist(),
                         "threshold": threshold if math.isfinite(threshold) else None,
                         "design_weight": r_design * scale, "unit": unit},
        "horizons": [design.mpc.prediction_horizon, design.mpc.control_horizon],
        "form": design.mpc.form,
        "rho_text": f"{res.rho_d0:.4g}",
        "threshold_text": f"{threshold:.4g}",
        "unit": unit,
    }


def mpc_report_figures(data: Mapping[str, Any]) -> list[ReportFigure]:
    """The convergence figure (ρ(D0) against R with R* marked) from the report data.

    Parameters
    ----------
    data : mapping
        :func:`mpc_report_data`.

    Returns
    -------
    list of ReportFigure
        One figure.

    Examples
    --------
    A hand-made sweep whose radius crosses 1 between R = 1 and R = 10:

    >>> sweep = {"weights": [0.1, 1.0, 10.0], "radii": [3.0, 1.2, 0.3], "threshold": 2.0,
    ...          "design_weight": 10.0, "unit": "per kN²"}
    >>> [figure] = mpc_report_figures({"weight_sweep": sweep})
    >>> figure.key, figure.title
    ('convergence', 'N-DMPC convergence against the input weight')
    """
    from matplotlib.figure import Figure

    from trainctl.plots import time as plot
    from trainctl.plots._common import fixed_margins
    from trainctl.plots.svg import ReportFigure, figure_svg

    sweep = data["weight_sweep"]
    threshold = math.inf if sweep["threshold"] is None else sweep["threshold"]
    figure = Figure(figsize=(7.0, 3.6))
    plot.convergence_plot(np.asarray(sweep["weights"]), np.asarray(sweep["radii"]),
                          threshold=threshold, design_weight=sweep["design_weight"],
                          unit=sweep["unit"], ax=figure.add_subplot())
    fixed_margins(figure, left=0.7, right=1.6, top=0.3)  # title above, legend right
    return [ReportFigure("convergence", "N-DMPC convergence against the input weight",
                         f"Spectral radius of the Jacobi iteration matrix D0 against a common "
                         f"input weight R [{sweep['unit']}]; the iteration converges where "
                         "ρ(D0) < 1, i.e. for R above R*.",
                         figure_svg(figure, prefix="fig-convergence"))]


def _eig(matrix: np.ndarray) -> list[list[float]]:
    values = np.linalg.eigvals(matrix).astype(complex)
    # A fixed order (by angle, then modulus) keeps saved files and figures stable.
    order = np.lexsort((np.round(np.abs(values), 12), np.round(np.angle(values), 12)))
    return [[float(z.real), float(z.imag)] for z in values[order]]
