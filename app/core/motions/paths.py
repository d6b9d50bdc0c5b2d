"""Task-space paths of a trajectory: where the feet and the CoM go (for traces and tests)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel


def task_space_paths(robot: RobotModel, trajectory: Trajectory) -> dict[str, np.ndarray]:
    """World positions [m], shape (T, 3), of "left" and "right" (sole centres) and "com"."""
    data = robot.model.createData()
    out = {
        "left": np.empty((trajectory.n_samples, 3)),
        "right": np.empty((trajectory.n_samples, 3)),
    }
    out["com"] = np.empty((trajectory.n_samples, 3))
    centres = {foot.side: foot.sole_corners_m.mean(axis=0) for foot in robot.feet}
    ids = {foot.side: robot.link_frame_ids[foot.link] for foot in robot.feet}
    for k, q in enumerate(trajectory.q):
        pin.framesForwardKinematics(robot.model, data, q)
        for side in ("left", "right"):
            placement = data.oMf[ids[side]]
            out[side][k] = placement.rotation @ centres[side] + placement.translation
        out["com"][k] = pin.centerOfMass(robot.model, data, q, False)
    return out
