"""The ready pose: knees bent, pelvis lowered, feet flat where they stand.

A straight leg is a kinematic singularity: the pelvis cannot be lowered to first order, so an
IK started there does not move (or twists the legs). Motions therefore start from the ready
pose: the pelvis READY_CROUCH of the leg length below standing, upright, feet at their
standing placements. The knee of each leg is found from the kinematics, not from names: the
actuated joint whose small rotation shortens the hip-to-foot distance most; it is bent by
KNEE_KICK_RAD (so that the foot goes backwards) before the IK solves the pose.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from app.core.errors import StudioError
from app.core.posing.ik import IkTargets, WholeBodyIK
from app.core.robot.model import RobotModel

READY_CROUCH = 0.05
"""Pelvis lowered by this fraction of the leg length in the ready pose."""
KNEE_KICK_RAD = 0.5
"""Knee bend the ready-pose solve starts from (the IK then finds the knee angle itself)."""
STRAIGHT_LEG = 0.1
"""A leg whose knee is closer than this fraction of its length to the hip-foot line is
treated as straight (and its knee bent before the solve)."""
POSE_ITERATIONS = 200
MOTION_POSTURE_WEIGHT = 1e-7
"""Posture weight of the IK that makes motions. The studio's default (1e-5, for drag posing)
leaves soft targets ~0.3 mm off on servo_biped (the posture task pulls towards straight
legs); motions need their keyframes met to a few µm."""


class PoseError(StudioError):
    """A pose that cannot be made for this robot (a fixed base, a leg without joints)."""


@dataclasses.dataclass(frozen=True)
class ReadyPose:
    q: np.ndarray
    leg_length_m: float
    """Mean hip height (top joint of each leg) above the soles when standing [m]."""
    warnings: tuple[str, ...]
    """The IK's, if the ready pose is not reached."""


def ready_pose(robot: RobotModel, ik: WholeBodyIK | None = None) -> ReadyPose:
    """The ready pose of a floating-base robot (module docstring)."""
    if not robot.floating_base:
        raise PoseError(
            f"robot {robot.name!r} is fixed to the world; the motions move a floating base"
        )
    data = robot.model.createData()
    q = robot.q_neutral.copy()
    hips = [_leg_chain(robot, side)[0] for side in ("left", "right")]
    pin.forwardKinematics(robot.model, data, q)
    leg = float(np.mean([data.oMi[jid].translation[2] for jid in hips]))
    for side in ("left", "right"):
        q = _bend_knee(robot, q, side)
    # Put the bent robot back on its left foot, then straighten the rest with the IK.
    standing = robot.link_placements(robot.q_neutral, data)
    bent = robot.link_placements(q, data)
    left = robot.foot("left").link
    T_world_base = standing[left] @ np.linalg.inv(bent[left]) @ bent[robot.tree.root]
    q[:3] = T_world_base[:3, 3]
    q[3:7] = pin.Quaternion(T_world_base[:3, :3]).coeffs()
    pelvis = standing[robot.tree.root].copy()
    pelvis[2, 3] -= READY_CROUCH * leg
    targets = IkTargets(
        T_world_right=standing[robot.foot("right").link], T_world_pelvis=pelvis, stance="left"
    )
    ik = ik or WholeBodyIK(robot, posture_weight=MOTION_POSTURE_WEIGHT)
    result = ik.solve(q, targets, com_in_support=False, max_iterations=POSE_ITERATIONS)
    return ReadyPose(result.q, leg, result.warnings)


def _leg_chain(robot: RobotModel, side: str) -> list[int]:
    """pinocchio ids of the actuated 1-DOF joints from the hip down to a foot (joints that
    also move the other foot, like a waist, are not part of the leg)."""
    model = robot.model
    actuated = {joint.name for joint in robot.joints if joint.kind != "continuous"}

    def ancestors(foot_side: str) -> list[int]:
        jid = model.frames[robot.link_frame_ids[robot.foot(foot_side).link]].parentJoint
        out = []
        while jid > 0:
            out.append(jid)
            jid = model.parents[jid]
        return out

    shared = set(ancestors("left")) & set(ancestors("right"))
    chain = [j for j in ancestors(side) if j not in shared and model.names[j] in actuated]
    if not chain:
        raise PoseError(f"robot {robot.name!r}: no actuated joint moves the {side} foot")
    return chain[::-1]


def _bend_knee(robot: RobotModel, q: np.ndarray, side: str) -> np.ndarray:
    """q with the knee of one leg bent by KNEE_KICK_RAD (inside its limits), foot backwards."""
    model, data = robot.model, robot.model.createData()
    chain = _leg_chain(robot, side)
    foot = robot.link_frame_ids[robot.foot(side).link]
    root = robot.link_frame_ids[robot.tree.root]

    def hip_to_foot(q_try: np.ndarray) -> tuple[float, float]:
        """(distance from the hip to the foot [m], foot x in the pelvis frame [m])."""
        pin.framesForwardKinematics(model, data, q_try)
        hip = data.oMi[chain[0]].translation
        p = data.oMf[foot].translation
        x = (data.oMf[root].inverse() * pin.SE3(np.eye(3), p)).translation[0]
        return float(np.linalg.norm(p - hip)), float(x)

    def bent(jid: int, angle: float) -> np.ndarray:
        q_try = q.copy()
        q_try[model.joints[jid].idx_q] += angle
        return q_try

    x0 = hip_to_foot(q)[1]
    knee = min(chain, key=lambda j: min(hip_to_foot(bent(j, s * 0.05))[0] for s in (1, -1)))
    pin.forwardKinematics(model, data, q)
    hip, at_knee = data.oMi[chain[0]].translation, data.oMi[knee].translation
    axis = data.oMf[foot].translation - hip
    off_line = np.linalg.norm(np.cross(axis, at_knee - hip)) / np.dot(axis, axis)
    if off_line > STRAIGHT_LEG:
        return q  # already bent: not singular
    i = model.joints[knee].idx_q
    lower, upper = model.lowerPositionLimit[i], model.upperPositionLimit[i]
    options = []
    for sign in (1.0, -1.0):
        angle = float(np.clip(q[i] + sign * KNEE_KICK_RAD, lower, upper)) - q[i]
        if abs(angle) > 1e-3:
            options.append((hip_to_foot(bent(knee, angle))[1] - x0, angle))
    return bent(knee, min(options)[1]) if options else q
