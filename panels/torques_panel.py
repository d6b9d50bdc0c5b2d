"""The torques' rows of the Compensation folder: *Compute torque feed-forward*, its progress
bar, and *Export τ CSV*. The callbacks only say what was clicked; the torques session works."""

from __future__ import annotations

from typing import Protocol

import viser

from panels.clicks import bind_clicks
from panels.compensation_folder import ORDER, CompensationFolder
from panels.quiet import set_value


class TorquesActions(Protocol):
    """What the torques' rows ask for."""

    def compute_torques(self, client: viser.ClientHandle | None) -> None: ...
    def export_torques(self, client: viser.ClientHandle | None) -> bytes | None: ...


class TorquesPanel:
    def __init__(self, parent: CompensationFolder, session: TorquesActions) -> None:
        gui = parent.gui
        self.status = parent.status
        with parent.folder:
            self.compute = gui.add_button(
                "Compute torque feed-forward", icon=viser.Icon.CALCULATOR, order=ORDER["compute"]
            )
            self.progress = gui.add_progress_bar(0.0, visible=False, order=ORDER["progress"])
            self.export_torques = gui.add_button(
                "Export τ CSV", icon=viser.Icon.DOWNLOAD, order=ORDER["export_torques"]
            )

        bind_clicks(
            (self.compute, session.compute_torques),
            (self.export_torques, session.export_torques),
        )

    def show_progress(self, fraction: float | None) -> None:
        self.progress.visible = fraction is not None
        if fraction is not None:
            set_value(self.progress, 100.0 * fraction)
