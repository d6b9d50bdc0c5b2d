"""Plots panel: joint torques over time (the paper's Figs. 8 and 13), torso roll and pitch
planned / without / with compensation (Figs. 6, 10, 12, …), the command offsets q_cmd − q, and
after a simulation the load on the feet the plan has in the air (the verdict's "leans on the
lifted foot" and swing-foot scuffs, against the lean threshold).

A dropdown picks which joints the torque and offset plots show (a whole leg, or one joint):
twelve lines in one small plot cannot be read. Roll and pitch get a plot each, one colour per
motion (the legend names them). Every plot has a vertical line at the playback time
(app.core.time_cursor). For a larger view, viser's expand button (top right of a plot, on
hover) opens one plot in a dialog, and *Wide plots* moves them all into a wide window docked
at the left of the page (its edge can be dragged).
"""

from __future__ import annotations

import threading

import numpy as np
import viser
import viser.uplot as uplot

from app.core.projects.display import ALL_JOINTS, plot_choices
from app.core.time_cursor import with_time_cursor

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
SCALES = {"x": uplot.Scale(time=False), "cursor": uplot.Scale(auto=False, range=(0.0, 1.0))}
"""The x axis is seconds from the motion's start, not a date; the time cursor's column is drawn
on a scale of its own, fixed to [0, 1] and without an axis (see app.core.time_cursor)."""
CURSOR_SERIES = uplot.Series(label="playback time", stroke="#222222", width=1.0, scale="cursor")
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
THRESHOLD_SERIES = ("lean threshold", "#777777", (2.0, 3.0))
"""The lifted-foot load plot's dashed line at the verdict's lean threshold."""
ALL = ALL_JOINTS
HINT = "Hover a plot and click its ⤢ button (top right) to see it large."
WIDE_PX = 600
"""Width of the *Wide plots* window [CSS px]: with the control panel (~400), a 1280-px screen
keeps a third of its width for the 3D view."""
ASPECT = {False: 1.6, True: 2.4}
"""Width / height of a plot in the control panel and in the wide window."""


SeriesSpec = tuple[tuple[str, str, float, tuple[float, ...]], ...]
"""(label, colour, width, dash) of each curve of a plot."""


