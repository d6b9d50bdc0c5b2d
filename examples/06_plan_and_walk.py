"""06 — Plan a walking gait (DIRCON) and turn it into a walk of a few steps.

The gait paper's planner: direct collocation with contact constraints over one symmetric
gait cycle (two steps), solved by IPOPT through casadi, minimising the specific resistance
(SR: energy per weight and distance). `GaitProblem` builds the NLP once per robot and knot
count; `solve` takes the settings (step length, duration, bounds). `build_walk` repeats the
cycle from rest to rest and lifts it to a whole-body 3-D motion with lateral sway.

    .venv/bin/python examples/06_plan_and_walk.py
"""

import dataclasses

from app.core.collocation.defaults import robot_gait_defaults
from app.core.collocation.dircon import GaitProblem
from app.core.robot.loading import load_robot
from app.core.walking.walk import build_walk

robot = load_robot("dircon_biped")  # the gait paper's robot (5 DOF per leg in the plane)

# Settings for this robot (the paper's for dircon_biped; scaled for another robot, with notes).
defaults = robot_gait_defaults(robot)
settings = dataclasses.replace(defaults.settings, knots=14, step_length_m=0.2, H_s=0.72)

problem = GaitProblem(robot, settings.knots, settings.baseline)  # the NLP, built once
result = problem.solve(settings)
print(f"{result.status} in {result.solve_s:.2f} s ({result.iterations} iterations)")
if not result.converged:
    raise SystemExit(f"no gait: {result.blame}")  # blame says which bound held it back

left, right = result.step_lengths_m
print(
    f"steps {left:.3f} / {right:.3f} m, SR {result.sr:.3f}, max |tau| {result.max_abs_tau_Nm:.1f} N·m"
)
print(f"foothold slack {result.slack0:.3g} (eq 5: x1 = (0.5 + slack0)(x0 + x2))")

# Four steps from standing to standing, sampled every 20 ms (the feet as far apart as the
# hips: step_width_m=None).
walk = build_walk(problem.model, result, steps=4, dt=0.02)
traj = walk.trajectory
print(f"walk: {traj.n_samples} samples over {traj.duration:.2f} s")
for f in walk.footprints:
    print(
        f"  {f.side:5s} foot at x = {f.x_m:.3f} m, y = {f.y_m:+.3f} m, {f.t_on_s:.2f}–{f.t_off_s:.2f} s"
    )
for note in walk.notes:
    print("note:", note)
# `traj` is a Trajectory like any motion's: examples 04 and 05 apply to it unchanged.
