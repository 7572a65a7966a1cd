"""
A train as a python-control system
==================================

trainctl builds the longitudinal model of a train from its vehicles and the
couplers between them. This tutorial takes seed 000's CRH2 half train (four
coaches T-M-M-T, Li & Zheng (2015, ch. 12)), linearises it at 300 km/h and
writes it twice: as one whole-train ``control.StateSpace`` and as four coach
subsystems with the blocks A_ii, A_ij, B_i and C_i, joined by
``control.interconnect``. The two must be the same system.

Every quantity is SI: masses in kg, forces in N, speeds in m/s, coupler
elongations in m.
"""

# %%
# Vehicles and couplers
# ---------------------
#
# ``crh2_half()`` is the preset of seed 000: four coaches of 42.8, 48, 46.5
# and 42 t, joined by three couplers of 10488 kN/m without damping. The
# script prints ``vehicles = 4, couplers = 3`` and the stiffness
# ``k = 10488 kN/m``.

import os

import control as ct
import matplotlib.pyplot as plt
import numpy as np

from trainctl.models import coach_subsystems, crh2_half, linearise

SHORT = os.environ.get("TRAINCTL_TUTORIAL_SHORT") == "1"

train = crh2_half()
print(f"vehicles = {train.n_vehicles}, couplers = {train.n_couplers}")
print("masses [kg]:", train.mass.tolist())
print(f"k = {train.stiffness[0] / 1e3:.0f} kN/m")

# %%
# The linear model of the whole train
# -----------------------------------
#
# ``linearise`` returns the deviation model about the cruise speed v_r: the
# states are the coach speeds ``v[i]`` and the coupler elongations
# ``delta[i]``, the inputs the coach forces ``u[i]`` [N]. With
# ``dummy_state=True`` it keeps the book's extra elongation of the last
# coach, an eigenvalue at 0 that nothing drives and nothing sees.
#
# The couplers give three oscillating modes. Because the Davis damping acts
# on every coach alike, each has the real part -d/2 and the imaginary parts
# are the coupler frequencies; the script prints
# ``coupler modes = 11.94, 21.66, 27.77 rad/s``. The fastest one, 27.77 rad/s,
# has a period of 0.226 s, which will matter for sampling in the next
# tutorial.

v_r = 300 / 3.6  # cruise speed [m/s]
whole = linearise(train, v_r, dummy_state=True)
print("states:", whole.state_labels)
eig = np.linalg.eigvals(whole.A)
freqs = sorted({round(abs(z.imag), 2) for z in eig if abs(z.imag) > 1e-9})
print("coupler modes = " + ", ".join(f"{w:.2f}" for w in freqs) + " rad/s")

# %%
# Coach subsystems
# ----------------
#
# Li & Zheng (2015, eqs. 12.12-12.17) write the train as coupled subsystems
# with the state z_i = [v_i; delta_i] of coach i (its speed and the
# elongation of the coupler behind it)::
#
#     dz_i/dt = A_ii z_i + B_i u_i + A_{i,i-1} z_{i-1} + A_{i,i+1} z_{i+1}.
#
# ``coach_subsystems`` builds these blocks from each coach's own parameters.
# The upper-right entry of A_11 is -k/m_1, printed as ``-k/m_1 = -245.05 1/s^2``
# (10488 kN/m over 42.8 t); B_1 holds 1/m_1, printed as
# ``B_1 = 2.3364e-05 1/kg``.

sub = coach_subsystems(train, v_r, dummy_state=True)
print("A_11 =", sub.A[0, 0].round(5).tolist())
print("A_21 =", sub.A[1, 0].round(3).tolist())
print("A_12 =", sub.A[0, 1].round(3).tolist())
print(f"-k/m_1 = {sub.A[0, 0][0, 1]:.2f} 1/s^2")
print(f"B_1 = {sub.B[0][0, 0]:.4e} 1/kg")
print("C_1 =", sub.C[0].tolist())

# %%
# Interconnection
# ---------------
#
# ``sub.subsystem(i)`` is coach i as a ``StateSpace`` whose inputs are its
# force and its neighbours' states, and whose outputs are its own states,
# named like ``v[1]`` and ``delta[1]``. ``sub.interconnection()`` wires the
# four by signal name with ``control.interconnect``. Its states come in the
# order [z_1; z_2; ...]; after reordering them into the whole-train order the
# matrices are the same, and the script prints ``interconnection equals
# whole-train model: True``.

coach2 = sub.subsystem(1)
print("coach 2 inputs:", coach2.input_labels)
joined = sub.interconnection()
order = [joined.state_labels.index(f"coach{lab[lab.index('[') + 1]}_{lab}")
         for lab in whole.state_labels]
P = np.eye(joined.nstates)[order]  # permutation: whole-train order from coach order
A_j = P @ joined.A @ P.T
B_j = P @ joined.B
C_j = joined.C @ P.T
same = (np.allclose(A_j, whole.A, rtol=1e-12, atol=1e-12)
        and np.allclose(B_j, whole.B, rtol=1e-12, atol=1e-15)
        and np.allclose(C_j, whole.C))
print(f"interconnection equals whole-train model: {same}")

# %%
# The same response
# -----------------
#
# A 1 kN step on the first motor coach (``u[1]``) through both models: the
# curves lie on top of each other. The coupler modes ring on top of the
# rigid-body acceleration because the couplers have no damping.

t = np.linspace(0.0, 2.0, 201 if SHORT else 2001)  # time [s]
u = np.zeros((4, t.size))
u[1] = 1e3  # force [N]
r_whole = ct.forced_response(whole, t, u)
r_joined = ct.forced_response(joined, t, u)
fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
for i in range(4):
    ax.plot(t, r_whole.outputs[i] * 1e3, label=f"v[{i}] whole train")
    ax.plot(t, r_joined.outputs[i] * 1e3, "k:", lw=1)
ax.set_xlabel("time [s]")
ax.set_ylabel("speed deviation [mm/s]")
ax.set_title("1 kN on coach 2: whole train and interconnection (dotted)")
ax.legend(fontsize=7)
print(f"largest response difference = {np.abs(r_whole.outputs - r_joined.outputs).max():.1e} m/s")
plt.show()
