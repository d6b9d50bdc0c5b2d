"""The robot in the 3D scene: one root node, a frame per link, its meshes, CoM marker.

An overlay owns its scene nodes: `update(q)` moves them, `set_visible` toggles layers, and
`remove` drops the whole robot at once. No computation beyond forward kinematics happens here.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import viser

from app.core.quaternions import matrices_to_xyzquat, matrix_to_wxyz, wxyz_to_matrix
from app.core.robot.model import RobotModel
from app.views.pose_push import push_pose

DEFAULT_RGB = (150, 156, 168)
COLLISION_RGB = (255, 140, 40)
COM_RGB = (230, 40, 90)
SEND_TOLERANCE = 1e-7
"""A node whose relative placement changed less than this (m, and rotation-matrix entries)
since it was last sent is not re-sent: far below what a screen shows, far above the IK's
rounding residue on links that did not move."""


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
        self._parent_index = np.array(
            [self._links.index(p) if (p := self._parent[link]) else -1 for link in self._links]
        )
        self._shown: np.ndarray | None = None
        """(links, 4, 4) placement of each link's node relative to its parent link's node, as
        last sent (None: nothing sent yet)."""
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
        """Move every link to its placement at configuration q: one pass of forward
        kinematics, the changed nodes found at once against what the scene shows, and only
        their pose fields queued (app.views.pose_push, without viser's per-setter check)."""
        pin.framesForwardKinematics(self.robot.model, self.data, q)
        relative = self._relative_placements()
        if self._shown is None:
            moved = turned = np.ones(len(self._links), dtype=bool)
        else:
            moved = np.abs(relative[:, :3, 3] - self._shown[:, :3, 3]).max(axis=1) >= SEND_TOLERANCE
            turned = (
                np.abs(relative[:, :3, :3] - self._shown[:, :3, :3]).max(axis=(1, 2))
                >= SEND_TOLERANCE
            )
            self._shown = self._shown.copy()
        shown = relative.copy() if self._shown is None else self._shown
        changed = np.flatnonzero(moved | turned)
        quats = _wxyz_of(relative[changed])  # all at once: per matrix, most of an update
        for i, wxyz in zip(changed, quats, strict=True):
            frame = self._link_frames[self._links[i]]
            # A revolute joint turns its link without moving it: send only what changed.
            position = relative[i, :3, 3] if moved[i] else None
            push_pose(frame, position, wxyz if turned[i] else None)
            if moved[i]:
                shown[i, :3, 3] = relative[i, :3, 3]
            if turned[i]:
                shown[i, :3, :3] = relative[i, :3, :3]
        self._shown = shown  # what the scene shows: creeping changes still get sent
        self._update_com(q)

    def update_per_node(self, q: np.ndarray) -> None:
        """The same scene through viser's setters, every link's position and orientation
        assigned one by one: the reference the batched `update` is checked and timed against."""
        pin.framesForwardKinematics(self.robot.model, self.data, q)
        for link, relative in zip(self._links, self._relative_placements(), strict=True):
            frame = self._link_frames[link]
            frame.position = relative[:3, 3]
            frame.wxyz = matrix_to_wxyz(relative[:3, :3])
        self._shown = None
        self._update_com(q)

    def _relative_placements(self) -> np.ndarray:
        """(links, 4, 4) placement of each link relative to its parent link, from self.data."""
        oMf, ids = self.data.oMf, self.robot.link_frame_ids
        world = np.array([oMf[ids[link]].homogeneous for link in self._links])
        parents = self._parent_index
        relative = world.copy()
        has_parent = parents >= 0
        parent_T = world[parents[has_parent]]
        R_t = np.transpose(parent_T[:, :3, :3], (0, 2, 1))
        child = world[has_parent]
        relative[has_parent, :3, :3] = R_t @ child[:, :3, :3]
        relative[has_parent, :3, 3] = np.einsum(
            "nij,nj->ni", R_t, child[:, :3, 3] - parent_T[:, :3, 3]
        )
        return relative

    def _update_com(self, q: np.ndarray) -> None:
        if self._com.visible:
            com = pin.centerOfMass(self.robot.model, self.data, q, False)
            push_pose(self._com, com)
            push_pose(self._com_ground, np.array([com[0], com[1], 0.0]))

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


def _wxyz_of(T: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4) (w, x, y, z), w >= 0, of transforms (n, 4, 4): what
    matrix_to_wxyz gives for each, in one vectorised pass."""
    xyzw = matrices_to_xyzquat(T)[:, 3:7]
    wxyz = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)
    wxyz /= np.linalg.norm(wxyz, axis=1, keepdims=True)
    wxyz[wxyz[:, 0] < 0.0] *= -1.0
    return wxyz


def _tree_order(robot: RobotModel) -> list[str]:
    """Links with a pinocchio frame, parents before children (breadth first from the root)."""
    order, queue = [], [robot.tree.root]
    while queue:
        link = queue.pop(0)
        if link in robot.link_frame_ids:
            order.append(link)
        queue.extend(joint.child for joint in robot.tree.children_of(link))
    return order
