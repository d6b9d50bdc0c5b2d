"""Balance overlay: the support polygon, the CoM's ground projection (green inside, red
outside), contact frames on the stance soles, and markers on joints near a limit.

`update` is on the drag path: it queues only what changed since it was last sent (the polygon
when the stance or its feet move, a marker's visibility when it flips, a colour when it
flips, a pose beyond SEND_TOLERANCE), poses through app.views.pose_push. `update_per_node`
assigns everything through viser's setters: the reference `update` is tested against.
"""

from __future__ import annotations

import numpy as np
import viser

from app.core.posing.drag import Balance
from app.core.quaternions import matrix_to_wxyz
from app.views.pose_push import push_pose
from app.views.robot_view import SEND_TOLERANCE

INSIDE_RGB = (40, 170, 80)
OUTSIDE_RGB = (220, 40, 40)
POLYGON_RGB = (30, 110, 220)
LIMIT_RGB = (255, 150, 0)
POLYGON_Z_M = 0.002
COM_Z_M = 0.003


class BalanceView:
    def __init__(self, server: viser.ViserServer, max_joints: int, root: str = "/balance") -> None:
        self._server = server
        self.root = root
        self._polygon = server.scene.add_line_segments(
            f"{root}/polygon",
            np.zeros((1, 2, 3)),
            POLYGON_RGB,
            thickness=3.0,
            thickness_units="screen",
        )
        self._com = server.scene.add_icosphere(f"{root}/com_ground", radius=0.015, color=INSIDE_RGB)
        self._limits = [
            server.scene.add_icosphere(
                f"{root}/limit_{i}", radius=0.018, color=LIMIT_RGB, visible=False
            )
            for i in range(max_joints)
        ]
        self._contacts: list[viser.FrameHandle] = []
        self.visible = True
        # What the scene shows, as last sent by `update` (None / NaN: not sent yet).
        self._polygon_xy: np.ndarray | None = None
        self._com_xy = np.full(2, np.nan)
        self._com_inside = True
        self._limit_positions = np.zeros((max_joints, 3))  # made at the origin
        self._contact_frames = np.zeros((0, 4, 4))
        self._limits_shown = 0
        """The first this-many limit markers are visible, the others hidden."""
        self._contacts_shown = 0
        """The first this-many contact frames are visible, the others hidden."""

    def update(self, balance: Balance) -> None:
        """Show `balance` (app.core.posing.drag): its polygon, its CoM (inside when its margin
        is ≥ 0), its joints near a limit and its contact frames. Queues only what changed
        since the last update."""
        polygon_xy = np.asarray(balance.polygon_xy, dtype=float)
        com_world, com_inside = balance.com_world, balance.com_margin_m >= 0.0
        joints_near_limit_m = balance.joint_positions_near_limit
        contact_frames = balance.contact_frames
        shown = self._polygon_xy
        if (
            shown is None
            or shown.shape != polygon_xy.shape
            or np.abs(shown - polygon_xy).max(initial=0.0) >= SEND_TOLERANCE
        ):
            self._polygon.points = _segments(polygon_xy)
            self._polygon_xy = polygon_xy.copy()
        com_xy = np.asarray(com_world, dtype=float)[:2]
        if np.abs(com_xy - self._com_xy).max() >= SEND_TOLERANCE or np.isnan(self._com_xy[0]):
            push_pose(self._com, np.array([com_xy[0], com_xy[1], COM_Z_M]))
            self._com_xy = com_xy.copy()
        if bool(com_inside) != self._com_inside:
            self._com_inside = bool(com_inside)
            self._com.color = INSIDE_RGB if com_inside else OUTSIDE_RGB

        n = min(len(joints_near_limit_m), len(self._limits))
        if n:
            positions = np.asarray(joints_near_limit_m[:n], dtype=float).reshape(n, 3)
            changed = ~(np.abs(positions - self._limit_positions[:n]).max(axis=1) < SEND_TOLERANCE)
            for i in np.flatnonzero(changed):
                push_pose(self._limits[i], positions[i])
                self._limit_positions[i] = positions[i]
        self._limits_shown = _show_first(self._limits, self._limits_shown, n * self.visible)

        while len(self._contacts) < len(contact_frames):
            i = len(self._contacts)
            # Born visible only if that keeps the visible frames first (else shown below).
            shown_now = self.visible and self._contacts_shown == i
            self._contacts.append(
                self._server.scene.add_frame(
                    f"{self.root}/contact_{i}",
                    axes_length=0.05,
                    axes_radius=0.003,
                    visible=shown_now,
                )
            )
            self._contacts_shown += shown_now
            # A new frame stands at the origin, unrotated, until moved.
            self._contact_frames = np.concatenate([self._contact_frames, np.eye(4)[None]])
        k = len(contact_frames)
        if k:
            frames = np.asarray(contact_frames, dtype=float).reshape(k, 4, 4)
            shown = self._contact_frames[:k]
            moved = ~(np.abs(frames[:, :3, 3] - shown[:, :3, 3]).max(axis=1) < SEND_TOLERANCE)
            turned = ~(
                np.abs(frames[:, :3, :3] - shown[:, :3, :3]).max(axis=(1, 2)) < SEND_TOLERANCE
            )
            for i in np.flatnonzero(moved | turned):
                T = frames[i]
                position = T[:3, 3] if moved[i] else None
                wxyz = matrix_to_wxyz(T[:3, :3]) if turned[i] else None
                push_pose(self._contacts[i], position, wxyz)
                if moved[i]:
                    shown[i, :3, 3] = T[:3, 3]
                if turned[i]:
                    shown[i, :3, :3] = T[:3, :3]
        self._contacts_shown = _show_first(self._contacts, self._contacts_shown, k * self.visible)

    def update_per_node(self, balance: Balance) -> None:
        """The same scene as `update`, every field assigned through viser's setters each
        time: the reference `update` is checked and timed against."""
        com_world, contact_frames = balance.com_world, balance.contact_frames
        joints_near_limit_m = balance.joint_positions_near_limit
        self._polygon.points = _segments(np.asarray(balance.polygon_xy, dtype=float))
        self._com.position = (float(com_world[0]), float(com_world[1]), COM_Z_M)
        self._com.color = INSIDE_RGB if balance.com_margin_m >= 0.0 else OUTSIDE_RGB
        for i, marker in enumerate(self._limits):
            marker.visible = self.visible and i < len(joints_near_limit_m)
            if i < len(joints_near_limit_m):
                marker.position = joints_near_limit_m[i]
        while len(self._contacts) < len(contact_frames):
            self._contacts.append(
                self._server.scene.add_frame(
                    f"{self.root}/contact_{len(self._contacts)}",
                    axes_length=0.05,
                    axes_radius=0.003,
                )
            )
        for i, frame in enumerate(self._contacts):
            frame.visible = self.visible and i < len(contact_frames)
            if i < len(contact_frames):
                frame.position = contact_frames[i][:3, 3]
                frame.wxyz = matrix_to_wxyz(contact_frames[i][:3, :3])

    def set_visible(self, visible: bool) -> None:
        self.visible = visible
        self._com.visible = visible
        self._polygon.visible = visible
        for node in [*self._limits, *self._contacts]:
            node.visible = visible and node.visible
        # Markers and frames come back with the next update.
        self._limits_shown = sum(node.visible for node in self._limits)
        self._contacts_shown = sum(node.visible for node in self._contacts)

    def remove(self) -> None:
        for node in [self._com, self._polygon, *self._limits, *self._contacts]:
            node.remove()


def _segments(polygon_xy: np.ndarray) -> np.ndarray:
    """(N, 2, 3) float32 line segments around a closed polygon (N, 2), just above the ground."""
    closed = np.concatenate([polygon_xy, polygon_xy[:1]])
    points = np.zeros((len(polygon_xy), 2, 3))
    points[:, 0, :2], points[:, 1, :2] = closed[:-1], closed[1:]
    points[:, :, 2] = POLYGON_Z_M
    return points.astype(np.float32)


def _show_first(nodes: list, shown: int, wanted: int) -> int:
    """Make the first `wanted` nodes visible and the rest hidden, given that the first `shown`
    are visible now: only the nodes between the two counts flip. Returns `wanted`."""
    for i in range(min(shown, wanted), max(shown, wanted)):
        nodes[i].visible = i < wanted
    return wanted
