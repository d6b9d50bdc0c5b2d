"""Project files: a save → open round trip gives back every value, bit for bit (checked by a
walk over the values written here, not by the codec); the archive holds only what it says;
robots travel as a built-in name or as their own files."""

from __future__ import annotations

import dataclasses
import io
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
import trimesh

from app.core.collocation.dircon import GaitProblem, GaitSettings, PlanarModel
from app.core.dynamics.wbc import torque_feedforward
from app.core.errors import StudioError
from app.core.motions.keyframes import capture_keyframe
from app.core.motions.library import run_motion
from app.core.projects.autosave import AutosaveStore
from app.core.projects.codec import ProjectError
from app.core.projects.files import FORMAT, VERSION, parse_project, read_project, save_project
from app.core.projects.project import Project, check_fits
from app.core.projects.robot_files import load_project_robot, robot_source
from app.core.robot.loading import load_robot
from app.core.robot.uploads import store_upload
from app.core.servo.model import ServoModel
from app.core.servo.presets import PRESETS, preset_params
from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.results import SweepRecord
from tests.same_values import assert_same

SWEEP_DATA = {
    "robot": "dircon_biped",
    "sampling": "latin",
    "samples": 2,
    "gait": {"knots": 14},
    "pareto": {"sr": "min", "max_torque_Nm": "min"},
    "parameter": [{"kind": "gait", "name": "step_length_m", "min": 0.14, "max": 0.26}],
}
NAN = float("nan")


def sweep_record(values: tuple[float, ...] = (0.2,)) -> SweepRecord:
    """A sweep of two points: one walked, one without a gait (NaN metrics, by design)."""
    walked = PointResult(
        0, values, True, "solved", "", 0.21, 0.25, 3.2, 4.5, 1.7, 12, 0.3, 2.1, "h:1"
    )
    failed = PointResult(
        1, values, False, "failed", "torque bound", *[NAN] * 5, 40, NAN, 0.0, "h:2"
    )
    return SweepRecord.of(SWEEP_DATA, (walked, failed))


@pytest.fixture(scope="module")
def work(robot) -> Project:
    """dircon_biped with a motion, its torques, keyframes, coefficients, servos and a gait."""
    motion = run_motion(robot, "com_shift").trajectory
    feedforward = torque_feedforward(robot, motion)
    gait = GaitProblem(PlanarModel(robot), 12, False).solve(GaitSettings(knots=12))
    assert gait.converged
    params = preset_params(next(iter(PRESETS)), robot)
    rng = np.random.default_rng(7)
    servo = ServoModel(
        robot.joint_names,
        rng.uniform(0, 0.5, robot.n_actuated),
        rng.uniform(0, 1, robot.n_actuated),
    )
    keyframes = tuple(
        capture_keyframe(robot, motion.q[k], "both", f"pose {k}", 0.5 + k / 100) for k in (0, 90)
    )
    return Project(
        robot=robot_source(robot),
        q=motion.q[40].copy(),
        stance="left",
        keyframes=keyframes,
        motion=motion,
        motion_summary="**com_shift** — 2 s",
        time_s=0.4,
        feedforward=feedforward,
        compensation=params,
        servo=servo,
        gait_settings=gait.settings,
        gait_steps=4,
        gait_symmetric=gait,
        sweep=sweep_record(),
    )


def test_round_trip_gives_back_every_value(work, tmp_path):
    path = tmp_path / "work.bstudio"
    save_project(path, work)
    opened = read_project(path)
    assert opened.saved_at  # stamped on save
    assert_same(dataclasses.replace(opened, saved_at=""), work)
    assert np.isnan(opened.gait_symmetric.mid_force).any()  # NaN by design survives
    assert opened.sweep is not None and opened.sweep.spec() == work.sweep.spec()
    assert np.isnan(opened.sweep.results[1].sr) and opened.sweep.results[1].reason == "torque bound"


@pytest.mark.parametrize(
    "spec_json, words",
    [
        ('{"robot": "nope"}', "a sweep runs on a built-in robot"),
        ("not json", "not JSON"),
        (json.dumps({**SWEEP_DATA, "samples": 10**9}), "samples"),
    ],
)
def test_a_sweep_that_is_not_a_valid_sweep_is_refused(work, tmp_path, spec_json, words):
    path = tmp_path / "work.bstudio"
    save_project(path, work)
    with zipfile.ZipFile(path) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    manifest = json.loads(entries["manifest.json"])
    manifest["project"]["sweep"]["spec_json"] = spec_json
    entries["manifest.json"] = json.dumps(manifest).encode()
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)
    with pytest.raises(ProjectError, match=f"project.sweep.*{words}"):
        parse_project(buffer.getvalue(), "edited.bstudio")


def test_sweep_results_must_fit_their_sweep():
    with pytest.raises(StudioError, match="does not fit"):
        sweep_record(values=(0.2, 0.3))  # two values, one swept parameter


