"""03 — Generate one of the papers' motions and save it as CSV.

The built-in motions (`MOTIONS`) are the spring-compensation paper's experiments (CoM shift,
one-leg stand, squats, swings) and the hybrid-leg paper's stepping, scaled to the robot's leg
length. Each is a few keyframes that the whole-body IK interpolates sample by sample; what
the IK could not reach comes back as per-sample warnings, not as an exception.

    .venv/bin/python examples/03_paper_motion.py [OUT.csv]
"""

import sys
from pathlib import Path

import numpy as np

from app.core.motions.csv_files import read_trajectory_csv, write_trajectory_csv
from app.core.motions.library import MOTIONS, run_motion
from app.core.robot.loading import load_robot

robot = load_robot("servo_biped")
for spec in MOTIONS.values():
    print(f"{spec.name:15s} {spec.description}")

# One squat on the left leg at twice the paper's speed; dt is the sample step [s].
result = run_motion(robot, "one_leg_squats", dt=0.02, squats=1, speed=2.0)
traj = result.trajectory
print(f"\n{traj.name}: {traj.n_samples} samples over {traj.duration:.2f} s")
print(f"feet in contact (left, right) at the middle: {traj.contacts[traj.n_samples // 2]}")
for line in result.summary():  # the notes, then warnings grouped per keyframe
    print("note:", line)

# The pelvis's height [m] along the motion (q[:, 2]: the floating base's z).
print(f"pelvis z from {traj.q[:, 2].max():.3f} m down to {traj.q[:, 2].min():.3f} m")

# A motion CSV (what `biped-studio motion` writes and the studio opens); reading it back
# checks it against the robot.
out = Path(sys.argv[1]) if len(sys.argv) > 1 else None
if out is not None:
    write_trajectory_csv(traj, out, robot)
    again = read_trajectory_csv(out, robot)
    print(f"wrote {out}; read back equal: {np.allclose(again.q, traj.q, atol=1e-6)}")
