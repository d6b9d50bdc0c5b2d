"""In a real Chromium tab: a tab left open across a restart of the studio reconnects by itself
and shows the studio (the access token is kept in the data folder), with the restored project
under its own name; *Undo* after a click says what it undid."""

from __future__ import annotations

import re

from playwright.sync_api import expect

from app.config import StudioConfig
from app.studio import Studio
from tests.browser.conftest import VIEWPORT, _free_port
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    click_button,
    dismiss_software_webgl_warning,
    expand_folder,
    studio_context,
    wait_notified,
)
from tests.studio.conftest import wait_for_signal

NOTICE = "needs its access link"


def test_an_open_tab_survives_a_restart_and_the_project_keeps_its_name(chromium, tmp_path):
    data, port = tmp_path / "data", _free_port()
    first = Studio(StudioConfig(port=port, data_dir=data))
    second: Studio | None = None
    context = studio_context(chromium, viewport=VIEWPORT)
    try:
        assert first.project.save_as("walker")
        wait_for_signal(
            first.project.autosave.written, lambda: first.joints.set_joint_angle(1, 0.2)
        )
        page = context.new_page()
        page.set_default_timeout(RENDER_TIMEOUT_S * 1000)
        page.goto(first.web.url)
        dismiss_software_webgl_warning(page)
        title = page.get_by_text(re.compile(r"^walker ● unsaved changes"))
        title.wait_for()
        assert len(first.web.server.get_clients()) == 1

        first.stop()
        second = Studio(StudioConfig(port=port, data_dir=data, restore_autosave=True))
        page.bring_to_front()  # viser's client retries its connection while the page has focus
        # Only the new studio greets a tab with the work it restored: the tab is connected to it.
        wait_notified(page, "Restored your work from", "walker", RENDER_TIMEOUT_S)
        title.wait_for()  # the restored project under its own name
        assert len(second.web.server.get_clients()) == 1

        page.reload()  # the link the tab was opened with still works
        dismiss_software_webgl_warning(page)
        title.wait_for()
        assert NOTICE not in page.content()
    finally:
        context.close()
        first.stop() if second is None else second.stop()


def test_undo_after_a_click_says_what_it_undid(studio, studio_url, browser_page):
    page = browser_page
    page.goto(studio_url)
    dismiss_software_webgl_warning(page)
    expand_folder(page, "Keyframes", "Capture pose")
    click_button(page, "Capture pose")
    expand_folder(page, "Project", "Undo")
    undo = page.get_by_role("button", name="Undo", exact=True)
    # The step is taken once the work has been still for a moment: Undo then enables.
    expect(undo).to_be_enabled(timeout=UI_TIMEOUT_S * 1000)
    assert len(studio.motions.keyframes) == 1
    captured = studio.motions.keyframes[0].name
    undo.click()
    said = f"Undid: keyframe “{captured}” added"
    wait_notified(page, said, "", UI_TIMEOUT_S)
    assert studio.motions.keyframes == []
    # Nothing left: the button is disabled again (a click could not reach the server).
    expect(undo).to_be_disabled(timeout=UI_TIMEOUT_S * 1000)
