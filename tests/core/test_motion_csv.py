"""Motion CSV files: exact round trip, a header that names every column, clear refusals, and
the import of the two real Roban S14 motions with an independent check of the quaternion order.
"""

from __future__ import annotations

import csv
import io
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.csv_files import (
    MotionFileError,
    read_roban_motion_csv,
    read_trajectory_csv,
    sole_contacts,
    write_trajectory_csv,
)
from app.core.motions.trajectory import Trajectory, from_configurations
from app.core.robot.loading import load_robot
from app.core.robot.model import RobotModel
from tests.conftest import ROBAN_URDF, tiny_biped_urdf

MOTIONS = ROBAN_URDF.parents[1] / "motions"
DANCE = MOTIONS / "new_year_dance_100fps.csv"
PRONE = MOTIONS / "prone_120fps.csv"


@pytest.fixture(scope="module")
def servo() -> RobotModel:
    return load_robot("servo_biped")


@pytest.fixture(scope="module")
def roban() -> RobotModel:
    return load_robot(ROBAN_URDF)


def smooth_motion(robot: RobotModel, n: int = 40, dt: float = 0.01) -> Trajectory:
    """A made-up smooth motion: the base drifts, sways, yaws and rolls; every joint swings."""
    t = np.arange(n) * dt
    q = np.tile(robot.q_neutral, (n, 1))
    for k, tk in enumerate(t):
        rotation = pin.rpy.rpyToMatrix(0.05 * np.sin(3 * tk), 0.02, 0.8 * tk)
        drift = np.array([0.1 * tk, 0.02 * np.sin(5 * tk), 0.01 * np.cos(4 * tk)])
        position = robot.q_neutral[:3] + drift
        q[k, :7] = pin.SE3ToXYZQUAT(pin.SE3(rotation, position))
    # every joint swings inside its limits (an import refuses a joint past them)
    lower = np.array([j.lower for j in robot.joints])
    upper = np.array([j.upper for j in robot.joints])
    middle, amplitude = (lower + upper) / 2, np.minimum(0.3, 0.45 * (upper - lower))
    angles = np.array(
        [
            middle[i] + amplitude[i] * np.sin(2 * np.pi * 1.2 * t + 0.4 * i)
            for i in range(robot.n_actuated)
        ]
    ).T
    q = np.array([robot.with_joint_angles(q_k, a_k) for q_k, a_k in zip(q, angles, strict=True)])
    contacts = np.stack([(t % 0.2) < 0.12, (t % 0.2) >= 0.08], axis=1)
    return from_configurations(robot.model, "smooth", robot.joint_names, dt, q, contacts)


def assert_same(read: Trajectory, written: Trajectory) -> None:
    assert read.joint_names == written.joint_names
    for field in ("t", "q", "v", "a"):
        np.testing.assert_allclose(
            getattr(read, field), getattr(written, field), rtol=0, atol=1e-12, err_msg=field
        )
    np.testing.assert_array_equal(read.contacts, written.contacts)


def header_of(path: Path) -> list[str]:
    with open(path, newline="") as file:
        return next(csv.reader(file))


def test_round_trip_is_exact(servo, tmp_path) -> None:
    traj = smooth_motion(servo)
    path = tmp_path / "walk.csv"
    write_trajectory_csv(traj, path, servo)
    read = read_trajectory_csv(path, servo)
    assert read.name == "walk"
    assert_same(read, traj)


def test_round_trip_through_an_open_text_file(servo) -> None:
    traj = smooth_motion(servo, n=5)
    buffer = io.StringIO()
    write_trajectory_csv(traj, buffer, servo)
    buffer.seek(0)
    assert_same(read_trajectory_csv(buffer, servo), traj)


