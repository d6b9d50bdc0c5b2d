"""Putting a robot down on a foot: the floating base moved rigidly so that one foot link sits
exactly at a given placement, joints unchanged."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from app.core.robot.model import RobotModel


def anchor_on_foot(
    robot: RobotModel,
    q: np.ndarray,
    foot_link: str,
    T_world_foot: np.ndarray,
    data: pin.Data,
    placed: pin.SE3 | None = None,
) -> np.ndarray:
    """A copy of q whose base is moved so that `foot_link` is at T_world_foot (4x4); `placed`:
    the foot's placement at q when already at hand (no forward kinematics then)."""
    out = np.array(q, dtype=float)
    if not robot.floating_base:
        return out
    current = placed
    if current is None:
        pin.framesForwardKinematics(robot.model, data, out)
        current = data.oMf[robot.link_frame_ids[foot_link]]
    correction = pin.SE3(T_world_foot) * current.inverse()
    out[:7] = pin.SE3ToXYZQUAT(correction * pin.XYZQUATToSE3(out[:7]))
    return out


def stance_link(robot: RobotModel, contacts: np.ndarray) -> str:
    """The foot a sample stands on: the only one in contact, the left one in double support
    (or with no contact at all, e.g. a flight phase)."""
    left, right = bool(contacts[0]), bool(contacts[1])
    return robot.feet[1].link if right and not left else robot.feet[0].link
