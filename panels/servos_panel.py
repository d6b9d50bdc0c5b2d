"""The "Servos" folder: a servo per joint (the ideal servo, or a catalogue servo with its
firmware settings; the user's own servo files added by upload, and removed), the stiffness K and compliance k = 1/K that follow beside the paper's k,
*Size servos* with its margin, stand margin and largest sag, the per-joint choice and its
violations, the battery, and a torque–speed plot of the selected joint (its planned points over
its servo's envelope).

Callbacks only say what changed; the servos session checks and recomputes.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
import viser
import viser.uplot as uplot

from app.core.servo.kp_sizing import MAX_SAG_DEG, MAX_STAND_MARGIN, STAND_MARGIN
from panels.quiet import Quiet, set_value
from panels.uplot_scale import scales_for

IDEAL_LABEL = "ideal servo"
SETTING_LABELS = {
    "kp": "kp (firmware)",
    "vin_V": "Supply [V]",
    "current_limit_A": "Current limit [A]",
    "dead_band_deg": "Dead band [°]",
    "stiffness_Nm_per_rad": "Stiffness K [N·m/rad]",
}
"""The firmware settings' rows, by JointServo field (the stiffness row in place of kp, for a
part without a kp law)."""
STATED = "stiffness_Nm_per_rad"
NO_PLOT = "Size servos to draw the selected joint's planned torque–speed points here."
NO_FILE = "(none added)"
CHOICE_LABELS = {
    "stand_margin": "Stand margin",
    "max_sag_deg": "Largest sag [°]",
    "battery_Wh": "Battery [Wh]",
}
"""The rows of values kept with the whole choice (not a joint's), by ServoChoice field."""


class ServosActions(Protocol):
    """What the Servos folder asks for."""

    def select_joint(self, joint: str) -> None: ...
    def select_servo(self, key: str) -> None: ...
    def set_setting(self, name: str, value: float) -> None: ...
    def set_choice_value(
        self, name: str, value: float, client: viser.ClientHandle | None
    ) -> None: ...
    def add_servo_file(
        self, name: str, content: bytes, client: viser.ClientHandle | None
    ) -> bool: ...
    def remove_servo_file(self, name: str, client: viser.ClientHandle | None) -> bool: ...
    def size_servos(self, client: viser.ClientHandle | None) -> None: ...


class ServosPanel:
    def __init__(self, gui: viser.GuiApi, session: ServosActions) -> None:
        self._gui = gui
        self._quiet = Quiet()
        self._labels: dict[str, str] = {IDEAL_LABEL: ""}
        """Dropdown label → catalogue key ("" for the ideal servo)."""
        self.plot: viser.GuiUplotHandle | None = None
        self.folder = gui.add_folder("Servos", order=4.2, expand_by_default=False)
        with self.folder:
            self.status = gui.add_markdown(
                "Each joint runs the **ideal servo** (the Compensation panel's virtual one) "
                "until you pick a catalogue servo or press *Size servos*."
            )
            self.joint = gui.add_dropdown("Servo of joint", ("—",), initial_value="—")
            self.servo = gui.add_dropdown("Servo", (IDEAL_LABEL,), initial_value=IDEAL_LABEL)
            self.not_offered = gui.add_markdown("")
            self.upload = gui.add_upload_button(
                "Add servo file (.toml)",
                icon=viser.Icon.UPLOAD,
                mime_type=".toml",
                hint="Your own servos: a TOML file with the catalogue's fields (one record or "
                "[[servo]] tables, every figure with its source; at most 64 KiB). Kept with the "
                "project; a file of the same name replaces the earlier one",
            )
            self.user_file = gui.add_dropdown(
                "Servo file", (NO_FILE,), initial_value=NO_FILE, disabled=True
            )
            self.remove_file = gui.add_button(
                "Remove servo file",
                icon=viser.Icon.TRASH,
                disabled=True,
                hint="Takes the selected file's servos out of those offered; joints on them go "
                "back to the ideal servo (named here). Undo puts them back",
            )
            self.settings = {
                name: gui.add_number(label, 0.0, min=0.0, step=0.01, disabled=True)
                for name, label in SETTING_LABELS.items()
            }
            self.settings[STATED].visible = False
            self.stiffness = gui.add_markdown("")
            self.margin = gui.add_slider(
                "Margin", min=0.0, max=1.0, step=0.05, initial_value=0.3,
                hint="Headroom asked of every planned point and of the RMS torque (0.3: 30 %)",
            )  # fmt: skip
            self.stand_margin = gui.add_number(
                CHOICE_LABELS["stand_margin"], STAND_MARGIN, step=0.05,
                hint="Each leg servo's kp is chosen stiff enough that the robot still stands "
                "with every leg servo (1 + this)× softer (the stand check's K*; 0.5: 1.5× K*, "
                f"0: just stands; at most {MAX_STAND_MARGIN:g}); the CLI's size --stand-margin",
            )  # fmt: skip
            self.max_sag = gui.add_number(
                CHOICE_LABELS["max_sag_deg"], MAX_SAG_DEG, step=0.1,
                hint="The largest quasi-static sag (load + the servo's friction)/K a joint may "
                "have in any motion, which its kp keeps (degrees in (0, 90]); the CLI's size "
                "--max-sag-deg",
            )  # fmt: skip
            self.size = gui.add_button(
                "Size servos",
                icon=viser.Icon.RULER_MEASURE,
                hint="Per joint, the lightest catalogue servo the simulation can run whose "
                "torque–speed envelope holds the motion's torques and the planned gaits",
            )
            self.sizing = gui.add_markdown("")
            self.battery = gui.add_number(
                "Battery [Wh]", 0.0, min=0.0, max=1.0e5, step=1.0,
                hint="A pack's usable energy: the simulation says how many minutes of the "
                "motion it lasts (0: not said)",
            )  # fmt: skip
            self.plot_note = gui.add_markdown(NO_PLOT)
        self.choice_values = {
            "stand_margin": self.stand_margin,
            "max_sag_deg": self.max_sag,
            "battery_Wh": self.battery,
        }
        """The inputs of CHOICE_LABELS, by ServoChoice field."""
        self._bind(session)

    def _bind(self, session: ServosActions) -> None:
        """Each input's callback: say what changed to `session` (not while the panel shows)."""

        @self.joint.on_update
        def _(_event: viser.GuiEvent) -> None:
            if not self._quiet.is_quiet() and self.joint.value != "—":
                session.select_joint(str(self.joint.value))

        @self.servo.on_update
        def _(_event: viser.GuiEvent) -> None:
            if not self._quiet.is_quiet():
                session.select_servo(self._labels.get(str(self.servo.value), ""))

        for name, handle in self.settings.items():

            def changed(_event: viser.GuiEvent, name: str = name, handle=handle) -> None:
                if not self._quiet.is_quiet():
                    session.set_setting(name, float(handle.value))

            handle.on_update(changed)

        @self.upload.on_upload
        def _(event: viser.GuiEvent) -> None:
            uploaded = self.upload.value
            session.add_servo_file(uploaded.name, uploaded.content, event.client)

        @self.remove_file.on_click
        def _(event: viser.GuiEvent) -> None:
            name = str(self.user_file.value)
            if name != NO_FILE:
                session.remove_servo_file(name, event.client)

        for name, handle in self.choice_values.items():

            def changed_value(event: viser.GuiEvent, name: str = name, handle=handle) -> None:
                if not self._quiet.is_quiet():
                    session.set_choice_value(name, float(handle.value), event.client)

            handle.on_update(changed_value)

        @self.size.on_click
        def _(event: viser.GuiEvent) -> None:
            session.size_servos(event.client)

    def show_catalogue(self, servos: Sequence[tuple[str, str]], not_offered: str = "") -> None:
        """The servos offered: (key, label) each, after the ideal servo; `not_offered` says
        which the simulation cannot run, and why."""
        self._labels = {IDEAL_LABEL: "", **{label: key for key, label in servos}}
        with self._quiet.quietly():
            self.servo.options = tuple(self._labels)
        self.not_offered.content = not_offered

    def show_user_files(self, names: Sequence[str]) -> None:
        """The user's servo files kept (the last added selected); Remove is off without one."""
        with self._quiet.quietly():
            self.user_file.options = tuple(names) or (NO_FILE,)
            set_value(self.user_file, names[-1] if names else NO_FILE)
        self.user_file.disabled = self.remove_file.disabled = not names

    def show_joints(self, joints: Sequence[str], selected: str) -> None:
        with self._quiet.quietly():
            self.joint.options = tuple(joints) or ("—",)
            set_value(self.joint, selected or "—")

    def show_joint(
        self, servo: str, settings: dict[str, float], stiffness: str, values: dict[str, float]
    ) -> None:
        """The selected joint's servo (key, "" ideal), its settings (the values in use; a
        stiffness shows its row in place of kp's) and the stiffness line; `values`: the whole choice's (CHOICE_LABELS' fields)."""
        label = next((lab for lab, key in self._labels.items() if key == servo), IDEAL_LABEL)
        with self._quiet.quietly():
            set_value(self.servo, label)
            for name, handle in self.settings.items():
                handle.disabled = not servo
                handle.visible = (name == STATED) == (STATED in settings)  # K or kp
                set_value(handle, float(settings.get(name, 0.0)))
            for name, handle in self.choice_values.items():
                set_value(handle, float(values[name]))
        self.stiffness.content = stiffness

    def show_sizing(self, running: bool) -> None:
        self.size.disabled = running

    def show_plot(
        self,
        title: str,
        speed_rad_s: np.ndarray,
        torque_Nm: np.ndarray,
        envelope: tuple[float, float, float] | None,
        note: str,
    ) -> None:
        """Planned points (ω, τ) over the envelope (stall torque, no-load speed, torque
        limit) of the joint's servo; None: no servo to draw."""
        self.plot_note.content = note
        if self.plot is not None:
            self.plot.remove()
            self.plot = None
        if len(speed_rad_s) == 0:
            return
        w_edge = max(float(np.max(np.abs(speed_rad_s))), 1e-3)
        lines: list[np.ndarray] = []
        if envelope is not None:
            stall, no_load, limit = envelope
            w_edge = max(w_edge, 1.05 * no_load)
        grid = np.linspace(-w_edge, w_edge, 81)
        x = np.concatenate([grid, speed_rad_s])
        order = np.argsort(x, kind="stable")
        x = x[order]
        nan_points = np.full(len(speed_rad_s), np.nan)
        if envelope is not None:
            damping = stall / no_load
            upper = np.minimum(stall - damping * grid, limit)
            lower = np.maximum(-stall - damping * grid, -limit)
            for curve in (upper, lower):
                lines.append(np.concatenate([curve, nan_points])[order])
        points = np.concatenate([np.full(len(grid), np.nan), torque_Nm])[order]
        series = [uplot.Series(label="speed [rad/s]")]
        if envelope is not None:
            for label in ("envelope (drive)", "envelope (brake)"):
                series.append(uplot.Series(label=label, stroke="#1f77b4", width=1.5, spanGaps=True))
        series.append(
            uplot.Series(
                label="planned points",
                stroke="#d62728",
                width=0.0,
                points=uplot.Series_Points(show=True, size=4.0, fill="#d62728"),
            )
        )
        with self.folder:
            self.plot = self._gui.add_uplot(
                (x, *lines, points),
                tuple(series),
                title=title,
                aspect=1.4,
                scales=scales_for(x, *lines, points),
            )
