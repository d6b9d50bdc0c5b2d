"""*Export video* films the current motion from a real Chromium tab's renders: the file lands in
the data folder's exports, decodes (imageio-ffmpeg's reader, not our writer) to the planned
number of frames at the chosen size, its frames change as the robot moves, and the timeline is
back where it was."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from app.config import StudioConfig
from app.studio import Studio
from tests.browser.conftest import VIEWPORT, _free_port
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    click_button,
    collect,
    open_share_page,
    studio_context,
    type_number,
    wait_for,
)

FPS = 4
WIDTH = 320


def _decode(path: Path) -> list[np.ndarray]:
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    return [np.frombuffer(raw, np.uint8).reshape(height, width, 3).copy() for raw in reader]


def test_export_video_films_the_motion_from_the_tab(chromium, tmp_path):
    studio = Studio(StudioConfig(port=_free_port(), data_dir=tmp_path / "data"))
    context = studio_context(chromium, viewport=VIEWPORT)
    saved, done = collect(studio.presenting.share.video_saved)
    try:
        assert studio.motions.generate("com_shift", {})
        trajectory = studio.state.trajectory
        assert trajectory is not None
        shown_before = trajectory.duration / 3
        studio.playback.seek(shown_before)
        page = open_share_page(context, studio.web.url, "Export video")
        type_number(page, "Video fps", FPS)
        type_number(page, "Video width (px)", WIDTH)
        wait_for(
            "the settings to reach the server",
            lambda: (
                studio.presenting.share.panel.video_fps.value == FPS
                and studio.presenting.share.panel.video_width.value == WIDTH
            ),
            UI_TIMEOUT_S,
        )
        click_button(page, "Export video")
        wait_for("the video", done.is_set, RENDER_TIMEOUT_S * 20)
        path = saved[0]
        assert path is not None and path.parent == tmp_path / "data" / "exports"
        assert str(path) in studio.presenting.share.panel.status.content

        frames = _decode(path)
        assert len(frames) == math.floor(trajectory.duration * FPS + 1e-9) + 1
        height, width, _ = frames[0].shape
        assert width == WIDTH and height % 2 == 0
        tab_aspect = VIEWPORT["width"] / VIEWPORT["height"]
        assert abs(width / height - tab_aspect) < 0.1  # the tab's view, not a stretched one
        # The robot moves over the motion: later frames differ from the first (com_shift leans
        # the robot over one foot mid-motion); and no frame is blank.
        first = frames[0].astype(int)
        moved = max(float((np.abs(f.astype(int) - first).max(axis=2) > 40).mean()) for f in frames)
        assert moved > 0.002
        assert all(float(f.std()) > 5.0 for f in frames)
        # The timeline is back where it was before filming.
        assert studio.state.time_s == shown_before
    finally:
        context.close()
        studio.stop()
