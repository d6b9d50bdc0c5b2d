"""Joints panel: a slider per actuated joint, grouped by limb, within the joint's limits.

Revolute joints are shown in degrees (what a servo datasheet uses), prismatic ones in
millimetres; the callback receives SI units.

The sliders are a pool reused from robot to robot (relabelled, re-ranged, hidden when not
needed): removing a GUI element leaves a removal message in viser's replay buffer for good, so
rebuilding the folder on every load would make each new tab's start-up grow all day.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import viser

from app.core.robot.model import ActuatedJoint, RobotModel
from panels.quiet import Quiet, set_value

LIMB_ORDER = ("Left leg", "Right leg", "Torso", "Left arm", "Right arm", "Head", "Other")


class JointsPanel:
    """Owns the "Joints" folder. Calls `on_change(index, value_si)` for the shown robot."""

    def __init__(self, gui: viser.GuiApi, on_change: Callable[[int, float], None]) -> None:
        self._gui = gui
        self._on_change = on_change
        self._quiet = Quiet()
        self.sliders: dict[str, viser.GuiSliderHandle[float]] = {}
        """The shown robot's sliders by joint name."""
        self._pool: dict[str, list[viser.GuiSliderHandle[float]]] = {
            limb: [] for limb in LIMB_ORDER
        }
        self._binding: dict[int, tuple[int, float]] = {}
        """id(slider) -> (joint index, scale from SI to the shown unit)."""
        self._scales: list[float] = []
        self.folder = gui.add_folder("Joints", order=1)
        with self.folder:
            self.status = gui.add_markdown("")
            self._limbs = {
                limb: gui.add_folder(limb, expand_by_default=limb.endswith("leg"), visible=False)
                for limb in LIMB_ORDER
            }

    def show_robot(self, robot: RobotModel, angles: np.ndarray) -> None:
        """Sliders for this robot's joints at `angles` [rad or m], without calling back."""
        used = dict.fromkeys(LIMB_ORDER, 0)
        self.sliders, self._binding, self._scales = {}, {}, []
        with self._quiet.quietly():
            for i, joint in enumerate(robot.joints):
                limb = joint.limb if joint.limb in used else "Other"
                k = used[limb]
                used[limb] += 1
                if k == len(self._pool[limb]):
                    self._pool[limb].append(self._new_slider(limb))
                slider = self._pool[limb][k]
                scale = self._fit(slider, joint, angles[i])
                self._binding[id(slider)] = (i, scale)
                self._scales.append(scale)
                self.sliders[joint.name] = slider
            for limb, sliders in self._pool.items():
                for slider in sliders[used[limb] :]:
                    slider.visible = False
                self._limbs[limb].visible = used[limb] > 0
        self.status.content = ""

    def _new_slider(self, limb: str) -> viser.GuiSliderHandle[float]:
        with self._limbs[limb]:
            slider = self._gui.add_slider("joint", min=-1.0, max=1.0, step=0.1, initial_value=0.0)

        @slider.on_update
        def _(_event: viser.GuiEvent) -> None:
            binding = self._binding.get(id(slider))
            if binding is not None and not self._quiet.is_quiet():
                index, scale = binding
                self._on_change(index, float(slider.value) / scale)

        return slider

    @staticmethod
    def _fit(slider: viser.GuiSliderHandle[float], joint: ActuatedJoint, value: float) -> float:
        """Relabel and re-range a pooled slider for a joint; its scale (SI → shown unit)."""
        scale = 1000.0 if joint.kind == "prismatic" else 180.0 / np.pi
        unit = "mm" if joint.kind == "prismatic" else "°"
        lower, upper = round(joint.lower * scale, 1), round(joint.upper * scale, 1)
        slider.label = joint.name
        slider.hint = (
            f"{joint.name} [{unit}], limits {joint.lower * scale:.1f} … {joint.upper * scale:.1f}"
        )
        slider.min, slider.max = lower, upper
        set_value(slider, float(np.clip(round(value * scale, 1), lower, upper)))
        slider.visible = True
        return scale

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
