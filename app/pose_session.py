"""Drag-to-pose for the loaded robot: gizmo events in, IK, pose out to the studio.

Gizmo drags arrive on viser's thread pool, at most every 50 ms per client, possibly from
several tabs at once. Only the latest target per handle matters: callbacks store it, then
take the studio lock and solve what is pending; a newer target replaces an older one that
has not been solved yet, so a backlog of stale drags is never worked through.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING

import numpy as np

from app.core.posing.drag import Posing
from app.core.posing.ik import IkResult
from app.core.robot.model import RobotModel
from app.views.balance_view import BalanceView
from app.views.drag_handles import DragHandles

if TYPE_CHECKING:
    from app.studio import Studio


class PoseSession:
    """Owns the posing state and the overlays (handles, balance) of one robot."""

    def __init__(self, studio: Studio, robot: RobotModel, com_in_support: bool) -> None:
        self._studio = studio
        self.robot = robot
        self.posing = Posing(robot, com_in_support=com_in_support)
        lower, upper = robot.bounds_m(robot.q_neutral, robot.model.createData())
        scale = 0.15 * float(upper[2] - lower[2])
        frames = {
            "left": robot.feet[0].link,
            "right": robot.feet[1].link,
            "pelvis": robot.tree.root,
        }
        self.handles = DragHandles(studio.server, frames, scale, self.request_drag)
        self.balance = BalanceView(studio.server, robot.n_actuated)
        self.last_result: IkResult | None = None
        self._pending: dict[str, np.ndarray] = {}
        self._pending_lock = threading.Lock()

    def request_drag(self, which: str, T_world: np.ndarray) -> None:
        """Record the latest target of a handle, then solve whatever is pending. A callback
        that gets the lock after another has drained its target finds nothing left to do."""
        with self._pending_lock:
            self._pending[which] = T_world
        with self._studio.lock:
            self._drain()

    def _drain(self) -> None:
        while True:
            with self._pending_lock:
                if not self._pending:
                    return
                which, T_world = self._pending.popitem()
            if self._studio.robot is not self.robot:
                return  # a new robot was loaded meanwhile
            result = self.posing.drag(self._studio.q, which, T_world)
            self.apply(result, dragged=which)

    def apply(self, result: IkResult, dragged: str | None = None) -> None:
        """Show a solved pose (caller holds the studio lock)."""
        self.last_result = result
        self._studio.show_pose(result.q, dragged=dragged)

    def update_overlays(self, q: np.ndarray, dragged: str | None) -> None:
        placements = self.robot.link_placements(q, self.robot.model.createData())
        self.handles.place(placements, skip=dragged)
        state = self.posing.balance(q)
        self.balance.update(
            state.polygon_xy,
            state.com_world,
            state.com_margin_m >= 0.0,
            state.joint_positions_near_limit,
            state.contact_frames,
        )

    def status_markdown(self) -> str:
        result = self.last_result
        lines = [f"Stance: **{self.posing.stance}**"]
        if result is not None:
            lines.append("Target reached ✓" if result.reached else "Target **not reached**")
            lines.append(f"CoM margin in support: {result.com_margin_m * 1000:.0f} mm")
            if result.joints_near_limit:
                lines.append("Near a limit: " + ", ".join(result.joints_near_limit))
            lines.extend(f"⚠️ {warning}" for warning in result.warnings)
        return "  \n".join(lines)

    def remove(self) -> None:
        self.handles.remove()
        self.balance.remove()
