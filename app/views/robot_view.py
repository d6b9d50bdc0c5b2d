"""The robot in the 3D scene: one root node, a frame per link, its meshes, CoM marker.

An overlay owns its scene nodes: `update(q)` moves them, `set_visible` toggles layers, and
`remove` drops the whole robot at once. No computation beyond forward kinematics happens here.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import viser

from app.core.quaternions import matrix_to_wxyz, wxyz_to_matrix
from app.core.robot.model import RobotModel

DEFAULT_RGB = (150, 156, 168)
COLLISION_RGB = (255, 140, 40)
COM_RGB = (230, 40, 90)
SEND_TOLERANCE = 1e-9
"""A node whose relative placement changed less than this (m, and rotation-matrix entries)
is not re-sent."""


class RobotView:
    """Scene nodes of one robot under `root`."""

    def __init__(
        self,
        server: viser.ViserServer,
        robot: RobotModel,
        root: str = "/robot",
        tint_rgb: tuple[int, int, int] | None = None,
        opacity: float | None = None,
        with_collision: bool = True,
    ) -> None:
        """tint_rgb and opacity draw every visual mesh in one colour (a "ghost" of the robot)."""
        self.robot = robot
        self.root = root
        self._tint, self._opacity, self._with_collision = tint_rgb, opacity, with_collision
        self.data = robot.model.createData()
        self._links = _tree_order(robot)
        self._parent = {
            link: (joint.parent if (joint := robot.tree.parent_joint(link)) else None)
            for link in self._links
        }
        self._link_frames: dict[str, viser.FrameHandle] = {}
        self._sent: dict[str, np.ndarray] = {}
        """Placement of each link's node relative to its parent link's node, as last sent."""
        self._visuals: list[viser.SceneNodeHandle] = []
        self._collisions: list[viser.SceneNodeHandle] = []
        self._axes: list[viser.FrameHandle] = []
        height_m = max(0.2, float(robot.q_neutral[2]) if robot.floating_base else 1.0)
        self.axes_length_m = 0.08 * height_m
        with server.atomic():
            self._build(server.scene)

    def _build(self, scene: viser.SceneApi) -> None:
        # Link nodes nest like the kinematic tree, each placed relative to its parent link, so
        # a joint change re-sends one node and a base move re-sends only the base.
        self._node: dict[str, str] = {}
        for i, link in enumerate(self._links):
            parent = self._parent[link]
            self._node[link] = f"{self._node[parent]}/{i}" if parent else f"{self.root}/links/{i}"
            frame = scene.add_frame(self._node[link], show_axes=False)
            self._link_frames[link] = frame
            self._axes.append(
                scene.add_frame(
                    f"{self._node[link]}/axes",
                    axes_length=self.axes_length_m,
                    axes_radius=self.axes_length_m * 0.05,
                    visible=False,
                )
            )
        counts: dict[str, int] = {}
        for mesh in self.robot.meshes:
            k = counts[mesh.link] = counts.get(mesh.link, -1) + 1
            name = f"{self._node[mesh.link]}/{mesh.role}_{k}"
            wxyz = matrix_to_wxyz(mesh.T_link_mesh[:3, :3])
            position = mesh.T_link_mesh[:3, 3]
            if mesh.role == "collision":
                if not self._with_collision:
                    continue
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
            rgb, opacity = DEFAULT_RGB, self._opacity
            if self._tint is not None:
                rgb = self._tint
            elif mesh.rgba is not None:
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
                cast_shadow=self._tint is None,
            )
            self._visuals.append(handle)
        self._com = scene.add_icosphere(
            f"{self.root}/com", radius=0.02, color=COM_RGB, visible=False
        )
        self._com_ground = scene.add_icosphere(
            f"{self.root}/com_ground", radius=0.012, color=COM_RGB, opacity=0.6, visible=False
        )

    def update(self, q: np.ndarray) -> None:
        """Move every link to its placement at configuration q (only changed nodes are sent)."""
        pin.framesForwardKinematics(self.robot.model, self.data, q)
        oMf, ids = self.data.oMf, self.robot.link_frame_ids
        for link, frame in self._link_frames.items():
            parent = self._parent[link]
            T = oMf[ids[link]] if parent is None else oMf[ids[parent]].actInv(oMf[ids[link]])
            relative = T.homogeneous
            last = self._sent.get(link)
            # A revolute joint turns its link without moving it: send only what changed (each
            # pose field is one message, and one more check inside viser).
            moved = last is None or np.abs(relative[:3, 3] - last[:3, 3]).max() >= SEND_TOLERANCE
            turned = last is None or np.abs(relative[:3, :3] - last[:3, :3]).max() >= SEND_TOLERANCE
            if not (moved or turned):
                continue
            sent = relative.copy() if last is None else last.copy()
            if moved:
                frame.position = relative[:3, 3]
                sent[:3, 3] = relative[:3, 3]
            if turned:
                frame.wxyz = matrix_to_wxyz(relative[:3, :3])
                sent[:3, :3] = relative[:3, :3]
            self._sent[link] = sent  # what the scene shows: creeping changes still get sent
        if self._com.visible:
            com = pin.centerOfMass(self.robot.model, self.data, q, False)
            self._com.position = com
            self._com_ground.position = (com[0], com[1], 0.0)

    def link_pose(self, link: str) -> tuple[np.ndarray, np.ndarray]:
        """World (position, wxyz) of a link's node, composed from what was sent to the scene."""
        T = np.eye(4)
        node: str | None = link
        while node is not None:
            frame = self._link_frames[node]
            local = np.eye(4)
            local[:3, :3] = wxyz_to_matrix(np.asarray(frame.wxyz))
            local[:3, 3] = frame.position
            T = local @ T
            node = self._parent[node]
        return T[:3, 3], matrix_to_wxyz(T[:3, :3])

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
        """Drop the whole robot: removing the root link node removes its subtree."""
        self._link_frames[self._links[0]].remove()
        self._com.remove()
        self._com_ground.remove()


def _tree_order(robot: RobotModel) -> list[str]:
    """Links with a pinocchio frame, parents before children (breadth first from the root)."""
    order, queue = [], [robot.tree.root]
    while queue:
        link = queue.pop(0)
        if link in robot.link_frame_ids:
            order.append(link)
        queue.extend(joint.child for joint in robot.tree.children_of(link))
    return order
