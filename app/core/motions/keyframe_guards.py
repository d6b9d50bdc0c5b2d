"""The checks on each sample of a keyframed motion (app.core.motions.keyframes): which feet are
in contact, which IK shortfalls are reported, and the guards that keep a standing foot from
sliding (re-solved without the CoM target, re-planted after a speed-limited step, or the
previous pose kept).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from app.core.motions.continuity import limit_joint_steps
from app.core.posing.ik import REACHED_M, REACHED_RAD, IkResult, IkTargets, Stance, WholeBodyIK
from app.core.robot.model import RobotModel

CONTACT_BAND_M = 1e-3
"""A non-stance foot whose sole is this close to the ground counts as in contact."""
STANCE_SLIDE_M = 5e-4
"""A sample whose stance feet are further than this from where they stood at the start of
the segment is re-solved (see _keep_stance)."""
REPORT_M, REPORT_RAD = 2e-3, np.deg2rad(1.0)
assert REPORT_M >= REACHED_M and REPORT_RAD >= REACHED_RAD  # a reached target is not reported
"""A pelvis or moving-foot target missed by less than this is not reported: between
keyframes the interpolated targets are not exactly consistent with each other (only the
keyframes are), and the IK's compromise can leave ~1 mm."""
SOLVE_ITERATIONS = 20
"""IK iterations per sample at most (warm-started, it converges in a few)."""


def _contacts(robot: RobotModel, placed: dict[str, np.ndarray], stance: Stance) -> np.ndarray:
    """(left, right): stance feet, and feet whose sole is within CONTACT_BAND_M of z = 0
    (`placed`: the feet's placements at the sample, by side, 4x4)."""
    flags = np.zeros(2, dtype=bool)
    for i, foot in enumerate(robot.feet):
        if stance in (foot.side, "both"):
            flags[i] = True
            continue
        T = placed[foot.side]
        lowest = float((foot.sole_corners_m @ T[2, :3]).min() + T[2, 3])
        flags[i] = lowest <= CONTACT_BAND_M
    return flags


def _shortfalls(
    robot: RobotModel,
    placed: dict[str, np.ndarray],
    targets: IkTargets,
    result: IkResult,
    q: np.ndarray,
) -> list[str]:
    """The IK's warnings, with its reach check redone (REPORT_M, REPORT_RAD) for the moving
    feet and the pelvis, whose horizontal position yields to a CoM target (not reported then).
    The IK's own reach message is recognised by its wording. `placed`: the placements of the
    feet and pelvis at q, the sample kept; when that is the IK's own answer, its measures of the
    feet and of a pelvis without a CoM target are the same numbers and are reused (and the
    pelvis's turn)."""
    measured = q is result.q
    if measured and result.reached and not result.warnings:
        return []  # every target within REACHED_M and REACHED_RAD: inside REPORT_M, REPORT_RAD
    messages = [m for m in result.warnings if " target out of reach: closest pose" not in m]
    stance = ("left", "right") if targets.stance == "both" else (targets.stance,)
    for label, T_target in (
        ("left", targets.T_world_left),
        ("right", targets.T_world_right),
        ("pelvis", targets.T_world_pelvis),
    ):
        if T_target is None or label in stance:
            continue
        if measured and (label != "pelvis" or targets.com_xy is None):
            distance = result.position_error_m[label]
            angle = result.orientation_error_rad[label]
        else:
            T = placed[label]
            miss = T[:3, 3] - T_target[:3, 3]
            if label == "pelvis" and targets.com_xy is not None:
                miss[:2] = 0.0
            if measured:
                angle = result.orientation_error_rad[label]
            else:
                turn = pin.log3(T_target[:3, :3].T @ T[:3, :3])
                angle = math.sqrt(float(turn.dot(turn)))
            distance = math.sqrt(float(miss.dot(miss)))
        if distance >= REPORT_M or angle >= REPORT_RAD:
            messages.append(
                f"{label} target out of reach: closest pose is {distance * 1000:.1f} mm, "
                f"{np.rad2deg(angle):.1f}° away"
            )
    return messages


def _placed(robot: RobotModel, data: pin.Data, q: np.ndarray) -> dict[str, np.ndarray]:
    """Placements of the feet ("left", "right") and the pelvis at q, 4x4 (`data`: pinocchio
    data to compute in)."""
    pin.framesForwardKinematics(robot.model, data, q)
    ids = robot.link_frame_ids
    placed = {foot.side: data.oMf[ids[foot.link]].homogeneous for foot in robot.feet}
    placed["pelvis"] = data.oMf[ids[robot.tree.root]].homogeneous
    return placed


