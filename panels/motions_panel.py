"""Motions panel: the papers' built-in motions with their parameters, and motion files."""

from __future__ import annotations

from typing import Protocol

import viser

from app.core.motions.library import MOTIONS
from app.core.motions.params import Param
from panels.clicks import bind_clicks


class MotionActions(Protocol):
    """What the Motions panel asks for."""

    def generate(
        self, name: str, params: dict[str, object], client: viser.ClientHandle | None
    ) -> bool: ...
    def export(self, client: viser.ClientHandle | None) -> bytes | None: ...
    def import_file(
        self,
        filename: str,
        content: bytes,
        quaternion_order: str,
        client: viser.ClientHandle | None,
    ) -> bool: ...


class MotionsPanel:
    """Owns the "Motions" folder; parameter inputs are rebuilt for the chosen motion."""

    def __init__(self, gui: viser.GuiApi, actions: MotionActions) -> None:
        self._gui = gui
        with gui.add_folder("Motions", order=2.5, expand_by_default=False) as self.folder:
            self.motion = gui.add_dropdown(
                "Motion", tuple(MOTIONS), initial_value=next(iter(MOTIONS))
            )
            self.description = gui.add_markdown("")
            self._params_folder: viser.GuiFolderHandle | None = None
            self.inputs: dict[str, viser.GuiInputHandle] = {}
            self.generate = gui.add_button("Generate", icon=viser.Icon.PLAYER_PLAY)
            self.export = gui.add_button("Export motion CSV", icon=viser.Icon.DOWNLOAD)
            self.quaternion = gui.add_dropdown(
                "Roban CSV quaternion",
                ("xyzw", "wxyz"),
                initial_value="xyzw",
                hint="Order of the base quaternion in a headerless Roban motion file (not stated in "
                "the files: Roban S14's dance is xyzw, its prone motion wxyz)",
            )
            self.upload = gui.add_upload_button(
                "Import motion CSV", icon=viser.Icon.UPLOAD, mime_type=".csv"
            )
            self.status = gui.add_markdown("")
        self._show_params()
        self.motion.on_update(lambda _: self._show_params())

        def generate(client: viser.ClientHandle | None) -> None:
            actions.generate(self.motion.value, self.values(), client)

        bind_clicks((self.generate, generate), (self.export, actions.export))

        @self.upload.on_upload
        def _(event: viser.GuiEvent) -> None:
            uploaded = self.upload.value
            actions.import_file(
                uploaded.name, uploaded.content, self.quaternion.value, event.client
            )

    def _show_params(self) -> None:
        spec = MOTIONS[self.motion.value]
        self.description.content = spec.description
        if self._params_folder is not None:
            self._params_folder.remove()
        self.inputs = {}
        with (
            self.folder,
            self._gui.add_folder("Parameters", order=self.description.order + 0.01) as folder,
        ):
            for param in spec.params:
                self.inputs[param.name] = _input(self._gui, param)
        self._params_folder = folder

    def values(self) -> dict[str, object]:
        """Parameter values as typed; "auto" leaves a robot-scaled parameter at its default."""
        out: dict[str, object] = {}
        for name, handle in self.inputs.items():
            value = handle.value
            if isinstance(value, str) and value.strip().lower() in ("", "auto"):
                continue
            out[name] = value
        return out


def _input(gui: viser.GuiApi, param: Param) -> viser.GuiInputHandle:
    label = f"{param.name} [{param.unit}]" if param.unit else param.name
    if param.choices:
        return gui.add_dropdown(
            label, param.choices, initial_value=str(param.default), hint=param.help
        )
    if param.default is None:
        return gui.add_text(label, "auto", hint=param.help + " (a number, or auto)")
    if param.kind is int:
        return gui.add_number(label, int(param.default), step=1, min=param.minimum, hint=param.help)
    return gui.add_number(label, float(param.default), step=0.001, hint=param.help)
