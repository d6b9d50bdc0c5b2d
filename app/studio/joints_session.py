"""Joint sliders in the studio: one per actuated joint, rebuilt for each robot; a slider sets
its joint (clamped to its limits), closing the robot's declared loops, and follows the pose
when something else moves the robot.

During a drag the sliders are refreshed off the drag path, at most every SLIDER_REFRESH_S
and always with the drag's last pose (a Throttle's trailing call): a dozen slider messages
per gizmo event would cost more than the IK. The refresh holds the panel's own lock, not the
studio state's, so a drag event never waits for it."""

from __future__ import annotations

import threading

import numpy as np
import viser

from app.core.robot.loops import close_loops
from app.core.robot.model import RobotModel
from app.studio.signals import Signal
from app.studio.state import LoadedRobot, Pose, StudioState
from app.studio.throttle import Throttle
from panels.joints_panel import JointsPanel

LOOP_TOLERANCE_M = 1e-6
"""A pose whose loops cannot close to this gap is refused."""
SLIDER_REFRESH_S = 0.1
"""The sliders follow a drag at most this often (10 Hz), and show its last pose."""


class JointsSession:
    def __init__(self, server: viser.ViserServer, state: StudioState) -> None:
        self._server, self._state = server, state
        self.panel = JointsPanel(server.gui, self.set_joint_angle)
        self._robot: RobotModel | None = None
        self._data = None
        self._panel_lock = threading.Lock()
        """Held while the sliders are set or rebuilt (the drag refresh runs on a timer thread)."""
        self._latest: Pose | None = None
        """The newest pose announced (poses are announced under the state's lock, in order)."""
        self._dragged: Throttle[Pose] = Throttle(
            SLIDER_REFRESH_S, self._show_dragged, name="joint sliders during a drag"
        )
        self.followed_drag: Signal[Pose] = Signal("joint_sliders_followed_drag")
        """Emitted with a drag's pose once the sliders show it."""
        state.on_robot.connect(self._on_robot)
        state.on_pose.connect(self._on_pose)

    def _on_robot(self, loaded: LoadedRobot) -> None:
        robot = loaded.robot
        with self._panel_lock:
            self._latest = None
            self._robot, self._data = robot, robot.model.createData()
            self.panel.show_robot(robot, robot.joint_angles(robot.q_neutral))

    def _on_pose(self, pose: Pose) -> None:
        self._latest = pose  # a drag refresh still pending for an older pose is dropped
        robot, panel = self._robot, self.panel
        if robot is None or pose.origin == "slider":
            return
        if pose.dragged is not None:
            self._dragged.submit(pose)
            return
        self._dragged.cancel()
        with self._panel_lock:
            panel.set_angles(robot, robot.joint_angles(pose.q))

    def _show_dragged(self, pose: Pose) -> None:
        """The sliders at a drag's pose, unless something has moved the robot since (that
        pose's own subscriber call set them, or a newer drag pose is on its way here)."""
        with self._panel_lock:
            robot = self._robot
            if robot is None or self._latest is not pose:
                return
            with self._server.atomic():
                self.panel.set_angles(robot, robot.joint_angles(pose.q))
        self.followed_drag.emit(pose)

    def set_joint_angle(self, index: int, value: float) -> None:
        """Set one actuated joint [rad or m], clamped to its limits; NaN and unknown joints are
        ignored (a crafted client can send anything)."""
        state = self._state
        with state.lock:
            robot, pose = self._robot, state.pose
            if robot is None or pose is None or robot is not state.robot:
                return
            if not 0 <= index < robot.n_actuated or not np.isfinite(value):
                return
            joint = robot.joints[index]
            angles = robot.joint_angles(pose.q)
            angles[index] = float(np.clip(value, joint.lower, joint.upper))
            q = robot.with_joint_angles(pose.q, angles)
            if robot.tree.loops:
                closure = close_loops(robot, q, self._data)
                if closure.residual_m > LOOP_TOLERANCE_M:
                    self.panel.show_status(
                        f"⚠️ {joint.name} at {np.rad2deg(angles[index]):.1f}° cannot close "
                        f"the robot's loops (gap {closure.residual_m * 1000:.1f} mm): pose kept."
                    )
                    with self._panel_lock:
                        self.panel.set_angles(robot, robot.joint_angles(pose.q))
                    return
                q = closure.q
            self.panel.show_status("")
            with self._server.atomic():
                state.set_pose(q, pose.stance, "slider", robot)
