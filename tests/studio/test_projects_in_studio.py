"""Projects in a real studio: save → open in a fresh studio gives back every panel's values,
every result and the display settings (camera, toggles, ghosts, plots, playback speed); a
refused file leaves the work exactly as it was; autosave follows edits and a restarted studio
restores it."""

from __future__ import annotations

import dataclasses
import io
import math
import zipfile
from pathlib import Path

import numpy as np
import pytest

from app.config import StudioConfig
from app.core.projects.display import CameraView, DisplaySettings
from app.core.projects.files import read_project
from app.core.servo.edits import SetBacklash, SetK
from app.studio import Studio
from panels.compensation_panel import COMPENSATED_TORQUE_LABELS
from tests.hostile.test_hostile_projects import rewrite
from tests.same_values import assert_same
from tests.studio.conftest import free_port, one_click, start_studio, wait_for_signal
from tests.studio.ws_tab import CAMERA, Tab, loop, wait

__all__ = ["loop"]  # the fixture, used by name

MOVED = dataclasses.replace(
    CAMERA,
    position=(1.6, -0.9, 0.8),
    look_at=(0.05, 0.02, 0.3),
    up_direction=(0.0, 0.1, 1.0),
    fov=0.7,
)
"""A tab's camera after the user orbits and zooms (the tab connected with CAMERA)."""


def _set_display(a: Studio, tab: Tab) -> None:
    """Every display setting away from its default, as a user would: toggles, the camera."""
    for name, value in (("collision", True), ("frames", True), ("com", False), ("dark", True)):
        getattr(a.robots.display, name).value = value
    a.servo_rooms.ghosts.panel.ghosts["planned"].value = True
    a.servo_rooms.ghosts.panel.ghosts["with"].value = False
    a.servo_rooms.ghosts.plots.joints.value = "left leg"
    a.servo_rooms.ghosts.plots.wide.value = True
    a.playback.panel.speed.value = "0.5"
    a.playback.panel.loop.value = False
    a.playback.panel.traces.value = False
    a.pose.panel.handles.value = False
    a.pose.panel.com_in_support.value = False
    wait("the tab's starting view", lambda: len(a.presenting.camera.tabs) == 1)
    wait_for_signal(
        a.state.on_display,
        lambda: tab.send(MOVED),
        accept=lambda display: display.settings.camera is not None,
    )


