"""Servos in the studio: a servo per joint (the ideal servo, or a catalogue servo and its
firmware settings), kept in the state (`StudioState.work.parts`) with the coefficients and
virtual servos that follow from it (app.core.servo.choice.with_parts: the part's compliance
1/K and dead band for the quick estimate, eq 7's k = 1/K); *Size servos* against the current
motion's torques and the planned gaits (app.core.servo.sizing_work) on a named thread, with the
stand margin and largest sag typed beside it (kept in the choice, so in the project) and each
joint's kp chosen on the fit its part runs (m1, or m6 where the choice says so). A part rated
by a continuous point (Dynamixel-P: no kp law) takes a stiffness K [N·m/rad] in place of kp:
picked by hand it starts at the stiffness the joint had; sized, at the one the sizing states.

A joint put back on the ideal servo keeps the compliance and dead band it had (the Compensation
panel edits them; *Undo* puts the earlier servo and values back).
"""

from __future__ import annotations

import dataclasses
import logging
import threading
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
import viser

from app.core.collocation.result import GaitResult
from app.core.errors import StudioError
from app.core.servo.catalogue import ServoRecord
from app.core.servo.choice import (
    IDEAL,
    JointServo,
    ServoChoice,
    check_sizing_bounds,
    choice_parts,
    ideal_choice,
    offered_catalogue,
    runnable,
    sized_servo,
    sizing_fits,
    take_joints,
    with_parts,
)
from app.core.servo.kp_sizing import size_with_kp
from app.core.servo.parts import ServoPartsError
from app.core.servo.sizing import Sizing
from app.core.servo.sizing_work import Work, gait_work, motion_work
from app.core.servo.user_files import UserServoFile, adding, records, user_file
from app.studio.notifier import Notifier
from app.studio.servo_joint import joint_line, sizing_plot, stiffness_now
from app.studio.servo_parts import (
    added_text,
    catalogue,
    not_offered_text,
    removed_text,
    sizing_text,
    users_of_files,
    without_file,
)
from app.studio.signals import Signal
from app.studio.state import LoadedRobot, StudioState
from app.studio.work import Coefficients
from panels.servos_panel import ServosPanel

log = logging.getLogger(__name__)