class PlotsPanel:
    """Owns the "Plots" folder; `show_*` replace the data (series are rebuilt when the set of
    curves changes), `show_time` moves the time cursor of every plot."""

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
            self.wide = gui.add_checkbox(
                "Wide plots",
                False,
                hint="Show the plots in a wide window docked at the left (drag its edge to resize)",
            )
            self.hint = gui.add_markdown(HINT)
        self.window: viser.PanelHandle | None = None
        """The wide window, while *Wide plots* is on."""
        self._tab: viser.GuiTabHandle | None = None
        self._handles: dict[str, viser.GuiUplotHandle] = {}
        self._curves: dict[str, tuple[str, SeriesSpec, np.ndarray, np.ndarray]] = {}
        """Plot key -> (title, its series, t [s] (T,), curves (C, T)) as last shown."""
        self._joint_data: dict[str, tuple[np.ndarray, tuple[str, ...], np.ndarray]] = {}
        self.time_s: float | None = None
        """Where the time cursor stands [s] (None: no cursor)."""
        self._lock = threading.RLock()
        """The cursor moves from a timer thread while edits redraw from viser's pool."""
        self.joints.on_update(lambda _: self._redraw_joints())
        self.wide.on_update(lambda _: self.set_wide(bool(self.wide.value)))

    # --- the plots, by key -----------------------------------------------------------------------

    @property
    def torques(self) -> viser.GuiUplotHandle | None:
        return self._handles.get("torques")

    @property
    def roll(self) -> viser.GuiUplotHandle | None:
        return self._handles.get("roll")

    @property
    def pitch(self) -> viser.GuiUplotHandle | None:
        return self._handles.get("pitch")

    @property
    def offsets(self) -> viser.GuiUplotHandle | None:
        return self._handles.get("offsets")

    @property
    def attitude(self) -> viser.GuiUplotHandle | None:
        """The roll plot (kept for callers that check a plot exists)."""
        return self.roll

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
        options = plot_choices(joint_names)
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
            series = tuple((names[i], PALETTE[i % len(PALETTE)], 1.2, ()) for i in chosen)
            self._draw(key, title, t, series, np.asarray(values)[:, chosen].T)

    # --- attitude ------------------------------------------------------------------------------

    def show_attitude(
        self,
        t: np.ndarray,
        roll_deg: list[np.ndarray],
        pitch_deg: list[np.ndarray],
        labels: tuple[tuple[str, str, tuple[float, ...]], ...] = ATTITUDE_SERIES,
    ) -> None:
        """Roll and pitch [°] of each motion in `labels` (planned, without, with, …)."""
        series = tuple((label, colour, 1.5, dash) for label, colour, dash in labels)
        for which, curves in (("roll", roll_deg), ("pitch", pitch_deg)):
            self._draw(which, f"Torso {which} [°]", t, series, np.vstack(curves))

    # --- the simulation's lifted-foot load ----------------------------------------------------

    def show_lifted_load(
        self, t: np.ndarray, load_percent: list[np.ndarray], threshold_percent: float, title: str
    ) -> None:
        """Load on the feet planned in the air [% of the weight] of each simulated run
        (SIMULATED_SERIES order) and the lean threshold; `title` names the lean spans."""
        series = tuple(
            (label, colour, 1.5, dash)
            for label, colour, dash in (*SIMULATED_SERIES, THRESHOLD_SERIES)
        )
        threshold = np.full(len(t), threshold_percent)
        self._draw("lifted", title, t, series, np.vstack([*load_percent, threshold]))

    @property
    def lifted(self) -> viser.GuiUplotHandle | None:
        return self._handles.get("lifted")

    def drop(self, key: str) -> None:
        """Remove plot `key` (e.g. the lifted-foot load when no simulation is of the motion)."""
        with self._lock:
            self._curves.pop(key, None)
            handle = self._handles.pop(key, None)
            if handle is not None:
                handle.remove()

    # --- where the plots are ------------------------------------------------------------------

    def set_wide(self, wide: bool) -> None:
        """Move every plot into the wide window (True) or back into the folder."""
        with self._lock:
            if wide == (self.window is not None):
                return
            old = self.window
            if wide:
                self.window = self._gui.add_panel()
                self._tab = self.window.add_tab("Plots", icon=viser.Icon.CHART_LINE)
                self.window.dock_left()
                self.window.set_width(WIDE_PX)
            else:
                self.window, self._tab = None, None
            for key, (title, series, t, rows) in list(self._curves.items()):
                self._handles.pop(key).remove()
                self._draw_locked(key, title, t, series, rows)
            if old is not None:
                old.remove()

    # --- drawing -------------------------------------------------------------------------------

    def show_time(self, time_s: float | None) -> None:
        """Move every plot's time cursor to `time_s` [s] (None hides it)."""
        with self._lock:
            self.time_s = time_s
            for key, (_title, _series, t, rows) in self._curves.items():
                handle = self._handles.get(key)
                if handle is not None:
                    handle.data = self._data(t, rows)

    def _data(self, t: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, ...]:
        cursor = with_time_cursor(t, rows, self.time_s)
        return (cursor.x, *cursor.rows, cursor.cursor)

    def _draw(self, key: str, title: str, t: np.ndarray, series: SeriesSpec, rows) -> None:
        """Show curves `rows` (C, T) over `t` in plot `key`: new data in place when the curves
        are the same ones, else the plot is rebuilt."""
        with self._lock:
            self._draw_locked(key, title, t, series, rows)

    def _draw_locked(
        self, key: str, title: str, t: np.ndarray, series: SeriesSpec, rows: np.ndarray
    ) -> None:
        t, rows = np.asarray(t, dtype=float), np.atleast_2d(np.asarray(rows, dtype=float))
        previous = self._curves.get(key)
        self._curves[key] = (title, series, t, rows)
        handle = self._handles.get(key)
        data = self._data(t, rows)
        if handle is not None and previous is not None and previous[:2] == (title, series):
            handle.data = data
            return
        if handle is not None:
            self._handles.pop(key).remove()
        uplot_series = (
            uplot.Series(label="t [s]"),
            *(
                uplot.Series(label=label, stroke=colour, width=width, dash=dash)
                for label, colour, width, dash in series
            ),
            CURSOR_SERIES,
        )
        wide = self._tab is not None
        with self._tab if self._tab is not None else self.folder:
            self._handles[key] = self._gui.add_uplot(
                data, uplot_series, title=title, aspect=ASPECT[wide], scales=SCALES
            )

    def clear(self) -> None:
        with self._lock:
            for handle in self._handles.values():
                handle.remove()
            self._handles, self._curves, self._joint_data = {}, {}, {}
        self.info.content = "Compute the torques of a motion to see the plots."
