"""dircon_biped against the symmetric-gait paper's numbers, computed with pinocchio.

Independent numbers (Chen et al. 2023, section 4): Table 1 joint ranges, Table 2 link masses,
18.532 kg, 10 revolute joints, 13 links with two fixed hip roll mounts, rated torques 13.0 N·m
(ankle 38.7 N·m), 6.28 rad/s (section 5.1), height 1.211 m, width 275 mm and feet 190 x 75 mm
(Figure 2), CoM between the legs.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

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

URDF_PATH = BUILTIN_ROBOTS["dircon_biped"].urdf_path
# Table 1 [deg] (left leg; the right hip roll is mirrored) and section 4 rated torques [N·m].
LEG = (
    # joint, child link, pinocchio joint type, range [deg], effort [N·m], Table 2 mass [kg]
    ("hip_roll", "hip_yaw_link", "JointModelRX", (-15, 95), 13.0, 0.776),
    ("hip_yaw", "hip_pitch_link", "JointModelRZ", (-45, 45), 13.0, 0.743),
    ("hip_pitch", "thigh", "JointModelRY", (-47, 47), 13.0, 1.116),
    ("knee", "shank", "JointModelRY", (-63, 63), 13.0, 1.597),
    ("ankle_pitch", "foot", "JointModelRY", (-85, 85), 38.7, 0.300),
)
TABLE2_BASE_KG, TABLE2_HIP_ROLL_KG, TABLE2_TOTAL_KG = 7.624, 0.922, 18.532


@pytest.fixture(scope="module")
def model() -> pin.Model:
    return floating_model(URDF_PATH)


def test_total_mass_is_table_2(model):
    assert pin.computeTotalMass(model) == pytest.approx(TABLE2_TOTAL_KG, abs=1e-9)


def test_link_masses_are_table_2(model):
    masses = {name: mass for name, (mass, _) in urdf_inertials(URDF_PATH).items()}
    assert len(masses) == 13  # section 4: 13 links
    assert masses["base"] == pytest.approx(TABLE2_BASE_KG)
    # The hip roll links are fixed to the baselink, so pinocchio merges them into the base body.
    merged_kg = TABLE2_BASE_KG + 2 * TABLE2_HIP_ROLL_KG
    assert model.inertias[1].mass == pytest.approx(merged_kg, abs=1e-9)
    for side in ("left", "right"):
        assert masses[f"{side}_hip_roll_link"] == pytest.approx(TABLE2_HIP_ROLL_KG)
        for joint, link, _, _, _, mass_kg in LEG:
            assert masses[f"{side}_{link}"] == pytest.approx(mass_kg)
            assert model.inertias[model.getJointId(f"{side}_{joint}")].mass == pytest.approx(
                mass_kg
            )


def test_ten_revolute_joints_in_order_from_the_base(model):
    assert model.nv - 6 == 10
    for side in ("left", "right"):
        ids = [model.getJointId(f"{side}_{joint}") for joint, *_ in LEG]
        assert all(i < model.njoints for i in ids)
        assert [model.parents[i] for i in ids] == [1, *ids[:-1]]
        assert [model.joints[i].shortname() for i in ids] == [kind for _, _, kind, *_ in LEG]
    fixed = [
        (j.find("parent").get("link"), j.find("child").get("link"))
        for j in ET.parse(URDF_PATH).getroot().iter("joint")
        if j.get("type") == "fixed" and not j.find("child").get("link").endswith("_sole")
    ]
    assert sorted(fixed) == [("base", "left_hip_roll_link"), ("base", "right_hip_roll_link")]


def test_limits_are_table_1(model):
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    for side in ("left", "right"):
        for joint, _, kind, (lower_deg, upper_deg), effort_Nm, _ in LEG:
            j = model.joints[model.getJointId(f"{side}_{joint}")]
            expected = (math.radians(lower_deg), math.radians(upper_deg))
            if side == "right" and kind != "JointModelRY":  # mirrored about the x-z plane
                expected = (-expected[1], -expected[0])
            # The URDF writer prints 6 significant digits: within 1e-5 rad (0.0006°).
            assert (lo[j.idx_q], hi[j.idx_q]) == pytest.approx(expected, abs=1e-5)
            assert model.effortLimit[j.idx_v] == pytest.approx(effort_Nm)
            assert model.velocityLimit[j.idx_v] == pytest.approx(6.28)


def test_hip_roll_range_abducts_outward(model):
    for side, sign in (("left", 1.0), ("right", -1.0)):
        j = model.joints[model.getJointId(f"{side}_hip_roll")]
        outward = (
            model.upperPositionLimit[j.idx_q] if sign > 0 else model.lowerPositionLimit[j.idx_q]
        )
        q = pin.neutral(model)
        q[j.idx_q] = outward
        sole_y = frame_placements(model, q).oMf[model.getFrameId(f"{side}_sole")].translation[1]
        home_y = (
            frame_placements(model, pin.neutral(model))
            .oMf[model.getFrameId(f"{side}_sole")]
            .translation[1]
        )
        assert abs(outward) == pytest.approx(math.radians(95), abs=1e-5)
        assert sign * (sole_y - home_y) > 0.5  # 95° of abduction swings the foot far outward


def test_size_height_width_and_feet(model):
    q = pin.neutral(model)
    data = frame_placements(model, q)
    sole_z = data.oMf[model.getFrameId("left_sole")].translation[2]
    low, high = geometry_bounds(model, URDF_PATH, q)
    assert low[2] == pytest.approx(sole_z, abs=1e-9)
    assert high[2] - sole_z == pytest.approx(1.211, abs=0.01)
    assert high[1] - low[1] == pytest.approx(0.275, abs=0.01)
    for side in ("left", "right"):
        foot_low, foot_high = geometry_bounds(model, URDF_PATH, q, (f"{side}_foot",))
        assert foot_high[0] - foot_low[0] == pytest.approx(0.190, abs=1e-9)
        assert foot_high[1] - foot_low[1] == pytest.approx(0.075, abs=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_leg_lengths_add_up_to_the_height(model, seed):
    q = pin.neutral(model)
    if seed:  # a seeded random leg configuration within the joint limits
        q[7:] = np.random.default_rng(seed).uniform(
            model.lowerPositionLimit[7:], model.upperPositionLimit[7:]
        )
    data = frame_placements(model, q)
    for side in ("left", "right"):
        at = {joint: data.oMi[model.getJointId(f"{side}_{joint}")].translation for joint, *_ in LEG}
        thigh_m = np.linalg.norm(at["knee"] - at["hip_pitch"])
        shank_m = np.linalg.norm(at["ankle_pitch"] - at["knee"])
        assert thigh_m == pytest.approx(shank_m, abs=1e-9)
    if not seed:
        base_top_m = geometry_bounds(model, URDF_PATH, q, ("base",))[1][2]
        sole_z = data.oMf[model.getFrameId("left_sole")].translation[2]
        assert base_top_m - sole_z == pytest.approx(1.211, abs=1e-9)


def test_com_is_between_the_legs_and_high(model):
    q = pin.neutral(model)
    com = pin.centerOfMass(model, model.createData(), q)
    data = frame_placements(model, q)
    sole_z = data.oMf[model.getFrameId("left_sole")].translation[2]
    assert abs(com[0]) < 1e-9 and abs(com[1]) < 1e-9
    assert (com[2] - sole_z) / 1.211 > 0.5  # "mid-top": upper half of the robot
