"""End to end in a real headless Chromium: capture two keyframes in the Keyframes folder, build
a motion from them, then play it back and pause it from the Playback folder.

Everything a user would do is done by clicking and typing in the page, except posing the
robot between the two captures: a user drags the foot's 3D gizmo, which Playwright cannot do
practically (a drag in a WebGL canvas needs the gizmo's projected screen position and a
software-rendered frame per mouse move), so the test calls `studio.pose.request_drag` — the
method the gizmo's drag callback calls — with the target such a drag would send.

The page is loaded once for the module (software WebGL is slow) and the second test plays
the motion the first one built: run them together, in file order.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from playwright.sync_api import expect

from app.studio import Studio
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    changed,
    click_button,
    expand_folder,
    folder,
    gui_row_input,
    not_blank,
    page_time_s,
    shot,
    type_number,
    wait_for,
    wait_stable,
)

LIFT_M = 0.03
"""How far the left foot is lifted between the two keyframes."""
SECOND_DURATION_S = 2.0
"""Duration typed for the second keyframe: the motion's length (the first one's is unused)."""
# Fraction of the view that must change while the motion plays: 20x the noise allowed between
# two "stable" shots (STABLE_FRACTION). Mid-motion the robot leans over its right foot (the CoM
# is kept over the support) and 1-4 % of the view changes (measured with servo_biped).
MIN_PLAY_FRACTION = 0.01
EDIT_BUTTONS = (
    "Go to",
    "Replace with current pose",
    "Rename",
    "Move up",
    "Move down",
    "Set duration",
    "Delete",
)
"""The Keyframes folder's buttons that act on the selected keyframe."""


def lifted_left_foot(studio: Studio) -> np.ndarray:
    """Where dragging the left foot's gizmo straight up by LIFT_M would put it."""
    robot = studio.state.robot
    assert robot is not None
    T = robot.link_placements(studio.state.q, robot.model.createData())[robot.feet[0].link]
    T[:3, 3] += [0.0, 0.0, LIFT_M]
    return T


def test_capture_two_keyframes_and_build_a_motion(page, studio: Studio) -> None:
    motions = studio.motions
    assert studio.state.trajectory is None and not motions.keyframes
    expand_folder(page, "Keyframes", "Capture pose")
    keyframes = folder(page, "Keyframes")
    # With no keyframe, what edits the selected one is disabled (clicks did nothing or asked
    # for a name for no keyframe); a capture enables it.
    edits = [keyframes.get_by_role("button", name=n, exact=True) for n in EDIT_BUTTONS]
    for button in edits:
        expect(button).to_be_disabled(timeout=UI_TIMEOUT_S * 1000)

    # Keyframe 1: the neutral pose, with the default duration (unused for a first keyframe).
    click_button(page, "Capture pose")
    wait_for("the first keyframe", lambda: len(motions.keyframes) == 1, UI_TIMEOUT_S)
    keyframes.get_by_text("pose 1 — start", exact=False).wait_for(state="visible")
    for button in edits:
        expect(button).to_be_enabled(timeout=UI_TIMEOUT_S * 1000)

    # Lift the left foot 3 cm (in place of a gizmo drag, see the module docstring).
    studio.pose.request_drag("left", lifted_left_foot(studio))
    assert studio.pose is not None and studio.state.pose.stance == "right"

    # Keyframe 2, reached in SECOND_DURATION_S: type it, then capture.
    type_number(page, "Duration [s]", SECOND_DURATION_S)
    wait_for(
        "the studio to receive the typed duration",
        lambda: studio.motions.keyframes_panel.duration.value == SECOND_DURATION_S,
        UI_TIMEOUT_S,
    )
    click_button(page, "Capture pose")
    wait_for("the second keyframe", lambda: len(motions.keyframes) == 2, UI_TIMEOUT_S)
    keyframes.get_by_text(f"pose 2 — {SECOND_DURATION_S:.2f} s", exact=False).wait_for(
        state="visible"
    )
    selected = gui_row_input(page, "Selected", "input.mantine-Select-input")
    wait_for(
        "the page to select the new keyframe",
        lambda: selected.input_value() == "2. pose 2",
        UI_TIMEOUT_S,
    )
    assert [kf.duration_s for kf in motions.keyframes] == [1.0, SECOND_DURATION_S]
    assert [kf.stance for kf in motions.keyframes] == ["both", "right"]

    click_button(page, "Build motion")
    trajectory = wait_for("the built motion", lambda: studio.state.trajectory, UI_TIMEOUT_S)
    # A motion lasts the sum of its keyframes' durations but the first's (samples every dt).
    expected = sum(kf.duration_s for kf in motions.keyframes[1:])
    assert trajectory.name == "keyframes"
    assert trajectory.duration == pytest.approx(expected, abs=trajectory.dt + 1e-9)

    # The page's Playback folder describes the motion and its timeline starts at 0.
    playback = folder(page, "Playback")
    playback.get_by_text(
        re.compile(rf"keyframes\s+—\s+{trajectory.duration:.2f} s, {trajectory.n_samples} samples")
    ).wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)
    assert page_time_s(page) == 0.0
    assert page.get_by_role("button", name="Play", exact=True).is_enabled()


