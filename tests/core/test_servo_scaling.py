"""Servos sized to the robot: the reference m·g·h recomputed, the issue's numbers for Roban S14,
and the sized servo inside the stand boundary of every robot the stand check fits."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.dynamics.stand_stiffness import StandCheckError, stand_check
from app.core.papers import TYPICAL_COMPLIANCE_DEG_PER_NM
from app.core.posing.ready_pose import ready_pose
from app.core.robot.loading import load_robot
from app.core.servo.presets import preset_params
from app.core.servo.scaling import (
    PAPER_GRAVITY_NM_PER_RAD,
    PAPER_MASS_KG,
    PAPER_TORQUE_LIMIT_NM,
    scaled_ideal_servo,
)
from app.core.simulation.files import sized_servos
from robots.catalogue import BUILTIN_ROBOTS
from tests.conftest import ROBAN_URDF, SIGMABAN_URDF


def _mgh_by_hand(robot) -> float:
    """m·g·h at the neutral pose, h above the ankle roll joints (pinocchio, by joint name)."""
    model, data = robot.model, robot.model.createData()
    com = pin.centerOfMass(model, data, robot.q_neutral)
    ankles = [
        data.oMi[model.getJointId(f"{side}_ankle_roll")].translation[2]
        for side in ("left", "right")
    ]
    return robot.mass_kg * 9.81 * (com[2] - np.mean(ankles))


def test_the_reference_is_servo_biped_the_papers_robot():
    robot = load_robot("servo_biped")
    assert robot.mass_kg == pytest.approx(PAPER_MASS_KG)
    assert _mgh_by_hand(robot) == pytest.approx(PAPER_GRAVITY_NM_PER_RAD, rel=1e-3)
    scaled = scaled_ideal_servo(robot)
    assert scaled.compliance_deg_per_Nm == TYPICAL_COMPLIANCE_DEG_PER_NM  # the paper's 1.4
    assert scaled.torque_limit_Nm == PAPER_TORQUE_LIMIT_NM
    # the paper robot's leg servos as its URDF has them
    assert all(j.effort == PAPER_TORQUE_LIMIT_NM for j in robot.joints)


def test_roban_s14_gets_the_issues_sized_servo():
    """Issue 26's audit: 0.146 °/(N·m) and 57 N·m for the 28.7 kg Roban S14."""
    scaled = scaled_ideal_servo(load_robot(str(ROBAN_URDF)))
    assert scaled.compliance_deg_per_Nm == pytest.approx(0.146, rel=0.05)
    assert scaled.torque_limit_Nm == pytest.approx(57.0, rel=0.05)
    # the rule keeps c·m·g·h (the stand margin) and τ/(m·g·h)
    assert scaled.compliance_deg_per_Nm * scaled.gravity_Nm_per_rad == pytest.approx(
        TYPICAL_COMPLIANCE_DEG_PER_NM * PAPER_GRAVITY_NM_PER_RAD, rel=0.01
    )
    assert "0.148 °/(N·m)" in scaled.text() and "56.8 N·m" in scaled.text()


def _sources() -> list[str]:
    return [*BUILTIN_ROBOTS, str(ROBAN_URDF), str(SIGMABAN_URDF)]


@pytest.mark.parametrize("source", _sources())
def test_the_sized_servo_stands_where_the_stand_check_fits(source):
    """Every built-in and vendored robot whose legs the stand check fits stands, at its ready
    (bent-knee) pose, on its sized leg servos, with a margin (the paper's robot has 3×)."""
    robot = load_robot(source)
    servo = sized_servos(robot)
    try:
        check = stand_check(robot, ready_pose(robot).q, servo.compliance_deg_per_Nm)
    except StandCheckError as error:
        pytest.skip(f"the stand check does not fit {robot.name}: {error}")
    assert check.stands, check.text()
    c = float(servo.compliance_deg_per_Nm.max())
    limit = check.max_leg_compliance_deg_per_Nm
    assert limit is not None and (math.isinf(limit) or limit > 2.0 * c)


def test_roban_s14_falls_on_the_papers_servo_and_stands_on_its_own():
    robot = load_robot(str(ROBAN_URDF))
    q = ready_pose(robot).q
    sized = sized_servos(robot)
    legs = sized.compliance_deg_per_Nm > 0.0
    paper = np.where(legs, TYPICAL_COMPLIANCE_DEG_PER_NM, 0.0)
    assert not stand_check(robot, q, paper).stands
    assert stand_check(robot, q, sized.compliance_deg_per_Nm).stands


def test_the_uniform_preset_compensates_the_sized_servo():
    robot = load_robot(str(ROBAN_URDF))
    params = preset_params("uniform", robot)
    sized = sized_servos(robot)
    np.testing.assert_array_equal(params.k_deg_per_Nm, sized.compliance_deg_per_Nm)


def test_roban_s14_stands_in_the_simulation_on_its_sized_servos():
    """3 s standing still at the ready pose in MuJoCo (dead band included): on the paper's
    servo Roban S14 falls (m·g·h ≈ 150 N·m/rad against 82 from its ankles); on its sized
    servo it stays up, and the URDF's missing torque limits are the sized 57 N·m."""
    from app.core.motions.trajectory import from_configurations
    from app.core.servo.model import joint_angles
    from app.core.simulation.files import default_servos
    from app.core.simulation.run import simulate

    robot = load_robot(str(ROBAN_URDF))
    q = ready_pose(robot).q
    n = 301
    stand = from_configurations(
        robot.model, "stand", robot.joint_names, 0.01, np.tile(q, (n, 1)), np.ones((n, 2), bool)
    )
    q_plan = joint_angles(robot, stand.q)
    paper = simulate(robot, stand, q_plan, default_servos(robot))
    sized = simulate(robot, stand, q_plan, sized_servos(robot))
    assert paper.outcome.kind == "falls", paper.verdict()
    assert sized.outcome.kind == "stays up", sized.verdict()
    assert any("56.8 N·m" in note for note in sized.notes), sized.notes
