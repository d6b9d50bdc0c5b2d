"""Pose panel: drag-to-pose options (CoM over support, stance foot) and pose buttons."""

from __future__ import annotations

from typing import TYPE_CHECKING

import viser

from panels.quiet import Quiet, set_value

if TYPE_CHECKING:
    from app.studio import Studio

STANCES = ("both", "left", "right")


class PosePanel:
    """Owns the "Pose" folder. Callbacks forward to the studio, which owns the state."""

    def __init__(self, gui: viser.GuiApi, studio: Studio) -> None:
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
            self.swap = gui.add_button("Swap stance foot", icon=viser.Icon.ARROWS_EXCHANGE)
            self.status = gui.add_markdown("")
        self._quiet = Quiet()
        self.com_in_support.on_update(
            lambda _: studio.set_com_in_support(self.com_in_support.value)
        )
        self.stance.on_update(
            lambda _: None if self._quiet.quiet else studio.set_stance(self.stance.value)
        )
        self.handles.on_update(lambda _: studio.set_handles_visible(self.handles.value))
        self.reset.on_click(lambda _: studio.reset_pose())
        self.ready.on_click(lambda _: studio.ready_pose())
        self.snap.on_click(lambda _: studio.snap_feet())
        self.swap.on_click(lambda _: studio.swap_stance())

    def show_stance(self, stance: str) -> None:
        """Reflect a stance changed by the studio (e.g. by a foot drag) without calling back."""
        with self._quiet.quietly():
            set_value(self.stance, stance)

    def show_status(self, text: str) -> None:
        self.status.content = text
