# The radio network between the vehicles: delays, losses, outages and noise, message by message.
"""A discrete-event model of the network over which vehicles exchange data.

Cooperative controllers (the H∞ cooperative law of seed 003 over GSM-R, the
consensus laws of seeds 001 and 002) do not see their neighbours' speeds
directly: each value travels over a radio link that delays it, may lose it,
is cut during outages and adds noise. :class:`Network` models that medium
and nothing else — no plant, no controller — so it can be used alone, in a
test, in a notebook or, later, inside the simulation loop
(:mod:`trainctl.sim`). It lives at the top level of the package, beside
:mod:`trainctl.models.graphs` whose :class:`~trainctl.models.graphs.CommunicationGraph`
says who hears whom, rather than in :mod:`trainctl.sim`, because it depends
on neither the plant nor the loop; the loop will depend on it.

Nodes and numbering
-------------------
Vehicles are numbered from 0, head first, as in
:class:`~trainctl.models.graphs.CommunicationGraph`, in the state arrays and in
the scenario files (the ``[controller]`` ``neighbourhood`` key); text meant
for a person numbers them from 1 (:mod:`trainctl.naming`). The reference
(the speed command, the virtual leader) is a sender too, named
:data:`REFERENCE` (``"reference"``), as in the graph's networkx form; it is
never a receiver. A link is a pair ``(receiver, sender)``: receiver i hears
sender j when ``graph.adjacency[i, j] > 0``, and hears the reference when
``graph.pinning[i] > 0``. The weights themselves are the controller's
business; the network only uses which links exist.

What happens to one message
---------------------------
``send(t, sender, value)`` broadcasts ``value`` at time t [s] on every link
from ``sender``: one message per receiver, which draws, at send time,

- its delay: ``delay_s`` (constant), or uniform in ``delay_range_s = [lo,
  hi]``, independently per message; it arrives at ``t + delay``;
- its loss: lost with probability ``loss_probability``;
- its noise: the receiver gets ``value + std · z`` with z standard normal
  per component, std = ``communication_noise_std`` (``reference_noise_std``
  for the reference, when given).

Interruptions (outage windows ``[start, end)`` on some links or all) block
a link: a message is *blocked* when the link is down at any moment of its
transit, i.e. when ``t_sent < end`` and ``t_arrival >= start``. So nothing
sent during a window is delivered, and nothing arrives during it: a
receiver's data from a blocked link stay frozen over the whole window. A
blocked message is not also counted as lost.

The random stream, in a fixed order
-----------------------------------
The generator is ``numpy.random.default_rng(seed)``, drawn only by
:meth:`Network.send`. A send to k receivers (the vehicles that hear the
sender, increasing index; k = 0 draws nothing) makes exactly two calls,
whatever the settings (as the simulation draws its measurement noise):

1. ``u = rng.random((k, 2))``: ``delay = lo + (hi - lo) · u[:, 0]``
   (lo = hi for a constant delay) and lost when ``u[:, 1] < loss_probability``;
2. ``z = rng.standard_normal((k, *shape))`` with ``shape`` the value's shape.

:meth:`Network.send_all` sends the reference first (when given), then
vehicles 0 .. n-1. The same seed and the same calls give the same history,
message for message; a blocked or lost message consumes its draws too, so
changing a window or the loss rate does not shift the other draws.

Receiving: hold the last value
------------------------------
``receive(t, receiver)`` gives, for every sender the receiver hears, the
newest message that has arrived by t (within :data:`ARRIVAL_TOLERANCE`) as
``Received(t_sent, value)``: the time stamp lets a controller know the age
of its data. "Newest" is by send time: with random delays messages can
arrive out of order, and an older message arriving late never replaces a
newer one. When nothing new arrived (an outage, a loss, a long delay), the
last delivered message is held. A sender from which nothing has arrived yet
is absent from the mapping. Time only moves forward: every ``send`` and
``receive`` must be at a time >= the previous call's.

Examples
--------
>>> from trainctl.models.graphs import make_graph
>>> settings = NetworkSettings(delay_s=0.5)
>>> net = Network(settings, make_graph("predecessor", 3, pinned="head"), seed=1)
>>> net.links
((0, 'reference'), (1, 0), (2, 1))
>>> net.send_all(0.0, [20.0, 21.0, 22.0], reference=20.5)
>>> net.receive(0.4, 1)
{}
>>> net.receive(0.5, 1)
{0: Received(t_sent=0.0, value=20.0)}
>>> net.messages(1.0)[(0, "reference")].value
20.5
>>> log = net.history()
>>> len(log), log.t_arrival.tolist()
(3, [0.5, 0.5, 0.5])

The package, by job: :mod:`~trainctl.models.network.schema` (the settings and their
rules) and :mod:`~trainctl.models.network.simulator` (the discrete-event simulator).
"""

from trainctl.models.graphs import REFERENCE
from trainctl.models.network.schema import Interruption, NetworkSettings
from trainctl.models.network.simulator import (
    ARRIVAL_TOLERANCE,
    FATES,
    MessageLog,
    Network,
    Received,
)

__all__ = [
    "ARRIVAL_TOLERANCE",
    "FATES",
    "REFERENCE",
    "Interruption",
    "MessageLog",
    "Network",
    "NetworkSettings",
    "Received",
]
