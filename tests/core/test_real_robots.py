"""Real third-party robots load as their files say: DOF, masses, feet, forward kinematics.

Expected values are counted from the XML in the test itself (ElementTree and numpy), or come
from pinocchio's own URDF parser where it accepts the file.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from app.core.robot.loading import load_robot
from app.core.robot.report import robot_report
from robots.catalogue import BUILTIN_ROBOTS
from tests.conftest import ROBAN_URDF, SIGMABAN_URDF

ERD = Path(pin.__file__).resolve().parents[4] / "share" / "example-robot-data" / "robots"


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' formula."""
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    return (
        _rot(np.array([0, 0, 1.0]), y)
        @ _rot(np.array([0, 1.0, 0]), p)
        @ _rot(np.array([1.0, 0, 0]), r)
    )


def xml_forward_kinematics(path: Path, angles: dict[str, float]) -> dict[str, np.ndarray]:
    """World placement of every link with the root at the origin, straight from the XML."""
    root = ET.parse(path).getroot()
    joints = root.findall("joint")
    children = {j.find("child").get("link") for j in joints}
    base = next(
        link.get("name") for link in root.findall("link") if link.get("name") not in children
    )
    placements = {base: np.eye(4)}
    pending = list(joints)
    while pending:
        joint = pending.pop(0)
        parent = joint.find("parent").get("link")
        if parent not in placements:
            pending.append(joint)
            continue
        origin = joint.find("origin")
        xyz = [
            float(v)
            for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()
        ]
        rpy = [
            float(v)
            for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()
        ]
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = _rpy(*rpy), xyz
        motion = np.eye(4)
        if joint.get("type") in ("revolute", "continuous"):
            axis = joint.find("axis")
            axis_xyz = np.array(
                [float(v) for v in (axis.get("xyz") if axis is not None else "1 0 0").split()]
            )
            motion[:3, :3] = _rot(axis_xyz, angles[joint.get("name")])
        placements[joint.find("child").get("link")] = placements[parent] @ T @ motion
    return placements


def _xml_counts(path: Path) -> tuple[int, float]:
    root = ET.parse(path).getroot()
    moving = [
        j for j in root.findall("joint") if j.get("type") in ("revolute", "continuous", "prismatic")
    ]
    mass = sum(float(m.get("value")) for m in root.iter("mass"))
    return len(moving), mass


def _base_at_origin(robot, angles: np.ndarray) -> np.ndarray:
    q = robot.with_joint_angles(robot.q_neutral, angles)
    if robot.floating_base:
        q[:7] = [0, 0, 0, 0, 0, 0, 1]
    return q


@pytest.mark.parametrize("path", [ROBAN_URDF, SIGMABAN_URDF], ids=["roban_s14", "sigmaban"])
def test_dof_mass_and_fk_match_the_file(path):
    robot = load_robot(path)
    n_moving, mass = _xml_counts(path)
    assert robot.n_actuated == n_moving
    assert robot.mass_kg == pytest.approx(mass, rel=1e-9)
    assert robot.floating_base
    rng = np.random.default_rng(7)
    lower = np.array([j.lower for j in robot.joints])
    upper = np.array([j.upper for j in robot.joints])
    for _ in range(5):
        angles = rng.uniform(lower, upper)
        expected = xml_forward_kinematics(path, dict(zip(robot.joint_names, angles, strict=True)))
        got = robot.link_placements(_base_at_origin(robot, angles), robot.model.createData())
        for link, T in expected.items():
            np.testing.assert_allclose(got[link], T, atol=1e-9, err_msg=link)


def test_roban_feet_are_the_last_leg_links():
    robot = load_robot(ROBAN_URDF)
    assert [(f.side, f.link) for f in robot.feet] == [
        ("left", "leg_l6_link"),
        ("right", "leg_r6_link"),
    ]
    report = robot_report(robot)
    assert report.missing_meshes == ()
    # The file gives no effort/velocity limits: every joint is flagged.
    assert {p.subject for p in report.problems if p.kind == "limits"} == set(robot.joint_names)


