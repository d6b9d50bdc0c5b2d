"""Display panel: which layers of the robot are drawn."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import viser


@dataclasses.dataclass(frozen=True)
class DisplayFlags:
    visual: bool = True
    collision: bool = False
    frames: bool = False
    com: bool = True


class DisplayPanel:
    """Owns the "Display" folder; calls `on_change(flags)` when a toggle moves."""

    def __init__(self, gui: viser.GuiApi, on_change: Callable[[DisplayFlags], None]) -> None:
        defaults = DisplayFlags()
        with gui.add_folder("Display", order=2, expand_by_default=False):
            self.visual = gui.add_checkbox("Visual meshes", defaults.visual)
            self.collision = gui.add_checkbox("Collision meshes", defaults.collision)
            self.frames = gui.add_checkbox("Link frames", defaults.frames)
            self.com = gui.add_checkbox("Centre of mass", defaults.com)
        for handle in (self.visual, self.collision, self.frames, self.com):
            handle.on_update(lambda _event: on_change(self.flags()))

    def flags(self) -> DisplayFlags:
        return DisplayFlags(
            self.visual.value, self.collision.value, self.frames.value, self.com.value
        )
