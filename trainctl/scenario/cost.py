# The [cost] table: declared prices that turn a run's energy and time into an operating cost.
"""Settings of the ``[cost]`` table: prices of energy and of train-hours.

A run's operating cost (:func:`trainctl.sim.energy.operating_cost`) is the
energy drawn, net of regeneration, at the price of a kWh (divided by the
drive's efficiency from the supply to the wheel), plus the run's duration in
hours times the price of a train-hour times the number of trains (a virtually
coupled formation counts each unit train: each has its crew and its
locomotives). Prices are in ``currency``, a label only.
"""

from __future__ import annotations

from typing import Annotated

from trainctl.declare.constraints import Number, Text
from trainctl.declare.keys import Key, settings

__all__ = ["CostSettings"]


@settings
class CostSettings:
    """Prices of a run's energy and time, for its operating cost.

    Parameters
    ----------
    energy_price : float
        Price of one kWh drawn from the supply [currency/kWh], >= 0.
    train_hour_price : float
        Price of one train running one hour (crew, rolling stock, path)
        [currency/h], >= 0.
    drive_efficiency : float
        Supply-to-wheel efficiency of traction [-], in (0, 1]: the supply
        gives the wheel's net energy divided by it.
    currency : str
        The prices' currency, a label.

    Examples
    --------
    >>> cost = CostSettings(energy_price=0.12, train_hour_price=450.0)
    >>> cost.currency, cost.drive_efficiency
    ('EUR', 1.0)
    """

    energy_price: Annotated[float, Number(ge=0), Key(
        "Price of one kWh drawn from the supply", unit="currency/kWh")] = 0.0
    train_hour_price: Annotated[float, Number(ge=0), Key(
        "Price of one train running one hour (crew, rolling stock, path)",
        unit="currency/h")] = 0.0
    drive_efficiency: Annotated[float, Number(gt=0, le=1), Key(
        "Supply-to-wheel efficiency of traction: the supply gives the net energy at the "
        "wheels divided by it")] = 1.0
    currency: Annotated[str, Text(nonblank=True, single_line=True), Key(
        "Currency of the prices, a label")] = "EUR"
