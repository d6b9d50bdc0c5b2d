"""End to end in a real headless Chromium: the robot renders, a joint slider moves it, and a
bad path is refused with a notification.

The page is loaded once for the module (software WebGL is slow). Waits poll screenshots or
the studio's state; nothing sleeps for a fixed time beyond a short polling interval.
"""

from __future__ import annotations

import io
import os
import re
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import numpy as np
import pytest
from PIL import Image

from app.studio import Studio, vars_of

REPO = Path(__file__).resolve().parents[2]
README_SCREENSHOT = REPO / "static" / "studio.png"
RENDER_TIMEOUT_S = 90.0
UI_TIMEOUT_S = 30.0
POLL_S = 0.25

# A pixel "differs" when a channel moves by more than this (0-255): well above the noise of
# antialiasing and of SwiftShader, well below a robot part against the grid.
PIXEL_DELTA = 40
# Robot pixels (shot vs. the same view with the robot hidden), as a fraction of the view.
MIN_ROBOT_FRACTION = 0.005
# Pixels of the robot's box that must change when a joint moves.
MIN_MOTION_FRACTION = 0.01
# Stable: two successive shots differ on fewer pixels than this fraction.
STABLE_FRACTION = 0.0005

T = TypeVar("T")


def wait_for(what: str, probe: Callable[[], T | None], timeout_s: float) -> T:
    """Poll `probe` until it returns something other than None or False; fail naming `what`
    after the timeout."""
    deadline = time.monotonic() + timeout_s
    while True:
        result = probe()
        if result is not None and result is not False:
            return result
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout_s:.0f} s waiting for {what}", pytrace=False)
        time.sleep(POLL_S)


