"""A foot dragged as the gizmo drags it, for the posing tests: frame placements by pinocchio and
the left foot pulled straight up in small events; placo's own iteration of a drag event."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import placo

from app.core.posing.drag import Posing
from app.core.posing.ik import DAMPING_MIN, TORSO_WEIGHT, IkResult, WholeBodyIK
from app.core.robot.model import RobotModel
from app.core.robot.urdf_xml import canonical_urdf


def placement(bot: RobotModel, q: np.ndarray, link: str) -> pin.SE3:
    """World placement of `link` at `q`, by pinocchio's forward kinematics."""
    data = bot.model.createData()
    pin.framesForwardKinematics(bot.model, data, q)
    return data.oMf[bot.model.getFrameId(link, pin.BODY)].copy()


def drag_up(bot: RobotModel, lift_m: float, events: int = 30) -> tuple[IkResult, np.ndarray]:
    """The left foot dragged straight up by `lift_m` from standing in `events` gizmo events:
    the last drag's result and its target (4 × 4)."""
    posing = Posing(bot)
    q = bot.q_neutral.copy()
    start = placement(bot, q, bot.foot("left").link).homogeneous
    for k in range(1, events + 1):
        target = start.copy()
        target[2, 3] += lift_m * k / events
        result = posing.drag(q, "left", target)
        q = result.q
    return result, target


def placo_fixed_point(
    bot: RobotModel,
    ik: WholeBodyIK,
    q_from: np.ndarray,
    target: np.ndarray,
    posture_q: np.ndarray,
    R_torso: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """placo alone on a drag event's problem, no Python of ours in its loop: the left foot soft
    to `target`, the right held hard, the torso held at `R_torso` (when given), the posture
    task towards `posture_q`, damping, the CoM in the right sole's polygon (`ik`'s weights and
    margin); QP steps from q_from applied until |dq| < 1e-11 (or 500): (configuration,
    iterations; a million when the QP is infeasible, the CoM starting outside the polygon,
    which the studio pulls in first)."""
    wrapper = placo.RobotWrapper("", 0, canonical_urdf(bot.tree))
    solver = placo.KinematicsSolver(wrapper)
    solver.enable_joint_limits(True)
    solver.enable_velocity_limits(False)
    solver.mask_fbase(not bot.floating_base)
    left, right = (foot.link for foot in bot.feet)
    left_task = solver.add_frame_task(left, np.eye(4))
    left_task.configure("left", "soft", 1.0, 1.0)
    right_task = solver.add_frame_task(right, np.eye(4))
    right_task.configure("right", "hard", 1.0, 1.0)
    if R_torso is not None:
        torso = solver.add_orientation_task(bot.tree.root, np.eye(3))
        torso.configure("torso", "soft", TORSO_WEIGHT)
        torso.R_world_frame = R_torso
    posture = solver.add_joints_task()
    posture.configure("posture", "soft", ik.posture_weight)
    posture.set_joints(
        {j.name: float(posture_q[j.idx_q]) for j in bot.joints if j.kind != "continuous"}
    )
    solver.add_regularization_task(DAMPING_MIN)
    polygon = ik.support_polygon(q_from, "right")[::-1]  # placo wants it clockwise
    constraint = solver.add_com_polygon_constraint([np.array(p) for p in polygon], ik.com_margin_m)
    constraint.configure("com polygon", "hard", 1.0)
    wrapper.state.q = q_from.copy()
    wrapper.update_kinematics()
    right_task.T_world_frame = wrapper.get_T_world_frame(right)
    left_task.T_world_frame = target
    for iterations in range(1, 501):  # noqa: B007 - returned
        try:
            dq = solver.solve(True)
        except RuntimeError:  # the CoM outside the polygon at the start: infeasible
            return q_from, 10**6
        wrapper.update_kinematics()
        if np.linalg.norm(dq) < 1e-11:
            break
    return wrapper.state.q.copy(), iterations
