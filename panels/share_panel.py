"""Share panel: export a replay that plays in any browser, download a screenshot, film a video."""

from __future__ import annotations

from typing import Protocol

import viser

from app.core.replay.video import DEFAULT_FPS, DEFAULT_WIDTH, MAX_FPS, MAX_SIDE, MIN_FPS, MIN_SIDE
from panels.quiet import set_value


class ShareActions(Protocol):
    """What the Share panel asks for."""

    def export_replay(self, client: viser.ClientHandle | None) -> None: ...
    def screenshot(self, client: viser.ClientHandle | None) -> None: ...
    def export_video(self, client: viser.ClientHandle | None) -> None: ...
    def cancel_video(self) -> None: ...


class SharePanel:
    """Owns the "Share" folder: *Export replay* (with a zip option), *Screenshot*, a progress
    bar and a status line that names the files written."""

    def __init__(self, gui: viser.GuiApi, actions: ShareActions) -> None:
        with gui.add_folder("Share", order=7, expand_by_default=False):
            self.export = gui.add_button(
                "Export replay", icon=viser.Icon.MOVIE, hint="a folder that plays in any browser"
            )
            self.zip = gui.add_checkbox("Also write a .zip", False)
            self.progress = gui.add_progress_bar(0.0, visible=False)
            self.screenshot = gui.add_button(
                "Screenshot", icon=viser.Icon.CAMERA, hint="this tab's view, as a PNG download"
            )
            self.video = gui.add_button(
                "Export video",
                icon=viser.Icon.VIDEO,
                hint="the motion played in this tab, filmed from its view",
            )
            self.video_format = gui.add_dropdown(
                "Video format", ("mp4", "gif"), initial_value="mp4"
            )
            self.video_fps = gui.add_number(
                "Video fps", DEFAULT_FPS, min=MIN_FPS, max=MAX_FPS, step=1
            )
            self.video_width = gui.add_number(
                "Video width (px)", DEFAULT_WIDTH, min=MIN_SIDE, max=MAX_SIDE, step=2
            )
            self.video_progress = gui.add_progress_bar(0.0, visible=False)
            self.video_cancel = gui.add_button("Cancel video", visible=False, color="red")
            self.status = gui.add_markdown(
                "Exports the current motion as played, with the ghosts and traces shown."
            )
        self.export.on_click(lambda event: actions.export_replay(event.client))
        self.screenshot.on_click(lambda event: actions.screenshot(event.client))
        self.video.on_click(lambda event: actions.export_video(event.client))
        self.video_cancel.on_click(lambda _event: actions.cancel_video())

    def show_progress(self, fraction: float | None) -> None:
        self.progress.visible = fraction is not None
        self.export.disabled = fraction is not None
        if fraction is not None:
            set_value(self.progress, 100.0 * fraction)

    def show_video_progress(self, fraction: float | None) -> None:
        """A video being filmed (its progress bar and Cancel shown), or none (None)."""
        self.video_progress.visible = fraction is not None
        self.video_cancel.visible = fraction is not None
        self.video.disabled = fraction is not None
        if fraction is not None:
            set_value(self.video_progress, 100.0 * fraction)
