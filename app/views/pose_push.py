"""Pose messages for scene nodes without viser's per-setter checks.

Assigning `handle.position` or `handle.wxyz` makes viser cast the value, compare it with
`np.allclose` and queue one message: on the drag path that check is most of the cost of a
scene update, and the caller has already decided (vectorised, against a display tolerance)
which nodes changed. `push_pose` records the new value in the handle (so `handle.position`
reads back what was sent, exactly as after an assignment) and queues the same message
viser's setter would.
"""

from __future__ import annotations

import numpy as np
import viser
from viser import _messages


def push_pose(
    handle: viser.SceneNodeHandle,
    position: np.ndarray | None = None,
    wxyz: np.ndarray | None = None,
) -> None:
    """Set a node's position (3,) and/or orientation (4,) and queue the messages, unchecked."""
    impl = handle._impl
    if impl.removed:
        raise RuntimeError(f"cannot move the removed scene node {impl.name}")
    if position is not None:
        value = (float(position[0]), float(position[1]), float(position[2]))
        impl.position[:] = value
        impl.api._queue_scene_message(_messages.SetPositionMessage(impl.name, value))
    if wxyz is not None:
        quat = (float(wxyz[0]), float(wxyz[1]), float(wxyz[2]), float(wxyz[3]))
        impl.wxyz[:] = quat
        impl.api._queue_scene_message(_messages.SetOrientationMessage(impl.name, quat))
