"""A foot dragged as the gizmo drags it, for the posing tests: frame placements by pinocchio and
the left foot pulled straight up in small events; placo's own iteration of an IK problem (a drag
event, a motion's sample)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import placo

from app.core.posing.drag import Posing
from app.core.posing.ik import DAMPING_MIN, TORSO_WEIGHT, IkResult, IkTargets, WholeBodyIK
from app.core.posing.ik_records import COM_TARGET_WEIGHT
from app.core.robot.model import RobotModel
from app.core.robot.urdf_xml import canonical_urdf


def placement(bot: RobotModel, q: np.ndarray, link: str) -> pin.SE3:
    """World placement of `link` at `q`, by pinocchio's forward kinematics."""
    data = bot.model.createData()
    pin.framesForwardKinematics(bot.model, data, q)
    return data.oMf[bot.model.getFrameId(link, pin.BODY)].copy()


def drag_up(bot: RobotModel, lift_m: float, events: int = 30) -> tuple[IkResult, np.ndarray]:
    """The left foot dragged straight up by `lift_m` from standing in `events` gizmo events,
    let go at the last (explained, as the studio's release is: app.core.posing.drag): the
    last drag's result and its target (4 × 4)."""
    posing = Posing(bot)
    q = bot.q_neutral.copy()
    start = placement(bot, q, bot.foot("left").link).homogeneous
    for k in range(1, events + 1):
        target = start.copy()
        target[2, 3] += lift_m * k / events
        result = posing.drag(q, "left", target, explain=True if k == events else None)
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
    """placo alone on a drag event's problem: the left foot soft to `target`, the right held
    where it is at q_from, the torso held at `R_torso` (when given), the posture task towards
    `posture_q` (placo_solve_of)."""
    targets = IkTargets(T_world_left=target, stance="right", posture_q=posture_q)
    return placo_solve_of(bot, ik, q_from, dataclasses.replace(targets, R_world_torso=R_torso))


def placo_solve_of(
    bot: RobotModel,
    ik: WholeBodyIK,
    q_from: np.ndarray,
    targets: IkTargets,
    wrapper: placo.RobotWrapper | None = None,
) -> tuple[np.ndarray, int]:
    """placo alone on the problem `targets` set `ik`, no Python of ours in its loop: the stance
    feet hard at their targets (where they are at q_from when they have none), the other foot,
    the pelvis and the CoM's ground projection soft (weights 1, 1, COM_TARGET_WEIGHT), the torso
    held (TORSO_WEIGHT) when asked, the posture task towards targets.posture_q (the standing
    pose when None), damping, the CoM in the stance soles' polygon at q_from (`ik`'s weights
    and margin); QP steps from q_from applied until |dq| < 1e-11 (or 500): (configuration,
    iterations; a million when the QP is infeasible, the CoM starting outside the polygon,
    which the studio pulls in first). `wrapper`: placo's model of `bot` to reuse (made here when
    None: parsing the URDF costs more than a solve)."""
    wrapper = wrapper or placo.RobotWrapper("", 0, canonical_urdf(bot.tree))
    solver = placo.KinematicsSolver(wrapper)
    solver.enable_joint_limits(True)
    solver.enable_velocity_limits(False)
    solver.mask_fbase(not bot.floating_base)
    wrapper.state.q = q_from.copy()
    wrapper.update_kinematics()
    stance = ("left", "right") if targets.stance == "both" else (targets.stance,)
    for foot in bot.feet:
        given = targets.T_world_left if foot.side == "left" else targets.T_world_right
        task = solver.add_frame_task(foot.link, np.eye(4))
        if foot.side in stance:
            task.configure(foot.side, "hard", 1.0, 1.0)
            task.T_world_frame = wrapper.get_T_world_frame(foot.link) if given is None else given
        elif given is not None:
            task.configure(foot.side, "soft", 1.0, 1.0)
            task.T_world_frame = given
    if targets.T_world_pelvis is not None:
        pelvis = solver.add_frame_task(bot.tree.root, np.eye(4))
        pelvis.configure("pelvis", "soft", 1.0, 1.0)
        pelvis.T_world_frame = targets.T_world_pelvis
    elif targets.R_world_torso is not None:
        torso = solver.add_orientation_task(bot.tree.root, np.eye(3))
        torso.configure("torso", "soft", TORSO_WEIGHT)
        torso.R_world_frame = targets.R_world_torso
    if targets.com_xy is not None:
        com = solver.add_com_task(np.array([*np.asarray(targets.com_xy)[:2], 0.0]))
        com.mask.set_axises("xy")
        com.configure("com target", "soft", COM_TARGET_WEIGHT)
    posture_q = bot.q_neutral if targets.posture_q is None else targets.posture_q
    posture = solver.add_joints_task()
    posture.configure("posture", "soft", ik.posture_weight)
    posture.set_joints(
        {j.name: float(posture_q[j.idx_q]) for j in bot.joints if j.kind != "continuous"}
    )
    solver.add_regularization_task(DAMPING_MIN)
    polygon = ik.support_polygon(q_from, targets.stance)[::-1]  # placo wants it clockwise
    constraint = solver.add_com_polygon_constraint([np.array(p) for p in polygon], ik.com_margin_m)
    constraint.configure("com polygon", "hard", 1.0)
    for iterations in range(1, 501):  # noqa: B007 - returned
        try:
            dq = solver.solve(True)
        except RuntimeError:  # the CoM outside the polygon at the start: infeasible
            return q_from, 10**6
        wrapper.update_kinematics()
        if np.linalg.norm(dq) < 1e-11:
            break
    return wrapper.state.q.copy(), iterations
