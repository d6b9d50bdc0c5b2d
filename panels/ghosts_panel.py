"""The "Ghosts" sub-folder of the Compensation folder: one toggle per ghost, each in its
ghost's colour (panels.swatches: no separate legend)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import viser

from panels.compensation_folder import ORDER, CompensationFolder
from panels.swatches import add_swatches


class GhostsActions(Protocol):
    def set_ghost_visible(self, name: str, visible: bool) -> None: ...


class GhostsPanel:
    def __init__(
        self,
        parent: CompensationFolder,
        session: GhostsActions,
        ghosts: dict[str, tuple[tuple[int, int, int], str]],
        shown: tuple[str, ...],
    ) -> None:
        """ghosts: name -> (colour, legend text) of each ghost; shown: the ones ticked first."""
        gui = parent.gui
        self._session = session
        with parent.folder, gui.add_folder("Ghosts", expand_by_default=True, order=ORDER["ghosts"]):
            self.ghosts = {
                name: gui.add_checkbox(text, name in shown, hint=f"Draw the {text} ghost")
                for name, (_rgb, text) in ghosts.items()
            }
            add_swatches(gui, self.ghosts, {name: rgb for name, (rgb, _) in ghosts.items()})
        for name, checkbox in self.ghosts.items():
            checkbox.on_update(self._ghost(name, checkbox))

    def _ghost(self, name: str, checkbox: viser.GuiCheckboxHandle) -> Callable[[object], None]:
        def callback(_event: object) -> None:
            self._session.set_ghost_visible(name, checkbox.value)

        return callback
