"""A real viser server in pytest: panels are driven by setting their handles' values."""

from __future__ import annotations

import threading

import numpy as np
import pinocchio as pin
import pytest
import viser

from app.studio import Studio
from app.studio.state import MotionMismatch
from tests.conftest import SIGMABAN_URDF, tiny_biped_urdf
from tests.studio.conftest import wait_for_signal


def _world_position(studio: Studio, link: str) -> np.ndarray:
    data = studio.state.robot.model.createData()
    return studio.state.robot.link_placements(studio.state.q, data)[link][:3, 3]


def test_serves_on_localhost_by_default(studio):
    assert studio.web.server.get_host() == "127.0.0.1"
    assert studio.state.robot.name == "servo_biped"


def test_joint_slider_moves_the_robot_in_the_scene(studio):
    slider = studio.joints.panel.sliders["left_knee"]
    foot = studio.state.robot.feet[0].link
    before = studio.robots.view.link_pose(foot)[0].copy()
    slider.value = 40.0
    i = studio.state.robot.joint_names.index("left_knee")
    assert studio.state.robot.joint_angles(studio.state.q)[i] == pytest.approx(np.deg2rad(40.0))
    position, wxyz = studio.robots.view.link_pose(foot)
    # The scene node is where pinocchio puts the foot, independently recomputed here.
    data = studio.state.robot.model.createData()
    T = studio.state.robot.link_placements(studio.state.q, data)[foot]
    np.testing.assert_allclose(position, T[:3, 3], atol=1e-9)
    quat = pin.Quaternion(T[:3, :3])
    np.testing.assert_allclose(np.abs(wxyz), np.abs([quat.w, quat.x, quat.y, quat.z]), atol=1e-9)
    assert np.linalg.norm(position - before) > 0.01
    # The other foot did not move.
    right = studio.state.robot.feet[1].link
    np.testing.assert_allclose(
        studio.robots.view.link_pose(right)[0], _world_position(studio, right), atol=1e-9
    )


def test_slider_values_outside_limits_are_clamped(studio):
    joint = studio.state.robot.joints[0]
    studio.joints.set_joint_angle(0, joint.upper + 1.0)
    assert studio.state.robot.joint_angles(studio.state.q)[0] == pytest.approx(joint.upper)
    studio.joints.set_joint_angle(0, float("nan"))
    assert studio.state.robot.joint_angles(studio.state.q)[0] == pytest.approx(joint.upper)


def test_reset_pose_button(studio):
    studio.joints.panel.sliders["right_hip_pitch"].value = -30.0
    assert not np.allclose(studio.state.q, studio.state.robot.q_neutral)
    studio.pose.panel.reset.value = True
    np.testing.assert_allclose(studio.state.q, studio.state.robot.q_neutral)
    assert studio.joints.panel.sliders["right_hip_pitch"].value == 0.0


def test_open_path_loads_a_third_party_robot_and_rebuilds_sliders(studio):
    studio.robots.panel.path.value = str(SIGMABAN_URDF)
    studio.robots.panel.open_path.value = True
    assert studio.state.robot.n_actuated == 20
    assert set(studio.joints.panel.sliders) == set(studio.state.robot.joint_names)
    assert "onshape" in studio.robots.panel.report.content
    assert studio.notifier.last_error == ""


@pytest.mark.parametrize(
    "text, message",
    [
        ("<robot name='x'><link name='a'>", "not well-formed XML"),
        (
            tiny_biped_urdf().replace('<parent link="left_thigh"/>', '<parent link="ghost"/>'),
            "ghost",
        ),
    ],
)
def test_bad_file_keeps_the_previous_robot(studio, tmp_path, text, message):
    before_robot, before_q = studio.state.robot, studio.state.q.copy()
    studio.joints.panel.sliders["left_knee"].value = 20.0
    posed_q = studio.state.q.copy()
    bad = tmp_path / "bad.urdf"
    bad.write_text(text)
    studio.robots.panel.path.value = str(bad)
    studio.robots.panel.open_path.value = True
    assert studio.state.robot is before_robot
    np.testing.assert_allclose(studio.state.q, posed_q)
    assert not np.allclose(posed_q, before_q)
    assert (
        message in studio.notifier.last_error
        and "previous robot is still loaded" in studio.notifier.last_error
    )
    assert "⚠️" in studio.robots.panel.status.content