def test_play_moves_the_robot_and_pause_stops_it(page, studio: Studio) -> None:
    trajectory = studio.state.trajectory
    assert trajectory is not None, "run with the previous test: it builds the motion played here"
    assert not studio.playback.player.playing
    start = wait_stable(page, "the motion's first pose drawn", not_blank)

    click_button(page, "Play")
    page.get_by_role("button", name="Pause", exact=True).wait_for(state="visible")
    assert studio.playback.player.playing

    # The page's timeline runs (it moves on again and again; the motion loops)...
    first = wait_for(
        "the page's Time [s] to leave 0",
        lambda: (t := page_time_s(page)) > 0.0 and t,
        UI_TIMEOUT_S,
    )
    wait_for(
        f"the page's Time [s] to move on from {first}",
        lambda: math.isfinite(t := page_time_s(page)) and t != first,
        UI_TIMEOUT_S,
    )

    # ... and the robot is redrawn away from its first pose, drawn before Play. (Over 2 s it
    # leans onto its right foot and lifts the left one, then loops; a shot takes ~1 s in
    # software WebGL, so the first shot or the next lands mid-motion.)
    moved = wait_for(
        "a shot of the robot away from its first pose",
        lambda: (f := float(changed(shot(page), start).mean())) > MIN_PLAY_FRACTION and f,
        RENDER_TIMEOUT_S,
    )
    assert moved > MIN_PLAY_FRACTION

    click_button(page, "Pause")
    page.get_by_role("button", name="Play", exact=True).wait_for(state="visible")
    assert studio.playback.player.playing is False
    # The page's timeline stops where the studio paused.
    paused_at = studio.playback.panel.time.value
    assert 0.0 <= paused_at <= trajectory.duration
    wait_for(
        f"the page's Time [s] to show the pause at {paused_at}",
        lambda: page_time_s(page) == pytest.approx(paused_at, abs=1e-6),
        UI_TIMEOUT_S,
    )


def test_space_plays_and_pauses_and_j_l_step_one_frame(page, studio: Studio) -> None:
    """The keys a user reaches for, pressed in the page (the Play button still has the focus
    from the last click: Space must toggle once, not also click it)."""
    trajectory = studio.state.trajectory
    assert trajectory is not None, "run with the previous tests: they build and pause the motion"
    assert not studio.playback.player.playing
    paused_at = studio.state.time_s
    page.keyboard.press("Space")
    page.get_by_role("button", name="Pause", exact=True).wait_for(state="visible")
    # It keeps playing (a click of the focused button on the key's release would pause it).
    wait_for(
        "the motion to play on",
        lambda: studio.state.time_s != paused_at and studio.state.pose.origin == "playback",
        UI_TIMEOUT_S,
    )
    page.get_by_role("button", name="Pause", exact=True).wait_for(state="visible")
    assert studio.playback.player.playing
    page.keyboard.press("Space")
    page.get_by_role("button", name="Play", exact=True).wait_for(state="visible")
    wait_for("the player to stop", lambda: not studio.playback.player.playing, UI_TIMEOUT_S)

    k = trajectory.index_at(studio.state.time_s)
    k = min(max(k, 1), trajectory.n_samples - 3)
    studio.playback.seek(float(trajectory.t[k]))
    page.keyboard.press("l")
    wait_for(
        "L to show the next sample",
        lambda: studio.state.time_s == trajectory.t[k + 1],
        UI_TIMEOUT_S,
    )
    page.keyboard.press("l")
    page.keyboard.press("j")
    page.keyboard.press("j")
    wait_for(
        "J to go back two samples",
        lambda: studio.state.time_s == trajectory.t[k],
        UI_TIMEOUT_S,
    )
    assert not studio.playback.player.playing
