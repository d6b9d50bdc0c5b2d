"""A project's camera restored in a real Chromium tab: the page reports the saved view back
(its own camera messages, not the server's copy), draws a different picture than before, and
the project is not left dirty by the page's echoes."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.config import StudioConfig
from app.core.projects.display import CameraView
from app.core.projects.files import save_project
from app.studio import Studio
from tests.browser.conftest import VIEWPORT, _free_port
from tests.browser.page_helpers import (
    UI_TIMEOUT_S,
    changed,
    dismiss_software_webgl_warning,
    not_blank,
    studio_context,
    wait_for,
    wait_stable,
)

SIDE = CameraView(position=(0.05, -1.3, 0.4), look_at=(0.0, 0.0, 0.28), fov_deg=55.0)
"""A side view, far from the studio's framing (front-right, above)."""


def test_an_opened_project_puts_its_camera_in_the_tab(chromium, tmp_path):
    studio = Studio(StudioConfig(port=_free_port(), data_dir=tmp_path / "data"))
    context = studio_context(chromium, viewport=VIEWPORT)
    try:
        work = studio.project.project()
        path = tmp_path / "side.bstudio"
        save_project(
            path, dataclasses.replace(work, display=dataclasses.replace(work.display, camera=SIDE))
        )
        page = context.new_page()
        page.set_default_timeout(120_000)
        page.goto(studio.web.url)
        dismiss_software_webgl_warning(page)
        before = wait_stable(page, "the studio's first render", not_blank)
        (client,) = studio.web.server.get_clients().values()
        reported: list[np.ndarray] = []
        client.camera.on_update(lambda camera: reported.append(camera.position.copy()))

        assert studio.project.open(path, trusted=True), studio.project.last_error
        wait_for(
            "the tab to report the saved view",
            lambda: any(np.allclose(p, SIDE.position, atol=1e-6) for p in reported),
            UI_TIMEOUT_S,
        )
        after = wait_stable(page, "the restored view", not_blank)
        assert changed(after, before).mean() > 0.02  # another picture: the robot from the side
        wait_for("the echoes to settle", lambda: not studio.project.dirty, UI_TIMEOUT_S)
        kept = studio.state.display.settings.camera
        assert kept is not None and kept.near(SIDE)
        assert np.allclose(client.camera.look_at, SIDE.look_at, atol=1e-6)
        assert abs(np.degrees(client.camera.fov) - SIDE.fov_deg) < 1e-6
    finally:
        context.close()
        studio.stop()
