"""Undo and redo of pose and keyframe edits: one step per still moment (app.studio.undo).

The autosave thread's looks at the work record the steps (`record`); a drag is one step however
slowly it goes (no step is taken while a tab holds a drag handle). Undo and Redo put a step back
and say which edit they took back, in the Project panel's status and to the tab that asked.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Protocol

import viser

from app.core.motions.keyframes import Keyframe
from app.studio.notifier import Notifier
from app.studio.project_work import Marks
from app.studio.state import LoadedRobot, Pose, StudioState
from app.studio.undo import Move, Step, UndoHistory
from panels.project_panel import ProjectPanel


class HoldsKeyframes(Protocol):
    """The session holding the keyframe list (undo and redo put one back)."""

    def set_keyframes(self, keyframes: tuple[Keyframe, ...]) -> None: ...


class HoldsServoParts(Protocol):
    """The session holding the servo parts (undo and redo put a choice back)."""

    def restore_parts(self, choice: Any, coefficients: tuple[Any, Any]) -> None: ...


class UndoSteps:
    """The undo history of pose and keyframe edits, and going back and forth in it."""

    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        notifier: Notifier,
        panel: ProjectPanel,
        keyframes: HoldsKeyframes,
        dragging: Callable[[], bool],
        marks: Callable[[], Marks],
        servos: HoldsServoParts | None = None,
    ) -> None:
        """marks: the work now (`ProjectWork.marks`); servos: the session holding the servo
        parts, whose changes are steps too."""
        self._server, self._state, self._notifier, self._panel = server, state, notifier, panel
        self._keyframes = keyframes
        self._dragging = dragging
        self._marks = marks
        self._servos = servos
        self.history = UndoHistory()
        """Pose and keyframe edits, one step per still moment (app.studio.undo)."""
        self._lock = threading.Lock()
        """Taking a step and going to one never interleave."""

    def record(self, marks: Marks) -> None:
        """Take the work in `marks` as a step, unless a drag is under way."""
        loaded: LoadedRobot | None = marks["loaded"]
        pose: Pose | None = marks["pose"]
        if loaded is None or pose is None or self._dragging():
            return
        with self._lock:
            if self._state.pose is not pose:
                return  # it changed meanwhile (an undo): the next look takes it
            taken = self.history.record(_step(loaded, pose, marks))
        if taken:
            self._panel.show_undo(self.history.can_undo, self.history.can_redo)

    def undo(self, client: viser.ClientHandle | None = None) -> bool:
        """Go back one step of pose and keyframe edits, saying which; False if there is none."""
        said = ("Undid", "Redo puts it back.", "Nothing to undo")
        return self._go(self.history.undo(), said, client)

    def redo(self, client: viser.ClientHandle | None = None) -> bool:
        said = ("Redid", "Undo takes it back again.", "Nothing to redo")
        return self._go(self.history.redo(), said, client)

    def _go(
        self, move: Move | None, said: tuple[str, str, str], client: viser.ClientHandle | None
    ) -> bool:
        """Install `move`'s step; say "Undid: <edit>" (or that there was nothing) in the
        panel's status and to the tab that asked."""
        done, hint, nothing = said
        state = self._state
        applied = False
        if move is not None:
            step = move.step
            with self._lock, state.lock, self._server.atomic():
                if state.loaded is step.loaded:
                    self._keyframes.set_keyframes(step.keyframes)
                    if self._servos is not None and step.servo_parts is not state.work.parts:
                        self._servos.restore_parts(step.servo_parts, step.coefficients)
                    state.set_pose(
                        step.pose.q.copy(), step.pose.stance, "button", step.loaded.robot
                    )
                    assert state.loaded is not None and state.pose is not None
                    self.history.replace_current(_step(state.loaded, state.pose, self._marks()))
                    applied = True
        self._panel.show_undo(self.history.can_undo, self.history.can_redo)
        if move is None or not applied:
            self._panel.show_status(nothing)
            self._notifier.notify(nothing, "", client, "yellow")
        else:
            self._panel.show_status(f"{done}: {move.edit}")
            self._notifier.notify(f"{done}: {move.edit}", hint, client, "blue")
        return applied


def _step(loaded: LoadedRobot, pose: Pose, marks: Marks) -> Step:
    """The undo step of the work in `marks`: pose, keyframes, servo parts (and coefficients)."""
    return Step(
        loaded,
        pose,
        tuple(marks.get("keyframes", ())),
        servo_parts=marks.get("servo_parts"),
        coefficients=(marks.get("compensation"), marks.get("servo")),
    )
