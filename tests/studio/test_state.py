"""The studio's plumbing: the state and its signals, latest-only coalescing, the per-thread
quiet flag. No server: these are plain objects."""

from __future__ import annotations

import dataclasses
import threading

import numpy as np
import pytest

from app.core.errors import StudioError
from app.core.motions.trajectory import from_configurations
from app.core.projects.display import GHOST_NAMES, CameraView, DisplayError, same_display
from app.core.robot.loading import load_robot
from app.core.robot.report import robot_report
from app.studio.admission import Admission, Busy
from app.studio.coalesce import Coalescer
from app.studio.signals import Signal
from app.studio.state import MotionMismatch, StudioState
from panels.quiet import Quiet


@pytest.fixture(scope="module")
def robots():
    return load_robot("servo_biped"), load_robot("dircon_biped")


def _motion(robot, n=11):
    q = np.tile(robot.q_neutral, (n, 1))
    return from_configurations(
        robot.model, "still", robot.joint_names, 0.1, q, np.ones((n, 2), bool)
    )


def test_loading_a_robot_announces_robot_then_no_motion_then_the_neutral_pose(robots):
    robot = robots[0]
    state = StudioState()
    events = []
    state.on_robot.connect(lambda loaded: events.append(("robot", loaded.robot.name)))
    state.on_motion.connect(lambda motion: events.append(("motion", motion)))
    state.on_pose.connect(lambda pose: events.append(("pose", pose.origin)))
    state.set_robot(robot, robot_report(robot))
    assert events == [("robot", "servo_biped"), ("motion", None), ("pose", "load")]
    np.testing.assert_array_equal(state.q, robot.q_neutral)


def test_a_motion_goes_with_its_robot(robots):
    servo, dircon = robots
    state = StudioState()
    state.set_robot(servo, robot_report(servo))
    motion = _motion(servo)
    state.set_motion(motion, "still", servo)
    assert state.trajectory is motion and state.time_s == 0.0
    state.set_robot(dircon, robot_report(dircon))
    assert state.trajectory is None
    with pytest.raises(MotionMismatch, match="another robot"):
        state.set_motion(motion, "still", servo)
    with pytest.raises(MotionMismatch, match="joints differ"):
        state.set_motion(motion, "still", dircon)


def test_time_is_clamped_to_the_motion_and_nan_is_ignored(robots):
    robot = robots[0]
    state = StudioState()
    state.set_robot(robot, robot_report(robot))
    motion = _motion(robot)
    state.set_motion(motion, "still", robot)
    assert state.set_time(99.0) == motion.n_samples - 1 and state.time_s == motion.duration
    assert state.set_time(-5.0) == 0
    assert state.set_time(float("nan")) is None and state.time_s == 0.0


def test_a_pose_of_a_robot_no_longer_loaded_is_dropped_and_nan_is_refused(robots):
    servo, dircon = robots
    state = StudioState()
    state.set_robot(servo, robot_report(servo))
    state.set_robot(dircon, robot_report(dircon))
    assert state.set_pose(servo.q_neutral, "both", "slider", servo) is False
    bad = dircon.q_neutral.copy()
    bad[8] = np.nan
    with pytest.raises(StudioError):
        state.set_pose(bad, "both", "slider", dircon)
    np.testing.assert_array_equal(state.q, dircon.q_neutral)


@pytest.mark.expected_traceback("app.studio.signals")
def test_a_failing_subscriber_does_not_stop_the_others():
    signal: Signal[int] = Signal("test")
    got = []

    def broken(_value: int) -> None:
        raise RuntimeError("a bug in one feature")

    signal.connect(broken)
    disconnect = signal.connect(got.append)
    signal.emit(1)
    disconnect()
    signal.emit(2)
    assert got == [1]


def test_coalescer_hands_over_only_the_newest_value_and_never_blocks_a_caller():
    handled, started, release = [], threading.Event(), threading.Event()

    def handle(key: str, value: int) -> None:
        handled.append((key, value))
        if len(handled) == 1:
            started.set()
            assert release.wait(60.0)

    coalescer: Coalescer[str, int] = Coalescer(handle)
    first = threading.Thread(target=coalescer.submit, args=("a", 0))
    first.start()
    assert started.wait(60.0)
    for value in range(1, 6):  # while "a" = 0 is being handled: these return at once
        coalescer.submit("a", value)
    coalescer.submit("b", 7)
    release.set()
    first.join()
    assert handled == [("a", 0), ("a", 5), ("b", 7)]
    assert (coalescer.received, coalescer.handled) == (7, 3)


def test_quiet_is_per_thread():
    """A value set quietly in one thread must not silence a browser event handled meanwhile
    in another thread of viser's pool."""
    quiet = Quiet()
    inside, seen_elsewhere = threading.Event(), []

    def elsewhere() -> None:
        assert inside.wait(60.0)
        seen_elsewhere.append(quiet.is_quiet())

    other = threading.Thread(target=elsewhere)
    other.start()
    with quiet.quietly():
        assert quiet.is_quiet()
        inside.set()
        other.join()
    assert seen_elsewhere == [False]
    assert not quiet.is_quiet()


