"""StudioState: what every feature of the studio shares, and the signals that announce it.

The state holds the loaded robot (and its report), the current pose, the current motion and its
work (`work`: torques, coefficients and virtual servos, quick estimate, last good simulation;
app.studio.work), the playback time and the display settings (camera, toggles: a frozen value replaced on every
change, so a change is seen by identity), under one re-entrant lock: viser runs callbacks on a thread pool, so
changes from several tabs overlap. Each setter changes the state and emits its signal while
holding the lock, so subscribers see every change in order and never half of one.

Sessions (one per feature) own their panel and overlays, subscribe to these signals, and
change the state only through the setters; they never reach into one another.
"""

from __future__ import annotations

import dataclasses
import threading
from typing import Literal

import numpy as np

from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.projects.display import CameraView, DisplaySettings
from app.core.robot.model import RobotModel
from app.core.robot.report import RobotReport
from app.studio.signals import Signal
from app.studio.work import MotionWork

Stance = Literal["both", "left", "right"]
STANCES: tuple[Stance, ...] = ("both", "left", "right")


class MotionMismatch(StudioError):
    """A motion whose joints are not the loaded robot's."""


@dataclasses.dataclass(frozen=True)
class LoadedRobot:
    robot: RobotModel
    report: RobotReport


@dataclasses.dataclass(frozen=True, eq=False)
class Pose:
    """The robot's current configuration and which feet hold it."""

    q: np.ndarray
    """Configuration, pinocchio layout (base xyz, quaternion xyzw, joints)."""
    stance: Stance
    origin: str
    """Who set it: "load", "slider", "drag:left" / "drag:right" / "drag:pelvis", "button",
    "playback" (the player), "timeline" (a seek). Subscribers use it to avoid echoing a change back to where it came from."""

    @property
    def dragged(self) -> str | None:
        """The drag handle the user holds, if the pose comes from a drag."""
        return self.origin.split(":", 1)[1] if self.origin.startswith("drag:") else None


@dataclasses.dataclass(frozen=True)
class Motion:
    trajectory: Trajectory
    summary: str
    """Markdown: name, duration, samples, warnings."""
    then: tuple[str, ...] = ()
    """Stages to run on it at once, in order, by the features that own them ("torques",
    "simulate"): the one-click pipeline plan → walk → torques → compensation → simulation."""


@dataclasses.dataclass(frozen=True)
class Display:
    """The display settings and who set them last: "panel" (a toggle), "camera" (a tab's
    camera, kept at most every few seconds) or "project" (an opened project: panels and cameras
    follow)."""

    settings: DisplaySettings
    origin: str


