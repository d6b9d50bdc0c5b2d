"""Drag posing keeps the pose the user built: moving a foot moves its leg, the rest stays near
where it was; snapping feet that are already flat changes nothing."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.posing.drag import Posing
from app.core.posing.ready_pose import ready_pose
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF, SIGMABAN_URDF

FEW_DEG = 6.0
"""What "near where it was" allows [°] for a joint the drag does not need."""


def _leg_joints(robot, side):
    """Actuated joints on the path from a foot up to the root (names)."""
    names, link = [], robot.foot(side).link
    while (joint := robot.tree.parent_joint(link)) is not None:
        if joint.name in robot.joint_names:
            names.append(joint.name)
        link = joint.parent
    return names


def _joints_off_the_legs(robot):
    """Actuated joints on neither leg's path to the root (arms, head, a waist)."""
    legs = set(_leg_joints(robot, "left")) | set(_leg_joints(robot, "right"))
    return [joint for joint in robot.joint_names if joint not in legs]


@pytest.mark.parametrize("name", ["servo_biped", "sigmaban", "roban"])
def test_lifting_a_foot_from_the_ready_pose_moves_only_the_legs(name):
    """The legs lift the foot (the stance leg carries the CoM over its sole and shares the
    lift, the torso held upright); arms, head and waist stay where they were, and no hip
    yaw twists (the fold of issue 23). Roban S14's ±15° ankle rolls stop the upright lift
    short of 5 cm: its result says so and names the ankle roll (pinocchio confirms the
    limit); its arms swing to carry the CoM (the light posture task lets them), so only the
    honesty of its result is checked."""
    source = {"roban": str(ROBAN_URDF), "sigmaban": str(SIGMABAN_URDF)}.get(name, name)
    robot = load_robot(source)
    q = ready_pose(robot).q
    T = robot.link_placements(q, robot.model.createData())[robot.foot("left").link]
    T[2, 3] += 0.05
    result = Posing(robot).drag(q, "left", T)
    if name == "roban":
        assert not result.reached
        named = [line for line in result.shortfall if "leg_l6_joint at its lower limit" in line]
        assert named, result.shortfall
        angle = robot.joint_angles(result.q)[robot.joint_names.index("leg_l6_joint")]
        assert angle - robot.joints[robot.joint_names.index("leg_l6_joint")].lower < 1e-3
        return
    assert result.reached, result.shortfall
    change = np.rad2deg(np.abs(robot.joint_angles(result.q) - robot.joint_angles(q)))
    watched = set(_joints_off_the_legs(robot)) | {
        joint for joint in robot.joint_names if "hip_yaw" in joint
    }
    assert len(watched) >= 2
    moved = {
        joint: float(c)
        for joint, c in zip(robot.joint_names, change, strict=True)
        if joint in watched and c > FEW_DEG
    }
    assert moved == {}


def test_snapping_flat_feet_keeps_the_pose():
    robot = load_robot("servo_biped")
    q = ready_pose(robot).q
    result = Posing(robot).snap_feet_to_ground(q)
    np.testing.assert_allclose(
        robot.joint_angles(result.q), robot.joint_angles(q), atol=np.deg2rad(0.5)
    )


def test_a_sole_without_area_gives_a_thin_polygon_not_an_error():
    """Points on a line (a foot whose geometry is missing): a strip around them."""
    from app.core.posing.support_polygon import DEGENERATE_PAD_M, convex_polygon

    line = np.array([[0.0, 0.0], [0.1, 0.0], [0.05, 0.0]])
    polygon = convex_polygon(line)
    assert np.ptp(polygon[:, 0]) == pytest.approx(0.1 + 2 * DEGENERATE_PAD_M)
    assert np.ptp(polygon[:, 1]) == pytest.approx(2 * DEGENERATE_PAD_M)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]])
    assert len(convex_polygon(square)) == 4  # a proper hull is untouched
