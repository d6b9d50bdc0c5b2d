"""Playback from its panel: one-frame steps (the J / L keys), and the camera that follows the
robot (checked against pinocchio's placement of the robot's root link)."""

from __future__ import annotations

import numpy as np
import pytest

from app.studio.camera_follow import follow_offset
from tests.studio.conftest import wait_for_signal


@pytest.fixture
def shifted(studio):
    """The studio showing the paper's CoM shift (the pelvis moves sideways)."""
    panel = studio.motions.panel
    panel.motion.value = "com_shift"
    panel.generate.value = True
    return studio.state.trajectory


def test_steps_move_one_sample_and_stop_at_the_ends(studio, shifted):
    playback = studio.playback
    playback.seek(float(shifted.t[10]))
    playback.step(1)
    assert studio.state.time_s == shifted.t[11]
    np.testing.assert_array_equal(studio.state.q, shifted.q[11])
    playback.step(-1)
    playback.step(-1)
    assert studio.state.time_s == shifted.t[9]
    assert playback.panel.time.value == pytest.approx(shifted.t[9], abs=0.006)
    playback.step(-100)
    assert studio.state.time_s == shifted.t[0]
    playback.seek(shifted.duration)
    playback.step(1)
    assert studio.state.time_s == shifted.t[-1]


def test_a_step_pauses_the_player(studio, shifted):
    playback = studio.playback
    wait_for_signal(studio.state.on_time, playback.toggle_play, accept=lambda t: t > shifted.t[3])
    assert playback.player.playing
    playback.step(1)
    assert not playback.player.playing


def test_the_cameras_follow_the_pelvis(studio, shifted):
    robot = studio.state.robot
    playback = studio.playback
    target = wait_for_signal(
        playback.camera.followed,
        lambda: setattr(playback.panel.follow, "value", True),
    )
    np.testing.assert_allclose(target, studio.state.q[:3])
    k = shifted.n_samples - 1
    target = wait_for_signal(
        playback.camera.followed,
        lambda: playback.seek(float(shifted.t[k])),
        accept=lambda xyz: np.allclose(xyz, shifted.q[k][:3]),
    )
    root = robot.link_placements(shifted.q[k], robot.model.createData())[robot.tree.root]
    np.testing.assert_allclose(target, root[:3, 3], atol=1e-9)
    assert np.linalg.norm(shifted.q[k][:2] - shifted.q[0][:2]) > 0.01  # it did move sideways


def test_following_keeps_the_view_and_its_height():
    look_at, position = np.array([0.1, 0.2, 0.4]), np.array([1.0, -0.5, 0.9])
    target = np.array([0.6, -0.3, 0.37])
    offset = follow_offset(look_at, target)
    new_look_at, new_position = look_at + offset, position + offset
    np.testing.assert_allclose(new_look_at[:2], target[:2])
    assert new_look_at[2] == look_at[2]  # the pelvis bobs; the camera does not
    np.testing.assert_allclose(new_position - new_look_at, position - look_at)


def test_the_player_rests_at_least_as_long_as_a_frame_took():
    """A frame that costs more than the display period (a slow machine, many ghosts) must not
    turn the player into a busy loop: between two frames it waits at least as long as the
    previous one took, so the server keeps half its time for clicks."""
    import itertools
    import threading
    import time

    from app.studio.playback_session import IDLE_PER_BUSY, Player

    spans: list[tuple[float, float]] = []
    done = threading.Event()

    def tick(_elapsed_s: float, _start_s: float, _stop: threading.Event) -> bool | None:
        started = time.perf_counter()
        while time.perf_counter() - started < 0.03:  # a 30 ms frame, twice the 60 Hz period
            pass
        spans.append((started, time.perf_counter()))
        if len(spans) == 6:
            done.set()
            return None
        return False

    player = Player(tick)
    player.play(0.0)
    assert done.wait(60.0)
    for (start_a, end_a), (start_b, _end_b) in itertools.pairwise(spans):
        assert start_b - end_a >= IDLE_PER_BUSY * (end_a - start_a) * 0.99
