"""Robot panel: pick a built-in, open a URDF path, upload a .urdf/.zip, read the robot report."""

from __future__ import annotations

from typing import Protocol

import viser

from app.core.robot.report import RobotReport
from panels.clicks import bind_clicks
from panels.quiet import Quiet, set_value
from robots.catalogue import BUILTIN_ROBOTS


class RobotActions(Protocol):
    """What the Robot panel asks for."""

    def load(self, source: str, client: viser.ClientHandle | None) -> bool: ...

    def load_upload(
        self, filename: str, content: bytes, client: viser.ClientHandle | None
    ) -> bool: ...


class RobotPanel:
    """Owns the "Robot" folder. Callbacks only forward the request."""

    def __init__(self, gui: viser.GuiApi, actions: RobotActions, max_upload_bytes: int) -> None:
        self._actions = actions
        self._quiet = Quiet()
        with gui.add_folder("Robot", order=0):
            self.builtin = gui.add_dropdown(
                "Built-in",
                tuple(BUILTIN_ROBOTS),
                initial_value=next(iter(BUILTIN_ROBOTS)),
                hint="Robots generated from the papers' numbers",
            )
            self.load_builtin = gui.add_button("Load built-in", icon=viser.Icon.ROBOT)
            self.path = gui.add_text(
                "URDF path", "", hint="A .urdf on the machine running the studio"
            )
            self.open_path = gui.add_button("Open path", icon=viser.Icon.FOLDER_OPEN)
            self.upload = gui.add_upload_button(
                "Upload .urdf or .zip",
                icon=viser.Icon.UPLOAD,
                mime_type=".urdf,.zip,application/zip",
                hint=f"A URDF, or a zip with the URDF and its meshes (at most {max_upload_bytes // 2**20} MB)",
            )
            self.status = gui.add_markdown("")
            with gui.add_folder("Report", expand_by_default=False):
                self.report = gui.add_markdown("")

        bind_clicks(
            (self.load_builtin, lambda client: actions.load(self.builtin.value, client=client)),
            (self.open_path, lambda client: actions.load(self.path.value.strip(), client=client)),
        )

        @self.upload.on_upload
        def _(event: viser.GuiEvent) -> None:
            self.receive_upload(self.upload.value, event.client)

    def receive_upload(
        self, uploaded: viser.UploadedFile, client: viser.ClientHandle | None = None
    ) -> None:
        """What the upload button does with a file the browser sent."""
        self._actions.load_upload(uploaded.name, uploaded.content, client=client)

    def show_report(self, report: RobotReport) -> None:
        lines = report.lines()
        self.report.content = "```\n" + "\n".join(lines) + "\n```"

    def show_status(self, text: str) -> None:
        self.status.content = text

    def show_builtin(self, name: str) -> None:
        """Show which built-in is loaded (the dropdown follows loads from anywhere)."""
        if name in BUILTIN_ROBOTS:
            with self._quiet.quietly():
                set_value(self.builtin, name)
