"""Undo / redo of pose and keyframe edits: a history of still moments.

A step is taken whenever the work has been still for a moment (the autosave thread's quiet
period), so a whole drag or a burst of slider moves is one step. Only edits count: a pose set
by playback or a timeline seek is not one. A new robot starts a new history (the steps of the
previous robot cannot be applied to it).
"""

from __future__ import annotations

import dataclasses
import threading

from app.core.motions.keyframes import Keyframe
from app.studio.state import LoadedRobot, Pose

MAX_STEPS = 100
"""Oldest steps are dropped beyond this many."""
NOT_EDITS = ("playback", "timeline")
"""Pose origins that are not the user's edits."""


@dataclasses.dataclass(frozen=True, eq=False)
class Step:
    loaded: LoadedRobot
    pose: Pose
    keyframes: tuple[Keyframe, ...]

    def same_as(self, other: Step) -> bool:
        return (
            self.loaded is other.loaded
            and self.pose is other.pose
            and len(self.keyframes) == len(other.keyframes)
            and all(a is b for a, b in zip(self.keyframes, other.keyframes, strict=True))
        )


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
            self.past.append(step)
            del self.past[:-MAX_STEPS]
            self.future.clear()
            return True

    def undo(self) -> Step | None:
        """The step to go back to, None if there is none."""
        with self._lock:
            if len(self.past) < 2:
                return None
            self.future.append(self.past.pop())
            return self.past[-1]

    def redo(self) -> Step | None:
        with self._lock:
            if not self.future:
                return None
            step = self.future.pop()
            self.past.append(step)
            return step

    def replace_current(self, step: Step) -> None:
        """After applying a step: the work as it now is (new objects, same values)."""
        with self._lock:
            if self.past:
                self.past[-1] = step

    @property
    def can_undo(self) -> bool:
        return len(self.past) >= 2

    @property
    def can_redo(self) -> bool:
        return bool(self.future)


def _same_keyframes(a: Step, b: Step) -> bool:
    return len(a.keyframes) == len(b.keyframes) and all(
        x is y for x, y in zip(a.keyframes, b.keyframes, strict=True)
    )
