# What the continuous-time law families share: base, sampled law, loops, pair potentials.
"""Shared parts of the continuous-time law families (potential, flocking, synchronous, hinf).

- :mod:`~trainctl.controllers.continuous.family`: the family and design base
  (:class:`~trainctl.controllers.continuous.family.ContinuousFamily`,
  :class:`~trainctl.controllers.continuous.family.SampledDesign`);
- :mod:`~trainctl.controllers.continuous.controller`: the full-state sampled
  law about the feedforward (potential, flocking);
- :mod:`~trainctl.controllers.continuous.loops`: the linear closed loop, its
  Hurwitz check and its report spectrum;
- :mod:`~trainctl.controllers.continuous.sampled`: the control interval, the
  initial errors, the loop held over an interval and its sampling check;
- :mod:`~trainctl.controllers.continuous.delay`: the delay margin against
  the ``[network]`` worst case, its check (synchronous, hinf);
- :mod:`~trainctl.controllers.continuous.resistance`: the resistance
  feedforward (synchronous, hinf);
- :mod:`~trainctl.controllers.continuous.potentials`: the pair potentials
  (potential, flocking).
"""
