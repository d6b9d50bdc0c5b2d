"""The camera in the display settings: the presenter's view is kept, and an opened project's
view is put back on every tab.

The presenter here is the last tab that moved its camera (a follower's camera is a copy of the
presenter's, app.studio.demo_session). A tab's starting view (its camera when it connects, or
the server's initial camera, which a page settles on after its first message) is not a move
and is not kept. A camera moves at display rate while orbiting: every move is
noted in the state (`StudioState.note_camera`, no new settings), and the settings take the
newest one at most every SAVE_PERIOD_S, or with the next other display change or save, so
autosave never sees sixty changes a second.
"""

from __future__ import annotations

import math
import threading

import numpy as np
import viser

from app.core.projects.display import CameraView, DisplayError
from app.studio.state import Display, StudioState
from app.studio.throttle import Throttle

SAVE_PERIOD_S = 2.0
"""A moving camera replaces the display settings at most this often."""


def camera_view(camera: viser.CameraHandle) -> CameraView:
    """A tab's camera as a CameraView (viser's fov is in radians)."""
    return CameraView(
        position=_xyz(camera.position),
        look_at=_xyz(camera.look_at),
        up=_xyz(camera.up_direction),
        fov_deg=math.degrees(float(camera.fov)),
    )


def _xyz(vector: np.ndarray) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in np.asarray(vector, dtype=float).reshape(3))
    return (x, y, z)


class CameraSession:
    """Keeps the presenter's camera in `StudioState.display`; shows a project's camera."""

    def __init__(self, server: viser.ViserServer, state: StudioState) -> None:
        self._server, self._state = server, state
        self._start: dict[int, CameraView | None] = {}
        """Each open tab's starting view, until it first moves (None after that)."""
        self._lock = threading.Lock()
        self._throttle: Throttle[None] = Throttle(
            SAVE_PERIOD_S, lambda _none: state.flush_camera(), name="camera-keep"
        )
        server.on_client_connect(self._on_connect)
        server.on_client_disconnect(self._on_disconnect)
        state.on_display.connect(self._on_display)

    @property
    def tabs(self) -> frozenset[int]:
        """client_ids of the tabs whose camera is watched (their starting view is known)."""
        with self._lock:
            return frozenset(self._start)

    def _on_connect(self, client: viser.ClientHandle) -> None:
        # viser calls this once the tab's first camera message is in: its starting view.
        try:
            start: CameraView | None = camera_view(client.camera)
        except DisplayError:
            start = None
        with self._lock:
            self._start[client.client_id] = start
        client.camera.on_update(self._on_camera)

    def _on_disconnect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self._start.pop(client.client_id, None)

    def _on_camera(self, camera: viser.CameraHandle) -> None:
        try:
            view = camera_view(camera)  # the newest state, whichever message this call is for
        except DisplayError:  # a degenerate camera a client sent: not kept
            return
        client_id = camera.client.client_id
        with self._lock:
            if client_id not in self._start:
                return
            starting = view.near(self._start[client_id]) or self._at_initial(view)
            if not starting:
                self._start[client_id] = None
        self._state.note_camera(view, starting)
        self._throttle.submit(None)

    def _at_initial(self, view: CameraView) -> bool:
        """Whether `view` stands where a new tab starts (a page settling on the initial camera
        after its first message, or *Reset view*)."""
        initial = self._server.initial_camera
        here = np.array((*view.position, *view.look_at))
        start = np.concatenate([initial.position, initial.look_at])
        return bool(np.allclose(here, start, rtol=1e-4, atol=1e-4))

    def _on_display(self, display: Display) -> None:
        camera = display.settings.camera
        if display.origin != "project" or camera is None:
            return
        initial = self._server.initial_camera
        initial.position, initial.look_at = camera.position, camera.look_at
        initial.up, initial.fov = camera.up, math.radians(camera.fov_deg)
        with self._lock:
            seen = set(self._start)
        for client in self._server.get_clients().values():
            if client.client_id not in seen:  # viser has no camera for it yet: it starts
                continue  # from the initial camera set above
            with client.atomic():
                client.camera.up_direction = camera.up
                client.camera.position = camera.position  # moves look_at along: set it after
                client.camera.look_at = camera.look_at
                client.camera.fov = math.radians(camera.fov_deg)

    def stop(self) -> None:
        self._throttle.cancel()
