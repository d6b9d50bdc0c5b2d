"""Motions in the studio: built-in motions, keyframes captured from poses, motion files.

Heavy work (IK at every sample) runs in the calling callback's thread, outside the studio
lock, on the robot that was loaded when it started; the result is only installed if that
robot is still the loaded one.
"""

from __future__ import annotations

import dataclasses
import io
import re
import tempfile
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, cast

import viser

from app.core.errors import StudioError
from app.core.motions.csv_files import (
    read_roban_motion_csv,
    read_trajectory_csv,
    write_trajectory_csv,
)
from app.core.motions.keyframes import Keyframe, MotionResult, capture_keyframe, interpolate
from app.core.motions.library import run_motion

if TYPE_CHECKING:
    from app.studio import Studio

MAX_MOTION_FILE_BYTES = 50 * 1024 * 1024


class MotionSession:
    def __init__(self, studio: Studio) -> None:
        self._studio = studio
        self.keyframes: list[Keyframe] = []
        self._lock = threading.Lock()
        """Guards the keyframe list (the studio lock guards the pose)."""

    # --- built-in motions and keyframes ----------------------------------------------------

    def generate(
        self, name: str, params: dict[str, object], client: viser.ClientHandle | None = None
    ) -> bool:
        studio = self._studio
        robot = studio.robot
        if robot is None:
            return False
        note = studio.notify_progress(f"Generating {name}", "IK at every sample…", client)
        try:
            result = run_motion(robot, name, **cast(dict[str, Any], params))
        except StudioError as error:
            note.remove()
            studio.report_error(f"Cannot generate {name}", str(error), client)
            return False
        note.remove()
        return self._install(robot, result, client)

    def capture(self, duration_s: float) -> None:
        studio = self._studio
        with studio.lock:
            robot, pose = studio.robot, studio.pose
            if robot is None or pose is None:
                return
            q, stance = studio.q.copy(), pose.posing.stance
        with self._lock:
            keyframe = capture_keyframe(
                robot, q, stance, f"pose {len(self.keyframes) + 1}", duration_s
            )
            self.keyframes.append(keyframe)
            self._show(len(self.keyframes) - 1)

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

    def set_duration(self, index: int, duration_s: float) -> None:
        with self._lock:
            if 0 <= index < len(self.keyframes):
                self.keyframes[index] = dataclasses.replace(
                    self.keyframes[index], duration_s=duration_s
                )
                self._show(index)

    def build(self, client: viser.ClientHandle | None = None) -> bool:
        studio = self._studio
        robot = studio.robot
        with self._lock:
            keyframes = list(self.keyframes)
        if robot is None:
            return False
        try:
            result = interpolate(robot, keyframes, name="keyframes")
        except StudioError as error:
            studio.report_error("Cannot build the motion", str(error), client)
            return False
        return self._install(robot, result, client)

    def clear(self) -> None:
        """Forget the keyframes (they belong to the robot that was loaded)."""
        with self._lock:
            self.keyframes = []
            self._show(-1)

    # --- files -----------------------------------------------------------------------------

    def export(self, client: viser.ClientHandle | None = None) -> bytes | None:
        """The current motion as CSV; sent to the browser as a download when a client asks."""
        studio = self._studio
        with studio.lock:
            trajectory, robot = studio.trajectory, studio.robot
        if trajectory is None or robot is None:
            studio.report_error("Nothing to export", "generate or build a motion first", client)
            return None
        buffer = io.StringIO()
        write_trajectory_csv(trajectory, buffer, robot)
        content = buffer.getvalue().encode()
        if client is not None:
            client.send_file_download(f"{_slug(trajectory.name)}.csv", content)
        return content

    def import_file(
        self,
        filename: str,
        content: bytes,
        quaternion_order: str,
        client: viser.ClientHandle | None = None,
    ) -> bool:
        """A motion CSV of ours (with a header), or a headerless Roban S14 motion file."""
        studio = self._studio
        robot = studio.robot
        if robot is None:
            return False
        if len(content) > MAX_MOTION_FILE_BYTES:
            studio.report_error(
                "Motion file refused",
                f"{filename} is over {MAX_MOTION_FILE_BYTES // 2**20} MB",
                client,
            )
            return False
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / _slug(Path(filename).name)
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
                studio.report_error("Cannot import the motion", str(error), client)
                return False
        return self._install(robot, MotionResult(trajectory, ()), client)

    # --- helpers ---------------------------------------------------------------------------

    def _install(self, robot, result: MotionResult, client: viser.ClientHandle | None) -> bool:
        studio = self._studio
        if studio.robot is not robot:
            studio.report_error("Motion discarded", "another robot was loaded meanwhile", client)
            return False
        trajectory = result.trajectory
        lines = [
            f"**{trajectory.name}** — {trajectory.duration:.2f} s, {trajectory.n_samples} samples at {1 / trajectory.dt:.0f} Hz"
        ]
        lines.extend(f"⚠️ {line}" for line in result.summary())
        studio.set_trajectory(trajectory, "  \n".join(lines))
        return True

    def _show(self, selected: int) -> None:
        self._studio.keyframes_panel.show(self.keyframes, selected)


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "motion"
