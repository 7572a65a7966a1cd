"""
Stability, controllability and sampling
=======================================

The built-in scenario ``crh2-dmpc`` is seed 000 as printed: the CRH2 half
train at 300 km/h with the sample time T = 20 s of Li & Zheng (2015, ch. 12).
This tutorial checks the continuous model for stability, controllability and
observability, and then shows why 20 s is far too long a sample time for a
train with stiff couplers: the coupler modes alias and every coach force
looks the same to the sampled model.
"""

# %%
# The model of the scenario
# -------------------------
#
# ``load_scenario`` reads a built-in by name (or a TOML file by path) and
# converts everything to SI. Its ``model`` section holds the cruise speed and
# the sample time: the script prints ``v_r = 83.333 m/s, T = 20 s``.

import os

import matplotlib.pyplot as plt
import numpy as np

import trainctl
from trainctl.analysis import (
    analyse_controllability,
    analyse_observability,
    analyse_sampling,
    analyse_stability,
)
from trainctl.models import discretise, linearise

SHORT = os.environ.get("TRAINCTL_TUTORIAL_SHORT") == "1"

scenario = trainctl.load_scenario("crh2-dmpc")
v_r, T = scenario.model.speed, scenario.model.sample_time
print(f"v_r = {v_r:.3f} m/s, T = {T:g} s")
sys = linearise(scenario.train, v_r)  # 7 states: 4 speeds, 3 elongations
print("states:", sys.state_labels)

# %%
# Stability
# ---------
#
# Without the dummy state every mode decays, but barely: the Davis
# resistance damps each coach in proportion to its mass, so the rigid-body
# mode decays at d = 2.68e-3 1/s and each coupler mode at d/2. The script
# prints the slowest decay rate ``spectral abscissa = -1.342e-03 1/s``.

stab = analyse_stability(sys, n_vehicles=4)
print(f"stability: {stab.status}")
print(f"spectral abscissa = {stab.spectral_abscissa:.3e} 1/s")
for mode in stab.modes:
    print(f"  {mode.name:>24s}: {mode.eigenvalue:.4g} 1/s")

# %%
# Controllability and observability
# ---------------------------------
#
# Four coach forces reach all seven states and the four speeds see them:
# ``controllability rank = 7/7`` and ``observability rank = 7/7``. The
# condition numbers are those of the scaled Kalman matrices.

ctrb = analyse_controllability(sys)
obsv = analyse_observability(sys)
print(f"controllability rank = {ctrb.rank}/{ctrb.n_states}, "
      f"condition number {ctrb.condition_number:.3g}")
print(f"observability rank = {obsv.rank}/{obsv.n_states}, "
      f"condition number {obsv.condition_number:.3g}")

# %%
# Why T = 20 s aliases the couplers
# ---------------------------------
#
# The fastest coupler mode oscillates at ω_max = 27.77 rad/s. A sampled
# model can only tell an oscillation apart from a slower one when
# ω_max·T < π, i.e. T < π/ω_max. With T = 20 s the product is 555 rad, and
# the script prints ``omega_max*T = 555.4 rad`` against
# ``pi/omega_max = 0.1131 s``.
#
# A second symptom: over 20 s the couplers have long settled, so a force
# on any coach moves the whole train alike. The columns of the sampled input
# matrix B_d are nearly equal; the smallest normalised singular value of B_d
# (the review's ``input_collapse``) is ``input collapse = 0.000134``. With
# T = 0.05 s the couplers are resolved (``omega_max*T = 1.388 rad``, input collapse 0.718).

samp = analyse_sampling(sys, T, n_vehicles=4)
print(f"omega_max = {samp.omega_max:.2f} rad/s")
print(f"omega_max*T = {samp.omega_t:.1f} rad")
print(f"pi/omega_max = {samp.nyquist_sample_time:.4f} s")
print(f"input collapse = {samp.input_collapse:.3g}")
print(f"resolves couplers at T = {T:g} s: {samp.resolves_couplers}")

sysd = discretise(sys, T)
print("B_d speed rows [m/s per kN]:")
print((sysd.B[:4] * 1e3).round(4))

fast = analyse_sampling(sys, 0.05, n_vehicles=4)
print(f"at T = 0.05 s: omega_max*T = {fast.omega_t:.3f} rad, "
      f"input collapse = {fast.input_collapse:.3g}")

# %%
# The eigenvalues of the two sampled models
# -----------------------------------------
#
# At T = 0.05 s the coupler eigenvalues sit at distinct angles on a circle
# just inside the unit circle; at T = 20 s their angles are the true ones
# folded back into (-π, π], and nothing in the sampled model tells the three
# coupler modes from slower oscillations.

fig, axes = plt.subplots(1, 2, figsize=(7, 3.5), layout="constrained")
theta = np.linspace(0, 2 * np.pi, 200 if SHORT else 1000)
for ax, dt in zip(axes, (T, 0.05), strict=True):
    z = np.linalg.eigvals(discretise(sys, dt).A)
    ax.plot(np.cos(theta), np.sin(theta), "k-", lw=0.5)
    ax.plot(z.real, z.imag, "x")
    ax.set_aspect("equal")
    ax.set_title(f"T = {dt:g} s")
    ax.set_xlabel("Re z")
axes[0].set_ylabel("Im z")
plt.show()