def test_save_then_open_in_a_fresh_studio_restores_everything(studio, tmp_path, loop):
    a = studio
    # One click: plan a gait on servo_biped, walk it, compute torques, simulate.
    simulated = one_click(a)
    assert simulated.error == "" and a.gait.results.symmetric is not None
    a.motions.capture(0.8)
    a.motions.capture(1.2)
    a.motions.rename(1, "lean")
    joint = a.state.work.coefficients.params.joint_names[3]
    a.servo_rooms.compensation.select_joint(joint)
    a.servo_rooms.compensation.edit(SetK(joint, 0.9))
    a.servo_rooms.compensation.edit(SetBacklash(joint, 1.5))  # the simulation is now stale
    a.gait.panel.steps.value = 5
    _set_display(a, Tab(a, loop))
    a.playback.seek(1.3)
    moved = a.state.robot.joints[2].name
    a.joints.panel.sliders[moved].value = 8.5  # a pose off the motion's sample
    assert not np.array_equal(a.state.q, a.state.trajectory.q[a.state.trajectory.index_at(1.3)])
    assert a.project.save_as("session")
    path = a.project.path
    assert path == a.config.data_dir / "projects" / "session.bstudio" and path.is_file()
    assert "unsaved" not in a.project.panel.title.content

    b = start_studio(tmp_path / "elsewhere")
    try:
        tab = Tab(b, loop)
        wait("b's tab", lambda: len(b.presenting.camera.tabs) == 1)
        assert b.project.open(str(path)), b.project.last_error
        sa, sb = a.state, b.state
        _assert_display_restored(a, b, tab)
        assert sb.robot.name == sa.robot.name and sb.robot is not sa.robot
        assert_same(sb.pose.q, sa.pose.q, "q")
        assert sb.pose.stance == sa.pose.stance
        assert_same(sb.trajectory, sa.trajectory, "motion")
        assert sb.motion.summary == sa.motion.summary
        assert sb.time_s == sa.time_s == pytest.approx(1.3, abs=sa.trajectory.dt)
        assert b.playback.panel.time.value == a.playback.panel.time.value
        assert_same(tuple(b.motions.keyframes), tuple(a.motions.keyframes), "keyframes")
        assert_same(sb.work.torques, sa.work.torques, "feedforward")
        assert_same(sb.work.coefficients.params, sa.work.coefficients.params, "compensation")
        assert_same(sb.work.coefficients.servo, sa.work.coefficients.servo, "servo")
        # The prediction is recomputed from the restored inputs: the same numbers come out.
        assert_same(sb.work.prediction, sa.work.prediction, "prediction")
        assert b.servo_rooms.ghosts.view is not None
        assert_same(sb.work.simulation.run.results, sa.work.simulation.run.results, "simulation")
        verdict = b.servo_rooms.simulation.panel.verdict.content
        assert sb.work.simulation.stale and sa.work.simulation.stale and "Stale" in verdict
        # The wait the user saw is kept, not "0.0 s".
        waited = sa.work.simulation.run.waited_s
        assert waited is not None and waited > 0 and sb.work.simulation.run.waited_s == waited
        assert f"(MuJoCo) in {waited:.1f} s" in verdict
        b.servo_rooms.compensation.select_joint(joint)
        ca, cb = a.servo_rooms.compensation, b.servo_rooms.compensation
        for field in ("enabled", "k", "phi", "compliance", "backlash"):
            assert getattr(cb.panel, field).value == getattr(ca.panel, field).value, field
        for name, slider in a.joints.panel.sliders.items():
            assert b.joints.panel.sliders[name].value == pytest.approx(slider.value, abs=1e-9)
        assert_same(b.gait.results.symmetric, a.gait.results.symmetric, "gait")
        assert b.gait.panel.steps.value == 5
        assert b.gait.walk.trajectory is sb.trajectory and b.gait.footprints is not None
        assert_same(b.gait.walk.footprints, a.gait.walk.footprints, "footprints")
        assert b.gait.panel.settings(False) == a.gait.panel.settings(False)
        title = b.project.panel.title.content
        assert "session" in title and "unsaved" not in title
        # A file saved before the wall time was kept still opens, and says where it came from.
        older = tmp_path / "older.bstudio"
        older.write_bytes(
            _crafted(path.read_bytes(), lambda m: m["project"].pop("simulation_wall_s"))
        )
        assert b.project.open(str(older)), b.project.last_error
        assert sb.work.simulation.run.waited_s is None
        assert (
            "(MuJoCo) restored from the project" in b.servo_rooms.simulation.panel.verdict.content
        )
        assert_same(sb.work.simulation.run.results, sa.work.simulation.run.results, "simulation")
    finally:
        b.stop()


