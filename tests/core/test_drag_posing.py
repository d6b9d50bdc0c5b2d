"""Drag posing keeps the pose the user built: moving a foot moves its leg, the rest stays near
where it was; snapping feet that are already flat changes nothing."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.posing.drag import Posing
from app.core.posing.ready_pose import ready_pose
from app.core.robot.loading import load_robot
from app.core.servo.presets import servo_joint_names
from tests.conftest import ROBAN_URDF

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


@pytest.mark.parametrize("name", ["servo_biped", "roban"])
def test_lifting_a_foot_from_the_ready_pose_moves_only_its_leg(name):
    robot = load_robot(str(ROBAN_URDF) if name == "roban" else name)
    q = ready_pose(robot).q
    T = robot.link_placements(q, robot.model.createData())[robot.foot("left").link]
    T[2, 3] += 0.05
    result = Posing(robot).drag(q, "left", T)
    assert result.reached
    change = np.rad2deg(np.abs(robot.joint_angles(result.q) - robot.joint_angles(q)))
    dragged = set(_leg_joints(robot, "left"))
    # The stance leg may roll at hip and ankle (the CoM goes over its sole): servos 8 and 12
    # in the paper's numbering, found from the joint axes.
    servos = servo_joint_names(robot)
    free = dragged | {servos[7], servos[11]}
    others = {
        joint: float(c)
        for joint, c in zip(robot.joint_names, change, strict=True)
        if joint not in free and c > FEW_DEG
    }
    assert others == {}


def test_snapping_flat_feet_keeps_the_pose():
    robot = load_robot("servo_biped")
    q = ready_pose(robot).q
    result = Posing(robot).snap_feet_to_ground(q)
    np.testing.assert_allclose(
        robot.joint_angles(result.q), robot.joint_angles(q), atol=np.deg2rad(0.5)
    )


def test_a_sole_without_area_gives_a_thin_polygon_not_an_error():
    """Points on a line (a foot whose geometry is missing): a strip around them."""
    from app.core.posing.ik import DEGENERATE_PAD_M, convex_polygon

    line = np.array([[0.0, 0.0], [0.1, 0.0], [0.05, 0.0]])
    polygon = convex_polygon(line)
    assert np.ptp(polygon[:, 0]) == pytest.approx(0.1 + 2 * DEGENERATE_PAD_M)
    assert np.ptp(polygon[:, 1]) == pytest.approx(2 * DEGENERATE_PAD_M)
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]])
    assert len(convex_polygon(square)) == 4  # a proper hull is untouched
