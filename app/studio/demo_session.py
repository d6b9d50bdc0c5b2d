"""Demo mode: a tab can follow the presenter's camera.

The presenter is the tab that last moved its camera while not following. Each camera message
from it is copied to every following tab (up direction, position, look-at, field of view). A
following tab's own camera messages (including the echoes of those copies) never make it the
presenter. The robot, the motion and the timeline are already shared by every tab (one
StudioState), so a follower sees the presenter's scene from the presenter's eye.
"""

from __future__ import annotations

import threading

import viser

from panels.demo_panel import DemoPanel


class DemoSession:
    def __init__(self, server: viser.ViserServer) -> None:
        self._server = server
        self._lock = threading.Lock()
        self._panels: dict[int, DemoPanel] = {}
        self._following: set[int] = set()
        self.presenter: int | None = None
        """client_id of the tab whose camera followers copy."""
        server.on_client_connect(self._on_connect)
        server.on_client_disconnect(self._on_disconnect)

    @property
    def followers(self) -> frozenset[int]:
        """client_ids of the tabs following the presenter."""
        with self._lock:
            return frozenset(self._following)

    def _on_connect(self, client: viser.ClientHandle) -> None:
        panel = DemoPanel(client, self)
        with self._lock:
            self._panels[client.client_id] = panel
        client.camera.on_update(lambda camera: self._on_camera(client))

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._panels.pop(client.client_id, None)
            self._following.discard(client.client_id)
            if self.presenter == client.client_id:
                self.presenter = None

    # --- actions (DemoActions) ---------------------------------------------------------------

    def set_following(self, client: viser.ClientHandle, following: bool) -> None:
        with self._lock:
            if following:
                self._following.add(client.client_id)
            else:
                self._following.discard(client.client_id)
            presenter = self.presenter
        if following and presenter is not None and presenter != client.client_id:
            source = self._server.get_clients().get(presenter)
            if source is not None:
                _copy_camera(source, client)

    # --- camera ------------------------------------------------------------------------------

    def _on_camera(self, client: viser.ClientHandle) -> None:
        with self._lock:
            if client.client_id in self._following:
                return
            self.presenter = client.client_id
            followers = [i for i in self._following if i != client.client_id]
        clients = self._server.get_clients()
        for follower_id in followers:
            follower = clients.get(follower_id)
            if follower is not None:
                _copy_camera(client, follower)


def _copy_camera(source: viser.ClientHandle, target: viser.ClientHandle) -> None:
    camera = source.camera
    up, position = camera.up_direction.copy(), camera.position.copy()
    look_at, fov = camera.look_at.copy(), camera.fov
    with target.atomic():
        target.camera.up_direction = up
        target.camera.position = position
        target.camera.look_at = look_at
        target.camera.fov = fov
