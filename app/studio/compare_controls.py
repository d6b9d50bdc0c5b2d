"""The Compare panel's actions: the plan and one chosen ghost drawn (by ticking the ghosts'
own toggles, so projects and the Compensation panel agree), and the acting tab's camera moved
to a preset (app.core.camera_presets). A simulation that just ran becomes the comparison."""

from __future__ import annotations

from collections.abc import Callable

import viser

from app.core.camera_presets import preset_view
from app.studio.signals import Signal
from app.studio.simulation_runner import SimulationRecord
from app.studio.state import StudioState
from panels.compare_panel import NOTHING, ComparePanel
from panels.quiet import set_value

SIMULATED_CHOICE = "sim_with"
"""What a simulation that just ended is compared as."""


class CompareControls:
    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        boxes: dict[str, viser.GuiCheckboxHandle],
        labels: dict[str, str],
        simulated: Signal[SimulationRecord],
        colour_by_error: Callable[[str | None], None],
        initial: str = "command",
    ) -> None:
        """boxes: ghost name -> its toggle; labels: ghost name -> its text; `simulated` is
        emitted with the state's simulation when it changes (a run that just ended: fresh, of
        origin "run");
        `colour_by_error(name)` colours that ghost's links by their error (None: stop)."""
        self._colour_by_error = colour_by_error
        self.error_ghost: str | None = None
        """The ghost drawn in error colours: the comparison, while *Colour by error* is on."""
        self._server, self._state, self._boxes = server, state, boxes
        self._names = {labels[name]: name for name in boxes if name != "planned"}
        self.panel = ComparePanel(server.gui, self, tuple(self._names), labels[initial])
        self._labels = labels
        simulated.connect(self._on_simulated)

    def compare_with(self, choice: str) -> None:
        """Tick the plan and the chosen ghost, untick the other comparisons."""
        chosen = self._names.get(choice)
        if chosen is None and choice != NOTHING:
            return
        self.set_error_colouring(bool(self.panel.errors.value), chosen)
        for name, box in self._boxes.items():
            wanted = name in ("planned", chosen)
            if box.value != wanted:
                set_value(box, wanted)  # its own callback shows or hides the ghost

    def set_error_colouring(self, on: bool, chosen: str | None = None) -> None:
        """Colour the comparison's links by their error from the plan (on), or not."""
        if chosen is None:
            chosen = self._names.get(str(self.panel.choice.value))
        self.error_ghost = chosen if on else None
        self._colour_by_error(self.error_ghost)

    def _on_simulated(self, record: SimulationRecord) -> None:
        if record.origin == "run" and not record.stale:
            set_value(self.panel.choice, self._labels[SIMULATED_CHOICE])

    def look_from(self, which: str, client: viser.ClientHandle | None) -> None:
        """Move the acting tab's camera (every tab's without one) to the preset."""
        with self._state.lock:
            robot, pose = self._state.robot, self._state.pose
        if robot is None or pose is None:
            return
        clients = [client] if client is not None else list(self._server.get_clients().values())
        for target in clients:
            position, look_at = preset_view(robot, pose.q, which, float(target.camera.fov))
            with target.atomic():
                target.camera.up_direction = (0.0, 0.0, 1.0)
                target.camera.position = tuple(position)
                target.camera.look_at = tuple(look_at)
