"""Close declared kinematic loops by solving for the passive joints (Gauss-Newton).

For every <loop_closure>, the origins of link_a and link_b must coincide:
r(q) = p_a(q) - p_b(q) = 0. With the actuated joints and the base fixed, the passive joint
coordinates are updated by damped least squares on the stacked residual,
dq_p = -(J_p^T J_p + λ I)^{-1} J_p^T r, with J_p the columns of dr/dv for the passive joints.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from app.core.robot.model import RobotModel

DAMPING = 1e-10
TOLERANCE_M = 1e-10


@dataclasses.dataclass(frozen=True)
class LoopClosure:
    q: np.ndarray
    """Configuration with the passive joints solved."""
    residual_m: float
    """Largest remaining gap between the two sides of any loop [m]."""
    iterations: int


def loop_residual(robot: RobotModel, q: np.ndarray, data: pin.Data) -> np.ndarray:
    """Stacked p_a - p_b [m] of every declared loop, shape (3 * n_loops,)."""
    pin.framesForwardKinematics(robot.model, data, q)
    gaps = [
        data.oMf[robot.link_frame_ids[loop.link_a]].translation
        - data.oMf[robot.link_frame_ids[loop.link_b]].translation
        for loop in robot.tree.loops
    ]
    return np.concatenate(gaps) if gaps else np.zeros(0)


def close_loops(
    robot: RobotModel, q: np.ndarray, data: pin.Data, max_iterations: int = 30
) -> LoopClosure:
    """Solve the passive joints so every declared loop closes; other coordinates stay as given."""
    q = np.array(q, dtype=float)
    if not robot.tree.loops:
        return LoopClosure(q, 0.0, 0)
    model = robot.model
    passive_v = [model.joints[model.getJointId(name)].idx_v for name in robot.passive_joints]
    passive_q = [model.joints[model.getJointId(name)].idx_q for name in robot.passive_joints]
    residual = loop_residual(robot, q, data)
    iterations = 0
    for iterations in range(1, max_iterations + 1):  # noqa: B007 - the count is reported
        if np.abs(residual).max() < TOLERANCE_M:
            break
        pin.computeJointJacobians(model, data, q)
        rows = []
        for loop in robot.tree.loops:
            J_a = pin.getFrameJacobian(
                model, data, robot.link_frame_ids[loop.link_a], pin.LOCAL_WORLD_ALIGNED
            )
            J_b = pin.getFrameJacobian(
                model, data, robot.link_frame_ids[loop.link_b], pin.LOCAL_WORLD_ALIGNED
            )
            rows.append((J_a - J_b)[:3, passive_v])
        J = np.vstack(rows)
        step = -np.linalg.solve(J.T @ J + DAMPING * np.eye(J.shape[1]), J.T @ residual)
        q[passive_q] += step
        residual = loop_residual(robot, q, data)
    return LoopClosure(q, float(np.abs(residual).max()), iterations)