def _assert_display_restored(a: Studio, b: Studio, tab: Tab) -> None:
    """b shows a's display settings: the values, every widget, the ghosts, the tab's camera."""
    assert b.state.display.settings == a.state.display.settings
    camera = b.state.display.settings.camera
    assert camera == CameraView(
        MOVED.position, MOVED.look_at, MOVED.up_direction, math.degrees(0.7)
    )
    for name in ("visual", "collision", "frames", "com", "dark"):
        assert getattr(b.robots.display, name).value == getattr(a.robots.display, name).value
    assert b.robots.display.flags() == a.robots.display.flags() != type(a.robots.display.flags())()
    for name, box in a.servo_rooms.ghosts.panel.ghosts.items():
        assert b.servo_rooms.ghosts.panel.ghosts[name].value == box.value, name
    assert b.servo_rooms.ghosts.view is not None
    shown = {
        name: b.servo_rooms.ghosts.view.shown(name) for name in b.servo_rooms.ghosts.view.names
    }
    assert shown == {name: box.value for name, box in a.servo_rooms.ghosts.panel.ghosts.items()}
    assert b.servo_rooms.ghosts.plots.joints.value == "left leg"
    assert b.servo_rooms.ghosts.plots.wide.value and b.servo_rooms.ghosts.plots.window is not None
    panel = b.playback.panel
    assert (panel.speed.value, panel.speed_factor, panel.loop.value) == ("0.5", 0.5, False)
    assert not panel.traces.value and b.playback.traces is not None
    assert not any(node.visible for node in b.playback.traces._nodes)
    settings = b.state.display.settings
    assert (settings.handles, settings.keep_com) == (False, False)
    assert not b.pose.panel.handles.value and not b.pose.panel.com_in_support.value
    assert b.pose.posing is not None and not b.pose.posing.com_in_support
    assert b.pose.handles is not None
    assert not any(control.visible for control in b.pose.handles._controls.values())
    # The tab's camera was put where a's was, and new tabs start there.
    (client,) = b.web.server.get_clients().values()
    assert np.allclose(client.camera.position, MOVED.position)
    assert np.allclose(client.camera.look_at, MOVED.look_at)
    assert client.camera.fov == pytest.approx(0.7)
    assert np.allclose(b.web.server.initial_camera.look_at, MOVED.look_at)
    wait(
        "the tab to be sent the camera",
        lambda: any(
            m.get("type") == "SetCameraLookAtMessage"
            and np.allclose(m["look_at"], MOVED.look_at)
            and not m["initial"]
            for m in tab.received
        ),
    )


def _crafted(data: bytes, edit) -> bytes:
    """The saved project with `edit` applied to its manifest (a dict, edited in place)."""
    return rewrite(data, manifest=edit)


def _slip(data: bytes) -> bytes:
    out = io.BytesIO(data)
    with zipfile.ZipFile(out, "a") as archive:
        archive.writestr("../../outside.npy", b"x")
    return out.getvalue()


BAD = {
    "newer version": (lambda d: _crafted(d, lambda m: m.update(version=2)), "newer Biped Studio"),
    "corrupt zip": (lambda d: d[:100], "not a valid zip"),
    "zip slip": (_slip, "'../../outside.npy' is not one a project holds"),
    "NaN": (
        lambda d: _crafted(d, lambda m: m["project"].update(time_s={"float": "nan"})),
        "project.time_s is nan",
    ),
    "wrong type": (
        lambda d: _crafted(d, lambda m: m["project"].update(keyframes="many")),
        "project.keyframes is 'many'",
    ),
    "display speed": (
        lambda d: _crafted(d, lambda m: m["project"]["display"].update(speed=3)),
        "project.display: speed is 3.0; give one of 0.25, 0.5, 1, 2",
    ),
    "display ghost": (
        lambda d: _crafted(d, lambda m: m["project"]["display"].update(ghosts=["ghoul"])),
        "project.display: ghosts is ('ghoul',)",
    ),
    "display camera": (
        lambda d: _crafted(
            d,
            lambda m: m["project"]["display"].update(
                camera={"position": [1, 2, 3], "look_at": [1, 2, 3]}
            ),
        ),
        "project.display.camera: camera.look_at equals camera.position",
    ),
    "display newer": (
        lambda d: _crafted(d, lambda m: m["project"]["display"].update(version=9)),
        "project.display: version is 9",
    ),
    "display plot joints": (
        lambda d: _crafted(d, lambda m: m["project"]["display"].update(plot_joints="tail")),
        "project.display.plot_joints is 'tail'",
    ),
    "missing robot": (
        lambda d: _crafted(d, lambda m: m["project"]["robot"].update(builtin="gone_bot")),
        "'gone_bot' is not a built-in robot",
    ),
    "another robot's work": (
        lambda d: _crafted(d, lambda m: m["project"]["robot"].update(builtin="dircon_biped")),
        "does not fit dircon_biped",
    ),
}


