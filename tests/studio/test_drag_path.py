"""The lean drag path shows what the plain one did: the robot's link nodes, queued only when
they changed and without viser's setters, end where one assignment per node puts them (and
where pinocchio places the links); and the joint sliders, refreshed off the drag path, end on
the drag's last pose."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
import viser

from app.core.posing.drag import Posing
from app.core.quaternions import wxyz_to_matrix
from app.core.robot.loading import load_robot
from app.views.balance_view import OUTSIDE_RGB, BalanceView
from app.views.robot_view import RobotView, _wxyz_of
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


def balance_steps(robot):
    """(stance, q) of the balance overlay along a drag of the left foot (the right foot
    standing), then both feet, then the left one, then poses with joints at their limits and
    the base pushed aside (markers appear, the CoM leaves the polygon), then standing again."""
    drags = drag_configurations(robot, events=20)[:-1]
    steps = [("right", q) for q in drags]
    steps += [("both", q) for q in drags[-3:]] + [("left", q) for q in drags[:3]]
    lower = np.array([max(j.lower, -np.pi) for j in robot.joints])
    upper = np.array([min(j.upper, np.pi) for j in robot.joints])
    rng = np.random.default_rng(4)
    for k in range(6):
        angles = rng.uniform(lower, upper)
        at_limit = rng.random(len(angles)) < 0.2 * (k + 1)
        angles[at_limit] = np.where(rng.random(len(angles)) < 0.5, lower, upper)[at_limit]
        q = robot.with_joint_angles(robot.q_neutral, np.clip(angles, lower, upper))
        q[0] += 0.05 * k
        steps.append((("right", "both", "left")[k % 3], q))
    steps.append(("both", robot.q_neutral.copy()))
    return steps


def balance_scene(view: BalanceView) -> dict[str, tuple]:
    """Each node of a balance view: shown or not and, shown, where and in which colour."""
    scene = {}
    for handle in [view._polygon, view._com, *view._limits, *view._contacts]:
        key = handle.name.removeprefix(view.root)
        if not handle.visible:
            scene[key] = (False,)
            continue
        extra = np.asarray(handle.points, dtype=float) if handle is view._polygon else None
        color = tuple(int(c) for c in handle.color) if hasattr(handle, "color") else None
        scene[key] = (True, np.array(handle.position), np.array(handle.wxyz), color, extra)
    return scene


def assert_same_balance_scene(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key in a:
        assert a[key][0] == b[key][0], key
        if not a[key][0]:
            continue
        _, position_a, wxyz_a, color_a, points_a = a[key]
        _, position_b, wxyz_b, color_b, points_b = b[key]
        assert np.abs(position_a - position_b).max() < VISER_RTOL, key
        assert np.abs(wxyz_to_matrix(wxyz_a) - wxyz_to_matrix(wxyz_b)).max() < VISER_RTOL, key
        assert color_a == color_b, key
        if points_a is not None:
            assert points_a.shape == points_b.shape and np.abs(points_a - points_b).max() < 1e-6


@pytest.mark.parametrize("name", ["servo_biped", str(ROBAN)])
def test_the_balance_overlay_sends_only_changes_and_shows_the_per_node_scene(name):
    """The batched balance update ends every event on the scene the setters give (nodes,
    visibility, poses, polygon, colours), through stance changes and a hide/show, with one
    contact frame per stance foot; and while a drag keeps the stance foot still (pinocchio),
    it sends nothing for the polygon or the contact frames, and fewer messages in all."""
    if name != "servo_biped" and not ROBAN.exists():
        pytest.skip("Roban S14 not available")
    robot = load_robot(name)
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    sent: list[str] = []
    queue = server.scene._queue_scene_message

    def counting(message) -> None:  # the real queue, each message's node name noted
        sent.append(getattr(message, "name", ""))
        queue(message)

    server.scene._queue_scene_message = counting  # type: ignore[method-assign]
    try:
        batched = BalanceView(server, robot.n_actuated, root="/batched")
        per_node = BalanceView(server, robot.n_actuated, root="/per_node")
        posing = Posing(robot)
        data = robot.model.createData()
        right_sole: list[np.ndarray] = []
        per_event: list[tuple[int, int, set[str]]] = []
        seen = {"markers": 0, "outside": 0}
        for step, (stance, q) in enumerate(balance_steps(robot)):
            if step == 10:  # hidden then shown again mid-drag
                for view in (batched, per_node):
                    view.set_visible(False)
                assert_same_balance_scene(balance_scene(batched), balance_scene(per_node))
                for view in (batched, per_node):
                    view.set_visible(True)
            posing.stance = stance
            state = posing.balance(q)
            sent.clear()
            with server.atomic():
                batched.update(state)
            ours = [n for n in sent if n.startswith("/batched/")]
            sent.clear()
            per_node.update_per_node(state)
            theirs = [n for n in sent if n.startswith("/per_node/")]
            per_event.append((len(ours), len(theirs), {n.split("/")[2] for n in ours}))
            scene = balance_scene(batched)
            assert_same_balance_scene(scene, balance_scene(per_node))
            contacts = [k for k, v in scene.items() if k.startswith("/contact_") and v[0]]
            assert len(contacts) == (2 if stance == "both" else 1)
            com = pin.centerOfMass(robot.model, data, q)
            assert np.abs(scene["/com_ground"][1][:2] - com[:2]).max() < 1e-6
            seen["markers"] += sum(k.startswith("/limit_") and v[0] for k, v in scene.items())
            seen["outside"] += scene["/com_ground"][3] == OUTSIDE_RGB
            if stance == "right" and step < 19:
                placements = robot.link_placements(q, data)
                right_sole.append(placements[robot.feet[1].link])
        assert seen["markers"] > 0 and seen["outside"] > 0  # the sequence shows both
        # The drag phase: the right foot stood still, so no polygon or contact frame is resent.
        still = max(np.abs(T - right_sole[0]).max() for T in right_sole)
        assert still < 1e-9, f"the stance foot moved {still:g}"
        drag_nodes = set().union(*(nodes for _, _, nodes in per_event[1:10]))
        assert not any(n in ("polygon",) or n.startswith("contact_") for n in drag_nodes)
        assert sum(o for o, _, _ in per_event) <= sum(t for _, t, _ in per_event)
    finally:
        server.stop()


def test_the_link_quaternions_computed_at_once_are_pinocchios_rotations():
    """The vectorised quaternions of the drag path: each the rotation pinocchio's own
    quaternion gives (up to sign), w >= 0, unit; through half turns and near-identity."""
    rng = np.random.default_rng(7)
    rotations = [pin.exp3(rng.normal(size=3)) for _ in range(200)]
    rotations += [pin.exp3(np.pi * axis) for axis in np.eye(3)]  # half turns: trace -1
    rotations += [np.eye(3), pin.exp3(np.array([1e-9, 0.0, 0.0]))]
    T = np.tile(np.eye(4), (len(rotations), 1, 1))
    T[:, :3, :3] = rotations
    for wxyz, R in zip(_wxyz_of(T), rotations, strict=True):
        xyzw = pin.Quaternion(R).coeffs()
        expected = np.array([xyzw[3], *xyzw[:3]])
        assert abs(abs(wxyz @ expected) - 1.0) < 1e-12  # the same rotation
        assert np.abs(wxyz_to_matrix(wxyz) - R).max() < 1e-12
        assert wxyz[0] >= 0.0 and abs(np.linalg.norm(wxyz) - 1.0) < 1e-12
