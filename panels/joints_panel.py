"""Joints panel: a slider per actuated joint, grouped by limb, within the joint's limits.

Revolute joints are shown in degrees (what a servo datasheet uses), prismatic ones in
millimetres; the studio receives SI units.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import viser

from app.core.robot.model import ActuatedJoint, RobotModel
from panels.quiet import Quiet, set_value

LIMB_ORDER = ("Left leg", "Right leg", "Torso", "Left arm", "Right arm", "Head", "Other")


class JointsPanel:
    """Owns the "Joints" folder, rebuilt for each robot. Calls `on_change(index, value_si)`."""

    def __init__(
        self,
        gui: viser.GuiApi,
        robot: RobotModel,
        angles: np.ndarray,
        on_change: Callable[[int, float], None],
    ) -> None:
        self.sliders: dict[str, viser.GuiSliderHandle[float]] = {}
        self._scales: list[float] = []
        self._quiet = Quiet()
        self.folder = gui.add_folder("Joints", order=1)
        with self.folder:
            self.status = gui.add_markdown("")
            limbs = sorted({j.limb for j in robot.joints}, key=lambda limb: LIMB_ORDER.index(limb))
            for limb in limbs:
                with gui.add_folder(limb, expand_by_default=limb.endswith("leg")):
                    for i, joint in enumerate(robot.joints):
                        if joint.limb == limb:
                            self.sliders[joint.name] = self._slider(
                                gui, i, joint, angles[i], on_change
                            )

    def _slider(
        self,
        gui: viser.GuiApi,
        index: int,
        joint: ActuatedJoint,
        value: float,
        on_change: Callable[[int, float], None],
    ) -> viser.GuiSliderHandle[float]:
        scale = 1000.0 if joint.kind == "prismatic" else 180.0 / np.pi
        unit = "mm" if joint.kind == "prismatic" else "°"
        while len(self._scales) <= index:
            self._scales.append(1.0)
        self._scales[index] = scale
        lower, upper = joint.lower * scale, joint.upper * scale
        slider = gui.add_slider(
            joint.name,
            min=round(lower, 1),
            max=round(upper, 1),
            step=0.1,
            initial_value=float(np.clip(round(value * scale, 1), round(lower, 1), round(upper, 1))),
            hint=f"{joint.name} [{unit}], limits {lower:.1f} … {upper:.1f}",
        )

        @slider.on_update
        def _(_event: viser.GuiEvent) -> None:
            if not self._quiet.is_quiet():
                on_change(index, slider.value / scale)

        return slider

    def set_angles(self, robot: RobotModel, angles: np.ndarray) -> None:
        """Show new angles without firing on_change (e.g. after Reset pose)."""
        with self._quiet.quietly():
            for i, joint in enumerate(robot.joints):
                slider = self.sliders[joint.name]
                value = float(
                    np.clip(round(angles[i] * self._scales[i], 1), slider.min, slider.max)
                )
                set_value(slider, value)

    def show_status(self, text: str) -> None:
        self.status.content = text

    def remove(self) -> None:
        self.folder.remove()