def test_a_refused_project_leaves_the_work_untouched(studio, tmp_path):
    studio.motions.generate("com_shift", {})
    studio.motions.capture(1.0)
    studio.playback.seek(0.5)
    assert studio.project.save_as(str(tmp_path / "good.bstudio"))
    good = (tmp_path / "good.bstudio").read_bytes()
    studio.joints.set_joint_angle(0, 0.1)  # unsaved work on top
    studio.playback.panel.speed.value = "2"  # unsaved display settings on top too
    state, motions = studio.state, studio.motions
    before = (state.loaded, state.pose, state.motion, state.time_s, state.work.coefficients)
    display = state.display
    keyframes = list(motions.keyframes)
    for case, (make, message) in BAD.items():
        assert not studio.project.open_upload(f"{case}.bstudio", make(good)), case
        assert message in studio.project.last_error, (case, studio.project.last_error)
        assert "unchanged" in studio.project.panel.status.content
        after = (state.loaded, state.pose, state.motion, state.time_s, state.work.coefficients)
        assert all(x is y for x, y in zip(before, after, strict=True)), case
        assert state.display is display and studio.playback.panel.speed.value == "2", case
        assert motions.keyframes == keyframes, case
    assert studio.project.dirty  # still the user's unsaved work


def test_display_settings_travel_and_an_older_file_opens_with_the_defaults(studio, tmp_path):
    studio.motions.generate("com_shift", {})
    studio.playback.panel.follow.value = True
    studio.playback.panel.speed.value = "0.25"
    studio.robots.display.visual.value = False
    studio.playback.seek(0.6)
    settings = studio.state.display.settings
    assert (settings.follow, settings.speed, settings.visual) == (True, 0.25, False)
    assert studio.project.save_as(str(tmp_path / "shown.bstudio"))
    saved = (tmp_path / "shown.bstudio").read_bytes()
    fresh = start_studio(tmp_path / "fresh")
    try:
        assert fresh.project.open(str(tmp_path / "shown.bstudio")), fresh.project.last_error
        assert fresh.state.display.settings == settings
        assert fresh.playback.panel.follow.value and fresh.playback.panel.speed.value == "0.25"
        assert not fresh.robots.display.visual.value
        assert fresh.state.time_s == studio.state.time_s == pytest.approx(0.6, abs=0.02)
        assert "unsaved" not in fresh.project.panel.title.content
        # The same file as the studio wrote it before display settings were kept.
        older = tmp_path / "older.bstudio"
        older.write_bytes(_crafted(saved, lambda m: m["project"].pop("display")))
        assert fresh.project.open(str(older)), fresh.project.last_error
        assert fresh.state.display.settings == DisplaySettings()
        assert not fresh.playback.panel.follow.value and fresh.playback.panel.speed.value == "1"
        assert fresh.robots.display.visual.value
        assert fresh.state.time_s == studio.state.time_s  # the rest of the work as saved
        assert "⚠️" not in fresh.project.panel.status.content
        assert "Opened **older**" in fresh.project.panel.status.content
    finally:
        fresh.stop()


def test_paths_outside_the_allowed_folders_are_refused(studio):
    assert not studio.project.open("/etc/passwd")
    assert "not inside the folders" in studio.project.last_error
    assert not studio.project.save_as("/tmp/../etc/evil.bstudio")
    assert "not inside the folders" in studio.project.last_error
    assert not Path("/etc/evil.bstudio").exists()


