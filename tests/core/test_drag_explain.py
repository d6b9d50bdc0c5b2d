"""A drag out of reach works out what holds its pose back on the gesture's first miss, on
every EXPLAIN_EVERY-th event after and on the release (app.core.posing.drag): the poses are
those of a drag that explains every event, bit for bit, and each event's shortfall is that
drag's, without the "held back by" lines on the events between."""

from __future__ import annotations

import numpy as np

from app.bench.ik_baseline import drag_events
from app.core.posing.drag import EXPLAIN_EVERY, Posing
from app.core.posing.ik_verdict import HELD_BACK_BY, explains
from app.core.posing.shortfall import NOTHING_PUSHED
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF


def test_a_drag_explains_on_its_cadence_and_poses_as_one_that_explains_every_event():
    robot = load_robot(str(ROBAN_URDF))
    q0 = robot.q_neutral.copy()
    start = robot.link_placements(q0, robot.model.createData())[robot.feet[0].link]
    always, cadence = Posing(robot), Posing(robot)
    due, explained_misses, between = True, 0, 0
    for event in drag_events(robot, q0, start, 80):
        full = always.drag(event.q_before, "left", event.target, explain=True)
        ours = cadence.drag(event.q_before, "left", event.target)
        assert np.array_equal(ours.q, full.q)
        assert ours.reached == full.reached
        if full.reached:
            assert ours.explained and ours.shortfall == full.shortfall == ()
            due = True
            continue
        # the rule written out: the first miss after a reached event (or the start), then
        # every EXPLAIN_EVERY-th miss
        assert ours.explained == due
        if due:
            assert ours.shortfall == full.shortfall
            explained_misses, since, due = explained_misses + 1, 0, False
        else:
            assert ours.shortfall == tuple(line for line in full.shortfall if not explains(line))
            between += 1
            since += 1
        due = due or since >= EXPLAIN_EVERY - 1
    assert explained_misses > 3 and between > 3  # both kinds were seen
    released = cadence.drag(ours.q, "left", event.target, explain=True)
    assert released.explained


def test_a_pelvis_pushed_down_on_straight_legs_says_why_as_a_sentence():
    """From standing (knees straight: pinocchio's knee angles 0), pulling the pelvis down moves
    nothing to first order; the shortfall says so in its own words and points at Ready pose,
    not as a "held back by no joint motion…" reason."""
    robot = load_robot("servo_biped")
    q = robot.q_neutral.copy()
    knees = [robot.joint_names.index(f"{side}_knee") for side in ("left", "right")]
    assert np.allclose(robot.joint_angles(q)[knees], 0.0)
    T = robot.link_placements(q, robot.model.createData())[robot.tree.root].copy()
    posing = Posing(robot)
    for k in range(1, 11):
        target = T.copy()
        target[2, 3] -= 0.05 * k / 10
        result = posing.drag(q, "pelvis", target, explain=k == 10)
        q = result.q
    pelvis = robot.link_placements(q, robot.model.createData())[robot.tree.root]
    assert abs(pelvis[2, 3] - T[2, 3]) < 1e-3  # it did not come down
    assert not result.reached
    assert NOTHING_PUSHED in result.shortfall
    assert not any(line.startswith(HELD_BACK_BY) for line in result.shortfall)
    assert "Ready pose" in NOTHING_PUSHED
