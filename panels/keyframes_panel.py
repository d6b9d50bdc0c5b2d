"""Keyframes panel: capture the current pose, reorder, delete, set durations, build a motion."""

from __future__ import annotations

from typing import Protocol

import viser

from app.core.motions.keyframes import Keyframe
from panels.quiet import set_value


class KeyframeActions(Protocol):
    """What the Keyframes panel asks for."""

    def capture(self, duration_s: float, client: viser.ClientHandle | None = None) -> None: ...
    def move(self, index: int, offset: int) -> None: ...
    def delete(self, index: int) -> None: ...
    def set_duration(
        self, index: int, duration_s: float, client: viser.ClientHandle | None = None
    ) -> None: ...
    def build(self, client: viser.ClientHandle | None) -> bool: ...
    def go_to(self, index: int) -> None: ...
    def replace(self, index: int) -> None: ...
    def rename(self, index: int, name: str, client: viser.ClientHandle | None = None) -> None: ...


class KeyframesPanel:
    """Owns the "Keyframes" folder. The motion session holds the keyframe list."""

    def __init__(self, gui: viser.GuiApi, actions: KeyframeActions) -> None:
        with gui.add_folder("Keyframes", order=2.6, expand_by_default=False):
            self.duration = gui.add_number(
                "Duration [s]",
                1.0,
                min=0.05,
                step=0.05,
                hint="Time to reach a keyframe from the previous one",
            )
            self.capture = gui.add_button("Capture pose", icon=viser.Icon.CAMERA)
            self.list = gui.add_markdown("No keyframes yet.")
            self.selected = gui.add_dropdown("Selected", ("—",), initial_value="—")
            with gui.add_folder("Edit selected", expand_by_default=True):
                self.go_to = gui.add_button(
                    "Go to", icon=viser.Icon.TARGET, hint="Show the robot in this keyframe's pose"
                )
                self.replace = gui.add_button(
                    "Replace with current pose",
                    icon=viser.Icon.REPLACE,
                    hint="Keep its name and duration, take the pose the robot has now",
                )
                self.name = gui.add_text("Name", "", hint="A new name for the selected keyframe")
                self.rename = gui.add_button("Rename", icon=viser.Icon.PENCIL)
                self.up = gui.add_button("Move up", icon=viser.Icon.ARROW_UP)
                self.down = gui.add_button("Move down", icon=viser.Icon.ARROW_DOWN)
                self.set_duration = gui.add_button("Set duration", icon=viser.Icon.CLOCK)
                self.delete = gui.add_button(
                    "Delete", icon=viser.Icon.TRASH, color="red", hint="Click twice to delete"
                )
            self.build = gui.add_button("Build motion", icon=viser.Icon.PLAYER_PLAY)
        self._edits = (
            self.selected,
            self.go_to,
            self.replace,
            self.rename,
            self.up,
            self.down,
            self.set_duration,
            self.delete,
        )
        """What acts on the selected keyframe: disabled while there is none (their clicks did
        nothing, or asked for a name for no keyframe)."""
        self._enable_edits(False)
        self._armed_delete = -1
        """The keyframe a first click on Delete armed (a second click deletes it)."""
        # A refusal (a bad duration, an empty name) is said in the tab that clicked.
        self.capture.on_click(lambda e: actions.capture(float(self.duration.value), e.client))
        self.go_to.on_click(lambda _: actions.go_to(self.index()))
        self.replace.on_click(lambda _: actions.replace(self.index()))
        self.rename.on_click(lambda e: actions.rename(self.index(), str(self.name.value), e.client))
        self.up.on_click(lambda _: actions.move(self.index(), -1))
        self.down.on_click(lambda _: actions.move(self.index(), +1))

        @self.delete.on_click
        def _(_event: viser.GuiEvent) -> None:
            index = self.index()
            if index < 0:
                return
            if self._armed_delete == index:
                self._disarm()
                actions.delete(index)
                return
            self._armed_delete = index
            self.delete.label = f"Click again to delete keyframe {index + 1}"

        self.set_duration.on_click(
            lambda e: actions.set_duration(self.index(), float(self.duration.value), e.client)
        )

        @self.build.on_click
        def _(event: viser.GuiEvent) -> None:
            actions.build(event.client)

    def index(self) -> int:
        """Index of the selected keyframe, -1 if none."""
        value = str(self.selected.value)
        number = value.split(".")[0]
        return int(number) - 1 if number.isdigit() else -1  # "—", or what a crafted client sent

    def _disarm(self) -> None:
        self._armed_delete = -1
        self.delete.label = "Delete"

    def _enable_edits(self, enabled: bool) -> None:
        for handle in self._edits:
            if handle.disabled == enabled:  # a set is a message to every tab: on a change only
                handle.disabled = not enabled

    def show(self, keyframes: list[Keyframe], selected: int) -> None:
        self._disarm()
        self._enable_edits(bool(keyframes))
        if not keyframes:
            self.list.content = "No keyframes yet."
            self.selected.options = ("—",)
            return
        rows = [
            f"{i + 1}. **{kf.name}** — "
            + ("start" if i == 0 else f"{kf.duration_s:.2f} s")
            + f", stance {kf.stance}"
            for i, kf in enumerate(keyframes)
        ]
        self.list.content = "  \n".join(rows)
        options = tuple(f"{i + 1}. {kf.name}" for i, kf in enumerate(keyframes))
        self.selected.options = options
        set_value(self.selected, options[max(0, min(selected, len(options) - 1))])