def test_header_names_every_column_with_joint_and_unit(servo, tmp_path) -> None:
    traj = smooth_motion(servo)
    path = tmp_path / "walk.csv"
    write_trajectory_csv(traj, path, servo)
    header = header_of(path)
    units = {}
    for cell in header:
        match = re.fullmatch(r"(\S+)(?: \[(.+)\])?", cell)
        assert match, cell
        units[match[1]] = match[2]
    assert len(units) == len(header) == 1 + 7 + 3 * 12 + 2 * 6 + 2
    assert units["t"] == "s"
    assert [units[f"base_{c}"] for c in "xyz"] == ["m"] * 3
    assert all(units[f"base_q{c}"] is None for c in "xyzw")
    assert header.index("base_qx") < header.index("base_qw")  # xyzw order
    for name in servo.joint_names:
        assert units[f"q:{name}"] == "rad"
        assert units[f"v:{name}"] == "rad/s"
        assert units[f"a:{name}"] == "rad/s^2"
    for c in "xyz":
        assert units[f"v:base_v{c}"] == "m/s" and units[f"v:base_w{c}"] == "rad/s"
        assert units[f"a:base_v{c}"] == "m/s^2" and units[f"a:base_w{c}"] == "rad/s^2"
    assert units["contact_left"] == units["contact_right"] == "0/1"

    # Values sit under their names: check row 3 against pinocchio's own layout.
    with open(path, newline="") as file:
        rows = list(csv.DictReader(file))
    row, k = rows[3], 3
    assert float(row["t [s]"]) == traj.t[k]
    assert [float(row[f"base_q{c}"]) for c in "xyzw"] == list(traj.q[k, 3:7])
    for name in servo.joint_names:
        joint = servo.model.joints[servo.model.getJointId(name)]
        assert float(row[f"q:{name} [rad]"]) == traj.q[k, joint.idx_q]
        assert float(row[f"a:{name} [rad/s^2]"]) == traj.a[k, joint.idx_v]
    assert float(row["v:base_wz [rad/s]"]) == traj.v[k, 5]
    assert row["contact_left [0/1]"] == str(int(traj.contacts[k, 0]))


def test_missing_velocity_columns_are_computed_from_the_configurations(servo, tmp_path) -> None:
    traj = smooth_motion(servo)
    full, reduced = tmp_path / "full.csv", tmp_path / "positions.csv"
    write_trajectory_csv(traj, full, servo)
    with open(full, newline="") as src, open(reduced, "w", newline="") as dst:
        rows = list(csv.reader(src))
        keep = [i for i, name in enumerate(rows[0]) if not name.startswith(("v:", "a:"))]
        csv.writer(dst).writerows([[row[i] for i in keep] for row in rows])
    assert len(keep) == 1 + 7 + 12 + 2
    assert_same(read_trajectory_csv(reduced, servo), traj)


def test_continuous_joint_is_written_as_an_angle(write_urdf, tmp_path) -> None:
    text = tiny_biped_urdf().replace(
        '<joint name="left_knee" type="revolute">', '<joint name="left_knee" type="continuous">'
    )
    robot = load_robot(write_urdf(text))
    assert [j.kind for j in robot.joints].count("continuous") == 1
    traj = smooth_motion(robot)
    path = tmp_path / "tiny.csv"
    write_trajectory_csv(traj, path, robot)
    header = header_of(path)
    assert "q:left_knee [rad]" in header and robot.model.nq == 7 + 5
    with open(path, newline="") as file:
        column = [float(row["q:left_knee [rad]"]) for row in csv.DictReader(file)]
    np.testing.assert_allclose(column, [robot.joint_angles(q)[1] for q in traj.q], atol=1e-15)
    assert_same(read_trajectory_csv(path, robot), traj)


def test_passive_loop_joints_get_columns_so_q_is_recovered(tmp_path) -> None:
    robot = load_robot("hybrid_leg_biped")
    assert robot.passive_joints
    traj = smooth_motion(robot, n=6)
    # Passive joints move too (a real motion would close the loops; the file does not care).
    q = traj.q.copy()
    for name in robot.passive_joints:
        q[:, robot.model.joints[robot.model.getJointId(name)].idx_q] = np.linspace(0, 0.2, 6)
    traj = from_configurations(robot.model, "loops", traj.joint_names, traj.dt, q, traj.contacts)
    path = tmp_path / "loops.csv"
    write_trajectory_csv(traj, path, robot)
    header = header_of(path)
    for name in robot.passive_joints:
        assert f"q:{name} [rad]" in header and f"v:{name} [rad/s]" in header
    assert_same(read_trajectory_csv(path, robot), traj)


