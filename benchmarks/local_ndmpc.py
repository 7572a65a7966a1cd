"""Global against neighbourhood-local N-DMPC on the CRH2 half train, in closed form.

Run:  .venv/bin/python benchmarks/local_ndmpc.py

For crh2-dmpc (T = 20 s, Δu-form, P = 4, M = 2, R = 10) and
crh2-dmpc-well-sampled (T = 0.05 s, u-form, P = 40, M = 5, R = 0.2): ρ(D0),
the threshold weight R*, the spectral radius of the converged (Nash) closed
loop and, for the local formulation, the largest relative error of a coach's
local output prediction (trainctl.controllers.mpc.theory.local_iteration), for the
variants of the outer-state coupling: hold (first/zero order), exchanged
samples per sample time (N) and boundary ("state": the book's Â_{i,i±1};
"force": boundary coupler elongations exchanged too).
"""

from __future__ import annotations

import numpy as np

from trainctl.controllers.mpc.theory.dmpc import analyse_dmpc
from trainctl.controllers.mpc.theory.iteration import spectral_radius
from trainctl.controllers.mpc.theory.local_iteration import (
    coach_predictions,
    local_closed_loop,
    local_iteration,
    local_model,
    local_nash_gain,
    local_prediction_error,
    local_threshold_weight,
    train_state_owner,
)
from trainctl.design import build_design
from trainctl.scenario import load_scenario

VARIANTS = (("state", "foh", 1), ("state", "zoh", 1), ("state", "foh", 4), ("force", "foh", 1),
            ("force", "foh", 4))


def main() -> None:
    for name in ("crh2-dmpc", "crh2-dmpc-well-sampled"):
        fam = build_design(load_scenario(name)).family("mpc")
        d, sys = fam.mpc, fam.model.design
        res = analyse_dmpc(d)
        radii = res.radii()
        print(f"\n{name}: T = {fam.scenario.model.sample_time} s, {d.form}-form, "
              f"P = {d.prediction_horizon}, M = {d.control_horizon}, R = {d.r[0]:g} per kN²")
        print(f"{'formulation':28}{'ρ(D0)':>9}{'R*':>10}{'ρ(A_cl Nash)':>14}{'pred. error':>13}")
        print(f"{'global':28}{res.rho_d0:>9.4f}{res.threshold_weight:>10.4g}"
              f"{radii['nash']:>14.7f}{0.0:>13.3g}")
        print(f"{'centralised':28}{'':>9}{'':>10}{radii['centralised']:>14.7f}")
        for boundary, hold, N in VARIANTS:
            model = local_model(d, np.asarray(sys.A), np.asarray(sys.B),
                                fam.scenario.model.sample_time, train_state_owner(d.n_inputs),
                                hold=hold, substeps=N, boundary=boundary)
            coaches = coach_predictions(d, model)
            it = local_iteration(d, model, coaches)
            cl = spectral_radius(local_closed_loop(d, local_nash_gain(it)[:it.n_plan]))
            err = local_prediction_error(d, model, coaches).max()
            r_star = local_threshold_weight(d, model, rtol=1e-3)
            label = f"local {boundary}, {hold}, N = {N}"
            print(f"{label:28}{it.rho:>9.4f}{r_star:>10.4g}{cl:>14.7f}{err:>13.3g}")


if __name__ == "__main__":
    main()
