"""Ghost robots: the same robot drawn several times, each in one translucent colour, for
comparing motions (planned, commanded, predicted) sample by sample.

All ghosts share one batched scene node per visual mesh, one instance per ghost (its colour,
its world pose; scale 0 while it is hidden or has no pose). A frame of playback is then one
pose message per mesh that moved, for every ghost at once, instead of one per link and ghost:
viser checks and queues each message in Python, which is most of a frame's cost.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import viser

from app.core.quaternions import matrices_to_xyzquat
from app.core.robot.model import RobotModel

GHOSTS = {
    "planned": ((60, 120, 230), "planned motion"),
    "command": ((40, 170, 80), "compensated servo command"),
    "without": ((220, 50, 50), "quick estimate, no compensation"),
    "with": ((240, 150, 20), "quick estimate, compensated"),
    "sim_without": ((150, 60, 200), "simulated (MuJoCo), no compensation"),
    "sim_with": ((20, 170, 170), "simulated (MuJoCo), compensated"),
}
"""name -> (colour, legend text)."""
OPACITY = 0.4
SEND_TOLERANCE = 1e-9
"""A mesh whose instances moved less than this (m, and quaternion entries) is not re-sent."""


class GhostsView:
    def __init__(self, server: viser.ViserServer, robot: RobotModel, root: str = "/ghosts") -> None:
        self.robot = robot
        self.names = tuple(GHOSTS)
        self._data = robot.model.createData()
        meshes = [mesh for mesh in robot.meshes if mesh.role != "collision"]
        self.mesh_links = tuple(mesh.link for mesh in meshes)
        self._frames = np.array([robot.link_frame_ids[mesh.link] for mesh in meshes], dtype=int)
        self._T_link_mesh = np.array([mesh.T_link_mesh for mesh in meshes]).reshape(-1, 4, 4)
        n = len(self.names)
        self._positions = np.zeros((len(meshes), n, 3))
        self._wxyzs = np.zeros((len(meshes), n, 4))
        self._wxyzs[..., 0] = 1.0
        self._scales = np.zeros(n)
        colours = np.array([rgb for rgb, _ in GHOSTS.values()], dtype=np.uint8)
        with server.atomic():
            self._handles = [
                server.scene.add_batched_meshes_simple(
                    f"{root}/mesh_{i}",
                    mesh.mesh.vertices,
                    mesh.mesh.faces,
                    batched_wxyzs=self._wxyzs[i],
                    batched_positions=self._positions[i],
                    batched_scales=self._scales,
                    batched_colors=colours,
                    opacity=OPACITY,
                    cast_shadow=False,
                    lod="off",
                )
                for i, mesh in enumerate(meshes)
            ]
        self._sent_positions = self._positions.copy()
        self._sent_wxyzs = self._wxyzs.copy()
        self._sent_scales = self._scales.copy()
        self._wanted = dict.fromkeys(GHOSTS, True)
        """What the user's toggles ask for."""
        self._poses: dict[str, np.ndarray] = {}

    def update(self, configurations: dict[str, np.ndarray]) -> None:
        """Place each ghost at its configuration (pinocchio layout): one message per mesh that
        moved, for all ghosts at once (call inside `server.atomic()` to apply them together)."""
        for name, q in configurations.items():
            self._poses[name] = np.asarray(q, dtype=float)
            self._place(name)
        self._send()

    def forget(self, name: str) -> None:
        """Hide a ghost until it gets a pose again (e.g. a simulation that went stale)."""
        if self._poses.pop(name, None) is not None:
            self._send()

    def set_visible(self, name: str, visible: bool) -> None:
        self._wanted[name] = visible
        if visible and name in self._poses:
            self._place(name)
        self._send()

    def shown(self, name: str) -> bool:
        """Whether the ghost is drawn (wanted, and has a pose)."""
        return bool(self._sent_scales[self.names.index(name)] > 0.0)

    def mesh_poses(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """World (positions (M, 3), wxyz (M, 4)) of a ghost's meshes, as last sent (one row per
        visual mesh, in `mesh_links` order)."""
        g = self.names.index(name)
        return self._sent_positions[:, g].copy(), self._sent_wxyzs[:, g].copy()

    def _place(self, name: str) -> None:
        if not self._wanted[name]:
            return
        model, data = self.robot.model, self._data
        pin.framesForwardKinematics(model, data, self._poses[name])
        T_world_link = np.array([data.oMf[int(f)].homogeneous for f in self._frames])
        xyzquat = matrices_to_xyzquat((T_world_link @ self._T_link_mesh).reshape(-1, 4, 4))
        g = self.names.index(name)
        self._positions[:, g] = xyzquat[:, :3]
        wxyz = xyzquat[:, [6, 3, 4, 5]]
        # one sign per rotation, so that an unchanged mesh is recognised as unchanged
        self._wxyzs[:, g] = np.where(wxyz[:, :1] < 0.0, -wxyz, wxyz)

    def _send(self) -> None:
        self._scales = np.array(
            [1.0 if self._wanted[name] and name in self._poses else 0.0 for name in self.names]
        )
        rescaled = not np.array_equal(self._scales, self._sent_scales)
        shown = self._scales > 0.0
        for i, handle in enumerate(self._handles):
            moved = np.abs(self._positions[i] - self._sent_positions[i])[shown]
            turned = np.abs(self._wxyzs[i] - self._sent_wxyzs[i])[shown]
            if moved.size and moved.max() >= SEND_TOLERANCE:
                handle.batched_positions = self._positions[i].copy()
                self._sent_positions[i] = self._positions[i]
            if turned.size and turned.max() >= SEND_TOLERANCE:
                handle.batched_wxyzs = self._wxyzs[i].copy()
                self._sent_wxyzs[i] = self._wxyzs[i]
            if rescaled:
                handle.batched_scales = self._scales.astype(np.float32)
        self._sent_scales = self._scales.copy()

    def remove(self) -> None:
        for handle in self._handles:
            handle.remove()