def test_writing_a_trajectory_of_another_robot_is_refused(servo, roban, tmp_path) -> None:
    with pytest.raises(MotionFileError, match="another robot"):
        write_trajectory_csv(smooth_motion(servo, n=3), tmp_path / "x.csv", roban)


# --- bad inputs: each writes a good file, spoils one thing, and checks the message -----------


@pytest.fixture
def good_lines(servo, tmp_path) -> list[str]:
    path = tmp_path / "good.csv"
    write_trajectory_csv(smooth_motion(servo, n=8), path, servo)
    return path.read_text().splitlines()


def read_lines(lines: list[str], robot: RobotModel, tmp_path: Path) -> Trajectory:
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    return read_trajectory_csv(path, robot)


def set_cell(lines: list[str], line_no: int, column: int, text: str) -> list[str]:
    """A copy of lines with one cell (1-based line and column) replaced."""
    out = list(lines)
    cells = out[line_no - 1].split(",")
    cells[column - 1] = text
    out[line_no - 1] = ",".join(cells)
    return out


def test_wrong_column_count_names_the_line(servo, good_lines, tmp_path) -> None:
    lines = list(good_lines)
    lines[3] = lines[3].rsplit(",", 1)[0]
    with pytest.raises(MotionFileError, match=r"line 4: 57 values, the header has 58 columns"):
        read_lines(lines, servo, tmp_path)


def test_unknown_joint_lists_unknown_and_known_names(servo, good_lines, tmp_path) -> None:
    lines = list(good_lines)
    lines[0] = lines[0].replace("q:left_knee [rad]", "q:left_knee_joint [rad]")
    with pytest.raises(MotionFileError) as info:
        read_lines(lines, servo, tmp_path)
    message = str(info.value)
    assert "unknown column(s) 'q:left_knee_joint'" in message
    assert all(name in message for name in servo.joint_names)


def without_column(lines: list[str], column: str) -> list[str]:
    """The CSV lines with the column headed `column` taken out."""
    drop = lines[0].split(",").index(column)
    return [",".join(c for i, c in enumerate(line.split(",")) if i != drop) for line in lines]


def test_missing_joint_is_named(servo, good_lines, tmp_path) -> None:
    lines = without_column(good_lines, "q:right_knee [rad]")
    with pytest.raises(MotionFileError, match=r"1 column\(s\) missing .*: q:right_knee"):
        read_lines(lines, servo, tmp_path)


def test_partial_derivative_columns_are_refused(servo, good_lines, tmp_path) -> None:
    lines = without_column(good_lines, "a:left_knee [rad/s^2]")
    with pytest.raises(MotionFileError, match=r"a:left_knee.*all v: and a: columns or none"):
        read_lines(lines, servo, tmp_path)


@pytest.mark.parametrize(
    "line, column, text, message",
    [
        (3, 5, "nan", r"line 3, column 5 \(base_qx\): nan is not a finite"),
        (6, 12, "inf", r"line 6, column 12 .*inf is not a finite"),
        (4, 9, "0.1o", r"line 4, column 9 \(q:left_hip_yaw \[rad\]\): '0.1o' is not a number"),
        (5, 1, "0.0312", r"line 5: time step .* differs .*evenly spaced"),
        (3, 1, "0.0", r"line 3: time 0 s does not increase"),
    ],
    ids=["nan", "inf", "not a number", "uneven time", "time going back"],
)
def test_a_spoiled_cell_is_named_by_line_and_column(
    servo, good_lines, tmp_path, line, column, text, message
) -> None:
    with pytest.raises(MotionFileError, match=message):
        read_lines(set_cell(good_lines, line, column, text), servo, tmp_path)


def test_too_few_rows_is_refused(servo, good_lines, tmp_path) -> None:
    with pytest.raises(MotionFileError, match=r"1 sample row\(s\); a motion needs at least 2"):
        read_lines(good_lines[:2], servo, tmp_path)
    with pytest.raises(MotionFileError, match="empty"):
        read_lines([], servo, tmp_path)


def test_missing_header_is_refused(servo, good_lines, tmp_path) -> None:
    with pytest.raises(MotionFileError, match=r"line 1 holds numbers, not a header row"):
        read_lines(good_lines[1:], servo, tmp_path)


