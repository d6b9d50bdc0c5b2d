"""The coefficients' rows of the Compensation folder: the preset, the torque compensated (the
load τ or the servos' drive torque), the clearance sign, the
spring/clearance compensation coefficients of the selected joint, the virtual servos' true
compliance and backlash, *Export servo commands CSV* and the help.

Moving a slider re-predicts the motion (no torque recomputation): the callbacks only say which
value changed, as a typed edit (app.core.servo.edits); the compensation session recomputes.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
import viser

from app.core.servo.compensation import MAX_ABS_K_DEG_PER_NM, MAX_PHI_DEG
from app.core.servo.edits import (
    JointEdit,
    SetBacklash,
    SetCompliance,
    SetEnabled,
    SetK,
    SetPhi,
)
from app.core.servo.presets import PRESETS
from panels.clicks import bind_clicks
from panels.compensation_folder import ORDER, CompensationFolder
from panels.quiet import Quiet, set_value

K_SLIDER_DEG_PER_NM = 20.0
"""The k and compliance sliders span ±this [°/(N·m)]: a hand can tune values around the
paper's identifiable 1.3–1.6 at 0.01 per step; larger values (Table 3's −650) are typed."""


def _k_slider(gui: viser.GuiApi, label: str, hint: str) -> viser.GuiSliderHandle[float]:
    """A slider of a compliance k [°/(N·m)] (eq 7's, or the virtual servo's true one) over
    ±K_SLIDER_DEG_PER_NM, starting at 0."""
    return gui.add_slider(
        label,
        min=-K_SLIDER_DEG_PER_NM,
        max=K_SLIDER_DEG_PER_NM,
        step=0.01,
        initial_value=0.0,
        hint=hint,
    )


class CompensationActions(Protocol):
    """What the coefficients' rows ask for."""

    def export_commands(self, client: viser.ClientHandle | None) -> bytes | None: ...
    def apply_preset(self, key: str) -> None: ...
    def set_clearance_sign(self, sign: str) -> None: ...
    def set_compensated_torque(self, torque: str) -> None: ...
    def select_joint(self, joint: str) -> None: ...
    def edit(self, edit: JointEdit) -> None: ...


HELP = """**q_cmd = q + k·τ** (eq. 7): each servo sags like a spring under its load τ; the command
is offset by k·τ so that it lands on the plan. k is in °/(N·m) as in the paper's tables
(×π/180 for rad/(N·m)).
**+ φ·sign(·)** (eq. 23): a servo's gear play (dead band) adds φ in the direction the load
pushes. The paper takes the sign of q + k·τ; the *torque* variant takes the sign of τ,
which is the exact inverse of a dead band loaded by τ (see `app/core/servo/model.py`).
The servo model below is the virtual robot: its true compliance and backlash.
**Compensate: drive torque** puts the servo's whole drive torque τ + D·q̇ + J·q̈ in eq 7 (D its
back-EMF damping, J its rotor, as the simulation's servos have them): on the load τ alone a
moving joint lags its plan by c·D·q̇ and a walk comes up short. For a slow motion both agree."""

COMPENSATED_TORQUE_LABELS = {
    "drive": "drive torque τ + D·q̇ + J·q̈",
    "load": "load torque τ (eq 7 as printed)",
}
"""The *Compensate* dropdown's options, by app.core.simulation.drive's names."""


