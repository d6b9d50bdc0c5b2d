"""The lean drag path shows what the plain one did: the robot's link nodes, queued only when
they changed and without viser's setters, end where one assignment per node puts them (and
where pinocchio places the links); and the joint sliders, refreshed off the drag path, end on
the drag's last pose."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import viser

from app.core.posing.drag import Posing
from app.core.quaternions import wxyz_to_matrix
from app.core.robot.loading import load_robot
from app.views.robot_view import RobotView
from tests.studio.conftest import free_port, wait_for_signal

ROBAN = Path(__file__).resolve().parents[1] / "third_party/roban_s14/urdf/robanS14.urdf"
EXACT_M = 1e-6
"""The batched nodes against pinocchio: the send tolerance (1e-7) piled up along a chain."""
VISER_RTOL = 2e-5
"""Viser's setters skip a change within np.allclose's default rtol (1e-5): the per-node path
is itself this far from exact."""


def drag_configurations(robot, events=30):
    """Configurations of a real drag (the left foot around a circle), then a jump back."""
    posing = Posing(robot)
    q = robot.q_neutral.copy()
    start = robot.link_placements(q, robot.model.createData())[robot.feet[0].link]
    out = []
    for k in range(events):
        angle = 2.0 * np.pi * k / 15.0
        target = start.copy()
        target[:3, 3] += [0.03 * np.cos(angle), 0.03 * np.sin(angle), 0.02]
        q = posing.drag(q, "left", target).q
        out.append(q)
    out.append(robot.q_neutral.copy())
    return out


def world_pose(view: RobotView, link: str) -> np.ndarray:
    position, wxyz = view.link_pose(link)
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = wxyz_to_matrix(wxyz), position
    return T


@pytest.mark.parametrize("name", ["servo_biped", str(ROBAN)])
def test_batched_robot_updates_give_the_per_node_scene(name):
    if name != "servo_biped" and not ROBAN.exists():
        pytest.skip("Roban S14 not available")
    robot = load_robot(name)
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        batched = RobotView(server, robot, root="/batched", with_collision=False)
        per_node = RobotView(server, robot, root="/per_node", with_collision=False)
        data = robot.model.createData()
        for q in drag_configurations(robot):
            with server.atomic():
                batched.update(q)
            per_node.update_per_node(q)
            placements = robot.link_placements(q, data)
            for link in batched._link_frames:
                a, b = world_pose(batched, link), world_pose(per_node, link)
                assert np.abs(a - placements[link]).max() < EXACT_M, link
                assert np.abs(a - b).max() < VISER_RTOL * max(1.0, np.abs(b).max()), link
    finally:
        server.stop()


def test_the_joint_sliders_end_on_the_drags_last_pose(studio):
    studio.robots.load("servo_biped")
    robot = studio.state.robot
    start = robot.link_placements(studio.state.q, robot.model.createData())[robot.feet[0].link]
    targets = []
    for k in range(12):
        target = start.copy()
        target[:3, 3] += [0.002 * k, 0.0, 0.003 * k]
        targets.append(target)
    for target in targets[:-1]:
        studio.pose.request_drag("left", target)
    shown = wait_for_signal(
        studio.joints.followed_drag,
        lambda: studio.pose.request_drag("left", targets[-1]),
        accept=lambda pose: pose is studio.state.pose,
    )
    assert shown.origin == "drag:left"
    angles = robot.joint_angles(studio.state.q)
    assert np.abs(angles - robot.joint_angles(robot.q_neutral)).max() > np.deg2rad(1.0)
    for joint, angle in zip(robot.joints, angles, strict=True):
        slider = studio.joints.panel.sliders[joint.name]
        # The slider shows degrees to one decimal (clamped to its range).
        expected = float(np.clip(np.rad2deg(angle), slider.min, slider.max))
        assert slider.value == pytest.approx(expected, abs=0.05 + 1e-9), joint.name


def test_the_pose_status_after_a_drag_and_a_snap_describes_that_solve(studio):
    """A drag writes the Pose panel's status once, from the drag's own result (reached, as
    pinocchio confirms); the Snap button's solve still replaces it."""
    studio.robots.load("servo_biped")
    robot = studio.state.robot
    data = robot.model.createData()
    target = robot.link_placements(studio.state.q, data)[robot.feet[0].link].copy()
    target[2, 3] += 0.02
    studio.pose.request_drag("left", target)
    reached = robot.link_placements(studio.state.q, data)[robot.feet[0].link]
    assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 1e-3  # pinocchio: reached
    status = studio.pose.panel.status.content
    assert "Stance: **right**" in status and "Target reached ✓" in status
    assert studio.pose.last_result is not None and studio.pose.last_result.q is studio.state.q
    studio.pose.snap_feet()
    status = studio.pose.panel.status.content
    assert "Stance: **both**" in status and "Target" in status
    assert studio.pose.last_result is not None and studio.pose.last_result.q is studio.state.q
