# Robust H∞ leader-following speed consensus (seed 003): the loop, its gains, per-channel γ.
"""The structured H∞ consensus law of seed 003 (spec §4.2) and the synthesis of its two gains.

The law (linear β) adds, per unit mass, to vehicle i's acceleration

    a_i = −κ_p b_i (v_i − v_d − n_0i) − κ_c Σ_j a_ij (v_i − v_j − n_ij)   [m/s²],

i.e. the force M_i a_i, with B = diag(b_i) the pinning matrix and
L = D − A the Laplacian of the communication graph
(:meth:`~trainctl.models.graphs.CommunicationGraph.pinning_matrix`,
:meth:`~trainctl.models.graphs.CommunicationGraph.laplacian`); n_0i is the noise on
the reference speed vehicle i receives, n_ij the noise on vehicle j's speed
as vehicle i receives it. On the design model (speed deviations v and
coupler elongations δ from the cruise at v_d, no dummy state) the closed
loop is affine in the gains:

    ẋ = (A₀ + κ_p A_p + κ_c A_c) x + (B_f + κ_p B_0 + κ_c B_L) w,
    A_p = −E B S_v,  A_c = −E L S_v,

with E the acceleration input (the design B times diag(M_i) / 1000, the
speed rows), S_v the speed rows of the state, and the disturbances

- ``f[i]``: a force disturbance on vehicle i as specific force [m/s²] (a
  grade, a resistance error), column E e_i;
- ``n0[i]``: noise on the reference speed vehicle i receives [m/s]
  (b_i > 0 only), column κ_p b_i E e_i;
- ``n[i,j]``: noise on vehicle j's speed as vehicle i receives it [m/s]
  (a_ij > 0 only), column κ_c a_ij E e_i.

The plant part A₀ is the design model's, with an optional gain-free
``local_feedback`` F_loc [N per unit of the state] closed around it on
current data: A₀ = A + B F_loc. The hinf family passes its resistance
feedforward's slope [diag(m_i c_i), 0] (c_i = a1_i + 2 a2_i v_d; each
vehicle's own Davis resistance at its measured speed), which cancels the
resistance damping of the design model, so that the loop synthesised here is
the one the family closes (:meth:`~trainctl.controllers.hinf.law.HinfLaw.resistance_feedback`);
without it A₀ keeps that damping (≈ 8.4e-4 1/s on heavy-haul-hinf).

Which part of the law acts on delayed data (``own_speed``, as the family's
setting): ``"delayed"``, the whole law (both sides of every difference
taken at the send time); ``"current"``, only the neighbours' speeds
κ_c Σ_j a_ij v_j (the own-speed parts −κ_p b_i v_i − κ_c d_i v_i act now,
and the reference's delay does not enter the deviation loop). The delay-free
loop is the same either way.

Performance output s: the tracking errors e_i = v_i − v_d [m/s]
(``output="tracking"``), or the disagreement (I − 11ᵀ/n) e
(``output="disagreement"``), which ignores a common speed error.

Scaling. ‖T_ws‖∞ < γ = 1 (the paper's requirement) means nothing until w
and s are scaled: each channel j enters as w_j = c_j w̃_j with c_j its
``scaling`` (the disturbance size taken as one unit: default 1 m/s² per
force channel and 1 m/s per noise channel) and s = s_0 s̃ with s_0
``output_scale`` (default 1 m/s), and γ is the gain w̃ → s̃ [-]. Whatever the
gains, the tracking error follows the reference noise at DC: a noise common
to every received reference (the broadcast command itself is wrong)
reaches every e_i with gain κ_p b̄/(κ_p b̄ + c) → 1 (c ≈ 8e-4 1/s, the
resistance's damping, b̄ the mass-weighted mean pinning weight; exactly 1
when the resistance feedforward cancels c), so the reference-noise channels
together have γ ≳ 1 for any κ_p (with the default scaling), and only the
disagreement output escapes that floor.

Synthesis (:func:`synthesise_gains`). For fixed gains the bounded-real
lemma is an SDP in P (:class:`~trainctl.analysis.hinf.BoundedRealProblem`,
built once with κ_p and κ_c as ``cp.Parameter``; the products κ·P are DPP).
Jointly in (P, κ_p, κ_c) the condition is bilinear (non-convex), so the
gains are searched outside the SDP: a coarse grid over the bounds, then
Nelder–Mead from the best grid point (scipy, within the bounds), each
point's γ certified by its own SDP solution and checked in floating point.
The result is a certified γ for the gains returned — not a proof that no
better gains exist in the bounds.

Delays (``tau_max``). The same search on the delay-dependent LMI of
:class:`~trainctl.analysis.delay_lmi.DelayHinfProblem` (with ``own_speed =
"delayed"`` the whole law delayed, ẋ = A₀x + (κ_pA_p + κ_cA_c)x(t − τ) +
B_w w; with ``"current"`` the own-speed parts undelayed, h = τ_max fixed,
the gains as parameters): γ is then certified for every delay in [0, τ_max]
(constant, or any time-varying τ(t) with ``delay="varying"``). Each SDP is
larger (3N + channels + outputs) and Jensen's inequality makes γ
conservative; the Padé-loop norms at delays in (0, τ_max] are reported
next to it as the independent check.

The package, by job: :mod:`~trainctl.controllers.hinf.synthesis.loop` (the closed
loop, affine in the gains) and :mod:`~trainctl.controllers.hinf.synthesis.gains`
(the gain search and the certificates).
"""

from trainctl.controllers.hinf.synthesis.gains import (
    PADE_POINTS,
    Certificate,
    GainSynthesis,
    certify_gains,
    synthesise_gains,
)
from trainctl.controllers.hinf.synthesis.loop import (
    CHANNEL_GROUPS,
    DEFAULT_SCALING,
    OUTPUTS,
    OWN_SPEEDS,
    ConsensusLoop,
    consensus_loop,
)

__all__ = [
    "CHANNEL_GROUPS", "DEFAULT_SCALING", "OUTPUTS", "OWN_SPEEDS", "PADE_POINTS", "Certificate",
    "ConsensusLoop", "GainSynthesis", "certify_gains", "consensus_loop", "synthesise_gains",
]
