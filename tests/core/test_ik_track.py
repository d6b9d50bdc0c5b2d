"""WholeBodyIK.track (one QP step from a prediction, app/core/posing/ik_track.py) against
WholeBodyIK.solve (iterated to convergence) on a foot moving along a circle, 1 mm per sample,
the pelvis held, as a keyframed motion moves them:

- each sample with a prediction is one QP step, and its pose is solve's to SAME_Q, the foot on its target by
  pinocchio's own forward kinematics (not read from the result), the held foot exactly where
  it stood;
- where one step cannot answer (a target out of reach, a stance that changed, a start that is
  not the IK's last answer), track answers exactly as solve does from the same start.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.posing.ik import REACHED_M, IkTargets, WholeBodyIK
from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT, ready_pose
from app.core.robot.loading import load_robot

SAME_Q = 1e-4
"""[rad, m] per configuration entry: one Gauss–Newton step from within ~1e-3 leaves ~1e-6;
solve itself stops once a step is shorter than 1e-6 and linearly converging tails (the light
posture task against the goals) leave up to ~1e-5."""


def _ik(robot):
    """An IK as keyframed motions make one (their light posture weight), without the CoM
    polygon: standing on the left foot from the ready pose, the CoM starts outside its sole
    (a motion shifts it first: tests/core/test_keyframes_tracking.py)."""
    return WholeBodyIK(robot, com_in_support=False, posture_weight=MOTION_POSTURE_WEIGHT)


@pytest.fixture(scope="module")
def robot():
    return load_robot("servo_biped")


@pytest.fixture(scope="module")
def start(robot):
    return ready_pose(robot, WholeBodyIK(robot)).q


def _foot_targets(robot, q, n=40, radius=0.05):
    """The right foot's placement at q moved along a circle in the sagittal plane, 1 mm a
    sample, lifted 2 cm (clear of the floor)."""
    T0 = robot.link_placements(q, robot.model.createData())[robot.foot("right").link].copy()
    T0[2, 3] += 0.02
    for k in range(n):
        angle = k * 0.001 / radius
        T = T0.copy()
        T[0, 3] += radius * np.sin(angle)
        T[2, 3] += radius * (1.0 - np.cos(angle))
        yield T


def _frame(robot, q, link):
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return data.oMf[robot.link_frame_ids[link]]


def test_one_step_per_sample_lands_where_solve_converges(robot, start):
    tracker, solver = _ik(robot), _ik(robot)
    placements = robot.link_placements(start, robot.model.createData())
    left, pelvis = placements[robot.foot("left").link], placements[robot.tree.root]
    targets = [
        IkTargets(T_world_left=left, T_world_right=T, T_world_pelvis=pelvis, stance="left")
        for T in _foot_targets(robot, start)
    ]
    lift = solver.solve(start, targets[0])  # the foot lifted: both start from there
    tracker.solve(start, targets[0])
    q_track, q_solve, previous = lift.q, lift.q, None
    for target in targets[1:]:
        guess = (
            None
            if previous is None
            else pin.integrate(robot.model, q_track, pin.difference(robot.model, previous, q_track))
        )
        tracked = tracker.track(q_track, target, guess)
        solved = solver.solve(q_solve, target)
        if guess is not None:  # the first move, unpredicted, is the whole 1 mm: solve's
            assert tracked.iterations == 1 and solved.iterations > 1
        assert tracked.reached and solved.reached
        assert np.abs(pin.difference(robot.model, solved.q, tracked.q)).max() < SAME_Q
        foot = _frame(robot, tracked.q, robot.foot("right").link)
        assert np.linalg.norm(foot.translation - target.T_world_right[:3, 3]) < REACHED_M
        held = _frame(robot, tracked.q, robot.foot("left").link)
        assert np.abs(held.homogeneous - left).max() < 1e-9
        previous, q_track, q_solve = q_track, tracked.q, solved.q


def _twin_answers(robot, start, second):
    """track and solve asked the same second question after the same first solve, each on an
    IK of its own."""
    placements = robot.link_placements(start, robot.model.createData())
    left, pelvis = placements[robot.foot("left").link], placements[robot.tree.root]
    first = IkTargets(
        T_world_left=left,
        T_world_right=next(_foot_targets(robot, start)),
        T_world_pelvis=pelvis,
        stance="left",
    )
    answers = []
    for use_track in (True, False):
        ik = _ik(robot)
        q = ik.solve(start, first).q
        target = second(q, left, pelvis)
        answers.append(ik.track(q, target) if use_track else ik.solve(q, target))
    return answers


@pytest.mark.parametrize(
    "case",
    ["out of reach", "stance changed", "not the last answer"],
)
def test_where_one_step_cannot_answer_solve_does(robot, start, case):
    def second(q, left, pelvis):
        lifted = robot.link_placements(q, robot.model.createData())[robot.foot("right").link]
        if case == "out of reach":
            far = lifted.copy()
            far[0, 3] += 0.3
            return IkTargets(
                T_world_left=left, T_world_right=far, T_world_pelvis=pelvis, stance="left"
            )
        if case == "stance changed":
            return IkTargets(
                T_world_left=left, T_world_right=lifted, T_world_pelvis=pelvis, stance="both"
            )
        return IkTargets(
            T_world_left=left, T_world_right=lifted, T_world_pelvis=pelvis, stance="left"
        )

    if case == "not the last answer":
        placements = robot.link_placements(start, robot.model.createData())
        left, pelvis = placements[robot.foot("left").link], placements[robot.tree.root]
        ik_a, ik_b = _ik(robot), _ik(robot)
        first = IkTargets(
            T_world_left=left,
            T_world_right=next(_foot_targets(robot, start)),
            T_world_pelvis=pelvis,
            stance="left",
        )
        q = ik_a.solve(start, first).q.copy()
        ik_b.solve(start, first)
        q[7] += 1e-3  # a start the IK did not answer
        target = second(q, left, pelvis)
        tracked, solved = ik_a.track(q, target), ik_b.solve(q, target)
    else:
        tracked, solved = _twin_answers(robot, start, second)
    assert np.array_equal(tracked.q, solved.q)
    assert tracked.iterations == solved.iterations
    assert tracked.reached == solved.reached
    assert tracked.warnings == solved.warnings
    if case == "out of reach":
        assert not tracked.reached
