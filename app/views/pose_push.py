"""Pose messages for scene nodes without viser's per-setter checks.

Assigning `handle.position` or `handle.wxyz` makes viser cast the value, compare it with
`np.allclose` and queue one message: on the drag path that check is most of the cost of a
scene update, and the caller has already decided (vectorised, against a display tolerance)
which nodes changed. `push_pose` records the new value in the handle (so `handle.position`
reads back what was sent, exactly as after an assignment) and queues the same message
viser's setter would (through app.web.viser_internals, viser having no public way to).
"""

from __future__ import annotations

import numpy as np
import viser

from app.web.viser_internals import queue_node_pose


def push_pose(
    handle: viser.SceneNodeHandle,
    position: np.ndarray | None = None,
    wxyz: np.ndarray | None = None,
) -> None:
    """Set a node's position (3,) and/or orientation (4,) and queue the messages, unchecked."""
    queue_node_pose(
        handle,
        None if position is None else (float(position[0]), float(position[1]), float(position[2])),
        None if wxyz is None else (float(wxyz[0]), float(wxyz[1]), float(wxyz[2]), float(wxyz[3])),
    )
