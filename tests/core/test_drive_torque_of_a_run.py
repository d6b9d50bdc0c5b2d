"""The drive torque compensated (`app.core.simulation.drive`) uses the D and J the simulation
really runs: read back from the MuJoCo model a run builds (`engine.start`), not from the law.

Roban S14's URDF gives no effort or velocity limits (read from the file here): its servos
get the torque of the servo sized to it (issue 26: 57 N·m) at the default 6 rad/s, so their
back-EMF damping is D = τ_max/ω_max = 57/6 N·m·s/rad, in MuJoCo and in the drive torque alike
(it was 20/6 from a fixed 20 N·m while the torque limit was 57).
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from app.core.servo.catalogue import load_catalogue
from app.core.servo.model import ServoModel, joint_angles
from app.core.servo.parts import parts_from_mapping
from app.core.simulation.drive import compensated_torque_Nm, plan_drive_torque_Nm
from app.core.simulation.engine import start
from app.core.simulation.part_law import law_with_parts
from app.core.simulation.run import prepare
from app.core.simulation.servo_law import DEFAULT_VELOCITY_RAD_S
from tests.conftest import ROBAN_URDF

ISSUE_SIZED_TORQUE_NM = 57.0
"""Roban S14's sized servo torque, as issue 26 gives it (c = 0.146 °/(N·m), 57 N·m)."""


def _simulated_D_and_J(robot, trajectory, servo, law=None) -> tuple[np.ndarray, np.ndarray]:
    """The actuated joints' damping and armature in the MuJoCo model of a run."""
    inp = prepare(robot, trajectory, joint_angles(robot, trajectory.q), servo, law=law)
    model, _data, _ctrl, _ticks = start(inp)
    dofs = inp.sim.actuated_dof
    return model.dof_damping[dofs].copy(), model.dof_armature[dofs].copy()


def _by_hand(robot, trajectory, tau, damping, armature) -> np.ndarray:
    columns = [joint.idx_v for joint in robot.joints]
    return tau + damping * trajectory.v[:, columns] + armature * trajectory.a[:, columns]


def test_a_robot_without_urdf_efforts_is_damped_by_its_sized_torque():
    limits = ET.parse(ROBAN_URDF).getroot().iter("limit")
    assert all(limit.get("effort") is None for limit in limits)  # the URDF gives none
    robot = load_robot(str(ROBAN_URDF))
    trajectory = run_motion(robot, "com_shift").trajectory
    servo = ServoModel(
        robot.joint_names, np.full(robot.n_actuated, 0.146), np.zeros(robot.n_actuated)
    )
    damping, armature = _simulated_D_and_J(robot, trajectory, servo)
    expected = ISSUE_SIZED_TORQUE_NM / DEFAULT_VELOCITY_RAD_S
    np.testing.assert_allclose(damping, expected, rtol=0.01)
    rng = np.random.default_rng(7)
    tau = rng.uniform(-5.0, 5.0, (trajectory.n_samples, robot.n_actuated))
    drive = plan_drive_torque_Nm(robot, trajectory, tau, servo)
    np.testing.assert_allclose(
        drive, _by_hand(robot, trajectory, tau, damping, armature), atol=1e-9
    )
    assert compensated_torque_Nm(robot, trajectory, tau, "load", servo) is not drive
    np.testing.assert_array_equal(compensated_torque_Nm(robot, trajectory, tau, "load", servo), tau)


def test_servo_parts_on_some_joints_give_their_own_D_and_J():
    robot = load_robot("servo_biped")
    trajectory = run_motion(robot, "com_shift").trajectory
    chosen = tuple(n for n in robot.joint_names if "knee" in n)
    parts = parts_from_mapping({"servo": "mx64"}, chosen, load_catalogue(), "test")
    servo = ServoModel(
        robot.joint_names, np.full(robot.n_actuated, 1.4), np.full(robot.n_actuated, 0.5)
    )
    law = law_with_parts(robot, servo, parts)
    damping, armature = _simulated_D_and_J(robot, trajectory, servo, law)
    mine = np.array([n in chosen for n in robot.joint_names])
    assert not np.allclose(damping[mine], damping[~mine][0])  # the parts differ from the rest
    np.testing.assert_allclose(damping[~mine], 6.0 / 6.0)  # servo_biped's URDF: 6 N·m, 6 rad/s
    tau = np.zeros((trajectory.n_samples, robot.n_actuated))
    drive = plan_drive_torque_Nm(robot, trajectory, tau, servo, law)
    np.testing.assert_allclose(
        drive, _by_hand(robot, trajectory, tau, damping, armature), atol=1e-12
    )
    assert np.abs(drive).max() > 0.0  # the motion moves: there is something to compensate


@pytest.mark.parametrize("torque", ["drive", "load"])
def test_a_motion_at_rest_needs_no_more_than_its_load(torque):
    """At rest (q̇ = q̈ = 0) the drive torque is τ: a standing pose is compensated as eq 7."""
    robot = load_robot("servo_biped")
    trajectory = run_motion(robot, "com_shift").trajectory
    still = dataclasses.replace(
        trajectory, v=np.zeros_like(trajectory.v), a=np.zeros_like(trajectory.a)
    )
    tau = np.ones((trajectory.n_samples, robot.n_actuated))
    servo = ServoModel(
        robot.joint_names, np.full(robot.n_actuated, 1.4), np.zeros(robot.n_actuated)
    )
    np.testing.assert_array_equal(compensated_torque_Nm(robot, still, tau, torque, servo), tau)