def test_admission_limits_jobs_per_tab_and_in_all():
    admission = Admission(per_client=2, total=3)
    with admission.admit(1), admission.admit(1):
        with pytest.raises(Busy, match="this tab already has 2 jobs"), admission.admit(1):
            pass
        with admission.admit(2), pytest.raises(Busy, match="busy"), admission.admit(3):
            pass
    with admission.admit(1), admission.admit(1), admission.admit(3):
        pass  # everything was released, also after a refusal


def test_display_settings_are_replaced_only_when_something_changes():
    state = StudioState()
    emitted = []
    state.on_display.connect(emitted.append)
    first = state.display
    state.set_display("panel", speed=1.0, loop=True)  # the defaults: no change
    assert state.display is first and emitted == []
    settings = state.set_display("panel", speed=0.5)
    assert settings.speed == 0.5 and state.display is not first and len(emitted) == 1
    with pytest.raises(DisplayError, match="speed is 3.0"):
        state.set_display("panel", speed=3.0)
    assert state.display.settings is settings and len(emitted) == 1


def test_a_moving_camera_waits_for_the_next_change_or_a_flush():
    state = StudioState()
    emitted = []
    state.on_display.connect(emitted.append)
    before = state.display
    views = [CameraView((1.0 + 0.01 * i, 2.0, 1.0), (0.0, 0.0, 0.3)) for i in range(60)]
    for view in views:
        state.note_camera(view)
    assert state.display is before and emitted == []  # sixty moves, no new settings
    state.set_display("panel", traces=False)  # the next other change takes the newest view
    assert state.display.settings.camera == views[-1] and not state.display.settings.traces
    assert len(emitted) == 1
    state.note_camera(views[-1])  # the same view again (an echo): nothing to keep
    state.flush_camera()
    assert len(emitted) == 1
    state.note_camera(views[0])
    state.flush_camera()
    assert state.display.settings.camera == views[0] and state.display.origin == "camera"
    assert len(emitted) == 2


def test_a_tab_at_its_starting_view_is_not_work_until_a_camera_is_kept():
    state = StudioState()
    start = CameraView((0.6, 0.5, 0.5), (0.0, 0.0, 0.3))
    state.note_camera(start, starting=True)
    state.flush_camera()
    assert state.display.settings.camera is None  # opening a tab changed nothing
    moved = CameraView((1.0, -0.5, 0.4), (0.0, 0.0, 0.3))
    state.note_camera(moved)
    state.flush_camera()
    state.note_camera(start, starting=True)  # back at the starting view: that is a move now
    state.flush_camera()
    assert state.display.settings.camera == start
    # A browser's echo differs in the last bits: the same view, the same settings.
    echo = CameraView((0.6 + 1e-15, 0.5, 0.5), (1e-17, 0.0, 0.3), (0.0, 1e-16, 2.0))
    assert same_display(
        state.display.settings, dataclasses.replace(state.display.settings, camera=echo)
    )
    assert not same_display(
        state.display.settings, dataclasses.replace(state.display.settings, camera=moved)
    )


def test_the_display_settings_know_every_ghost_the_studio_draws():
    from app.views.ghosts_view import GHOSTS

    assert tuple(GHOSTS) == GHOST_NAMES


def test_the_motions_work_belongs_to_that_motion(robots):
    """Torques, the estimate and the simulation go with the motion they were made for: a
    result for a motion since replaced is dropped, and a new motion starts without them."""
    from app.core.dynamics.wbc import FeedForward
    from app.core.servo.model import Prediction
    from app.studio.compensation_session import default_params

    robot, other = robots
    state = StudioState()
    state.set_robot(robot, robot_report(robot))
    first, second = _motion(robot), _motion(robot)
    state.set_motion(first, "first", robot)
    torques: list = []
    state.work.on_torques.connect(torques.append)
    result = object.__new__(FeedForward)  # only its identity matters to the state
    assert (
        state.work.set_torques(result, first)
        and state.work.torques is result
        and torques == [result]
    )
    params, servo = default_params(robot)
    state.work.set_coefficients(params, servo, "robot")
    kept = state.work.coefficients
    prediction = object.__new__(Prediction)
    assert state.work.set_prediction(prediction, result, kept)
    state.work.set_coefficients(params, servo, "edit")
    assert not state.work.set_prediction(object.__new__(Prediction), result, kept)  # stale inputs
    assert state.work.prediction is prediction

    state.set_motion(second, "second", robot)
    assert (state.work.torques, state.work.prediction, state.work.simulation) == (None, None, None)
    assert not state.work.set_torques(result, first)  # computed for the motion replaced
    assert state.work.torques is None and torques == [result]
    assert state.work.coefficients is not None  # the coefficients belong to the robot

    other_params, other_servo = default_params(other)
    with pytest.raises(StudioError, match="another robot's joints"):
        state.work.set_coefficients(other_params, other_servo, "sweep")
    state.set_robot(other, robot_report(other))
    assert state.work.coefficients is None and state.work.torques is None
