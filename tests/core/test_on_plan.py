"""Simulated runs drawn over the plan (app.core.simulation.on_plan), checked with pinocchio."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.simulation.on_plan import on_plan_stance


@pytest.fixture(scope="module")
def robot(servo_biped):
    """servo_biped (the conftest's), under the name the tests here use; `one_leg` is its
    one-leg stand."""
    return servo_biped


def stance_position(robot, q, contacts):
    left, right = contacts
    foot = robot.feet[1 if right and not left else 0].link
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return data.oMf[robot.link_frame_ids[foot]].translation.copy()


def test_a_run_that_drifted_is_put_back_exactly(robot, one_leg):
    """The plan slid over the floor by a different offset at each sample comes back to the
    plan, and the drift reported is that offset."""
    rng = np.random.default_rng(3)
    offsets = rng.uniform(-0.15, 0.15, size=(one_leg.n_samples, 2))
    drifted = one_leg.q.copy()
    drifted[:, :2] += offsets
    on_plan = on_plan_stance(robot, one_leg, drifted)
    np.testing.assert_allclose(on_plan.q, one_leg.q, atol=1e-12)
    np.testing.assert_allclose(on_plan.drift_m, offsets, atol=1e-12)
    assert on_plan.max_drift_m == pytest.approx(np.max(np.linalg.norm(offsets, axis=1)))


def test_posture_height_and_tilt_are_kept(robot, one_leg):
    """A run with other joint angles, tilted and drifted: only x, y change, and its stance foot
    then stands over the plan's."""
    rng = np.random.default_rng(4)
    q_sim = one_leg.q.copy()
    q_sim[:, 7:] += rng.normal(0.0, 0.05, size=q_sim[:, 7:].shape)
    tilt = pin.Quaternion(pin.rpy.rpyToMatrix(0.05, -0.08, 0.3))
    q_sim[:, 3:7] = np.array([tilt.x, tilt.y, tilt.z, tilt.w])
    q_sim[:, :2] += np.array([0.07, -0.04])
    q_sim[:, 2] -= 0.02
    out = on_plan_stance(robot, one_leg, q_sim).q
    np.testing.assert_array_equal(out[:, 2:], q_sim[:, 2:])
    for k in range(one_leg.n_samples):
        contacts = one_leg.contacts[k]
        moved = stance_position(robot, out[k], contacts)
        planned = stance_position(robot, one_leg.q[k], contacts)
        np.testing.assert_allclose(moved[:2], planned[:2], atol=1e-9)