def test_the_archive_holds_a_manifest_and_plain_npy_arrays(work, tmp_path):
    path = tmp_path / "work.bstudio"
    save_project(path, work)
    with zipfile.ZipFile(path) as archive:
        names = archive.namelist()
        manifest = json.loads(archive.read("manifest.json"))
        q = np.load(io.BytesIO(archive.read("arrays/project.motion.q.npy")), allow_pickle=False)
    assert manifest["format"] == FORMAT and manifest["version"] == VERSION
    assert manifest["project"]["robot"]["builtin"] == "dircon_biped"
    assert names[0] == "manifest.json" and all(
        n.startswith(("arrays/", "blobs/")) for n in names[1:]
    )
    assert np.array_equal(q, work.motion.q)


def test_saving_over_a_project_is_atomic(work, tmp_path):
    """A save that fails midway (the target is a folder) leaves no temporary file behind."""
    target = tmp_path / "dir.bstudio"
    target.mkdir()
    with pytest.raises(ProjectError, match="not a regular file"):
        save_project(target, work)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.bstudio"]


def test_check_fits_refuses_another_robots_work(work):
    servo_biped = load_robot("servo_biped")
    with pytest.raises(ProjectError, match="does not fit servo_biped"):
        check_fits(work, servo_biped)


def _mesh_robot(folder: Path, package_root: Path) -> Path:
    """A two-leg URDF whose visuals are STL meshes: one beside it, one in a package."""
    box = trimesh.creation.box((0.05, 0.04, 0.03))
    (folder / "meshes").mkdir(parents=True)
    box.export(folder / "meshes" / "foot.stl")
    (package_root / "mypkg" / "meshes").mkdir(parents=True)
    trimesh.creation.icosphere(1, 0.03).export(package_root / "mypkg" / "meshes" / "pelvis.stl")
    urdf = load_robot("servo_biped").source.read_text()
    first, last = urdf.index("<visual>"), urdf.rindex("<visual>")
    foot = '<visual><geometry><mesh filename="meshes/foot.stl"/></geometry></visual>'
    pelvis = (
        '<visual><geometry><mesh filename="package://mypkg/meshes/pelvis.stl"/></geometry></visual>'
    )
    urdf = urdf[:first] + foot + urdf[first:last] + pelvis + urdf[last:]
    path = folder / "robot.urdf"
    path.write_text(urdf)
    return path


def test_a_robot_with_meshes_travels_inside_the_project(tmp_path):
    urdf = _mesh_robot(tmp_path / "desc", tmp_path / "packages")
    original = load_robot(urdf, package_roots=(tmp_path / "packages",))
    uris = {g.uri for g in original.tree.geometries}
    assert {"meshes/foot.stl", "package://mypkg/meshes/pelvis.stl"} <= uris
    assert not original.missing_meshes
    source = robot_source(original, (tmp_path / "packages",))
    assert not source.builtin and not source.notes
    project = Project(robot=source, q=original.q_neutral)
    save_project(tmp_path / "p.bstudio", project)
    urdf.unlink()  # the original files are gone: the project alone must do
    (tmp_path / "packages" / "mypkg" / "meshes" / "pelvis.stl").unlink()
    reopened = load_project_robot(read_project(tmp_path / "p.bstudio").robot, tmp_path / "up")
    assert reopened.joint_names == original.joint_names and not reopened.missing_meshes
    assert len(reopened.meshes) == len(original.meshes)
    for a, b in zip(original.meshes, reopened.meshes, strict=True):
        assert np.array_equal(a.mesh.vertices, b.mesh.vertices)


def test_an_uploaded_robot_travels_whole(tmp_path):
    urdf = _mesh_robot(tmp_path / "desc", tmp_path / "desc")
    archive = io.BytesIO()
    with zipfile.ZipFile(archive, "w") as z:
        for path in (tmp_path / "desc").rglob("*"):
            if path.is_file():
                z.write(path, path.relative_to(tmp_path / "desc").as_posix())
    stored = store_upload("robot.zip", archive.getvalue(), tmp_path / "uploads")
    original = load_robot(stored, sandbox=stored.parent)
    assert stored.name == urdf.name and not original.missing_meshes
    source = robot_source(original)
    reopened = load_project_robot(source, tmp_path / "other-uploads")
    assert reopened.joint_names == original.joint_names and not reopened.missing_meshes


def test_autosaves_keep_the_newest_five(tmp_path):
    store = AutosaveStore(tmp_path / "autosave")
    written = [store.write(f"save {i}".encode()) for i in range(8)]
    assert store.saves() == written[-5:]
    assert store.latest() == written[-1]
    assert [p.read_bytes() for p in store.saves()] == [f"save {i}".encode() for i in range(3, 8)]


def test_parse_refuses_what_is_not_a_project():
    with pytest.raises(ProjectError, match="not a valid zip"):
        parse_project(b"hello", "x.bstudio")
