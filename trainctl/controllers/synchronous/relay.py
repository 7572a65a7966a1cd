# The radio relay of synchronous operation: the lead's command to every remote over the network.
"""The lead's command on its way to the remotes: a
:class:`~trainctl.models.network.Network` on a star.

Synchronous operation relays *commands*, not speeds: the lead locomotive
sends its specific-force command a_ℓ [m/s²] and every remote applies what
it last received. :class:`CommandRelay` owns a
:class:`~trainctl.models.network.Network` built on the star graph lead → every
remote (:func:`relay_graph`: remote i hears the lead, nobody hears the
reference, which the lead reads locally) with the scenario's
``[network]`` settings, so the command reaches each remote after that
link's delay, is lost with the link's loss probability, is blocked by the
outage windows that cut the link (an interruption's ``[receiver, sender]``
pairs name the relay's links ``[i, lead]``; pairs with another sender, the
reference's included, cut nothing here) and carries the settings' noise,
``communication_noise_std`` read in the command's unit, m/s² (the family
gives it its ``command_noise_std_m_s2``, 0 by default: a digital command
link is noise-free; the scenario's speed-noise keys do not apply). Between arrivals, during outages
and after losses, a remote holds the newest command it has (the network's
hold-last-value), and before its first arrival it has none.

Why not the simulation's network
--------------------------------
:func:`trainctl.run.analysis.simulate_strategy` gives controllers that declare
``uses_network`` a network on which every vehicle sends its *measured speed*
and the reference its speed (``Measurement.messages``): the medium of the
distributed consensus laws. The synchronous baseline sends none of those;
its one message per sample is the lead's command, which depends on the
lead's own measurement and has to be sent from inside the controller's
step. So the controller owns its relay (and does not declare
``uses_network``), on its own random stream
``SeedSequence([seed, RELAY_STREAM])``, apart from the measurement noise's
``default_rng(seed)`` and from the simulation network's
``SeedSequence([seed, NETWORK_STREAM])`` (:data:`trainctl.run.analysis.NETWORK_STREAM`).
Without a ``[network]`` section the relay is instantaneous and lossless
(default :class:`~trainctl.models.network.NetworkSettings`).

Timing: the relay is read at the controller's samples, so a command whose
delay is not a whole number of control intervals is applied at the first
sample after it arrives (within :data:`trainctl.models.network.ARRIVAL_TOLERANCE`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from trainctl.models.graphs import CommunicationGraph, make_graph
from trainctl.models.network.schema import NetworkSettings
from trainctl.models.network.simulator import Network

__all__ = ["RELAY_STREAM", "CommandRelay", "relay_graph", "relay_settings"]

Array = NDArray[np.float64]

RELAY_STREAM = 2
"""Spawn key of the relay's random stream: ``SeedSequence([seed, RELAY_STREAM])``.

Different from :data:`trainctl.run.analysis.NETWORK_STREAM` (1), so that the relay's
draws are not those of the simulation's speed network (a scenario may run a
networked family beside this one) nor of the measurement noise."""


def relay_settings(network: NetworkSettings | None, command_noise: float) -> NetworkSettings | None:
    """The relay's link settings: the network's delays, losses and outages, its own noise.

    Parameters
    ----------
    network : NetworkSettings or None
        A scenario's ``[network]`` (None: an instantaneous relay).
    command_noise : float
        Standard deviation of the noise on the command [m/s²], >= 0.

    Returns
    -------
    NetworkSettings or None

    Examples
    --------
    >>> relay_settings(NetworkSettings(delay_s=0.5, communication_noise_std=0.05), 0.0)
    NetworkSettings(delay_s=0.5, delay_range_s=None, loss_probability=0.0, \
communication_noise_std=0.0, reference_noise_std=None, interruptions=())
    """
    import dataclasses

    if network is None:
        return None
    return dataclasses.replace(network, communication_noise_std=float(command_noise),
                               reference_noise_std=None)


def relay_graph(n: int, lead: int) -> CommunicationGraph:
    """The star graph lead → every remote, nobody pinned to the reference.

    Parameters
    ----------
    n : int
        Vehicles [-], >= 2.
    lead : int
        The lead's index (0-based).

    Returns
    -------
    CommunicationGraph
        ``adjacency[i, lead] = 1`` for every i ≠ lead, zeros elsewhere.

    Examples
    --------
    >>> relay_graph(3, 1).adjacency.tolist()
    [[0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    """
    adjacency = np.zeros((n, n))
    adjacency[:, lead] = 1.0
    adjacency[lead, lead] = 0.0
    return make_graph("explicit", n, pinned="none", adjacency=adjacency)


class CommandRelay:
    """The lead's command over the radio links to the remotes (module docstring).

    Parameters
    ----------
    settings : NetworkSettings or None
        The scenario's ``[network]``; None: an instantaneous, lossless,
        noise-free relay.
    n : int
        Vehicles [-], >= 2.
    lead : int
        The lead's index (0-based).
    seed : int or numpy.random.SeedSequence
        The network's seed (:meth:`reset` restarts it).

    Examples
    --------
    >>> relay = CommandRelay(NetworkSettings(delay_s=0.2), 3, 0, seed=0)
    >>> relay.relay(0.0, 0.05)[0].tolist(), relay.relay(0.1, 0.04)[0].tolist()
    ([0.05, nan, nan], [0.04, nan, nan])
    >>> commands, ages = relay.relay(0.2, 0.03)
    >>> commands.tolist(), [round(a, 12) for a in ages.tolist()]
    ([0.03, 0.05, 0.05], [0.0, 0.2, 0.2])
    """

    def __init__(self, settings: NetworkSettings | None, n: int, lead: int, *,
                 seed: int | np.random.SeedSequence) -> None:
        self.settings = NetworkSettings() if settings is None else settings
        self.lead = int(lead)
        self.network = Network(self.settings, relay_graph(n, lead), seed=seed)
        self.n = int(n)

    def reset(self) -> None:
        """Forget every message and restart the random stream."""
        self.network.reset()

    def reseed(self, seed: int | np.random.SeedSequence) -> None:
        """Use another seed from now on (and restart: :meth:`reset`).

        Parameters
        ----------
        seed : int or numpy.random.SeedSequence
            The network's new seed.
        """
        self.network = Network(self.settings, self.network.graph, seed=seed)

    def relay(self, t: float, command: float) -> tuple[Array, Array]:
        """Send the lead's command at ``t`` and read what every vehicle holds then.

        Parameters
        ----------
        t : float
            Time [s], >= the previous call's.
        command : float
            The lead's command a_ℓ [m/s²], finite.

        Returns
        -------
        (commands, ages) : ndarray
            Shape (n,) each: the command every vehicle holds [m/s²] (the
            lead's own at its index, NaN for a remote that has received
            nothing yet) and its age t − t_sent [s] (0 for the lead, NaN
            where nothing was received).
        """
        self.network.send(t, self.lead, command)
        commands = np.full(self.n, math.nan)
        ages = np.full(self.n, math.nan)
        commands[self.lead], ages[self.lead] = command, 0.0
        for (receiver, _), message in self.network.messages(t).items():
            commands[receiver] = float(message.value)
            ages[receiver] = t - message.t_sent
        return commands, ages
