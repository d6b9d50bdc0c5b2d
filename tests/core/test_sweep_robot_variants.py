"""Robot parameters: a changed URDF whose geometry and masses pinocchio confirms."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.sweeps.robot_variants import RobotVariant, SweepSpecError


def _mass(robot) -> float:
    return float(sum(inertia.mass for inertia in robot.model.inertias))


def _base_height(robot) -> float:
    return float(robot.q_neutral[2])


def test_longer_segments_raise_the_standing_base_by_their_extra_length():
    plain = RobotVariant.of("dircon_biped", {}).load()
    longer = RobotVariant.of(
        "dircon_biped", {"thigh_length_m": 0.43, "shank_length_m": 0.36}
    ).load()
    extra = (0.43 - 0.3905) + (0.36 - 0.3905)
    # both models stand with their soles on z = 0: the base rises by the legs' extra length
    assert _base_height(longer) - _base_height(plain) == pytest.approx(extra, abs=1e-6)
    assert _mass(longer) == pytest.approx(_mass(plain), abs=1e-9)  # lengths keep the masses
    # the thigh's centre of mass moved with its length (a rod: in proportion)
    thigh = longer.model.getJointId("left_hip_pitch")
    base_thigh = plain.model.getJointId("left_hip_pitch")
    ratio = longer.model.inertias[thigh].lever[2] / plain.model.inertias[base_thigh].lever[2]
    assert ratio == pytest.approx(0.43 / 0.3905, rel=1e-6)


def test_masses_change_the_total_mass_by_exactly_the_difference():
    plain = RobotVariant.of("dircon_biped", {}).load()
    heavy = RobotVariant.of("dircon_biped", {"base_mass_kg": 10.0, "foot_mass_kg": 0.5}).load()
    assert _mass(heavy) - _mass(plain) == pytest.approx((10.0 - 7.624) + 2 * (0.5 - 0.3), abs=1e-6)
    mass_matrix = pin.crba(heavy.model, heavy.model.createData(), heavy.q_neutral)
    mass_matrix = np.triu(mass_matrix) + np.triu(mass_matrix, 1).T
    assert np.linalg.eigvalsh(mass_matrix).min() > 0.0  # inertias still physical


def test_out_of_range_and_unknown_parameters_are_refused():
    with pytest.raises(SweepSpecError, match=r"\[0.25, 0.55\]"):
        RobotVariant.of("dircon_biped", {"thigh_length_m": 0.9})
    with pytest.raises(SweepSpecError, match=r"\[0.07, 0.16\]"):
        RobotVariant.of("servo_biped", {"thigh_length_m": 0.3})
    with pytest.raises(SweepSpecError, match="no sweepable robot parameters"):
        RobotVariant.of("hybrid_leg_biped", {"thigh_length_m": 0.3})
    with pytest.raises(SweepSpecError, match="known: thigh_length_m"):
        RobotVariant.of("dircon_biped", {"tail_m": 0.3})


def test_servo_biped_lengths_masses_and_torque_limit_reach_pinocchio_and_the_planner():
    from app.core.sweeps.sampling import sweep_points
    from app.core.sweeps.spec import SweepSpec

    plain = RobotVariant.of("servo_biped", {}).load()
    values = {
        "thigh_length_m": 0.12,
        "shank_length_m": 0.10,
        "torso_mass_kg": 2.0,
        "torque_limit_Nm": 9.0,
    }
    changed = RobotVariant.of("servo_biped", values).load()
    extra = (0.12 - 0.1028) + (0.10 - 0.129)
    assert _base_height(changed) - _base_height(plain) == pytest.approx(extra, abs=1e-6)
    assert _mass(changed) - _mass(plain) == pytest.approx(2.0 - 1.4, abs=1e-6)
    legs = [j for j in changed.joint_names if j.startswith(("left_", "right_"))]
    assert len(legs) == 12
    for name in legs:
        index = changed.model.getJointId(name)
        assert changed.model.effortLimit[changed.model.joints[index].idx_v] == 9.0
        assert plain.model.effortLimit[plain.model.joints[index].idx_v] == 6.0
    # the planner's torque bound follows the servos' limit
    spec = SweepSpec.from_mapping(
        {
            "robot": "servo_biped",
            "samples": 3,
            "parameter": [{"kind": "robot", "name": "torque_limit_Nm", "min": 4.0, "max": 12.0}],
        }
    )
    for point in sweep_points(spec):
        assert point.settings.tau_max_Nm == point.values[0]
    with pytest.raises(SweepSpecError, match="sets the planner's tau_max_Nm itself"):
        SweepSpec.from_mapping(
            {
                "robot": "servo_biped",
                "parameter": [
                    {"kind": "robot", "name": "torque_limit_Nm", "min": 4.0, "max": 12.0},
                    {"kind": "gait", "name": "tau_max_Nm", "min": 4.0, "max": 12.0},
                ],
            }
        )


@pytest.mark.parametrize(
    ("robot_name", "length", "width"),
    [("servo_biped", 0.2, 0.06), ("dircon_biped", 0.25, 0.12), ("dircon_biped", 0.13, 0.05)],
)
def test_foot_size_moves_the_sole_corners_and_keeps_the_mass(robot_name, length, width):
    import xml.etree.ElementTree as ET

    import robots.dircon_biped.build as dircon
    import robots.servo_biped.build as servo

    builder = {"servo_biped": servo, "dircon_biped": dircon}[robot_name]
    thickness = builder.SOLE_THICKNESS_M
    variant = RobotVariant.of(robot_name, {"sole_length_m": length, "sole_width_m": width})
    # the URDF: each foot's lowest collision box is the sole, of the asked size
    root = ET.fromstring(variant.urdf_text())
    for side in ("left", "right"):
        (foot,) = [link for link in root.iter("link") if link.get("name") == f"{side}_foot"]
        boxes = []
        for collision in foot.findall("collision"):
            box = collision.find("geometry/box")
            origin = collision.find("origin")
            if box is not None and origin is not None:
                size = [float(x) for x in box.get("size", "").split()]
                z = float(origin.get("xyz", "").split()[2])
                boxes.append((z - 0.5 * size[2], size))
        assert min(boxes)[1] == pytest.approx([length, width, thickness], abs=1e-6)
    plain, big = RobotVariant.of(robot_name, {}).load(), variant.load()
    assert _mass(big) == pytest.approx(_mass(plain), abs=1e-9)  # a foot keeps its mass
    # the studio's sole (read from the collision meshes), placed by pinocchio at the neutral
    # pose: a rectangle of length × width on the floor, centred under the ankle
    data = big.model.createData()
    pin.framesForwardKinematics(big.model, data, big.q_neutral)
    for side in ("left", "right"):
        foot = big.foot(side)
        placement = data.oMf[big.link_frame_ids[foot.link]]
        corners = np.array([placement.act(c) for c in foot.sole_corners_m])
        ankle = data.oMi[big.model.getJointId(f"{side}_ankle_pitch")].translation
        assert np.ptp(corners[:, 0]) == pytest.approx(length, abs=1e-6)
        assert np.ptp(corners[:, 1]) == pytest.approx(width, abs=1e-6)
        assert corners[:, :2].mean(axis=0) == pytest.approx(ankle[:2], abs=1e-6)
        assert corners[:, 2] == pytest.approx(np.zeros(4), abs=1e-6)  # standing on z = 0
    # the planner's heel and toe are the sole's rear and front edges: length apart
    from app.core.collocation.planar_model import PlanarModel, evaluate

    planar = PlanarModel(big)
    heel_toe = evaluate(planar.contact_positions, planar.from_full_q(big.q_neutral)).reshape(4, 2)
    for heel, toe in (heel_toe[0:2], heel_toe[2:4]):
        assert toe[0] - heel[0] == pytest.approx(length, abs=1e-6)
        assert heel[1] == pytest.approx(0.0, abs=1e-6) and toe[1] == pytest.approx(0.0, abs=1e-6)


def test_foot_size_defaults_build_the_committed_robot_and_bad_sizes_are_refused():
    import robots.dircon_biped.build as dircon
    import robots.servo_biped.build as servo
    from robots.catalogue import BUILTIN_ROBOTS

    for name, builder in (("servo_biped", servo), ("dircon_biped", dircon)):
        assert builder.build_urdf() == BUILTIN_ROBOTS[name].urdf_path.read_text(encoding="utf-8")
    assert servo.build_urdf(sole_length_m=0.14, sole_width_m=0.08) == servo.build_urdf()
    assert dircon.build_urdf(foot_length_m=0.19, foot_width_m=0.075) == dircon.build_urdf()
    with pytest.raises(SweepSpecError, match=r"\[0.05, 0.09\]"):
        RobotVariant.of("servo_biped", {"sole_width_m": 0.12})  # the feet would overlap
