"""Plots panel: joint torques over time (the paper's Figs. 8 and 13), torso roll and pitch
with and without compensation (Figs. 6, 10, 12, …), and the command offsets q_cmd − q."""

from __future__ import annotations

import numpy as np
import viser
import viser.uplot as uplot

PALETTE = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
    "#393b79",
    "#637939",
)
SECONDS_AXIS = {"x": uplot.Scale(time=False)}
"""The x axis is seconds from the motion's start, not a date."""
ATTITUDE_SERIES = (
    ("roll planned", "#3c78e6", (4.0, 4.0)),
    ("pitch planned", "#3c78e6", ()),
    ("roll no comp.", "#dc3232", (4.0, 4.0)),
    ("pitch no comp.", "#dc3232", ()),
    ("roll comp.", "#f09614", (4.0, 4.0)),
    ("pitch comp.", "#f09614", ()),
)


class PlotsPanel:
    """Owns the "Plots" folder; `show_*` replace the data (series are rebuilt per motion)."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self._gui = gui
        self.folder = gui.add_folder("Plots", order=5, expand_by_default=False)
        with self.folder:
            self.info = gui.add_markdown("Compute the torques of a motion to see the plots.")
        self.torques: viser.GuiUplotHandle | None = None
        self.attitude: viser.GuiUplotHandle | None = None
        self.offsets: viser.GuiUplotHandle | None = None

    def show_torques(self, t: np.ndarray, joint_names: tuple[str, ...], tau_Nm: np.ndarray) -> None:
        self.torques = self._replace(self.torques, "Joint torque [N·m]", t, joint_names, tau_Nm.T)

    def show_offsets(
        self, t: np.ndarray, joint_names: tuple[str, ...], offsets_deg: np.ndarray
    ) -> None:
        self.offsets = self._replace(self.offsets, "q_cmd − q [°]", t, joint_names, offsets_deg.T)

    def show_attitude(self, t: np.ndarray, curves_deg: list[np.ndarray]) -> None:
        """curves: roll/pitch planned, without, with compensation [°], in ATTITUDE_SERIES order."""
        data = (t, *curves_deg)
        if self.attitude is not None:
            self.attitude.data = tuple(np.asarray(d, dtype=float) for d in data)
            return
        series = (
            uplot.Series(label="t [s]"),
            *(
                uplot.Series(label=label, stroke=colour, width=1.5, dash=dash)
                for label, colour, dash in ATTITUDE_SERIES
            ),
        )
        with self.folder:
            self.attitude = self._gui.add_uplot(
                tuple(np.asarray(d, dtype=float) for d in data),
                series,
                title="Torso roll and pitch [°]",
                aspect=1.6,
                scales=SECONDS_AXIS,
            )

    def _replace(self, handle, title: str, t: np.ndarray, names: tuple[str, ...], rows: np.ndarray):
        data = (np.asarray(t, dtype=float), *(np.asarray(row, dtype=float) for row in rows))
        if handle is not None and len(handle.data) == len(data):
            handle.data = data
            return handle
        if handle is not None:
            handle.remove()
        series = (
            uplot.Series(label="t [s]"),
            *(
                uplot.Series(label=name, stroke=PALETTE[i % len(PALETTE)], width=1.2)
                for i, name in enumerate(names)
            ),
        )
        with self.folder:
            return self._gui.add_uplot(data, series, title=title, aspect=1.6, scales=SECONDS_AXIS)

    def clear(self) -> None:
        for handle in (self.torques, self.attitude, self.offsets):
            if handle is not None:
                handle.remove()
        self.torques = self.attitude = self.offsets = None
        self.info.content = "Compute the torques of a motion to see the plots."
