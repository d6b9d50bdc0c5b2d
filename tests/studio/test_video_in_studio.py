"""*Export video* against a real studio with a websocket tab that never renders: a tab that
closes mid-film and settings past the bounds end with a message, no file, and the timeline
where it was. (The browser test films a real video: tests/browser/test_video_browser.py.)"""

from __future__ import annotations

import threading

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
        wait("the tab", lambda: len(studio.server.get_clients()) == 1)
        (client,) = studio.server.get_clients().values()
        wait("the tab's camera", lambda: client.camera.image_width > 0)
        saved: list = []
        done = threading.Event()
        studio.share.video_saved.connect(lambda path: (saved.append(path), done.set()))
        studio.share.panel.video_fps.value = 5
        studio.share.export_video(client)
        wait("the first frame asked", lambda: studio.state.time_s == 0.0)
        tab.close()
        assert done.wait(GUARD_S)
        assert saved == [None]
        assert "Video export failed" in studio.share.panel.status.content
        assert list((tmp_path / "data" / "exports").glob("*")) == []
        assert studio.state.time_s == duration / 2
        assert not studio.share.panel.video.disabled  # the button is back
    finally:
        studio.stop()


def test_bad_video_settings_are_refused_with_the_bound(tmp_path, loop):
    """Settings past the bounds (as a crafted message could send: the widget's own min/max
    are the browser's) are refused by the server with the bound, and nothing is filmed."""
    studio = _studio(tmp_path, presenter_only=False)
    try:
        assert studio.motions.generate("com_shift", {})
        tab = Tab(studio, loop)
        wait("the tab", lambda: len(studio.server.get_clients()) == 1)
        (client,) = studio.server.get_clients().values()
        wait("the tab's camera", lambda: client.camera.image_width > 0)
        saved: list = []
        studio.share.video_saved.connect(saved.append)
        time_before = studio.state.time_s
        studio.share.panel.video_width.value = 4000
        studio.share.export_video(client)
        assert saved == [None]
        assert "width 4000 px: give 16 to 1920 px" in studio.share.panel.status.content
        studio.share.panel.video_width.value = 640
        studio.share.panel.video_fps.value = 0
        studio.share.export_video(client)
        assert saved == [None, None] and "fps 0" in studio.share.panel.status.content
        studio.share.export_video(None)
        assert saved[-1] is None and "from a browser tab" in studio.share.panel.status.content
        assert studio.state.time_s == time_before
        assert not (tmp_path / "data" / "exports").exists()
        tab.close()
    finally:
        studio.stop()
