# Delay-dependent LMI certificates (Lyapunov–Krasovskii with Jensen's inequality) in cvxpy.
"""Certified delay bounds for ẋ = A x(t) + A_d x(t − τ) (+ B_w w, s = Cx + Dw).

:mod:`trainctl.analysis.delay` finds where the loop loses stability (Padé,
the *exact-ish* margin). This module gives *certificates*: a
Lyapunov–Krasovskii functional

    V = xᵀPx + ∫_{t−τ}^{t} xᵀQx ds + h ∫_{−h}^{0} ∫_{t+θ}^{t} ẋᵀRẋ ds dθ,   h = τ_max,

whose derivative is negative along every solution when one LMI in
(P, Q, R) holds. With Jensen's inequality, for τ ∈ (0, h],
h ∫_{t−h}^{t} ẋᵀRẋ ≥ h ∫_{t−τ}^{t} ẋᵀRẋ ≥ (h/τ)|x − x_τ|²_R ≥ |x − x_τ|²_R,
so, with ξ = (x, x_τ) and ẋ = A x + A_d x_τ,

    V̇ ≤ ξᵀ( [[PA + AᵀP + Q − R, PA_d + R], [A_dᵀP + R, −Q − R]]
           + h² [A, A_d]ᵀ R [A, A_d] ) ξ,

and, by a Schur complement, V̇ < 0 when

    Ξ(h) = [[PA + AᵀP + Q − R, PA_d + R, h AᵀR],
            [A_dᵀP + R, −Q − R, h A_dᵀR],
            [h RA, h RA_d, −R]] ≺ 0,   P ≻ 0, Q ⪰ 0, R ≻ 0.

What it certifies:

- ``delay="constant"``: asymptotic stability for every *constant* delay
  τ ∈ [0, h] (τ = 0 too: [I, I] Ξ [I; I] ≺ 0 makes A + A_d Hurwitz);
- ``delay="varying"``: Q = 0, which removes the only term that needed τ
  constant (d/dt ∫_{t−τ(t)}^{t} xᵀQx contains (1 − τ̇)); the certificate
  then holds for any time-varying delay τ(t) ∈ [0, h], however fast it
  varies (the random GSM-R delays of seed 003). More conservative.

The condition is sufficient only (Jensen's inequality loses a factor: for
ẋ = −a x(t − τ) the exact bound is π/(2a) and this LMI certifies √2/a
for constant delays, 90 % of it, and 1/a for varying ones, see
:func:`max_certified_delay`), so a certified h is always below
the true margin; it is never above it.

:func:`max_certified_delay` bisects on h. h enters Ξ only as h·R A and
h·R A_d (a parameter times a variable), which is DPP, so one cvxpy problem
with h as a ``cp.Parameter`` is compiled once and re-solved. Measured on
the heavy-haul loop (7 states, a 21 × 21 LMI, Clarabel, a shared 2-core
machine): 50–55 ms per re-solve, of which Clarabel itself takes 35–40 ms,
against 65–75 ms for building and solving a fresh problem at every step;
at this size the solver dominates and the parameter saves the
canonicalisation, about a quarter of each step.

:func:`delay_hinf_gamma` adds a disturbance w and an output s: with ζ =
(x, x_τ, w) and V̇ + |s|² − γ²|w|² < 0 it certifies the L2 gain
‖s‖₂ < γ‖w‖₂ (zero initial function) for every delay in [0, h] (constant
or varying as above):

    [[PA + AᵀP + Q − R, PA_d + R, PB_w, h AᵀR, Cᵀ],
     [·, −Q − R, 0, h A_dᵀR, 0],
     [·, ·, −γ²I, h B_wᵀR, Dᵀ],
     [·, ·, ·, −R, 0],
     [·, ·, ·, ·, −I]] ≺ 0.

Every SDP runs on state-balanced data (one diagonal similarity for A and
A_d, ``scipy.linalg.matrix_balance`` of A + A_d), and every solution is
checked in floating point (eigenvalues of Ξ, P, Q, R) before it counts; a
solver status other than ``optimal`` is recorded, never ignored.

Examples
--------
>>> import math
>>> res = max_certified_delay([[0.0]], [[-1.0]])
>>> 0.9 < res.tau < math.pi / 2
True

The package, by job: :mod:`~trainctl.analysis.delay_lmi.stability` (the stability
LMI and the largest certified delay) and :mod:`~trainctl.analysis.delay_lmi.gain`
(the delay-dependent L2 gain).
"""

from trainctl.analysis.delay_lmi.gain import (
    LK_MARGIN,
    DelayHinf,
    DelayHinfProblem,
    delay_hinf_gamma,
)
from trainctl.analysis.delay_lmi.stability import (
    DELAY_KINDS,
    DelayCertificate,
    KrasovskiiProblem,
    MaxCertifiedDelay,
    krasovskii_lmi,
    max_certified_delay,
)

__all__ = [
    "DELAY_KINDS", "LK_MARGIN", "DelayCertificate", "DelayHinf", "DelayHinfProblem",
    "KrasovskiiProblem",
    "MaxCertifiedDelay", "delay_hinf_gamma", "krasovskii_lmi", "max_certified_delay",
]
