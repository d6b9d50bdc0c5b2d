"""Presets that would drive servo_biped past its joint limits are scaled to fit, and absurd
predictions are named."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from app.core.servo.compensation import CompensationError, compensated_command, disabled_params
from app.core.servo.files import check_commands
from app.core.servo.model import ServoModel, joint_angles, predict
from app.core.servo.preset_safety import (
    SCALE_TOLERANCE,
    implausible_prediction,
    limit_scale,
    scaled_to_limits,
)
from app.core.servo.presets import paper_table2_preset


@pytest.fixture(scope="module")
def stand():
    robot = load_robot("servo_biped")
    traj = run_motion(robot, "one_leg_stand", dt=0.05).trajectory
    tau = torque_feedforward(robot, traj).tau_Nm
    lower = np.array([j.lower for j in robot.joints])
    upper = np.array([j.upper for j in robot.joints])
    return robot, traj, tau, joint_angles(robot, traj.q), lower, upper


def _commands(params, q, tau):
    return compensated_command(q, tau, params)


def test_table2_is_scaled_to_the_largest_k_that_fits(stand) -> None:
    robot, traj, tau, q, lower, upper = stand
    table2 = paper_table2_preset(robot).for_joints(robot.joint_names)
    with pytest.raises(CompensationError, match="outside its limits"):  # as given: refused
        check_commands(traj.t, robot.joint_names, _commands(table2, q, tau), lower, upper)
    scaled, s = scaled_to_limits(table2, q, tau, lower, upper)
    assert 0.0 < s < 1.0 and "k scaled by" in scaled.notes[-1]
    np.testing.assert_allclose(scaled.k_deg_per_Nm, s * table2.k_deg_per_Nm)
    check_commands(traj.t, robot.joint_names, _commands(scaled, q, tau), lower, upper)
    # maximal: a little more k leaves the limits
    more = dataclasses.replace(table2, k_deg_per_Nm=table2.k_deg_per_Nm * (s + 2 * SCALE_TOLERANCE))
    with pytest.raises(CompensationError, match="outside its limits"):
        check_commands(traj.t, robot.joint_names, _commands(more, q, tau), lower, upper)


def test_coefficients_that_fit_are_unchanged(stand) -> None:
    robot, _, tau, q, lower, upper = stand
    none = disabled_params(robot.joint_names)
    assert limit_scale(none, q, tau, lower, upper) == 1.0
    assert scaled_to_limits(none, q, tau, lower, upper) == (none, 1.0)


def test_absurd_predictions_are_named(stand) -> None:
    """Rigid servos sent the plan as it is do exactly the plan: nothing to report (closed
    form). Servos as compliant as Table 2 says make the torso fall: reported."""
    robot, traj, tau, _, _, _ = stand
    plan = predict(
        robot, traj, tau, disabled_params(robot.joint_names), ServoModel.rigid(robot.joint_names)
    )
    assert implausible_prediction(plan) == []
    table2 = paper_table2_preset(robot)
    fall = predict(robot, traj, tau, table2, ServoModel.matching(table2))
    reasons = implausible_prediction(fall)
    assert reasons and all("the robot would fall" in reason for reason in reasons)
