"""The "Simulation (MuJoCo)" sub-folder of the Compensation folder: the stand check (can the
robot stand on these servos, before any motion), *Simulate without / with compensation*,
*Cancel simulation*, the optional balance feedback (a checkbox, its gains shown), a progress
bar and the verdict with how far a walk went."""

from __future__ import annotations

from typing import Protocol

import viser

from panels.compensation_folder import ORDER, CompensationFolder
from panels.quiet import set_value

NO_VERDICT = "Compute the torques, then simulate: the verdict appears here."
BALANCE_FEEDBACK = "Balance feedback (IMU → ankles/hips)"


class SimulationActions(Protocol):
    """What the Simulation rows ask for."""

    def simulate(self, client: viser.ClientHandle | None) -> None: ...
    def cancel_simulation(self) -> None: ...
    def set_balance_feedback(self, on: bool) -> None: ...


class SimulationPanel:
    def __init__(
        self, parent: CompensationFolder, session: SimulationActions, balance_gains: str
    ) -> None:
        """`balance_gains`: the balance feedback's gains in one line (shown under its box)."""
        gui = parent.gui
        self.status = parent.status
        """The Compensation folder's status line."""
        with (
            parent.folder,
            gui.add_folder(
                "Simulation (MuJoCo)", expand_by_default=True, order=ORDER["simulation"]
            ),
        ):
            self.stand = gui.add_markdown("")
            """The stand check's line (app.studio.stand_checker)."""
            self.simulate = gui.add_button(
                "Simulate without / with compensation",
                icon=viser.Icon.PLAYER_PLAY,
                hint="Runs the plan and the compensated commands on a physics model of this "
                "robot with the virtual servos below (compliance, dead band, torque and speed "
                "limits), each from the first pose settled on the floor",
            )
            self.cancel_simulation = gui.add_button(
                "Cancel simulation", icon=viser.Icon.PLAYER_STOP, color="red", disabled=True
            )
            self.balance = gui.add_checkbox(
                BALANCE_FEEDBACK,
                False,
                hint="Simulate with a servo firmware's balance feedback: every 10 ms the torso's "
                "roll/pitch error (IMU) adds offsets to the stance legs' ankle and hip commands; "
                "the verdicts then say 'with balance feedback'",
            )
            self.balance_gains = gui.add_markdown(f"Balance feedback gains: {balance_gains}")
            self.progress = gui.add_progress_bar(0.0, visible=False)
            self.verdict = gui.add_markdown(NO_VERDICT)

        @self.simulate.on_click
        def _(event: viser.GuiEvent) -> None:
            session.simulate(event.client)

        @self.cancel_simulation.on_click
        def _(_event: viser.GuiEvent) -> None:
            session.cancel_simulation()

        @self.balance.on_update
        def _(_event: viser.GuiEvent) -> None:
            session.set_balance_feedback(bool(self.balance.value))

    def show_simulating(self, fraction: float | None) -> None:
        """A simulation runs (fraction done), or none (None)."""
        self.progress.visible = fraction is not None
        self.cancel_simulation.disabled = fraction is None
        self.simulate.disabled = fraction is not None
        if fraction is not None:
            set_value(self.progress, 100.0 * min(max(fraction, 0.0), 1.0))
