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
ERROR_FULL_SCALE_M = 0.03
"""Error colouring: a link this far [m] (or farther) from the plan's is drawn red; at 0, green."""


def error_colours(errors_m: np.ndarray, full_scale_m: float = ERROR_FULL_SCALE_M) -> np.ndarray:
    """RGB (N, 3) uint8 for position errors [m] (N,): green at 0, yellow at half the full
    scale, red at the full scale and beyond."""
    t = np.clip(np.asarray(errors_m, dtype=float) / full_scale_m, 0.0, 1.0)
    rgb = np.stack(
        [np.minimum(1.0, 2.0 * t), np.minimum(1.0, 2.0 * (1.0 - t)), np.full_like(t, 0.15)]
    )
    return np.round(255.0 * rgb.T).astype(np.uint8)


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
        self._colours = np.repeat(colours[None], len(meshes), axis=0)
        """(meshes, ghosts, 3) colour of each instance, as last sent."""
        self.error_ghost: str | None = None
        """The ghost whose links are coloured by their distance from the plan's (None: none)."""
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
        self._colour_errors()

    def colour_by_error(self, name: str | None) -> None:
        """Colour ghost `name`'s links by their distance from the planned ones (green → red,
        ERROR_FULL_SCALE_M), or give every ghost back its own colour (None)."""
        self.error_ghost = name if name in self.names else None
        self._colour_errors()

    def link_errors_m(self, name: str) -> np.ndarray | None:
        """Per visual mesh (`mesh_links` order), the distance [m] of its link's origin in ghost
        `name` from the plan's; None without both poses."""
        if name not in self._poses or "planned" not in self._poses:
            return None
        model, data = self.robot.model, self._data
        origins = []
        for q in (self._poses[name], self._poses["planned"]):
            pin.framesForwardKinematics(model, data, q)
            origins.append(np.array([data.oMf[int(f)].translation for f in self._frames]))
        return np.linalg.norm(origins[0] - origins[1], axis=1)

    def colours(self, name: str) -> np.ndarray:
        """RGB (M, 3) of a ghost's meshes, as last sent."""
        return self._colours[:, self.names.index(name)].copy()

    def _colour_errors(self) -> None:
        wanted = self._colours.copy()
        wanted[:] = np.array([rgb for rgb, _ in GHOSTS.values()], dtype=np.uint8)[None]
        if self.error_ghost is not None:
            errors = self.link_errors_m(self.error_ghost)
            if errors is not None:
                wanted[:, self.names.index(self.error_ghost)] = error_colours(errors)
        for i, handle in enumerate(self._handles):
            if not np.array_equal(wanted[i], self._colours[i]):
                handle.batched_colors = wanted[i].copy()
        self._colours = wanted

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
