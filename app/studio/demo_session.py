"""Demo mode: a tab can follow the presenter's camera.

The presenter is the tab that last moved its camera while not following. Each camera message
from it is copied to every following tab (up direction, position, look-at, field of view). A
following tab's own camera messages (including the echoes of those copies) never make it the
presenter. The robot, the motion and the timeline are already shared by every tab (one
StudioState), so a follower sees the presenter's scene from the presenter's eye.

Presenter only (`serve --presenter-only`): only the *editing tab* may change the work — the
oldest tab still open (the first one opened; when it closes, the next oldest). Every other
tab's GUI edits, uploads and key commands are refused before any callback runs (app.web.gui_gate),
its widget snaps back to the server's value, and it is told so. Its own Demo folder stays usable.
"""

from __future__ import annotations

import threading
import time

import viser

from app.web.gui_gate import gate_gui_edits
from panels.demo_panel import DemoPanel

REFUSAL_NOTICE_S = 3.0
"""A refused tab is told at most once in this long (a drag sends many edits)."""


class DemoSession:
    def __init__(self, server: viser.ViserServer, presenter_only: bool = False) -> None:
        self._server = server
        self.presenter_only = presenter_only
        self.refused = 0
        """Edits refused so far (presenter only)."""
        self._told: dict[int, float] = {}
        self._lock = threading.Lock()
        self._panels: dict[int, DemoPanel] = {}
        self._following: set[int] = set()
        self.presenter: int | None = None
        """client_id of the tab whose camera followers copy."""
        server.on_client_connect(self._on_connect)
        server.on_client_disconnect(self._on_disconnect)
        if presenter_only:
            gate_gui_edits(server, self.may_edit, self._on_refused)

    @property
    def editor(self) -> int | None:
        """client_id of the tab that may edit under presenter only: the oldest one open."""
        ids = list(self._server.get_clients())
        return min(ids) if ids else None

    def may_edit(self, client_id: int) -> bool:
        return not self.presenter_only or client_id == self.editor

    def _on_refused(self, client_id: int) -> None:
        self.refused += 1
        now = time.monotonic()
        if now - self._told.get(client_id, -REFUSAL_NOTICE_S) < REFUSAL_NOTICE_S:
            return
        self._told[client_id] = now
        client = self._server.get_clients().get(client_id)
        if client is not None:
            client.add_notification(
                "Presenter only",
                "This studio is in presenter-only mode: only the presenter's tab (the first "
                "one opened) can change the work. You can still follow the presenter.",
                color="yellow",
                auto_close_seconds=6.0,
            )

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
