"""A drag out of reach works out what holds its pose back on the gesture's first miss, on
every EXPLAIN_EVERY-th event after and on the release (app.core.posing.drag): the poses are
those of a drag that explains every event, bit for bit, and each event's shortfall is that
drag's, without the "held back by" lines on the events between."""

from __future__ import annotations

import numpy as np

from app.bench.ik_baseline import drag_events
from app.core.posing.drag import EXPLAIN_EVERY, Posing
from app.core.posing.ik_verdict import HELD_BACK_BY
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
            assert ours.shortfall == tuple(
                line for line in full.shortfall if not line.startswith(HELD_BACK_BY)
            )
            between += 1
            since += 1
        due = due or since >= EXPLAIN_EVERY - 1
    assert explained_misses > 3 and between > 3  # both kinds were seen
    released = cadence.drag(ours.q, "left", event.target, explain=True)
    assert released.explained
