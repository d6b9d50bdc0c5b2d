"""End to end in a real headless Chromium: the robot renders, a joint slider moves it, and a
bad path is refused with a notification.

The page is loaded once for the module (software WebGL is slow). Waits poll screenshots or
the studio's state; nothing sleeps for a fixed time beyond a short polling interval.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.studio import Studio
from app.studio.robot_session import vars_of
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    box_of,
    changed,
    dismiss_software_webgl_warning,
    expand_folder,
    frame_interval_ms,
    gui_row_input,
    not_blank,
    publish,
    wait_for,
    wait_notified,
    wait_stable,
)

# Robot pixels (shot vs. the same view with the robot hidden), as a fraction of the view.
MIN_ROBOT_FRACTION = 0.005
# Pixels of the robot's box that must change when a joint moves.
MIN_MOTION_FRACTION = 0.01


def joint_to_move(studio: Studio) -> tuple[int, str, float]:
    """A knee (else a hip pitch) joint and a target [deg] far from its current angle."""
    robot = studio.state.robot
    assert robot is not None
    names = [joint.name for joint in robot.joints]
    pick = next((n for n in names if "knee" in n), None) or next(
        (n for n in names if "hip_pitch" in n), None
    )
    assert pick is not None, f"no knee or hip pitch joint in {names}"
    index = names.index(pick)
    joint = robot.joints[index]
    current = float(np.degrees(robot.joint_angles(studio.state.q)[index]))
    lower, upper = np.degrees(joint.lower), np.degrees(joint.upper)
    # 60 % of the way to the farther limit, rounded to the slider's 0.1° step, capped at 90°.
    far = upper if upper - current >= current - lower else lower
    target = current + float(np.clip(0.6 * (far - current), -90.0, 90.0))
    return index, pick, round(target, 1)


@pytest.fixture(scope="module")
def page(browser_page, studio: Studio, studio_url: str):
    """The studio page, loaded once and connected (its GUI shows the joint sliders)."""
    browser_page.goto(studio_url)
    first_joint = studio.state.robot.joints[0].name
    gui_row_input(browser_page, first_joint, "input.mantine-NumberInput-input").wait_for(
        state="visible", timeout=RENDER_TIMEOUT_S * 1000
    )
    return browser_page


def test_robot_renders_and_a_joint_slider_moves_it(page, studio: Studio, tmp_path: Path) -> None:
    # 1. The robot is drawn: the view is not blank and differs from the same view without it.
    dismiss_software_webgl_warning(page)
    with_robot = wait_stable(page, "a first render of the scene", not_blank)
    view = studio.robots.view
    assert view is not None
    view.set_visible(visual=False, collision=False, frames=False, com=False)
    try:
        empty = wait_stable(
            page,
            "the scene with the robot hidden",
            lambda image: changed(image, with_robot).mean() > MIN_ROBOT_FRACTION,
        )
    finally:
        view.set_visible(**vars_of(studio.robots.display.flags()))
    robot_mask = changed(with_robot, empty)
    assert robot_mask.mean() > MIN_ROBOT_FRACTION, (
        f"the robot covers only {robot_mask.mean():.2%} of the view: it did not render"
    )
    before = wait_stable(
        page,
        "the robot drawn again",
        lambda image: changed(image, empty).mean() > 0.5 * robot_mask.mean(),
    )

    screenshot = tmp_path / "studio.png"
    page.screenshot(path=str(screenshot))
    publish(page, "studio.png")
    assert not_blank(np.asarray(Image.open(screenshot).convert("RGB"), dtype=np.int16))

    # 2. Type a new angle into the number box next to the joint's slider, as a user would.
    index, name, target_deg = joint_to_move(studio)
    assert studio.joints.panel is not None
    number = gui_row_input(page, name, "input.mantine-NumberInput-input")
    number.scroll_into_view_if_needed()
    number.fill(f"{target_deg:g}")
    number.press("Enter")

    robot = studio.state.robot
    assert robot is not None

    # (a) The server received it: the studio's configuration has the new angle.
    def server_angle() -> bool:
        return abs(np.degrees(robot.joint_angles(studio.state.q)[index]) - target_deg) < 0.2

    wait_for(f"the studio to set {name} to {target_deg}°", server_angle, UI_TIMEOUT_S)
    assert studio.joints.panel.sliders[name].value == pytest.approx(target_deg, abs=0.1)

    # (b) The browser redrew the robot: its part of the view changed.
    region = box_of(robot_mask)
    after = wait_stable(
        page,
        f"the robot redrawn with {name} at {target_deg}°",
        lambda image: changed(image[region], before[region]).mean() > MIN_MOTION_FRACTION,
    )
    moved = changed(after[region], before[region]).mean()
    assert moved > MIN_MOTION_FRACTION, f"only {moved:.2%} of the robot's box changed"
    Image.fromarray(after.astype(np.uint8)).save(tmp_path / "studio_moved.png")


LOST_CLICK_S = 20.0
"""A box that still shows its old state this long after a click, while the studio has not
moved, lost the click (seen once in a clean-clone run: 120 s and nothing): click again."""


def tick(box, checked: bool, what: str, followed: Callable[[], bool]) -> None:
    """Tick (checked) or untick the box as a user does, and wait for the studio to follow; a
    click the page lost is clicked again, as a user clicks again (at most three times). The
    page shows a click at once (the box's own state), so a box still showing its old state
    after LOST_CLICK_S was not clicked; one that shows the new state and a studio that does
    not follow fails after UI_TIMEOUT_S."""
    for _attempt in range(3):
        box.click()
        deadline = time.monotonic() + LOST_CLICK_S
        while time.monotonic() < deadline and not followed():
            if box.is_checked() == checked:
                break
            time.sleep(0.2)
        else:
            if followed():
                return
            continue  # the page did not take the click
        wait_for(what, followed, UI_TIMEOUT_S)
        return
    pytest.fail(f"three clicks on the box and the page never showed it {checked=}", pytrace=False)


def test_detailed_lighting_is_one_tick_away_and_fast_lighting_comes_back(
    page, studio: Studio
) -> None:
    """The studio starts with the fast lighting (no environment map, no shadows: a software
    renderer draws it ~10x faster); the Display folder's *Detailed lighting* changes the
    picture in the page, and unticking it brings the fast picture back."""
    lighting = studio.robots.lighting
    assert not lighting.detailed
    dismiss_software_webgl_warning(page)
    # A notification still up from an earlier test (they close after 8 s) is masked black in
    # one shot and gone from the next: that alone would read as a change of the picture.
    notes = page.locator(".mantine-Notification-root")
    wait_for(
        "the notifications to close",
        lambda: not any(note.is_visible() for note in notes.all()),
        UI_TIMEOUT_S,
    )
    fast = wait_stable(page, "the scene in the fast lighting", not_blank)
    fast_ms = frame_interval_ms(page)
    checkbox = gui_row_input(page, "Detailed lighting", "input")
    if not checkbox.is_visible():
        expand_folder(page, "Display", "Frame robot")
    tick(checkbox, True, "the studio to switch the lighting", lambda: lighting.detailed)
    detailed = wait_stable(
        page,
        "the scene in the detailed lighting",
        lambda image: changed(image, fast).mean() > MIN_ROBOT_FRACTION,
    )
    detailed_ms = frame_interval_ms(page)
    tick(checkbox, False, "the studio to switch back", lambda: not lighting.detailed)
    back = wait_stable(
        page,
        "the scene in the fast lighting again",
        lambda image: changed(image, detailed).mean() > MIN_ROBOT_FRACTION,
    )
    # Back to the fast picture: much closer to it than the detailed one (under load a shot can
    # catch the environment map still fading in, so no tighter than half).
    assert changed(back, fast).mean() < 0.5 * changed(detailed, fast).mean()
    print(f"page frame interval: fast lighting {fast_ms:.0f} ms, detailed {detailed_ms:.0f} ms")


def test_opening_a_missing_path_notifies_and_keeps_the_robot(page, studio: Studio) -> None:
    robot_before, view_before = studio.state.robot, studio.robots.view
    missing = "/nonexistent/biped_studio_missing.urdf"

    path_box = gui_row_input(page, "URDF path", "input")
    path_box.scroll_into_view_if_needed()
    path_box.fill(missing)
    # Text edits and clicks travel on one websocket, in order; wait anyway so that a failure
    # says which half broke.
    wait_for(
        "the studio to receive the typed path",
        lambda: studio.robots.panel.path.value == missing,
        UI_TIMEOUT_S,
    )
    page.get_by_role("button", name="Open path").click()

    wait_notified(page, "Could not load the robot", missing, UI_TIMEOUT_S)
    assert studio.state.robot is robot_before
    assert studio.robots.view is view_before
    assert missing in studio.notifier.last_error
