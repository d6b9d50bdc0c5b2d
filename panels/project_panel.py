"""Project panel: the project's name, whether it has unsaved changes, when it was last saved;
Save, Save as (a path), Open (a path, or an uploaded .bstudio), and the autosave status."""

from __future__ import annotations

from typing import Protocol

import viser

from panels.clicks import bind_clicks
from panels.quiet import set_value


class ProjectActions(Protocol):
    """What the Project panel asks for."""

    def save(self, client: viser.ClientHandle | None) -> bool: ...

    def save_as(self, path: str, client: viser.ClientHandle | None) -> bool: ...

    def open(self, path: str, client: viser.ClientHandle | None) -> bool: ...

    def open_upload(
        self, filename: str, content: bytes, client: viser.ClientHandle | None
    ) -> bool: ...

    def undo(self, client: viser.ClientHandle | None) -> bool: ...

    def redo(self, client: viser.ClientHandle | None) -> bool: ...


class ProjectPanel:
    """Owns the "Project" folder, at the top of the GUI. Callbacks only forward the request."""

    def __init__(self, gui: viser.GuiApi, actions: ProjectActions, projects_dir: str) -> None:
        self._actions = actions
        # The name and dirty marker stay in view; the buttons fold away (the studio opens on
        # the robot, not on file handling).
        self.title = gui.add_markdown("**untitled** — not saved yet", order=-11)
        with gui.add_folder("Project", order=-10, expand_by_default=False):
            self.save = gui.add_button("Save", icon=viser.Icon.DEVICE_FLOPPY)
            self.path = gui.add_text(
                "Path",
                "",
                hint=f"A .bstudio file; a bare name goes to {projects_dir}",
            )
            self.save_as = gui.add_button("Save as", icon=viser.Icon.FILE_PLUS)
            self.open = gui.add_button("Open", icon=viser.Icon.FOLDER_OPEN)
            self.upload = gui.add_upload_button(
                "Open an uploaded .bstudio",
                icon=viser.Icon.UPLOAD,
                mime_type=".bstudio,application/zip",
            )
            self.undo = gui.add_button(
                "Undo", icon=viser.Icon.ARROW_BACK_UP, disabled=True, hint="Pose and keyframe edits"
            )
            self.redo = gui.add_button("Redo", icon=viser.Icon.ARROW_FORWARD_UP, disabled=True)
            self.status = gui.add_markdown("")

        def typed_path() -> str:
            return str(self.path.value).strip()

        bind_clicks(
            (self.save, actions.save),
            (self.save_as, lambda client: actions.save_as(typed_path(), client)),
            (self.open, lambda client: actions.open(typed_path(), client)),
            (self.undo, actions.undo),
            (self.redo, actions.redo),
        )

        @self.upload.on_upload
        def _(event: viser.GuiEvent) -> None:
            uploaded = self.upload.value
            actions.open_upload(uploaded.name, uploaded.content, event.client)

    def show_title(self, name: str, dirty: bool, saved_at: str) -> None:
        marker = " ● unsaved changes" if dirty else ""
        saved = f"saved {saved_at}" if saved_at else "not saved yet"
        text = f"**{name}**{marker} — {saved}"
        if self.title.content != text:
            self.title.content = text

    def show_undo(self, can_undo: bool, can_redo: bool) -> None:
        self.undo.disabled = not can_undo
        self.redo.disabled = not can_redo

    def show_status(self, text: str) -> None:
        self.status.content = text

    def show_path(self, path: str) -> None:
        set_value(self.path, path)
