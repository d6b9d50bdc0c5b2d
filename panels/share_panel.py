"""Share panel: export a replay that plays in any browser, and save a screenshot."""

from __future__ import annotations

from typing import Protocol

import viser

from panels.quiet import set_value


class ShareActions(Protocol):
    """What the Share panel asks for."""

    def export_replay(self, client: viser.ClientHandle | None) -> None: ...
    def screenshot(self, client: viser.ClientHandle | None) -> None: ...


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
            self.screenshot = gui.add_button("Screenshot", icon=viser.Icon.CAMERA)
            self.status = gui.add_markdown(
                "Exports the current motion as played, with the ghosts and traces shown."
            )
        self.export.on_click(lambda event: actions.export_replay(event.client))
        self.screenshot.on_click(lambda event: actions.screenshot(event.client))

    def show_progress(self, fraction: float | None) -> None:
        self.progress.visible = fraction is not None
        self.export.disabled = fraction is not None
        if fraction is not None:
            set_value(self.progress, 100.0 * fraction)
