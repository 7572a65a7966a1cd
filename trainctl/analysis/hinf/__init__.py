# H∞ norms of linear systems: python-control (slycot ab13dd), a Hamiltonian level set, the BRL.
"""The H∞ norm of a stable LTI system, by three routes that check each other.

``‖G‖∞ = sup_ω σ̄(G(jω))`` (continuous) or ``sup_θ σ̄(G(e^{jθ}))``
(discrete) is the worst-case L2 (ℓ2) gain from the inputs to the outputs:
for a robust law, the largest amplification of a disturbance w into a
performance output s. Three ways to get it:

- :func:`control_hinf_norm`: python-control's ``linfnorm`` (slycot's
  ``ab13dd``), the reference;
- :func:`hamiltonian_hinf_norm`: this module's own level-set iteration
  (Bruinsma & Steinbuch, *Systems & Control Letters* 14, 1990; after Boyd,
  Balakrishnan & Kabamba, *Math. Control Signals Systems* 2, 1989). γ is a
  singular value of G(jω) exactly when jω is an eigenvalue of the
  Hamiltonian matrix H(γ) (formula in :func:`hamiltonian_matrix`), so with
  a lower bound γ_lb the level γ = (1 + 2ε)γ_lb either leaves H(γ) without
  imaginary eigenvalues (then ‖G‖∞ < γ: stop) or its imaginary eigenvalues
  jω₁ < … < jω_k bound the intervals where σ̄ > γ, and σ̄ at their midpoints
  is the next, larger lower bound (quadratic convergence). Discrete systems
  go through the Cayley transform z = (1 + s)/(1 − s), which maps the unit
  circle onto the imaginary axis (θ = 2 arctan ω) and leaves the norm
  unchanged: it turns the symplectic pencil of the discrete level set into
  the Hamiltonian matrix of a continuous system, so both time domains use
  the same exact test — chosen over a frequency sweep, which can step over
  the sharp coupler resonances of a train (damping ratios of 1–4 %); σ̄ is
  still evaluated on the discrete system itself, at z = e^{jθ};
- :func:`bounded_real_gamma`: the bounded-real lemma as an SDP in cvxpy,
  which certifies ‖G‖∞ ≤ γ with a matrix P ≻ 0 and is an exact
  characterisation (its infimum is the norm).

:func:`hinf_norm` returns the first two with their peak frequencies and
whether they agree to :data:`AGREEMENT`; :func:`channel_norms` the SISO norm
of every input → output channel, so that a report can show γ per
disturbance channel.

Stability. The H∞ norm is that of the state-space system: when A is not
Hurwitz (not Schur, discrete) the norm is infinite (``inf``, with the
spectral abscissa or radius in the result), even if the unstable mode is
uncontrollable or unobservable — reduce the system (``control.minreal``)
first when only the transfer function matters. (``linfnorm`` itself returns
the L∞ norm, finite for unstable systems without poles on the axis; this
module does not call it then.)

Scaling. Train models mix speeds [m/s], coupler elongations [m] and forces
[kN] (spec §5 item 7), so each route works on a state-balanced realisation
(a diagonal similarity from ``scipy.linalg.matrix_balance`` of the system
matrix [[A, B],[C, 0]] with the input and output blocks collapsed, which
leaves G unchanged), and the level set and the SDP on G divided by a crude
lower bound of its norm (so that γ ≈ 1). The SDP then goes on to the
square-root balanced realisation (equal, diagonal Gramians) where it
exists: a diagonal scaling alone leaves the SDP badly conditioned for a
non-normal A, and the solver fails or stops inaccurate. Outputs in
different units are never rescaled one against the other (that would
change the norm): :func:`channel_norms` reports each channel on its own.

Examples
--------
A first-order lag 2/(s + 4) has its peak 0.5 at DC:

>>> import control as ct
>>> res = hinf_norm(ct.tf([2.0], [1.0, 4.0]))
>>> round(res.norm, 9), round(res.hamiltonian, 9), res.agree
(0.5, 0.5, True)

The package, by job: :mod:`~trainctl.analysis.hinf.balancing` (system data and
balancing), :mod:`~trainctl.analysis.hinf.level_set` (the Hamiltonian route),
:mod:`~trainctl.analysis.hinf.norms` (the two routes compared, per channel) and
:mod:`~trainctl.analysis.hinf.bounded_real` (the bounded-real SDP).
"""

from trainctl.analysis.hinf.balancing import gramian_transform, state_balance
from trainctl.analysis.hinf.bounded_real import (
    BRL_MARGIN,
    BoundedRealProblem,
    BoundedRealResult,
    bounded_real_gamma,
    certified_level,
    parameter_terms,
    solve_quietly,
)
from trainctl.analysis.hinf.level_set import LEVEL_TOL, hamiltonian_hinf_norm, hamiltonian_matrix
from trainctl.analysis.hinf.norms import (
    AGREEMENT,
    ChannelNorms,
    HinfNorm,
    channel_norms,
    control_hinf_norm,
    hinf_norm,
)

__all__ = [
    "AGREEMENT", "BRL_MARGIN", "LEVEL_TOL", "BoundedRealProblem", "BoundedRealResult",
    "ChannelNorms", "HinfNorm", "bounded_real_gamma", "certified_level", "channel_norms",
    "control_hinf_norm", "gramian_transform", "hamiltonian_hinf_norm", "hamiltonian_matrix",
    "hinf_norm", "parameter_terms", "solve_quietly", "state_balance",
]
