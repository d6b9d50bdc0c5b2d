"""The studio: one viser server, the shared state of the loaded robot, and the panels.

Panels collect input and call the methods here; this module owns the state (under one lock,
since viser runs callbacks on a thread pool) and the scene. Computation lives in app.core.
"""

from __future__ import annotations

import logging
import threading
from pathlib import Path
from typing import Literal

import numpy as np
import viser

from app.compensation_session import CompensationSession
from app.config import StudioConfig
from app.core.errors import StudioError
from app.core.motions.paths import task_space_paths
from app.core.motions.trajectory import Trajectory
from app.core.posing.ready_pose import ready_pose
from app.core.robot.loading import load_robot
from app.core.robot.loops import close_loops
from app.core.robot.model import RobotModel
from app.core.robot.report import RobotReport, robot_report
from app.core.robot.uploads import store_upload
from app.gait_session import GaitSession
from app.motion_session import MotionSession
from app.player import Player
from app.pose_session import PoseSession
from app.views.robot_view import RobotView
from app.views.traces_view import TracesView
from app.web.guard import guarded_server
from panels.display_panel import DisplayFlags, DisplayPanel
from panels.joints_panel import JointsPanel
from panels.keyframes_panel import KeyframesPanel
from panels.motions_panel import MotionsPanel
from panels.playback_panel import PlaybackPanel
from panels.pose_panel import PosePanel
from panels.robot_panel import RobotPanel

log = logging.getLogger(__name__)

LOOP_TOLERANCE_M = 1e-6
"""A pose whose loops cannot close to this gap is refused."""


