"""Hostile project *values* (issue 24, item 7): a file that is well formed but holds a state no
robot can take — a pose of 1e308 in every joint, a motion of zero quaternions, a joint past its
URDF limits, absurd rates or torques — is refused by the CLI, by the studio's *Open* (a path
or an upload) and by `serve --project`, with one line naming the field, the work unchanged; an
autosave holding such a state is skipped with a note and the next older one restored.

The limits come from the robot's URDF read here with ElementTree (not from our loader), and
the tolerance is probed on both sides: 5 mrad past a limit opens, 50 mrad past is refused."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from app.config import StudioConfig
from app.core.dynamics.wbc import FeedForward
from app.core.motions.keyframes import capture_keyframe
from app.core.motions.library import run_motion
from app.core.projects.codec import ProjectError
from app.core.projects.files import parse_project, project_bytes
from app.core.projects.project import Project, check_fits
from app.core.projects.robot_files import robot_source
from app.core.robot.loading import load_robot
from app.studio import Studio
from tests.hostile.cli_runner import run_cli
from tests.hostile.test_hostile_projects import npy, rewrite
from tests.studio.conftest import free_port, start_studio

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def robot():
    return load_robot("servo_biped")


@pytest.fixture(scope="module")
def urdf_limits(robot) -> dict[str, tuple[float, float]]:
    """(lower, upper) of every limited joint, read from the URDF text itself."""
    tree = ET.parse(robot.source)
    return {
        joint.get("name"): (float(limit.get("lower")), float(limit.get("upper")))
        for joint in tree.getroot().iter("joint")
        if (limit := joint.find("limit")) is not None and joint.get("type") == "revolute"
    }


@pytest.fixture(scope="module")
def motion(robot):
    return run_motion(robot, "com_shift").trajectory


@pytest.fixture(scope="module")
def good(robot, motion) -> bytes:
    """A sound project: a pose, a keyframe, a motion and (zero) torques of it."""
    n, joints = motion.n_samples, robot.joint_names
    torques = FeedForward(
        trajectory_name=motion.name,
        joint_names=joints,
        t=motion.t,
        tau_Nm=np.zeros((n, len(joints))),
        contact_forces_N=np.zeros((n, 2, 4, 3)),
        qdd=np.zeros((n, robot.model.nv)),
        loop_forces_N=np.zeros((n, 0, 3)),
        status=("solved",) * n,
        qp_time_s=np.zeros(n),
        tau_units=("N·m",) * len(joints),
    )
    keyframe = capture_keyframe(robot, motion.q[5], "both", "start", 1.0)
    project = Project(
        robot=robot_source(robot),
        q=motion.q[3],
        motion=motion,
        time_s=0.5,
        keyframes=(keyframe,),
        feedforward=torques,
    )
    return project_bytes(project)


def _array(data: bytes, entry: str) -> np.ndarray:
    with zipfile.ZipFile(io.BytesIO(data)) as archive:
        return np.load(io.BytesIO(archive.read(entry)), allow_pickle=False)


def _edited(entry: str, edit: Callable[[np.ndarray], None]) -> Callable[[bytes], bytes]:
    """A maker of a copy of the project whose `entry` array went through `edit`."""

    def make(data: bytes) -> bytes:
        array = _array(data, entry).copy()
        edit(array)
        return rewrite(data, entries={entry: npy(array)})

    return make


def _fill(index, value: float) -> Callable[[np.ndarray], None]:
    def edit(array: np.ndarray) -> None:
        array[index] = value

    return edit


POSE = "arrays/project.q.npy"
MOTION_Q = "arrays/project.motion.q.npy"
CASES: dict[str, tuple[Callable[[bytes], bytes], str]] = {
    "a pose of 1e308 in every joint": (
        _edited(POSE, _fill(np.s_[7:], 1e308)),
        r"project\.q \(the pose\): joint left_hip_yaw is at 1e\+308, beyond its limits",
    ),
    "a pose with a zero quaternion": (
        _edited(POSE, _fill(np.s_[3:7], 0.0)),
        r"project\.q \(the pose\): the base orientation \(0, 0, 0, 0\) is not a unit quaternion",
    ),
    "a pose with a scaled quaternion": (
        _edited(POSE, lambda q: q.__setitem__(np.s_[3:7], 2.0 * q[3:7])),
        r"project\.q \(the pose\): the base orientation .* is not a unit quaternion \(norm 2\)",
    ),
    "a pose 1e308 m away": (
        _edited(POSE, _fill(0, 1e308)),
        r"project\.q \(the pose\): the base is at \(1e\+308, .* beyond ±10000 m",
    ),
    "NaN in the pose": (_edited(POSE, _fill(9, np.nan)), r"project\.q contains NaN"),
    "a motion of zero quaternions": (
        _edited(MOTION_Q, _fill(np.s_[:, 3:7], 0.0)),
        r"project\.motion\.q, sample 0 \(t = 0\.000 s\): the base orientation \(0, 0, 0, 0\) "
        r"is not a unit quaternion",
    ),
    "a motion with a knee far past its limit": (
        _edited(MOTION_Q, _fill((40, 10), 3.0)),
        r"project\.motion\.q, sample 40 \(t = 0\.400 s\): joint left_knee is at 3, beyond its "
        r"limits \[0, 2\.3\]",
    ),
    "velocities of 1e308": (
        _edited("arrays/project.motion.v.npy", _fill((7, 8), 1e308)),
        r"project\.motion: velocities reach 1e\+308 at sample 7",
    ),
    "times that go back": (
        _edited("arrays/project.motion.t.npy", lambda t: t.__setitem__(np.s_[:], t[::-1])),
        r"project\.motion: .*sample times must increase",
    ),
    "torques of 1e308": (
        _edited("arrays/project.feedforward.tau_Nm.npy", _fill((3, 2), 1e308)),
        r"project\.feedforward\.tau_Nm reaches 1e\+308",
    ),
    "a keyframe whose pose is past the limits": (
        _edited("arrays/project.keyframes[0].q.npy", _fill(10, -1.0)),
        r"project\.keyframes\[0\]\.q: joint left_knee is at -1, beyond its limits",
    ),
    "a keyframe's foot placement that is not rigid": (
        _edited("arrays/project.keyframes[0].T_world_left.npy", _fill((0, 0), 5.0)),
        r"project\.keyframes\[0\]\.T_world_left is not a rigid placement",
    ),
}
CLI_CASES = ("a pose of 1e308 in every joint", "a motion of zero quaternions", "NaN in the pose")


def test_the_good_project_opens(good, robot):
    check_fits(parse_project(good, "good.bstudio"), robot)


@pytest.mark.parametrize("case", list(CASES))
def test_a_non_physical_value_is_refused_naming_its_field(good, robot, case):
    make, message = CASES[case]
    with pytest.raises(ProjectError, match=message):
        check_fits(parse_project(make(good), f"{case}.bstudio"), robot)


@pytest.mark.parametrize("side", ["lower", "upper"])
def test_joint_limits_hold_with_a_small_tolerance(good, robot, urdf_limits, side):
    """Each joint 5 mrad past its URDF limit opens; 50 mrad past is refused, naming it."""
    lower, upper = urdf_limits["left_knee"]
    limit, sign = (lower, -1.0) if side == "lower" else (upper, 1.0)
    index = robot.model.joints[robot.model.getJointId("left_knee")].idx_q
    near = _edited(POSE, _fill(index, limit + sign * 0.005))(good)
    check_fits(parse_project(near, "near.bstudio"), robot)
    far = _edited(POSE, _fill(index, limit + sign * 0.05))(good)
    with pytest.raises(ProjectError, match=rf"joint left_knee is at {limit + sign * 0.05:.4g}"):
        check_fits(parse_project(far, "far.bstudio"), robot)


@pytest.mark.parametrize("case", CLI_CASES)
def test_the_cli_refuses_with_one_line(good, tmp_path, case):
    make, message = CASES[case]
    path = tmp_path / "bad.bstudio"
    path.write_bytes(make(good))
    run = run_cli("feedforward", str(path), "--out", str(tmp_path / "t.csv"), tmp_path=tmp_path)
    assert run.returncode == 1, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in run.stderr, run.stderr
    assert re.search(message, lines[0]), lines[0]
    assert not (tmp_path / "t.csv").exists()


def test_serve_refuses_a_bad_project_before_starting_the_server(good, tmp_path):
    """`serve --project BAD`: one line, exit 1, and no web server was started (viser prints
    its banner and the studio its link when one is)."""
    path = tmp_path / "bad.bstudio"
    path.write_bytes(CASES["a motion of zero quaternions"][0](good))
    env = {**os.environ, "BIPED_STUDIO_DATA": str(tmp_path / "data")}
    done = subprocess.run(
        [sys.executable, "-m", "app", "serve", "--port", str(free_port()), "--project", str(path)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "project.motion.q, sample 0" in lines[0], done.stderr
    assert "viser" not in done.stdout + done.stderr and "Open this link" not in done.stdout


def test_the_studio_refuses_them_and_keeps_the_work(good, tmp_path):
    studio = start_studio(tmp_path / "data")
    try:
        studio.motions.generate("one_leg_stand", {})
        studio.joints.set_joint_angle(0, 0.1)
        state = studio.state
        before = (state.loaded, state.pose, state.motion, state.time_s)
        for case, (make, message) in CASES.items():
            assert not studio.project.open_upload(f"{case}.bstudio", make(good)), case
            error = studio.project.last_error
            assert re.search(message, error) and "\n" not in error, (case, error)
            assert "unchanged" in studio.project.panel.status.content
            assert all(
                x is y
                for x, y in zip(
                    before, (state.loaded, state.pose, state.motion, state.time_s), strict=True
                )
            ), case
        path = tmp_path / "bad.bstudio"  # Open by path: the same answer
        path.write_bytes(CASES["a pose of 1e308 in every joint"][0](good))
        assert not studio.project.open(str(path))
        assert "project.q (the pose): joint left_hip_yaw" in studio.project.last_error
        assert state.pose is before[1]
        assert studio.project.open_upload("good.bstudio", good), studio.project.last_error
    finally:
        studio.stop()


def test_a_bad_newest_autosave_is_skipped_and_the_older_one_restored(good, robot, tmp_path):
    data = tmp_path / "data"
    folder = data / "autosave"
    folder.mkdir(parents=True)
    older = folder / "autosave-20261101T100000-000000Z.bstudio"
    newer = folder / "autosave-20261101T110000-000000Z.bstudio"
    older.write_bytes(good)
    newer.write_bytes(CASES["a pose of 1e308 in every joint"][0](good))
    studio = Studio(StudioConfig(port=free_port(), data_dir=data, restore_autosave=True))
    try:
        assert np.array_equal(studio.state.q, parse_project(good, "good").q)
        assert (
            studio.state.motion is not None and studio.state.motion.trajectory.name == "com_shift"
        )
        assert studio.project.welcome.startswith("Restored your work from ")
        (note,) = studio.project.skipped_autosaves
        assert newer.name in note and "project.q (the pose): joint left_hip_yaw" in note
        status = studio.project.panel.status.content
        assert older.name in status and f"{newer.name}` skipped" in status
        assert newer.exists()  # kept: the user may still want to look at it
    finally:
        studio.stop()