def _keep_stance(
    ik: WholeBodyIK,
    q: np.ndarray,
    targets: IkTargets,
    result: IkResult,
    com_in_support: bool,
) -> tuple[IkResult, list[str]]:
    """Make sure a sample does not slide a stance foot from where it stood at the start of
    the segment. When the IK's compromise with an unreachable CoM target moves a held foot
    (its hold is a heavy soft task), the sample is solved again without the CoM target; if a
    foot still slides, the previous pose is kept."""
    slid = _held_miss_m(result, targets.stance)
    if slid <= STANCE_SLIDE_M:
        return result, []
    message = f"the CoM target would slide a standing foot {slid * 1000:.1f} mm"
    if targets.com_xy is not None:
        retry = ik.solve(
            q,
            dataclasses.replace(targets, com_xy=None),
            com_in_support=com_in_support,
            max_iterations=SOLVE_ITERATIONS,
        )
        if _held_miss_m(retry, targets.stance) <= STANCE_SLIDE_M:
            return retry, [f"{message}: solved without it"]
    kept = dataclasses.replace(result, q=q, placements={})  # placements: of the pose refused
    return kept, [f"{message}: the previous pose is kept"]


def _continuous(
    robot: RobotModel,
    ik: WholeBodyIK,
    q_prev: np.ndarray,
    q_new: np.ndarray,
    start: dict[str, np.ndarray],
    targets: IkTargets,
    dt: float,
    com_in_support: bool,
    scratch: pin.Data,
) -> tuple[np.ndarray, str | None]:
    """q_new with no joint faster than its limit (app.core.motions.continuity). When the
    scaled step slides a stance foot, the standing feet are re-planted by the IK around the
    scaled pose (its pelvis and free foot as targets) and the step scaled again, up to three
    times; if a foot still slides, the previous pose is kept. Returns the flag, if any."""
    q, jump = limit_joint_steps(robot, q_prev, q_new, dt)
    if jump is None:
        return q, None
    for _ in range(3):
        if _slide_m(robot, scratch, start, q, targets.stance) <= STANCE_SLIDE_M:
            return q, jump
        # re-plant the standing feet, keeping the scaled pose's pelvis and free foot
        where = _where(robot, q, robot.model.createData())
        held = {
            side: start[side] if targets.stance in (side, "both") else where[side]
            for side in ("left", "right")
        }
        fix = IkTargets(held["left"], held["right"], where["pelvis"], None, targets.stance)
        solved = ik.solve(q, fix, com_in_support=com_in_support, max_iterations=SOLVE_ITERATIONS)
        q, _ = limit_joint_steps(robot, q_prev, solved.q, dt)
    if _slide_m(robot, scratch, start, q, targets.stance) <= STANCE_SLIDE_M:
        return q, jump
    return q_prev.copy(), f"{jump}; it would slide a standing foot: the previous pose is kept"


def _held_miss_m(result: IkResult, stance: Stance) -> float:
    """How far the stance feet are from their targets in an IK result [m]: during a
    segment their targets are where they stood at its start, so this is _slide_m at result.q,
    measured by the IK's own final forward kinematics."""
    sides = ("left", "right") if stance == "both" else (stance,)
    return max(result.position_error_m[side] for side in sides)


def _slide_m(
    robot: RobotModel,
    scratch: pin.Data,
    start: dict[str, np.ndarray],
    q: np.ndarray,
    stance: Stance,
) -> float:
    """How far the stance feet are at q from where they were at the segment's start [m]
    (`scratch`: pinocchio data to compute in; only the stance feet's frames are placed)."""
    pin.forwardKinematics(robot.model, scratch, q)
    return max(
        float(
            np.linalg.norm(
                pin.updateFramePlacement(
                    robot.model, scratch, robot.link_frame_ids[foot.link]
                ).translation
                - start[foot.side][:3, 3]
            )
        )
        for foot in robot.feet
        if stance in (foot.side, "both")
    )


def _where(robot: RobotModel, q: np.ndarray, data: pin.Data) -> dict[str, np.ndarray]:
    """Placements of the feet ("left", "right") and pelvis, and the CoM's xy ("com"), at q."""
    placements = robot.link_placements(q, data)
    return {
        "left": placements[robot.foot("left").link],
        "right": placements[robot.foot("right").link],
        "pelvis": placements[robot.tree.root],
        "com": robot.com(q, data)[:2],
    }
