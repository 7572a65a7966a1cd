"""
A scenario file, the design review and the HTML report
======================================================

Everything trainctl analyses can be written down in a scenario file: a TOML
document with the train, the model settings, the controllers, a simulation
and the verdicts the design review is expected to reach. This tutorial
writes a small one from scratch into a temporary directory, loads it, reads
the design review, lets trainctl catch two typical mistakes, and renders
the self-contained HTML report.
"""

# %%
# Writing the file
# ----------------
#
# Three identical 45 t motor coaches at 200 km/h, joined by couplers of
# 8000 kN/m, under the ``lqr`` family (discrete LQR on the whole train, and
# per coach on its own block). Keys whose names carry a unit use it
# (``mass_t`` in tonnes, ``_kn`` in kN, ``speed_kmh`` in km/h); everything
# else is SI. ``[expected]`` declares the verdict of each design check;
# ``trainctl analyse --strict`` fails when a verdict differs, so the file
# doubles as a regression test of the design.

import os
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import trainctl
from trainctl.analysis import analyse_sampling, review_design
from trainctl.models import linearise
from trainctl.report import (
    build_report_context,
    collect_report_data,
    render_report,
    write_report,
)
from trainctl.run import run_scenario

SHORT = os.environ.get("TRAINCTL_TUTORIAL_SHORT") == "1"

SCENARIO = """\
schema_version = 1
name = "Three-coach EMU under LQR"
description = "3 motor coaches at 200 km/h, T = 0.05 s, centralised and decentralised LQR"
seed = 0

[[train.vehicle]]
name = "M"                       # motor coach
count = 3                        # three identical coaches in a row
mass_t = 45.0                    # mass [t]
length = 25.0                    # length over couplers [m]
davis_n_per_kn_kmh = [0.88, 0.0074, 0.000114]  # unit resistance [N/kN, V in km/h]
max_traction_kn = 60.0           # traction limit [kN]
max_braking_kn = 60.0            # braking limit [kN]

[train.coupler]                  # one coupler type for both links
stiffness_kn_per_m = 8000.0      # stiffness [kN/m]
damping_kn_s_per_m = 20.0        # damping [kN s/m]

[model]
speed_kmh = 200.0                # linearisation speed [km/h]
sample_time = 0.05               # sample time [s]

[controller]
family = "lqr"                   # discrete LQR
q_velocity = 10.0                # weight per (m/s)^2
r_per_kn2 = 0.2                  # weight per kN^2

[simulation]
duration = DURATION              # simulated time [s]
strategies = ["centralised", "decentralised"]
settle_time = 10.0               # tracking judged after this time [s]

[simulation.reference]
times = [0.0, 5.0, 15.0]         # breakpoints [s]
speeds_kmh = [195.0, 195.0, 200.0]  # reference speed [km/h]

[expected]
open_loop_stability = "pass"
controllability = "pass"
observability = "pass"
sampling = "pass"
input_collapse = "pass"
feasibility = "pass"
plausibility = "pass"
lqr_closed_loop = "pass"
lqr_decentralised_closed_loop = "pass"
string_stability = "pass"
"""

workdir = Path(tempfile.mkdtemp(prefix="trainctl-tutorial-"))
path = workdir / "emu3.toml"
# the short mode of these tutorials simulates 12 s instead of 20 s
path.write_text(SCENARIO.replace("DURATION", "12.0" if SHORT else "20.0"), encoding="utf-8")
scenario = trainctl.load_scenario(path)  # a path: read as a file, not a built-in name
print(f"loaded {scenario.name!r}: {scenario.train.n_vehicles} vehicles, "
      f"T = {scenario.model.sample_time:g} s")

# %%
# The design review
# -----------------
#
# ``run_scenario`` does what ``trainctl analyse`` does: the model summary,
# the design review and the simulations. Each check has a status, a value
# with its unit and a one-line message.
#
# The sampling check can be worked out by hand. For three equal masses m on
# two springs k the coupler modes are √(k/m) and √(3k/m); with k = 8000 kN/m
# and m = 45 t the fastest is √(3k/m) = 23.09 rad/s, lowered very slightly by
# the coupler damping. The script prints ``omega_max = 23.08 rad/s`` and
# ``omega_max*T = 1.154 rad``, below π, so T = 0.05 s resolves the couplers.
# Every check meets its ``[expected]`` verdict:
# ``checks differing from [expected]: none``.

run = run_scenario(scenario)
for check in run.review.checks:
    print(f"{check.name:>30s}  {check.status:4s}  {check.message[:90]}")
samp = analyse_sampling(linearise(scenario.train, scenario.model.speed),
                        scenario.model.sample_time, n_vehicles=3)
print(f"omega_max = {samp.omega_max:.2f} rad/s")
print(f"omega_max*T = {samp.omega_t:.3f} rad")
print(f"checks differing from [expected]: {', '.join(run.unexpected_checks()) or 'none'}")
print(f"strict failures: {len(run.strict_failures())}")

fig, ax = plt.subplots(figsize=(6, 3.5), layout="constrained")
for name, result in run.simulations.items():
    ax.plot(result.time, (result.velocities[0] - result.reference_speed) * 1e3, label=name)
ax.set_xlabel("time [s]")
ax.set_ylabel("head coach speed error [mm/s]")
ax.legend()

# %%
# Two mistakes trainctl catches
# -----------------------------
#
# A mass given in kilograms under the key ``mass_t`` is a valid number, but
# not a plausible coach: the ``plausibility`` check warns and its message
# names the likely unit slip (``plausibility with mass_t = 45000: warn``,
# "did you mean kg?"). The index ``vehicle[0]`` is the first vehicle group
# of the file, here all three coaches.
# A misspelt key is refused when the file is read, with the key path and
# the keys that would have been accepted.

heavy = scenario.replace("train.vehicle[0].mass_t", 45000.0)
plaus = review_design(heavy).check("plausibility")
print(f"plausibility with mass_t = 45000: {plaus.status}")
print("  ", plaus.message)
try:
    scenario.replace("model.sample_tme", 0.05)
except trainctl.ScenarioError as exc:
    print("ScenarioError:", str(exc).splitlines()[0][:160])

# %%
# The HTML report
# ---------------
#
# The report is made in four steps, each usable alone:
# ``collect_report_data`` computes what the report shows beyond the run,
# ``build_report_context`` turns it into display values and inline SVG
# figures, ``render_report`` fills the template, and ``write_report`` writes
# the page atomically. The page has no scripts and no external resources:
# it can be mailed or archived as one file. ``trainctl report emu3.toml``
# does the same from the command line.

data = collect_report_data(run, scenario_text=path.read_text(encoding="utf-8"),
                           command="trainctl report emu3.toml")
context = build_report_context(data, deterministic=True)
html = render_report(context)
out = write_report(html, workdir / "emu3.html")
print(f"report written: {out.exists()}, {out.stat().st_size / 1e3:.0f} kB")
self_contained = "<script" not in html and 'src="http' not in html
print(f"self-contained: {self_contained}")
plt.show()
shutil.rmtree(workdir)  # the scenario file and the report
