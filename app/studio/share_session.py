"""Sharing from the studio: *Export replay* records the current motion as shown (robot, the
ghosts and traces that are on, a title card) into a folder that plays in any browser,
*Screenshot* sends a tab's render to that tab as a PNG download (the user's browser saves it;
nothing is written on the server, which may be another machine), and *Export video* films the
current motion from a tab's renders (MP4 or GIF). Replays and videos are written under the data
folder.

The recording is drawn on a private viser server (app/replay_recorder.py): the live tabs see
nothing of it. An export runs in one named thread, "replay-export"; its end is announced by
`exported` (the result, or None after a failure), a screenshot's by `screenshot_sent`. A video
is filmed in the "video-export" thread (viser's callback thread stays free): the timeline is
moved frame by frame and the tab asked for a render of each; the time shown before is restored
after, and the end is announced by `video_saved` (the file, or None after a failure or Cancel).
"""

from __future__ import annotations

import dataclasses
import logging
import re
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import viser

from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.replay.scene import ReplayLayers, replay_scene, title_card
from app.core.replay.video import VideoError, VideoPlan, VideoWriter, plan_video
from app.core.robot.model import RobotModel
from app.replay_recorder import RecordedReplay, export_replay
from app.studio.admission import Admission, Busy
from app.studio.notifier import Notifier, failure_told
from app.studio.signals import Signal
from app.studio.state import StudioState
from panels.share_panel import SharePanel

log = logging.getLogger(__name__)

MAX_SCREENSHOT_SIDE = 4096
SCREENSHOT_WORKERS = 2
"""Screenshots taken at once, all tabs together (one per tab): their own threads, so a tab
that never returns its renders holds one of these for at most RENDER_TIMEOUT_S, never viser's
callback threads, which every tab's clicks need."""
RENDER_TIMEOUT_S = 20.0
"""How long a tab may take to return a render for a screenshot [s]."""
MAX_DOWNLOAD_BYTES = 100_000_000
"""A video larger than this is left on disk, not also sent to the tab."""


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-.")[:60] or "untitled"


def on_white(image: np.ndarray) -> np.ndarray:
    """An RGBA render (transparent where nothing is drawn) over the studio's white page, RGB."""
    if image.ndim != 3 or image.shape[2] != 4:
        return image
    alpha = image[..., 3:4].astype(np.float32) / 255.0
    rgb = image[..., :3].astype(np.float32) * alpha + 255.0 * (1.0 - alpha)
    return np.round(rgb).astype(np.uint8)


@dataclasses.dataclass(frozen=True)
class Screenshot:
    """A screenshot sent to a tab as a download."""

    filename: str
    png: bytes
    """The PNG file's bytes, as the browser receives them."""
    width: int
    height: int
    """Its size [px]: the tab's view."""


