"""What one tab does, seen from the others in a real Chromium: its upload's progress and its
refusals are said in that tab only.

viser 1.1.1 sent an upload's receipts to every tab and kept them for tabs opened later: each
showed "Uploading undefined (9.9K) — File uploaded successfully" for a file it never sent. A
keyframe refused (an empty name, a bad duration) was told to every tab.
"""

from __future__ import annotations

from pathlib import Path

from playwright.sync_api import expect

from app.studio import Studio
from tests.browser.conftest import VIEWPORT
from tests.browser.page_helpers import (
    UI_TIMEOUT_S,
    click_button,
    expand_folder,
    folder,
    gui_row_input,
    notifications_seen,
    open_studio,
    studio_context,
    wait_for,
    wait_notified,
)


def shows_first_keyframe(page) -> bool:
    """The page's Keyframes folder lists the keyframe captured after the upload."""
    return "pose 1 — start" in folder(page, "Keyframes").inner_text()


def test_an_upload_is_announced_in_the_uploading_tab_only(
    page, studio: Studio, chromium, tmp_path: Path
) -> None:
    uploader_context = studio_context(chromium, viewport=VIEWPORT)
    later_context = studio_context(chromium, viewport=VIEWPORT)
    try:
        uploader = open_studio(uploader_context.new_page(), studio.web.url)
        broken = tmp_path / "half.urdf"
        broken.write_text('<?xml version="1.0"?>\n<robot name="half"><link name="a">')
        with uploader.expect_file_chooser() as chooser:
            click_button(uploader, "Upload .urdf or .zip")
        chooser.value.set_files(str(broken))
        uploader.get_by_role("button", name="Load it", exact=True).click()  # another tab is open
        wait_notified(uploader, "Could not load the robot", "half.urdf", UI_TIMEOUT_S)
        assert any("Uploading half.urdf" in n for n in notifications_seen(uploader))

        # A change every tab sees, made after the upload: a tab showing it has been sent
        # everything queued for it before (one connection delivers in order).
        expand_folder(uploader, "Keyframes", "Capture pose")
        click_button(uploader, "Capture pose")
        later = open_studio(later_context.new_page(), studio.web.url)
        for other in (page, later):
            expand_folder(other, "Keyframes", "Capture pose")
            wait_for("the captured keyframe", lambda p=other: shows_first_keyframe(p), UI_TIMEOUT_S)
        for name, other in (("the tab open beside it", page), ("a tab opened after", later)):
            seen = [n for n in notifications_seen(other) if "Upload" in n]
            assert not seen, f"{name} was told of another tab's upload: {seen}"
    finally:
        uploader_context.close()
        later_context.close()


def test_a_refused_rename_is_said_in_the_tab_that_clicked_only(page, studio: Studio, chromium):
    other_context = studio_context(chromium, viewport=VIEWPORT)
    try:
        other = open_studio(other_context.new_page(), studio.web.url)
        expand_folder(other, "Keyframes", "Capture pose")
        click_button(other, "Capture pose")
        name = gui_row_input(other, "Name", "input")
        rename = other.get_by_role("button", name="Rename", exact=True)
        expect(rename).to_be_enabled(timeout=UI_TIMEOUT_S * 1000)
        name.fill("")
        wait_for(
            "the empty name", lambda: studio.motions.keyframes_panel.name.value == "", UI_TIMEOUT_S
        )
        rename.click()
        wait_notified(other, "Name refused", "give the keyframe a name", UI_TIMEOUT_S)

        # A change every tab sees, made after the refusal (see the test above).
        name.fill("lean")
        wait_for(
            "the typed name",
            lambda: studio.motions.keyframes_panel.name.value == "lean",
            UI_TIMEOUT_S,
        )
        rename.click()
        expand_folder(page, "Keyframes", "Capture pose")
        wait_for(
            "the rename", lambda: "lean" in folder(page, "Keyframes").inner_text(), UI_TIMEOUT_S
        )
        seen = [n for n in notifications_seen(page) if "refused" in n]
        assert not seen, f"the other tab was told of a refusal it did not cause: {seen}"
    finally:
        other_context.close()
