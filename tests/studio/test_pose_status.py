"""The Pose panel's status after a foot drag says what the solve did (issue 23, defect 1):
"Target reached ✓" only when pinocchio finds the foot on its target and the torso upright;
a foot dragged out of reach gives "Closest reachable pose" with the distance and the joint
at its limit."""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin


def drag_left_foot_up(studio, lift_m: float, events: int = 20, release: bool = True) -> np.ndarray:
    """Drag the left foot's handle straight up in `events` gizmo events and (release) let it
    go there, as viser reports a hand's drag: the release is one more event at the last
    move's pose. The last target."""
    robot = studio.state.robot
    start = robot.link_placements(studio.state.q, robot.model.createData())[robot.feet[0].link]
    for k in range(1, events + 1):
        target = start.copy()
        target[2, 3] += lift_m * k / events
        studio.pose.request_drag("left", target)
    if release:
        studio.pose.request_drag("left", target, released=True)
    return target


def test_a_foot_lifted_from_standing_is_reached_upright_and_says_so(studio):
    studio.robots.load("servo_biped")
    robot = studio.state.robot
    target = drag_left_foot_up(studio, 0.11)  # 60 px in the default framing (test_foot_lift)
    q = studio.state.q
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    foot = data.oMf[robot.link_frame_ids[robot.feet[0].link]]
    assert np.linalg.norm(foot.translation - target[:3, 3]) < 1e-3
    torso = data.oMf[robot.link_frame_ids[robot.tree.root]].rotation
    assert np.rad2deg(np.arccos(torso[2, 2])) < 2.0
    status = studio.pose.panel.status.content
    assert "Target reached ✓" in status and "Closest reachable" not in status


def test_a_foot_dragged_out_of_reach_says_closest_reachable_and_why(studio):
    studio.robots.load("servo_biped")
    robot = studio.state.robot
    target = drag_left_foot_up(studio, 0.40, events=30)
    status = studio.pose.panel.status.content
    assert "Target reached" not in status
    assert "**Closest reachable pose**" in status
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, studio.state.q)
    foot = data.oMf[robot.link_frame_ids[robot.feet[0].link]]
    miss_mm = 1000 * np.linalg.norm(foot.translation - target[:3, 3])
    shown = re.search(r"left foot ([\d.]+) mm", status)
    assert shown and abs(float(shown.group(1)) - miss_mm) < 0.06, status
    knee = robot.joint_names.index("left_knee")
    upper = robot.joints[knee].upper  # the URDF's bound, where pinocchio finds the knee
    assert abs(robot.joint_angles(studio.state.q)[knee] - upper) < 1e-2
    assert f"left_knee at its upper limit ({np.rad2deg(upper):.1f}°)" in status
    assert status.count("out of reach") == 0  # the reason is said once, not again as a warning


def test_events_between_explanations_keep_the_last_reasons_with_their_own_miss(studio):
    """Out of reach, what holds the pose back is worked out on the first miss, every
    EXPLAIN_EVERY-th event and at the release (app.core.posing.drag): the events between show
    their own miss (pinocchio's distance at their pose) beside the last "held back by" lines,
    and the release's lines name the knee pinocchio finds at its URDF bound."""
    studio.robots.load("servo_biped")
    robot = studio.state.robot
    data = robot.model.createData()
    start = robot.link_placements(studio.state.q, data)[robot.feet[0].link]
    seen = []
    for k in range(1, 31):
        target = start.copy()
        target[2, 3] += 0.40 * k / 30
        studio.pose.request_drag("left", target)
        result = studio.pose.last_result
        foot = robot.link_placements(studio.state.q, data)[robot.feet[0].link]
        seen.append((result, studio.pose.panel.status.content, foot, target))
    misses = [(r, s, f, t) for r, s, f, t in seen if not r.reached]
    between = [m for m in misses if not m[0].explained]
    assert misses and between, "the drag never got out of reach, or every event was explained"
    assert len(between) < len(misses) - 2  # some explained after the first miss too
    for _result, status, foot, target in misses:
        assert "held back by" in status
        shown = re.search(r"left foot ([\d.]+) mm", status)
        miss_mm = 1000 * np.linalg.norm(foot[:3, 3] - target[:3, 3])
        assert shown and abs(float(shown.group(1)) - miss_mm) < 0.06, status
    handle = studio.pose.handles.handle("left")
    assert np.linalg.norm(np.asarray(handle.position) - seen[-1][2][:3, 3]) > 0.05  # held
    studio.pose.request_drag("left", seen[-1][3], released=True)
    assert studio.pose.last_result.explained
    # let go, the handle is back on the foot (pinocchio's placement), not left in the air
    foot = robot.link_placements(studio.state.q, data)[robot.feet[0].link]
    assert np.linalg.norm(np.asarray(handle.position) - foot[:3, 3]) < 1e-4
    knee = robot.joint_names.index("left_knee")
    upper = robot.joints[knee].upper
    assert abs(robot.joint_angles(studio.state.q)[knee] - upper) < 1e-2
    status = studio.pose.panel.status.content
    assert f"left_knee at its upper limit ({np.rad2deg(upper):.1f}°)" in status
