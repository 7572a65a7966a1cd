"""
Your own (A, B) with the generic MPC
====================================

The train MPC of trainctl is built on a general MPC core that takes any
discrete ``control.StateSpace``: ``make_linear_mpc`` in
``trainctl.controllers.mpc``. This tutorial uses it three ways: on a small
textbook problem whose answer is known, on a two-wagon model written from
scratch, and against LQR, which an MPC with the right terminal weight must
reproduce exactly.
"""

# %%
# A problem with a known answer
# -----------------------------
#
# The regulation example of the MPT3 toolbox, which python-control also uses
# in its own tests: x(k+1) = [[1, 1], [0, 1]] x + [1, 0.5] u, Q = I, R = 1,
# P = 4, bounds ``|u| <= 1`` and ``|x| <= 5``, from x = [4, 0]. The optimal plan is
# ``plan = [-1.0000, -1.0000, 0.1393, 0.3361]``: the first two moves sit on
# the input bound.

import os

import control as ct
import matplotlib.pyplot as plt
import numpy as np

from trainctl.controllers.mpc import make_linear_mpc
from trainctl.models import discretise

SHORT = os.environ.get("TRAINCTL_TUTORIAL_SHORT") == "1"

sysd = ct.ss([[1, 1], [0, 1]], [[1], [0.5]], np.eye(2), 0, dt=1)
mpc = make_linear_mpc(sysd, Q=np.eye(2), R=1, prediction_horizon=4,
                      u_min=-1, u_max=1, x_min=-5, x_max=5)
sol = mpc.solve([4.0, 0.0])
print(f"status: {sol.status}")
print("plan = [" + ", ".join(f"{u:.4f}" for u in sol.inputs.ravel()) + "]")

# %%
# A model of your own: two wagons and a coupler
# ---------------------------------------------
#
# Two 40 t wagons joined by a 5000 kN/m coupler with 50 kN·s/m damping; the
# state is [v_1, v_2, δ] (speed deviations in m/s, coupler elongation in m),
# the inputs the two wagons' forces in kN (working in kN keeps the QP well
# scaled). Written with plain numpy and sampled with ``discretise`` (zero
# order hold) at T = 0.05 s, well below π/ω of the coupler mode. The two
# wagons oscillate against each other at about √(2k/m) = 15.8 rad/s; the
# damping lowers it slightly and the script prints
# ``coupler mode = 15.76 rad/s``.

m, k, d = 40e3, 5e6, 5e4  # mass [kg], stiffness [N/m], damping [N s/m]
A = np.array([[-d / m, d / m, -k / m],
              [d / m, -d / m, k / m],
              [1.0, -1.0, 0.0]])
B = np.array([[1e3 / m, 0.0], [0.0, 1e3 / m], [0.0, 0.0]])  # per kN
wagons = ct.ss(A, B, np.eye(3), 0, states=["v[0]", "v[1]", "delta[0]"],
               inputs=["u[0]", "u[1]"], name="wagons")
omega = np.abs(np.linalg.eigvals(A).imag).max()
print(f"coupler mode = {omega:.2f} rad/s, pi/omega = {np.pi / omega:.3f} s")
T = 0.05  # sample time [s]
wagons_d = discretise(wagons, T)

# %%
# Receding horizon
# ----------------
#
# Both wagons start 1 m/s too fast; each force is limited to ±20 kN, the
# coupler elongation to ±5 mm (soft). Every sample the MPC solves its QP and
# the first move is applied to the model. In the short mode of these
# tutorials the loop runs 2 s instead of 10 s.

Q = np.diag([1.0, 1.0, 0.0])  # weight on [v_1, v_2, δ]: speeds only
ctrl = make_linear_mpc(wagons_d, Q=Q, R=1e-3, prediction_horizon=20, control_horizon=5,
                       u_min=-20, u_max=20, y_min=[-np.inf, -np.inf, -5e-3],
                       y_max=[np.inf, np.inf, 5e-3], soft={"y": True})
steps = int((2.0 if SHORT else 10.0) / T)
x = np.array([1.0, 1.0, 0.0])
xs, us = [x], []
for _ in range(steps):
    u = ctrl.solve(x).inputs[0]
    x = wagons_d.A @ x + wagons_d.B @ u
    xs.append(x)
    us.append(u)
xs, us = np.array(xs), np.array(us)
print(f"first move = [{us[0, 0]:.1f}, {us[0, 1]:.1f}] kN")
print(f"speed error after {steps * T:g} s = {np.abs(xs[-1, :2]).max():.4f} m/s")

t = np.arange(steps + 1) * T
fig, axes = plt.subplots(2, 1, figsize=(6, 5), sharex=True, layout="constrained")
axes[0].plot(t, xs[:, 0], label="v_1")
axes[0].plot(t, xs[:, 1], "--", label="v_2")
axes[0].set_ylabel("speed deviation [m/s]")
axes[0].legend()
axes[1].step(t[:-1], us[:, 0], where="post", label="u_1")
axes[1].step(t[:-1], us[:, 1], "--", where="post", label="u_2")
axes[1].set_ylabel("force [kN]")
axes[1].set_xlabel("time [s]")
axes[1].legend()

# %%
# MPC with the LQR terminal weight is LQR
# ---------------------------------------
#
# Without constraints, an MPC whose cost-to-go after the horizon is the
# solution S of the discrete Riccati equation has the infinite-horizon cost
# as its tail, so its first move is the LQR move u = -K x, for any horizon.
# ``make_linear_mpc`` weights the outputs y(k+1), ..., y(k+P) with Q and adds
# the terminal weight on x(k+P) on top, so the terminal weight that makes
# x(k+P) cost exactly S is S - Q. The script
# checks this on the wagons with python-control's ``dlqr`` and prints
# ``first move equals LQR: True``.

Qx = np.eye(3)
K, S, _ = ct.dlqr(wagons_d.A, wagons_d.B, Qx, np.eye(2))
lq = make_linear_mpc(wagons_d, Q=Qx, R=1.0, prediction_horizon=3, terminal_weight=S - Qx,
                     qp_solver="daqp")
x0 = np.array([0.3, -0.2, 1e-3])
u_mpc = lq.solve(x0).inputs[0]
u_lqr = -K @ x0
print(f"MPC first move = {u_mpc.round(5).tolist()} kN, LQR = {u_lqr.round(5).tolist()} kN")
print(f"first move equals LQR: {np.allclose(u_mpc, u_lqr, rtol=1e-6, atol=1e-9)}")
plt.show()
