"""Undo / redo of pose, keyframe and servo part edits: a history of still moments.

A step is taken whenever the work has been still for a moment (the autosave thread's quiet
period), so a whole drag or a burst of slider moves is one step. Only edits count: a pose set
by playback or a timeline seek is not one. A new robot starts a new history (the steps of the
previous robot cannot be applied to it).

Each step carries the edit that made it, in words (`describe`: "left foot drag", "joint
l_knee +10.0°", "keyframe “pose 1” added"), worked out when the step is taken, so that *Undo*
and *Redo* can say what they undid or redid.
"""

from __future__ import annotations

import dataclasses
import math
import threading

import numpy as np

from app.core.motions.keyframes import Keyframe
from app.core.servo.choice import JointServo, ServoChoice
from app.studio.state import LoadedRobot, Pose

MAX_STEPS = 100
"""Oldest steps are dropped beyond this many."""
NOT_EDITS = ("playback", "timeline")
"""Pose origins that are not the user's edits."""
NAMED_JOINTS = 2
"""An edit moving more joints than this is said as "N joints"."""
DRAGGED = {"left": "left foot", "right": "right foot", "pelvis": "pelvis"}


@dataclasses.dataclass(frozen=True, eq=False)
class Step:
    loaded: LoadedRobot
    pose: Pose
    keyframes: tuple[Keyframe, ...]
    edit: str = ""
    """The edit that made this step from the one before, in words (set when it is taken)."""
    servo_parts: ServoChoice | None = None
    """The servo per joint (`StudioState.work.parts`), compared by identity."""
    coefficients: tuple[object, object] = (None, None)
    """The compensation coefficients and virtual servos with it: a part change taken back puts
    its joints' values back too."""

    def same_as(self, other: Step) -> bool:
        return _same_keyframes(self, other) and (
            self.loaded is other.loaded and self.pose is other.pose
        )


@dataclasses.dataclass(frozen=True)
class Move:
    """What *Undo* or *Redo* does: the step to install and the edit it takes back or redoes."""

    step: Step
    edit: str


