"""Pose panel: drag-to-pose options (CoM over support, stance foot) and pose buttons."""

from __future__ import annotations

from typing import Protocol

import viser

from panels.quiet import Quiet, set_value

STANCES = ("both", "left", "right")


class PoseActions(Protocol):
    """What the Pose panel asks for."""

    def set_com_in_support(self, on: bool) -> None: ...
    def set_stance(self, stance: str) -> None: ...
    def set_handles_visible(self, visible: bool) -> None: ...
    def reset_pose(self) -> None: ...
    def ready_pose(self) -> None: ...
    def snap_feet(self) -> None: ...
    def swap_stance(self) -> None: ...


class PosePanel:
    """Owns the "Pose" folder. Callbacks only forward the request."""

    def __init__(self, gui: viser.GuiApi, actions: PoseActions) -> None:
        with gui.add_folder("Pose (drag the feet)", order=0.5):
            self.com_in_support = gui.add_checkbox(
                "Keep CoM over support",
                True,
                hint="The CoM's ground projection stays inside the support polygon while you drag",
            )
            self.stance = gui.add_dropdown(
                "Stance",
                STANCES,
                initial_value="both",
                hint="Feet held in place; dragging a foot makes the other one the stance foot",
            )
            self.handles = gui.add_checkbox("Show drag handles", True)
            self.reset = gui.add_button("Reset pose", icon=viser.Icon.REFRESH)
            self.ready = gui.add_button(
                "Ready pose (knees bent)",
                icon=viser.Icon.ARROW_DOWN,
                hint="Straight legs are singular: from them the pelvis cannot be lowered by dragging",
            )
            self.snap = gui.add_button("Snap feet to ground", icon=viser.Icon.ARROW_BAR_TO_DOWN)
            self.swap = gui.add_button(
                "Swap stance foot",
                icon=viser.Icon.ARROWS_EXCHANGE,
                disabled=True,  # the stance starts as "both": no one held foot to swap
                hint="The held foot becomes the free one; with Stance both there is none to swap",
            )
            self.status = gui.add_markdown("")
        self._quiet = Quiet()
        self.com_in_support.on_update(
            lambda _: (
                None
                if self._quiet.is_quiet()
                else actions.set_com_in_support(self.com_in_support.value)
            )
        )
        self.stance.on_update(
            lambda _: None if self._quiet.is_quiet() else actions.set_stance(self.stance.value)
        )
        self.handles.on_update(
            lambda _: (
                None if self._quiet.is_quiet() else actions.set_handles_visible(self.handles.value)
            )
        )
        self.reset.on_click(lambda _: actions.reset_pose())
        self.ready.on_click(lambda _: actions.ready_pose())
        self.snap.on_click(lambda _: actions.snap_feet())
        self.swap.on_click(lambda _: actions.swap_stance())

    def show_stance(self, stance: str) -> None:
        """Reflect a stance changed by the studio (e.g. by a foot drag) without calling back."""
        with self._quiet.quietly():
            set_value(self.stance, stance)
        # Enabled only when it can act: with both feet held a click did nothing, silently.
        # Set on a change only: this runs on every drag event, and each set is a message.
        if self.swap.disabled != (stance == "both"):
            self.swap.disabled = stance == "both"

    def show_toggles(self, handles: bool, keep_com: bool) -> None:
        """Reflect an opened project's Pose toggles without calling back."""
        with self._quiet.quietly():
            set_value(self.handles, handles)
            set_value(self.com_in_support, keep_com)

    def show_status(self, text: str) -> None:
        self.status.content = text
