"""Joint sliders in the studio: one per actuated joint, rebuilt for each robot; a slider sets
its joint (clamped to its limits), closing the robot's declared loops, and follows the pose
when something else moves the robot."""

from __future__ import annotations

import numpy as np
import viser

from app.core.robot.loops import close_loops
from app.core.robot.model import RobotModel
from app.studio.state import LoadedRobot, Pose, StudioState
from panels.joints_panel import JointsPanel

LOOP_TOLERANCE_M = 1e-6
"""A pose whose loops cannot close to this gap is refused."""


class JointsSession:
    def __init__(self, server: viser.ViserServer, state: StudioState) -> None:
        self._server, self._state = server, state
        self.panel = JointsPanel(server.gui, self.set_joint_angle)
        self._robot: RobotModel | None = None
        self._data = None
        state.on_robot.connect(self._on_robot)
        state.on_pose.connect(self._on_pose)

    def _on_robot(self, loaded: LoadedRobot) -> None:
        robot = loaded.robot
        self._robot, self._data = robot, robot.model.createData()
        self.panel.show_robot(robot, robot.joint_angles(robot.q_neutral))

    def _on_pose(self, pose: Pose) -> None:
        robot, panel = self._robot, self.panel
        if robot is not None and pose.origin != "slider":
            panel.set_angles(robot, robot.joint_angles(pose.q))

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
                    self.panel.set_angles(robot, robot.joint_angles(pose.q))
                    return
                q = closure.q
            self.panel.show_status("")
            with self._server.atomic():
                state.set_pose(q, pose.stance, "slider", robot)