def test_autosave_follows_edits_and_a_restart_restores_them(tmp_path):
    data = tmp_path / "data"
    first = start_studio(data)
    try:
        path = wait_for_signal(
            first.project.autosave.written, lambda: first.joints.set_joint_angle(1, 0.12)
        )
        assert_same(read_project(path).q, first.state.q, "autosaved q")
        assert "unsaved" in first.project.panel.title.content
        # A keyframe edit emits no state signal: the poll finds it.
        path = wait_for_signal(first.project.autosave.written, lambda: first.motions.capture(0.7))
        assert len(read_project(path).keyframes) == 1
        q = first.state.q.copy()
    finally:
        first.stop()
    config = StudioConfig(port=free_port(), data_dir=data, restore_autosave=True)
    second = Studio(config)
    try:
        assert_same(second.state.q, q, "restored q")
        assert len(second.motions.keyframes) == 1
        assert second.project.welcome.startswith("Restored your work from ")
        assert second.notifier.last is not None and second.notifier.last.title == "Welcome back"
    finally:
        second.stop()


def test_a_fresh_start_writes_no_autosave_until_something_changes(tmp_path):
    config = StudioConfig(port=free_port(), data_dir=tmp_path / "data")
    studio = Studio(config)
    try:
        assert studio.project.autosave.now() is None  # nothing changed since the start
        assert studio.project.autosave.store.saves() == []
        studio.joints.set_joint_angle(0, -0.1)
        assert studio.project.autosave.now() is not None
        assert np.array_equal(
            read_project(studio.project.autosave.store.latest()).q, studio.state.q
        )
    finally:
        studio.stop()


def test_undo_and_redo_walk_back_through_pose_and_keyframe_edits(studio):
    """Each still moment after an edit is one step (the autosave thread takes it)."""
    project, state = studio.project, studio.state
    assert project.panel.undo.disabled and project.panel.redo.disabled
    q0 = state.q.copy()
    name, slider = next(iter(studio.joints.panel.sliders.items()))
    joint = state.robot.joint_names.index(name)
    wait_for_signal(project.autosave.written, lambda: setattr(slider, "value", slider.value + 10.0))
    q1 = state.q.copy()
    assert not np.array_equal(q1, q0)
    wait_for_signal(project.autosave.written, lambda: studio.motions.capture(0.8))
    assert len(studio.motions.keyframes) == 1 and not project.panel.undo.disabled

    project.panel.undo.value = True  # the keyframe goes, the pose stays
    assert studio.motions.keyframes == [] and np.array_equal(state.q, q1)
    project.panel.undo.value = True  # the slider move goes
    assert np.array_equal(state.q, q0)
    angle_deg = np.rad2deg(state.robot.joint_angles(q0)[joint])
    assert slider.value == pytest.approx(angle_deg, abs=0.1)  # the slider follows
    assert project.panel.undo.disabled and not project.panel.redo.disabled
    assert not project.undo()  # nothing older

    project.panel.redo.value = True
    assert np.array_equal(state.q, q1)
    project.panel.redo.value = True
    assert len(studio.motions.keyframes) == 1 and project.panel.redo.disabled
    # A new edit after an undo drops what could be redone.
    project.panel.undo.value = True
    wait_for_signal(project.autosave.written, lambda: studio.motions.capture(1.5))
    assert project.panel.redo.disabled and not project.redo()
    assert [k.duration_s for k in studio.motions.keyframes] == [1.5]