def test_wrong_unit_zero_quaternion_and_bad_contact_are_refused(
    servo, good_lines, tmp_path
) -> None:
    lines = list(good_lines)
    lines[0] = lines[0].replace("q:left_knee [rad]", "q:left_knee [deg]")
    with pytest.raises(MotionFileError, match=r"'q:left_knee' is in \[deg\], expected \[rad\]"):
        read_lines(lines, servo, tmp_path)
    lines = good_lines
    for column in range(5, 9):
        lines = set_cell(lines, 4, column, "0")
    with pytest.raises(MotionFileError, match=r"line 4: the base quaternion is zero"):
        read_lines(lines, servo, tmp_path)
    lines = set_cell(good_lines, 7, 58, "0.5")
    with pytest.raises(MotionFileError, match=r"line 7, column 58 \(contact_right\): 0.5"):
        read_lines(lines, servo, tmp_path)


def test_missing_file_is_a_motion_file_error(servo, tmp_path) -> None:
    with pytest.raises(MotionFileError, match="cannot read"):
        read_trajectory_csv(tmp_path / "nowhere.csv", servo)


# --- Roban S14 motion files ------------------------------------------------------------------


def urdf_joint_order(path: Path) -> list[str]:
    """Moving joints in the order the URDF declares them, straight from the XML."""
    root = ET.parse(path).getroot()
    return [j.get("name", "") for j in root.findall("joint") if j.get("type") != "fixed"]


def raw(path: Path) -> np.ndarray:
    return np.loadtxt(path, delimiter=",")


@pytest.mark.parametrize(
    ("path", "fps", "order"), [(DANCE, 100, "xyzw"), (PRONE, 120, "wxyz")], ids=["dance", "prone"]
)
def test_roban_motions_load(roban, path, fps, order) -> None:
    traj = read_roban_motion_csv(path, roban, quaternion_order=order)
    data = raw(path)
    assert len(traj.joint_names) == 21 and traj.joint_names == roban.joint_names
    assert traj.n_samples == len(data)
    assert traj.t[1] - traj.t[0] == pytest.approx(1 / fps, rel=1e-12)
    np.testing.assert_allclose(np.linalg.norm(traj.q[:, 3:7], axis=1), 1.0, atol=1e-12)
    np.testing.assert_array_equal(traj.q[:, :3], data[:, :3])
    # Joint columns follow the URDF's declaration order.
    assert urdf_joint_order(ROBAN_URDF) == list(roban.joint_names)
    for column, name in enumerate(urdf_joint_order(ROBAN_URDF), start=7):
        idx_q = roban.model.joints[roban.model.getJointId(name)].idx_q
        np.testing.assert_array_equal(traj.q[:, idx_q], data[:, column])
    assert traj.contacts.any(axis=1).all()  # the lowest foot is always in contact
    assert np.isfinite(traj.v).all() and np.isfinite(traj.a).all()


def base_axes(quats_xyzw: np.ndarray) -> np.ndarray:
    """Rotation matrices (T, 3, 3) of unit-normalised quaternions, by the textbook formula."""
    x, y, z, w = (quats_xyzw / np.linalg.norm(quats_xyzw, axis=1, keepdims=True)).T
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    ).transpose(2, 0, 1)


def as_xyzw(data: np.ndarray, order: str) -> np.ndarray:
    return data[:, 3:7] if order == "xyzw" else data[:, [4, 5, 6, 3]]


def lowest_point_z(robot: RobotModel, traj: Trajectory, step: int) -> np.ndarray:
    """Height [m] of the lowest visual-mesh vertex of the robot, every `step` frames."""
    data = robot.model.createData()
    visual = [m for m in robot.meshes if m.role == "visual"]
    out = []
    for q in traj.q[::step]:
        placements = robot.link_placements(q, data)
        heights = []
        for m in visual:
            T_world_mesh = placements[m.link] @ m.T_link_mesh
            heights.append((m.mesh.vertices @ T_world_mesh[2, :3] + T_world_mesh[2, 3]).min())
        out.append(min(heights))
    return np.array(out)


