"""A copy of a robot's pinocchio model with frames at each sole's heel and toe mid-points.

These are the gait planner's contact points, built here from the sole corners alone so that
tests check the planner's solutions with pinocchio, not with the planner's own functions.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def model_with_sole_edge_frames(robot) -> tuple[pin.Model, pin.Data, list[int]]:
    """(model, data, frame ids of left heel, left toe, right heel, right toe) for `robot`
    (a RobotModel), feet in the robot's order."""
    model = robot.model.copy()
    frame_ids = []
    for foot in robot.feet:
        sole = model.frames[robot.link_frame_ids[foot.link]]
        corners = foot.sole_corners_m
        rear = corners[np.isclose(corners[:, 0], corners[:, 0].min())].mean(axis=0)
        front = corners[np.isclose(corners[:, 0], corners[:, 0].max())].mean(axis=0)
        for name, point in (("heel", rear), ("toe", front)):
            frame = pin.Frame(
                f"{foot.side}_{name}_check",
                sole.parentJoint,
                sole.placement * pin.SE3(np.eye(3), point),
                pin.FrameType.OP_FRAME,
            )
            frame_ids.append(model.addFrame(frame))
    return model, model.createData(), frame_ids


def planar_contact_jacobian(planar, full, q: np.ndarray) -> np.ndarray:
    """The sole points' world x and z rows of pinocchio's frame Jacobians, mapped to the planar
    velocities through the planar model's G: shape (2 · points, planar nv), the planar
    contact Jacobian's layout. `full` is `model_with_sole_edge_frames`'s answer."""
    model, data, frame_ids = full
    pin.computeJointJacobians(model, data, planar.to_full_q(q))
    pin.updateFramePlacements(model, data)
    G = planar.velocity_map(q)
    return np.vstack(
        [
            pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[[0, 2]] @ G
            for fid in frame_ids
        ]
    )
