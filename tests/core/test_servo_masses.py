"""Servo masses replacing the links': total mass and pinocchio's centre of mass."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.robot.loading import load_robot
from app.core.servo.masses import ServoMassError, with_servo_masses


@pytest.fixture(scope="module")
def robot():
    return load_robot("servo_biped")


def test_mass_and_com_move_as_the_point_masses_say(robot):
    new = {"left_knee": 0.153, "right_knee": 0.153, "left_hip_roll": 0.135}
    counted = {"left_knee": 0.077, "right_knee": 0.077}
    heavier, swap = with_servo_masses(robot, new, counted)
    delta = {name: new[name] - counted.get(name, 0.0) for name in new}
    assert heavier.mass_kg == pytest.approx(robot.mass_kg + sum(delta.values()), abs=1e-12)
    assert swap.mass_after_kg - swap.mass_before_kg == pytest.approx(sum(delta.values()))
    # CoM at a bent pose: the old CoM and the moved point masses at the joints' origins (from
    # the original model's forward kinematics), weighted.
    q = robot.q_neutral.copy()
    rng = np.random.default_rng(1)
    for joint in robot.joints:
        q[joint.idx_q] = rng.uniform(max(joint.lower, -0.5), min(joint.upper, 0.5))
    data = robot.model.createData()
    com = pin.centerOfMass(robot.model, data, q)
    weighted = robot.mass_kg * com
    for name, dm in delta.items():
        weighted += dm * data.oMi[robot.model.getJointId(name)].translation
    expected = weighted / (robot.mass_kg + sum(delta.values()))
    moved = pin.centerOfMass(heavier.model, heavier.model.createData(), q)
    assert np.allclose(moved, expected, atol=1e-12)
    assert not np.allclose(moved, com, atol=1e-6)
    assert robot.model.inertias[robot.model.getJointId("left_knee")].mass != (
        heavier.model.inertias[heavier.model.getJointId("left_knee")].mass
    )  # the original is untouched: a copy


def test_swapping_a_servo_for_itself_changes_nothing(robot):
    same, _ = with_servo_masses(robot, {"left_knee": 0.1}, {"left_knee": 0.1})
    q = robot.q_neutral
    a = pin.centerOfMass(robot.model, robot.model.createData(), q)
    b = pin.centerOfMass(same.model, same.model.createData(), q)
    assert np.allclose(a, b, atol=1e-14) and same.mass_kg == pytest.approx(robot.mass_kg)


@pytest.mark.parametrize(
    ("new", "counted", "words"),
    [
        ({"no_joint": 0.1}, None, "no joint named"),
        ({"left_knee": float("nan")}, None, "finite mass"),
        ({"left_knee": -0.1}, None, "finite mass"),
        ({"left_knee": 0.1}, {"left_knee": 1e3}, "leaves no mass"),
        ({}, {"left_knee": 0.1}, "no new one"),
    ],
)
def test_bad_masses_are_one_clear_error(robot, new, counted, words):
    with pytest.raises(ServoMassError, match=words):
        with_servo_masses(robot, new, counted)
