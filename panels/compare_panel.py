"""Compare panel: the plan against ONE chosen comparison (the compensated command, a quick
estimate or a simulated run), and camera presets that show the robot from its front or side."""

from __future__ import annotations

from typing import Protocol

import viser

NOTHING = "nothing (the plan alone)"


class CompareActions(Protocol):
    """What the Compare panel asks for."""

    def compare_with(self, choice: str) -> None: ...
    def look_from(self, which: str, client: viser.ClientHandle | None) -> None: ...
    def set_error_colouring(self, on: bool) -> None: ...


class ComparePanel:
    """Owns the "Compare" folder."""

    def __init__(
        self, gui: viser.GuiApi, actions: CompareActions, choices: tuple[str, ...], initial: str
    ) -> None:
        with gui.add_folder("Compare", order=4.5, expand_by_default=True):
            self.choice = gui.add_dropdown(
                "Plan vs",
                (*choices, NOTHING),
                initial_value=initial,
                hint="Draw the plan and this one ghost only (the Ghosts toggles in the "
                "Compensation panel can add others)",
            )
            self.errors = gui.add_checkbox(
                "Colour by error",
                False,
                hint="Draw the compared ghost's links green (on the plan) to red (3 cm or more "
                "from the plan's link)",
            )
            self.front = gui.add_button(
                "Front view",
                icon=viser.Icon.USER,
                hint="This tab's camera looks at the robot's face",
            )
            self.side = gui.add_button(
                "Side view",
                icon=viser.Icon.ARROW_RIGHT,
                hint="This tab's camera looks at the robot's right side",
            )
        self.choice.on_update(lambda _: actions.compare_with(str(self.choice.value)))
        self.errors.on_update(lambda _: actions.set_error_colouring(bool(self.errors.value)))

        @self.front.on_click
        def _(event: viser.GuiEvent) -> None:
            actions.look_from("front", event.client)

        @self.side.on_click
        def _(event: viser.GuiEvent) -> None:
            actions.look_from("side", event.client)
