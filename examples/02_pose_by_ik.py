"""02 — Pose the robot by whole-body IK.

`WholeBodyIK` (placo) moves frames to targets while the stance feet stay put and the centre
of mass stays over the support polygon. We start from the ready pose (knees bent: a straight
leg is singular), then lift the right foot 3 cm while standing on the left one.

    .venv/bin/python examples/02_pose_by_ik.py
"""

import numpy as np

from app.core.posing.ik import IkTargets, WholeBodyIK
from app.core.posing.ready_pose import ready_pose
from app.core.robot.loading import load_robot

robot = load_robot("servo_biped")
ik = WholeBodyIK(robot)  # one solver per robot (not thread-safe)

ready = ready_pose(robot, ik)
print(f"ready pose: leg length {ready.leg_length_m:.3f} m, pelvis at z = {ready.q[2]:.3f} m")

# Where the right foot is now (a 4x4 placement in the world), and 3 cm higher.
data = robot.model.createData()  # pinocchio's workspace for forward kinematics
T_world_right = robot.link_placements(ready.q, data)[robot.foot("right").link]
T_target = T_world_right.copy()
T_target[2, 3] += 0.03

# Stand on the left foot: it is held; the right foot follows its (soft) target. The CoM
# must first move over the left sole, which the IK does (com_in_support is on by default);
# posture_q keeps what the targets leave free (the knees' bend) near the ready pose.
targets = IkTargets(T_world_right=T_target, stance="left", posture_q=ready.q)
result = ik.solve(ready.q, targets, max_iterations=200)

lifted = robot.link_placements(result.q, data)[robot.foot("right").link]
print(f"reached: {result.reached} after {result.iterations} iterations")
print(f"right foot raised by {1000 * (lifted[2, 3] - T_world_right[2, 3]):.1f} mm")
print(f"CoM margin inside the left sole: {1000 * result.com_margin_m:.1f} mm")
for line in result.shortfall:  # empty when reached: otherwise why the pose falls short
    print("short:", line)

# Joint angles [rad] in the robot's joint order (what a servo is sent, before compensation).
angles = np.degrees(robot.joint_angles(result.q))
print(", ".join(f"{name} {a:+.1f}°" for name, a in zip(robot.joint_names, angles, strict=True)))