class ServosSession:
    """Owns the Servos folder and the sizing thread."""

    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        notifier: Notifier,
        gaits: Callable[[], dict[str, GaitResult | None]] = dict,
    ) -> None:
        """gaits(): the planned gaits to size against too (label → gait or None)."""
        self._state, self._notifier, self._gaits = state, notifier, gaits
        self.records: dict[str, ServoRecord] = runnable(catalogue())
        """The servos offered: those the simulation can run (a motor model and firmware, or a
        continuous point: a stated stiffness), the user's own files' included."""
        self._user_files: tuple[UserServoFile, ...] = ()
        """The user's servo files, kept across robots (the state's parts hold them too)."""
        self.panel = ServosPanel(server.gui, self)
        self._show_catalogue(())
        self._selected = ""
        self.last: tuple[Sizing, dict[str, Work]] | None = None
        """The last sizing and the works it was made against."""
        self._thread: threading.Thread | None = None
        self.sized: Signal[Sizing | str] = Signal("servos_sized")
        """Emitted when *Size servos* ends: its sizing, or why it could not size."""
        state.on_robot.connect(self._on_robot)
        state.on_motion.connect(lambda _motion: self._forget_sizing())
        state.work.on_coefficients.connect(self._on_coefficients)
        state.work.on_parts.connect(self._on_parts)

    # --- state ----------------------------------------------------------------------------

    def choice(self) -> ServoChoice | None:
        """The current servo per joint (every joint ideal when the state holds none)."""
        with self._state.lock:
            robot = self._state.robot
            if robot is None:
                return None
            parts = self._state.work.parts
            if parts is not None:
                return parts
            return replace(ideal_choice(robot.joint_names), user_servos=self._user_files)

    def _on_robot(self, loaded: LoadedRobot) -> None:
        names = loaded.robot.joint_names
        self._selected = names[0] if names else ""
        self.last = None
        self.panel.show_joints(names, self._selected)
        self.panel.sizing.content = ""
        self._show_selected()

    def _on_parts(self, choice: ServoChoice) -> None:
        if choice.user_servos != self._user_files:
            self._show_catalogue(choice.user_servos)
        self._show_selected()

    def _show_catalogue(self, files: tuple[UserServoFile, ...]) -> None:
        """Offer the catalogue's servos the simulation can run and the user's `files`'."""
        self._user_files = files
        offered = offered_catalogue(ServoChoice((), (), user_servos=files), catalogue())
        self.records = runnable(offered)
        self.panel.show_catalogue(
            [(k, f"{k} — {r.maker} {r.model}") for k, r in sorted(self.records.items())],
            not_offered_text(offered),
        )
        self.panel.show_user_files([f.name for f in files])

    def _on_coefficients(self, _coefficients: Coefficients) -> None:
        self._show_selected()

    def _forget_sizing(self) -> None:
        self.last = None
        self._show_selected()

    # --- the choice (ServosActions) -----------------------------------------------------------

    def select_joint(self, joint: str) -> None:
        self._selected = joint
        self._show_selected()

    def select_servo(self, key: str) -> None:
        choice = self.choice()
        if choice is None or self._selected not in choice.joint_names:
            return
        record = self.records.get(key)
        stiffness = None
        if record is not None and not record.kp_law:  # no kp: the stiffness the joint has now
            with self._state.lock:
                stiffness = stiffness_now(self._state.work.coefficients, self._selected)
        servo = JointServo(key, stiffness_Nm_per_rad=stiffness)
        self._apply(choice.with_joint(self._selected, servo), "parts")

    def set_setting(self, name: str, value: float) -> None:
        choice = self.choice()
        if choice is None or self._selected not in choice.joint_names:
            return
        joint = choice.joint(self._selected)
        if joint.servo == IDEAL:
            return
        changed = dataclasses.replace(joint, **{name: float(value)})  # type: ignore[arg-type]
        self._apply(choice.with_joint(self._selected, changed), "parts")

    def set_choice_value(
        self, name: str, value: float, client: viser.ClientHandle | None = None
    ) -> None:
        """A value of the whole choice, kept with the parts (and the project): the battery
        pack [Wh] (0: not said), or *Size servos*' stand margin or largest sag [°] (the CLI's
        checks; refused with one line, the last good value kept and shown again)."""
        with self._state.lock:
            choice = self.choice()
            if choice is None:
                return
            if name == "battery_Wh":
                self._apply(replace(choice, battery_Wh=None if value == 0.0 else value), "parts")
                return
            bounds = {"stand_margin": choice.stand_margin, "max_sag_deg": choice.max_sag_deg}
            if name not in bounds:
                raise ValueError(f"the servo choice has no value {name!r}")  # a panel's bug
            bounds[name] = value
            changed = replace(
                choice, stand_margin=bounds["stand_margin"], max_sag_deg=bounds["max_sag_deg"]
            )
            try:
                check_sizing_bounds(changed, "Size servos")
            except ServoPartsError as error:
                self._fail("Sizing bound refused", str(error), client)
                self._show_selected()
                return
            self._state.work.set_sizing_bounds(changed)

    def add_servo_file(
        self, name: str, content: bytes, client: viser.ClientHandle | None = None
    ) -> bool:
        """A user's servo TOML added to those offered (a file of the same name replaced),
        kept with the parts and so with the project; refused with one line, nothing lost."""
        choice = self.choice()
        if choice is None:
            self._fail("Servo file not added", "load a robot first", client)
            return False
        try:
            file = user_file(name, content)
            files = adding(choice.user_servos, file)
            offered = offered_catalogue(replace(choice, user_servos=files), catalogue())
        except StudioError as error:
            self._fail("Servo file refused", str(error), client)
            return False
        if not self._apply(replace(choice, user_servos=files), "parts", client):
            return False
        self.panel.status.content = added_text(file, offered)
        return True

    def remove_servo_file(self, name: str, client: viser.ClientHandle | None = None) -> bool:
        """The user's servo file `name` taken out of those offered; the joints on its servos
        go back to the ideal servo (keeping the compliance they had) and are named in the
        folder and to the tab. *Undo* puts the file and their servos back."""
        choice = self.choice()
        if choice is None:
            return False
        try:
            file = next((f for f in choice.user_servos if f.name == name), None)
            keys = [r.key for r in records(file)] if file is not None else []
            changed, reset = without_file(choice, name)
        except StudioError as error:
            self._fail("Servo file not removed", str(error), client)
            return False
        if not self._apply(changed, "parts", client):
            return False
        said = removed_text(name, keys, reset)
        self.panel.status.content = said
        self._notifier.notify("Servo file removed", said.replace("**", ""), client, "blue")
        return True

    def restore_parts(self, choice: ServoChoice | None, coefficients: tuple[Any, Any]) -> None:
        """Undo / redo: `choice` again (None: every joint ideal), the joints it changes taking
        their coefficients and virtual servo from `coefficients` (params, servo) of that step."""
        with self._state.lock:
            robot, current = self._state.robot, self._state.work.coefficients
            now = self.choice()
            if robot is None or current is None or now is None:
                return
            target = choice if choice is not None else ideal_choice(robot.joint_names)
            if target.joint_names != robot.joint_names:
                return
            changed = [
                name
                for name, a, b in zip(target.joint_names, target.joints, now.joints, strict=True)
                if a != b
            ]
            params, servo = take_joints(current.params, current.servo, coefficients, changed)
            try:
                self._state.work.set_parts(target, params, servo, "undo")
            except StudioError as error:
                self._fail("Servo parts not restored", str(error), None)

    def _apply(
        self, choice: ServoChoice, origin: str, client: viser.ClientHandle | None = None
    ) -> bool:
        """Check `choice` and install it with the coefficients that follow; a refused one
        leaves the last good one (one line in the folder and to the tabs)."""
        with self._state.lock:
            robot, current = self._state.robot, self._state.work.coefficients
            if robot is None or current is None:
                return False
            now = self.choice()
            changed = [
                name
                for name, a, b in zip(choice.joint_names, choice.joints, now.joints, strict=True)
                if a != b
            ] if now is not None else None  # fmt: skip
            if changed is not None and now is not None and choice.user_servos != now.user_servos:
                changed += users_of_files(choice, changed)  # a replaced file's k follows
            try:
                parts = choice_parts(choice, robot.joint_names, catalogue())
                params, servo = with_parts(current.params, current.servo, parts, changed)
                self._state.work.set_parts(choice, params, servo, origin)
            except StudioError as error:
                self._fail("Servo refused", str(error), client)
                self._show_selected()
                return False
        return True

    # --- display ----------------------------------------------------------------------------

    def _show_selected(self) -> None:
        """The selected joint's servo, settings and line, and its points of the last sizing
        (app/studio/servo_joint.py)."""
        choice = self.choice()
        with self._state.lock:
            coefficients = self._state.work.coefficients
        if choice is None or self._selected not in choice.joint_names:
            return
        servo = choice.joint(self._selected).servo
        settings, line = joint_line(choice, self._selected, coefficients)
        values = {
            "stand_margin": choice.stand_margin,
            "max_sag_deg": choice.max_sag_deg,
            "battery_Wh": choice.battery_Wh or 0.0,
        }
        self.panel.show_joint(servo, settings, line, values)
        self.panel.show_plot(*sizing_plot(self.last, self._selected, servo, self.records))

    # --- sizing ----------------------------------------------------------------------------

    def size_servos(self, client: viser.ClientHandle | None = None) -> None:
        """Size every joint against the current motion's torques and the planned gaits, on a
        thread; the end is announced by `sized`."""
        if self._thread is not None and self._thread.is_alive():
            return
        margin = float(self.panel.margin.value)
        self.panel.show_sizing(True)
        self.panel.sizing.content = "⏳ Sizing…"
        self._thread = threading.Thread(
            target=self._size, args=(margin, client), name="size-servos", daemon=True
        )
        self._thread.start()

    def _size(self, margin: float, client: viser.ClientHandle | None) -> None:
        try:
            self._size_now(margin, client)
        except Exception as error:  # a bug: said in the folder, logged, the button back
            log.exception("sizing servos")
            self.panel.sizing.content = f"⚠️ {type(error).__name__}: {error}"
            self._fail("Sizing failed", f"{type(error).__name__}: {error}", client)
            self.sized.emit(str(error))
        finally:
            self.panel.show_sizing(False)

    def _size_now(self, margin: float, client: viser.ClientHandle | None) -> None:
        with self._state.lock:
            state = self._state
            robot, trajectory, torques = state.robot, state.trajectory, state.work.torques
        if robot is None:
            return
        works: dict[str, Work] = {}
        duration = 0.0
        try:
            if trajectory is not None and torques is not None:
                works[trajectory.name] = motion_work(
                    robot,
                    trajectory,
                    np.nan_to_num(torques.tau_Nm),
                    [int(k) for k in torques.infeasible_samples],
                )
                duration = trajectory.duration
            for label, gait in self._gaits().items():
                work = None if gait is None else gait_work(robot, gait)
                if work is not None and gait is not None:
                    works[label] = work
                    duration = duration or gait.duration_s
            asked = self.choice()
            if asked is None:
                return
            sizing = size_with_kp(
                robot, works, max(duration, 1e-3), self.records, margin, trajectory=trajectory,
                stand_margin=asked.stand_margin, max_sag_deg=asked.max_sag_deg,
                fits=sizing_fits(asked),
            )  # fmt: skip
        except StudioError as error:
            self.panel.sizing.content = f"⚠️ {error}"
            self._fail("Cannot size the servos", str(error), client)
            self.sized.emit(str(error))
            return
        choice = self.choice()
        if choice is None or self._state.robot is not robot:
            return
        for joint in sizing.joints:
            choice = choice.with_joint(joint.joint, sized_servo(joint))
        self.last = (sizing, works)
        total = len(offered_catalogue(choice, catalogue()))
        self.panel.sizing.content = sizing_text(sizing, works, self.records, total)
        if self._apply(choice, "sizing"):
            self._show_selected()
        self.sized.emit(sizing)

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        self.panel.status.content = f"⚠️ {body}"
        self._notifier.error(title, body, client)
