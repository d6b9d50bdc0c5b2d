"""The "Ghosts" sub-folder of the Compensation folder: one toggle per ghost, each in its
ghost's colour (panels.swatches: no separate legend), and the simulated walk's landings."""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import viser

from panels.compensation_folder import ORDER, CompensationFolder
from panels.swatches import add_swatches


class GhostsActions(Protocol):
    def set_ghost_visible(self, name: str, visible: bool) -> None: ...
    def show_landings(self, visible: bool) -> None: ...


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
            self.landings = gui.add_checkbox(
                "simulated footsteps vs planned",
                initial_value=True,
                hint="For a simulated walk: where each foot landed (small spheres in the "
                "simulated ghost's colour) against where the plan put it (white), joined by a line",
            )
        for name, checkbox in self.ghosts.items():
            checkbox.on_update(self._ghost(name, checkbox))
        self.landings.on_update(lambda _event: session.show_landings(bool(self.landings.value)))

    def _ghost(self, name: str, checkbox: viser.GuiCheckboxHandle) -> Callable[[object], None]:
        def callback(_event: object) -> None:
            self._session.set_ghost_visible(name, checkbox.value)

        return callback
