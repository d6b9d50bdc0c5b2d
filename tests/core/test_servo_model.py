"""The servo as a spring with backlash, its inverse (eq 7 / eq 23), and the torso it tilts."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.trajectory import from_configurations
from app.core.robot.loading import load_robot
from app.core.servo.compensation import CompensationParams, disabled_params
from app.core.servo.model import (
    ServoModel,
    ServoModelError,
    grounded_configurations,
    joint_angles,
    predict,
    servo_response,
    torso_attitude,
)

D = math.radians


@pytest.fixture(scope="module")
def robot(servo_biped):
    """servo_biped (the conftest's), under the name the tests here use; `one_leg` is its
    one-leg stand."""
    return servo_biped


def stance_frame(robot, contacts):
    left, right = contacts
    return robot.link_frame_ids[robot.feet[1 if right and not left else 0].link]


@pytest.fixture(scope="module")
def static_tau(robot, one_leg):
    """Made-up but plausible torques: the static gravity torques with the whole weight on the
    stance foot. From G(q) = Sᵀτ + Jᵀf: the base rows give the foot wrench f, the joint rows τ."""
    model, data = robot.model, robot.model.createData()
    idx_v = [joint.idx_v for joint in robot.joints]
    tau = np.empty((one_leg.n_samples, robot.n_actuated))
    for k, q in enumerate(one_leg.q):
        gravity = pin.computeGeneralizedGravity(model, data, q)
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        J = pin.getFrameJacobian(model, data, stance_frame(robot, one_leg.contacts[k]), pin.LOCAL)
        wrench = np.linalg.solve(J[:, :6].T, gravity[:6])
        tau[k] = (gravity - J.T @ wrench)[idx_v]
    return tau


def planned_roll_pitch(robot, traj):
    """The plan's torso (root link) roll and pitch, by pinocchio FK and matrixToRpy."""
    model, data = robot.model, robot.model.createData()
    root = robot.link_frame_ids[robot.tree.root]
    rpy = []
    for q in traj.q:
        pin.framesForwardKinematics(model, data, q)
        rpy.append(pin.rpy.matrixToRpy(data.oMf[root].rotation))
    return np.array(rpy)[:, 0], np.array(rpy)[:, 1]


# --- one servo ------------------------------------------------------------------------------


def test_servo_response_by_hand():
    model = ServoModel(("a", "b", "c"), [1.5, 1.5, 1.5], [4.0, 4.0, 4.0])
    q_cmd = np.full((1, 3), D(10.0))
    tau = np.array([[2.0, -2.0, 0.0]])
    # 10 − 1.5·2 − 2 = 5°;  10 + 3 + 2 = 15°;  no torque: centre of the dead band, 10°.
    assert servo_response(q_cmd, tau, model) == pytest.approx(np.array([[D(5), D(15), D(10)]]))


@pytest.mark.parametrize(
    "compliance, backlash, message",
    [
        ([float("nan")], [0.0], "compliance of a is nan"),
        ([1.0], [-1.0], "backlash of a is -1"),
        ([1.0, 2.0], [0.0], "2 value"),
    ],
)
def test_servo_model_validation(compliance, backlash, message):
    with pytest.raises(ServoModelError, match=message):
        ServoModel(("a",), compliance, backlash)


def test_matching_servo_is_inverted_exactly_by_the_torque_sign_rule():
    rng = np.random.default_rng(1)
    q, tau = rng.normal(size=(300, 3)), rng.normal(size=(300, 3))
    tau[::7] = 0.0
    params = CompensationParams(
        ("a", "b", "c"), [2.0, -40.0, 0.3], [1.0, 8.0, 0.0], [1, 1, 1], "torque"
    )
    from app.core.servo.compensation import compensated_command

    actual = servo_response(compensated_command(q, tau, params), tau, ServoModel.matching(params))
    assert np.abs(actual - q).max() < 1e-14


# --- the torso ------------------------------------------------------------------------------


def test_torso_attitude_of_the_plan_is_the_plans_own(robot, one_leg):
    roll, pitch = torso_attitude(robot, one_leg, joint_angles(robot, one_leg.q))
    roll_fk, pitch_fk = planned_roll_pitch(robot, one_leg)
    assert np.abs(roll - roll_fk).max() < 1e-12
    assert np.abs(pitch - pitch_fk).max() < 1e-12


@pytest.mark.parametrize(
    "contacts, joint, axis",
    [
        ((True, True), "left_ankle_roll", 0),
        ((True, False), "left_ankle_pitch", 1),
        ((True, False), "left_hip_roll", 0),
        ((False, True), "right_ankle_roll", 0),
        ((False, True), "right_knee", 1),
    ],
)
def test_one_deflected_stance_joint_tilts_the_torso_by_minus_its_deflection(
    robot, contacts, joint, axis
):
    """Straight legs, level pelvis, foot held flat: turning one stance-leg joint by δ turns
    everything above it by −δ about the same (world) axis, so roll or pitch becomes −δ."""
    q = np.tile(robot.q_neutral, (2, 1))
    traj = from_configurations(robot.model, "stand", robot.joint_names, 0.01, q, [contacts] * 2)
    angles = joint_angles(robot, q)
    delta = D(1.5)
    angles[:, robot.joint_names.index(joint)] += delta
    attitude = torso_attitude(robot, traj, angles)
    assert attitude[axis] == pytest.approx([-delta, -delta], abs=1e-12)
    assert attitude[1 - axis] == pytest.approx([0.0, 0.0], abs=1e-12)


def test_swing_leg_deflection_does_not_tilt_the_torso(robot):
    q = np.tile(robot.q_neutral, (2, 1))
    traj = from_configurations(robot.model, "stand", robot.joint_names, 0.01, q, [(1, 0)] * 2)
    angles = joint_angles(robot, q)
    angles[:, robot.joint_names.index("right_hip_roll")] += D(3.0)
    roll, pitch = torso_attitude(robot, traj, angles)
    assert np.abs(roll).max() < 1e-12 and np.abs(pitch).max() < 1e-12


def test_grounded_robot_keeps_its_stance_foot_where_the_plan_has_it(robot, one_leg, static_tau):
    servos = ServoModel(
        robot.joint_names, np.full(robot.n_actuated, 2.0), np.zeros(robot.n_actuated)
    )
    actual = servo_response(joint_angles(robot, one_leg.q), static_tau, servos)
    world = grounded_configurations(robot, one_leg, actual)
    model, data = robot.model, robot.model.createData()
    for k in range(0, one_leg.n_samples, 10):
        fid = stance_frame(robot, one_leg.contacts[k])
        pin.framesForwardKinematics(model, data, one_leg.q[k])
        planned = data.oMf[fid].homogeneous.copy()
        pin.framesForwardKinematics(model, data, world[k])
        assert np.abs(data.oMf[fid].homogeneous - planned).max() < 1e-12
        assert robot.joint_angles(world[k]) == pytest.approx(actual[k], abs=1e-14)


# --- predict --------------------------------------------------------------------------------


def test_matching_compensation_reproduces_the_plan(robot, one_leg, static_tau):
    compliance = np.array([0.5, 3.0, 2.0, 1.0, 2.0, 3.0] * 2)  # °/(N·m), plausible servo lags
    params = CompensationParams(
        robot.joint_names, compliance, np.zeros(12), np.ones(12, bool), "command"
    )
    prediction = predict(
        robot, one_leg, static_tau, params, ServoModel(robot.joint_names, compliance, np.zeros(12))
    )
    assert np.abs(prediction.q_actual_compensated_rad - prediction.q_plan_rad).max() < 1e-14
    roll_fk, pitch_fk = planned_roll_pitch(robot, one_leg)
    assert np.abs(prediction.roll_compensated_rad - roll_fk).max() < 1e-12
    assert np.abs(prediction.pitch_compensated_rad - pitch_fk).max() < 1e-12
    assert np.abs(prediction.roll_planned_rad - roll_fk).max() < 1e-12
    # Without compensation the loaded stance leg sags and the torso tilts.
    sag = prediction.q_actual_uncompensated_rad - prediction.q_plan_rad
    assert sag == pytest.approx(-np.deg2rad(compliance) * static_tau, abs=1e-15)
    errors = prediction.attitude_errors_deg()
    assert errors["roll_uncompensated"] > 1.0
    assert errors["pitch_uncompensated"] > 0.1
    assert errors["roll_compensated"] < 1e-9 and errors["pitch_compensated"] < 1e-9
    assert np.array_equal(
        prediction.q_cmd_rad, prediction.q_plan_rad + np.deg2rad(compliance) * static_tau
    )


def test_eq23_with_half_the_dead_band_cancels_backlash(robot, one_leg, static_tau):
    compliance = np.full(12, 1.5)
    backlash = np.full(12, 2.0)
    servos = ServoModel(robot.joint_names, compliance, backlash)
    torque_rule = CompensationParams(
        robot.joint_names, compliance, backlash / 2, np.ones(12, bool), "torque"
    )
    exact = predict(robot, one_leg, static_tau, torque_rule, servos)
    assert np.abs(exact.q_actual_compensated_rad - exact.q_plan_rad).max() < 1e-14
    assert (
        max(exact.attitude_errors_deg()[key] for key in ("roll_compensated", "pitch_compensated"))
        < 1e-9
    )
    # Spring compensation alone leaves the dead band: every loaded joint is b/2 off.
    spring_only = predict(robot, one_leg, static_tau, torque_rule_without_phi(torque_rule), servos)
    off = spring_only.q_actual_compensated_rad - spring_only.q_plan_rad
    assert off == pytest.approx(-np.deg2rad(1.0) * np.sign(static_tau), abs=1e-14)
    assert spring_only.attitude_errors_deg()["roll_compensated"] > 0.1
    # The paper's rule sign(q + kτ) is exact only where that sign is the torque's.
    paper_rule = CompensationParams(
        robot.joint_names, compliance, backlash / 2, np.ones(12, bool), "command"
    )
    paper = predict(robot, one_leg, static_tau, paper_rule, servos)
    spring = paper.q_plan_rad + np.deg2rad(compliance) * static_tau
    expected = np.deg2rad(1.0) * (np.sign(spring) - np.sign(static_tau))
    assert paper.q_actual_compensated_rad - paper.q_plan_rad == pytest.approx(expected, abs=1e-14)
    assert np.any(expected != 0.0)


def torque_rule_without_phi(params):
    return CompensationParams(
        params.joint_names, params.k_deg_per_Nm, np.zeros(params.n_joints), params.enabled, "torque"
    )


def test_predict_with_rigid_servos_and_no_compensation_is_the_plan(robot, one_leg, static_tau):
    prediction = predict(
        robot,
        one_leg,
        static_tau,
        disabled_params(robot.joint_names),
        ServoModel.rigid(robot.joint_names),
    )
    assert np.array_equal(prediction.q_actual_uncompensated_rad, prediction.q_plan_rad)
    assert np.abs(prediction.q_world_uncompensated - one_leg.q).max() < 1e-12


def test_predict_refuses_bad_inputs(robot, one_leg, static_tau):
    rigid = ServoModel.rigid(robot.joint_names)
    params = disabled_params(robot.joint_names)
    with pytest.raises(ServoModelError, match="torques have shape"):
        predict(robot, one_leg, static_tau[:, :6], params, rigid)
    with pytest.raises(ServoModelError, match="no joint named 'elbow'"):
        predict(robot, one_leg, static_tau, params, ServoModel(("elbow",), [1.0], [0.0]))
    other = load_robot("dircon_biped")
    with pytest.raises(ServoModelError, match="other joints"):
        predict(other, one_leg, static_tau, params, rigid)
