# Plot functions returning matplotlib Axes: time and frequency domain, graphs.
"""Plot functions for notebooks and reports; each draws on an Axes and returns it."""

from __future__ import annotations

from trainctl.plots.frequency import sigma_plot as sigma_plot
from trainctl.plots.frequency import step_response_plot as step_response_plot
from trainctl.plots.frequency import string_gain_plot as string_gain_plot
from trainctl.plots.time import convergence_plot as convergence_plot
from trainctl.plots.time import coupler_force_plot as coupler_force_plot
from trainctl.plots.time import eigenvalue_plot as eigenvalue_plot
from trainctl.plots.time import graph_plot as graph_plot
from trainctl.plots.time import input_plot as input_plot
from trainctl.plots.time import iterations_plot as iterations_plot
from trainctl.plots.time import speed_error_plot as speed_error_plot
from trainctl.plots.time import velocity_plot as velocity_plot

__all__ = [
    'convergence_plot', 'coupler_force_plot', 'eigenvalue_plot', 'graph_plot', 'input_plot',
    'iterations_plot', 'sigma_plot', 'speed_error_plot', 'step_response_plot',
    'string_gain_plot', 'velocity_plot',
]
