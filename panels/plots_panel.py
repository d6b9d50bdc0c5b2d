"""Plots panel: joint torques over time (the paper's Figs. 8 and 13), torso roll and pitch
planned / without / with compensation (Figs. 6, 10, 12, …), and the command offsets q_cmd − q.

A dropdown picks which joints the torque and offset plots show (a whole leg, or one joint):
twelve lines in one small plot cannot be read. Roll and pitch get a plot each, one colour per
motion (the legend names them).
"""

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
    ("planned", "#3c78e6", ()),
    ("no comp. (quick estimate)", "#dc3232", (4.0, 4.0)),
    ("comp. (quick estimate)", "#f09614", (4.0, 4.0)),
)
"""(label, colour, dash) of the attitude curves, in the order `show_attitude` takes them."""
SIMULATED_SERIES = (
    ("no comp. (simulated)", "#9632c8", ()),
    ("comp. (simulated)", "#14aaaa", ()),
)
"""Added after ATTITUDE_SERIES when a simulation of the motion exists."""
ALL = "all joints"


class PlotsPanel:
    """Owns the "Plots" folder; `show_*` replace the data (series are rebuilt when the set of
    curves changes)."""

    def __init__(self, gui: viser.GuiApi) -> None:
        self._gui = gui
        self.folder = gui.add_folder("Plots", order=5, expand_by_default=False)
        with self.folder:
            self.info = gui.add_markdown("Compute the torques of a motion to see the plots.")
            self.joints = gui.add_dropdown(
                "Joints shown",
                (ALL,),
                initial_value=ALL,
                hint="Which joints the torque and offset plots draw",
            )
        self.torques: viser.GuiUplotHandle | None = None
        self.roll: viser.GuiUplotHandle | None = None
        self.pitch: viser.GuiUplotHandle | None = None
        self.offsets: viser.GuiUplotHandle | None = None
        self._joint_data: dict[str, tuple[np.ndarray, tuple[str, ...], np.ndarray]] = {}
        self._labels: dict[int, tuple[str, ...]] = {}
        """id(plot) -> the joints it draws, to update data in place when they are the same."""
        self.joints.on_update(lambda _: self._redraw_joints())

    # --- joints: torques and offsets ----------------------------------------------------------

    def show_torques(self, t: np.ndarray, joint_names: tuple[str, ...], tau_Nm: np.ndarray) -> None:
        self._set_joint_choices(joint_names)
        self._joint_data["torques"] = (t, joint_names, tau_Nm)
        self._redraw_joints(("torques",))

    def show_offsets(
        self, t: np.ndarray, joint_names: tuple[str, ...], offsets_deg: np.ndarray
    ) -> None:
        self._joint_data["offsets"] = (t, joint_names, offsets_deg)
        self._redraw_joints(("offsets",))

    def _set_joint_choices(self, joint_names: tuple[str, ...]) -> None:
        legs = [side for side in ("left", "right") if any(n.startswith(side) for n in joint_names)]
        options = (ALL, *(f"{side} leg" for side in legs), *joint_names)
        if tuple(self.joints.options) != options:
            self.joints.options = options

    def _selected(self, joint_names: tuple[str, ...]) -> list[int]:
        choice = self.joints.value
        if choice == ALL or choice not in (*joint_names, "left leg", "right leg"):
            return list(range(len(joint_names)))
        if choice.endswith(" leg"):
            side = choice.split()[0]
            return [i for i, n in enumerate(joint_names) if n.startswith(side)]
        return [joint_names.index(choice)]

    def _redraw_joints(self, keys: tuple[str, ...] = ("torques", "offsets")) -> None:
        for key, title in (("torques", "Joint torque [N·m]"), ("offsets", "q_cmd − q [°]")):
            if key not in keys or key not in self._joint_data:
                continue
            t, names, values = self._joint_data[key]
            chosen = self._selected(names)
            handle = self.torques if key == "torques" else self.offsets
            handle = self._replace(
                handle, title, t, [names[i] for i in chosen], values[:, chosen].T, chosen
            )
            if key == "torques":
                self.torques = handle
            else:
                self.offsets = handle

    # --- attitude ------------------------------------------------------------------------------

    def show_attitude(
        self,
        t: np.ndarray,
        roll_deg: list[np.ndarray],
        pitch_deg: list[np.ndarray],
        labels: tuple[tuple[str, str, tuple[float, ...]], ...] = ATTITUDE_SERIES,
    ) -> None:
        """Roll and pitch [°] of each motion in `labels` (planned, without, with, …)."""
        for which, curves in (("roll", roll_deg), ("pitch", pitch_deg)):
            data = (np.asarray(t, dtype=float), *(np.asarray(c, dtype=float) for c in curves))
            handle = self.roll if which == "roll" else self.pitch
            if handle is not None and len(handle.data) == len(data):
                handle.data = data
                continue
            if handle is not None:
                handle.remove()
            series = (
                uplot.Series(label="t [s]"),
                *(
                    uplot.Series(label=label, stroke=colour, width=1.5, dash=dash)
                    for label, colour, dash in labels
                ),
            )
            with self.folder:
                handle = self._gui.add_uplot(
                    data, series, title=f"Torso {which} [°]", aspect=1.6, scales=SECONDS_AXIS
                )
            if which == "roll":
                self.roll = handle
            else:
                self.pitch = handle

    @property
    def attitude(self) -> viser.GuiUplotHandle | None:
        """The roll plot (kept for callers that check a plot exists)."""
        return self.roll

    def _replace(
        self,
        handle,
        title: str,
        t: np.ndarray,
        names: list[str],
        rows: np.ndarray,
        colours: list[int],
    ):
        data = (np.asarray(t, dtype=float), *(np.asarray(row, dtype=float) for row in rows))
        if handle is not None and self._labels.get(id(handle)) == tuple(names):
            handle.data = data
            return handle
        if handle is not None:
            handle.remove()
        series = (
            uplot.Series(label="t [s]"),
            *(
                uplot.Series(label=name, stroke=PALETTE[c % len(PALETTE)], width=1.2)
                for name, c in zip(names, colours, strict=True)
            ),
        )
        with self.folder:
            handle = self._gui.add_uplot(data, series, title=title, aspect=1.6, scales=SECONDS_AXIS)
        self._labels[id(handle)] = tuple(names)
        return handle

    def clear(self) -> None:
        for handle in (self.torques, self.roll, self.pitch, self.offsets):
            if handle is not None:
                handle.remove()
        self.torques = self.roll = self.pitch = self.offsets = None
        self._joint_data = {}
        self.info.content = "Compute the torques of a motion to see the plots."
