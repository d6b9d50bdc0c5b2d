"""Balance overlay: the support polygon, the CoM's ground projection (green inside, red
outside), contact frames on the soles, and markers on joints near a limit."""

from __future__ import annotations

import numpy as np
import viser

from app.core.quaternions import matrix_to_wxyz
from app.views.pose_push import push_pose

INSIDE_RGB = (40, 170, 80)
OUTSIDE_RGB = (220, 40, 40)
POLYGON_RGB = (30, 110, 220)
LIMIT_RGB = (255, 150, 0)


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

    def update(
        self,
        polygon_xy: np.ndarray,
        com_world: np.ndarray,
        com_inside: bool,
        joints_near_limit_m: list[np.ndarray],
        contact_frames: list[np.ndarray],
    ) -> None:
        """polygon_xy (N, 2) [m]; com_world (3,); positions of joints near a limit; 4x4 contact frames."""
        closed = np.concatenate([polygon_xy, polygon_xy[:1]])
        points = np.zeros((len(polygon_xy), 2, 3))
        points[:, 0, :2], points[:, 1, :2] = closed[:-1], closed[1:]
        points[:, :, 2] = 0.002
        self._polygon.points = points.astype(np.float32)
        push_pose(self._com, np.array([com_world[0], com_world[1], 0.003]))
        self._com.color = INSIDE_RGB if com_inside else OUTSIDE_RGB
        for i, marker in enumerate(self._limits):
            marker.visible = self.visible and i < len(joints_near_limit_m)
            if i < len(joints_near_limit_m):
                push_pose(marker, joints_near_limit_m[i])
        while len(self._contacts) < len(contact_frames):
            i = len(self._contacts)
            self._contacts.append(
                self._server.scene.add_frame(
                    f"{self.root}/contact_{i}", axes_length=0.05, axes_radius=0.003
                )
            )
        for frame, T in zip(self._contacts, contact_frames, strict=False):
            push_pose(frame, T[:3, 3], matrix_to_wxyz(T[:3, :3]))
            frame.visible = self.visible

    def set_visible(self, visible: bool) -> None:
        self.visible = visible
        self._com.visible = visible
        self._polygon.visible = visible
        for node in [*self._limits, *self._contacts]:
            node.visible = visible and node.visible

    def remove(self) -> None:
        for node in [self._com, self._polygon, *self._limits, *self._contacts]:
            node.remove()
