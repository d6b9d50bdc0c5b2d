"""The ready pose: knees bent, pelvis lowered, feet flat where they stand.

A straight leg is a kinematic singularity: the pelvis cannot be lowered to first order, so an
IK started there does not move (or twists the legs). Motions therefore start from the ready
pose: the pelvis READY_CROUCH of the leg length below standing, upright, feet at their
standing placements. The knee of each leg is found from the kinematics, not from names: the
actuated joint whose small rotation shortens the hip-to-foot distance most; it is bent by
KNEE_KICK_RAD (so that the foot goes backwards) before the IK solves the pose.

`crouch` does the same from any pose (feet where they are, the torso as it was): drag posing
starts a foot drag from it when the moving leg is straight.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

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
    return crouch(
        robot, robot.q_neutral, ik or WholeBodyIK(robot, posture_weight=MOTION_POSTURE_WEIGHT)
    )


def crouch(
    robot: RobotModel, q: np.ndarray, ik: WholeBodyIK, stance: Literal["left", "both"] = "left"
) -> ReadyPose:
    """q with the knees of its straight legs bent and the pelvis lowered by READY_CROUCH of
    the leg length, the pelvis's orientation and both feet where they are at q: the left
    foot held, the right one a soft target (the ready pose's way), or (stance "both") both
    held, so that neither moves by a hair."""
    if not robot.floating_base:
        raise PoseError(
            f"robot {robot.name!r} is fixed to the world; the motions move a floating base"
        )
    data = robot.model.createData()
    leg = leg_length_m(robot)
    bent_q = np.array(q, dtype=float)
    for side in ("left", "right"):
        bent_q = _bend_knee(robot, bent_q, side)
    # Put the bent robot back on its left foot, then straighten the rest with the IK.
    placed = robot.link_placements(q, data)
    bent = robot.link_placements(bent_q, data)
    left = robot.foot("left").link
    T_world_base = placed[left] @ np.linalg.inv(bent[left]) @ bent[robot.tree.root]
    bent_q[:3] = T_world_base[:3, 3]
    bent_q[3:7] = pin.Quaternion(T_world_base[:3, :3]).coeffs()
    pelvis = placed[robot.tree.root].copy()
    pelvis[2, 3] -= READY_CROUCH * leg
    targets = IkTargets(
        T_world_right=placed[robot.foot("right").link], T_world_pelvis=pelvis, stance=stance
    )
    result = ik.solve(bent_q, targets, com_in_support=False, max_iterations=POSE_ITERATIONS)
    return ReadyPose(result.q, leg, result.warnings)


def leg_length_m(robot: RobotModel) -> float:
    """Mean height [m] of the legs' top joints above the ground when standing."""
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, robot.q_neutral)
    hips = [_leg_chain(robot, side)[0] for side in ("left", "right")]
    return float(np.mean([data.oMi[jid].translation[2] for jid in hips]))


def leg_is_straight(robot: RobotModel, q: np.ndarray, side: str) -> bool:
    """Whether a leg's knee is within STRAIGHT_LEG of its length of the hip-foot line at q
    (a singular leg: bending its knee does not shorten it to first order)."""
    return _knee(robot, q, side)[1]


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


def _knee(robot: RobotModel, q: np.ndarray, side: str) -> tuple[int, bool]:
    """(pinocchio id of the knee of one leg: the joint whose small rotation shortens the
    hip-to-foot distance most, whether the leg is straight at q)."""
    model, data = robot.model, robot.model.createData()
    chain = _leg_chain(robot, side)
    foot = robot.link_frame_ids[robot.foot(side).link]

    def hip_to_foot(jid: int, angle: float) -> float:
        q_try = np.array(q, dtype=float)
        q_try[model.joints[jid].idx_q] += angle
        pin.framesForwardKinematics(model, data, q_try)
        return float(np.linalg.norm(data.oMf[foot].translation - data.oMi[chain[0]].translation))

    knee = min(chain, key=lambda j: min(hip_to_foot(j, s * 0.05) for s in (1, -1)))
    pin.framesForwardKinematics(model, data, q)
    hip, at_knee = data.oMi[chain[0]].translation, data.oMi[knee].translation
    axis = data.oMf[foot].translation - hip
    off_line = np.linalg.norm(np.cross(axis, at_knee - hip)) / np.dot(axis, axis)
    return knee, bool(off_line <= STRAIGHT_LEG)


def _bend_knee(robot: RobotModel, q: np.ndarray, side: str) -> np.ndarray:
    """q with the knee of one leg bent by KNEE_KICK_RAD (inside its limits), foot backwards,
    if the leg is straight; else q."""
    knee, straight = _knee(robot, q, side)
    if not straight:
        return q  # already bent: not singular
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
    i = model.joints[knee].idx_q
    lower, upper = model.lowerPositionLimit[i], model.upperPositionLimit[i]
    options = []
    for sign in (1.0, -1.0):
        angle = float(np.clip(q[i] + sign * KNEE_KICK_RAD, lower, upper)) - q[i]
        if abs(angle) > 1e-3:
            options.append((hip_to_foot(bent(knee, angle))[1] - x0, angle))
    return bent(knee, min(options)[1]) if options else q
