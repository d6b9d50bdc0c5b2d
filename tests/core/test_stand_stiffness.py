"""The stand check (linearised stiffness balance) against the textbook inverted pendulum and
against the simulation's stand/fall boundary on servo_biped and Roban S14."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.dynamics.stand_stiffness import stand_check
from app.core.motions.library import run_motion
from app.core.motions.trajectory import from_configurations
from app.core.robot.loading import load_robot
from app.core.servo.model import ServoModel, joint_angles
from app.core.simulation.files import default_servos
from app.core.simulation.run import simulate
from tests.conftest import ROBAN_URDF

STEP = 1.25
"""One step of compliance: the simulation must stand at c*/STEP and fall at c*·STEP."""


def _stance(robot):
    return run_motion(robot, "com_shift", shift_m=0.0, speed=100.0).trajectory.q[0]


def test_rigid_knees_and_hips_give_the_textbook_ankle_balance():
    """With every leg joint rigid but the ankles, the robot is one body turning about its
    ankle axes: it stands while the two ankle pitch servos' 2/c exceed m·g·h, h the CoM's
    height above the ankle axes (pinocchio)."""
    robot = load_robot("servo_biped")
    q = _stance(robot)
    data = robot.model.createData()
    com_z = pin.centerOfMass(robot.model, data, q)[2]
    ankle = robot.model.getJointId("left_ankle_pitch")
    h = com_z - data.oMi[ankle].translation[2]
    mgh = robot.mass_kg * 9.81 * h
    rigid = np.zeros(robot.n_actuated)
    check = stand_check(robot, q, rigid)
    assert check.gravity_Nm_per_rad == pytest.approx(mgh, rel=1e-4)  # mean of both ankles
    assert check.max_ankle_compliance_deg_per_Nm == pytest.approx(math.degrees(2.0 / mgh), rel=0.02)
    assert check.stands and "needs ≤" in check.text()


@pytest.mark.parametrize("source", ["servo_biped", str(ROBAN_URDF)])
def test_the_predicted_leg_compliance_is_the_simulations_stand_fall_boundary(source):
    """Every leg servo at c*/1.25 stands 3 s in MuJoCo, at c*·1.25 it falls (no dead band:
    the balance is linear). Roban S14 (28.7 kg, m·g·h ≈ 144 N·m/rad) cannot stand on the
    paper's 1.4 °/(N·m) servos."""
    robot = load_robot(source)
    q = _stance(robot)
    legs = default_servos(robot).for_joints(robot.joint_names).compliance_deg_per_Nm > 0.0
    check = stand_check(robot, q, np.where(legs, 1.4, 0.0))
    c_star = check.max_leg_compliance_deg_per_Nm
    assert c_star is not None and math.isfinite(c_star)
    n = 301
    stand = from_configurations(
        robot.model, "stand", robot.joint_names, 0.01, np.tile(q, (n, 1)), np.ones((n, 2), bool)
    )
    verdicts = {}
    for factor in (1.0 / STEP, STEP):
        servo = ServoModel(
            robot.joint_names, np.where(legs, factor * c_star, 0.0), np.zeros(robot.n_actuated)
        )
        verdicts[factor] = simulate(robot, stand, joint_angles(robot, stand.q), servo).outcome
    assert verdicts[1.0 / STEP].kind == "stays up", verdicts[1.0 / STEP].text
    assert verdicts[STEP].kind == "falls", verdicts[STEP].text
    assert check.stands == (c_star >= 1.4)
    if source != "servo_biped":
        assert not check.stands and check.gravity_Nm_per_rad == pytest.approx(144.0, rel=0.03)


def test_straight_legs_are_refused_in_one_line_not_a_linear_algebra_error():
    """At the neutral pose the knees are straight: the leg IK map is singular there, so the
    check must say so as a StandCheckError (the CLI then skips its note), not raise numpy's."""
    import pytest

    from app.core.dynamics.stand_stiffness import StandCheckError, stand_check
    from app.core.robot.loading import load_robot
    from app.core.simulation.files import default_servos

    robot = load_robot("servo_biped")
    compliance = default_servos(robot).for_joints(robot.joint_names).compliance_deg_per_Nm
    with pytest.raises(StandCheckError, match="singular"):
        stand_check(robot, robot.q_neutral, compliance)
