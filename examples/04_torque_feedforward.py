"""04 — Joint torques of a motion by the whole-body QP (torque feed-forward).

At every sample, `torque_feedforward` solves a QP for the joint torques and contact forces
that realise the motion's accelerations (an LQR term keeps the CoM on its plan; friction
pyramids keep the feet from slipping). A sample without a solution is marked in `status`,
never raised. `torque_peaks` gives each joint's largest |τ|, the number a servo is sized by.

    .venv/bin/python examples/04_torque_feedforward.py
"""

import numpy as np

from app.core.dynamics.peaks import torque_peaks
from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot

robot = load_robot("servo_biped")
traj = run_motion(robot, "one_leg_stand", dt=0.02, speed=2.0).trajectory

ff = torque_feedforward(robot, traj)  # FeedForward: tau_Nm has shape (T, n_actuated)
print(f"{traj.name}: {traj.n_samples} samples, tau_Nm shape {ff.tau_Nm.shape}")
print(
    f"not solved: {len(ff.infeasible_samples)} sample(s); median QP {1e3 * np.median(ff.qp_time_s):.2f} ms"
)

# The weight is carried by the feet: the vertical contact forces [N] add up to m·g when the
# robot is still (the first sample stands on both feet).
fz = ff.contact_forces_N[0, :, :, 2].sum()
print(f"sum of vertical contact forces at t = 0: {fz:.2f} N (m·g = {robot.mass_kg * 9.81:.2f} N)")

# Peaks per joint, over the samples neither infeasible nor over a joint's speed limit.
peaks = torque_peaks(robot, traj, ff)
order = np.argsort(peaks.max_abs_tau_Nm)[::-1]
for i in order[:6]:
    print(f"  {peaks.joint_names[i]:18s} max |tau| {peaks.max_abs_tau_Nm[i]:.3f} N·m")

# On a multi-core machine, FeedForwardPool spreads long motions over worker processes
# with bit-identical results:
#     with FeedForwardPool() as pool: ff = torque_feedforward(robot, traj, pool=pool)
