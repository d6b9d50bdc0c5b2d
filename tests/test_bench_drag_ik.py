"""The IK baseline of `biped-studio bench` (app.bench.ik_baseline): placo's own loop on the
drag events' problem, stopped at the studio's final foot error.

Checked against pinocchio's forward kinematics, not against the code's own numbers:
- the events record the studio's answers as they are (each starts where the last ended; the
  recorded foot errors are those of the answer's placement);
- placo's loop solves the same problem: its answer holds the right foot where it was and keeps
  the CoM inside the right sole's polygon, less the margin; the errors it reports are those of
  its answer, and "reached" means at least as close as the studio.
No timing is asserted.
"""

from __future__ import annotations

import itertools

import numpy as np
import pinocchio as pin
import pytest

from app.bench.ik_baseline import PlacoLoop, drag_events
from app.bench.posing import drag_target
from app.core.posing.ik import WholeBodyIK
from app.core.posing.ready_pose import ready_pose
from app.core.robot.loading import load_robot


def foot_errors(robot, q: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    T = data.oMf[robot.link_frame_ids[robot.feet[0].link]]
    return (
        float(np.linalg.norm(T.translation - target[:3, 3])),
        float(np.linalg.norm(pin.log3(target[:3, :3].T @ T.rotation))),
    )


def placement(robot, q: np.ndarray, link: str) -> np.ndarray:
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return data.oMf[robot.link_frame_ids[link]].homogeneous.copy()


@pytest.fixture(scope="module")
def events():
    robot = load_robot("servo_biped")
    q0 = ready_pose(robot).q
    start = placement(robot, q0, robot.feet[0].link)
    return robot, drag_events(robot, q0, start, 16)


def test_events_chain_the_studios_answers_and_record_their_true_errors(events):
    robot, chain = events
    for before, after in itertools.pairwise(chain):
        # The next event starts from this one's answer: the answer's errors are the record.
        distance, turn = foot_errors(robot, after.q_before, before.target)
        assert distance == pytest.approx(before.position_error_m, abs=1e-12)
        assert turn == pytest.approx(before.orientation_error_rad, abs=1e-9)
    start = chain[0].target.copy()
    start[:3, 3] -= [0.03, 0.0, 0.02]  # drag_target at k = 0 from the foot's start
    assert np.allclose(chain[3].target, drag_target(start, 3, 50))


def test_placos_loop_solves_the_same_problem_and_stops_as_it_says(events):
    robot, chain = events
    loop = PlacoLoop(robot)
    margin = WholeBodyIK(robot).com_margin_m
    endings = set()
    for event in chain[5:]:
        stop = loop.solve(event)
        q = np.array(loop.wrapper.state.q)
        endings.add(stop.ending)
        distance, turn = foot_errors(robot, q, event.target)
        assert distance == pytest.approx(stop.position_error_m, abs=1e-12)
        assert turn == pytest.approx(stop.orientation_error_rad, abs=1e-9)
        if stop.ending == "reached":
            assert distance <= event.position_error_m and turn <= event.orientation_error_rad
        # The right foot is held where it was (hard: to first order per step, so a few
        # micrometres of second-order drift remain; the studio removes its own by a rigid
        # shift of the base), the CoM inside its sole less the margin.
        right = robot.feet[1].link
        held = placement(robot, event.q_from, right)
        assert np.abs(placement(robot, q, right) - held).max() < 1e-5
        com = pin.centerOfMass(robot.model, robot.model.createData(), q)[:2]
        low, high = event.polygon.min(axis=0), event.polygon.max(axis=0)  # a rectangle sole
        assert np.all(com >= low + margin - 1e-6) and np.all(com <= high - margin + 1e-6)
        assert 1 <= stop.steps <= 60
        # Close to the target: within 0.1 mm, as the studio.
        assert distance < 1e-4
    assert "reached" in endings


def test_the_entry_runs_beside_the_drag():
    from app.bench import ENTRIES

    names = list(ENTRIES)
    assert names.index("drag_ik") == names.index("drag") + 1
