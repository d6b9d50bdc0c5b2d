"""A project's round trip as a user makes it, in a real headless Chromium: generate a motion,
*Save as* a name, load another robot, reload the page, *Open* the name, and find the robot,
the motion and the name back, in the page and in the studio.

The check is the round trip itself: the motion opened equals the motion saved (every
configuration), the robot is the one saved, not whatever was loaded last.
"""

from __future__ import annotations

import re
import time

import numpy as np
from playwright.sync_api import expect

from app.studio import Studio
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    click_button,
    dismiss_software_webgl_warning,
    expand_folder,
    folder_title,
    generate_motion,
    gui_row_input,
    select_option,
    wait_for,
    wait_notified,
)

MOTION = "com_shift"
NAME = "tour"


def type_text(page, label: str, text: str, studio_value) -> None:
    """Type into the text box `label` and wait until the studio has it (edits and clicks
    travel in order on one websocket; the wait makes a failure say which half broke)."""
    box = gui_row_input(page, label, "input")
    box.scroll_into_view_if_needed()
    box.fill(text)
    box.press("Enter")
    wait_for(f"the studio to receive {text!r}", lambda: studio_value() == text, UI_TIMEOUT_S)


def title_shows(page, name: str):
    """The project's name at the top of the panel."""
    return page.locator("p", has_text=re.compile(rf"^{re.escape(name)}\b.* — ")).first


def test_save_as_reload_and_open_bring_the_work_back(page, studio: Studio) -> None:
    saved = generate_motion(page, studio, MOTION, RENDER_TIMEOUT_S)
    robot_saved = studio.state.robot.name

    expand_folder(page, "Project", "Save as")
    type_text(page, "Path", NAME, lambda: studio.project.panel.path.value)
    click_button(page, "Save as")
    title_shows(page, NAME).wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)
    assert "unsaved" not in title_shows(page, NAME).inner_text()

    # Other work replaces it: another robot (one tab, so no confirmation).
    select_option(page, "Built-in", "dircon_biped")
    click_button(page, "Load built-in")
    wait_notified(page, "Robot loaded", "dircon_biped", RENDER_TIMEOUT_S)
    assert studio.state.trajectory is None

    page.reload()
    folder_title(page, "Playback").wait_for(state="visible", timeout=RENDER_TIMEOUT_S * 1000)
    dismiss_software_webgl_warning(page)
    expand_folder(page, "Project", "Open")
    type_text(page, "Path", NAME, lambda: studio.project.panel.path.value)
    started = time.monotonic()
    click_button(page, "Open")
    title_shows(page, NAME).wait_for(state="visible", timeout=RENDER_TIMEOUT_S * 1000)
    opened = wait_for(
        "the opened motion",
        lambda: (t := studio.state.trajectory) is not None and t.name == MOTION and t,
        RENDER_TIMEOUT_S,
    )
    print(f"Open {NAME}: shown {time.monotonic() - started:.1f} s after the click")
    assert studio.state.robot.name == robot_saved
    # The dropdown follows the opened robot (Mantine syncs its text a render later: wait on it).
    expect(gui_row_input(page, "Built-in", "input.mantine-Select-input")).to_have_value(
        robot_saved, timeout=UI_TIMEOUT_S * 1000
    )
    assert opened.q.shape == saved.q.shape
    np.testing.assert_allclose(opened.q, saved.q, atol=1e-12)
    np.testing.assert_allclose(opened.t, saved.t, atol=1e-12)
    assert not page.locator(".mantine-Notification-root", has_text="Something went wrong").count()
