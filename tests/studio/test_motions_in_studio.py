"""Motions through the studio's panels: built-in motions, keyframes, CSV export and import."""

from __future__ import annotations

import csv
import io

import numpy as np
import pinocchio as pin
import pytest

from app.studio import Studio
from tests.conftest import ROBAN_URDF, THIRD_PARTY_ROBOTS


def _sole_centre(studio: Studio, q: np.ndarray, side: str) -> np.ndarray:
    foot = studio.state.robot.foot(side)
    T = studio.state.robot.link_placements(q, studio.state.robot.model.createData())[foot.link]
    return T[:3, :3] @ foot.sole_corners_m.mean(axis=0) + T[:3, 3]


def test_generate_a_builtin_motion_from_the_panel(studio):
    panel = studio.motions.panel
    panel.motion.value = "com_shift"
    panel.inputs["shift_m"].value = 0.043
    panel.generate.value = True
    trajectory = studio.state.trajectory
    assert trajectory is not None and trajectory.name == "com_shift"
    data = studio.state.robot.model.createData()
    start = pin.centerOfMass(studio.state.robot.model, data, trajectory.q[0])
    end = pin.centerOfMass(studio.state.robot.model, data, trajectory.q[-1])
    assert abs(end[1] - start[1]) == pytest.approx(0.043, abs=2e-3)  # the paper's second shift
    assert "com_shift" in studio.playback.panel.info.content


def test_keyframes_capture_reorder_and_build(studio):
    motions, panel = studio.motions, studio.motions.keyframes_panel
    studio.pose.reset_pose()
    panel.duration.value = 0.5
    panel.capture.value = True
    foot = studio.state.robot.link_placements(
        studio.state.q, studio.state.robot.model.createData()
    )[studio.state.robot.feet[0].link]
    foot[:3, 3] += [0.0, 0.0, 0.03]
    studio.pose.request_drag("left", foot)
    panel.capture.value = True
    panel.capture.value = True
    assert [kf.name for kf in motions.keyframes] == ["pose 1", "pose 2", "pose 3"]
    panel.selected.value = panel.selected.options[2]
    panel.up.value = True
    assert [kf.name for kf in motions.keyframes] == ["pose 1", "pose 3", "pose 2"]
    panel.delete.value = True  # the selection followed the moved keyframe; confirm below
    panel.delete.value = True
    assert [kf.name for kf in motions.keyframes] == ["pose 1", "pose 2"]
    panel.build.value = True
    trajectory = studio.state.trajectory
    assert trajectory.name == "keyframes"
    assert trajectory.duration == pytest.approx(0.5, abs=0.011)
    # The right foot was the stance foot throughout: planted.
    right = np.array([_sole_centre(studio, q, "right") for q in trajectory.q])
    assert np.abs(right - right[0]).max() < 1e-3
    left = np.array([_sole_centre(studio, q, "left") for q in trajectory.q])
    assert left[-1, 2] - left[0, 2] == pytest.approx(0.03, abs=1e-3)


@pytest.mark.parametrize("duration_s", [0.0, -1.0, float("nan"), 1e9])
def test_a_bad_keyframe_duration_is_refused_with_a_message(studio, duration_s):
    panel = studio.motions.keyframes_panel
    panel.duration.value = 0.5
    panel.capture.value = True
    panel.capture.value = True
    studio.motions.set_duration(1, duration_s)  # what a crafted client could send
    assert studio.motions.keyframes[1].duration_s == 0.5
    assert "duration" in studio.notifier.last_error
    assert "duration" in studio.motions.panel.status.content


def test_export_then_import_round_trip(studio):
    studio.motions.panel.motion.value = "com_shift"
    studio.motions.panel.generate.value = True
    content = studio.motions.export()
    header = next(csv.reader(io.StringIO(content.decode())))
    assert header[0] == "t [s]" and "q:left_knee [rad]" in header
    original = studio.state.trajectory
    studio.motions.import_file("shift.csv", content, "xyzw")
    np.testing.assert_allclose(studio.state.trajectory.q, original.q, atol=1e-12)


def test_bad_motion_file_keeps_the_motion(studio):
    studio.motions.panel.generate.value = True
    before = studio.state.trajectory
    assert before is not None
    studio.motions.import_file("bad.csv", b"t [s],q:nonexistent [rad]\n0,1\n", "xyzw")
    assert studio.state.trajectory is before
    assert "nonexistent" in studio.notifier.last_error


def test_roban_dance_imports_on_roban(studio):
    studio.robots.load(ROBAN_URDF)
    path = THIRD_PARTY_ROBOTS / "roban_s14" / "motions" / "new_year_dance_100fps.csv"
    assert studio.motions.import_file(path.name, path.read_bytes(), "xyzw")
    assert studio.state.trajectory.dt == pytest.approx(0.01)  # 100 fps, from the file name
    assert studio.state.trajectory.n_samples == len(path.read_text().splitlines())


def test_keyframes_go_to_replace_rename_and_delete_only_when_confirmed(studio):
    motions, panel = studio.motions, studio.motions.keyframes_panel
    panel.capture.value = True
    first_q = studio.state.q.copy()
    studio.pose.panel.ready.value = True  # another pose
    panel.capture.value = True
    assert [kf.name for kf in motions.keyframes] == ["pose 1", "pose 2"]
    # Go to: the robot takes the first keyframe's pose.
    panel.selected.value = panel.selected.options[0]
    panel.go_to.value = True
    np.testing.assert_allclose(studio.state.q, first_q)
    # Replace: the second keyframe takes the current pose (the first's), keeps its name.
    panel.selected.value = panel.selected.options[1]
    panel.replace.value = True
    second = motions.keyframes[1]
    assert second.name == "pose 2"
    np.testing.assert_allclose(second.T_world_pelvis, motions.keyframes[0].T_world_pelvis)
    # Rename.
    panel.name.value = "  lift   left  "
    panel.rename.value = True
    assert motions.keyframes[1].name == "lift left"
    # Delete asks twice.
    panel.delete.value = True
    assert len(motions.keyframes) == 2 and "again" in panel.delete.label
    panel.delete.value = True
    assert [kf.name for kf in motions.keyframes] == ["pose 1"]
    assert panel.delete.label == "Delete"
