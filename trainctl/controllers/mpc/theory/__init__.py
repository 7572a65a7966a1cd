# The MPC family's theory: predictions, unconstrained (D)MPC, Jacobi iterations.
"""Theory of the MPC family: prediction matrices, unconstrained (D)MPC conditions and
the convergence of the Jacobi iterations (global and local N-DMPC)."""

from __future__ import annotations

from trainctl.controllers.mpc.theory.dmpc import LOCAL_THRESHOLD_SIZE as LOCAL_THRESHOLD_SIZE
from trainctl.controllers.mpc.theory.dmpc import DMPCAnalysis as DMPCAnalysis
from trainctl.controllers.mpc.theory.dmpc import LocalDMPCAnalysis as LocalDMPCAnalysis
from trainctl.controllers.mpc.theory.dmpc import analyse_dmpc as analyse_dmpc
from trainctl.controllers.mpc.theory.dmpc import analyse_local_dmpc as analyse_local_dmpc
from trainctl.controllers.mpc.theory.iteration import RelaxationResult as RelaxationResult
from trainctl.controllers.mpc.theory.iteration import closed_loop_matrix as closed_loop_matrix
from trainctl.controllers.mpc.theory.iteration import convergence_sweep as convergence_sweep
from trainctl.controllers.mpc.theory.iteration import cooperative_iteration as cooperative_iteration
from trainctl.controllers.mpc.theory.iteration import (
    finite_iteration_closed_loop as finite_iteration_closed_loop,
)
from trainctl.controllers.mpc.theory.iteration import iteration_matrices as iteration_matrices
from trainctl.controllers.mpc.theory.iteration import log_bisection as log_bisection
from trainctl.controllers.mpc.theory.iteration import nash_gain as nash_gain
from trainctl.controllers.mpc.theory.iteration import relaxation as relaxation
from trainctl.controllers.mpc.theory.iteration import shift_matrix as shift_matrix
from trainctl.controllers.mpc.theory.iteration import spectral_radius as spectral_radius
from trainctl.controllers.mpc.theory.iteration import threshold_weight as threshold_weight
from trainctl.controllers.mpc.theory.mpc import FORMS as FORMS
from trainctl.controllers.mpc.theory.mpc import MPCDesign as MPCDesign
from trainctl.controllers.mpc.theory.mpc import Prediction as Prediction
from trainctl.controllers.mpc.theory.mpc import prediction as prediction
from trainctl.controllers.mpc.theory.mpc import prediction_matrices as prediction_matrices

__all__ = [
    'DMPCAnalysis', 'FORMS', 'LOCAL_THRESHOLD_SIZE', 'LocalDMPCAnalysis', 'MPCDesign',
    'Prediction', 'RelaxationResult', 'analyse_dmpc', 'analyse_local_dmpc',
    'closed_loop_matrix', 'convergence_sweep', 'cooperative_iteration',
    'finite_iteration_closed_loop', 'iteration_matrices', 'log_bisection', 'nash_gain',
    'prediction', 'prediction_matrices', 'relaxation', 'shift_matrix', 'spectral_radius',
    'threshold_weight',
]
