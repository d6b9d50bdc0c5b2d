"""A camera that follows the robot: every tab's camera slides so that it keeps looking at the
robot's pelvis over the ground, at the distance, height and angle the user chose.

Only the horizontal position is followed (the pelvis bobs a few centimetres every step; a
camera that bobs with it is tiring to watch). viser moves a camera and its look-at point
together when its position is set, so the user's orbit is kept. Moves are throttled: playback
asks at 60 Hz.
"""

from __future__ import annotations

import numpy as np
import viser

from app.studio.signals import Signal
from app.studio.throttle import Throttle

FOLLOW_PERIOD_S = 1.0 / 20.0


def follow_offset(look_at: np.ndarray, target_xyz: np.ndarray) -> np.ndarray:
    """How far [m] to slide a camera looking at `look_at` so that it looks at `target_xyz`
    from above the same ground point: shape (3,), z = 0."""
    offset = np.asarray(target_xyz, dtype=float) - np.asarray(look_at, dtype=float)
    return np.array([offset[0], offset[1], 0.0])


class CameraFollower:
    """Slides the cameras of every tab whose camera is known towards a target."""

    def __init__(self, server: viser.ViserServer) -> None:
        self._server = server
        self._known: set[int] = set()
        """Tabs that reported their camera (reading one before that is an error in viser)."""
        self._throttle: Throttle[np.ndarray] = Throttle(
            FOLLOW_PERIOD_S, self._follow, name="camera-follow"
        )
        self.followed: Signal[np.ndarray] = Signal("camera_followed")
        """Emitted with the target [m] (3,) after the cameras were moved towards it."""
        server.on_client_connect(self._on_connect)
        server.on_client_disconnect(lambda client: self._known.discard(client.client_id))

    def _on_connect(self, client: viser.ClientHandle) -> None:
        client.camera.on_update(lambda camera: self._known.add(camera.client.client_id))

    def follow(self, target_xyz: np.ndarray) -> None:
        self._throttle.submit(np.array(target_xyz, dtype=float))

    def stop(self) -> None:
        self._throttle.cancel()

    def _follow(self, target_xyz: np.ndarray) -> None:
        for client in self._server.get_clients().values():
            if client.client_id not in self._known:
                continue
            camera = client.camera
            offset = follow_offset(camera.look_at, target_xyz)
            if np.linalg.norm(offset) > 1e-4:
                with client.atomic():  # position and look-at arrive together
                    camera.position = camera.position + offset  # look_at slides with it
        self.followed.emit(target_xyz)