class StudioState:
    """The shared state; see the module docstring."""

    def __init__(self) -> None:
        self.lock = threading.RLock()
        self.loaded: LoadedRobot | None = None
        self.pose: Pose | None = None
        self.motion: Motion | None = None
        self.time_s = 0.0
        self.display = Display(DisplaySettings(), "load")
        self.work = MotionWork(self.lock, lambda: (self.robot, self.trajectory))
        """The motion's torques, coefficients, quick estimate and simulation (app.studio.work)."""
        self._camera: CameraView | None = None
        """The newest camera a tab reported, not yet in `display` (see `note_camera`)."""
        self.on_robot: Signal[LoadedRobot] = Signal("on_robot")
        self.on_pose: Signal[Pose] = Signal("on_pose")
        self.on_motion: Signal[Motion | None] = Signal("on_motion")
        self.on_time: Signal[float] = Signal("on_time")
        self.on_display: Signal[Display] = Signal("on_display")
        self.on_play: Signal[None] = Signal("on_play")
        """A feature asks for the current motion to be played (e.g. a walk just planned)."""

    # --- reading ------------------------------------------------------------------------

    @property
    def robot(self) -> RobotModel | None:
        loaded = self.loaded
        return loaded.robot if loaded is not None else None

    @property
    def q(self) -> np.ndarray:
        pose = self.pose
        return pose.q if pose is not None else np.zeros(0)

    @property
    def trajectory(self) -> Trajectory | None:
        motion = self.motion
        return motion.trajectory if motion is not None else None

    # --- changing -----------------------------------------------------------------------

    def set_robot(self, robot: RobotModel, report: RobotReport) -> None:
        """Install a robot: its motion is dropped (a motion belongs to its robot) and it
        stands in its neutral pose."""
        with self.lock:
            self.loaded = LoadedRobot(robot, report)
            self.motion, self.time_s = None, 0.0
            self.work.drop(coefficients=True)
            self.on_robot.emit(self.loaded)
            self.on_motion.emit(None)
            self.set_pose(robot.q_neutral.copy(), "both", "load")

    def set_pose(
        self, q: np.ndarray, stance: Stance, origin: str, robot: RobotModel | None = None
    ) -> bool:
        """Make q the current pose. With `robot`, only if that robot is still the loaded one
        (work that started before another robot was loaded is dropped): False then."""
        with self.lock:
            if self.loaded is None or (robot is not None and robot is not self.loaded.robot):
                return False
            if q.shape != (self.loaded.robot.model.nq,) or not np.all(np.isfinite(q)):
                raise StudioError(f"a pose of shape {q.shape} with finite values is needed")
            self.pose = Pose(q, stance, origin)
            self.on_pose.emit(self.pose)
            return True

    def set_stance(self, stance: Stance) -> None:
        with self.lock:
            if self.pose is not None and stance != self.pose.stance:
                self.set_pose(self.pose.q, stance, "button")

    def set_motion(
        self,
        trajectory: Trajectory,
        summary: str,
        robot: RobotModel,
        then: tuple[str, ...] = (),
    ) -> None:
        """Make a motion of `robot` the current one and show its first sample. Raises
        MotionMismatch when `robot` is no longer loaded or the joints differ."""
        with self.lock:
            loaded = self.loaded
            if loaded is None or loaded.robot is not robot:
                raise MotionMismatch("another robot was loaded meanwhile; the motion is discarded")
            if trajectory.joint_names != robot.joint_names:
                raise MotionMismatch(
                    f"motion {trajectory.name!r}: its joints differ from {robot.name}'s"
                )
            self.motion = Motion(trajectory, summary, then)
            self.work.drop()
            self.on_motion.emit(self.motion)
            self.set_time(0.0)

    def set_time(self, time_s: float) -> int | None:
        """Move the current motion to the sample nearest time_s (clamped); its index, or None
        without a motion."""
        with self.lock:
            trajectory = self.trajectory
            if trajectory is None or not np.isfinite(time_s):
                return None
            self.time_s = float(np.clip(time_s, 0.0, trajectory.duration))
            self.on_time.emit(self.time_s)
            return trajectory.index_at(self.time_s)

    def set_display(self, origin: str, **changes: object) -> DisplaySettings:
        """Change display settings (DisplaySettings field → value); a newer camera a tab
        reported goes in too. The value is replaced (and on_display emitted) only when
        something differs. Raises DisplayError for a value out of range."""
        with self.lock:
            settings = self.display.settings
            camera, self._camera = self._camera, None
            if camera is not None and "camera" not in changes and not camera.near(settings.camera):
                changes["camera"] = camera
            new = dataclasses.replace(settings, **changes)  # type: ignore[arg-type]
            if new != settings:
                self.display = Display(new, origin)
                self.on_display.emit(self.display)
            return self.display.settings

    def restore_display(self, settings: DisplaySettings) -> None:
        """Install a project's display settings: every panel and tab follows (origin
        "project")."""
        with self.lock:
            self._camera = None
            self.display = Display(settings, "project")
            self.on_display.emit(self.display)

    def note_camera(self, camera: CameraView, starting: bool = False) -> None:
        """A tab's camera moved: kept aside, and put into `display` by the next
        `set_display` (a toggle, `flush_camera`); a camera moving at 60 Hz does not replace
        the settings 60 times a second. `starting`: the tab is at the view a tab starts from,
        which is not kept while the settings hold no camera (opening a tab is not work)."""
        with self.lock:
            kept = self.display.settings.camera
            if kept is None and starting:
                self._camera = None
            else:
                self._camera = None if camera.near(kept) else camera

    def flush_camera(self) -> None:
        """Put the newest reported camera into `display` now (before a save, on a timer)."""
        self.set_display("camera")