def test_a_sweep_travels_with_the_project(studio, tmp_path):
    """The Sweep panel's last sweep is saved with the project and comes back in a fresh
    studio: its points, the Pareto plot (the front recomputed by brute force here), the panel's
    choices, and Load point for the walked designs."""
    import dataclasses

    from app.core.projects.files import save_project
    from app.core.sweeps.evaluate import PointResult
    from app.core.sweeps.results import SweepRecord

    data = {
        "robot": "dircon_biped",
        "sampling": "latin",
        "samples": 4,
        "gait": {"knots": 16},
        "pareto": {"energy_J": "min", "max_torque_Nm": "min"},
        "parameter": [{"kind": "gait", "name": "H_s", "min": 0.65, "max": 0.85}],
    }
    metrics = [(1.0, 5.0), (2.0, 2.0), (3.0, 4.0), (float("nan"), float("nan"))]
    results = tuple(
        PointResult(
            i,
            (0.7,),
            i < 3,
            "solved" if i < 3 else "failed",
            "",
            0.2,
            0.3,
            torque,
            4.0,
            energy,
            10,
            0.1,
            0.0,
            "h:1",
        )
        for i, (energy, torque) in enumerate(metrics)
    )
    path = tmp_path / "swept.bstudio"
    save_project(
        path, dataclasses.replace(studio.project.project(), sweep=SweepRecord.of(data, results))
    )
    fresh = start_studio(tmp_path / "fresh")
    try:
        assert fresh.project.open(path, trusted=True), fresh.project.last_error
        session, panel = fresh.sweep, fresh.sweep.panel
        assert session.outcome is not None
        assert_same(session.outcome.results, results)  # NaN metrics of the failed point too
        dominated = {
            i
            for i, (e, t) in enumerate(metrics[:3])
            for j, (e2, t2) in enumerate(metrics[:3])
            if j != i and e2 <= e and t2 <= t and (e2, t2) != (e, t)
        }
        assert set(session.outcome.pareto) == {0, 1, 2} - dominated == {0, 1}
        assert sorted(session.points) == [0, 1, 2, 3]
        assert (panel.param_a.value, panel.min_a.value, panel.max_a.value) == (
            "gait:H_s",
            0.65,
            0.85,
        )
        assert (panel.samples.value, panel.knots.value) == (4, 16)
        assert (panel.metric_x.value, panel.metric_y.value) == ("energy_J", "max_torque_Nm")
        assert panel.plot is not None
        x, y, _fell, front, failed = panel.plot.data
        drawn = np.isfinite(y)
        assert list(x[drawn]) == [1.0, 2.0, 3.0] and list(y[drawn]) == [5.0, 2.0, 4.0]
        assert np.count_nonzero(np.isfinite(front)) == 2  # the front: points 0 and 1
        assert np.count_nonzero(np.isfinite(failed)) == 1  # the failed point, in its strip
        assert "3 solved, 1 failed, 0 cancelled" in panel.status.content
        assert not panel.load_button.disabled
        assert fresh.project.project().sweep is session.record  # saved again as it came
    finally:
        fresh.stop()


def test_the_compensated_torque_travels_and_an_older_file_opens_on_the_load(studio, tmp_path):
    """*Compensate* (drive torque by default) is kept in the file; a file saved before the
    choice existed was compensated on the load torque τ and opens so."""
    studio.motions.generate("com_shift", {})
    panel = studio.servo_rooms.compensation.panel
    assert studio.state.work.coefficients.torque == "drive"
    assert studio.project.save_as(str(tmp_path / "drive.bstudio"))
    panel.compensate.value = COMPENSATED_TORQUE_LABELS["load"]
    assert studio.state.work.coefficients.torque == "load"
    assert studio.project.save_as(str(tmp_path / "load.bstudio"))
    fresh = start_studio(tmp_path / "fresh")
    try:
        assert fresh.state.work.coefficients.torque == "drive"  # a fresh studio's default
        assert fresh.project.open(str(tmp_path / "load.bstudio")), fresh.project.last_error
        assert fresh.state.work.coefficients.torque == "load"
        assert (
            fresh.servo_rooms.compensation.panel.compensate.value
            == COMPENSATED_TORQUE_LABELS["load"]
        )
        assert fresh.project.open(str(tmp_path / "drive.bstudio")), fresh.project.last_error
        assert fresh.state.work.coefficients.torque == "drive"
        assert (
            fresh.servo_rooms.compensation.panel.compensate.value
            == COMPENSATED_TORQUE_LABELS["drive"]
        )
        older = tmp_path / "older.bstudio"
        saved = (tmp_path / "drive.bstudio").read_bytes()
        older.write_bytes(_crafted(saved, lambda m: m["project"].pop("compensation_torque")))
        assert fresh.project.open(str(older)), fresh.project.last_error
        assert fresh.state.work.coefficients.torque == "load"
    finally:
        fresh.stop()
