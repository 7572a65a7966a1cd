# The simulated plant: re-exported from trainctl.models.plant.
"""The nonlinear train as a plant: :class:`trainctl.models.Plant`.

The integrator lives in :mod:`trainctl.models.plant`, where the controllers'
observers can use it too; ``trainctl.sim.Plant`` and this module keep
working for simulations.
"""

from trainctl.models.plant import Plant as Plant

__all__ = ["Plant"]