class Studio:
    """A running studio. All browser tabs share its state."""

    def __init__(self, config: StudioConfig, robot: RobotModel | None = None) -> None:
        self.config = config
        self.web = guarded_server(
            config.host,
            config.port,
            config.access_token,
            label="Biped Studio",
            max_upload_bytes=config.max_upload_bytes,
        )
        self.server = self.web.server
        self.lock = threading.RLock()
        self.server.gui.configure_theme(control_width="medium", dark_mode=False, show_logo=False)
        self.server.scene.set_up_direction("+z")
        self.server.scene.add_grid(
            "/ground",
            width=4.0,
            height=4.0,
            cell_size=0.1,
            section_size=0.5,
            plane="xy",
            shadow_opacity=0.2,
        )
        self.robot_panel = RobotPanel(self.server.gui, self, config.max_upload_bytes)
        self.pose_panel = PosePanel(self.server.gui, self)
        self.playback_panel = PlaybackPanel(self.server.gui, self)
        self.motions_panel = MotionsPanel(self.server.gui, self)
        self.keyframes_panel = KeyframesPanel(self.server.gui, self)
        self.motions = MotionSession(self)
        self.compensation = CompensationSession(self)
        self.gait = GaitSession(self)
        self.trajectory: Trajectory | None = None
        self.traces: TracesView | None = None
        self.player = Player(self)
        self.display_panel = DisplayPanel(self.server.gui, self._on_display)
        self.robot: RobotModel | None = None
        self.report: RobotReport | None = None
        self.q = np.zeros(0)
        self.view: RobotView | None = None
        self.joints_panel: JointsPanel | None = None
        self.pose: PoseSession | None = None
        self.last_error = ""
        self._install(
            robot if robot is not None else load_robot(config.robot, **self._load_options())
        )

    # --- loading -------------------------------------------------------------------------

    def load(
        self,
        source: str | Path,
        client: viser.ClientHandle | None = None,
        sandbox: Path | None = None,
    ) -> bool:
        """Load a robot; on failure tell the user and keep the current one. True on success."""
        if not str(source):
            self._fail("Nothing to open", "Type the path of a .urdf file first.", client)
            return False
        try:
            options = self._load_options()
            if sandbox is not None:
                options = {**options, "sandbox": sandbox, "feet": None}
            robot = load_robot(source, **options)
        except StudioError as error:
            self._fail(
                "Could not load the robot", f"{error} — the previous robot is still loaded.", client
            )
            return False
        self._install(robot)
        report = self.report
        assert report is not None
        warning = f", {len(report.problems)} problem(s) in the report" if report.problems else ""
        self._notify(
            "Robot loaded",
            f"{robot.name}: {robot.n_actuated} actuated joints, {robot.mass_kg:.2f} kg{warning}.",
            client,
            color="green" if not report.problems else "yellow",
        )
        return True

    def load_upload(
        self, filename: str, content: bytes, client: viser.ClientHandle | None = None
    ) -> bool:
        """Store an uploaded .urdf/.zip in its own folder and load it from there."""
        try:
            urdf = store_upload(
                filename, content, self.config.uploads_dir, self.config.max_upload_bytes
            )
        except StudioError as error:
            self._fail("Upload refused", f"{error} — the previous robot is still loaded.", client)
            return False
        return self.load(urdf, client=client, sandbox=urdf.parent)

    def _install(self, robot: RobotModel) -> None:
        report = robot_report(robot)
        self.player.pause()
        with self.lock, self.server.atomic():
            for old in (self.view, self.joints_panel, self.pose, self.traces):
                if old is not None:
                    old.remove()
            self.trajectory, self.traces = None, None  # a motion belongs to its robot
            self.motions.clear()
            self.compensation.reset(robot, None)
            self.robot, self.report = robot, report
            self.q = robot.q_neutral.copy()
            self.view = RobotView(self.server, robot)
            self.view.set_visible(**vars_of(self.display_panel.flags()))
            self.joints_panel = JointsPanel(
                self.server.gui, robot, robot.joint_angles(self.q), self.set_joint_angle
            )
            self.pose = PoseSession(self, robot, self.pose_panel.com_in_support.value)
            self.pose.handles.set_visible(self.pose_panel.handles.value)
            self.show_pose(self.q)
            self.robot_panel.show_report(report)
            self.robot_panel.show_status(
                f"**{robot.name}** — {robot.n_actuated} DOF, {robot.mass_kg:.2f} kg"
            )
            self._frame_camera(robot)
        self.gait.show_robot()

    def _load_options(self) -> dict:
        return {"package_roots": self.config.package_roots, "feet": self.config.feet}

    # --- posing --------------------------------------------------------------------------

    def show_pose(
        self, q: np.ndarray, dragged: str | None = None, from_slider: bool = False
    ) -> None:
        """Make q the current pose and draw it everywhere (caller holds the lock). `dragged`
        is the handle being dragged (left where the user holds it); a pose set by a joint
        slider does not write back to the sliders."""
        assert self.robot is not None and self.view is not None
        self.q = q
        with self.server.atomic():
            self.view.update(q)
            if self.pose is not None:
                self.pose.update_overlays(q, dragged)
                self.pose_panel.show_stance(self.pose.posing.stance)
                self.pose_panel.show_status(self.pose.status_markdown())
            if self.joints_panel is not None and not from_slider:
                self.joints_panel.set_angles(self.robot, self.robot.joint_angles(q))

    def set_joint_angle(self, index: int, value: float) -> None:
        """Set one actuated joint [rad or m], clamped to its limits, and redraw."""
        with self.lock:
            robot, view = self.robot, self.view
            if (
                robot is None
                or view is None
                or not 0 <= index < robot.n_actuated
                or not np.isfinite(value)
            ):
                return
            joint = robot.joints[index]
            angles = robot.joint_angles(self.q)
            angles[index] = float(np.clip(value, joint.lower, joint.upper))
            q = robot.with_joint_angles(self.q, angles)
            if robot.tree.loops:
                closure = close_loops(robot, q, view.data)
                if closure.residual_m > LOOP_TOLERANCE_M:
                    self.robot_panel.show_status(
                        f"⚠️ {joint.name} at {np.rad2deg(angles[index]):.1f}° cannot close the robot's "
                        f"loops (gap {closure.residual_m * 1000:.1f} mm): pose kept."
                    )
                    return
                q = closure.q
            self.show_pose(q, from_slider=True)

    def request_drag(self, which: str, T_world: np.ndarray) -> None:
        """A drag handle ("left", "right", "pelvis") moved to T_world: solve IK and redraw."""
        if self.pose is not None:
            self.pose.request_drag(which, T_world)

    def reset_pose(self) -> None:
        with self.lock:
            if self.robot is None or self.pose is None:
                return
            self.pose.posing.stance = "both"
            self.pose.last_result = None
            self.show_pose(self.robot.q_neutral.copy())

    def ready_pose(self) -> None:
        """Knees bent, pelvis lowered, feet where they stand (app.core.posing.ready_pose)."""
        with self.lock:
            robot, pose = self.robot, self.pose
            if robot is None or pose is None:
                return
            try:
                ready = ready_pose(robot)
            except StudioError as error:
                self._fail("No ready pose", str(error), None)
                return
            pose.posing.stance = "both"
            pose.last_result = None
            self.show_pose(ready.q)

    def snap_feet(self) -> None:
        with self.lock:
            if self.pose is not None:
                result = self.pose.posing.snap_feet_to_ground(self.q)
                self.pose.last_result = result
                self.show_pose(result.q)

    def swap_stance(self) -> None:
        with self.lock:
            if self.pose is not None:
                self.pose.posing.swap_stance()
                self.show_pose(self.q)

    def set_stance(self, stance: str) -> None:
        with self.lock:
            if self.pose is not None and stance in ("both", "left", "right"):
                self.pose.posing.stance = stance  # type: ignore[assignment]
                self.show_pose(self.q)

    def set_com_in_support(self, on: bool) -> None:
        with self.lock:
            if self.pose is not None:
                self.pose.posing.com_in_support = on

    def set_handles_visible(self, visible: bool) -> None:
        with self.lock:
            if self.pose is not None:
                self.pose.handles.set_visible(visible)

    # --- motions and playback -------------------------------------------------------------

    def set_trajectory(self, trajectory: Trajectory, summary: str) -> None:
        """Make a motion of the current robot the one played back, and show its start."""
        self.player.pause()
        with self.lock:
            assert self.robot is not None
            if trajectory.joint_names != self.robot.joint_names:
                self._fail(
                    "Motion not for this robot", "its joints differ from the loaded robot's", None
                )
                return
            if self.traces is not None:
                self.traces.remove()
            self.trajectory = trajectory
            self.compensation.reset(self.robot, trajectory)
            self.traces = TracesView(self.server, task_space_paths(self.robot, trajectory))
            self.traces.set_visible(self.playback_panel.traces.value)
            self.playback_panel.show_trajectory(trajectory, summary)
            self.show_time(0.0)

    def show_time(self, time_s: float, playing: bool = False) -> None:
        """Show the trajectory's sample nearest to time_s (the player calls this every frame)."""
        with self.lock:
            trajectory = self.trajectory
            if trajectory is None or self.pose is None:
                return
            k = trajectory.index_at(time_s)
            left, right = trajectory.contacts[k]
            self.pose.posing.stance = "both" if left == right else ("left" if left else "right")
            self.pose.last_result = None
            self.show_pose(trajectory.q[k], from_slider=playing)
            self.compensation.show_sample(k)
            self.playback_panel.show_time(time_s)
            if not playing:
                self.playback_panel.show_playing(False)

    def seek(self, time_s: float) -> None:
        self.player.pause()
        self.show_time(time_s)

    def toggle_play(self) -> None:
        if self.player.playing:
            self.player.pause()
            self.playback_panel.show_playing(False)
            self.show_time(self.playback_panel.time.value)
        elif self.trajectory is not None:
            start = self.playback_panel.time.value
            self.player.play(0.0 if start >= self.trajectory.duration else start)
            self.playback_panel.show_playing(True)

    def set_traces_visible(self, visible: bool) -> None:
        with self.lock:
            if self.traces is not None:
                self.traces.set_visible(visible)

    def _on_display(self, flags: DisplayFlags) -> None:
        with self.lock:
            if self.view is not None:
                self.view.set_visible(**vars_of(flags))
                self.view.update(self.q)

    # --- messages and camera -------------------------------------------------------------

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        self.last_error = body
        log.warning("%s: %s", title, body)
        self.robot_panel.show_status(f"⚠️ {body}")
        self._notify(title, body, client, color="red")

    def report_error(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        """Tell the user something failed (the state is unchanged)."""
        self._fail(title, body, client)

    def notify_progress(
        self, title: str, body: str, client: viser.ClientHandle | None
    ) -> _Progress:
        """A loading notification to remove when the work is done."""
        clients = [client] if client is not None else list(self.server.get_clients().values())
        return _Progress(
            [
                c.add_notification(title, body, loading=True, with_close_button=False)
                for c in clients
            ]
        )

    def _notify(
        self,
        title: str,
        body: str,
        client: viser.ClientHandle | None,
        color: Literal["red", "green", "yellow"],
    ) -> None:
        clients = [client] if client is not None else list(self.server.get_clients().values())
        for target in clients:
            target.add_notification(title, body, color=color, auto_close_seconds=8.0)

    def _frame_camera(self, robot: RobotModel) -> None:
        lower, upper = robot.bounds_m(robot.q_neutral, robot.model.createData())
        height = max(float(upper[2] - min(lower[2], 0.0)), 0.3)
        centre = 0.5 * (lower + upper)
        look_at = (float(centre[0]), float(centre[1]), 0.45 * height)
        position = (centre[0] + 0.95 * height, centre[1] + 0.7 * height, 0.7 * height)
        self.server.initial_camera.position = position
        self.server.initial_camera.look_at = look_at
        for client in self.server.get_clients().values():
            client.camera.position = position
            client.camera.look_at = look_at

    def stop(self) -> None:
        self.player.pause()
        self.gait.close()
        self.server.stop()


def vars_of(flags: DisplayFlags) -> dict[str, bool]:
    return {
        "visual": flags.visual,
        "collision": flags.collision,
        "frames": flags.frames,
        "com": flags.com,
    }


class _Progress:
    def __init__(self, handles: list) -> None:
        self._handles = handles

    def remove(self) -> None:
        for handle in self._handles:
            handle.remove()
