"""Comparing the plan with one ghost, in a real headless Chromium: each ghost toggle shows its
colour in its label, the *Plan vs* dropdown ticks the plan and that one ghost, and the Front /
Side buttons move this tab's camera to look at the robot from its front and its right side
(read back from what the browser reports of its camera, and seen in the page)."""

from __future__ import annotations

import io
import re

import numpy as np
import pinocchio as pin
from PIL import Image

from app.studio import Studio
from app.views.ghosts_view import GHOSTS
from tests.browser.page_helpers import (
    UI_TIMEOUT_S,
    changed,
    click_button,
    expand_folder,
    gui_row_input,
    not_blank,
    wait_for,
    wait_stable,
)

COLOUR_TOLERANCE = 8
"""Largest difference per channel (0–255) between a swatch's pixel and its ghost's colour."""
DIRECTION_TOLERANCE = 0.02
"""Largest distance between the camera's unit viewing direction and the expected one."""


def label_of(page, text: str):
    return page.locator("label", has_text=re.compile(rf"^{re.escape(text)}$")).first


def test_each_ghost_toggle_shows_its_colour(page) -> None:
    expand_folder(page, "Compensation", "Compute torque feed-forward")
    for name, (rgb, text) in GHOSTS.items():
        label = label_of(page, text)
        label.scroll_into_view_if_needed()
        label.wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)
        box = label.bounding_box()
        assert box is not None
        png = page.screenshot(clip=box, animations="disabled")
        pixels = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)
        close = np.abs(pixels - np.array(rgb)).max(axis=2) <= COLOUR_TOLERANCE
        # a square swatch of at least 6x6 px in the ghost's colour, inside the label
        assert close.sum() >= 36, f"no {rgb} swatch in the label of {name!r}"


def test_plan_vs_ticks_the_plan_and_one_ghost(page, studio: Studio) -> None:
    boxes = studio.servo_rooms.ghosts.panel.ghosts
    assert {name for name, box in boxes.items() if box.value} == {"planned", "command"}
    choice = GHOSTS["with"][1]
    dropdown = gui_row_input(page, "Plan vs", "input.mantine-Select-input")
    dropdown.scroll_into_view_if_needed()
    dropdown.click()
    page.get_by_role("option", name=choice, exact=True).click()
    wait_for(
        "the ghosts' toggles to follow Plan vs",
        lambda: {name for name, box in boxes.items() if box.value} == {"planned", "with"},
        UI_TIMEOUT_S,
    )
    # and the page's own checkboxes show it
    for name, (_rgb, text) in GHOSTS.items():
        row = gui_row_input(page, text, "input[type=checkbox]")
        wait_for(
            f"the {name} toggle drawn {'on' if name in ('planned', 'with') else 'off'}",
            lambda row=row, name=name: row.is_checked() == (name in ("planned", "with")),
            UI_TIMEOUT_S,
        )


def expected_direction(studio: Studio, which: str) -> np.ndarray:
    """Unit vector from the robot to the camera: its forward axis (front) or its right (side),
    level, from the base's rotation (pinocchio)."""
    q = studio.state.pose.q
    R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
    axis = R[:, 0] if which == "front" else -R[:, 1]
    axis[2] = 0.0
    return axis / np.linalg.norm(axis)


def test_front_and_side_buttons_move_this_tabs_camera(page, studio: Studio) -> None:
    (client,) = studio.web.server.get_clients().values()
    reports: list[tuple[np.ndarray, np.ndarray]] = []
    client.camera.on_update(
        lambda camera: reports.append((camera.position.copy(), camera.look_at.copy()))
    )
    robot = studio.state.robot
    lower, upper = robot.bounds_m(studio.state.pose.q, robot.model.createData())
    views = {}
    for which, button in (("front", "Front view"), ("side", "Side view")):
        expected = expected_direction(studio, which)
        reports.clear()
        click_button(page, button)

        def looking(expected: np.ndarray = expected) -> bool:
            for position, look_at in list(reports):
                direction = (position - look_at) / np.linalg.norm(position - look_at)
                inside = np.all(look_at[:2] >= lower[:2] - 1e-6) and np.all(
                    look_at[:2] <= upper[:2] + 1e-6
                )
                if np.linalg.norm(direction - expected) < DIRECTION_TOLERANCE and inside:
                    return True
            return False

        wait_for(f"the browser's camera to look at the robot's {which}", looking, UI_TIMEOUT_S)
        views[which] = wait_stable(page, f"the {which} view drawn", not_blank)
    # the two presets show the robot differently in the page
    assert changed(views["front"], views["side"]).mean() > 0.01