class UndoHistory:
    """Past steps (the last is the current work) and undone ones to redo."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.past: list[Step] = []
        self.future: list[Step] = []

    def record(self, step: Step) -> bool:
        """Take `step` as the current work if it differs from the last; True if taken."""
        with self._lock:
            last = self.past[-1] if self.past else None
            if last is not None and last.loaded is not step.loaded:
                self.past, self.future = [], []  # another robot: a new history
                last = None
            if last is not None and last.same_as(step):
                return False
            if last is not None and step.pose.origin in NOT_EDITS:
                if _same_keyframes(last, step):
                    return False  # only playback moved: not an edit
                step = dataclasses.replace(step, pose=last.pose)
            if last is not None:
                step = dataclasses.replace(step, edit=describe(last, step))
            self.past.append(step)
            del self.past[:-MAX_STEPS]
            self.future.clear()
            return True

    def undo(self) -> Move | None:
        """The step to go back to and the edit undone; None if there is none."""
        with self._lock:
            if len(self.past) < 2:
                return None
            undone = self.past.pop()
            self.future.append(undone)
            return Move(self.past[-1], undone.edit)

    def redo(self) -> Move | None:
        """The step to go forward to and the edit redone; None if there is none."""
        with self._lock:
            if not self.future:
                return None
            step = self.future.pop()
            self.past.append(step)
            return Move(step, step.edit)

    def replace_current(self, step: Step) -> None:
        """After applying a step: the work as it now is (new objects, same values; the edit
        that made it stays)."""
        with self._lock:
            if self.past:
                self.past[-1] = dataclasses.replace(step, edit=self.past[-1].edit)

    @property
    def can_undo(self) -> bool:
        return len(self.past) >= 2

    @property
    def can_redo(self) -> bool:
        return bool(self.future)


def _same_keyframes(a: Step, b: Step) -> bool:
    """The same keyframes and servo parts (what playback never changes)."""
    return (
        a.servo_parts is b.servo_parts
        and len(a.keyframes) == len(b.keyframes)
        and all(x is y for x, y in zip(a.keyframes, b.keyframes, strict=True))
    )


def describe(before: Step, after: Step) -> str:
    """The edit that took the work from `before` to `after`, in a few words."""
    parts = [
        _keyframe_edit(before.keyframes, after.keyframes),
        _parts_edit(before.servo_parts, after.servo_parts),
        _pose_edit(before, after),
    ]
    return "; ".join(part for part in parts if part) or "no visible change"


def _keyframe_edit(before: tuple[Keyframe, ...], after: tuple[Keyframe, ...]) -> str:
    if len(before) == len(after) and all(a is b for a, b in zip(before, after, strict=True)):
        return ""
    added = [k for k in after if not any(k is b for b in before)]
    removed = [k for k in before if not any(k is a for a in after)]
    if added and not removed:
        return f"{_keyframes(added)} added"
    if removed and not added:
        return f"{_keyframes(removed)} deleted"
    if not added and not removed:
        return "keyframes reordered"
    return f"{_keyframes(added)} changed"


def _parts_edit(before: ServoChoice | None, after: ServoChoice | None) -> str:
    if before is after or after is None:
        return ""
    old = before.joints if before is not None else (None,) * len(after.joints)
    changed = [
        f"{name} {servo.servo or 'ideal servo'}"
        for name, servo, was in zip(after.joint_names, after.joints, old, strict=True)
        if servo != (was if was is not None else JointServo())
    ]
    files = before.user_servos if before is not None else ()
    if after.user_servos != files:
        gone = sorted({f.name for f in files} - {f.name for f in after.user_servos})
        if gone and len(after.user_servos) < len(files):
            return f"servo file {', '.join(gone)} removed"
        names = ", ".join(f.name for f in after.user_servos) or "none"
        return f"servo files ({names})"
    if not changed:
        was = before if before is not None else ServoChoice(after.joint_names, after.joints)
        if (was.stand_margin, was.max_sag_deg) != (after.stand_margin, after.max_sag_deg):
            return "sizing bounds"
        return "battery" if before is None or before.battery_Wh != after.battery_Wh else ""
    if len(changed) > NAMED_JOINTS:
        return f"servos of {len(changed)} joints"
    return "servo " + ", ".join(changed)


def _keyframes(keyframes: list[Keyframe]) -> str:
    if len(keyframes) == 1:
        return f"keyframe “{keyframes[0].name}”"
    return f"{len(keyframes)} keyframes"


def _pose_edit(before: Step, after: Step) -> str:
    a, b = before.pose, after.pose
    if a is b or (a.stance == b.stance and np.array_equal(a.q, b.q)):
        return ""
    dragged = b.dragged
    if dragged is not None:
        return f"{DRAGGED.get(dragged, dragged)} drag"
    robot = after.loaded.robot
    delta = robot.joint_angles(b.q) - robot.joint_angles(a.q)
    moved = [
        _joint_change(joint.name, joint.kind, float(d))
        for joint, d in zip(robot.joints, delta, strict=True)
        if abs(d) > 1e-6
    ]
    if b.origin == "load":
        return "pose loaded"
    if not moved:
        return f"stance {a.stance} → {b.stance}" if a.stance != b.stance else "robot moved"
    if len(moved) > NAMED_JOINTS:
        joints = f"{len(moved)} joints"
        return f"{joints} moved" if b.origin == "slider" else f"pose change ({joints})"
    joints = ", ".join(moved)
    if b.origin == "slider":
        return f"{'joint' if len(moved) == 1 else 'joints'} {joints}"
    return f"pose change ({joints})"


def _joint_change(name: str, kind: str, delta: float) -> str:
    if kind == "prismatic":
        return f"{name} {delta * 1000.0:+.1f} mm"
    return f"{name} {math.degrees(delta):+.1f}°"
