"""The slider's predictor (cached, vectorised grounding) against `predict`, which grounds the
robot with pinocchio one sample at a time and caches nothing."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.library import run_motion
from app.core.quaternions import matrices_to_xyzquat, xyzquat_to_matrices
from app.core.robot.loading import load_robot
from app.core.servo.compensation import CompensationParams
from app.core.servo.grounding import LegChains
from app.core.servo.model import Prediction, ServoModel, command_configuration, predict
from app.core.servo.predictor import Predictor

ROBAN = Path(__file__).resolve().parents[1] / "third_party/roban_s14/urdf/robanS14.urdf"
ARRAYS = [f.name for f in dataclasses.fields(Prediction) if f.name != "joint_names"]


def same_prediction(fast, slow) -> None:
    for name in ARRAYS:
        np.testing.assert_allclose(
            getattr(fast, name), getattr(slow, name), atol=1e-12, err_msg=name
        )


def setup(name: str, motion: str):
    robot = load_robot(name)
    trajectory = run_motion(robot, motion, dt=0.02).trajectory
    rng = np.random.default_rng(7)
    tau = rng.normal(scale=2.0, size=(trajectory.n_samples, robot.n_actuated))
    params = CompensationParams(
        joint_names=robot.joint_names,
        k_deg_per_Nm=rng.uniform(-2.0, 2.0, robot.n_actuated),
        phi_deg=rng.uniform(0.0, 1.0, robot.n_actuated),
        enabled=rng.uniform(size=robot.n_actuated) < 0.8,
        clearance_sign="torque",
    )
    servo = ServoModel(
        robot.joint_names,
        rng.uniform(0.0, 2.0, robot.n_actuated),
        rng.uniform(0.0, 1.0, robot.n_actuated),
    )
    return robot, trajectory, tau, params, servo


@pytest.mark.parametrize(
    "name, motion", [("servo_biped", "one_leg_squats"), (str(ROBAN), "one_leg_stand")]
)
def test_the_cached_predictor_equals_the_uncached_prediction_on_every_edit(name, motion):
    if not Path(name).exists() and name != "servo_biped":
        pytest.skip("Roban S14 not available")
    robot, trajectory, tau, params, servo = setup(name, motion)
    predictor = Predictor(robot, trajectory, tau)
    assert predictor.vectorised
    same_prediction(
        predictor.predict(params, servo), predict(robot, trajectory, tau, params, servo)
    )
    # a slider move: k changes, the uncompensated robot comes from the cache
    moved = dataclasses.replace(params, k_deg_per_Nm=params.k_deg_per_Nm * 1.7 + 0.3)
    fast = predictor.predict(moved, servo)
    slow = predict(robot, trajectory, tau, moved, servo)
    same_prediction(fast, slow)
    # the servos change: the cache must not answer for the old ones
    softer = ServoModel(robot.joint_names, servo.compliance_deg_per_Nm * 2.0, servo.backlash_deg)
    same_prediction(
        predictor.predict(moved, softer), predict(robot, trajectory, tau, moved, softer)
    )
    # the ghosts' poses: every ghost configuration the studio would show, sample by sample
    for k in range(0, trajectory.n_samples, max(1, trajectory.n_samples // 7)):
        np.testing.assert_allclose(
            command_configuration(robot, trajectory, fast, k),
            command_configuration(robot, trajectory, slow, k),
            atol=1e-12,
        )


@pytest.mark.parametrize("block", [9, 64])
def test_the_predictor_in_blocks_equals_the_uncached_prediction(monkeypatch, block):
    """The predictor grounds a block of samples at a time: blocks that split the stance
    phases (one foot throughout, or both feet within a block) give the uncached prediction,
    and the last, shorter block too."""
    from app.core.servo import predictor as model

    robot, trajectory, tau, params, servo = setup("servo_biped", "one_leg_squats")
    assert trajectory.n_samples % block != 0
    # The stance switches to the right foot for stretches of several lengths (the grounding
    # then moves the base to that foot: a different leg's kinematics within a block).
    contacts = trajectory.contacts.copy()
    for begin, length in ((40, 3), (100, 80), (300, 1)):
        contacts[begin : begin + length] = (False, True)
    trajectory = dataclasses.replace(trajectory, contacts=contacts)
    monkeypatch.setattr(model, "BLOCK_SAMPLES", block)
    predictor = Predictor(robot, trajectory, tau)
    for k_scale in (1.0, -0.5):
        moved = dataclasses.replace(params, k_deg_per_Nm=params.k_deg_per_Nm * k_scale)
        same_prediction(
            predictor.predict(moved, servo), predict(robot, trajectory, tau, moved, servo)
        )


def test_the_legs_forward_kinematics_match_pinocchio():
    """T_base_foot of both legs, over random configurations, against pinocchio's frames."""
    robot = load_robot(str(ROBAN)) if ROBAN.exists() else load_robot("servo_biped")
    chains = LegChains.of(robot)
    assert chains is not None
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(5)
    q = np.array([pin.randomConfiguration(model) for _ in range(40)])
    q[:, :3] = rng.normal(size=(40, 3))  # the free base has no limits to draw within
    for foot_index, foot in enumerate(robot.feet):
        fast = chains.base_to_foot(foot_index, q)
        for k in range(len(q)):
            pin.framesForwardKinematics(model, data, q[k])
            base = data.oMi[1]
            expected = base.actInv(data.oMf[robot.link_frame_ids[foot.link]]).homogeneous
            np.testing.assert_allclose(fast[k], expected, atol=1e-12)


def test_pose_conversions_round_trip_and_follow_pinocchio():
    rng = np.random.default_rng(3)
    poses = [pin.SE3.Random() for _ in range(200)]
    poses += [
        pin.SE3(pin.exp3(np.pi * np.eye(3)[i] * s), rng.normal(size=3))
        for i in range(3)
        for s in (1, -1)
    ]
    matrices = np.array([p.homogeneous for p in poses])
    xyzquat = matrices_to_xyzquat(matrices)
    np.testing.assert_allclose(xyzquat, np.array([pin.SE3ToXYZQUAT(p) for p in poses]), atol=1e-12)
    np.testing.assert_allclose(xyzquat_to_matrices(xyzquat), matrices, atol=1e-12)


def test_the_predictor_equals_the_uncached_prediction_for_a_base_turned_round():
    """A base turned by more than 120° about the vertical (its rotation's trace ≤ 0, where the
    quaternion takes the other branch of the conversion) for part of the motion."""
    robot, trajectory, tau, params, servo = setup("servo_biped", "one_leg_squats")
    q = trajectory.q.copy()
    half = np.deg2rad(170.0) / 2.0
    yaw = pin.Quaternion(np.cos(half), 0.0, 0.0, np.sin(half))  # w, x, y, z
    for k in range(0, len(q), 3):  # every third sample: both branches within a block
        turned = yaw * pin.Quaternion(q[k, 6], q[k, 3], q[k, 4], q[k, 5])
        q[k, 3:7] = turned.coeffs()  # x, y, z, w
    trajectory = dataclasses.replace(trajectory, q=q)
    predictor = Predictor(robot, trajectory, tau)
    same_prediction(
        predictor.predict(params, servo), predict(robot, trajectory, tau, params, servo)
    )
