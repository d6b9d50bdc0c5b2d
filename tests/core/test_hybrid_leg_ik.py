"""The hybrid leg's closed-form IK against pinocchio on the hybrid_leg_biped model.

FK(IK(x)) = x with FK computed independently: the actuated joints set from the IK's answer,
the passive joints solved by app.core.robot.loops.close_loops (walked there from the standing
pose so that the four-bars keep their assembly branches), and the sole's placement read from
pinocchio in the hip frame (the pelvis frame moved to the hip centre O, the hip_roll joint's
origin).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.errors import StudioError
from app.core.robot.loading import load_robot
from app.core.robot.loops import close_loops
from app.core.robot.model import RobotModel
from tests.oracles.hybrid_leg_ik import UnreachableFootPose, leg_fk, leg_ik

FK_TOL_m, FK_TOL_rad = 1e-6, 1e-6
Q30_rad, Q40_rad, Q50_rad = math.radians(151.92), math.radians(126.85), math.radians(74.1)
"""The paper's fixed angles (DESIGN.md values of the authors' code), restated here."""
ANGLE_ROUNDING_rad = 1e-5
"""q30, q40 are given to 0.01° and the URDF's points sit on a 1 µm grid."""
JOINTS = ("hip_roll", "hip_yaw", "hip_pitch", "knee", "ankle")
STRIDE_m, STEP_HEIGHT_m = 0.20, 0.10
"""Semi-ellipse of the paper's stepping test (§4.1, Figure 9): the shape is the paper's; its
size is ours (the paper does not give it). Zero stride is the paper's in-place stepping."""


@pytest.fixture(scope="module")
def robot() -> RobotModel:
    return load_robot("hybrid_leg_biped")


def q_of(robot: RobotModel, side: str, urdf_rad: np.ndarray, steps: int = 8) -> np.ndarray:
    """Configuration with one leg's actuated joints at urdf_rad and every loop closed."""
    model, data = robot.model, robot.model.createData()
    idx = [model.joints[model.getJointId(f"{side}_{name}")].idx_q for name in JOINTS]
    q = robot.q_neutral.copy()
    for fraction in np.linspace(0.0, 1.0, steps + 1)[1:]:
        q[idx] = fraction * np.asarray(urdf_rad)
        closure = close_loops(robot, q, data)
        assert closure.residual_m < 1e-9, f"loops open by {closure.residual_m:.1e} m"
        q = closure.q
    return q


def pinocchio_T_hip_sole(robot: RobotModel, side: str, urdf_rad: np.ndarray) -> np.ndarray:
    """T_hip_sole by pinocchio: hip frame = pelvis placement times the hip_roll joint origin."""
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, q_of(robot, side, urdf_rad))
    hip_roll = model.getJointId(f"{side}_hip_roll")
    T_world_hip = data.oMi[model.parents[hip_roll]] * model.jointPlacements[hip_roll]
    T_world_sole = data.oMf[model.getFrameId(f"{side}_sole", pin.BODY)]
    return (T_world_hip.inverse() * T_world_sole).homogeneous


def pose(roll: float, yaw: float, pitch: float, x: float, z: float) -> np.ndarray:
    """A sole pose a 5-DOF leg can take: a point (x, z) of a plane through the hip, turned by
    roll then yaw, the foot pitched in that plane (built with pinocchio's rotations)."""
    R_plane = pin.rpy.rpyToMatrix(roll, 0.0, 0.0) @ pin.rpy.rpyToMatrix(0.0, 0.0, yaw)
    T = np.eye(4)
    T[:3, :3] = R_plane @ pin.rpy.rpyToMatrix(0.0, pitch, 0.0)
    T[:3, 3] = R_plane @ np.array([x, 0.0, z])
    return T


STANDING = (0.117576, -1.090675)
"""Sole (x, z) [m] below the hip at q = 0 (README: E 82.576 mm ahead of O, sole 40 mm below E,
sole frame 35 mm ahead of E; hip 1090.675 mm above the sole)."""


def semi_ellipse(stride_m: float, n: int = 9) -> list[np.ndarray]:
    return [
        pose(
            0.0,
            0.0,
            0.0,
            STANDING[0] - 0.5 * stride_m * math.cos(t),
            STANDING[1] + STEP_HEIGHT_m * math.sin(t),
        )
        for t in np.linspace(0.0, math.pi, n)
    ]


GRID = [
    pose(roll, yaw, pitch, STANDING[0] + dx, STANDING[1] + dz)
    for roll in (-0.3, 0.3)
    for yaw in (-0.3, 0.0, 0.4)
    for pitch in (-0.2, 0.0, 0.2)
    for dx, dz in ((0.0, 0.05), (-0.15, 0.15), (0.15, 0.1))
]


def assert_same_pose(T: np.ndarray, T_expected: np.ndarray) -> None:
    position_m = np.linalg.norm(T[:3, 3] - T_expected[:3, 3])
    angle_rad = np.linalg.norm(pin.log3(T_expected[:3, :3].T @ T[:3, :3]))
    assert position_m < FK_TOL_m and angle_rad < FK_TOL_rad, (position_m, angle_rad)


