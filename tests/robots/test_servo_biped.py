"""servo_biped against the spring-compensation paper's numbers, computed with pinocchio.

Independent numbers: Table 1 (6.6 kg, 0.70 m, 6 DOF per leg), the Roban leg dimensions (hip
half-width 0.0466 m, thigh 0.1028 m, shank 0.129 m, ankle height 0.035 m) and the standing
pose of Table 2 (q_des of the 12 leg servos).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from robots.catalogue import BUILTIN_ROBOTS
from tests.robots.urdf_facts import (
    floating_model,
    frame_placements,
    geometry_bounds,
    urdf_inertials,
)

URDF_PATH = BUILTIN_ROBOTS["servo_biped"].urdf_path
LEG_JOINTS = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
LEG_LINKS = ("hip_yaw_link", "hip_roll_link", "thigh", "shank", "ankle_link", "foot")
AXES = (
    "JointModelRZ",
    "JointModelRX",
    "JointModelRY",
    "JointModelRY",
    "JointModelRY",
    "JointModelRX",
)
# Table 2 of the paper, q_des [deg] of servos 1-6 (left leg) and 7-12 (right leg).
TABLE2_Q_DES_DEG = {
    "left": (-0.00026, 0.6226, -37.9075, 68.7407, -30.8239, -0.6245),
    "right": (0.00017, -0.60888, -37.9126, 68.7484, -30.8266, 0.60647),
}


@pytest.fixture(scope="module")
def model() -> pin.Model:
    return floating_model(URDF_PATH)


def leg_q(model: pin.Model, degrees: dict[str, tuple[float, ...]]) -> np.ndarray:
    q = pin.neutral(model)
    for side, values in degrees.items():
        for joint, value_deg in zip(LEG_JOINTS, values, strict=True):
            q[model.idx_qs[model.getJointId(f"{side}_{joint}")]] = np.radians(value_deg)
    return q


def test_total_mass_is_table_1(model):
    assert pin.computeTotalMass(model) == pytest.approx(6.6, abs=1e-9)


def test_twelve_leg_joints_in_order_from_the_pelvis(model):
    assert model.nv - 6 == 12
    for side in ("left", "right"):
        ids = [model.getJointId(f"{side}_{name}") for name in LEG_JOINTS]
        assert all(i < model.njoints for i in ids)
        assert [model.parents[i] for i in ids] == [1, *ids[:-1]]
        assert [model.joints[i].shortname() for i in ids] == list(AXES)


def test_standing_height_is_table_1(model):
    q = pin.neutral(model)
    sole_z = frame_placements(model, q).oMf[model.getFrameId("left_sole")].translation[2]
    low, high = geometry_bounds(model, URDF_PATH, q)
    low_z, high_z = low[2], high[2]
    assert low_z == pytest.approx(sole_z, abs=1e-9)
    assert high_z - sole_z == pytest.approx(0.70, abs=0.01)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_leg_dimensions_are_roban(model, seed):
    q = pin.neutral(model)
    if seed:  # a seeded random leg configuration within the joint limits
        lo, hi = model.lowerPositionLimit[7:], model.upperPositionLimit[7:]
        q[7:] = np.random.default_rng(seed).uniform(lo, hi)
    data = frame_placements(model, q)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        at = {n: data.oMi[model.getJointId(f"{side}_{n}")].translation for n in LEG_JOINTS}
        assert np.linalg.norm(at["knee"] - at["hip_pitch"]) == pytest.approx(0.1028, abs=1e-9)
        assert np.linalg.norm(at["ankle_pitch"] - at["knee"]) == pytest.approx(0.129, abs=1e-9)
        sole = data.oMf[model.getFrameId(f"{side}_sole")].translation
        assert np.linalg.norm(sole - at["ankle_roll"]) == pytest.approx(0.035, abs=1e-9)
        hip_in_base = data.oMi[1].actInv(at["hip_yaw"])
        assert hip_in_base[1] == pytest.approx(sign * 0.0466, abs=1e-9)


def test_table_2_standing_pose_is_within_limits_with_flat_feet(model):
    q = leg_q(model, TABLE2_Q_DES_DEG)
    assert np.all(q >= model.lowerPositionLimit) and np.all(q <= model.upperPositionLimit)
    data = frame_placements(model, q)
    for side in ("left", "right"):
        rot = data.oMf[model.getFrameId(f"{side}_sole")].rotation
        assert np.degrees(np.linalg.norm(pin.log3(rot))) < 0.2


def test_axis_signs(model):
    def sole_after(joint: str, angle_rad: float) -> np.ndarray:
        q = pin.neutral(model)
        q[model.idx_qs[model.getJointId(joint)]] = angle_rad
        return (
            frame_placements(model, q)
            .oMf[model.getFrameId(joint.split("_")[0] + "_sole")]
            .translation
        )

    home = {s: sole_after(f"{s}_knee", 0.0) for s in ("left", "right")}
    assert sole_after("left_knee", 0.5)[0] < home["left"][0]  # knee flexion: foot backward
    assert sole_after("left_hip_pitch", -0.5)[0] > home["left"][0]  # hip flexion: foot forward
    assert sole_after("left_hip_roll", 0.3)[1] > home["left"][1]  # abduction: left foot out
    assert sole_after("right_hip_roll", -0.3)[1] < home["right"][1]  # mirrored on the right


def test_limits_efforts_and_speeds(model):
    for side in ("left", "right"):
        for name in LEG_JOINTS:
            joint = model.joints[model.getJointId(f"{side}_{name}")]
            lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
            assert lo <= 0.0 <= hi and hi - lo > 0.5
            assert model.effortLimit[joint.idx_v] == pytest.approx(6.0)
            assert model.velocityLimit[joint.idx_v] == pytest.approx(6.0)
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    left_roll = model.joints[model.getJointId("left_hip_roll")].idx_q
    right_roll = model.joints[model.getJointId("right_hip_roll")].idx_q
    assert (lo[left_roll], hi[left_roll]) == pytest.approx((-hi[right_roll], -lo[right_roll]))


def test_pinocchio_bodies_carry_the_link_masses(model):
    masses = {name: mass for name, (mass, _) in urdf_inertials(URDF_PATH).items()}
    assert sum(masses.values()) == pytest.approx(6.6, abs=1e-9)
    upper_body = ("base", "torso", "head", "left_arm", "right_arm")
    assert model.inertias[1].mass == pytest.approx(sum(masses[n] for n in upper_body), abs=1e-9)
    for side in ("left", "right"):
        for joint, link in zip(LEG_JOINTS, LEG_LINKS, strict=True):
            body = model.inertias[model.getJointId(f"{side}_{joint}")]
            assert body.mass == pytest.approx(masses[f"{side}_{link}"], abs=1e-9)
