"""The "Compensation" folder: one folder in the GUI, built by three sessions' panels.

Top to bottom: the torques (button, bar, the folder's status line), the coefficients (preset,
the torque compensated, clearance sign, joint, the selected joint's values), the simulation's
sub-folder, the ghosts' toggles, the two exports and the help. Each panel adds its own rows inside `folder` at the
places `ORDER` gives them, whichever panel is built first.
"""

from __future__ import annotations

import viser

ORDER = {
    "compute": 1.0,
    "progress": 1.1,
    "status": 1.2,
    "preset": 2.0,
    "compensate": 2.05,
    "clearance": 2.1,
    "joint": 2.2,
    "selected": 2.3,
    "simulation": 3.0,
    "ghosts": 4.0,
    "export_commands": 5.0,
    "export_torques": 5.1,
    "help": 6.0,
}
"""Each row's place in the folder."""


class CompensationFolder:
    """The folder and its status line, which the torques and the coefficients both write."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self.gui = gui
        self.folder = gui.add_folder("Compensation", order=4, expand_by_default=False)
        with self.folder:
            self.status = gui.add_markdown(
                "Generate or build a motion, then compute its torques.", order=ORDER["status"]
            )