@pytest.mark.parametrize("side", ["left", "right"])
@pytest.mark.parametrize("stride_m", [STRIDE_m, 0.0])
def test_fk_of_ik_is_identity_along_the_stepping_path(
    robot: RobotModel, side: str, stride_m: float
):
    for T in semi_ellipse(stride_m):
        angles = leg_ik(T)
        assert_same_pose(pinocchio_T_hip_sole(robot, side, angles.urdf_rad), T)


def test_fk_of_ik_is_identity_over_turned_legs_and_pitched_feet(robot: RobotModel):
    for T in GRID:
        assert_same_pose(pinocchio_T_hip_sole(robot, "left", leg_ik(T).urdf_rad), T)


def test_zero_pose_and_paper_convention(robot: RobotModel):
    """The standing sole gives all-zero URDF angles; paper q5 is the builder's 1.52° offset."""
    angles = leg_ik(pinocchio_T_hip_sole(robot, "left", np.zeros(5)))
    assert np.abs(angles.urdf_rad).max() < 1e-9
    np.testing.assert_allclose(angles.paper_rad[:4], 0.0, atol=1e-9)
    assert math.degrees(angles.paper_rad[4]) == pytest.approx(1.52, abs=0.01)
    assert set(angles.joint_values("right")) == {f"right_{name}" for name in JOINTS}


def interior(p: np.ndarray, vertex: np.ndarray, q: np.ndarray) -> float:
    u, v = p - vertex, q - vertex
    return math.atan2(np.linalg.norm(np.cross(u, v)), float(u @ v))


PAPER_POINT_JOINTS = {"A": "thigh_a", "D": "knee", "C": "shin_c", "E": "foot_e", "G": "ankle"}
PAPER_POINT_JOINTS |= {"H": "ankle_rod_h"}
"""The joint whose origin is each of the paper's points."""


def test_paper_angles_follow_eqs_27_28_32_on_the_model(robot: RobotModel):
    """q3 = π − ∠DAF − q30, q4 = ∠ADC − q40, q5 = ∠EGH − q50, the angles measured on pinocchio's
    joint positions (F straight below A in the leg plane)."""
    model, data = robot.model, robot.model.createData()
    for T in (semi_ellipse(STRIDE_m, 5)[1], GRID[7], GRID[30]):
        angles = leg_ik(T)
        pin.framesForwardKinematics(model, data, q_of(robot, "left", angles.urdf_rad))
        point = {
            key: data.oMi[model.getJointId(f"left_{joint}")].translation
            for key, joint in PAPER_POINT_JOINTS.items()
        }
        down = -data.oMi[model.getJointId("left_hip_yaw")].rotation[:, 2]
        q3 = math.pi - interior(point["D"], point["A"], point["A"] + down) - Q30_rad
        q4 = interior(point["A"], point["D"], point["C"]) - Q40_rad
        q5 = interior(point["E"], point["G"], point["H"]) - Q50_rad
        np.testing.assert_allclose(angles.paper_rad[2:], [q3, q4, q5], atol=ANGLE_ROUNDING_rad)


def test_closed_form_fk_matches_pinocchio(robot: RobotModel):
    rng = np.random.default_rng(3)
    lower = np.array([-0.5, -0.5, -1.0, -0.9, -0.8])
    upper = np.array([0.5, 0.5, 1.0, 0.6, 0.8])
    for _ in range(8):
        angles = rng.uniform(lower, upper)
        assert_same_pose(leg_fk(angles), pinocchio_T_hip_sole(robot, "right", angles))
        np.testing.assert_allclose(leg_ik(leg_fk(angles)).urdf_rad, angles, atol=1e-9)


def lowered(dz: float) -> np.ndarray:
    return pose(0.0, 0.0, 0.0, STANDING[0], STANDING[1] + dz)


@pytest.mark.parametrize(
    ("T", "words"),
    [
        (lowered(-0.1), "knee four-bar"),
        (pose(0.0, 0.0, 0.0, STANDING[0], -1.5), "hip-pitch axis A"),
        (pose(0.0, 0.0, 0.0, 1.2, 0.0), "hip-pitch axis A"),
        (pose(0.0, 0.0, 0.0, 0.035, -0.1545 - 0.04), "hip-pitch axis A"),
        (pose(0.0, 0.0, 0.6, STANDING[0], STANDING[1] + 0.05), "ankle would be"),
        (pose(0.0, 0.0, 1.4, STANDING[0], STANDING[1] + 0.05), "ankle four-bar"),
        (
            pose(0.0, 0.0, 0.0, STANDING[0], STANDING[1] + 0.3) @ pose(0.2, 0, 0, 0, 0),
            "roll its foot",
        ),
        (pose(0.7, 0.0, 0.0, STANDING[0], STANDING[1]), "hip_roll would be"),
    ],
)
def test_unreachable_pose_raises_with_a_clear_message(T: np.ndarray, words: str):
    with pytest.raises(UnreachableFootPose, match="out of reach") as caught:
        leg_ik(T)
    assert isinstance(caught.value, StudioError)
    assert words in str(caught.value), str(caught.value)
