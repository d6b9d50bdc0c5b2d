"""The robot in the 3D scene: one root node, a frame per link, its meshes, CoM marker.

An overlay owns its scene nodes: `update(q)` moves them, `set_visible` toggles layers, and
`remove` drops the whole robot at once. No computation beyond forward kinematics happens here.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import viser

from app.core.model import RobotModel
from app.core.quaternions import matrix_to_wxyz

DEFAULT_RGB = (150, 156, 168)
COLLISION_RGB = (255, 140, 40)
COM_RGB = (230, 40, 90)


class RobotView:
    """Scene nodes of one robot under `root`."""

    def __init__(self, server: viser.ViserServer, robot: RobotModel, root: str = "/robot") -> None:
        self.robot = robot
        self.root = root
        self.data = robot.model.createData()
        self._links = sorted({mesh.link for mesh in robot.meshes} | set(robot.link_frame_ids))
        self._link_frames: dict[str, viser.FrameHandle] = {}
        self._visuals: list[viser.SceneNodeHandle] = []
        self._collisions: list[viser.SceneNodeHandle] = []
        self._axes: list[viser.FrameHandle] = []
        height_m = max(0.2, float(robot.q_neutral[2]) if robot.floating_base else 1.0)
        self.axes_length_m = 0.08 * height_m
        with server.atomic():
            self._build(server.scene)

    def _build(self, scene: viser.SceneApi) -> None:
        for i, link in enumerate(self._links):
            frame = scene.add_frame(f"{self.root}/links/{i}", show_axes=False)
            self._link_frames[link] = frame
            self._axes.append(
                scene.add_frame(
                    f"{self.root}/links/{i}/axes",
                    axes_length=self.axes_length_m,
                    axes_radius=self.axes_length_m * 0.05,
                    visible=False,
                )
            )
        counts: dict[str, int] = {}
        for mesh in self.robot.meshes:
            i = self._links.index(mesh.link)
            k = counts[mesh.link] = counts.get(mesh.link, -1) + 1
            name = f"{self.root}/links/{i}/{mesh.role}_{k}"
            wxyz = matrix_to_wxyz(mesh.T_link_mesh[:3, :3])
            position = mesh.T_link_mesh[:3, 3]
            if mesh.role == "collision":
                handle = scene.add_mesh_simple(
                    name,
                    mesh.mesh.vertices,
                    mesh.mesh.faces,
                    color=COLLISION_RGB,
                    opacity=0.45,
                    wxyz=wxyz,
                    position=position,
                    visible=False,
                )
                self._collisions.append(handle)
                continue
            if mesh.rgba is not None:
                rgb = (int(255 * mesh.rgba[0]), int(255 * mesh.rgba[1]), int(255 * mesh.rgba[2]))
                opacity = mesh.rgba[3] if mesh.rgba[3] < 1.0 else None
                handle = scene.add_mesh_simple(
                    name,
                    mesh.mesh.vertices,
                    mesh.mesh.faces,
                    color=rgb,
                    opacity=opacity,
                    wxyz=wxyz,
                    position=position,
                )
            else:
                handle = scene.add_mesh_simple(
                    name,
                    mesh.mesh.vertices,
                    mesh.mesh.faces,
                    color=DEFAULT_RGB,
                    wxyz=wxyz,
                    position=position,
                )
            self._visuals.append(handle)
        self._com = scene.add_icosphere(
            f"{self.root}/com", radius=0.02, color=COM_RGB, visible=False
        )
        self._com_ground = scene.add_icosphere(
            f"{self.root}/com_ground", radius=0.012, color=COM_RGB, opacity=0.6, visible=False
        )

    def update(self, q: np.ndarray) -> None:
        """Move every link to its placement at configuration q."""
        pin.framesForwardKinematics(self.robot.model, self.data, q)
        oMf = self.data.oMf
        for link, frame in self._link_frames.items():
            fid = self.robot.link_frame_ids.get(link)
            if fid is None:
                continue
            placement = oMf[fid]
            frame.position = placement.translation
            frame.wxyz = matrix_to_wxyz(placement.rotation)
        if self._com.visible:
            com = pin.centerOfMass(self.robot.model, self.data, q, False)
            self._com.position = com
            self._com_ground.position = (com[0], com[1], 0.0)

    def link_pose(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """(position, wxyz) of a link's node as last sent to the scene."""
        frame = self._link_frames[link]
        return np.asarray(frame.position), np.asarray(frame.wxyz)

    def set_visible(self, *, visual: bool, collision: bool, frames: bool, com: bool) -> None:
        for handle in self._visuals:
            handle.visible = visual
        for handle in self._collisions:
            handle.visible = collision
        for handle in self._axes:
            handle.visible = frames
        self._com.visible = com
        self._com_ground.visible = com

    def remove(self) -> None:
        for frame in self._link_frames.values():
            frame.remove()
        self._com.remove()
        self._com_ground.remove()
