"""*Export video* against a real studio with a websocket tab that never renders: a tab that
closes mid-film and settings past the bounds end with a message, no file, and the timeline
where it was; a tab that answers renders is sent the video as a download. (The browser test
films a real video: tests/browser/test_video_browser.py.)"""

from __future__ import annotations

import io
import math
import threading

import numpy as np

from tests.studio.conftest import GUARD_S
from tests.studio.test_presenter_only import _studio
from tests.studio.ws_tab import Tab, loop, wait

__all__ = ["loop"]  # the fixture, used by name


def test_a_video_whose_tab_closes_leaves_the_studio_as_it_was(tmp_path, loop):
    """A tab that closes while a frame is awaited: a clear message, no file, the timeline
    put back."""
    studio = _studio(tmp_path, presenter_only=False)
    try:
        assert studio.motions.generate("com_shift", {})
        duration = studio.state.trajectory.duration
        studio.playback.seek(duration / 2)
        tab = Tab(studio, loop)
        wait("the tab", lambda: len(studio.web.server.get_clients()) == 1)
        (client,) = studio.web.server.get_clients().values()
        wait("the tab's camera", lambda: client.camera.image_width > 0)
        saved: list = []
        done = threading.Event()
        studio.presenting.share.video_saved.connect(lambda path: (saved.append(path), done.set()))
        studio.presenting.share.panel.video_fps.value = 5
        studio.presenting.share.export_video(client)
        wait("the first frame asked", lambda: studio.state.time_s == 0.0)
        tab.close()
        assert done.wait(GUARD_S)
        assert saved == [None]
        assert "Video export failed" in studio.presenting.share.panel.status.content
        assert list((tmp_path / "data" / "exports").glob("*")) == []
        assert studio.state.time_s == duration / 2
        assert not studio.presenting.share.panel.video.disabled  # the button is back
    finally:
        studio.stop()


def test_bad_video_settings_are_refused_with_the_bound(tmp_path, loop):
    """Settings past the bounds (as a crafted message could send: the widget's own min/max
    are the browser's) are refused by the server with the bound, and nothing is filmed."""
    studio = _studio(tmp_path, presenter_only=False)
    try:
        assert studio.motions.generate("com_shift", {})
        tab = Tab(studio, loop)
        wait("the tab", lambda: len(studio.web.server.get_clients()) == 1)
        (client,) = studio.web.server.get_clients().values()
        wait("the tab's camera", lambda: client.camera.image_width > 0)
        saved: list = []
        studio.presenting.share.video_saved.connect(saved.append)
        time_before = studio.state.time_s
        studio.presenting.share.panel.video_width.value = 4000
        studio.presenting.share.export_video(client)
        assert saved == [None]
        assert "width 4000 px: give 16 to 1920 px" in studio.presenting.share.panel.status.content
        studio.presenting.share.panel.video_width.value = 640
        studio.presenting.share.panel.video_fps.value = 0
        studio.presenting.share.export_video(client)
        assert saved == [None, None] and "fps 0" in studio.presenting.share.panel.status.content
        studio.presenting.share.export_video(None)
        assert (
            saved[-1] is None
            and "from a browser tab" in studio.presenting.share.panel.status.content
        )
        assert studio.state.time_s == time_before
        assert not (tmp_path / "data" / "exports").exists()
        tab.close()
    finally:
        studio.stop()


COLOURS = ((200, 40, 40), (40, 190, 60), (50, 60, 210), (220, 200, 40), (30, 30, 30))
"""What the tab 'renders', frame after frame (solid colours survive the video's compression)."""


def test_a_filmed_video_is_sent_to_the_tab_and_decodes_to_its_frames(tmp_path, loop):
    """The tab answers each render request with the next solid colour; the MP4 the studio
    sends it (put together from the file-transfer parts the tab received) is the saved file,
    and imageio-ffmpeg's reader decodes it to one frame per render, each of the colour the
    tab sent for it."""
    import imageio_ffmpeg
    from PIL import Image

    studio = _studio(tmp_path, presenter_only=False)
    try:
        assert studio.motions.generate("com_shift", {})
        tab = Tab(studio, loop)
        sent: list[tuple[int, int, int]] = []

        def render(height: int, width: int) -> bytes:
            colour = COLOURS[len(sent) % len(COLOURS)]
            sent.append(colour)
            out = io.BytesIO()
            Image.new("RGB", (width, height), colour).save(out, "JPEG", quality=95)
            return out.getvalue()

        tab.render = render
        wait("the tab", lambda: len(studio.web.server.get_clients()) == 1)
        (client,) = studio.web.server.get_clients().values()
        wait("the tab's camera", lambda: client.camera.image_width > 0)
        studio.presenting.share.panel.video_fps.value = 4
        saved: list = []
        done = threading.Event()
        studio.presenting.share.video_saved.connect(lambda path: (saved.append(path), done.set()))
        studio.presenting.share.export_video(client)
        assert done.wait(GUARD_S) and saved[0] is not None, (
            studio.presenting.share.panel.status.content
        )
        path = saved[0]
        wait("the download", lambda: tab.download() is not None)
        start, content = tab.download()
        assert start["filename"] == path.name and start["mime_type"] == "video/mp4"
        assert start["size_bytes"] == len(content) and content == path.read_bytes()

        received = tmp_path / "received.mp4"
        received.write_bytes(content)
        reader = imageio_ffmpeg.read_frames(str(received))
        width, height = next(reader)["size"]
        frames = [np.frombuffer(raw, np.uint8).reshape(height, width, 3) for raw in reader]
        duration = studio.state.trajectory.duration
        assert len(frames) == len(sent) == math.floor(duration * 4 + 1e-9) + 1
        for k, (frame, colour) in enumerate(zip(frames, sent, strict=True)):
            mean = frame.reshape(-1, 3).mean(axis=0)
            assert np.all(np.abs(mean - colour) < 12), (k, mean, colour)
        tab.close()
    finally:
        studio.stop()
