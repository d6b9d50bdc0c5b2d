"""Motions in the studio: the papers' built-in motions, keyframes captured from poses, motion
files in and out.

Heavy work (IK at every sample) runs in the calling callback's thread, outside the state lock,
on the robot that was loaded when it started; the result is only installed if that robot is
still the loaded one. Keyframes belong to their robot and go when another is loaded.
"""

from __future__ import annotations

import dataclasses
import io
import math
import tempfile
import threading
from pathlib import Path
from typing import Any, Literal, cast

import numpy as np
import viser

from app.core.errors import StudioError
from app.core.motions.csv_files import (
    read_roban_motion_csv,
    read_trajectory_csv,
    write_trajectory_csv,
)
from app.core.motions.keyframes import Keyframe, MotionResult, capture_keyframe, interpolate
from app.core.motions.library import run_motion
from app.core.projects.project import Project
from app.core.robot.model import RobotModel
from app.studio.admission import Admission, Busy
from app.studio.file_names import file_slug
from app.studio.notifier import Notifier
from app.studio.state import LoadedRobot, Stance, StudioState
from panels.keyframes_panel import KeyframesPanel
from panels.motions_panel import MotionsPanel

MAX_MOTION_FILE_BYTES = 50 * 1024 * 1024
MAX_NAME = 60
"""Longest keyframe name (characters)."""
MAX_KEYFRAME_S = 60.0
"""Longest time between two keyframes [s]."""