def test_dance_quaternions_are_xyzw(roban) -> None:
    """Read as xyzw, the dancing robot stands upright (base z axis up) in every frame and its
    lowest point stays at the floor; read as wxyz, it leans over 45° in almost every frame
    and hovers tens of centimetres above the floor."""
    data = raw(DANCE)
    up = {order: base_axes(as_xyzw(data, order))[:, 2, 2] for order in ("xyzw", "wxyz")}
    assert (up["xyzw"] > 0.9).mean() > 0.99
    assert (up["wxyz"] > 0.7).mean() < 0.1
    for order, floor_band in (("xyzw", True), ("wxyz", False)):
        traj = read_roban_motion_csv(DANCE, roban, quaternion_order=order)
        np.testing.assert_allclose(base_axes(traj.q[:, 3:7])[:, 2, 2], up[order], atol=1e-12)
        lowest = lowest_point_z(roban, traj, step=10)
        if floor_band:
            assert np.abs(lowest).max() < 0.07
        else:
            assert np.median(lowest) > 0.2


def test_prone_quaternions_are_wxyz(roban) -> None:
    """The prone get-up starts lying face down: read as wxyz the base's forward (x) axis points
    at the floor for the first second; read as xyzw it points at the sky (lying on its back,
    against the file's name) and the robot later hovers 20 cm above the floor for a second."""
    data = raw(PRONE)
    forward_z = {order: base_axes(as_xyzw(data, order))[:, 2, 0] for order in ("xyzw", "wxyz")}
    assert (forward_z["wxyz"][:120] < -0.9).all()
    assert (forward_z["xyzw"][:120] > 0.9).all()
    right = read_roban_motion_csv(PRONE, roban)  # the default, wxyz
    wrong = read_roban_motion_csv(PRONE, roban, quaternion_order="xyzw")
    lowest_right = lowest_point_z(roban, right, step=10)
    lowest_wrong = lowest_point_z(roban, wrong, step=10)
    assert np.abs(lowest_right).max() < 0.1
    assert lowest_wrong.max() > 0.2
    # Standing up at the end: feet on the floor, both in contact most of the time.
    assert np.abs(lowest_right[-20:]).max() < 0.02
    assert right.contacts[-200:].all(axis=1).mean() > 0.5


def test_fps_from_argument_or_refused(roban, servo, tmp_path) -> None:
    unnamed = tmp_path / "dance.csv"
    shutil.copy(DANCE, unnamed)
    with pytest.raises(MotionFileError, match=r"frame rate is not in the file name.*fps="):
        read_roban_motion_csv(unnamed, roban)
    assert read_roban_motion_csv(unnamed, roban, fps=50).dt == pytest.approx(0.02)
    with pytest.raises(MotionFileError, match=r"line 1: 28 values; robot .* needs 19"):
        read_roban_motion_csv(DANCE, servo)
    short = tmp_path / "short_30fps.csv"
    short.write_text(DANCE.read_text().splitlines()[0] + "\n")
    with pytest.raises(MotionFileError, match=r"1 frame\(s\)"):
        read_roban_motion_csv(short, roban)


def test_sole_contact_heuristic(servo) -> None:
    """Standing: both feet in contact. Right foot lifted (flat) by its hip, knee and ankle:
    still in contact within the 1 cm band, out of contact above it."""
    names = list(servo.joint_names)
    data = servo.model.createData()
    right = servo.feet[1]

    def lift(amount: float) -> tuple[np.ndarray, float]:
        angles = servo.joint_angles(servo.q_neutral)
        angles[names.index("right_hip_pitch")] -= amount
        angles[names.index("right_knee")] += 2 * amount
        angles[names.index("right_ankle_pitch")] -= amount
        q = servo.with_joint_angles(servo.q_neutral, angles)
        T = servo.link_placements(q, data)[right.link]
        return q, float((T[:3, :3] @ right.sole_corners_m.T + T[:3, 3:4])[2].min())

    q_low, z_low = lift(0.2)
    q_high, z_high = lift(0.5)
    assert 0.002 < z_low < 0.009 and z_high > 0.02  # the left sole stays at z = 0
    contacts = sole_contacts(servo, np.array([servo.q_neutral, q_low, q_high]))
    np.testing.assert_array_equal(contacts, [[True, True], [True, True], [True, False]])
