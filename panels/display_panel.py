"""Display panel: which layers of the robot are drawn, and the theme."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import viser

from panels.quiet import Quiet, set_value


@dataclasses.dataclass(frozen=True)
class DisplayFlags:
    visual: bool = True
    collision: bool = False
    frames: bool = False
    com: bool = True
    dark: bool = False
    """Dark mode (the theme, not a layer)."""


class DisplayPanel:
    """Owns the "Display" folder; calls `on_change(flags)` when a toggle moves."""

    def __init__(
        self,
        gui: viser.GuiApi,
        on_change: Callable[[DisplayFlags], None],
        on_frame: Callable[[viser.ClientHandle | None], None],
        on_lighting: Callable[[bool], None] = lambda _detailed: None,
    ) -> None:
        self._gui = gui
        self._quiet = Quiet()
        defaults = DisplayFlags()
        with gui.add_folder("Display", order=2, expand_by_default=False):
            self.visual = gui.add_checkbox("Visual meshes", defaults.visual)
            self.collision = gui.add_checkbox("Collision meshes", defaults.collision)
            self.frames = gui.add_checkbox("Link frames", defaults.frames)
            self.com = gui.add_checkbox("Centre of mass", defaults.com)
            self.frame = gui.add_button(
                "Frame robot",
                icon=viser.Icon.FOCUS_CENTERED,
                hint="Point this tab's camera at the robot",
            )
            self.dark = gui.add_checkbox("Dark mode", defaults.dark)
            self.detailed_lighting = gui.add_checkbox(
                "Detailed lighting",
                False,
                hint="Environment map and shadows, for a computer with a graphics card (without "
                "one the browser draws them in software, about a second per frame)",
            )
        for handle in (self.visual, self.collision, self.frames, self.com):
            handle.on_update(
                lambda _event: None if self._quiet.is_quiet() else on_change(self.flags())
            )
        self.frame.on_click(lambda event: on_frame(event.client))

        def on_dark(_event: object) -> None:
            self._theme()
            if not self._quiet.is_quiet():
                on_change(self.flags())

        self.dark.on_update(on_dark)
        self.detailed_lighting.on_update(
            lambda _event: on_lighting(bool(self.detailed_lighting.value))
        )

    def _theme(self) -> None:
        self._gui.configure_theme(
            control_width="large", dark_mode=bool(self.dark.value), show_logo=False
        )

    def flags(self) -> DisplayFlags:
        return DisplayFlags(
            self.visual.value,
            self.collision.value,
            self.frames.value,
            self.com.value,
            self.dark.value,
        )

    def show(self, flags: DisplayFlags) -> None:
        """Set every toggle to `flags` (a project's) without calling `on_change`."""
        with self._quiet.quietly():
            for name in ("visual", "collision", "frames", "com", "dark"):
                set_value(getattr(self, name), getattr(flags, name))