class MotionSession:
    """Owns the Motions and Keyframes panels and the keyframe list."""

    def __init__(self, server: viser.ViserServer, state: StudioState, notifier: Notifier) -> None:
        self._state, self._notifier = state, notifier
        self.panel = MotionsPanel(server.gui, self)
        self.keyframes_panel = KeyframesPanel(server.gui, self)
        self.keyframes: list[Keyframe] = []
        self._lock = threading.Lock()
        """Guards the keyframe list (the state lock guards the pose)."""
        self._admission = Admission(per_client=1, total=2)
        """Motions take seconds of IK: one per tab, two in all, at a time."""
        state.on_robot.connect(self._on_robot)

    # --- projects (HoldsWork) -------------------------------------------------------------------

    def snapshot(self) -> dict[str, object]:
        with self._lock:
            return {"keyframes": tuple(self.keyframes)}

    def restore(self, project: Project) -> None:
        with self._lock:
            self.keyframes = list(project.keyframes)
            self._show(len(self.keyframes) - 1)

    def set_keyframes(self, keyframes: tuple[Keyframe, ...]) -> None:
        """Put a keyframe list back (undo / redo)."""
        with self._lock:
            self.keyframes = list(keyframes)
            self._show(len(self.keyframes) - 1)

    def _on_robot(self, _loaded: LoadedRobot) -> None:
        with self._lock:
            self.keyframes = []
            self._show(-1)

    # --- built-in motions (MotionActions) -----------------------------------------------------

    def generate(
        self, name: str, params: dict[str, object], client: viser.ClientHandle | None = None
    ) -> bool:
        robot = self._state.robot
        if robot is None:
            return False
        try:
            with self._admission.admit(client.client_id if client is not None else None):
                progress = self._notifier.progress(
                    f"Generating {name}", "IK at every sample…", client
                )
                try:
                    result = run_motion(robot, name, **cast(dict[str, Any], params))
                finally:
                    progress.done()
        except Busy as busy:
            return self._fail("Not now", str(busy), client)
        except StudioError as error:
            return self._fail(f"Cannot generate {name}", str(error), client)
        return self._install(robot, result, client)

    # --- keyframes (KeyframeActions) ------------------------------------------------------------

    def capture(self, duration_s: float, client: viser.ClientHandle | None = None) -> None:
        if not _valid_duration(duration_s):
            self._fail("Keyframe refused", _duration_message(duration_s), client)
            return
        current = self._current_pose()
        if current is None:
            return
        robot, q, stance = current
        with self._lock:
            keyframe = capture_keyframe(
                robot, q, stance, f"pose {len(self.keyframes) + 1}", duration_s
            )
            self.keyframes.append(keyframe)
            self._show(len(self.keyframes) - 1)

    def _current_pose(self) -> tuple[RobotModel, np.ndarray, Stance] | None:
        """The robot and a copy of its pose (configuration, stance); None before a robot."""
        with self._state.lock:
            robot, pose = self._state.robot, self._state.pose
            if robot is None or pose is None:
                return None
            return robot, pose.q.copy(), pose.stance

    def move(self, index: int, offset: int) -> None:
        with self._lock:
            target = index + offset
            if 0 <= index < len(self.keyframes) and 0 <= target < len(self.keyframes):
                self.keyframes[index], self.keyframes[target] = (
                    self.keyframes[target],
                    self.keyframes[index],
                )
                self._show(target)

    def delete(self, index: int) -> None:
        with self._lock:
            if 0 <= index < len(self.keyframes):
                del self.keyframes[index]
                self._show(index - 1)

    def go_to(self, index: int) -> None:
        """Show the robot in a keyframe's pose (its stance too)."""
        with self._lock:
            keyframe = self.keyframes[index] if 0 <= index < len(self.keyframes) else None
        robot = self._state.robot
        if keyframe is None or keyframe.q is None or robot is None:
            return
        with self._state.lock:
            self._state.set_pose(keyframe.q.copy(), keyframe.stance, "button", robot)

    def replace(self, index: int) -> None:
        """The selected keyframe takes the current pose; its name and duration stay."""
        current = self._current_pose()
        if current is None:
            return
        robot, q, stance = current
        with self._lock:
            if 0 <= index < len(self.keyframes):
                old = self.keyframes[index]
                self.keyframes[index] = capture_keyframe(robot, q, stance, old.name, old.duration_s)
                self._show(index)

    def rename(self, index: int, name: str, client: viser.ClientHandle | None = None) -> None:
        name = " ".join(str(name).split())[:MAX_NAME]
        if not name:
            self._fail("Name refused", "give the keyframe a name", client)
            return
        with self._lock:
            if 0 <= index < len(self.keyframes):
                self.keyframes[index] = dataclasses.replace(self.keyframes[index], name=name)
                self._show(index)

    def set_duration(
        self, index: int, duration_s: float, client: viser.ClientHandle | None = None
    ) -> None:
        if not _valid_duration(duration_s):
            self._fail("Duration refused", _duration_message(duration_s), client)
            return
        with self._lock:
            if 0 <= index < len(self.keyframes):
                self.keyframes[index] = dataclasses.replace(
                    self.keyframes[index], duration_s=duration_s
                )
                self._show(index)

    def build(self, client: viser.ClientHandle | None = None) -> bool:
        robot = self._state.robot
        with self._lock:
            keyframes = list(self.keyframes)
        if robot is None:
            return False
        try:
            with self._admission.admit(client.client_id if client is not None else None):
                result = interpolate(robot, keyframes, name="keyframes")
        except Busy as busy:
            return self._fail("Not now", str(busy), client)
        except StudioError as error:
            return self._fail("Cannot build the motion", str(error), client)
        return self._install(robot, result, client)

    # --- files ------------------------------------------------------------------------------

    def export(self, client: viser.ClientHandle | None = None) -> bytes | None:
        """The current motion as CSV; sent to the browser as a download when a client asks."""
        with self._state.lock:
            trajectory, robot = self._state.trajectory, self._state.robot
        if trajectory is None or robot is None:
            self._fail("Nothing to export", "generate or build a motion first", client)
            return None
        buffer = io.StringIO()
        write_trajectory_csv(trajectory, buffer, robot)
        content = buffer.getvalue().encode()
        if client is not None:
            client.send_file_download(f"{file_slug(trajectory.name)}.csv", content)
        return content

    def import_file(
        self,
        filename: str,
        content: bytes,
        quaternion_order: str,
        client: viser.ClientHandle | None = None,
    ) -> bool:
        """A motion CSV of ours (with a header), or a headerless Roban S14 motion file."""
        robot = self._state.robot
        if robot is None:
            return False
        if len(content) > MAX_MOTION_FILE_BYTES:
            return self._fail(
                "Motion file refused",
                f"{filename} is over {MAX_MOTION_FILE_BYTES // 2**20} MB",
                client,
            )
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / file_slug(Path(filename).name)
            path.write_bytes(content)
            try:
                if content[:1].isalpha():
                    trajectory = read_trajectory_csv(path, robot)
                else:
                    order: Literal["xyzw", "wxyz"] = (
                        "xyzw" if quaternion_order == "xyzw" else "wxyz"
                    )
                    trajectory = read_roban_motion_csv(path, robot, quaternion_order=order)
            except StudioError as error:
                return self._fail("Cannot import the motion", str(error), client)
        return self._install(robot, MotionResult(trajectory, ()), client)

    # --- helpers ----------------------------------------------------------------------------

    def _install(
        self, robot: RobotModel, result: MotionResult, client: viser.ClientHandle | None
    ) -> bool:
        trajectory = result.trajectory
        lines = [
            f"**{trajectory.name}** — {trajectory.duration:.2f} s, {trajectory.n_samples} "
            f"samples at {1 / trajectory.dt:.0f} Hz"
        ]
        jumps = result.jump_samples
        if jumps:
            lines.append(
                f"⚠️ **{len(jumps)} sample(s) the IK could not follow within the joints' speed "
                f"limits** (first at t = {trajectory.t[jumps[0]]:.2f} s): clipped, their targets "
                "missed; torque peaks leave them out"
            )
        lines.extend(f"⚠️ {line}" for line in result.summary())
        try:
            self._state.set_motion(trajectory, "  \n".join(lines), robot)
        except StudioError as error:
            return self._fail("Motion discarded", str(error), client)
        self.panel.status.content = "  \n".join(lines[:2])
        return True

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> bool:
        self.panel.status.content = f"⚠️ {body}"
        self._notifier.error(title, body, client)
        return False

    def _show(self, selected: int) -> None:
        self.keyframes_panel.show(self.keyframes, selected)


def _valid_duration(duration_s: float) -> bool:
    return (
        isinstance(duration_s, int | float)
        and math.isfinite(duration_s)
        and (0.0 < duration_s <= MAX_KEYFRAME_S)
    )


def _duration_message(duration_s: object) -> str:
    return f"a keyframe duration of {duration_s!r} s: give a time in (0, {MAX_KEYFRAME_S:g}] s"
