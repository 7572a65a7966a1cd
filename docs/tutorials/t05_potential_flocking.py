"""
Potential-function and flocking control
=======================================

Two consensus laws sit beside MPC in trainctl. The *potential* family is the
four-term cruise law of Zhao & Wang (2017) on the eight cars of one train:
position pinning to the reference, speed feedback, velocity consensus over
a communication graph, and the gradient of a pair potential between
neighbours. The *flocking* family is Olfati-Saber's flocking algorithm on
the gaps of virtually coupled heavy-haul trains (seed 002, a 2023
virtual-coupling patent). Both are continuous-time laws; the design review
certifies them (Hurwitz, Lyapunov, collision energy) and judges their
string stability, i.e. whether a disturbance at the head grows on its way
down the train.
"""

# %%
# The potential law on the CRH-type train
# ---------------------------------------
#
# ``crh2-potential`` is an 8-car train at 300 km/h. The review certifies the
# linear closed loop of the law: its slowest mode decays at
# ``potential_closed_loop = -1.003 1/s``; computing the eigenvalues of the
# same loop with numpy gives ``max Re(eig) of the loop = -1.003 1/s``. A
# Lyapunov function is found by an LMI in cvxpy (the cars' masses differ, so
# the closed form for equal masses does not apply), and from its value at
# the initial errors the review bounds every spacing error by
# ``spacing bound = 0.05402 m``.

import os

import matplotlib.pyplot as plt
import numpy as np

import trainctl
from trainctl.analysis import review_design, string_stability
from trainctl.design import build_design
from trainctl.run import simulate_strategy

SHORT = os.environ.get("TRAINCTL_TUTORIAL_SHORT") == "1"

potential = trainctl.load_scenario("crh2-potential")
review = review_design(potential)
for name in ("potential_closed_loop", "potential_lyapunov", "potential_spacing_bound",
             "potential_position"):
    check = review.check(name)
    print(f"{name}: {check.status} | {check.message}")
print(f"potential_closed_loop = {review.check('potential_closed_loop').value:.3f} 1/s")
print(f"spacing bound = {review.check('potential_spacing_bound').value:.5f} m")

design = build_design(potential)
loop = design.closed_loop("consensus")  # continuous StateSpace: w[i] -> v, f, d
print(f"max Re(eig) of the loop = {np.linalg.eigvals(loop.A).real.max():.3f} 1/s")

# %%
# String stability of the potential law
# -------------------------------------
#
# ``string_stability`` takes any closed loop with disturbance inputs ``w[i]``
# [m/s²] and spacing outputs ``d[i]`` [m] and coupler forces ``f[i]`` [kN],
# and returns the peak gain over frequency from ``w[0]`` (the head) to each.
# With position pinning the peaks shrink along the train; the largest ratio of
# one peak to the one before is ``largest peak ratio = 0.9567``, below one:
# string stable.

ss_pot = string_stability(loop)
print(f"string stable: {ss_pot.string_stable}")
print(f"largest peak ratio = {ss_pot.max_ratio:.4f}")
print("spacing peaks [m per m/s^2]:", np.round(ss_pot.chains["d"].gains, 5).tolist())

# %%
# Without pinning
# ---------------
#
# The built-in ``crh2-potential-unpinned`` drops the position pinning: every
# car still agrees on the speed, but nothing pulls the train back to the
# reference position. The review rejects it on purpose, and its string
# stability check fails (``unpinned string_stability: fail``); the train
# settles 1.243 m ahead of its reference position and stays there.

unpinned = review_design(trainctl.load_scenario("crh2-potential-unpinned"))
print(f"unpinned string_stability: {unpinned.check('string_stability').status}")
print(f"unpinned potential_position: {unpinned.check('potential_position').status} | "
      f"{unpinned.check('potential_position').message}")

# %%
# Flocking of virtually coupled trains
# ------------------------------------
#
# ``heavy-haul-flocking`` runs four heavy-haul unit trains with no physical
# coupler between them. The law keeps each gap near the desired distance
# d_α through a σ-norm potential that acts only within the range r_α. The
# review prints ``d_alpha = 23.17, r_alpha = 29.24`` (in σ-norm units), and
# the collision certificate: the energy of the initial errors,
# ``H(0) = 14.28 m^2/s^2``, is below the energy of the collision barrier,
# ``E(0) = 42.43 m^2/s^2``, so no two trains can touch as long as the law
# does not saturate. The ``flocking_actuators`` check warns that it may.
# The gaps of the flocking loop are string stable too:
# ``flocking largest peak ratio = 0.7968``.

flocking = trainctl.load_scenario("heavy-haul-flocking")
fl_review = review_design(flocking)
for name in ("flocking_parameters", "flocking_closed_loop", "flocking_collision",
             "flocking_connectivity", "flocking_actuators"):
    check = fl_review.check(name)
    print(f"{name}: {check.status} | {check.message}")
params = fl_review.check("flocking_parameters").details
collision = fl_review.check("flocking_collision").details
print(f"d_alpha = {params['d_alpha']:.2f}, r_alpha = {params['r_alpha']:.2f}")
print(f"H(0) = {collision['initial_energy_m2_s2']:.2f} m^2/s^2")
print(f"E(0) = {collision['bound_m2_s2']:.2f} m^2/s^2")

fl_loop = build_design(flocking).closed_loop("flocking")
ss_fl = string_stability(fl_loop)
print(f"flocking largest peak ratio = {ss_fl.max_ratio:.4f}")

# %%
# Simulation of both
# ------------------
#
# Each law is sampled at its ``control_interval`` on the nonlinear plant. The
# full runs are the scenarios' own (100 s and 1800 s); the short mode
# simulates 10 s and 300 s.

pot_time, fl_time = (10.0, 300.0) if SHORT else (100.0, 1800.0)
pot = potential.replace("simulation.settle_time", pot_time / 2).replace(
    "simulation.duration", pot_time)
fl = flocking.replace("simulation.settle_time", fl_time / 2).replace(
    "simulation.duration", fl_time)
pot_run = simulate_strategy(pot, "consensus")
fl_run = simulate_strategy(fl, "flocking")

fig, axes = plt.subplots(1, 2, figsize=(8, 3.5), layout="constrained")
axes[0].plot(pot_run.time, (pot_run.velocities - pot_run.reference_speed).T)
axes[0].set_title("potential law: speed errors")
axes[0].set_xlabel("time [s]")
axes[0].set_ylabel("speed error [m/s]")
axes[1].plot(fl_run.time, fl_run.velocities.T * 3.6)
axes[1].set_title("flocking: train speeds")
axes[1].set_xlabel("time [s]")
axes[1].set_ylabel("speed [km/h]")
print(f"potential: largest |speed error| at the end = "
      f"{np.abs(pot_run.velocities[:, -1] - pot_run.reference_speed[-1]).max():.4f} m/s")
plt.show()