class ShareSession:
    """Owns the Share panel; `layers()` says what the studio shows beside the robot."""

    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        notifier: Notifier,
        data_dir: Path,
        layers: Callable[[], ReplayLayers],
        pause_playback: Callable[[], None] = lambda: None,
    ) -> None:
        self._server, self._state, self._notifier = server, state, notifier
        self._data_dir, self._layers = Path(data_dir), layers
        self.panel = SharePanel(server.gui, self)
        self._worker: threading.Thread | None = None
        self.exported: Signal[RecordedReplay | None] = Signal("replay_exported")
        self.screenshot_sent: Signal[Screenshot | None] = Signal("screenshot_sent")
        self.video_saved: Signal[Path | None] = Signal("video_saved")
        self._pause_playback = pause_playback
        self._video_worker: threading.Thread | None = None
        self._video_cancel = threading.Event()
        self._shots = ThreadPoolExecutor(SCREENSHOT_WORKERS, thread_name_prefix="screenshot")
        self._shot_admission = Admission(
            per_client=1,
            total=SCREENSHOT_WORKERS,
            busy_tab="a screenshot is already being taken for this tab",
            busy_studio="the studio is taking other tabs' screenshots; try again in a moment",
        )

    # --- replay ----------------------------------------------------------------------------

    def export_replay(self, client: viser.ClientHandle | None = None) -> None:
        """Start recording the current motion in the "replay-export" thread."""
        with self._state.lock:
            robot, trajectory = self._state.robot, self._state.trajectory
        if robot is None or trajectory is None:
            self._fail("Nothing to export", "generate or build a motion first", client)
            self.exported.emit(None)
            return
        if self._worker is not None and self._worker.is_alive():
            self._notifier.notify("Export running", "one replay at a time", client, "yellow")
            return
        out = (
            self._data_dir
            / "replays"
            / (f"{_slug(robot.name)}-{_slug(trajectory.name)}-{time.strftime('%Y%m%d-%H%M%S')}")
        )
        layers = self._layers()
        make_zip = bool(self.panel.zip.value)
        self.panel.show_progress(0.0)
        self.panel.status.content = f"Recording **{trajectory.name}**…"
        self._worker = threading.Thread(
            target=self._export,
            args=(robot, trajectory, layers, out, make_zip, client),
            name="replay-export",
            daemon=True,
        )
        self._worker.start()

    def _export(
        self,
        robot: RobotModel,
        trajectory: Trajectory,
        layers: ReplayLayers,
        out: Path,
        make_zip: bool,
        client: viser.ClientHandle | None,
    ) -> None:
        result: RecordedReplay | None = None
        try:
            with failure_told(self._fail, "Replay export failed", client, log):
                title = title_card(
                    robot.name,
                    trajectory.name,
                    trajectory.duration,
                    layers.parameters,
                    layers.verdicts,
                )
                scene = replay_scene(
                    robot,
                    trajectory,
                    title,
                    layers.prediction,
                    ghosts=layers.ghosts,
                    extra_ghosts=layers.extra_ghosts,
                    traces=layers.traces,
                )
                progress = self.panel.show_progress
                result = export_replay(robot, scene, out, make_zip, progress=progress)
        finally:
            self.panel.show_progress(None)
        if result is not None:
            folder = result.folder
            zipped = f" and `{folder.zip_path}`" if folder.zip_path is not None else ""
            self.panel.status.content = (
                f"Replay of **{trajectory.name}** ({result.n_frames} frames, "
                f"{folder.total_bytes / 1e6:.1f} MB) in `{folder.path}`{zipped}.  \n"
                f"Open it with `biped-studio replay open {folder.path}`, or serve the folder "
                "with any static web server."
            )
            self._notifier.notify("Replay exported", str(folder.path), client)
        self.exported.emit(result)

    # --- screenshot ------------------------------------------------------------------------

    def screenshot(self, client: viser.ClientHandle | None = None) -> None:
        """Send what `client` renders now to that tab as a PNG download, in a "screenshot"
        thread (the click returns at once). One per tab and SCREENSHOT_WORKERS in all: a
        click beyond that is refused in one line."""
        if client is None:
            self._fail("Screenshot failed", "a screenshot is taken from a browser tab", None)
            self.screenshot_sent.emit(None)
            return
        admitted = self._shot_admission.admit(client.client_id)
        try:
            admitted.__enter__()
        except Busy as busy:
            self._notifier.notify("Screenshot not taken", str(busy), client, "yellow")
            return

        def take() -> None:
            try:
                self._take_screenshot(client)
            finally:
                admitted.__exit__(None, None, None)

        self._shots.submit(take)

    def _take_screenshot(self, client: viser.ClientHandle) -> None:
        shot: Screenshot | None = None
        try:
            height = min(int(client.camera.image_height), MAX_SCREENSHOT_SIDE)
            width = min(int(client.camera.image_width), MAX_SCREENSHOT_SIDE)
            if height <= 0 or width <= 0:
                raise StudioError("the tab has not drawn the scene yet")
            image = client.get_render(
                height, width, transport_format="png", timeout=RENDER_TIMEOUT_S
            )
            png = iio.imwrite("<bytes>", on_white(image), extension=".png")
            name = self._state.trajectory.name if self._state.trajectory is not None else "pose"
            filename = f"{_slug(name)}-{time.strftime('%Y%m%d-%H%M%S')}.png"
            client.send_file_download(filename, png, save_immediately=True)
            shot = Screenshot(filename, png, width, height)
            self.panel.status.content = (
                f"Screenshot ({width}×{height}) sent to your browser as `{filename}`."
            )
            self._notifier.notify("Screenshot downloaded", filename, client)
        except (StudioError, OSError, TimeoutError, RuntimeError) as error:
            # RuntimeError: viser's answer when the tab closed while the render was awaited.
            reason = str(error) or type(error).__name__
            if isinstance(error, TimeoutError):
                reason = f"the tab did not return its view within {RENDER_TIMEOUT_S:g} s"
            self._fail("Screenshot failed", reason, client)
        except Exception as error:  # a bug: said in the panel, logged, and the end announced
            log.exception("screenshot")
            self._fail("Screenshot failed", f"{type(error).__name__}: {error}", client)
        self.screenshot_sent.emit(shot)

    # --- video ---------------------------------------------------------------------------------

    def export_video(self, client: viser.ClientHandle | None = None) -> None:
        """Start filming the current motion from `client`'s view in the "video-export" thread."""
        with self._state.lock:
            trajectory, time_s = self._state.trajectory, self._state.time_s
        if self._video_worker is not None and self._video_worker.is_alive():
            self._notifier.notify("Video running", "one video at a time", client, "yellow")
            return
        try:
            if client is None:
                raise VideoError("a video is filmed from a browser tab; none asked")
            if trajectory is None:
                raise VideoError("no motion to film: generate or build a motion first")
            tab_w, tab_h = int(client.camera.image_width), int(client.camera.image_height)
            if tab_w <= 0 or tab_h <= 0:
                raise VideoError("the tab has not drawn the scene yet")
            plan = plan_video(
                trajectory.duration,
                float(self.panel.video_fps.value),
                float(self.panel.video_width.value),
                tab_w / tab_h,
                str(self.panel.video_format.value),
            )
        except VideoError as error:
            self._fail("Video export failed", str(error), client)
            self.video_saved.emit(None)
            return
        self._pause_playback()
        self._video_cancel = cancel = threading.Event()
        path = (
            self._data_dir
            / "exports"
            / f"{_slug(trajectory.name)}-{time.strftime('%Y%m%d-%H%M%S')}.{plan.format}"
        )
        self.panel.show_video_progress(0.0)
        self.panel.status.content = f"Filming **{trajectory.name}** ({plan.n_frames} frames)…"
        self._video_worker = threading.Thread(
            target=self._film,
            args=(client, trajectory, time_s, plan, path, cancel, (tab_w, tab_h)),
            name="video-export",
            daemon=True,
        )
        self._video_worker.start()

    def cancel_video(self) -> None:
        """Stop the video being filmed (no file is kept)."""
        self._video_cancel.set()

    def _film(
        self,
        client: viser.ClientHandle,
        trajectory: Trajectory,
        time_before: float,
        plan: VideoPlan,
        path: Path,
        cancel: threading.Event,
        tab_size: tuple[int, int],
    ) -> None:
        saved: Path | None = None
        writer: VideoWriter | None = None
        # The tab renders at most its own size; the writer fits the frames to the plan's.
        width, height = min(plan.width, tab_size[0]), min(plan.height, tab_size[1])
        try:
            writer = VideoWriter(path, plan)
            for k, time_s in enumerate(plan.times):
                if cancel.is_set():
                    raise VideoError("cancelled; no file kept")
                with self._state.lock, self._server.atomic():
                    if self._state.trajectory is not trajectory:
                        raise VideoError("the motion changed while it was filmed; no file kept")
                    self._state.set_time(time_s)
                writer.add(client.get_render(height, width, timeout=60.0))
                self.panel.show_video_progress((k + 1) / plan.n_frames)
            saved = writer.close()
        except (StudioError, OSError, TimeoutError, RuntimeError) as error:
            # RuntimeError: viser's answer when the tab closed while a frame was awaited.
            if writer is not None:
                writer.abort()
            self._fail("Video export failed", str(error) or type(error).__name__, client)
        finally:
            self.panel.show_video_progress(None)
            with self._state.lock, self._server.atomic():
                if self._state.trajectory is trajectory:
                    self._state.set_time(time_before)
        if saved is not None:
            size_mb = saved.stat().st_size / 1e6
            self.panel.status.content = (
                f"Video of **{trajectory.name}** ({plan.n_frames} frames at {plan.fps} fps, "
                f"{plan.width}×{plan.height}, {size_mb:.1f} MB) saved to `{saved}`."
            )
            self._notifier.notify("Video saved", str(saved), client)
            self._offer_download(client, saved)
        self.video_saved.emit(saved)

    def _offer_download(self, client: viser.ClientHandle, path: Path) -> None:
        """Send the file to the tab as a download; the file on disk is what counts."""
        if path.stat().st_size > MAX_DOWNLOAD_BYTES or client.client_id not in (
            self._server.get_clients()
        ):
            return
        try:
            client.send_file_download(path.name, path.read_bytes())
        except Exception:  # a closed tab: the file is saved, the status line names it
            log.info("video download not sent to client %s", client.client_id, exc_info=True)

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        self.panel.status.content = f"⚠️ {title}: {body}"
        self._notifier.error(title, body, client)

    def close(self) -> None:
        self._video_cancel.set()
        self._shots.shutdown(wait=False, cancel_futures=True)  # a render awaited ends in time
        for worker in (self._worker, self._video_worker):
            if worker is not None:
                worker.join()
