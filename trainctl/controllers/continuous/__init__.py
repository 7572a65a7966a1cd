# What the continuous-time law families share: the sampled law, pair potentials.
"""Shared parts of the continuous-time law families (potential, flocking, synchronous,
hinf): the sampled law and its checks (:mod:`~trainctl.controllers.continuous.sampled`)
and the pair potentials (:mod:`~trainctl.controllers.continuous.potentials`)."""