def shot(page) -> np.ndarray:
    """The 3D view as an RGB array; the control panel and notifications are painted black so
    that only the scene can make two shots differ."""
    png = page.screenshot(
        mask=[page.locator("[data-dock-group]"), page.locator(".mantine-Notification-root")],
        mask_color="#000000",
        animations="disabled",
    )
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Boolean mask of the pixels that differ between two shots."""
    return np.abs(a - b).max(axis=2) > PIXEL_DELTA


def not_blank(image: np.ndarray) -> bool:
    """A drawn scene, not a cleared canvas: varied colours and contrast."""
    colours = np.unique(image.reshape(-1, 3)[::7], axis=0)
    return len(colours) > 50 and float(image.std()) > 10.0


def wait_stable(
    page, what: str, accept: Callable[[np.ndarray], bool], timeout_s: float = RENDER_TIMEOUT_S
):
    """The first shot that `accept`s and equals the shot taken just before it."""
    previous: list[np.ndarray] = []

    def probe() -> np.ndarray | None:
        image = shot(page)
        ok = accept(image)
        stable = ok and bool(previous) and changed(image, previous[0]).mean() < STABLE_FRACTION
        previous[:] = [image] if ok else []
        return image if stable else None  # an array: wait_for tests it against None

    return wait_for(what, probe, timeout_s)


def dismiss_software_webgl_warning(page) -> None:
    """viser warns about SwiftShader with a sticky notification; close it for a clean picture."""
    close = page.locator("#webgl-software-rendering .mantine-Notification-closeButton")
    if close.count():
        close.first.click()
        close.wait_for(state="detached")


def gui_row_input(page, label: str, css: str):
    """The input `css` in the GUI row whose label reads exactly `label` (viser puts the label
    in a <label> and the controls in the same flex row)."""
    text = page.locator("label", has_text=re.compile(rf"^{re.escape(label)}$"))
    row = text.locator("xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]")
    return row.locator(css)


def box_of(mask: np.ndarray, margin: int = 20) -> tuple[slice, slice]:
    rows, cols = np.nonzero(mask)
    height, width = mask.shape
    return (
        slice(max(0, rows.min() - margin), min(height, rows.max() + margin + 1)),
        slice(max(0, cols.min() - margin), min(width, cols.max() + margin + 1)),
    )


def joint_to_move(studio: Studio) -> tuple[int, str, float]:
    """A knee (else a hip pitch) joint and a target [deg] far from its current angle."""
    robot = studio.robot
    assert robot is not None
    names = [joint.name for joint in robot.joints]
    pick = next((n for n in names if "knee" in n), None) or next(
        (n for n in names if "hip_pitch" in n), None
    )
    assert pick is not None, f"no knee or hip pitch joint in {names}"
    index = names.index(pick)
    joint = robot.joints[index]
    current = float(np.degrees(robot.joint_angles(studio.q)[index]))
    lower, upper = np.degrees(joint.lower), np.degrees(joint.upper)
    # 60 % of the way to the farther limit, rounded to the slider's 0.1° step, capped at 90°.
    far = upper if upper - current >= current - lower else lower
    target = current + float(np.clip(0.6 * (far - current), -90.0, 90.0))
    return index, pick, round(target, 1)


@pytest.fixture(scope="module")
def page(browser_page, studio: Studio, studio_url: str):
    """The studio page, loaded once and connected (its GUI shows the joint sliders)."""
    browser_page.goto(studio_url)
    first_joint = studio.robot.joints[0].name
    gui_row_input(browser_page, first_joint, "input.mantine-NumberInput-input").wait_for(
        state="visible", timeout=RENDER_TIMEOUT_S * 1000
    )
    return browser_page


def test_robot_renders_and_a_joint_slider_moves_it(page, studio: Studio, tmp_path: Path) -> None:
    # 1. The robot is drawn: the view is not blank and differs from the same view without it.
    dismiss_software_webgl_warning(page)
    with_robot = wait_stable(page, "a first render of the scene", not_blank)
    view = studio.view
    assert view is not None
    view.set_visible(visual=False, collision=False, frames=False, com=False)
    try:
        empty = wait_stable(
            page,
            "the scene with the robot hidden",
            lambda image: changed(image, with_robot).mean() > MIN_ROBOT_FRACTION,
        )
    finally:
        view.set_visible(**vars_of(studio.display_panel.flags()))
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
    if os.environ.get("BIPED_STUDIO_SCREENSHOT") == "1":
        README_SCREENSHOT.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(screenshot, README_SCREENSHOT)
    assert not_blank(np.asarray(Image.open(screenshot).convert("RGB"), dtype=np.int16))

    # 2. Type a new angle into the number box next to the joint's slider, as a user would.
    index, name, target_deg = joint_to_move(studio)
    assert studio.joints_panel is not None
    number = gui_row_input(page, name, "input.mantine-NumberInput-input")
    number.scroll_into_view_if_needed()
    number.fill(f"{target_deg:g}")
    number.press("Enter")

    robot = studio.robot
    assert robot is not None

    # (a) The server received it: the studio's configuration has the new angle.
    def server_angle() -> bool:
        return abs(np.degrees(robot.joint_angles(studio.q)[index]) - target_deg) < 0.2

    wait_for(f"the studio to set {name} to {target_deg}°", server_angle, UI_TIMEOUT_S)
    assert studio.joints_panel.sliders[name].value == pytest.approx(target_deg, abs=0.1)

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


def test_opening_a_missing_path_notifies_and_keeps_the_robot(page, studio: Studio) -> None:
    robot_before, view_before = studio.robot, studio.view
    missing = "/nonexistent/biped_studio_missing.urdf"

    path_box = gui_row_input(page, "URDF path", "input")
    path_box.scroll_into_view_if_needed()
    path_box.fill(missing)
    # Text edits and clicks travel on one websocket, in order; wait anyway so that a failure
    # says which half broke.
    wait_for(
        "the studio to receive the typed path",
        lambda: studio.robot_panel.path.value == missing,
        UI_TIMEOUT_S,
    )
    page.get_by_role("button", name="Open path").click()

    notification = page.locator(".mantine-Notification-root", has_text="Could not load the robot")
    notification.wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)
    assert missing in notification.inner_text()
    assert studio.robot is robot_before
    assert studio.view is view_before
    assert missing in studio.last_error
