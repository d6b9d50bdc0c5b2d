"""Camera presets for comparing poses: the robot seen straight from its front or its side.

"Front" and "side" follow the robot's heading (the yaw of its floating base): the front camera
stands ahead of the pelvis on the robot's forward axis, the side camera on its right, both
level with the middle of the robot and far enough for its whole height to fit the view.
"""

from __future__ import annotations

import math

import numpy as np

from app.core.robot.model import RobotModel

PRESETS = ("front", "side")
MARGIN = 1.25
"""The robot's height fills 1/MARGIN of the view's height."""


def heading_rad(q: np.ndarray) -> float:
    """Yaw [rad] of the floating base (pinocchio layout, quaternion xyzw at q[3:7])."""
    x, y, z, w = (float(v) for v in q[3:7])
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def preset_view(
    robot: RobotModel, q: np.ndarray, which: str, fov_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """(camera position, look-at point) [m] in the world for preset `which` ("front": looking
    at the robot's face; "side": at its right side), with a vertical field of view fov_rad."""
    if which not in PRESETS:
        raise ValueError(f"camera preset {which!r}: give one of {', '.join(PRESETS)}")
    lower, upper = robot.bounds_m(q, robot.model.createData())
    height = max(float(upper[2] - min(float(lower[2]), 0.0)), 0.2)
    look_at = np.array(
        [0.5 * (lower[0] + upper[0]), 0.5 * (lower[1] + upper[1]), 0.5 * height], dtype=float
    )
    yaw = heading_rad(q) if robot.floating_base else 0.0
    forward = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    direction = forward if which == "front" else right
    depth = float(np.max(upper[:2] - lower[:2]))
    distance = MARGIN * 0.5 * height / math.tan(0.5 * min(max(fov_rad, 0.2), 2.5)) + depth
    return look_at + distance * direction, look_at