def test_sigmaban_feet_and_fk_against_pinocchio_parser():
    robot = load_robot(SIGMABAN_URDF)
    assert [f.link for f in robot.feet] == ["left_foot_tip", "right_foot_tip"]
    reference = pin.buildModelFromUrdf(str(SIGMABAN_URDF), pin.JointModelFreeFlyer())
    ref_data, data = reference.createData(), robot.model.createData()
    pin.seed(3)
    for _ in range(5):
        q = pin.randomConfiguration(reference, -np.ones(reference.nq), np.ones(reference.nq))
        q[3:7] /= np.linalg.norm(q[3:7])
        # Same joint order in both models: map by name to be safe.
        ours = robot.q_neutral.copy()
        ours[:7] = q[:7]
        for joint in robot.joints:
            ours[joint.idx_q] = q[reference.joints[reference.getJointId(joint.name)].idx_q]
        pin.framesForwardKinematics(reference, ref_data, q)
        pin.framesForwardKinematics(robot.model, data, ours)
        for link, fid in robot.link_frame_ids.items():
            ref_T = ref_data.oMf[reference.getFrameId(link, pin.BODY)].homogeneous
            np.testing.assert_allclose(data.oMf[fid].homogeneous, ref_T, atol=1e-9, err_msg=link)
        np.testing.assert_allclose(
            pin.centerOfMass(robot.model, data, ours),
            pin.centerOfMass(reference, ref_data, q),
            atol=1e-9,
        )


@pytest.mark.parametrize("name", list(BUILTIN_ROBOTS))
def test_builtin_robots_load_with_feet_and_no_problems(name):
    robot = load_robot(name)
    n_moving, mass = _xml_counts(BUILTIN_ROBOTS[name].urdf_path)
    assert robot.n_actuated == n_moving - len(robot.passive_joints)
    assert robot.mass_kg == pytest.approx(mass)
    report = robot_report(robot)
    assert report.problems == ()
    assert {f.side for f in robot.feet} == {"left", "right"}


@pytest.mark.parametrize("name", ["servo_biped", "dircon_biped", "hybrid_leg_biped"])
def test_neutral_pose_stands_on_the_ground(name):
    robot = load_robot(name)
    data = robot.model.createData()
    placements = robot.link_placements(robot.q_neutral, data)
    lowest = []
    for foot in robot.feet:
        T = placements[foot.link]
        corners = (T[:3, :3] @ foot.sole_corners_m.T + T[:3, 3:4]).T
        lowest.append(corners[:, 2].min())
    assert min(lowest) == pytest.approx(0.0, abs=1e-9)
    # No visual geometry below the ground plane.
    for mesh in robot.meshes:
        T = placements[mesh.link] @ mesh.T_link_mesh
        z = (T[:3, :3] @ mesh.mesh.vertices.T + T[:3, 3:4])[2]
        assert z.min() > -1e-6, mesh.link


def test_package_uris_resolve_from_an_installed_share_folder():
    path = ERD / "bolt_description" / "robots" / "bolt.urdf"
    assert "package://example-robot-data/" in path.read_text()
    robot = load_robot(path)
    assert robot.missing_meshes == ()
    assert robot.meshes


@pytest.mark.parametrize("name, height_m", [("servo_biped", 0.70), ("dircon_biped", 1.211)])
def test_standing_height_matches_the_papers(name, height_m):
    robot = load_robot(name)
    lower, upper = robot.bounds_m(robot.q_neutral, robot.model.createData())
    assert lower[2] == pytest.approx(0.0, abs=1e-9)
    assert upper[2] == pytest.approx(height_m, abs=0.005)


def test_every_leg_joint_is_grouped_with_its_leg():
    # The hybrid leg's ankle motor drives a crank on the shin, off the chain to the foot.
    robot = load_robot("hybrid_leg_biped")
    for joint in robot.joints:
        side = "Left" if joint.name.startswith("left_") else "Right"
        assert joint.limb == f"{side} leg", joint.name
    roban = load_robot(ROBAN_URDF)
    limbs = {j.name: j.limb for j in roban.joints}
    assert limbs["waist_yaw_joint"] == "Torso"
    assert {limbs[f"leg_l{i}_joint"] for i in range(1, 7)} == {"Left leg"}
    assert {limbs[f"zarm_r{i}_joint"] for i in range(1, 5)} == {"Right arm"}