def test_upload_zip_through_the_panel_and_refused_upload(studio):
    import io
    import zipfile

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("tiny/tiny.urdf", tiny_biped_urdf())
    studio.robots.panel.receive_upload(viser.UploadedFile("tiny.zip", buffer.getvalue()))
    assert studio.state.robot.name == "tiny"
    assert studio.state.robot.source.is_relative_to(studio.config.uploads_dir.resolve())

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("../../evil.urdf", tiny_biped_urdf())
    studio.robots.panel.receive_upload(viser.UploadedFile("evil.zip", buffer.getvalue()))
    assert studio.state.robot.name == "tiny"
    assert "outside the archive" in studio.notifier.last_error


def test_builtin_dropdown(studio):
    studio.robots.panel.builtin.value = "dircon_biped"
    studio.robots.panel.load_builtin.value = True
    assert studio.state.robot.name == "dircon_biped"
    assert studio.state.robot.n_actuated == 10


def test_display_toggles(studio):
    studio.robots.display.collision.value = True
    studio.robots.display.frames.value = True
    assert studio.robots.display.flags().collision and studio.robots.display.flags().frames


def test_concurrent_slider_updates_leave_a_consistent_state(studio):
    """Callbacks from two tabs overlap on viser's thread pool; the lock keeps q consistent."""
    names = list(studio.joints.panel.sliders)

    def drag(offset: int) -> None:
        for k in range(50):
            studio.joints.set_joint_angle((k + offset) % len(names), 0.01 * k)

    threads = [threading.Thread(target=drag, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for link in (studio.state.robot.feet[0].link, studio.state.robot.feet[1].link):
        np.testing.assert_allclose(
            studio.robots.view.link_pose(link)[0], _world_position(studio, link), atol=1e-9
        )


def test_knee_slider_keeps_the_hybrid_legs_four_bars_closed(studio):
    from app.core.robot.loops import loop_residual

    studio.robots.panel.builtin.value = "hybrid_leg_biped"
    studio.robots.panel.load_builtin.value = True
    studio.joints.panel.sliders["left_knee"].value = 20.0
    studio.joints.panel.sliders["left_ankle"].value = -15.0
    angles = studio.state.robot.joint_angles(studio.state.q)
    assert angles[studio.state.robot.joint_names.index("left_knee")] == pytest.approx(
        np.deg2rad(20.0)
    )
    gap = loop_residual(studio.state.robot, studio.state.q, studio.state.robot.model.createData())
    assert np.abs(gap).max() < 1e-9
    # The passive joints really moved: the loop would be open with them at the neutral values.
    opened = studio.state.q.copy()
    for name in studio.state.robot.passive_joints:
        opened[studio.state.robot.model.joints[studio.state.robot.model.getJointId(name)].idx_q] = (
            0.0
        )
    assert (
        np.abs(
            loop_residual(studio.state.robot, opened, studio.state.robot.model.createData())
        ).max()
        > 1e-3
    )


def _placement(studio: Studio, link: str) -> np.ndarray:
    return studio.state.robot.link_placements(
        studio.state.q, studio.state.robot.model.createData()
    )[link]


def test_dragging_a_foot_moves_it_and_keeps_the_other_planted(studio):
    left, right = (foot.link for foot in studio.state.robot.feet)
    right_before = _placement(studio, right)
    target = _placement(studio, left)
    target[:3, 3] += [0.02, 0.0, 0.03]
    # The sliders follow a drag off its path (at most 10 Hz, ending on its last pose).
    wait_for_signal(studio.joints.followed_drag, lambda: studio.pose.request_drag("left", target))
    np.testing.assert_allclose(_placement(studio, left)[:3, 3], target[:3, 3], atol=1e-3)
    np.testing.assert_allclose(_placement(studio, right), right_before, atol=1e-6)
    assert studio.state.pose.stance == "right"
    assert studio.pose.panel.stance.value == "right"
    # The CoM's ground projection is over the right sole (checked against its corners).
    com = pin.centerOfMass(
        studio.state.robot.model, studio.state.robot.model.createData(), studio.state.q
    )
    corners = studio.state.robot.feet[1].sole_corners_m
    T = _placement(studio, right)
    world = (T[:3, :3] @ corners.T + T[:3, 3:4]).T
    assert world[:, 0].min() < com[0] < world[:, 0].max()
    assert world[:, 1].min() < com[1] < world[:, 1].max()
    # The sliders show the solved angles.
    knee = studio.state.robot.joint_names.index("left_knee")
    assert studio.joints.panel.sliders["left_knee"].value == pytest.approx(
        np.rad2deg(studio.state.robot.joint_angles(studio.state.q)[knee]), abs=0.051
    )


def test_unreachable_drag_keeps_a_finite_pose_and_says_so(studio):
    target = _placement(studio, studio.state.robot.feet[0].link)
    target[:3, 3] += [1.0, 0.5, 0.4]
    studio.pose.request_drag("left", target)
    assert np.all(np.isfinite(studio.state.q))
    status = studio.pose.panel.status.content
    assert (
        "Closest reachable pose" in status and "left foot" in status and "from its target" in status
    )
    for joint, angle in zip(
        studio.state.robot.joints, studio.state.robot.joint_angles(studio.state.q), strict=True
    ):
        assert joint.lower - 1e-9 <= angle <= joint.upper + 1e-9


def test_snap_feet_and_swap_stance_buttons(studio):
    target = _placement(studio, studio.state.robot.feet[0].link)
    target[:3, 3] += [0.0, 0.0, 0.04]
    studio.pose.request_drag("left", target)
    studio.pose.panel.swap.value = True
    assert studio.state.pose.stance == "left"
    studio.pose.panel.snap.value = True
    for foot in studio.state.robot.feet:
        T = _placement(studio, foot.link)
        sole = (T[:3, :3] @ foot.sole_corners_m.T + T[:3, 3:4]).T
        np.testing.assert_allclose(sole[:, 2], 0.0, atol=1e-3)
    assert studio.state.pose.stance == "both"


def test_two_tabs_dragging_at_once_latest_target_wins(studio):
    """Targets that arrive while a solve runs replace each other: only the newest is solved
    next, and the callbacks that brought them return at once instead of queueing."""
    base = _placement(studio, studio.state.robot.feet[0].link)
    targets = []
    for k in range(1, 6):
        T = base.copy()
        T[2, 3] += 0.005 * k
        targets.append(T)
    solved = []
    first_started, release = threading.Event(), threading.Event()
    original = studio.pose.posing.drag

    def recording_drag(q, which, T, **options):
        solved.append(T[2, 3])
        if len(solved) == 1:
            first_started.set()
            assert release.wait(60.0)
        return original(q, which, T, **options)

    studio.pose.posing.drag = recording_drag
    first = threading.Thread(target=studio.pose.request_drag, args=("left", targets[0]))
    first.start()
    assert first_started.wait(60.0)
    for T in targets[1:]:
        studio.pose.request_drag("left", T)  # another tab: returns without solving
    release.set()
    first.join()
    assert solved == [targets[0][2, 3], targets[-1][2, 3]]
    np.testing.assert_allclose(
        _placement(studio, studio.state.robot.feet[0].link)[:3, 3], targets[-1][:3, 3], atol=1e-3
    )


def _knee_bend(studio: Studio, duration_s: float = 1.0, dt: float = 0.01):
    from app.core.motions.trajectory import from_configurations

    robot = studio.state.robot
    knee = robot.joint_names.index("left_knee")
    qs = []
    for t in np.arange(0.0, duration_s + 1e-9, dt):
        angles = robot.joint_angles(robot.q_neutral)
        angles[knee] = 0.5 * np.sin(np.pi * t / duration_s)
        qs.append(robot.with_joint_angles(robot.q_neutral, angles))
    contacts = np.ones((len(qs), 2), dtype=bool)
    return from_configurations(
        robot.model, "knee bend", robot.joint_names, dt, np.array(qs), contacts
    )


def test_timeline_slider_seeks_and_the_player_plays(studio):
    trajectory = _knee_bend(studio)
    studio.state.set_motion(trajectory, "knee bend", studio.state.robot)
    assert studio.playback.panel.time.max == pytest.approx(1.0)
    studio.playback.panel.time.value = 0.5
    np.testing.assert_allclose(studio.state.q, trajectory.q[50])
    studio.playback.panel.speed.value = "2"
    studio.playback.panel.time.value = 0.0
    wait_for_signal(
        studio.state.on_time,
        lambda: setattr(studio.playback.panel.play, "value", True),
        accept=lambda time_s: time_s >= 0.2,
    )
    assert studio.playback.player.playing
    studio.playback.panel.play.value = True  # pause
    assert not studio.playback.player.playing
    k = trajectory.index_at(studio.playback.panel.time.value)
    np.testing.assert_allclose(studio.state.q, trajectory.q[k])
    assert k > 0


def test_a_motion_for_another_robot_is_refused(studio):
    trajectory = _knee_bend(studio)
    old_robot = studio.state.robot
    studio.robots.panel.builtin.value = "dircon_biped"
    studio.robots.panel.load_builtin.value = True
    assert studio.state.trajectory is None  # the old motion went with the old robot
    with pytest.raises(MotionMismatch, match="another robot"):
        studio.state.set_motion(trajectory, "knee bend", old_robot)
    assert studio.state.trajectory is None


def test_ready_pose_bends_the_knees_with_feet_in_place(studio):
    robot = studio.state.robot
    feet_before = {f.link: _placement(studio, f.link) for f in robot.feet}
    pelvis_before = _placement(studio, robot.tree.root)[2, 3]
    studio.pose.panel.ready.value = True
    for link, T in feet_before.items():
        np.testing.assert_allclose(_placement(studio, link), T, atol=1e-5)
    assert _placement(studio, robot.tree.root)[2, 3] < pelvis_before - 0.005
    knee = robot.joint_names.index("left_knee")
    assert robot.joint_angles(studio.state.q)[knee] > 0.1
    # From the ready pose the pelvis can be dragged down (from straight legs it cannot).
    T = _placement(studio, robot.tree.root)
    T[2, 3] -= 0.02
    studio.pose.request_drag("pelvis", T)
    assert _placement(studio, robot.tree.root)[2, 3] == pytest.approx(T[2, 3], abs=1e-3)


def test_switching_robots_all_day_does_not_grow_what_a_new_tab_replays(studio):
    """viser keeps a replay buffer that every new tab receives; removed scene nodes and GUI
    elements leave messages in it. After one round of every built-in, more rounds must not add
    any (the buffer is viser's private state: read only to measure it)."""
    buffer = studio.web.server._websock_server._broadcast_buffer

    def round_of_loads() -> int:
        for name in ("dircon_biped", "hybrid_leg_biped", "servo_biped"):
            assert studio.robots.load(name)
        return len(buffer.message_from_id)

    round_of_loads()
    after_one = round_of_loads()
    for _ in range(3):
        assert round_of_loads() == after_one


def test_open_path_outside_the_allowed_folders_is_refused_without_saying_what_is_there(studio):
    before = studio.state.robot
    messages = []
    for path in ("/etc/passwd", "/etc/no-such-file.urdf", "/proc/self/environ", "/dev/zero"):
        studio.robots.panel.path.value = path
        studio.robots.panel.open_path.value = True
        assert studio.state.robot is before
        messages.append(studio.notifier.last_error.replace(path, "PATH"))
    assert len(set(messages)) == 1 and "--allow" in messages[0]


def test_an_upload_opened_by_path_keeps_its_sandbox(studio, tmp_path):
    """A URDF uploaded with a mesh outside its folder is refused in the upload; opening the
    stored copy by path must not load the outside mesh either."""
    import io
    import zipfile

    secret = tmp_path / "secret.stl"
    secret.write_bytes(b"solid x\nendsolid x\n")
    urdf = tiny_biped_urdf(foot_geometry=f'<mesh filename="file://{secret}"/>')
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        archive.writestr("evil/evil.urdf", urdf)
    studio.robots.panel.receive_upload(viser.UploadedFile("evil.zip", buffer.getvalue()))
    uploaded = studio.state.robot
    assert uploaded.name == "tiny"
    assert any(str(secret) in missing.uri for missing in uploaded.missing_meshes)
    stored = next(studio.config.uploads_dir.rglob("evil.urdf"))
    studio.robots.panel.path.value = str(stored)
    studio.robots.panel.open_path.value = True
    reopened = studio.state.robot
    assert reopened is not uploaded and reopened.name == "tiny"  # loaded again, by path
    assert any(str(secret) in missing.uri for missing in reopened.missing_meshes)
    assert len(reopened.meshes) == len(uploaded.meshes)


def test_forty_hostile_open_paths_at_once_leave_the_studio_answering(studio, tmp_path):
    """A page clicking Open path on devices and pipes forty times at once (viser runs each
    click on its thread pool): every click is answered (refused, by the input gate or as
    "not now"), none blocks on the device, and the studio then loads as before."""
    import os

    fifo = tmp_path / "pipe.urdf"
    os.mkfifo(fifo)
    hostile = ["/dev/zero", "/dev/tty", str(fifo), "/dev/urandom"] * 10
    answers = []

    def click(path: str) -> None:
        answers.append(studio.robots.load(path))

    threads = [threading.Thread(target=click, args=(path,)) for path in hostile]
    before = studio.state.robot
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()  # each returns: nothing waits on /dev/tty or the pipe
    assert answers == [False] * len(hostile)
    assert studio.state.robot is before
    assert studio.robots.load("dircon_biped")
