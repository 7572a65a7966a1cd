"""
MPC and N-DMPC
==============

In the networked distributed MPC (N-DMPC) of Li & Zheng (2015, ch. 12) each
coach solves its own small QP: it plans its force so that its own speed and
its neighbours' speeds follow the reference, assuming the plans the other
coaches announced in the previous iteration. The coaches iterate (Jacobi)
until the plans stop changing. Whether that iteration converges is decided
by the spectral radius ρ(D0) of its iteration matrix, and ρ(D0) falls as the
input weight R grows; the weight where it crosses 1 is the threshold R*.

This tutorial reads those numbers for ``crh2-dmpc`` (R = 10 per kN², T = 20 s,
P = 4, M = 2), shows what happens below R* and how relaxation rescues the
iteration, and simulates the three MPC strategies on the nonlinear train.
"""

# %%
# The design and its convergence numbers
# --------------------------------------
#
# ``build_design`` linearises and discretises the scenario's train once and
# builds each controller family's design on it. The MPC family's
# ``analysis`` holds the closed-form N-DMPC numbers the design review judges.
# Weights are in the design units: inputs in kN, so R is per kN².
#
# For ``crh2-dmpc`` the script prints ``rho(D0) = 0.3057`` and the threshold
# ``R* = 2.253 per kN^2``: the scenario's R = 10 per kN² is well above it, so
# plain Jacobi iteration converges. As a check of R* itself, ρ(D0) evaluated
# at R = R* is one: ``rho(D0) at R* = 1.0000``.

import os

import matplotlib.pyplot as plt
import numpy as np

import trainctl
from trainctl.analysis import convergence_sweep, review_design
from trainctl.design import build_design
from trainctl.run import simulate_strategy
from trainctl.sim import compute_metrics

SHORT = os.environ.get("TRAINCTL_TUTORIAL_SHORT") == "1"

scenario = trainctl.load_scenario("crh2-dmpc")
design = build_design(scenario)
mpc = design.family("mpc")
res = mpc.analysis
print(f"rho(D0) = {res.rho_d0:.4f}")
print(f"R* = {res.threshold_weight:.3f} per kN^2")
print(f"converges: {res.converges}")
r_star = convergence_sweep(mpc.mpc, [res.threshold_weight])[0]
print(f"rho(D0) at R* = {r_star:.4f}")

# %%
# ρ(D0) against the input weight
# ------------------------------
#
# ``convergence_sweep`` evaluates ρ(D0) for a list of common input weights.
# With T = 20 s all four coach forces act on the train almost alike (see the
# previous tutorial), so each coach over-corrects for the others unless its
# own moves are penalised enough.

weights = np.logspace(-1, 2, 13 if SHORT else 61)  # R [per kN^2]
rho = convergence_sweep(mpc.mpc, weights)
fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
ax.loglog(weights, rho, "o-", ms=3)
ax.axhline(1.0, color="k", lw=0.8)
ax.axvline(res.threshold_weight, color="r", ls="--", label="R*")
ax.set_xlabel("input weight R [per kN²]")
ax.set_ylabel("ρ(D0) [-]")
ax.legend()

# %%
# Below the threshold, and relaxation
# -----------------------------------
#
# ``scenario.replace`` changes one file key (in the file's unit) and returns
# a new, validated scenario. With R = 1 per kN² the review's
# ``ndmpc_convergence`` check fails (``ndmpc_convergence at R = 1: fail``)
# and ρ(D0) is above one (``rho(D0) at R = 1: 1.5849``). Relaxed Jacobi
# U ← (1 - ω)U + ω U_new converges for a small enough ω whenever every
# eigenvalue of D0 has a real part below one; the review's ``relaxation``
# check names the best ω: ``best omega = 0.666``.

light = scenario.replace("controller.r_per_kn2", 1.0)
light_review = review_design(light)
light_res = build_design(light).family("mpc").analysis
print(f"ndmpc_convergence at R = 1: {light_review.check('ndmpc_convergence').status}")
print(f"rho(D0) at R = 1: {light_res.rho_d0:.4f}")
rel = light_res.relaxation
print(f"relaxation exists: {rel.exists}, best omega = {rel.omega_best:.3f}, "
      f"rate = {rel.rate:.4f}")
print("relaxation check:", light_review.check("relaxation").message)

# %%
# Simulation on the nonlinear train
# ---------------------------------
#
# ``simulate_strategy`` runs one strategy of the ``[simulation]`` section on
# the nonlinear plant (actuator envelopes, Davis resistance, couplers). The
# full run is the 1200 s reference of the scenario (60 steps of 20 s); the
# short mode of these tutorials simulates 200 s. The metrics after the
# scenario's settle time are per coach, in m/s.

if SHORT:
    scenario = scenario.replace("simulation.duration", 200.0)
results = {}
for strategy in ("centralised", "decentralised", "ndmpc"):
    results[strategy] = simulate_strategy(scenario, strategy)
    m = compute_metrics(results[strategy], settle_time=100.0)
    print(f"{strategy:>13s}: max speed error after 100 s = "
          f"{np.max(m.max_error):.3f} m/s")

fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
for strategy, result in results.items():
    ax.plot(result.time, result.velocities[0], label=strategy)
ax.plot(results["ndmpc"].time, results["ndmpc"].reference_speed, "k--", lw=0.8,
        label="reference")
ax.set_xlabel("time [s]")
ax.set_ylabel("head coach speed [m/s]")
ax.legend()
plt.show()
