"""The pipeline step motion + torques + coefficients → servo commands, with its checks."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.motions.trajectory import from_configurations
from app.core.robot.loading import load_robot
from app.core.servo.commands import servo_commands, torques_of_motion
from app.core.servo.compensation import CompensationError, CompensationParams
from app.core.servo.files import TorqueTable
from app.core.servo.presets import PRESETS, preset_params


@pytest.fixture(scope="module")
def robot():
    return load_robot("servo_biped")


def _still(robot, n=5, dt=0.01):
    q = np.tile(robot.q_neutral, (n, 1))
    return from_configurations(
        robot.model, "still", robot.joint_names, dt, q, np.ones((n, 2), bool)
    )


def test_commands_are_q_plus_k_tau_in_radians(robot):
    """eq 7 by hand: k = 2 °/(N·m) on one joint, τ = 3 N·m → the command is 6° above the plan."""
    trajectory = _still(robot)
    n = robot.n_actuated
    knee = robot.joint_names.index("left_knee")
    k = np.zeros(n)
    k[knee] = 2.0
    params = CompensationParams(robot.joint_names, k, np.zeros(n), k != 0)
    tau = np.zeros((trajectory.n_samples, n))
    tau[:, knee] = 3.0
    commands = servo_commands(robot, trajectory, tau, params)
    np.testing.assert_allclose(
        commands.q_cmd_rad - commands.q_plan_rad, np.deg2rad(6.0) * (tau != 0)
    )
    assert commands.warnings == ()


def test_commands_outside_the_limits_and_odd_statuses_are_warned(robot):
    trajectory = _still(robot)
    n = robot.n_actuated
    params = CompensationParams(
        robot.joint_names, np.full(n, 1000.0), np.zeros(n), np.ones(n, bool)
    )
    tau = np.ones((trajectory.n_samples, n))
    statuses = ("solved", "solved", "infeasible", "ok", "infeasible")
    warnings = servo_commands(robot, trajectory, tau, params, statuses).warnings
    assert any("outside its limits" in line for line in warnings)
    assert "2 torque sample(s) have status 'infeasible'" in warnings


def test_torques_must_come_from_the_motion(robot):
    trajectory = _still(robot)
    n = robot.n_actuated
    short = TorqueTable(np.arange(4) * 0.01, np.zeros((4, n)), ("",) * 4)
    with pytest.raises(CompensationError, match="4 samples but the motion has 5"):
        torques_of_motion(trajectory, short, "tau.csv")
    shifted = TorqueTable(np.arange(5) * 0.02, np.zeros((5, n)), ("",) * 5)
    with pytest.raises(CompensationError, match="must come from this motion"):
        torques_of_motion(trajectory, shifted, "tau.csv")
    later = TorqueTable(10.0 + np.arange(5) * 0.01, np.ones((5, n)), ("",) * 5)
    np.testing.assert_array_equal(torques_of_motion(trajectory, later, "tau.csv"), np.ones((5, n)))


def test_every_preset_fits_servo_biped_and_an_unknown_one_is_refused(robot):
    for key in PRESETS:
        assert preset_params(key, robot).joint_names == robot.joint_names
    with pytest.raises(CompensationError, match="no preset 'table9'"):
        preset_params("table9", robot)
