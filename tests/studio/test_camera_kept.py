"""The camera in the display settings, with a real websocket tab: a tab's starting view is not
work; a burst of camera moves replaces the settings at most once per SAVE_PERIOD_S and ends on
the last view; the autosave holds it."""

from __future__ import annotations

import dataclasses
import math
import time

from app.config import StudioConfig
from app.core.projects.display import CameraView
from app.core.projects.files import read_project
from app.studio import Studio
from app.studio.camera_session import SAVE_PERIOD_S
from tests.studio.conftest import free_port
from tests.studio.ws_tab import CAMERA, Tab, loop, wait

__all__ = ["loop"]  # the fixture, used by name


def test_a_camera_burst_is_kept_once_per_period_and_autosaved(tmp_path, loop):
    studio = Studio(StudioConfig(port=free_port(), data_dir=tmp_path / "data"))
    try:
        tab = Tab(studio, loop)
        wait("the tab's starting view", lambda: len(studio.presenting.camera.tabs) == 1)
        assert studio.state.display.settings.camera is None
        assert studio.project.autosave.now() is None  # opening a tab is not work

        replaced: list[str] = []
        studio.state.on_display.connect(lambda display: replaced.append(display.origin))
        moves = [
            dataclasses.replace(CAMERA, position=(2.0, 0.02 * i, 1.0), fov=0.8)
            for i in range(1, 41)
        ]
        start = time.monotonic()
        for move in moves:
            tab.send(move)
        last = CameraView(
            moves[-1].position, CAMERA.look_at, CAMERA.up_direction, math.degrees(0.8)
        )
        wait("the last view", lambda: studio.state.display.settings.camera == last)
        elapsed_s = time.monotonic() - start
        assert set(replaced) == {"camera"}
        # At most one replacement per period (the first at once), not one per move.
        assert len(replaced) <= 2 + elapsed_s / SAVE_PERIOD_S < len(moves)

        studio.project.autosave.now()  # unless the autosave thread wrote it already
        path = studio.project.autosave.store.latest()
        assert path is not None and read_project(path).display.camera == last
        tab.close()
    finally:
        studio.stop()
