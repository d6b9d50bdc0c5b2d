"""The fill between a keyframed motion's IK nodes (app.core.motions.keyframe_fill), against
closed forms: the degree-5 polynomial through six nodes reproduces any quintic exactly, its
error estimate (the difference to the polynomial through seven) vanishes there and is large
where the filled curve has a kink; and the per-sample checks pass the samples of a motion the
IK solved and fail a sample moved off its targets, past a joint limit or past a speed limit.
"""

from __future__ import annotations

import types

import numpy as np
import pytest

from app.core.motions import keyframe_samples
from app.core.motions.continuity import speed_limits
from app.core.motions.keyframe_fill import FILL_Q, HELD_M, _within_limits, check, fill
from app.core.motions.keyframes import interpolate
from app.core.motions.library import MOTIONS, resolve_params
from app.core.posing.ik import IkTargets
from app.core.robot.loading import load_robot

FIXED_BASE = types.SimpleNamespace(floating_base=False)


def test_the_fill_is_exact_on_quintics_and_its_estimate_sees_a_kink():
    nodes = np.array([0, 3, 6, 9, 12, 15, 18, 20])  # a node every 3 samples, the last closer
    t = np.arange(21, dtype=float)
    quintic = np.stack([0.3 - 0.01 * t + 2e-4 * t**3 - 1e-6 * t**5, 1e-3 * t**2], axis=1)
    where, q, estimate = fill(FIXED_BASE, nodes, quintic)
    assert list(where) == [k for k in range(21) if k not in set(nodes)]
    assert np.abs(q - quintic[where]).max() < 1e-12
    assert estimate.max() < 1e-12
    kinked = np.abs(t - 10.5)[:, None] * 1e-3  # its slope turns between samples 10 and 11
    where, q, estimate = fill(FIXED_BASE, nodes, kinked)
    near = (where > 6) & (where < 15)
    assert estimate[near].max() > FILL_Q  # the samples next to the kink are not trusted
    errors = np.abs(q - kinked[where])[:, 0]
    assert np.all(estimate[errors > FILL_Q] > FILL_Q)  # every sample filled wrong is caught


@pytest.fixture(scope="module")
def solved_shift():
    """servo_biped's CoM shift (both feet down) with every sample solved by the IK, and the
    targets of each sample."""
    robot = load_robot("servo_biped")
    plan = MOTIONS["com_shift"].build(robot, **resolve_params("com_shift", {}))
    planned: dict[int, IkTargets] = {}
    made = keyframe_samples._segment

    def recorded(robot, keyframes, segment, start, k, *args):
        targets = made(robot, keyframes, segment, start, k, *args)
        for i, sample_targets in enumerate(targets):
            planned.setdefault(k + i, sample_targets)
        return targets

    keyframe_samples._segment = recorded
    try:
        motion = interpolate(robot, plan.keyframes, dt=0.01, fill_every=1)
    finally:
        keyframe_samples._segment = made
    return robot, motion.trajectory.q, planned


def test_the_checks_pass_the_iks_own_samples_and_fail_each_kind_of_fault(solved_shift):
    robot, q, planned = solved_shift
    data = robot.model.createData()
    nodes = np.arange(30, 64, 3)  # every third sample treated as a node, the rest as filled
    where = np.array([k for k in range(31, 63) if k not in set(nodes)])
    assert planned[40].stance == "both"

    def failing(qs):
        ok, contacts = check(robot, data, qs, nodes, where, planned.__getitem__, None, 0.01)
        assert contacts.all()  # both feet stand
        return list(where[~ok])

    assert failing(q) == []  # the IK's own answers between nodes pass
    moved = q.copy()
    moved[where[4], 0] += 2 * HELD_M  # the base, so both standing feet, 2 µm forward
    assert failing(moved) == [where[4]]
    joint = robot.joints[3]
    fast = q.copy()  # one sample a step faster than the joint's speed limit from the one before
    k = where[6]
    assert k - 1 in nodes and k + 1 in where
    fast[k, joint.idx_q] += 1.5 * speed_limits(robot)[3] * 0.01
    assert list(where[~_within_limits(robot, fast, where, 0.01)]) == [k, k + 1]
    assert _within_limits(robot, q, where, 0.01).all()
    upper = robot.model.upperPositionLimit.copy()
    limit = upper.copy()
    try:
        limit[joint.idx_q] = q[where[4], joint.idx_q] - 1e-6  # sample where[4] just past it
        robot.model.upperPositionLimit = limit
        over = q[where, joint.idx_q] > limit[joint.idx_q]
        assert over[4] and np.array_equal(~_within_limits(robot, q, where, 0.01), over)
    finally:
        robot.model.upperPositionLimit = upper
