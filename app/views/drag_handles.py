"""Transform gizmos on the feet and the pelvis: drag them and the robot follows (IK).

The overlay only reports where the user dragged a handle (`on_drag(which, T_world, released)`:
released on the event that ends the drag, at the pose of the last move) and is
told where to sit afterwards (`place`). It owns its scene nodes under one root.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import viser

from app.core.quaternions import matrix_to_wxyz, wxyz_to_matrix
from app.views.pose_push import push_pose
from app.views.robot_view import SEND_TOLERANCE

HANDLES = ("left", "right", "pelvis")


class DragHandles:
    def __init__(
        self,
        server: viser.ViserServer,
        frames: dict[str, str],
        scale_m: float,
        on_drag: Callable[[str, np.ndarray, bool], None],
        root: str = "/drag",
    ) -> None:
        """frames maps "left"/"right"/"pelvis" to the link each handle sits on."""
        self.frames = frames
        self.held: set[str] = set()
        """The handles a tab holds now (grabbed, not yet released)."""
        self._controls: dict[str, viser.TransformControlsHandle] = {}
        for which in HANDLES:
            control = server.scene.add_transform_controls(
                f"{root}/{which}", scale=scale_m, line_width=2.0, depth_test=False, opacity=0.85
            )
            control.on_update(self._callback(which, control, on_drag))
            self._controls[which] = control

    def _callback(self, which: str, control: viser.TransformControlsHandle, on_drag):
        def callback(event: viser.TransformControlsEvent) -> None:
            phase = getattr(event, "phase", "update")
            if phase == "start":
                self.held.add(which)
            elif phase == "end":
                self.held.discard(which)
            T = transform_of(np.asarray(control.position), np.asarray(control.wxyz))
            on_drag(which, T, phase == "end")

        return callback

    def place(self, placements: dict[str, np.ndarray], skip: str | None = None) -> None:
        """Move the handles onto their links (except the one being dragged)."""
        for which, control in self._controls.items():
            if which == skip:
                continue
            T = placements[self.frames[which]]
            wxyz = matrix_to_wxyz(T[:3, :3])
            if (
                np.abs(T[:3, 3] - control.position).max() >= SEND_TOLERANCE
                or np.abs(wxyz - control.wxyz).max() >= SEND_TOLERANCE
            ):
                push_pose(control, T[:3, 3], wxyz)

    def handle(self, which: str) -> viser.TransformControlsHandle:
        """The gizmo of "left", "right" or "pelvis" (its scale, and where a drag left it)."""
        return self._controls[which]

    def set_visible(self, visible: bool) -> None:
        for control in self._controls.values():
            control.visible = visible

    def remove(self) -> None:
        for control in self._controls.values():
            control.remove()


def transform_of(position: np.ndarray, wxyz: np.ndarray) -> np.ndarray:
    """4x4 transform from a viser position and (w, x, y, z) quaternion."""
    T = np.eye(4)
    T[:3, :3] = wxyz_to_matrix(wxyz)
    T[:3, 3] = position
    return T
