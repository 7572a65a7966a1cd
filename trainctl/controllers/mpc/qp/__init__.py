# The MPC family's QP: one parametric problem and its fast solve paths.
"""The parametric QP of the MPC family (:mod:`~trainctl.controllers.mpc.qp.parametric`), its
fast paths (OSQP :mod:`~trainctl.controllers.mpc.qp.fast`, DAQP
:mod:`~trainctl.controllers.mpc.qp.dense`) and solver statuses
(:mod:`~trainctl.controllers.mpc.qp.status`)."""