class CompensationPanel:
    """Owns the coefficients' rows; the per-joint controls edit the selected joint."""

    def __init__(self, parent: CompensationFolder, session: CompensationActions) -> None:
        gui = parent.gui
        self._session = session
        self._quiet = Quiet()
        self.status = parent.status
        with parent.folder:
            labels = tuple(preset.label for preset in PRESETS.values())
            self._preset_keys = {preset.label: key for key, preset in PRESETS.items()}
            self.preset = gui.add_dropdown(
                "Preset", labels, initial_value=labels[0], order=ORDER["preset"]
            )
            torques = tuple(COMPENSATED_TORQUE_LABELS.values())
            self.compensate = gui.add_dropdown(
                "Compensate",
                torques,
                initial_value=torques[0],
                order=ORDER["compensate"],
                hint="Which torque eq 7 multiplies: the servo's whole drive torque (its back-EMF "
                "damping and rotor, as simulated) or the load τ alone (a walk then lags its plan)",
            )
            self.clearance_sign = gui.add_dropdown(
                "Clearance sign",
                ("q + kτ (paper)", "τ (dead-band inverse)"),
                initial_value="q + kτ (paper)",
                order=ORDER["clearance"],
            )
            self.joint = gui.add_dropdown("Joint", ("—",), initial_value="—", order=ORDER["joint"])
            with gui.add_folder("Selected joint", order=ORDER["selected"]):
                self._add_joint_controls(gui)
            self.export_commands = gui.add_button(
                "Export servo commands CSV",
                icon=viser.Icon.DOWNLOAD,
                order=ORDER["export_commands"],
            )
            with gui.add_folder("Help", expand_by_default=False, order=ORDER["help"]):
                gui.add_markdown(HELP)

        bind_clicks((self.export_commands, session.export_commands))

        self.preset.on_update(
            lambda _: (
                None
                if self._quiet.is_quiet()
                else session.apply_preset(self._preset_keys[self.preset.value])
            )
        )
        self.compensate.on_update(
            lambda _: (
                None
                if self._quiet.is_quiet()
                else session.set_compensated_torque(self._torque_of(self.compensate.value))
            )
        )
        self.clearance_sign.on_update(
            lambda _: (
                None
                if self._quiet.is_quiet()
                else session.set_clearance_sign(
                    "torque" if self.clearance_sign.value.startswith("τ") else "command"
                )
            )
        )
        self.joint.on_update(
            lambda _: None if self._quiet.is_quiet() else session.select_joint(self.joint.value)
        )
        for handle, edit in (
            (self.enabled, SetEnabled),
            (self.k, SetK),
            (self.k_exact, SetK),
            (self.phi, SetPhi),
            (self.compliance, SetCompliance),
            (self.backlash, SetBacklash),
        ):
            handle.on_update(self._edit(edit, handle))

    def _add_joint_controls(self, gui: viser.GuiApi) -> None:
        self.enabled = gui.add_checkbox("Compensate", False)
        self.k = _k_slider(
            gui,
            "k [°/(N·m)]",
            "Spring compensation of eq 7: q_cmd = q + k·τ. Drag here, or type any value below",
        )
        self.k_exact = gui.add_number(
            "k, typed [°/(N·m)]",
            0.0,
            min=-MAX_ABS_K_DEG_PER_NM,
            max=MAX_ABS_K_DEG_PER_NM,
            step=0.001,
            hint="Any k (the paper's Table 3 has −650 and −1200)",
        )
        self.k_rad = gui.add_markdown("")
        self.phi = gui.add_slider(
            "φ [°]",
            min=0.0,
            max=min(15.0, MAX_PHI_DEG),
            step=0.1,
            initial_value=0.0,
            hint="Clearance compensation of eq 23: + φ·sign(·) (the paper found 8°)",
        )
        self.compliance = _k_slider(
            gui,
            "servo compliance [°/(N·m)]",
            "The virtual servo's true k: how far it sags per N·m",
        )
        self.backlash = gui.add_slider(
            "servo backlash [°]",
            min=0.0,
            max=20.0,
            step=0.1,
            initial_value=0.0,
            hint="Full width of the virtual servo's dead band",
        )

    def _edit(
        self, edit: type[JointEdit], handle: viser.GuiInputHandle
    ) -> Callable[[object], None]:
        def callback(_event: object) -> None:
            if not self._quiet.is_quiet():
                self._session.edit(edit(self.joint.value, handle.value))

        return callback

    @staticmethod
    def _torque_of(label: str) -> str:
        return next(k for k, v in COMPENSATED_TORQUE_LABELS.items() if v == label)

    def show_compensated_torque(self, torque: str) -> None:
        """Show which torque is compensated without calling back."""
        with self._quiet.quietly():
            set_value(self.compensate, COMPENSATED_TORQUE_LABELS[torque])

    def show_joints(self, joint_names: tuple[str, ...], selected: str) -> None:
        with self._quiet.quietly():
            self.joint.options = joint_names or ("—",)
            set_value(
                self.joint,
                selected if selected in joint_names else (joint_names[0] if joint_names else "—"),
            )

    def show_joint(
        self, enabled: bool, k: float, phi: float, compliance: float, backlash: float
    ) -> None:
        """Show the selected joint's values without calling back."""
        with self._quiet.quietly():
            set_value(self.enabled, enabled)
            set_value(self.k, float(np.clip(k, self.k.min, self.k.max)))
            set_value(self.k_exact, float(k))
            set_value(self.phi, float(np.clip(phi, self.phi.min, self.phi.max)))
            set_value(
                self.compliance,
                float(np.clip(compliance, self.compliance.min, self.compliance.max)),
            )
            set_value(self.backlash, float(np.clip(backlash, self.backlash.min, self.backlash.max)))
            self.k_rad.content = f"k = {np.deg2rad(k):.4g} rad/(N·m)"
